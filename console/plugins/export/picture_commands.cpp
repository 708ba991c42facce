// Pictures of the selected map (docs/export-pictures.md): plot_map (PNG, top and side views)
// and export_html (one self-contained HTML page with a three.js 3-D view).
#include "vilma/console/command_registry.h"
#include "vilma/mapping/export/html_viewer.h"
#include "vilma/mapping/export/map_plot.h"

namespace vilma::console {
namespace {

struct PlotMapCommandOptions {
  std::string out;  // PNG file, or a folder (map.png in it)
  mapping::MapPlotOptions plot;
  std::string Validate() const {
    if (out.empty()) return "out: a .png file or an existing folder";
    return plot.Validate();
  }
};

struct ExportHtmlCommandOptions {
  std::string out;  // HTML file, or a folder (map.html in it)
  mapping::HtmlViewerOptions viewer;
  std::string Validate() const {
    if (out.empty()) return "out: a .html file or an existing folder";
    return viewer.Validate();
  }
};

void Register(CommandRegistry* registry) {
  using P = PlotMapCommandOptions;
  registry->Add(
      Command<P>("plot_map")
          .Group("export")
          .Summary("PNG of the map in G: top (x-y) and side (x-z) views, trajectories, landmarks, "
                   "loop closures, scale bar")
          .Usage("[PATH]")
          .Access(MapAccess::kRead)
          .PathFlag("out", &P::out, "PNG file to write, or an existing folder (map.png in it)")
          .Positional("out")
          .FlagAt("width_px", [](P& o) -> int& { return o.plot.width_px; }, "image width [px]")
          .FlagAt("height_px", [](P& o) -> int& { return o.plot.height_px; }, "image height [px]")
          .FlagAt("views", [](P& o) -> std::string& { return o.plot.views; },
                  "views stacked top to bottom, comma separated: xy (top), xz, yz (sides)")
          .FlagAt("landmarks", [](P& o) -> std::string& { return o.plot.landmarks; },
                  "landmark qualities drawn: good, unknown, bad (comma separated) or none")
          .FlagAt("max_landmarks", [](P& o) -> int& { return o.plot.max_landmarks; },
                  "landmarks drawn at most (every k-th in map order above)")
          .FlagAt("show_vertices", [](P& o) -> bool& { return o.plot.show_vertices; },
                  "a dot per vertex")
          .FlagAt("show_loop_closures", [](P& o) -> bool& { return o.plot.show_loop_closures; },
                  "draw loop-closure edges")
          .FlagAt("mission", [](P& o) -> std::string& { return o.plot.mission; },
                  kMissionListHelp,
                  {"map_mission"})
          .FlagAt("title", [](P& o) -> std::string& { return o.plot.title; },
                  "title of the picture (default: VI-map)")
          .Run([](CommandContext& c, const P& o) {
            const mapping::MapPlotSummary summary =
                mapping::PlotMap(c.map(), o.plot, o.out, c.progress());
            c.out() << summary.FullReport();
          }));

  using H = ExportHtmlCommandOptions;
  registry->Add(
      Command<H>("export_html")
          .Group("export")
          .Summary("one self-contained HTML file with an interactive 3-D view (three.js inlined)")
          .Usage("[PATH]")
          .Access(MapAccess::kRead)
          .PathFlag("out", &H::out, "HTML file to write, or an existing folder (map.html in it)")
          .Positional("out")
          .FlagAt("three_js_path", [](H& o) -> std::string& { return o.viewer.three_js_path; },
                  "three.js to inline (Debian package libjs-three)")
          .FlagAt("orbit_controls_path",
                  [](H& o) -> std::string& { return o.viewer.orbit_controls_path; },
                  "three.js OrbitControls to inline (Debian package libjs-three)")
          .FlagAt("landmarks", [](H& o) -> std::string& { return o.viewer.landmarks; },
                  "landmark qualities shown: good, unknown, bad (comma separated) or none")
          .FlagAt("max_landmarks", [](H& o) -> int& { return o.viewer.max_landmarks; },
                  "landmarks embedded at most (every k-th in map order above)")
          .FlagAt("mission", [](H& o) -> std::string& { return o.viewer.mission; },
                  kMissionListHelp,
                  {"map_mission"})
          .FlagAt("title", [](H& o) -> std::string& { return o.viewer.title; },
                  "page title (default: VI-map)")
          .Run([](CommandContext& c, const H& o) {
            const mapping::HtmlViewerSummary summary =
                mapping::ExportHtmlViewer(c.map(), o.viewer, o.out, c.progress());
            c.out() << summary.FullReport();
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)

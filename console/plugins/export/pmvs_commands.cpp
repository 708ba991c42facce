// export_for_pmvs (maplab's command of the same name): the selected map's images, cameras and
// landmarks as the input folder of PMVS2 / CMVS (docs/export.md "PMVS2"). Reads the map only;
// the folder appears complete or not at all.
#include "vilma/console/command_registry.h"
#include "vilma/mapping/export/map_plot.h"
#include "vilma/mapping/export/pmvs_export.h"

namespace vilma::console {
namespace {

// The library's options plus the mission selector, resolved against the selected map.
struct PmvsCommandOptions : mapping::PmvsExportOptions {
  std::string mission;
};

void Register(CommandRegistry* registry) {
  using O = PmvsCommandOptions;
  using L = mapping::PmvsExportOptions;
  registry->Add(
      Command<O>("export_for_pmvs")
          .Group("export")
          .Summary("PMVS2/CMVS input folder: undistorted images (visualize/), projection "
                   "matrices (txt/), bundle.rd.out, vis.dat, option-0000 (world = G)")
          .Access(MapAccess::kRead)
          .PathFlag("out", &L::out, "folder to make (must not exist or be empty)",
                    {"pmvs_reconstruction_folder"})
          .Positional("out")
          .Flag("mission", &O::mission,
                kMissionListHelp,
                {"map_mission"})
          .Flag("landmarks", &L::landmarks,
                "landmark qualities that become bundle.rd.out points: good, unknown, bad (comma "
                "separated)")
          .Flag("min_observations", &L::min_observations,
                "points need this many observations in exported images")
          .Flag("min_covisible_landmarks", &L::min_covisible_landmarks,
                "vis.dat: images sharing this many points are neighbours",
                {"pmvs_min_covisible_landmarks"})
          .Flag("jpeg_quality", &L::jpeg_quality, "quality of visualize/*.jpg (1 .. 100)")
          .Flag("threads", &L::threads, "option-0000 CPU: threads PMVS2 runs")
          .Run([](CommandContext& c, const O& o) {
            mapping::PmvsExportOptions options = o;
            options.missions = mapping::SelectMissions(c.map(), o.mission, "mission");
            c.out() << mapping::ExportPmvs(c.map(), options, c.progress()).FullReport();
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)

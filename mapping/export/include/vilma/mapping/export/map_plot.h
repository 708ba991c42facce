// Pictures of a VI-map (docs/export-pictures.md): `plot_map` draws a PNG with a top-down (x-y)
// and a side view (x-z) of the map in the global frame G — trajectories per mission, landmarks,
// vertices, loop-closure edges, a scale bar, axes, a legend and a title with counts. Drawn with
// OpenCV's CPU rasterizer only (no fonts from the system, no randomness), so the same map and
// options give the same bytes.
//
// The mission selection, landmark subsampling and output-path rules here are shared with the
// HTML viewer (html_viewer.h).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct MapPlotOptions {
  int width_px = 1600;   // image width [px], 200 ... 10000
  int height_px = 1200;  // image height [px], 150 ... 10000
  // Views, comma separated, drawn one above the other with one scale [px/m]: "xy" (top-down),
  // "xz" (side, looking along +y), "yz" (side, looking along -x). Axes of G.
  std::string views = "xy,xz";
  // Landmark qualities drawn, comma separated from "good", "unknown", "bad", or "none".
  std::string landmarks = "good";
  // Landmarks drawn at most; above, every k-th in map order (deterministic, exactly this many).
  int max_landmarks = 50000;
  bool show_vertices = true;       // a dot per vertex on the trajectory line
  bool show_loop_closures = true;  // kLoopClosure edges as lines between their two vertices
  // Missions: "" for all; otherwise comma separated mission ids (32 hex digits), unique id
  // prefixes (4 hex digits at least) or mission names.
  std::string mission;
  std::string title;  // first part of the title line ("" : "VI-map")

  // "field: expectation", or "" when valid.
  std::string Validate() const;
};

// One view's projection: G -> pixels. Columns grow with the horizontal axis, rows shrink with
// the vertical axis (image rows grow downwards); both axes have the same scale (metric picture).
struct MapPlotView {
  std::string axes;       // "xy", "xz" or "yz": the horizontal then the vertical axis of G
  cv::Rect panel_px;      // the plotting area inside the view's axes
  double px_per_m = 1.0;  // scale [px/m]
  Eigen::Vector2d min_m = Eigen::Vector2d::Zero();  // G coordinates at the panel's lower left

  // (column, row) of p_G in the image, sub-pixel [px].
  Eigen::Vector2d Project(const Eigen::Vector3d& p_G) const;
};

struct MapPlotSummary {
  std::string path;  // file written ("" for RenderMapPlot)
  std::size_t missions = 0;
  std::size_t vertices = 0;
  std::size_t loop_closures = 0;    // drawn (both vertices in the selected missions)
  std::size_t landmarks_total = 0;  // in the selected missions, any quality
  std::size_t landmarks_shown = 0;  // passing the quality filter
  std::size_t landmarks_drawn = 0;  // after subsampling
  double scale_bar_m = 0.0;         // length of the scale bar [m]
  double px_per_m = 0.0;
  std::size_t bytes = 0;  // PNG size
  std::string BriefReport() const;  // one line: counts and where it went
  std::string FullReport() const;   // the brief line and the details (what the command prints)
};

struct MapPlot {
  cv::Mat image;  // CV_8UC3, BGR
  std::vector<MapPlotView> views;
  MapPlotSummary summary;
};

// Draws the picture. Throws InputError for a selection that matches no mission or has no
// vertex, Cancelled when `progress` asks (nothing is written then).
MapPlot RenderMapPlot(const mapstore::VIMap& map, const MapPlotOptions& options,
                      ProgressObserver* progress = nullptr);

// Draws and writes the PNG atomically to ResolveOutputFile(out, "map.png", ".png").
MapPlotSummary PlotMap(const mapstore::VIMap& map, const MapPlotOptions& options,
                       const std::string& out, ProgressObserver* progress = nullptr);

// ---- shared with the HTML viewer ----

// The mission colours (RGB), by the mission's position in the map (MissionIndex), so that a
// mission keeps its colour whatever the selection: Tableau 10 without its red (red marks loop
// closures) and grey (landmarks); repeats after 8 missions.
std::array<uint8_t, 3> MissionColorRgb(std::size_t index);
// Position of the mission in map.mission_ids().
std::size_t MissionIndex(const mapstore::VIMap& map, const mapstore::MissionId& mission_id);
// The loop-closure colour (RGB).
std::array<uint8_t, 3> LoopClosureColorRgb();

// The missions a selector names (see MapPlotOptions::mission), in map order. Throws InputError
// naming `flag` when a word matches no mission or an id prefix matches several.
std::vector<mapstore::MissionId> SelectMissions(const mapstore::VIMap& map,
                                                const std::string& selector,
                                                const std::string& flag = "mission");

// The mission's vertices in time order (ties: insertion order).
std::vector<mapstore::VertexId> VerticesInTimeOrder(const mapstore::VIMap& map,
                                                    const mapstore::MissionId& mission_id);

// Indices of the elements kept when at most `max_count` of `count` are wanted: all when
// count <= max_count, else floor(i * count / max_count) for i = 0 .. max_count - 1 (evenly
// spread, deterministic).
std::vector<std::size_t> SubsampleIndices(std::size_t count, std::size_t max_count);

// The file to write for `--out PATH`: PATH/default_name when PATH is an existing folder, else
// PATH, which must end in `extension` (case-insensitive) and lie in an existing folder. Throws
// InputError naming `flag` and the path otherwise.
std::string ResolveOutputFile(const std::string& out, const std::string& default_name,
                              const std::string& extension, const std::string& flag = "out");

// Landmark qualities from "good,unknown,bad" / "none"; empty string when valid, else what is
// expected. `keep[q]` is set for quality value q (LandmarkQuality as integer).
std::string ParseLandmarkQualities(const std::string& text, std::array<bool, 3>* keep);

}  // namespace vilma::mapping

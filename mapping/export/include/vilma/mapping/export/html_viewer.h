// export_html: one self-contained HTML file with an interactive 3-D view of a VI-map
// (docs/export-pictures.md). The page inlines three.js and its OrbitControls from Debian's
// libjs-three (read at run time from the paths in the options) and the map as JSON, so it opens
// from file:// in any browser with WebGL, with no server and no network.
//
// In the page: trajectories per mission in G, landmarks as points, vertices as dots (optionally
// their IMU axes), loop-closure edges; drag to orbit, wheel to zoom, right drag (or shift drag)
// to pan; a click on a vertex shows its id, time and pose and draws the frustums of the
// mission's cameras there. The URL fragment #vertex=<32 hex digits> selects a vertex on load
// through the same picking as a click. When the first frame is drawn the page sets
// data-vilma-state="drawn" on <body>; JavaScript errors and warnings are listed in
// <pre id="vilma-errors"> and counted in data-vilma-errors (for tests and for users).
#pragma once

#include <cstddef>
#include <string>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct HtmlViewerOptions {
  // three.js (the UMD build that defines the global THREE), from Debian's libjs-three.
  std::string three_js_path = "/usr/share/javascript/three/three.min.js";
  // OrbitControls for that three.js (the UMD build in examples/js/, THREE.OrbitControls).
  std::string orbit_controls_path =
      "/usr/share/javascript/three/examples/js/controls/OrbitControls.js";
  // Landmark qualities included, as MapPlotOptions::landmarks ("good", "unknown", "bad", "none").
  std::string landmarks = "good";
  // Landmarks embedded at most; above, every k-th in map order (deterministic, exactly this
  // many). 200,000 landmarks make about 5 MB of JSON.
  int max_landmarks = 200000;
  // Missions, as MapPlotOptions::mission ("" for all).
  std::string mission;
  std::string title;  // page title ("" : "VI-map")

  // "field: expectation", or "" when valid.
  std::string Validate() const;
};

struct HtmlViewerSummary {
  std::string path;  // file written ("" for RenderHtmlViewer)
  std::size_t missions = 0;
  std::size_t vertices = 0;
  std::size_t loop_closures = 0;
  std::size_t landmarks_total = 0;     // in the selected missions, any quality
  std::size_t landmarks_shown = 0;     // passing the quality filter
  std::size_t landmarks_embedded = 0;  // after subsampling
  std::string three_js_revision;       // REVISION of the inlined three.js ("111")
  std::size_t bytes = 0;               // size of the page
  std::string BriefReport() const;  // one line: counts and where it went
  std::string FullReport() const;   // the brief line and the details (what the command prints)
};

// The page as text. Throws InputError naming the file when three.js or OrbitControls cannot
// be read or do not look like three.js, and for a selection without vertices.
std::string RenderHtmlViewer(const mapstore::VIMap& map, const HtmlViewerOptions& options,
                             HtmlViewerSummary* summary = nullptr,
                             ProgressObserver* progress = nullptr);

// Writes the page atomically to ResolveOutputFile(out, "map.html", ".html") (map_plot.h).
HtmlViewerSummary ExportHtmlViewer(const mapstore::VIMap& map, const HtmlViewerOptions& options,
                                   const std::string& out, ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping

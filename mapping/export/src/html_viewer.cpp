// export_html: the map as JSON inside one HTML page with three.js inlined
// (docs/export-pictures.md "export_html"). The JSON (format "vilma-map-viewer", version 1):
//
//   title, frame ("G"), origin_m: [x, y, z] whole metres near the map's centre, subtracted in
//     the page before positions become float32 (whose 24-bit mantissa keeps mm only near 0);
//   missions[]: id, name, color "#rrggbb", baseframe_known, path_length_m,
//     t0_ns (string: ns do not fit a double), vertex_ids[] (hex), dt_ns[] (since t0),
//     p_mm[] (x y z per vertex, p_G_I rounded to mm), q_G_I[] (w x y z, 4 decimals),
//     cameras[]: name, p_I_C_mm, q_I_C (w x y z), corners (x/z, y/z of the four image corners
//     (0,0) (w,0) (w,h) (0,h), undistorted: the frustum through the image's corners);
//   loop_closures[]: [mission index, vertex index, mission index, vertex index];
//   loop_closure_color; landmarks: total, shown, embedded, qualities, p_mm[], quality[]
//     (0 unknown, 1 bad, 2 good).
#include "vilma/mapping/export/html_viewer.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <sstream>
#include <unordered_map>

#include "html_viewer_page.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/json.h"
#include "vilma/mapping/export/map_plot.h"

namespace vilma::mapping {
namespace {

using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

// JSON string literal that can sit inside a <script> element.
std::string JsonString(const std::string& s) { return vilma::JsonString(s, true); }

std::string HtmlEscape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// Locale-independent number with at most `decimals` decimals, trailing zeros dropped.
std::string Number(double value, int decimals) {
  char buffer[64];
  const auto result =
      std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::fixed, decimals);
  std::string text(buffer, result.ptr);
  if (text.find('.') != std::string::npos) {
    while (text.back() == '0') text.pop_back();
    if (text.back() == '.') text.pop_back();
  }
  if (text == "-0") text = "0";
  return text;
}

void AppendMm(const Eigen::Vector3d& p, std::string* out) {
  for (int k = 0; k < 3; ++k) {
    if (out->back() != '[') *out += ',';
    *out += std::to_string(std::llround(p[k] * 1000.0));
  }
}

void AppendQuaternion(const Eigen::Quaterniond& q, std::string* out) {
  for (const double v : {q.w(), q.x(), q.y(), q.z()}) {
    if (out->back() != '[') *out += ',';
    *out += Number(v, 4);
  }
}

std::string Hex(const std::array<uint8_t, 3>& rgb) {
  char buffer[8];
  std::snprintf(buffer, sizeof(buffer), "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
  return buffer;
}

std::string ReadLibraryFile(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(
        FormatInputError(path, "",
                         "a readable " + what + " (Debian package libjs-three: apt install " +
                             "libjs-three, or give its path with --" +
                             (what == "three.js" ? "three_js_path" : "orbit_controls_path") + ")"));
  }
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The digits of three.js's `REVISION = "111"` (minified: REVISION="111"), or "".
std::string ThreeJsRevision(const std::string& text) {
  for (std::size_t at = text.find("REVISION"); at != std::string::npos;
       at = text.find("REVISION", at + 1)) {
    std::size_t i = at + 8;
    while (i < text.size() && text[i] == ' ') ++i;
    if (i >= text.size() || text[i] != '=') continue;
    ++i;
    while (i < text.size() && text[i] == ' ') ++i;
    if (i >= text.size() || (text[i] != '"' && text[i] != '\'')) continue;
    const char quote = text[i++];
    const std::size_t begin = i;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
    if (i > begin && i < text.size() && text[i] == quote) return text.substr(begin, i - begin);
  }
  return "";
}

// The corners of the image on the plane z = 1 of the camera, undistorted where the model
// converges, else by the pinhole part alone.
std::vector<Eigen::Vector2d> CornerRays(const Camera& camera) {
  std::vector<Eigen::Vector2d> corners;
  const double w = camera.width(), h = camera.height();
  for (const Eigen::Vector2d& uv : {Eigen::Vector2d(0, 0), Eigen::Vector2d(w, 0),
                                    Eigen::Vector2d(w, h), Eigen::Vector2d(0, h)}) {
    Eigen::Vector3d bearing;
    if (camera.Unproject(uv, &bearing) && bearing.z() > 1e-3) {
      corners.emplace_back(bearing.x() / bearing.z(), bearing.y() / bearing.z());
    } else {
      corners.emplace_back((uv.x() - camera.cx()) / camera.fx(),
                           (uv.y() - camera.cy()) / camera.fy());
    }
  }
  return corners;
}

}  // namespace

std::string HtmlViewerOptions::Validate() const {
  if (three_js_path.empty()) return "three_js_path: the path of three.min.js (libjs-three)";
  if (orbit_controls_path.empty()) {
    return "orbit_controls_path: the path of OrbitControls.js (libjs-three)";
  }
  std::array<bool, 3> keep;
  const std::string problem = ParseLandmarkQualities(landmarks, &keep);
  if (!problem.empty()) return "landmarks: " + problem;
  if (max_landmarks < 0) return "max_landmarks: 0 or more";
  return "";
}

std::string HtmlViewerSummary::BriefReport() const {
  std::ostringstream out;
  if (!path.empty()) out << "wrote " << path << " (" << bytes << " bytes): ";
  out << missions << " mission(s), " << vertices << " vertices, " << loop_closures
      << " loop closure(s), landmarks " << landmarks_embedded << " embedded of " << landmarks_shown
      << " shown of " << landmarks_total << ", three.js r" << three_js_revision;
  return out.str();
}

std::string HtmlViewerSummary::FullReport() const { return BriefReport() + "\n"; }

std::string RenderHtmlViewer(const VIMap& map, const HtmlViewerOptions& options,
                             HtmlViewerSummary* summary_out, ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "export_html options");
  const std::vector<MissionId> selected = SelectMissions(map, options.mission);
  std::array<bool, 3> keep_quality;
  ParseLandmarkQualities(options.landmarks, &keep_quality);
  BeginProgress(progress, "export_html", 3);
  HtmlViewerSummary summary;

  const std::string three_js = ReadLibraryFile(options.three_js_path, "three.js");
  summary.three_js_revision = ThreeJsRevision(three_js);
  if (summary.three_js_revision.empty() || three_js.find("WebGLRenderer") == std::string::npos) {
    throw InputError(
        FormatInputError(options.three_js_path, "", "three.js (a REVISION and a WebGLRenderer)"));
  }
  const std::string orbit = ReadLibraryFile(options.orbit_controls_path, "OrbitControls.js");
  if (orbit.find("OrbitControls") == std::string::npos) {
    throw InputError(FormatInputError(options.orbit_controls_path, "",
                                      "three.js's OrbitControls (THREE.OrbitControls)"));
  }
  for (const std::string* library : {&three_js, &orbit}) {
    // An inlined script ends at the first "</script"; Debian's files have none.
    std::string lower = *library;
    std::transform(lower.begin(), lower.end(), lower.begin(), ::tolower);
    if (lower.find("</script") != std::string::npos) {
      throw InputError(FormatInputError(
          library == &three_js ? options.three_js_path : options.orbit_controls_path, "",
          "a script without \"</script\" (to inline it)"));
    }
  }
  ReportProgress(progress, 1);

  // Vertex positions decide the origin (whole metres at the middle of their bounding box).
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  std::vector<std::vector<VertexId>> vertices;
  for (const MissionId& id : selected) {
    vertices.push_back(VerticesInTimeOrder(map, id));
    for (const VertexId& v : vertices.back()) {
      const Eigen::Vector3d p = map.T_G_I(v).translation();
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    summary.vertices += vertices.back().size();
  }
  summary.missions = selected.size();
  if (summary.vertices == 0) {
    throw InputError(FormatInputError("export_html", "--mission",
                                      "missions with vertices (the selection has none)"));
  }
  const Eigen::Vector3d origin = (0.5 * (lo + hi)).array().round();

  std::string json = "{\"format\":\"vilma-map-viewer\",\"version\":1,\"frame\":\"G\",\"title\":";
  const std::string title = options.title.empty() ? "VI-map" : options.title;
  json += JsonString(title) + ",\"origin_m\":[" + Number(origin.x(), 0) + "," +
          Number(origin.y(), 0) + "," + Number(origin.z(), 0) + "],\"missions\":[";
  // (mission index, vertex index) of each drawn vertex, for the loop closures.
  std::unordered_map<VertexId, std::pair<std::size_t, std::size_t>, mapstore::IdHash> where;
  for (std::size_t mi = 0; mi < selected.size(); ++mi) {
    const mapstore::Mission& mission = map.mission(selected[mi]);
    const std::vector<VertexId>& ids = vertices[mi];
    std::string vertex_ids = "[", dt = "[", p_mm = "[", q = "[";
    double length_m = 0.0;
    Eigen::Vector3d previous = Eigen::Vector3d::Zero();
    const int64_t t0 = ids.empty() ? 0 : map.vertex(ids.front()).t_ns;
    for (std::size_t k = 0; k < ids.size(); ++k) {
      where[ids[k]] = {mi, k};
      const Transformation T_G_I = map.T_G_I(ids[k]);
      if (k > 0) {
        vertex_ids += ',';
        dt += ',';
        length_m += (T_G_I.translation() - previous).norm();
      }
      previous = T_G_I.translation();
      vertex_ids += "\"" + ids[k].Hex() + "\"";
      dt += std::to_string(map.vertex(ids[k]).t_ns - t0);
      AppendMm(T_G_I.translation(), &p_mm);
      AppendQuaternion(T_G_I.rotation(), &q);
    }
    std::string cameras = "[";
    for (const CameraConfig& camera : mission.rig.cameras) {
      if (cameras.size() > 1) cameras += ',';
      std::string p_I_C = "[", q_I_C = "[", corners;
      AppendMm(camera.T_I_C.translation(), &p_I_C);
      AppendQuaternion(camera.T_I_C.rotation(), &q_I_C);
      for (const Eigen::Vector2d& c : CornerRays(camera.camera)) {
        corners += (corners.empty() ? "" : ",") + Number(c.x(), 4) + "," + Number(c.y(), 4);
      }
      cameras += "{\"name\":" + JsonString(camera.name) + ",\"p_I_C_mm\":" + p_I_C +
                 "],\"q_I_C\":" + q_I_C + "],\"corners\":[" + corners + "]}";
    }
    json += std::string(mi > 0 ? "," : "") + "{\"id\":\"" + mission.id.Hex() +
            "\",\"name\":" + JsonString(mission.name) + ",\"color\":\"" +
            Hex(MissionColorRgb(MissionIndex(map, mission.id))) +
            "\",\"baseframe_known\":" + (mission.baseframe_known ? "true" : "false") +
            ",\"path_length_m\":" + Number(length_m, 3) + ",\"t0_ns\":\"" + std::to_string(t0) +
            "\",\"vertex_ids\":" + vertex_ids + "],\"dt_ns\":" + dt + "],\"p_mm\":" + p_mm +
            "],\"q_G_I\":" + q + "],\"cameras\":" + cameras + "]}";
  }
  json += "],\"loop_closures\":[";
  for (const MissionId& id : selected) {
    for (const mapstore::EdgeId& edge_id : map.edge_ids(id)) {
      const mapstore::Edge& edge = map.edge(edge_id);
      if (edge.type != mapstore::EdgeType::kLoopClosure) continue;
      const auto a = where.find(edge.from), b = where.find(edge.to);
      if (a == where.end() || b == where.end()) continue;
      json += std::string(summary.loop_closures++ > 0 ? "," : "") + "[" +
              std::to_string(a->second.first) + "," + std::to_string(a->second.second) + "," +
              std::to_string(b->second.first) + "," + std::to_string(b->second.second) + "]";
    }
  }
  json += "],\"loop_closure_color\":\"" + Hex(LoopClosureColorRgb()) + "\"";
  ReportProgress(progress, 2);

  std::vector<mapstore::LandmarkId> shown;
  for (const MissionId& id : selected) {
    for (const mapstore::LandmarkId& landmark_id : map.landmark_ids(id)) {
      ++summary.landmarks_total;
      if (keep_quality[static_cast<int>(map.landmark(landmark_id).quality)]) {
        shown.push_back(landmark_id);
      }
    }
  }
  summary.landmarks_shown = shown.size();
  std::string l_p = "[", l_q = "[";
  for (std::size_t i :
       SubsampleIndices(shown.size(), static_cast<std::size_t>(options.max_landmarks))) {
    AppendMm(map.LandmarkPosition_G(shown[i]), &l_p);
    if (l_q.size() > 1) l_q += ',';
    l_q += std::to_string(static_cast<int>(map.landmark(shown[i]).quality));
    ++summary.landmarks_embedded;
  }
  json += ",\"landmarks\":{\"total\":" + std::to_string(summary.landmarks_total) +
          ",\"shown\":" + std::to_string(summary.landmarks_shown) +
          ",\"embedded\":" + std::to_string(summary.landmarks_embedded) +
          ",\"qualities\":" + JsonString(options.landmarks) + ",\"p_mm\":" + l_p +
          "],\"quality\":" + l_q + "]}}";

  // Fill the page's placeholders (split first: inserted text is never searched again).
  const std::string page = internal::kHtmlViewerPage;
  const std::vector<std::pair<std::string, const std::string*>> fills = {
      {"@@TITLE@@", nullptr},
      {"@@REVISION@@", &summary.three_js_revision},
      {"@@THREE_JS@@", &three_js},
      {"@@ORBIT_CONTROLS@@", &orbit},
      {"@@MAP_JSON@@", &json}};
  const std::string escaped_title = HtmlEscape(title);
  std::string html;
  html.reserve(page.size() + three_js.size() + orbit.size() + json.size() + 256);
  std::size_t at = 0;
  while (true) {
    std::size_t next = std::string::npos;
    const std::pair<std::string, const std::string*>* fill = nullptr;
    for (const auto& f : fills) {
      const std::size_t found = page.find(f.first, at);
      if (found < next) {
        next = found;
        fill = &f;
      }
    }
    html.append(page, at, next == std::string::npos ? std::string::npos : next - at);
    if (fill == nullptr) break;
    html += fill->second == nullptr ? escaped_title : *fill->second;
    at = next + fill->first.size();
  }
  summary.bytes = html.size();
  ReportProgress(progress, 3);
  if (summary_out != nullptr) *summary_out = summary;
  return html;
}

HtmlViewerSummary ExportHtmlViewer(const VIMap& map, const HtmlViewerOptions& options,
                                   const std::string& out, ProgressObserver* progress) {
  const std::string path = ResolveOutputFile(out, "map.html", ".html");
  HtmlViewerSummary summary;
  const std::string html = RenderHtmlViewer(map, options, &summary, progress);
  WriteFileAtomically(path, html);
  summary.path = path;
  return summary;
}

}  // namespace vilma::mapping

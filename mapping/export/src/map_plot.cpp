// plot_map: a PNG of a VI-map seen from above and from the side (docs/export-pictures.md).
//
// Layout: a title line, a legend, then the views stacked top to bottom. All views share one
// scale s [px/m] so that distances compare across them, and views over the same horizontal
// axis (x for "xy" and "xz") share its pixel columns. With Wp the plotting width, Hp the height
// left for all views, a_i and b_i the horizontal and vertical extents of view i [m]:
//   s = min(Wp / max_i a_i, Hp / sum_i b_i),   view i gets Hp * b_i / sum_j b_j rows,
// where b_i is at least a fifth of the widest extent, so that a flat side view keeps some height.
#include "vilma/mapping/export/map_plot.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "map_plot_util.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"

namespace vilma::mapping {
namespace {

using internal::SplitComma;
using mapstore::LandmarkId;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

cv::Scalar Bgr(const std::array<uint8_t, 3>& rgb) { return cv::Scalar(rgb[2], rgb[1], rgb[0]); }

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kText(30, 30, 30);
const cv::Scalar kGrid(232, 232, 232);
const cv::Scalar kFrame(90, 90, 90);
// Landmark colours (BGR) by quality: unknown, bad, good.
const cv::Scalar kLandmarkColor[3] = {cv::Scalar(215, 180, 170), cv::Scalar(170, 170, 235),
                                      cv::Scalar(150, 150, 150)};
constexpr int kShift = 4;  // sub-pixel bits of OpenCV's drawing functions
constexpr double kOne = 1 << kShift;

// Hershey fonts have ASCII only.
std::string Ascii(const std::string& s) {
  std::string out = s;
  for (char& c : out) {
    if (c < 32 || c > 126) c = '?';
  }
  return out;
}

// Locale-independent fixed-point text (std::to_chars never uses the locale).
std::string Fixed(double value, int decimals) {
  char buffer[64];
  if (std::abs(value) < 0.5 * std::pow(10.0, -decimals)) value = 0.0;  // no "-0"
  const auto result =
      std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::fixed, decimals);
  return std::string(buffer, result.ptr);
}

// 12345 -> "12,345".
std::string Count(std::size_t n) {
  std::string digits = std::to_string(n);
  for (int i = static_cast<int>(digits.size()) - 3; i > 0; i -= 3) digits.insert(i, ",");
  return digits;
}

// Smallest 1, 2, 5 x 10^k >= x (ceil) or largest <= x (floor), x > 0.
double NiceStep(double x, bool ceil) {
  const double decade = std::pow(10.0, std::floor(std::log10(x)));
  const double steps[] = {1.0, 2.0, 5.0, 10.0};
  if (ceil) {
    for (double s : steps) {
      if (s * decade >= x * (1 - 1e-9)) return s * decade;
    }
    return 10.0 * decade;
  }
  double best = decade;
  for (double s : steps) {
    if (s * decade <= x * (1 + 1e-9)) best = s * decade;
  }
  return best;
}

// Digits after the decimal point that show multiples of `step` exactly (1, 2, 5 x 10^k).
int DecimalsFor(double step) {
  return std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
}

int AxisIndex(char axis) { return axis - 'x'; }

// Text drawing with one font and size for the whole picture.
struct Painter {
  cv::Mat* image;
  double font_scale;
  int thickness;
  int line_h;  // text line height [px]
  int pad;     // general spacing [px]

  cv::Size Measure(const std::string& text) const {
    int baseline = 0;
    return cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, font_scale, thickness, &baseline);
  }
  // Text with its baseline-left at `origin`.
  void Text(const std::string& text, cv::Point origin, const cv::Scalar& color,
            double scale_factor = 1.0) const {
    cv::putText(*image, Ascii(text), origin, cv::FONT_HERSHEY_SIMPLEX, font_scale * scale_factor,
                color, thickness, cv::LINE_AA);
  }
};

// `text`, cut and ended with "..." where needed, so that it is at most `width` pixels wide at
// `scale` times the painter's text size.
std::string FitText(const Painter& painter, const std::string& text, int width, double scale) {
  const auto measure = [&](const std::string& t) {
    int baseline = 0;
    return cv::getTextSize(Ascii(t), cv::FONT_HERSHEY_SIMPLEX, painter.font_scale * scale,
                           painter.thickness, &baseline)
        .width;
  };
  if (measure(text) <= width) return text;
  std::string cut = text;
  while (!cut.empty() && measure(cut + "...") > width) cut.pop_back();
  return cut + "...";
}

struct MissionData {
  MissionId id;
  std::string label;
  cv::Scalar color;
  std::vector<Eigen::Vector3d> p_G;  // vertex positions in time order
  std::size_t num_landmarks = 0;
};

struct LandmarkData {
  std::vector<Eigen::Vector3d> p_G;
  std::vector<uint8_t> quality;
};

struct LegendEntry {
  enum class Swatch { kLine, kDot, kCircle } swatch;
  cv::Scalar color;
  std::string text;
};

// Lays out legend entries left to right, wrapping; returns the height used. Draws when `draw`.
int Legend(const Painter& painter, const std::vector<LegendEntry>& entries, int top, int width,
           bool draw) {
  const int swatch_w = 3 * painter.line_h / 2;
  int x = painter.pad, y = top + painter.line_h;
  for (LegendEntry entry : entries) {
    entry.text = FitText(painter, entry.text, width - 3 * painter.pad - swatch_w, 1.0);
    const int w = swatch_w + painter.pad / 2 + painter.Measure(entry.text).width + 2 * painter.pad;
    if (x > painter.pad && x + w > width) {
      x = painter.pad;
      y += painter.line_h;
    }
    if (draw) {
      const cv::Point mid(x + swatch_w / 2, y - painter.line_h / 4);
      const int r = std::max(2, painter.line_h / 6);
      switch (entry.swatch) {
        case LegendEntry::Swatch::kLine:
          cv::line(*painter.image, {x, mid.y}, {x + swatch_w, mid.y}, entry.color,
                   std::max(2, painter.thickness + 1), cv::LINE_AA);
          cv::circle(*painter.image, mid, r, entry.color, cv::FILLED, cv::LINE_8);
          break;
        case LegendEntry::Swatch::kDot:
          cv::circle(*painter.image, mid, r, entry.color, cv::FILLED, cv::LINE_8);
          break;
        case LegendEntry::Swatch::kCircle:
          cv::circle(*painter.image, mid, 2 * r, entry.color, painter.thickness, cv::LINE_AA);
          break;
      }
      painter.Text(entry.text, {x + swatch_w + painter.pad / 2, y}, kText);
    }
    x += w;
  }
  return y - top + painter.pad / 2;
}

// Grid, frame, ticks and labels of one view.
void DrawAxes(const Painter& painter, const MapPlotView& view, double step_m,
              const std::string& name) {
  cv::Mat& image = *painter.image;
  const cv::Rect& r = view.panel_px;
  const int decimals = DecimalsFor(step_m);
  const int tick = std::max(3, painter.pad / 2);
  // Vertical grid lines and ticks (horizontal axis).
  const double h_max = view.min_m.x() + r.width / view.px_per_m;
  for (double h = std::ceil(view.min_m.x() / step_m) * step_m; h <= h_max; h += step_m) {
    const int c = r.x + static_cast<int>(std::lround((h - view.min_m.x()) * view.px_per_m));
    cv::line(image, {c, r.y}, {c, r.y + r.height - 1}, kGrid, 1);
    cv::line(image, {c, r.y + r.height}, {c, r.y + r.height + tick}, kFrame, 1);
    const std::string label = Fixed(h, decimals);
    const cv::Size size = painter.Measure(label);
    painter.Text(label, {c - size.width / 2, r.y + r.height + tick + painter.line_h * 3 / 4},
                 kText);
  }
  const double v_max = view.min_m.y() + r.height / view.px_per_m;
  for (double v = std::ceil(view.min_m.y() / step_m) * step_m; v <= v_max; v += step_m) {
    const int row =
        r.y + r.height - 1 - static_cast<int>(std::lround((v - view.min_m.y()) * view.px_per_m));
    cv::line(image, {r.x, row}, {r.x + r.width - 1, row}, kGrid, 1);
    cv::line(image, {r.x - tick, row}, {r.x - 1, row}, kFrame, 1);
    const std::string label = Fixed(v, decimals);
    const cv::Size size = painter.Measure(label);
    painter.Text(label, {r.x - tick - painter.pad / 2 - size.width, row + size.height / 2}, kText);
  }
  cv::rectangle(image, {r.x - 1, r.y - 1}, {r.x + r.width, r.y + r.height}, kFrame, 1);
  // Axis names: the horizontal one centred below the tick labels, the vertical one above the
  // left frame; the view's name above the right end.
  const std::string h_label = std::string(1, view.axes[0]) + " [m]";
  const std::string v_label = std::string(1, view.axes[1]) + " [m]";
  painter.Text(h_label,
               {r.x + r.width / 2 - painter.Measure(h_label).width / 2,
                r.y + r.height + tick + painter.line_h * 7 / 4},
               kText);
  painter.Text(v_label, {r.x - painter.Measure(v_label).width / 2, r.y - painter.pad / 2}, kText);
  painter.Text(name, {r.x + r.width - painter.Measure(name).width, r.y - painter.pad / 2}, kText);
}

void DrawScaleBar(const Painter& painter, const MapPlotView& view, double length_m) {
  cv::Mat& image = *painter.image;
  const int bar_px = static_cast<int>(std::lround(length_m * view.px_per_m));
  const std::string label = Fixed(length_m, DecimalsFor(length_m)) + " m";
  const cv::Size text = painter.Measure(label);
  const int box_w = std::max(bar_px, text.width) + 2 * painter.pad;
  const int box_h = painter.line_h + 2 * painter.pad;
  const cv::Rect box(view.panel_px.x + painter.pad,
                     view.panel_px.y + view.panel_px.height - painter.pad - box_h, box_w, box_h);
  cv::rectangle(image, box, kWhite, cv::FILLED);
  cv::rectangle(image, box, kFrame, 1);
  const int y = box.y + box.height - painter.pad;
  const int x0 = box.x + painter.pad;
  const int bar_t = std::max(2, painter.thickness + 1);
  cv::line(image, {x0, y}, {x0 + bar_px, y}, kText, bar_t);
  cv::line(image, {x0, y - painter.pad / 2 - 2}, {x0, y}, kText, bar_t);
  cv::line(image, {x0 + bar_px, y - painter.pad / 2 - 2}, {x0 + bar_px, y}, kText, bar_t);
  painter.Text(label, {x0 + (bar_px - text.width) / 2, y - painter.pad / 2 - bar_t - 2}, kText);
}

cv::Point ToPoint(const Eigen::Vector2d& px, const cv::Rect& panel) {
  return cv::Point(static_cast<int>(std::lround((px.x() - panel.x) * kOne)),
                   static_cast<int>(std::lround((px.y() - panel.y) * kOne)));
}

}  // namespace

std::string MapPlotOptions::Validate() const {
  if (width_px < 200 || width_px > 10000) return "width_px: 200 ... 10000 pixels";
  if (height_px < 150 || height_px > 10000) return "height_px: 150 ... 10000 pixels";
  const std::vector<std::string> view_list = SplitComma(views);
  if (view_list.empty() || view_list.size() > 3) return "views: 1 to 3 of xy, xz, yz";
  for (const std::string& v : view_list) {
    if (v != "xy" && v != "xz" && v != "yz") {
      return "views: comma separated xy, xz, yz (not '" + v + "')";
    }
  }
  std::array<bool, 3> keep;
  const std::string problem = ParseLandmarkQualities(landmarks, &keep);
  if (!problem.empty()) return "landmarks: " + problem;
  if (max_landmarks < 0) return "max_landmarks: 0 or more";
  return "";
}

Eigen::Vector2d MapPlotView::Project(const Eigen::Vector3d& p_G) const {
  const double h = p_G[AxisIndex(axes[0])];
  const double v = p_G[AxisIndex(axes[1])];
  return Eigen::Vector2d(panel_px.x + (h - min_m.x()) * px_per_m,
                         panel_px.y + panel_px.height - 1 - (v - min_m.y()) * px_per_m);
}

std::string MapPlotSummary::BriefReport() const {
  std::ostringstream out;
  if (!path.empty()) out << "wrote " << path << " (" << Count(bytes) << " bytes): ";
  out << missions << " mission(s), " << vertices << " vertices, " << loop_closures
      << " loop closure(s), landmarks " << landmarks_drawn << " drawn of " << landmarks_shown
      << " shown of " << landmarks_total << ", scale bar " << scale_bar_m << " m ("
      << Fixed(px_per_m, 2) << " px/m)";
  return out.str();
}

std::string MapPlotSummary::FullReport() const { return BriefReport() + "\n"; }

MapPlot RenderMapPlot(const VIMap& map, const MapPlotOptions& options, ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "plot_map options");
  const std::vector<MissionId> selected = SelectMissions(map, options.mission);
  std::array<bool, 3> keep_quality;
  ParseLandmarkQualities(options.landmarks, &keep_quality);
  BeginProgress(progress, "plot_map", 3);

  MapPlot plot;
  MapPlotSummary& summary = plot.summary;
  // --- gather: vertex positions per mission, landmark positions, loop closures in G ---
  std::vector<MissionData> missions;
  VIMap::IdSet selected_vertices;
  for (std::size_t i = 0; i < selected.size(); ++i) {
    const mapstore::Mission& mission = map.mission(selected[i]);
    MissionData data;
    data.id = mission.id;
    data.color = Bgr(MissionColorRgb(MissionIndex(map, mission.id)));
    for (const VertexId& v : VerticesInTimeOrder(map, mission.id)) {
      data.p_G.push_back(map.T_G_I(v).translation());
      selected_vertices.insert(v);
    }
    double length_m = 0.0;
    for (std::size_t k = 1; k < data.p_G.size(); ++k)
      length_m += (data.p_G[k] - data.p_G[k - 1]).norm();
    const std::string id8 = mission.id.Hex().substr(0, 8);
    data.label = (mission.name.empty() ? "mission " + id8 : mission.name + " (" + id8 + ")") +
                 ": " + Count(data.p_G.size()) + " vertices, " + Fixed(length_m, 1) + " m" +
                 (mission.baseframe_known ? "" : ", baseframe unknown");
    summary.vertices += data.p_G.size();
    missions.push_back(std::move(data));
  }
  summary.missions = missions.size();
  if (summary.vertices == 0) {
    throw InputError(FormatInputError("plot_map", "--mission",
                                      "missions with vertices (the selection has none)"));
  }
  LandmarkData shown;
  for (const MissionId& mission_id : selected) {
    for (const LandmarkId& id : map.landmark_ids(mission_id)) {
      ++summary.landmarks_total;
      const auto quality = static_cast<uint8_t>(map.landmark(id).quality);
      if (!keep_quality[quality]) continue;
      shown.p_G.push_back(map.LandmarkPosition_G(id));
      shown.quality.push_back(quality);
    }
  }
  summary.landmarks_shown = shown.p_G.size();
  LandmarkData drawn;
  for (std::size_t i :
       SubsampleIndices(shown.p_G.size(), static_cast<std::size_t>(options.max_landmarks))) {
    drawn.p_G.push_back(shown.p_G[i]);
    drawn.quality.push_back(shown.quality[i]);
  }
  summary.landmarks_drawn = drawn.p_G.size();
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> loops;
  if (options.show_loop_closures) {
    for (const MissionId& mission_id : selected) {
      for (const mapstore::EdgeId& id : map.edge_ids(mission_id)) {
        const mapstore::Edge& edge = map.edge(id);
        if (edge.type != mapstore::EdgeType::kLoopClosure) continue;
        if (!selected_vertices.count(edge.from) || !selected_vertices.count(edge.to)) continue;
        loops.emplace_back(map.T_G_I(edge.from).translation(), map.T_G_I(edge.to).translation());
      }
    }
  }
  summary.loop_closures = loops.size();
  ReportProgress(progress, 1);

  // --- extents: all vertices, and the landmarks between their 1st and 99th percentile per
  // axis (a few far outliers must not shrink the map to a dot) ---
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const MissionData& m : missions) {
    for (const Eigen::Vector3d& p : m.p_G) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  if (drawn.p_G.size() >= 2) {
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<double> values;
      values.reserve(drawn.p_G.size());
      for (const Eigen::Vector3d& p : drawn.p_G) values.push_back(p[axis]);
      const std::size_t n = values.size();
      const std::size_t k_lo = n / 100, k_hi = n - 1 - n / 100;
      std::nth_element(values.begin(), values.begin() + k_lo, values.end());
      lo[axis] = std::min(lo[axis], values[k_lo]);
      std::nth_element(values.begin(), values.begin() + k_hi, values.end());
      hi[axis] = std::max(hi[axis], values[k_hi]);
    }
  }
  const double largest = std::max(1.0, (hi - lo).maxCoeff());
  Eigen::Vector3d centre = 0.5 * (lo + hi);
  Eigen::Vector3d extent = (hi - lo).cwiseMax(1.0) + Eigen::Vector3d::Constant(0.1 * largest);

  // --- layout ---
  const int W = options.width_px, H = options.height_px;
  plot.image = cv::Mat(H, W, CV_8UC3, kWhite);
  const double unit = std::min(W, H) / 800.0;
  Painter painter{&plot.image, std::max(0.35, 0.5 * unit),
                  std::max(1, static_cast<int>(std::lround(unit))), 0,
                  std::max(4, static_cast<int>(std::lround(8 * unit)))};
  painter.line_h = painter.Measure("Ag").height * 2;

  std::vector<LegendEntry> legend;
  for (const MissionData& m : missions)
    legend.push_back({LegendEntry::Swatch::kLine, m.color, m.label});
  legend.push_back({LegendEntry::Swatch::kCircle, kFrame, "start"});
  for (int q : {2, 0, 1}) {
    if (!keep_quality[q]) continue;
    static const char* kNames[3] = {"unknown", "bad", "good"};
    legend.push_back({LegendEntry::Swatch::kDot, kLandmarkColor[q],
                      std::string("landmarks (") + kNames[q] + ")"});
  }
  if (options.show_loop_closures) {
    legend.push_back({LegendEntry::Swatch::kLine, Bgr(LoopClosureColorRgb()),
                      "loop closures: " + Count(loops.size())});
  }
  const int title_h = painter.line_h * 3 / 2 + painter.pad;
  const int legend_h = Legend(painter, legend, title_h, W, false);

  const std::vector<std::string> view_axes = SplitComma(options.views);
  const std::size_t n_views = view_axes.size();
  // Room for the widest tick label: the most negative coordinate a view can show, 2 decimals.
  const double widest_m = std::max(std::abs(lo.minCoeff()), std::abs(hi.maxCoeff())) + largest;
  const int margin_left = painter.Measure(Fixed(-widest_m, 2)).width + 2 * painter.pad;
  const int margin_right = 2 * painter.pad;
  const int margin_top = painter.line_h;
  const int margin_bottom = painter.line_h * 2 + painter.pad;
  const int Wp = W - margin_left - margin_right;
  const int Hp = H - title_h - legend_h - static_cast<int>(n_views) * (margin_top + margin_bottom) -
                 painter.pad;
  if (Wp < 50 || Hp < 30 * static_cast<int>(n_views)) {
    throw InputError(FormatInputError("plot_map", "--width_px/--height_px",
                                      "a picture large enough for " + std::to_string(n_views) +
                                          " view(s), the legend and the title"));
  }
  double max_a = 0.0;
  for (const std::string& axes : view_axes) max_a = std::max(max_a, extent[AxisIndex(axes[0])]);
  std::vector<double> b(n_views);
  double sum_b = 0.0;
  for (std::size_t i = 0; i < n_views; ++i) {
    b[i] = std::max(extent[AxisIndex(view_axes[i][1])], 0.2 * max_a);
    sum_b += b[i];
  }
  const double s = std::min(Wp / max_a, Hp / sum_b);
  summary.px_per_m = s;
  int y = title_h + legend_h;
  for (std::size_t i = 0; i < n_views; ++i) {
    MapPlotView view;
    view.axes = view_axes[i];
    const int rows = static_cast<int>(std::floor(Hp * b[i] / sum_b));
    y += margin_top;
    view.panel_px = cv::Rect(margin_left, y, Wp, rows);
    y += rows + margin_bottom;
    view.px_per_m = s;
    const int h = AxisIndex(view.axes[0]), v = AxisIndex(view.axes[1]);
    view.min_m = Eigen::Vector2d(centre[h] - 0.5 * Wp / s, centre[v] - 0.5 * rows / s);
    plot.views.push_back(view);
  }

  // --- draw ---
  {
    const std::string title =
        (options.title.empty() ? std::string("VI-map") : options.title) + ": " +
        Count(missions.size()) + " mission(s), " + Count(summary.vertices) + " vertices, " +
        Count(summary.landmarks_total) + " landmarks (" + Count(summary.landmarks_drawn) +
        " drawn: " + options.landmarks + "), " + Count(loops.size()) + " loop closure(s); frame G";
    // 1.25 times the text size, smaller (down to 0.8) or cut with "..." to fit the width.
    const int room = W - 2 * painter.pad;
    const double factor =
        std::clamp(room / static_cast<double>(painter.Measure(title).width), 0.8, 1.25);
    painter.Text(FitText(painter, title, room, factor),
                 {painter.pad, painter.line_h + painter.pad / 2}, kText, factor);
  }
  Legend(painter, legend, title_h, W, true);
  const double step_m = NiceStep(90.0 * unit / s, true);
  const int dot_r = std::max(1, static_cast<int>(std::lround(0.7 * unit)));
  const int line_t = std::max(2, static_cast<int>(std::lround(1.3 * unit)));
  const int vertex_r = std::max(2, static_cast<int>(std::lround(1.6 * unit)));
  for (const MapPlotView& view : plot.views) {
    std::string name = view.axes == "xy"   ? "top view (x-y)"
                       : view.axes == "xz" ? "side view (x-z)"
                                           : "side view (y-z)";
    DrawAxes(painter, view, step_m, name);
    // Everything of the map is clipped to the panel: drawn into the panel's sub-image.
    cv::Mat panel = plot.image(view.panel_px);
    for (int q : {1, 0, 2}) {  // bad, unknown, then good on top
      for (std::size_t k = 0; k < drawn.p_G.size(); ++k) {
        if (drawn.quality[k] != q) continue;
        cv::circle(panel, ToPoint(view.Project(drawn.p_G[k]), view.panel_px), dot_r << kShift,
                   kLandmarkColor[q], cv::FILLED, cv::LINE_8, kShift);
      }
    }
    for (const MissionData& m : missions) {
      std::vector<cv::Point> points;
      for (const Eigen::Vector3d& p : m.p_G)
        points.push_back(ToPoint(view.Project(p), view.panel_px));
      cv::polylines(panel, points, false, m.color, line_t, cv::LINE_AA, kShift);
    }
    for (const auto& [a, b_G] : loops) {
      cv::line(panel, ToPoint(view.Project(a), view.panel_px),
               ToPoint(view.Project(b_G), view.panel_px), Bgr(LoopClosureColorRgb()), line_t,
               cv::LINE_AA, kShift);
    }
    for (const MissionData& m : missions) {
      if (options.show_vertices) {
        for (const Eigen::Vector3d& p : m.p_G) {
          cv::circle(panel, ToPoint(view.Project(p), view.panel_px), vertex_r << kShift, m.color,
                     cv::FILLED, cv::LINE_8, kShift);
        }
      }
      if (m.p_G.empty()) continue;
      cv::circle(panel, ToPoint(view.Project(m.p_G.front()), view.panel_px),
                 (3 * vertex_r + line_t) << kShift, m.color, line_t, cv::LINE_AA, kShift);
    }
  }
  summary.scale_bar_m = NiceStep(0.2 * Wp / s, false);
  DrawScaleBar(painter, plot.views.front(), summary.scale_bar_m);
  ReportProgress(progress, 2);
  return plot;
}

MapPlotSummary PlotMap(const VIMap& map, const MapPlotOptions& options, const std::string& out,
                       ProgressObserver* progress) {
  const std::string path = ResolveOutputFile(out, "map.png", ".png");
  MapPlot plot = RenderMapPlot(map, options, progress);
  std::vector<uchar> png;
  if (!cv::imencode(".png", plot.image, png, {cv::IMWRITE_PNG_COMPRESSION, 9})) {
    throw InputError(FormatInputError(path, "", "a PNG that OpenCV can encode"));
  }
  ReportProgress(progress, 3);
  WriteFileAtomically(path, std::string(png.begin(), png.end()));
  plot.summary.path = path;
  plot.summary.bytes = png.size();
  return plot.summary;
}

}  // namespace vilma::mapping

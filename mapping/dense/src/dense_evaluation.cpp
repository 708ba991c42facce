#include "vilma/mapping/dense/dense_evaluation.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/mapping/dense/depth_map.h"

namespace vilma::mapping {
namespace {

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const std::size_t k = std::min(values.size() - 1, static_cast<std::size_t>(q * values.size()));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

std::vector<DepthView> DepthViews(const mapstore::VIMap& map,
                                  const std::vector<mapstore::MissionId>& missions) {
  std::vector<DepthView> views;
  for (const mapstore::MissionId& mid : missions.empty() ? map.mission_ids() : missions) {
    for (const mapstore::VertexId& vid : map.vertex_ids(mid)) {
      const mapstore::Vertex& v = map.vertex(vid);
      for (int c = 0; c < static_cast<int>(v.frames.size()); ++c) {
        if (!v.frames[c].depth_resource_id.IsValid()) continue;
        const DepthMap depth = LoadDepthMap(map, vid, c);
        DepthView view;
        view.vertex = vid;
        view.camera = c;
        view.T_G_D = DepthViewPose(map, vid, c, depth);
        view.fx = depth.fx;
        view.fy = depth.fy;
        view.cx = depth.cx;
        view.cy = depth.cy;
        view.width = depth.width();
        view.height = depth.height();
        views.push_back(view);
      }
    }
  }
  return views;
}

std::string DepthConsistencyOptions::Validate() const {
  return pixel_stride >= 1 ? "" : "pixel_stride: >= 1";
}

std::string DepthConsistency::BriefReport() const {
  std::ostringstream s;
  s << std::fixed << std::setprecision(4) << "depth consistency over " << pairs
    << " neighbouring keyframe pairs, " << overlapping_points << " overlapping points: median "
    << median_abs_m << " m, p90 " << p90_abs_m << " m, median relative " << std::setprecision(2)
    << 100.0 * median_relative << " %";
  return s.str();
}

std::string DepthConsistency::FullReport() const { return BriefReport() + "\n"; }

namespace {

struct PosedDepthMap {
  DepthMap depth;
  Eigen::Matrix4d T_G_D = Eigen::Matrix4d::Identity();
};

// Appends |depth predicted from a - depth measured in b| (and relative) for a's points.
void AccumulateDifferences(const PosedDepth& a, const PosedDepth& b, int stride,
                           std::vector<double>* abs_diff, std::vector<double>* rel_diff) {
  const DepthMap& da = *a.depth;
  const DepthMap& db = *b.depth;
  const Eigen::Matrix4d T_B_A = b.T_G_D.inverse() * a.T_G_D;
  for (int v = 0; v < da.height(); v += stride) {
    for (int u = 0; u < da.width(); u += stride) {
      const float z = da.depth_m.at<float>(v, u);
      if (!(z > 0.0f)) continue;
      const Eigen::Vector4d p_A(z * (u - da.cx) / da.fx, z * (v - da.cy) / da.fy, z, 1.0);
      const Eigen::Vector4d p_B = T_B_A * p_A;
      if (p_B.z() <= 0.0) continue;
      const long ub = std::lround(db.fx * p_B.x() / p_B.z() + db.cx);
      const long vb = std::lround(db.fy * p_B.y() / p_B.z() + db.cy);
      if (ub < 0 || vb < 0 || ub >= db.width() || vb >= db.height()) continue;
      const float z_b = db.depth_m.at<float>(static_cast<int>(vb), static_cast<int>(ub));
      if (!(z_b > 0.0f)) continue;
      const double diff = std::abs(p_B.z() - z_b);
      abs_diff->push_back(diff);
      rel_diff->push_back(diff / z_b);
    }
  }
}

DepthConsistency Summarize(int pairs, const std::vector<double>& abs_diff,
                           const std::vector<double>& rel_diff) {
  DepthConsistency result;
  result.pairs = pairs;
  result.overlapping_points = static_cast<long>(abs_diff.size());
  result.median_abs_m = Percentile(abs_diff, 0.5);
  result.p90_abs_m = Percentile(abs_diff, 0.9);
  result.median_relative = Percentile(rel_diff, 0.5);
  return result;
}

}  // namespace

DepthConsistency MeasureDepthConsistency(const std::vector<std::pair<PosedDepth, PosedDepth>>& pairs,
                                         const DepthConsistencyOptions& options) {
  ThrowIfInvalid(options.Validate(), "depth consistency options");
  std::vector<double> abs_diff, rel_diff;
  for (const auto& [a, b] : pairs) AccumulateDifferences(a, b, options.pixel_stride, &abs_diff, &rel_diff);
  return Summarize(static_cast<int>(pairs.size()), abs_diff, rel_diff);
}

DepthConsistency MeasureDepthConsistency(const mapstore::VIMap& map,
                                         const std::vector<mapstore::MissionId>& missions,
                                         const DepthConsistencyOptions& options) {
  ThrowIfInvalid(options.Validate(), "depth consistency options");
  // Pair by pair, so that only two depth maps are decoded at a time.
  int pairs = 0;
  std::vector<double> abs_diff, rel_diff;
  // The second map of a pair is the first of the next one: decoded once, kept per camera.
  std::map<int, std::pair<mapstore::VertexId, PosedDepthMap>> previous;
  auto load = [&map](const mapstore::VertexId& vertex, int camera) {
    PosedDepthMap d;
    d.depth = LoadDepthMap(map, vertex, camera);
    d.T_G_D = DepthViewPose(map, vertex, camera, d.depth);
    return d;
  };
  for (const mapstore::MissionId& mid : missions.empty() ? map.mission_ids() : missions) {
    const std::vector<mapstore::VertexId>& vertices = map.vertex_ids(mid);
    for (std::size_t i = 0; i + 1 < vertices.size(); ++i) {
      const mapstore::Vertex& a = map.vertex(vertices[i]);
      const mapstore::Vertex& b = map.vertex(vertices[i + 1]);
      for (int c = 0; c < static_cast<int>(std::min(a.frames.size(), b.frames.size())); ++c) {
        if (!a.frames[c].depth_resource_id.IsValid() || !b.frames[c].depth_resource_id.IsValid()) continue;
        auto it = previous.find(c);
        const PosedDepthMap da = it != previous.end() && it->second.first == a.id
                                     ? std::move(it->second.second)
                                     : load(a.id, c);
        PosedDepthMap db = load(b.id, c);
        AccumulateDifferences({&da.depth, da.T_G_D}, {&db.depth, db.T_G_D}, options.pixel_stride,
                              &abs_diff, &rel_diff);
        previous[c] = {b.id, std::move(db)};
        ++pairs;
      }
    }
  }
  return Summarize(pairs, abs_diff, rel_diff);
}

}  // namespace vilma::mapping

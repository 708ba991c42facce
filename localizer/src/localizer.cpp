#include "vilma/localizer/localizer.h"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <numeric>
#include <sstream>
#include <unordered_map>

#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"
#include "vilma/core/timing.h"
#include "vilma/core/yaml_io.h"

namespace vilma::localizer {
namespace {

// One list of every option (core/options_fields.h): the reader and the writer stay in sync.
template <typename Options, typename Visitor>
void VisitLocalizerOptions(Options& o, Visitor&& v) {
  v("map", "max_descriptors_per_landmark", o.map.max_descriptors_per_landmark);
  v("map", "min_observations", o.map.min_observations);
  v("map", "calibrate_landmark_covariances", o.map.calibrate_landmark_covariances);
  v("projection", "dimensions", o.projection.dimensions);
  v("projection", "max_pairs", o.projection.max_pairs);
  v("projection", "regularization", o.projection.regularization);
  v("projection", "seed", o.projection.seed);
  v("index", "codebook_size", o.index.codebook_size);
  v("index", "kmeans_iterations", o.index.kmeans_iterations);
  v("index", "kmeans_max_samples", o.index.kmeans_max_samples);
  v("index", "seed", o.index.seed);
  v("index", "min_neighbors", o.index.min_neighbors);
  v("index", "max_neighbors", o.index.max_neighbors);
  v("index", "descriptors_per_extra_neighbor", o.index.descriptors_per_extra_neighbor);
  v("index", "candidates_per_neighbor", o.index.candidates_per_neighbor);
  v("matching", "max_hamming_distance", o.matching.max_hamming_distance);
  v("matching", "max_landmarks_per_keypoint", o.matching.max_landmarks_per_keypoint);
  v("matching", "covisibility_filter", o.matching.covisibility_filter);
  v("matching", "min_matches", o.matching.min_matches);
  v("ransac", "threshold_px", o.ransac.threshold_px);
  v("ransac", "max_iterations", o.ransac.max_iterations);
  v("ransac", "probability", o.ransac.probability);
  v("ransac", "min_inliers", o.ransac.min_inliers);
  v("ransac", "refine_iterations", o.ransac.refine_iterations);
  v("ransac", "keypoint_sigma_px", o.ransac.keypoint_sigma_px);
  v("ransac", "seed", o.ransac.seed);
  v("acceptance", "min_inlier_ratio", o.acceptance.min_inlier_ratio);
  v("acceptance", "refine_rounds", o.acceptance.refine_rounds);
  v("acceptance", "max_median_error_ratio", o.acceptance.max_median_error_ratio);
  v("acceptance", "max_p90_error_ratio", o.acceptance.max_p90_error_ratio);
  v("acceptance", "grid_cols", o.acceptance.grid_cols);
  v("acceptance", "grid_rows", o.acceptance.grid_rows);
  v("acceptance", "min_cell_fraction", o.acceptance.min_cell_fraction);
  v("acceptance", "min_hull_fraction", o.acceptance.min_hull_fraction);
  v("acceptance", "max_position_sigma_m", o.acceptance.max_position_sigma_m);
  v("acceptance", "max_rotation_sigma_deg", o.acceptance.max_rotation_sigma_deg);
  v("acceptance", "landmark_uncertainty", o.acceptance.landmark_uncertainty);
  v("acceptance", "unweighted_covariance", o.acceptance.unweighted_covariance);
  v("acceptance", "rival_check", o.acceptance.rival_check);
  v("acceptance", "rival_exclusion_factor", o.acceptance.rival_exclusion_factor);
  v("acceptance", "max_rival_ratio", o.acceptance.max_rival_ratio);
  v("acceptance", "max_outweighed_rival_ratio", o.acceptance.max_outweighed_rival_ratio);
  v("acceptance", "min_rival_margin_sigma", o.acceptance.min_rival_margin_sigma);
  v("acceptance", "rival_max_iterations", o.acceptance.rival_max_iterations);
  v("acceptance", "rival_min_position_m", o.acceptance.rival_min_position_m);
  v("acceptance", "rival_min_rotation_deg", o.acceptance.rival_min_rotation_deg);
  v("acceptance", "displaced_rival_check", o.acceptance.displaced_rival_check);
  v("acceptance", "max_displaced_rival_ratio", o.acceptance.max_displaced_rival_ratio);
  v("acceptance", "displaced_rival_samples", o.acceptance.displaced_rival_samples);
  v("acceptance", "adopt_displaced_rival", o.acceptance.adopt_displaced_rival);
  v("acceptance", "measure_all_gates", o.acceptance.measure_all_gates);
}

struct UnionFind {
  std::vector<uint32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  uint32_t Find(uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void Union(uint32_t a, uint32_t b) {
    a = Find(a);
    b = Find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace

std::string MatchingOptions::Validate() const {
  if (max_hamming_distance < 0 || max_hamming_distance > 512) {
    return "max_hamming_distance: expected 0..512";
  }
  if (max_landmarks_per_keypoint < 1) return "max_landmarks_per_keypoint: expected >= 1";
  if (min_matches < 4) return "min_matches: expected >= 4";
  return "";
}

std::string LocalizerOptions::Validate() const {
  const std::pair<const char*, std::string> checks[] = {
      {"map", map.Validate()},           {"projection", projection.Validate()},
      {"index", index.Validate()},       {"matching", matching.Validate()},
      {"ransac", ransac.Validate()},     {"acceptance", acceptance.Validate()}};
  for (const auto& [section, error] : checks) {
    if (!error.empty()) return std::string(section) + "." + error;
  }
  return "";
}

LocalizerOptions ParseLocalizerOptions(const std::string& yaml_text, const std::string& source) {
  const YamlNode root = YamlNode::LoadString(yaml_text, source);
  LocalizerOptions o;
  // Missing keys (and sections) keep their defaults: config/localizer.yaml lists only what a
  // user changes.
  ReadOptionFields(root, MissingKey::kKeepDefault, &o,
                   [](auto& options, auto&& v) { VisitLocalizerOptions(options, v); });
  ThrowIfInvalid(o.Validate(), source);
  return o;
}

std::string LocalizerOptionsToYaml(const LocalizerOptions& options) {
  return OptionFieldsToYaml(options,
                            [](auto& o, auto&& v) { VisitLocalizerOptions(o, v); });
}

LocalizerOptions LoadLocalizerOptions(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(FormatInputError(path, "", "expected a readable YAML file"));
  std::stringstream ss;
  ss << in.rdbuf();
  return ParseLocalizerOptions(ss.str(), path);
}

const char* LocalizationStatusName(LocalizationStatus status) {
  switch (status) {
    case LocalizationStatus::kOk: return "ok";
    case LocalizationStatus::kNoKeypoints: return "no_keypoints";
    case LocalizationStatus::kNoDescriptorMatches: return "no_descriptor_matches";
    case LocalizationStatus::kTooFewMatches: return "too_few_matches";
    case LocalizationStatus::kRansacFailed: return "ransac_failed";
    case LocalizationStatus::kTooFewInliers: return "too_few_inliers";
    case LocalizationStatus::kLowInlierRatio: return "low_inlier_ratio";
    case LocalizationStatus::kHighReprojectionError: return "high_reprojection_error";
    case LocalizationStatus::kClusteredInliers: return "clustered_inliers";
    case LocalizationStatus::kUncertainPose: return "uncertain_pose";
    case LocalizationStatus::kAmbiguousPose: return "ambiguous_pose";
    case LocalizationStatus::kNumStatuses: break;
  }
  return "unknown";
}

bool HasRefinedPose(LocalizationStatus status) {
  switch (status) {
    case LocalizationStatus::kOk:
    case LocalizationStatus::kTooFewInliers:
    case LocalizationStatus::kLowInlierRatio:
    case LocalizationStatus::kHighReprojectionError:
    case LocalizationStatus::kClusteredInliers:
    case LocalizationStatus::kUncertainPose:
    case LocalizationStatus::kAmbiguousPose:
      return true;
    case LocalizationStatus::kNoKeypoints:
    case LocalizationStatus::kNoDescriptorMatches:
    case LocalizationStatus::kTooFewMatches:
    case LocalizationStatus::kRansacFailed:
    case LocalizationStatus::kNumStatuses:
      return false;
  }
  return false;
}

std::string LocalizerStats::FullReport() const {
  std::ostringstream ss;
  ss << "queries " << queries << "\n";
  for (int s = 0; s < static_cast<int>(LocalizationStatus::kNumStatuses); ++s) {
    ss << "  " << LocalizationStatusName(static_cast<LocalizationStatus>(s)) << " "
       << status_counts[s] << "\n";
  }
  return ss.str();
}

std::string LocalizerStats::BriefReport() const {
  std::ostringstream ss;
  ss << "queries " << queries;
  for (int s = 0; s < static_cast<int>(LocalizationStatus::kNumStatuses); ++s) {
    ss << ", " << LocalizationStatusName(static_cast<LocalizationStatus>(s)) << " "
       << status_counts[s];
  }
  return ss.str();
}

std::vector<int> LargestCovisibleComponent(const LocalizationMap& map,
                                           const std::vector<Match2D3D>& matches) {
  std::vector<int> keep;
  if (matches.empty()) return keep;
  // Nodes: matched landmarks (dense 0..m-1). Landmarks sharing an observer vertex are joined.
  std::unordered_map<uint32_t, uint32_t> node_of;
  for (const Match2D3D& m : matches) node_of.emplace(m.landmark, static_cast<uint32_t>(node_of.size()));
  UnionFind uf(node_of.size());
  std::unordered_map<uint32_t, uint32_t> first_node_of_observer;
  for (const auto& [landmark, node] : node_of) {
    for (uint32_t k = map.observer_begin[landmark]; k < map.observer_begin[landmark + 1]; ++k) {
      const auto [it, inserted] = first_node_of_observer.emplace(map.observer_index[k], node);
      if (!inserted) uf.Union(node, it->second);
    }
  }
  std::unordered_map<uint32_t, int> size_of_root;
  for (const Match2D3D& m : matches) ++size_of_root[uf.Find(node_of[m.landmark])];
  int best_size = 0;
  uint32_t best_root = 0;
  for (const Match2D3D& m : matches) {  // first match order breaks ties deterministically
    const uint32_t root = uf.Find(node_of[m.landmark]);
    if (size_of_root[root] > best_size) {
      best_size = size_of_root[root];
      best_root = root;
    }
  }
  for (std::size_t i = 0; i < matches.size(); ++i) {
    if (uf.Find(node_of[matches[i].landmark]) == best_root) keep.push_back(static_cast<int>(i));
  }
  return keep;
}

Localizer::Localizer(std::shared_ptr<const LocalizationMap> map, const LocalizerOptions& options)
    : map_(std::move(map)), options_(options) {
  const std::string error = options.Validate();
  if (!error.empty()) throw InputError(FormatInputError("LocalizerOptions", "", error));
  if (!map_ || map_->num_descriptors() < 2) {
    throw InputError(FormatInputError("localization map", "descriptors",
                                      "expected at least 2 descriptors"));
  }
  auto t0 = std::chrono::steady_clock::now();
  if (map_->projection.rows() > 0) {
    projection_ = map_->projection;
  } else {
    projection_ = TrainProjectionMatrix(map_->descriptors, static_cast<int>(map_->descriptor_bytes),
                                        map_->descriptor_landmark, options.projection);
  }
  projection_train_ms_ = MsSince(t0);
  t0 = std::chrono::steady_clock::now();
  index_ = DescriptorIndex(projection_, map_->descriptors.data(),
                           static_cast<int>(map_->descriptor_bytes), map_->num_descriptors(),
                           options.index);
  index_build_ms_ = MsSince(t0);
}

std::vector<Match2D3D> Localizer::Match(const std::vector<Eigen::Vector2d>& keypoints,
                                        const uint8_t* descriptors, int* num_raw_matches) const {
  const int bytes = static_cast<int>(map_->descriptor_bytes);
  std::vector<Match2D3D> matches;
  matches.reserve(keypoints.size() *
                  static_cast<std::size_t>(options_.matching.max_landmarks_per_keypoint));
  std::vector<Match2D3D> per_keypoint;
  // One set of search buffers for all keypoints of the query: no allocation per keypoint.
  DescriptorSearchScratch scratch;
  std::vector<Neighbor> neighbors;
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const uint8_t* d = descriptors + i * bytes;
    index_.Search(d, &scratch, &neighbors);
    // The neighbours' descriptors are scattered over the map's descriptor array (6.4 MB for
    // 100k descriptors, beyond L2): request all their cache lines first so that the k misses
    // overlap instead of stalling one Hamming check after the other.
    for (const Neighbor& n : neighbors) {
      const uint8_t* m = map_->descriptor(n.index);
      __builtin_prefetch(m);
      __builtin_prefetch(m + bytes - 1);
    }
    per_keypoint.clear();
    for (const Neighbor& n : neighbors) {
      const int h = HammingDistance(d, map_->descriptor(n.index), bytes);
      if (h > options_.matching.max_hamming_distance) continue;
      const uint32_t l = map_->descriptor_landmark[n.index];
      auto it = std::find_if(per_keypoint.begin(), per_keypoint.end(),
                             [&](const Match2D3D& m) { return m.landmark == l; });
      if (it == per_keypoint.end()) {
        per_keypoint.push_back({static_cast<int>(i), l, h});
      } else {
        it->hamming = std::min(it->hamming, h);
      }
    }
    std::sort(per_keypoint.begin(), per_keypoint.end(), [](const Match2D3D& a, const Match2D3D& b) {
      return a.hamming < b.hamming || (a.hamming == b.hamming && a.landmark < b.landmark);
    });
    const std::size_t keep =
        std::min<std::size_t>(per_keypoint.size(), options_.matching.max_landmarks_per_keypoint);
    matches.insert(matches.end(), per_keypoint.begin(), per_keypoint.begin() + keep);
  }
  if (num_raw_matches) *num_raw_matches = static_cast<int>(matches.size());
  if (!options_.matching.covisibility_filter) return matches;
  std::vector<Match2D3D> filtered;
  for (int i : LargestCovisibleComponent(*map_, matches)) filtered.push_back(matches[i]);
  return filtered;
}

LocalizationResult Localizer::Localize(const Camera& camera, const Transformation& T_I_C,
                                       const std::vector<Eigen::Vector2d>& keypoints,
                                       const uint8_t* descriptors) const {
  LocalizationResult result;
  if (keypoints.empty()) {
    result.status = LocalizationStatus::kNoKeypoints;
    return result;
  }
  auto t0 = std::chrono::steady_clock::now();
  double c0 = ThreadCpuMs();
  result.matches = Match(keypoints, descriptors, &result.num_raw_matches);
  result.match_ms = MsSince(t0);
  result.match_cpu_ms = ThreadCpuMs() - c0;
  if (result.num_raw_matches == 0) {
    result.status = LocalizationStatus::kNoDescriptorMatches;
    return result;
  }
  if (static_cast<int>(result.matches.size()) < options_.matching.min_matches) {
    result.status = LocalizationStatus::kTooFewMatches;
    return result;
  }
  t0 = std::chrono::steady_clock::now();
  c0 = ThreadCpuMs();
  std::vector<Eigen::Vector2d> uv;
  std::vector<Eigen::Vector3d> p_G;
  uv.reserve(result.matches.size());
  p_G.reserve(result.matches.size());
  // The matched landmarks' covariances when the map has them and the gates use them.
  std::vector<Eigen::Matrix3d> p_G_covariance;
  const bool with_covariance =
      options_.acceptance.landmark_uncertainty && !map_->p_G_covariance.empty();
  for (const Match2D3D& m : result.matches) {
    uv.push_back(keypoints[m.keypoint]);
    p_G.push_back(map_->p_G[m.landmark]);
    if (with_covariance) p_G_covariance.push_back(map_->p_G_covariance[m.landmark].cast<double>());
  }
  const PoseResult pose = EstimateCameraPose(camera, uv, p_G, options_.ransac);
  result.ransac_iterations = pose.ransac_iterations;
  if (pose.status == PoseStatus::kRansacFailed || pose.status == PoseStatus::kTooFewMatches) {
    result.status = pose.status == PoseStatus::kRansacFailed ? LocalizationStatus::kRansacFailed
                                                             : LocalizationStatus::kTooFewMatches;
    result.pose_ms = MsSince(t0);
    result.pose_cpu_ms = ThreadCpuMs() - c0;
    return result;
  }
  // A model: refined with all its inliers and gated (pose_acceptance.h). The pose and its
  // measurements are kept in the result also when a gate rejects it, for diagnosis.
  const AcceptedPose accepted =
      AcceptPose(camera, uv, p_G, pose, options_.ransac, options_.acceptance, p_G_covariance);
  result.pose_ms = MsSince(t0);
  result.pose_cpu_ms = ThreadCpuMs() - c0;
  switch (accepted.verdict) {
    case PoseVerdict::kAccepted: result.status = LocalizationStatus::kOk; break;
    case PoseVerdict::kTooFewInliers: result.status = LocalizationStatus::kTooFewInliers; break;
    case PoseVerdict::kLowInlierRatio: result.status = LocalizationStatus::kLowInlierRatio; break;
    case PoseVerdict::kHighReprojectionError:
      result.status = LocalizationStatus::kHighReprojectionError;
      break;
    case PoseVerdict::kClusteredInliers:
      result.status = LocalizationStatus::kClusteredInliers;
      break;
    case PoseVerdict::kUncertainPose: result.status = LocalizationStatus::kUncertainPose; break;
    case PoseVerdict::kAmbiguousPose: result.status = LocalizationStatus::kAmbiguousPose; break;
  }
  result.T_G_C = accepted.T_G_C;
  // T_G_I = T_G_C T_C_I; T_G_C Exp(xi_C) T_C_I = T_G_I Exp(Ad_{T_I_C} xi_C).
  result.T_G_I = accepted.T_G_C * T_I_C.inverse();
  const Matrix6d Ad = T_I_C.Adjoint();
  result.covariance_I = Ad * accepted.covariance_C * Ad.transpose();
  result.inliers = accepted.inliers;
  result.rms_reprojection_px = accepted.rms_reprojection_px;
  result.quality = accepted.quality;
  return result;
}

}  // namespace vilma::localizer

#include "vilma/eval/localization/kitti_scenarios.h"

#include <algorithm>
#include <memory>
#include <opencv2/imgcodecs.hpp>

#include "vilma/core/error.h"
#include "vilma/mapping/locmap/localization_map_builder.h"

namespace vilma::eval {

using namespace localizer;  // the harness is written in the localizer's types
namespace {

std::vector<int> Frames(int frames, int begin, int end, int step, int offset_mod = 0,
                        std::vector<int> residues = {}) {
  std::vector<int> out;
  for (int k = std::max(0, begin); k < std::min(frames, end); k += step) {
    if (!residues.empty() &&
        std::find(residues.begin(), residues.end(), k % offset_mod) == residues.end()) {
      continue;
    }
    out.push_back(k);
  }
  return out;
}

// Copies landmark l of `in` (its descriptors, observers and covariance, when the map has
// covariances) to the end of `out`, moved by shift.
void AppendLandmark(const LocalizationMap& in, std::size_t l, const Eigen::Vector3d& shift,
                    const std::vector<std::vector<std::size_t>>& descriptors_of,
                    LocalizationMap* out) {
  const uint32_t nl = static_cast<uint32_t>(out->p_G.size());
  out->landmark_ids.push_back(in.landmark_ids[l]);
  out->p_G.push_back(in.p_G[l] + shift);
  if (!in.p_G_covariance.empty()) out->p_G_covariance.push_back(in.p_G_covariance[l]);
  for (uint32_t k = in.observer_begin[l]; k < in.observer_begin[l + 1]; ++k) {
    out->observer_index.push_back(in.observer_index[k]);
  }
  out->observer_begin.push_back(static_cast<uint32_t>(out->observer_index.size()));
  for (std::size_t d : descriptors_of[l]) {
    out->descriptor_landmark.push_back(nl);
    out->descriptors.insert(out->descriptors.end(), in.descriptor(d),
                            in.descriptor(d) + in.descriptor_bytes);
  }
}

std::vector<std::vector<std::size_t>> DescriptorsOf(const LocalizationMap& map) {
  std::vector<std::vector<std::size_t>> of(map.num_landmarks());
  for (std::size_t d = 0; d < map.num_descriptors(); ++d) of[map.descriptor_landmark[d]].push_back(d);
  return of;
}

LocalizationMap EmptyLike(const LocalizationMap& map) {
  LocalizationMap out;
  out.descriptor_bytes = map.descriptor_bytes;
  out.observers = map.observers;
  out.observer_begin = {0};
  return out;
}

}  // namespace

std::vector<KittiScenario> KittiScenarios(int frames) {
  std::vector<KittiScenario> s;
  const std::vector<int> even = Frames(frames, 0, frames, 2);
  const std::vector<int> odd = Frames(frames, 1, frames, 2);
  auto add = [&](const std::string& name, const std::string& description) -> KittiScenario& {
    KittiScenario k;
    k.name = name;
    k.description = description;
    k.map_frames = even;
    k.query_frames = odd;
    s.push_back(k);
    return s.back();
  };
  add("even-odd", "map of the even frames, the odd frames as queries (the KITTI check)");
  {
    KittiScenario& k = add("sparse-map",
                           "map of every 8th frame, queries 3-5 frames (~4-6 m) from the nearest");
    k.map_frames = Frames(frames, 0, frames, 8);
    k.query_frames = Frames(frames, 0, frames, 1, 8, {3, 4, 5});
  }
  {
    KittiScenario& k = add("other-part",
                           "map of the first half's even frames, queries of the second half");
    k.map_frames = Frames(frames, 0, frames / 2, 2);
    k.query_frames = Frames(frames, frames / 2 + 2, frames, 2, 2, {1});
  }
  add("swapped-50", "even-odd with 50 % of the query descriptors swapped between keypoints")
      .perturbation.swap_fraction = 0.5;
  add("swapped-80", "even-odd with 80 % of the query descriptors swapped between keypoints")
      .perturbation.swap_fraction = 0.8;
  add("few-keypoints", "even-odd with the 100 best query keypoints only")
      .perturbation.max_keypoints = 100;
  {
    KittiScenario& k = add("corner", "even-odd with the query keypoints of the top-left "
                                     "30 % x 50 % of the image only");
    k.perturbation.box_max_x = 0.3;
    k.perturbation.box_max_y = 0.5;
  }
  add("far-landmarks", "even-odd map without the landmarks nearer than 15 m to a map camera")
      .min_landmark_distance_m = 15.0;
  add("repeated", "even-odd map plus a copy of every landmark 2.5 m to the side (same "
                  "descriptors and observers): two poses with equal support")
      .repeat_shift_W = Eigen::Vector3d(2.5, 0.0, 0.0);
  {
    KittiScenario& k = add("repeated-third", "even-odd map plus a copy of every third landmark "
                                             "2.5 m to the side: a rival pose with 1/3 support");
    k.repeat_shift_W = Eigen::Vector3d(2.5, 0.0, 0.0);
    k.repeat_every_nth = 3;
  }
  return s;
}

LocalizationMap KeepFarLandmarks(const LocalizationMap& map,
                                 const std::vector<Eigen::Vector3d>& camera_positions_G,
                                 double min_distance_m) {
  const std::vector<std::vector<std::size_t>> descriptors_of = DescriptorsOf(map);
  LocalizationMap out = EmptyLike(map);
  for (std::size_t l = 0; l < map.num_landmarks(); ++l) {
    bool far = true;
    for (const Eigen::Vector3d& c : camera_positions_G) {
      if ((map.p_G[l] - c).norm() < min_distance_m) {
        far = false;
        break;
      }
    }
    if (far) AppendLandmark(map, l, Eigen::Vector3d::Zero(), descriptors_of, &out);
  }
  return out;
}

LocalizationMap RepeatLandmarks(const LocalizationMap& map, const Eigen::Vector3d& shift_G,
                                int every_nth) {
  const std::vector<std::vector<std::size_t>> descriptors_of = DescriptorsOf(map);
  LocalizationMap out = EmptyLike(map);
  for (std::size_t l = 0; l < map.num_landmarks(); ++l) {
    AppendLandmark(map, l, Eigen::Vector3d::Zero(), descriptors_of, &out);
  }
  const std::size_t step = static_cast<std::size_t>(std::max(1, every_nth));
  for (std::size_t l = 0; l < map.num_landmarks(); l += step) {
    AppendLandmark(map, l, shift_G, descriptors_of, &out);
  }
  return out;
}

std::vector<AcceptanceQuery> RunKittiScenario(const KittiSequence& seq,
                                              const KittiLocalizationOptions& options,
                                              const KittiScenario& scenario,
                                              const AcceptanceGates& gates) {
  const mapstore::VIMap vimap = BuildKittiFrameMap(seq, options, scenario.map_frames);
  LocalizationMap map = mapping::BuildLocalizationMap(vimap, options.localizer.map);
  if (scenario.min_landmark_distance_m > 0.0) {
    std::vector<Eigen::Vector3d> cameras;
    for (int k : scenario.map_frames) cameras.push_back(seq.T_W_C[k].translation());
    map = KeepFarLandmarks(map, cameras, scenario.min_landmark_distance_m);
  }
  if (!scenario.repeat_shift_W.isZero()) {
    map = RepeatLandmarks(map, scenario.repeat_shift_W, scenario.repeat_every_nth);
  }
  const std::string error = map.Validate();
  if (!error.empty()) throw InputError(FormatInputError(scenario.name, "map", error));
  const Localizer localizer(std::make_shared<const LocalizationMap>(std::move(map)),
                            options.localizer);
  const FeatureExtractor extractor(options.features);
  std::vector<AcceptanceQuery> out;
  for (int k : scenario.query_frames) {
    if (k < 0 || static_cast<std::size_t>(k) >= seq.size()) {
      throw InputError(FormatInputError(scenario.name, "query frame " + std::to_string(k),
                                        "a frame of the slice"));
    }
    const cv::Mat image = cv::imread(seq.left_images[static_cast<std::size_t>(k)],
                                     cv::IMREAD_GRAYSCALE);
    if (image.empty()) {
      throw InputError(FormatInputError(seq.left_images[static_cast<std::size_t>(k)], "",
                                        "a readable 8-bit image"));
    }
    const KeyframeFeatures f = extractor.Extract(image);
    std::vector<Eigen::Vector2d> uv;
    for (const cv::KeyPoint& kp : f.keypoints) uv.emplace_back(kp.pt.x, kp.pt.y);
    std::vector<uint8_t> descriptors;
    if (f.size() > 0) {
      descriptors.assign(f.descriptors.ptr<uint8_t>(),
                         f.descriptors.ptr<uint8_t>() + f.descriptors.total());
    }
    QueryPerturbation perturbation = scenario.perturbation;
    perturbation.seed += static_cast<uint64_t>(k);
    PerturbQuery(perturbation, seq.camera, &uv, &descriptors, f.descriptors.cols);
    AcceptanceQuery q = EvaluateAcceptanceQuery(localizer, seq.camera, Transformation(), uv,
                                                descriptors, seq.T_W_C[static_cast<std::size_t>(k)],
                                                gates);
    q.frame = k;
    out.push_back(q);
  }
  return out;
}

}  // namespace vilma::eval

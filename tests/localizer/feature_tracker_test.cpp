#include "vilma/localizer/feature_tracker.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <map>
#include <numeric>
#include <opencv2/core/utility.hpp>
#include <string>

#include "localizer/synthetic_texture.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/geometry.h"
#include "vilma/core/rig.h"
#include "core/test_data.h"
#include "test_skip.h"

namespace vilma::localizer {
namespace {

Eigen::Vector2d Pt(const cv::KeyPoint& kp) { return Eigen::Vector2d(kp.pt.x, kp.pt.y); }

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}
double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

struct RotationTrackingStats {
  int trackable = 0;      // previous keypoints re-detected within 1.5 px of their true position
  int correct = 0;        // of those, tracked to that keypoint
  int matches = 0;        // all accepted matches
  int imprecise = 0;      // accepted matches 1.5..3 px from the true position
  int wrong = 0;          // accepted matches more than 3 px from it (another image point)
  int inside = 0;         // previous keypoints whose true position is inside the current image
};

// Tracks `image` -> its warp by R_Ck_Ckm1; `q_given` is the rotation handed to the tracker.
RotationTrackingStats TrackRotation(const KeyframeFeatureOptions& o, const cv::Mat& image,
                                    const Eigen::Matrix3d& R_Ck_Ckm1,
                                    const Eigen::Quaterniond& q_given) {
  const Camera camera = test::PinholeCamera(image.cols, image.rows);
  const cv::Mat warped = test::WarpByRotation(image, camera, R_Ck_Ckm1);
  const cv::Mat H = test::RotationHomography(camera, R_Ck_Ckm1);
  FeatureTracker tracker(o);
  const TrackingResult first = tracker.Track(image, camera, Eigen::Quaterniond::Identity());
  CHECK(first.num_new == first.features.size());
  CHECK(first.num_matched == 0);
  const TrackingResult second = tracker.Track(warped, camera, q_given);
  RotationTrackingStats s;
  std::vector<int> match_of_prev(static_cast<std::size_t>(first.features.size()), -1);
  for (const FeatureMatch& m : second.matches) {
    match_of_prev[static_cast<std::size_t>(m.prev_index)] = m.cur_index;
    ++s.matches;
    const Eigen::Vector2d truth =
        test::ApplyHomography(H, Pt(first.features.keypoints[static_cast<std::size_t>(m.prev_index)]));
    const double error =
        (Pt(second.features.keypoints[static_cast<std::size_t>(m.cur_index)]) - truth).norm();
    if (error > 3.0) {
      ++s.wrong;
    } else if (error > 1.5) {
      ++s.imprecise;
    }
    CHECK(second.track_ids[static_cast<std::size_t>(m.cur_index)] ==
          first.track_ids[static_cast<std::size_t>(m.prev_index)]);
  }
  for (int i = 0; i < first.features.size(); ++i) {
    const Eigen::Vector2d truth =
        test::ApplyHomography(H, Pt(first.features.keypoints[static_cast<std::size_t>(i)]));
    if (!camera.IsInImage(truth, o.detector.border_px)) continue;
    ++s.inside;
    bool redetected = false;
    for (const cv::KeyPoint& kp : second.features.keypoints) {
      if ((Pt(kp) - truth).norm() < 1.5) redetected = true;
    }
    if (!redetected) continue;
    ++s.trackable;
    const int j = match_of_prev[static_cast<std::size_t>(i)];
    if (j >= 0 && (Pt(second.features.keypoints[static_cast<std::size_t>(j)]) - truth).norm() < 1.5) {
      ++s.correct;
    }
  }
  return s;
}

TEST_CASE("FeatureTracker follows a pure rotation with the gyro-predicted window",
          "[features]") {
  const cv::Mat image = test::TexturedImage(752, 480, 21);
  KeyframeFeatureOptions o;
  o.detector.type = GENERATE(std::string("orb"), std::string("fast"));
  o.matcher.window_radius_px = 15.0;
  // Yaw that shifts the image centre by 40 px, plus some pitch and roll.
  const double yaw = std::atan(40.0 / 458.0);
  const Eigen::Matrix3d R_Ck_Ckm1 =
      ExpSO3(Eigen::Vector3d(0.01, yaw, 0.02)).toRotationMatrix();
  const RotationTrackingStats s =
      TrackRotation(o, image, R_Ck_Ckm1, Eigen::Quaterniond(R_Ck_Ckm1));
  INFO(o.detector.type << ": inside " << s.inside << ", re-detected " << s.trackable
                       << ", tracked correctly " << s.correct << ", matches " << s.matches
                       << ", imprecise (1.5..3 px) " << s.imprecise << ", wrong " << s.wrong);
  CHECK(s.trackable >= s.inside / 2);
  CHECK(s.correct >= 0.8 * s.trackable);
  CHECK(s.imprecise <= 0.05 * s.matches);  // integer-pixel corners of a resampled image
  CHECK(s.wrong <= 0.01 * s.matches);

  // Without the rotation (identity handed to the tracker) the 15 px window misses the 40 px
  // shift: the prediction is what makes the tracking work.
  const RotationTrackingStats blind =
      TrackRotation(o, image, R_Ck_Ckm1, Eigen::Quaterniond::Identity());
  INFO("without prediction: tracked correctly " << blind.correct << " of " << blind.trackable);
  CHECK(blind.correct < 0.1 * blind.trackable);
}

TEST_CASE("FeatureTracker assigns deterministic track ids from its counter", "[features]") {
  const cv::Mat image = test::TexturedImage(752, 480, 22);
  const Camera camera = test::PinholeCamera();
  const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(0.0, 0.03, 0.0)).toRotationMatrix();
  const cv::Mat warped = test::WarpByRotation(image, camera, R);
  const KeyframeFeatureOptions o;
  std::vector<std::vector<int64_t>> ids(2);
  for (int run = 0; run < 2; ++run) {
    FeatureTracker tracker(o, 1000);
    const TrackingResult a = tracker.Track(image, camera, Eigen::Quaterniond::Identity());
    for (int i = 0; i < a.features.size(); ++i) CHECK(a.track_ids[static_cast<std::size_t>(i)] == 1000 + i);
    const TrackingResult b = tracker.Track(warped, camera, Eigen::Quaterniond(R));
    CHECK(b.num_matched + b.num_new == b.features.size());
    CHECK(b.num_candidates == b.num_matched + b.num_rejected_ransac);
    CHECK(tracker.next_track_id() == 1000 + a.features.size() + b.num_new);
    ids[static_cast<std::size_t>(run)] = b.track_ids;
    // New ids are unique and above every continued one.
    std::vector<int64_t> sorted = b.track_ids;
    std::sort(sorted.begin(), sorted.end());
    CHECK(std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end());
    tracker.Reset();
    const TrackingResult c = tracker.Track(warped, camera, Eigen::Quaterniond::Identity());
    CHECK(c.num_matched == 0);
    CHECK(c.track_ids.front() == 1000 + a.features.size() + b.num_new);
  }
  CHECK(ids[0] == ids[1]);
}

// ---------------------------------------------------------------------------------------
// Simulated sequence with ground truth.

struct Pose {
  Eigen::Quaterniond q_W_C;
  Eigen::Vector3d p_W_C;
};

TEST_CASE("FeatureTracker on the simulated room: tracks agree with the ground-truth poses",
          "[features]") {
  const std::string root = vilma::testing::SimulatedDatasetsDir() + "/room-easy";
  AslDataset dataset;
  SensorRig rig;
  try {
    dataset = AslDataset::Open(root);
    rig = LoadSensorRig(root + "/rig.yaml");
  } catch (const std::exception& e) {
    if (std::filesystem::exists(root)) FAIL(root << ": " << e.what());
    VILMA_SKIP_OPTIONAL("simulated dataset " << root
                                             << " absent (scripts/make-datasets.sh makes it)");
  }
  REQUIRE(!dataset.ground_truth().empty());
  const Camera& camera = rig.cameras[0].camera;
  const Transformation& T_I_C = rig.cameras[0].T_I_C;
  std::map<int64_t, const GroundTruthState*> gt;
  for (const GroundTruthState& s : dataset.ground_truth()) gt[s.t_ns] = &s;
  auto pose_at = [&](int64_t t_ns) {
    auto it = gt.lower_bound(t_ns);
    REQUIRE(it != gt.end());
    REQUIRE(std::abs(it->first - t_ns) < 1000000);  // GT on the camera stamps (< 1 ms)
    const Transformation T_W_I(it->second->q_W_I, it->second->p_W_I);
    const Transformation T_W_C = T_W_I * T_I_C;
    return Pose{T_W_C.rotation(), T_W_C.translation()};
  };

  // Keyframes at 10 Hz (every second 20 Hz frame), 30 s.
  const auto& frames = dataset.cameras()[0].frames;
  const int num_keyframes = std::min<int>(300, static_cast<int>(frames.size()) / 2);
  const KeyframeFeatureOptions o;
  FeatureTracker tracker(o);
  struct Observation {
    int keyframe;
    Eigen::Vector2d keypoint;
  };
  std::map<int64_t, std::vector<Observation>> tracks;
  std::vector<Pose> poses;
  std::vector<double> tracked_fraction, inlier_ratio;
  Pose previous{Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()};
  for (int k = 0; k < num_keyframes; ++k) {
    const CameraFrame& frame = frames[static_cast<std::size_t>(2 * k)];
    const Pose pose = pose_at(frame.t_ns);
    const Eigen::Quaterniond q_Ck_Ckm1 =
        k == 0 ? Eigen::Quaterniond::Identity() : pose.q_W_C.conjugate() * previous.q_W_C;
    const TrackingResult r =
        tracker.Track(AslDataset::LoadImage(frame.image_path), camera, q_Ck_Ckm1);
    if (k > 0 && r.num_previous > 0) {
      tracked_fraction.push_back(static_cast<double>(r.num_matched) / r.num_previous);
      if (r.num_candidates > 0) {
        inlier_ratio.push_back(static_cast<double>(r.num_matched) / r.num_candidates);
      }
    }
    for (int j = 0; j < r.features.size(); ++j) {
      tracks[r.track_ids[static_cast<std::size_t>(j)]].push_back(
          {k, Pt(r.features.keypoints[static_cast<std::size_t>(j)])});
    }
    poses.push_back(pose);
    previous = pose;
  }

  // Track lengths (keyframes observed) of tracks seen at least twice.
  std::vector<double> lengths;
  for (const auto& t : tracks) {
    if (t.second.size() >= 2) lengths.push_back(static_cast<double>(t.second.size()));
  }

  // Triangulate each track of >= 3 observations with the ground-truth poses (linear
  // intersection of the rays, then Gauss-Newton on the reprojection error) and measure the
  // reprojection error of every observation.
  std::vector<double> errors;
  int triangulated = 0, bad_tracks = 0;
  for (const auto& t : tracks) {
    const auto& obs = t.second;
    if (obs.size() < 3) continue;
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> rays;
    for (const Observation& ob : obs) {
      Eigen::Vector3d f_C;
      REQUIRE(camera.Unproject(ob.keypoint, &f_C));
      const Pose& P = poses[static_cast<std::size_t>(ob.keyframe)];
      const Eigen::Vector3d f_W = P.q_W_C * f_C;
      const Eigen::Matrix3d M = Eigen::Matrix3d::Identity() - f_W * f_W.transpose();
      A += M;
      b += M * P.p_W_C;
      rays.push_back(f_W);
    }
    double max_angle = 0.0;
    for (const auto& r : rays) max_angle = std::max(max_angle, std::acos(std::min(1.0, r.dot(rays[0]))));
    if (max_angle < 2.0 * M_PI / 180.0) continue;  // too little parallax to check
    Eigen::Vector3d p_W = A.ldlt().solve(b);
    for (int it = 0; it < 5; ++it) {
      Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
      Eigen::Vector3d Jtr = Eigen::Vector3d::Zero();
      for (const Observation& ob : obs) {
        const Pose& P = poses[static_cast<std::size_t>(ob.keyframe)];
        const Eigen::Matrix3d R_C_W = P.q_W_C.conjugate().toRotationMatrix();
        Eigen::Vector2d kp;
        Eigen::Matrix<double, 2, 3> J;
        if (camera.Project(R_C_W * (p_W - P.p_W_C), &kp, &J) ==
            Camera::ProjectionResult::kBehindCamera) {
          continue;
        }
        const Eigen::Matrix<double, 2, 3> J_W = J * R_C_W;
        JtJ += J_W.transpose() * J_W;
        Jtr += J_W.transpose() * (kp - ob.keypoint);
      }
      p_W -= JtJ.ldlt().solve(Jtr);
    }
    ++triangulated;
    double worst = 0.0;
    for (const Observation& ob : obs) {
      const Pose& P = poses[static_cast<std::size_t>(ob.keyframe)];
      Eigen::Vector2d kp;
      const auto res = camera.Project(P.q_W_C.conjugate() * (p_W - P.p_W_C), &kp);
      const double e = res == Camera::ProjectionResult::kBehindCamera
                           ? 1e3
                           : (kp - ob.keypoint).norm();
      errors.push_back(e);
      worst = std::max(worst, e);
    }
    if (worst > 5.0) ++bad_tracks;
  }

  const double mean_tracked =
      std::accumulate(tracked_fraction.begin(), tracked_fraction.end(), 0.0) /
      std::max<std::size_t>(1, tracked_fraction.size());
  const double mean_inlier = std::accumulate(inlier_ratio.begin(), inlier_ratio.end(), 0.0) /
                             std::max<std::size_t>(1, inlier_ratio.size());
  WARN("room-easy, " << num_keyframes << " keyframes at 10 Hz: tracked fraction mean "
                     << mean_tracked << " (min " << Percentile(tracked_fraction, 0.0)
                     << "), RANSAC inlier ratio mean " << mean_inlier << ", track length median "
                     << Median(lengths) << " mean "
                     << std::accumulate(lengths.begin(), lengths.end(), 0.0) / std::max<std::size_t>(1, lengths.size())
                     << " p90 " << Percentile(lengths, 0.9) << "; " << triangulated
                     << " tracks triangulated, reprojection error median " << Median(errors)
                     << " px, p90 " << Percentile(errors, 0.9) << " px, tracks with an error > 5 px: "
                     << bad_tracks);
  CHECK(mean_tracked >= 0.5);
  CHECK(Percentile(tracked_fraction, 0.0) >= 0.2);
  CHECK(mean_inlier >= 0.9);
  CHECK(Median(lengths) >= 3.0);
  REQUIRE(triangulated >= 1000);
  CHECK(Median(errors) < 1.0);
  CHECK(bad_tracks <= 0.05 * triangulated);
}

// ---------------------------------------------------------------------------------------
// Real EuRoC slice: static camera.

bool OpenEuroc(AslDataset* dataset, Camera* camera) {
  const std::string root = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_micro";
  try {
    *dataset = AslDataset::Open(root);
    *camera = ImportEurocRig(root).cameras[0].camera;
  } catch (const std::exception& e) {
    VILMA_SKIP_NOTE("EuRoC slice not found under " VILMA_SHARED_DATA_DIR " (" << e.what() << ")");
    return false;
  }
  return !dataset->cameras().empty();
}

TEST_CASE("FeatureTracker on the static EuRoC slice: tracks persist with near-zero motion",
          "[features]") {
  AslDataset dataset;
  Camera camera;
  if (!OpenEuroc(&dataset, &camera)) return;
  const auto& frames = dataset.cameras()[0].frames;
  FeatureTracker tracker{KeyframeFeatureOptions()};
  const int n = std::min<int>(40, static_cast<int>(frames.size()));
  std::vector<TrackingResult> results;
  std::vector<double> tracked, redetected_tracked, motion;
  int rotation_only = 0, rejected = 0, candidates = 0;
  for (int k = 0; k < n; ++k) {
    results.push_back(tracker.Track(
        AslDataset::LoadImage(frames[static_cast<std::size_t>(k)].image_path), camera,
        Eigen::Quaterniond::Identity()));
    const TrackingResult& r = results.back();
    if (k == 0) continue;
    const TrackingResult& p = results[results.size() - 2];
    tracked.push_back(static_cast<double>(r.num_matched) / r.num_previous);
    rotation_only += r.rotation_only ? 1 : 0;
    rejected += r.num_rejected_ransac;
    candidates += r.num_candidates;
    // Tracking vs detection: of the previous keypoints that the detector found again (within
    // 1 px), how many were tracked?
    std::vector<int> match_of_prev(static_cast<std::size_t>(p.features.size()), -1);
    for (const FeatureMatch& m : r.matches) {
      match_of_prev[static_cast<std::size_t>(m.prev_index)] = m.cur_index;
      motion.push_back((Pt(r.features.keypoints[static_cast<std::size_t>(m.cur_index)]) -
                        Pt(p.features.keypoints[static_cast<std::size_t>(m.prev_index)]))
                           .norm());
    }
    int again = 0, again_tracked = 0;
    for (int i = 0; i < p.features.size(); ++i) {
      const Eigen::Vector2d x = Pt(p.features.keypoints[static_cast<std::size_t>(i)]);
      bool found = false;
      for (const cv::KeyPoint& kp : r.features.keypoints) found = found || (Pt(kp) - x).norm() < 1.0;
      if (!found) continue;
      ++again;
      again_tracked += match_of_prev[static_cast<std::size_t>(i)] >= 0 ? 1 : 0;
    }
    redetected_tracked.push_back(static_cast<double>(again_tracked) / again);
  }
  // Persistence: how many frame-0 tracks are alive after 1, 5, 10, 39 frames.
  auto alive_after = [&](int k) {
    const std::vector<int64_t>& first = results[0].track_ids;
    int alive = 0;
    for (int64_t id : results[static_cast<std::size_t>(k)].track_ids) {
      alive += std::binary_search(first.begin(), first.end(), id) ? 1 : 0;  // ids ascend
    }
    return static_cast<double>(alive) / static_cast<double>(first.size());
  };
  std::map<int64_t, int> length;
  for (const TrackingResult& r : results) {
    for (int64_t id : r.track_ids) ++length[id];
  }
  std::vector<double> lengths;
  for (const auto& l : length) lengths.push_back(l.second);
  int displaced = 0;
  for (double m : motion) displaced += m > 3.0 ? 1 : 0;
  WARN("EuRoC static, " << n << " frames: tracked fraction per frame median " << Median(tracked)
                        << " min " << Percentile(tracked, 0.0)
                        << "; of the re-detected keypoints tracked: median "
                        << Median(redetected_tracked) << " min "
                        << Percentile(redetected_tracked, 0.0)
                        << "; frame-0 tracks alive after 1/5/10/" << n - 1 << " frames: "
                        << alive_after(1) << " / " << alive_after(5) << " / " << alive_after(10)
                        << " / " << alive_after(n - 1) << "; track length mean "
                        << std::accumulate(lengths.begin(), lengths.end(), 0.0) /
                               static_cast<double>(lengths.size())
                        << " p90 " << Percentile(lengths, 0.9) << "; match displacement median "
                        << Median(motion) << " px, " << displaced << " of " << motion.size()
                        << " above 3 px; RANSAC rejected " << rejected << " of " << candidates
                        << ", rotation-only model in " << rotation_only << " of " << n - 1
                        << " frames");
  CHECK(Median(tracked) >= 0.7);
  // The tracker keeps what the detector finds again; losses are the detector's (a keypoint
  // not re-detected under image noise), which is why tracks still end in a static scene.
  CHECK(Median(redetected_tracked) >= 0.95);
  CHECK(Percentile(redetected_tracked, 0.0) >= 0.85);
  CHECK(alive_after(1) >= 0.7);
  CHECK(alive_after(10) >= 0.2);
  CHECK(Median(motion) < 0.5);
  // Nothing moves: a match displaced by more than 3 px is wrong, and the epipolar check can
  // only miss the rare wrong match that lies on its epipolar plane.
  CHECK(displaced <= 0.001 * static_cast<double>(motion.size()));
  // RANSAC removes few candidates here (descriptor mismatches, keypoints that jitter by more
  // than the threshold): the rotation-only model explains a static scene.
  CHECK(rejected <= 0.05 * candidates);
}

TEST_CASE("FeatureTracker: RANSAC rejects injected wrong matches (swapped descriptors)",
          "[features]") {
  AslDataset dataset;
  Camera camera;
  if (!OpenEuroc(&dataset, &camera)) return;
  const auto& frames = dataset.cameras()[0].frames;
  const cv::Mat image0 = AslDataset::LoadImage(frames[0].image_path);
  const cv::Mat image1 = AslDataset::LoadImage(frames[1].image_path);
  KeyframeFeatureOptions o;
  const FeatureExtractor extractor(o);
  const KeyframeFeatures f0 = extractor.Extract(image0);
  const KeyframeFeatures f1 = extractor.Extract(image1);

  // Clean run: which current keypoints are matched.
  FeatureTracker clean(o);
  clean.TrackFeatures(f0, camera, Eigen::Quaterniond::Identity());
  const TrackingResult clean_result =
      clean.TrackFeatures(f1, camera, Eigen::Quaterniond::Identity());
  std::vector<char> matched(static_cast<std::size_t>(f1.size()), 0);
  for (const FeatureMatch& m : clean_result.matches) matched[static_cast<std::size_t>(m.cur_index)] = 1;

  // Swap the descriptors of 25 disjoint pairs of matched keypoints 5..20 px apart: each pair
  // makes two wrong matches that pass the descriptor checks (the window holds both).
  KeyframeFeatures swapped = f1;
  swapped.descriptors = f1.descriptors.clone();
  std::vector<char> used(static_cast<std::size_t>(f1.size()), 0);
  int pairs = 0;
  for (int j = 0; j < f1.size() && pairs < 25; ++j) {
    if (!matched[static_cast<std::size_t>(j)] || used[static_cast<std::size_t>(j)]) continue;
    for (int k = j + 1; k < f1.size(); ++k) {
      if (!matched[static_cast<std::size_t>(k)] || used[static_cast<std::size_t>(k)]) continue;
      const double d = (Pt(f1.keypoints[static_cast<std::size_t>(j)]) -
                        Pt(f1.keypoints[static_cast<std::size_t>(k)])).norm();
      if (d < 5.0 || d > 20.0) continue;
      cv::Mat row_j = swapped.descriptors.row(j).clone();
      swapped.descriptors.row(k).copyTo(swapped.descriptors.row(j));
      row_j.copyTo(swapped.descriptors.row(k));
      used[static_cast<std::size_t>(j)] = used[static_cast<std::size_t>(k)] = 1;
      ++pairs;
      break;
    }
  }
  REQUIRE(pairs == 25);

  auto count_wrong = [&](const std::string& method, TrackingResult* out) {
    KeyframeFeatureOptions options = o;
    options.ransac.method = method;
    FeatureTracker tracker(options);
    tracker.TrackFeatures(f0, camera, Eigen::Quaterniond::Identity());
    *out = tracker.TrackFeatures(swapped, camera, Eigen::Quaterniond::Identity());
    int wrong = 0;
    for (const FeatureMatch& m : out->matches) {
      if ((Pt(swapped.keypoints[static_cast<std::size_t>(m.cur_index)]) -
           Pt(f0.keypoints[static_cast<std::size_t>(m.prev_index)])).norm() > 3.0) {
        ++wrong;
      }
    }
    return wrong;
  };
  TrackingResult without, with;
  const int wrong_without = count_wrong("none", &without);
  const int wrong_with = count_wrong("two_point", &with);
  const int injected = 2 * pairs;
  WARN("EuRoC, " << injected << " wrong matches injected: accepted without RANSAC "
                 << wrong_without << ", with RANSAC " << wrong_with << "; RANSAC rejected "
                 << with.num_rejected_ransac << " of " << with.num_candidates
                 << ", clean run rejected " << clean_result.num_rejected_ransac);
  CHECK(wrong_without >= 0.8 * injected);  // the descriptor checks let them through
  CHECK(wrong_with <= 0.1 * injected);
  CHECK(with.num_rejected_ransac >= wrong_without - wrong_with);
  // Correct matches survive: the accepted count drops by about the injected ones only.
  CHECK(with.num_matched >= clean_result.num_matched - injected - 5);
}

// ---------------------------------------------------------------------------------------
// Timing (hidden): one core, 752x480.

TEST_CASE("FeatureTracker timing per keyframe", "[.][features][benchmark]") {
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);  // the daemon runs the keyframe features on one thread
  auto run = [](const std::string& name, const std::vector<cv::Mat>& images,
                const Camera& camera, const std::vector<Eigen::Quaterniond>& rotations,
                const std::string& detector) {
    KeyframeFeatureOptions o;
    o.detector.type = detector;
    FeatureTracker tracker(o);
    std::vector<double> extract, match, total;
    std::vector<double> features;
    for (std::size_t k = 0; k < images.size(); ++k) {
      const TrackingResult r = tracker.Track(images[k], camera, rotations[k]);
      if (k == 0) continue;
      extract.push_back(r.extract_ms);
      match.push_back(r.match_ms);
      total.push_back(r.extract_ms + r.match_ms);
      features.push_back(r.features.size());
    }
    WARN(name << " (" << detector << "), " << total.size() << " keyframes, "
              << Median(features) << " keypoints: extraction p50 " << Median(extract)
              << " ms p99 " << Percentile(extract, 0.99) << " ms; tracking p50 " << Median(match)
              << " ms p99 " << Percentile(match, 0.99) << " ms; total p50 " << Median(total)
              << " ms p99 " << Percentile(total, 0.99) << " ms");
    CHECK(Median(total) <= 30.0);
  };
  // Simulated room (moving camera), 10 Hz keyframes.
  const std::string room = vilma::testing::SimulatedDatasetsDir() + "/room-easy";
  try {
    const AslDataset dataset = AslDataset::Open(room);
    const SensorRig rig = LoadSensorRig(room + "/rig.yaml");
    std::map<int64_t, Eigen::Quaterniond> q_W_I;
    for (const auto& s : dataset.ground_truth()) q_W_I[s.t_ns] = s.q_W_I;
    std::vector<cv::Mat> images;
    std::vector<Eigen::Quaterniond> rotations;
    Eigen::Quaterniond q_prev = Eigen::Quaterniond::Identity();
    const Eigen::Quaterniond q_I_C = rig.cameras[0].T_I_C.rotation();
    for (std::size_t k = 0; k < 200 && 2 * k < dataset.cameras()[0].frames.size(); ++k) {
      const CameraFrame& f = dataset.cameras()[0].frames[2 * k];
      const Eigen::Quaterniond q_W_C = q_W_I.lower_bound(f.t_ns)->second * q_I_C;
      rotations.push_back(k == 0 ? Eigen::Quaterniond::Identity() : q_W_C.conjugate() * q_prev);
      q_prev = q_W_C;
      images.push_back(AslDataset::LoadImage(f.image_path));
    }
    for (const char* d : {"orb", "fast"}) run("room-easy", images, rig.cameras[0].camera, rotations, d);
  } catch (const std::exception& e) {
    if (std::filesystem::exists(room)) FAIL(room << ": " << e.what());
    VILMA_SKIP_OPTIONAL_NOTE("the room-easy part: " << room
                                                    << " absent (scripts/make-datasets.sh makes it)");
  }
  AslDataset euroc;
  Camera camera;
  if (OpenEuroc(&euroc, &camera)) {
    std::vector<cv::Mat> images;
    for (const auto& f : euroc.cameras()[0].frames) images.push_back(AslDataset::LoadImage(f.image_path));
    const std::vector<Eigen::Quaterniond> rotations(images.size(), Eigen::Quaterniond::Identity());
    for (const char* d : {"orb", "fast"}) run("euroc_V1_01_micro", images, camera, rotations, d);
  }
  cv::setNumThreads(threads);
}

}  // namespace
}  // namespace vilma::localizer

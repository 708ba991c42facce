#include "vilma/eval/localization/kitti_localization.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/timing.h"
#include "vilma/eval/trajectory.h"
#include "vilma/localizer/descriptor_index.h"
#include "vilma/mapping/locmap/localization_map_builder.h"

namespace vilma::eval {

using namespace localizer;  // the harness is written in the localizer's types
namespace fs = std::filesystem;

namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<std::string> SortedPngs(const fs::path& dir) {
  std::vector<std::string> files;
  if (!fs::is_directory(dir)) {
    throw InputError(FormatInputError(dir.string(), "", "a folder of PNG images"));
  }
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    if (e.is_regular_file() && e.path().extension() == ".png") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// One calib.txt row "P0: 12 numbers" or (as in this slice) just 12 numbers.
bool ParseProjection(const std::string& line, Eigen::Matrix<double, 3, 4>* P) {
  std::istringstream in(line);
  std::string first;
  if (!(in >> first)) return false;
  std::vector<double> values;
  if (first.back() != ':') values.push_back(std::strtod(first.c_str(), nullptr));
  double v;
  while (in >> v) values.push_back(v);
  if (values.size() != 12) return false;
  for (int i = 0; i < 12; ++i) (*P)(i / 4, i % 4) = values[static_cast<std::size_t>(i)];
  return P->allFinite();
}

cv::Mat LoadGray(const std::string& path) {
  cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (image.empty()) throw InputError(FormatInputError(path, "", "a readable 8-bit image"));
  return image;
}

std::vector<Eigen::Vector2d> Pixels(const KeyframeFeatures& f) {
  std::vector<Eigen::Vector2d> uv;
  uv.reserve(f.keypoints.size());
  for (const cv::KeyPoint& k : f.keypoints) uv.emplace_back(k.pt.x, k.pt.y);
  return uv;
}

mapstore::VisualFrame ToVisualFrame(const KeyframeFeatures& f) {
  mapstore::VisualFrame frame;
  frame.descriptor_type = "BRISK";
  frame.descriptor_size_bytes = static_cast<uint32_t>(f.descriptors.cols);
  for (int i = 0; i < f.size(); ++i) {
    const cv::KeyPoint& k = f.keypoints[static_cast<std::size_t>(i)];
    mapstore::Keypoint kp;
    kp.uv = Eigen::Vector2d(k.pt.x, k.pt.y);
    kp.scale = k.size;
    kp.orientation = k.angle * M_PI / 180.0;
    kp.score = k.response;
    frame.keypoints.push_back(kp);
    const uint8_t* d = f.descriptors.ptr<uint8_t>(i);
    frame.descriptors.insert(frame.descriptors.end(), d, d + f.descriptors.cols);
  }
  frame.track_ids.assign(frame.keypoints.size(), -1);
  frame.landmark_ids.assign(frame.keypoints.size(), mapstore::LandmarkId());
  return frame;
}

// Covariance of a stereo point p_C of the left camera [m^2] as a triangulation gives it: the
// two rectified views (left at the origin, right at +b along x) under isotropic keypoint noise
// sigma, sigma^2 (J_L^T J_L + J_R^T J_R)^-1 with J = d pi / d p. Along the optical axis this
// is the disparity's sigma_Z = Z^2 sigma_d / (f b), sigma_d = sqrt(2) sigma: 3 m at Z = 30 m
// for KITTI (f = 718 px, b = 0.54 m, sigma = 1 px), 3 mm across. Zero if it does not project.
Eigen::Matrix3d StereoPointCovariance_C(const KittiSequence& seq, const Eigen::Vector3d& p_C,
                                        double sigma_px) {
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (const double x : {0.0, seq.baseline_m}) {
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J;
    if (seq.camera.Project(p_C - Eigen::Vector3d(x, 0.0, 0.0), &uv, &J) !=
        Camera::ProjectionResult::kValid) {
      return Eigen::Matrix3d::Zero();
    }
    H += J.transpose() * J;
  }
  return sigma_px * sigma_px * H.inverse();
}

}  // namespace

std::string StereoMatchOptions::Validate() const {
  if (!(std::isfinite(max_row_difference_px) && max_row_difference_px >= 0.0)) {
    return "max_row_difference_px: expected >= 0";
  }
  if (!(std::isfinite(min_disparity_px) && min_disparity_px > 0.0)) {
    return "min_disparity_px: expected > 0";
  }
  if (!(std::isfinite(max_disparity_px) && max_disparity_px > min_disparity_px)) {
    return "max_disparity_px: expected > min_disparity_px";
  }
  if (max_hamming_distance < 0 || max_hamming_distance > 512) {
    return "max_hamming_distance: expected 0..512";
  }
  if (!(std::isfinite(ratio) && ratio > 0.0 && ratio <= 1.0)) return "ratio: expected in (0, 1]";
  if (!(std::isfinite(max_depth_m) && max_depth_m > 0.0)) return "max_depth_m: expected > 0";
  return "";
}

KeyframeFeatureOptions KittiLocalizationOptions::KittiFeatureOptions() {
  KeyframeFeatureOptions o;
  o.detector.type = "orb";
  o.detector.fast_threshold = 12;
  o.detector.num_levels = 3;
  o.detector.scale_factor = 1.2;
  o.detector.grid_cols = 16;
  o.detector.grid_rows = 4;
  o.detector.max_per_cell = 40;
  o.detector.max_keypoints = 2000;
  o.detector.min_distance_px = 3.0;
  o.detector.border_px = 24;
  o.descriptor.keypoint_size_px = 12.0;
  o.descriptor.scale_with_level = true;
  return o;
}

std::string KittiLocalizationOptions::Validate() const {
  std::string e;
  if (!(e = features.Validate()).empty()) return "features." + e;
  if (!(e = stereo.Validate()).empty()) return "stereo." + e;
  if (!(e = localizer.Validate()).empty()) return "localizer." + e;
  if (!(std::isfinite(merge_radius_px) && merge_radius_px >= 0.0)) {
    return "merge_radius_px: expected >= 0";
  }
  if (!(std::isfinite(landmark_sigma_px) && landmark_sigma_px > 0.0)) {
    return "landmark_sigma_px: expected > 0";
  }
  if (merge_max_hamming_distance < 0 || merge_max_hamming_distance > 512) {
    return "merge_max_hamming_distance: expected 0..512";
  }
  if (!(e = disparity.Validate()).empty()) return "disparity." + e;
  if (!(std::isfinite(track_max_residual_px) && track_max_residual_px > 0.0)) {
    return "track_max_residual_px: expected > 0";
  }
  if (!(max_position_error_m > 0.0) || !(max_rotation_error_deg > 0.0)) {
    return "max_position_error_m, max_rotation_error_deg: expected > 0";
  }
  return "";
}

KittiSequence LoadKittiSequence(const std::string& directory) {
  const fs::path dir(directory);
  KittiSequence seq;
  const fs::path calib = dir / "calib.txt";
  std::ifstream in(calib);
  if (!in) throw InputError(FormatInputError(calib.string(), "", "a readable KITTI calib.txt"));
  std::vector<Eigen::Matrix<double, 3, 4>> P;
  std::string line;
  while (std::getline(in, line) && P.size() < 2) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    Eigen::Matrix<double, 3, 4> p;
    if (!ParseProjection(line, &p)) {
      throw InputError(FormatInputError(calib.string(), "P" + std::to_string(P.size()),
                                        "12 numbers of a 3x4 projection matrix"));
    }
    P.push_back(p);
  }
  if (P.size() < 2) {
    throw InputError(FormatInputError(calib.string(), "P1", "two projection rows (P0, P1)"));
  }
  const double fx = P[0](0, 0), fy = P[0](1, 1), cx = P[0](0, 2), cy = P[0](1, 2);
  seq.baseline_m = -P[1](0, 3) / P[1](0, 0);
  if (!(fx > 0.0 && fy > 0.0 && seq.baseline_m > 0.0)) {
    throw InputError(FormatInputError(calib.string(), "P0/P1",
                                      "positive focal lengths and a positive baseline"));
  }
  seq.left_images = SortedPngs(dir / "image_l");
  seq.right_images = SortedPngs(dir / "image_r");
  const Trajectory poses = ReadTrajectoryFile((dir / "poses.txt").string());
  seq.T_W_C = poses.T_W_B;
  if (seq.left_images.size() < seq.size() || seq.right_images.size() < seq.size() ||
      seq.size() < 2) {
    throw InputError(FormatInputError(
        directory, "image_l/image_r",
        "at least as many left and right images as poses (" + std::to_string(seq.size()) +
            "), and at least 2"));
  }
  seq.left_images.resize(seq.size());
  seq.right_images.resize(seq.size());
  const cv::Mat first = LoadGray(seq.left_images.front());
  seq.camera = Camera(first.cols, first.rows, Eigen::Vector4d(fx, fy, cx, cy),
                      DistortionModel::kNone, Eigen::VectorXd());
  const std::string error = seq.camera.Validate();
  if (!error.empty()) throw InputError(FormatInputError(calib.string(), "P0", error));
  return seq;
}

std::vector<StereoMatch> MatchStereo(const KeyframeFeatures& left, const KeyframeFeatures& right,
                                     const Camera& camera, double baseline_m,
                                     const StereoMatchOptions& options) {
  std::vector<StereoMatch> out;
  if (left.size() == 0 || right.size() == 0) return out;
  const int bytes = left.descriptors.cols;
  // Right keypoints bucketed by integer row, so a left keypoint visits only the rows within
  // max_row_difference_px.
  const int rows = camera.height() + 2;
  std::vector<std::vector<int>> by_row(static_cast<std::size_t>(rows));
  for (int j = 0; j < right.size(); ++j) {
    const int r = static_cast<int>(std::lround(right.keypoints[static_cast<std::size_t>(j)].pt.y));
    by_row[static_cast<std::size_t>(std::clamp(r, 0, rows - 1))].push_back(j);
  }
  const double fb = camera.fx() * baseline_m;
  for (int i = 0; i < left.size(); ++i) {
    const cv::Point2f& pl = left.keypoints[static_cast<std::size_t>(i)].pt;
    const int r0 = std::max(0, static_cast<int>(std::floor(pl.y - options.max_row_difference_px)));
    const int r1 =
        std::min(rows - 1, static_cast<int>(std::ceil(pl.y + options.max_row_difference_px)));
    int best = -1, best_h = 513, second_h = 513;
    for (int r = r0; r <= r1; ++r) {
      for (int j : by_row[static_cast<std::size_t>(r)]) {
        const cv::Point2f& pr = right.keypoints[static_cast<std::size_t>(j)].pt;
        if (std::abs(pr.y - pl.y) > options.max_row_difference_px) continue;
        const double d = pl.x - pr.x;
        if (d < options.min_disparity_px || d > options.max_disparity_px) continue;
        const int h = HammingDistance(left.descriptors.ptr<uint8_t>(i),
                                      right.descriptors.ptr<uint8_t>(j), bytes);
        if (h < best_h || (h == best_h && j < best)) {
          second_h = best_h;
          best_h = h;
          best = j;
        } else if (h < second_h) {
          second_h = h;
        }
      }
    }
    if (best < 0 || best_h > options.max_hamming_distance) continue;
    if (second_h <= 512 && !(best_h < options.ratio * second_h)) continue;
    // Rectified stereo (StereoPoint_C), with the row of the left keypoint (the right one
    // differs by at most max_row_difference_px).
    const double d = pl.x - right.keypoints[static_cast<std::size_t>(best)].pt.x;
    if (fb / d > options.max_depth_m) continue;
    StereoMatch m;
    m.left = i;
    m.right = best;
    m.hamming = best_h;
    m.disparity_px = d;
    m.p_C = StereoPoint_C(camera, baseline_m, Eigen::Vector2d(pl.x, pl.y), d);
    out.push_back(m);
  }
  return out;
}

mapstore::VIMap BuildKittiEvenFrameMap(const KittiSequence& seq,
                                       const KittiLocalizationOptions& options,
                                       KittiLocalizationReport* report) {
  std::vector<int> even;
  for (std::size_t k = 0; k < seq.size(); k += 2) even.push_back(static_cast<int>(k));
  return BuildKittiFrameMap(seq, options, even, report);
}

mapstore::VIMap BuildKittiFrameMap(const KittiSequence& seq, const KittiLocalizationOptions& options,
                                   const std::vector<int>& map_frames,
                                   KittiLocalizationReport* report) {
  for (int k : map_frames) {
    if (k < 0 || static_cast<std::size_t>(k) >= seq.size()) {
      throw InputError(FormatInputError("KITTI map frames", std::to_string(k),
                                        "a frame index below " + std::to_string(seq.size())));
    }
  }
  const std::string error = options.Validate();
  if (!error.empty()) throw InputError(FormatInputError("KittiLocalizationOptions", "", error));
  const FeatureExtractor extractor(options.features);
  mapstore::VIMap map;
  mapstore::IdGenerator mission_ids(2011);
  mapstore::Mission mission;
  mission.id = mission_ids.Next();
  mission.name = "kitti-even";
  mission.baseframe_known = true;  // T_G_M = identity: G = KITTI world
  mission.complete = true;
  map.AddMission(mission);
  mapstore::IdGenerator ids = mapstore::IdGenerator::ForMission(mission.id);

  // Landmarks of the previous even frame, for merging: id, p_W, the left descriptor of its
  // latest observation and its track (every stereo view of the landmark).
  struct Tracked {
    mapstore::LandmarkId id;
    Eigen::Vector3d p_W;
    const uint8_t* descriptor;
    std::size_t track;
  };
  struct Track {
    mapstore::LandmarkId id;
    std::vector<StereoObservation> views;
  };
  std::vector<Track> tracks;
  std::vector<Tracked> previous;
  KeyframeFeatures previous_left;  // owns the descriptors `previous` points into
  int frames = 0, landmarks = 0, merged = 0, refined = 0, unrefined = 0;
  for (const int frame : map_frames) {
    const std::size_t k = static_cast<std::size_t>(frame);
    const cv::Mat left_image = LoadGray(seq.left_images[k]);
    const cv::Mat right_image = LoadGray(seq.right_images[k]);
    const KeyframeFeatures left = extractor.Extract(left_image);
    const KeyframeFeatures right = extractor.Extract(right_image);
    std::vector<StereoMatch> stereo =
        MatchStereo(left, right, seq.camera, seq.baseline_m, options.stereo);
    // Disparity of each match: the keypoints' (whole pixels at the detector's level 0), or
    // refined by patch alignment at the left keypoint.
    if (options.refine_disparity) {
      for (StereoMatch& m : stereo) {
        const cv::Point2f& pl = left.keypoints[static_cast<std::size_t>(m.left)].pt;
        const Eigen::Vector2d uv_left(pl.x, pl.y);
        const DisparityRefinement r =
            RefineDisparity(left_image, right_image, uv_left, m.disparity_px, options.disparity);
        if (r.ok() && r.disparity_px >= options.stereo.min_disparity_px) {
          m.disparity_px = r.disparity_px;
          m.p_C = StereoPoint_C(seq.camera, seq.baseline_m, uv_left, r.disparity_px);
          ++refined;
        } else {
          ++unrefined;
        }
      }
    }
    const Transformation& T_W_C = seq.T_W_C[k];
    mapstore::Vertex v;
    v.id = ids.Next();
    v.mission_id = mission.id;
    v.t_ns = static_cast<int64_t>(k) * 100'000'000LL;  // KITTI: 10 Hz
    v.T_M_I = T_W_C;  // I = C0, M = G = W
    v.frames = {ToVisualFrame(left), ToVisualFrame(right)};
    const mapstore::VertexId vertex_id = v.id;
    map.AddVertex(std::move(v));
    ++frames;

    // Projections of the previous frame's landmarks into this left image (ground-truth pose).
    const Transformation T_C_W = T_W_C.inverse();
    std::vector<Eigen::Vector2d> projected(previous.size());
    std::vector<bool> visible(previous.size(), false);
    for (std::size_t p = 0; p < previous.size(); ++p) {
      visible[p] = seq.camera.Project(T_C_W * previous[p].p_W, &projected[p]) ==
                   Camera::ProjectionResult::kValid;
    }
    std::vector<bool> taken(previous.size(), false);
    std::vector<Tracked> current;
    const int bytes = left.descriptors.cols;
    for (const StereoMatch& m : stereo) {
      const cv::Point2f& pt = left.keypoints[static_cast<std::size_t>(m.left)].pt;
      const StereoObservation view{T_W_C, Eigen::Vector2d(pt.x, pt.y), m.disparity_px};
      const uint8_t* d = left.descriptors.ptr<uint8_t>(m.left);
      int best = -1, best_h = options.merge_max_hamming_distance + 1;
      for (std::size_t p = 0; p < previous.size(); ++p) {
        if (!visible[p] || taken[p]) continue;
        if ((projected[p] - Eigen::Vector2d(pt.x, pt.y)).norm() > options.merge_radius_px) continue;
        const int h = HammingDistance(d, previous[p].descriptor, bytes);
        if (h < best_h) {
          best_h = h;
          best = static_cast<int>(p);
        }
      }
      const Eigen::Vector3d p_W = T_W_C * m.p_C;
      mapstore::LandmarkId id;
      std::size_t track = tracks.size();
      if (best >= 0) {
        // Re-observed: keep the nearer (more precise: depth noise grows with Z^2) position
        // until the track is triangulated from all its views below.
        taken[static_cast<std::size_t>(best)] = true;
        id = previous[static_cast<std::size_t>(best)].id;
        track = previous[static_cast<std::size_t>(best)].track;
        tracks[track].views.push_back(view);
        const Eigen::Vector3d p_old = map.LandmarkPosition_M(id);
        if (m.p_C.z() < (T_C_W * p_old).z()) {
          map.SetLandmarkPosition_M(id, p_W);
          // Its covariance with it, in the store vertex's frame: R_Is_W R_W_C Sigma_C (...)^T.
          mapstore::Landmark& l = map.landmark(id);
          const Eigen::Matrix3d R_Is_C =
              (map.vertex(l.store_vertex_id).T_M_I.inverse() * T_W_C).rotation().toRotationMatrix();
          l.covariance = R_Is_C * StereoPointCovariance_C(seq, m.p_C, options.landmark_sigma_px) *
                         R_Is_C.transpose();
        }
        ++merged;
      } else {
        mapstore::Landmark l;
        l.id = ids.Next();
        l.store_vertex_id = vertex_id;
        l.p_I = m.p_C;
        l.covariance = StereoPointCovariance_C(seq, m.p_C, options.landmark_sigma_px);
        l.quality = mapstore::LandmarkQuality::kGood;
        id = l.id;
        map.AddLandmark(std::move(l));
        tracks.push_back({id, {view}});
        ++landmarks;
      }
      map.AddObservation(id, {vertex_id, 0, static_cast<uint32_t>(m.left)});
      map.AddObservation(id, {vertex_id, 1, static_cast<uint32_t>(m.right)});
      current.push_back({id, map.LandmarkPosition_M(id), d, track});
    }
    previous = std::move(current);
    previous_left = left;  // cv::Mat shares the buffer `previous` points into
  }
  // Landmarks seen by several map frames: the maximum-likelihood point of all stereo views
  // (M = W), its covariance in the store vertex's frame R_Is_W Sigma_W R_Is_W^T.
  int triangulated = 0, dropped = 0;
  if (options.triangulate_tracks) {
    StereoTrackOptions track_options;
    track_options.sigma_px = options.landmark_sigma_px;
    track_options.max_residual_px = options.track_max_residual_px;
    for (const Track& t : tracks) {
      if (t.views.size() < 2) continue;
      const StereoTrackPoint p =
          TriangulateStereoTrack(t.views, seq.camera, seq.baseline_m, track_options);
      if (!p.ok) continue;
      ++triangulated;
      dropped += static_cast<int>(t.views.size()) - p.views_used;
      map.SetLandmarkPosition_M(t.id, p.p_W);
      mapstore::Landmark& l = map.landmark(t.id);
      const Eigen::Matrix3d R_Is_W =
          map.vertex(l.store_vertex_id).T_M_I.inverse().rotation().toRotationMatrix();
      l.covariance = R_Is_W * p.covariance_W * R_Is_W.transpose();
    }
  }
  if (report != nullptr) {
    report->map_frames = frames;
    report->map_vertices_landmarks = landmarks;
    report->merged_observations = merged;
    report->refined_disparities = refined;
    report->unrefined_disparities = unrefined;
    report->triangulated_tracks = triangulated;
    report->dropped_track_views = dropped;
  }
  return map;
}

KittiLocalizationReport EvaluateKittiLocalization(const KittiSequence& seq,
                                                  const KittiLocalizationOptions& options) {
  KittiLocalizationReport report;
  auto t0 = std::chrono::steady_clock::now();
  const mapstore::VIMap vimap = BuildKittiEvenFrameMap(seq, options, &report);
  auto loc_map =
      std::make_shared<const LocalizationMap>(mapping::BuildLocalizationMap(vimap, options.localizer.map));
  report.map_build_ms = MsSince(t0);
  report.localization_landmarks = static_cast<int>(loc_map->num_landmarks());
  report.localization_descriptors = static_cast<int>(loc_map->num_descriptors());
  const Localizer localizer(loc_map, options.localizer);
  report.projection_train_ms = localizer.projection_train_ms();
  report.index_build_ms = localizer.index_build_ms();

  const FeatureExtractor extractor(options.features);
  std::vector<double> pos, rot, query_ms, extract_ms;
  int successes = 0;
  for (std::size_t k = 1; k < seq.size(); k += 2) {
    KittiQueryResult q;
    q.frame = static_cast<int>(k);
    const cv::Mat image = LoadGray(seq.left_images[k]);
    const auto te = std::chrono::steady_clock::now();
    const KeyframeFeatures f = extractor.Extract(image);
    q.extract_ms = MsSince(te);
    q.keypoints = f.size();
    const LocalizationResult r = localizer.Localize(seq.camera, Transformation(), Pixels(f),
                                                    f.descriptors.ptr<uint8_t>());
    report.stats.Add(r);
    q.status = r.status;
    q.raw_matches = r.num_raw_matches;
    q.matches = static_cast<int>(r.matches.size());
    q.inliers = static_cast<int>(r.inliers.size());
    q.match_ms = r.match_ms;
    q.pose_ms = r.pose_ms;
    if (r.status == LocalizationStatus::kOk) {
      const Transformation& T_gt = seq.T_W_C[k];
      q.position_error_m = (r.T_G_C.translation() - T_gt.translation()).norm();
      q.rotation_error_deg =
          AngleBetween(r.T_G_C.rotation(), T_gt.rotation()) *
          180.0 / M_PI;
      q.success = q.position_error_m <= options.max_position_error_m &&
                  q.rotation_error_deg <= options.max_rotation_error_deg;
      pos.push_back(q.position_error_m);
      rot.push_back(q.rotation_error_deg);
    }
    successes += q.success ? 1 : 0;
    query_ms.push_back(q.match_ms + q.pose_ms);
    extract_ms.push_back(q.extract_ms);
    report.queries.push_back(q);
  }
  report.max_position_error_m = options.max_position_error_m;
  report.max_rotation_error_deg = options.max_rotation_error_deg;
  report.successes = successes;
  report.recall = report.queries.empty()
                      ? 0.0
                      : static_cast<double>(successes) / static_cast<double>(report.queries.size());
  report.median_position_error_m = Median(pos);
  report.median_rotation_error_deg = Median(rot);
  report.p50_query_ms = Percentile(query_ms, 0.5);
  report.p90_query_ms = Percentile(query_ms, 0.9);
  report.p50_extract_ms = Percentile(extract_ms, 0.5);
  return report;
}

std::string KittiLocalizationReport::BriefReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(1) << "recall " << 100.0 * recall << " % (" << successes
      << "/" << queries.size() << " within " << std::setprecision(2) << max_position_error_m
      << " m and " << max_rotation_error_deg << " deg), median " << std::setprecision(3)
      << median_position_error_m << " m / " << median_rotation_error_deg << " deg, query p50 "
      << std::setprecision(1) << p50_query_ms << " ms";
  return out.str();
}

std::string KittiLocalizationReport::FullReport() const {
  std::ostringstream out;
  out << "map: " << map_frames << " even frames, " << map_vertices_landmarks
      << " stereo landmarks (" << merged_observations
      << " re-observations merged), localization map " << localization_landmarks
      << " landmarks / " << localization_descriptors << " descriptors\n";
  out << "stereo: " << refined_disparities << " sub-pixel disparities, "
      << unrefined_disparities << " kept whole-pixel; " << triangulated_tracks
      << " landmarks triangulated from >= 2 stereo views (" << dropped_track_views
      << " views left out)\n";
  out << std::fixed << std::setprecision(1) << "map build " << map_build_ms
      << " ms, projection training " << projection_train_ms << " ms, index build "
      << index_build_ms << " ms\n\n";
  out << "frame  status                    kpts  raw  cov  inl   pos[m]  rot[deg]  ok  extract  "
         "match   pose [ms]\n";
  for (const KittiQueryResult& q : queries) {
    out << std::setw(5) << q.frame << "  " << std::left << std::setw(24)
        << LocalizationStatusName(q.status) << std::right << std::setw(6) << q.keypoints
        << std::setw(5) << q.raw_matches << std::setw(5) << q.matches << std::setw(5)
        << q.inliers;
    if (q.position_error_m >= 0.0) {
      out << std::setprecision(3) << std::setw(9) << q.position_error_m << std::setw(10)
          << q.rotation_error_deg;
    } else {
      out << std::setw(9) << "-" << std::setw(10) << "-";
    }
    out << std::setw(4) << (q.success ? "y" : "n") << std::setprecision(1) << std::setw(9)
        << q.extract_ms << std::setw(7) << q.match_ms << std::setw(7) << q.pose_ms << "\n";
  }
  out << "\nrecall (within " << std::setprecision(2) << max_position_error_m << " m and "
      << max_rotation_error_deg << " deg): " << successes << "/" << queries.size() << " = "
      << std::setprecision(1) << 100.0 * recall << " %\n";
  out << std::setprecision(3) << "median error of localized queries: " << median_position_error_m
      << " m, " << median_rotation_error_deg << " deg\n";
  out << std::setprecision(1) << "query (match + pose) p50 " << p50_query_ms << " ms, p90 "
      << p90_query_ms << " ms; feature extraction p50 " << p50_extract_ms << " ms\n";
  out << "statuses: " << stats.BriefReport() << "\n";
  return out.str();
}

}  // namespace vilma::eval

#include "vilma/eval/localization/dataset_localization.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/timing.h"
#include "vilma/eval/alignment_json.h"

namespace vilma::eval {
namespace {

using localizer::LocalizationStatus;
using Query = DatasetLocalizationQuery;

double RotationErrorDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return Eigen::AngleAxisd(a.conjugate() * b).angle() * 180.0 / M_PI;
}

// Errors of the localized queries against ground truth after S_W_G = `align`:
// T_W_I = S_W_G T_G_I, e_p = |p_W_I - p_W_I_gt|, e_R = angle(R_W_I_gt^T R_W_I).
void ComputeErrors(const Alignment& align, std::vector<Query>* queries) {
  for (Query& q : *queries) {
    q.has_error = q.has_gt && q.status == LocalizationStatus::kOk;
    if (!q.has_error) continue;
    const Transformation T_W_I = align.Apply(q.T_G_I);
    q.position_error_m = (T_W_I.translation() - q.T_W_I_gt.translation()).norm();
    q.rotation_error_deg = RotationErrorDeg(q.T_W_I_gt.rotation(), T_W_I.rotation());
  }
}

// S_W_G fitted to the localized positions (posyaw / se3), robustly: a least-squares fit to all,
// then one refit to those within max(3 x median error, 0.3 m) of the first fit, so that a few
// wrong localizations (metres off) do not bend it. False if too few localized queries.
bool FitAlignment(AlignmentType type, std::vector<Query>* queries, Alignment* align) {
  std::vector<Eigen::Vector3d> p_W, p_G;
  for (const Query& q : *queries) {
    if (!q.has_gt || q.status != LocalizationStatus::kOk) continue;
    p_W.push_back(q.T_W_I_gt.translation());
    p_G.push_back(q.T_G_I.translation());
  }
  const std::size_t min_poses = std::max<std::size_t>(MinimumPosesForAlignment(type), 3);
  if (p_W.size() < min_poses) return false;
  *align = AlignPositions(type, p_W, p_G);
  std::vector<double> e(p_W.size());
  for (std::size_t i = 0; i < p_W.size(); ++i) {
    e[i] = (align->Apply(Transformation(Eigen::Quaterniond::Identity(), p_G[i])).translation() -
            p_W[i])
               .norm();
  }
  const double gate = std::max(3.0 * Percentile(e, 0.5), 0.3);
  std::vector<Eigen::Vector3d> p_W_in, p_G_in;
  for (std::size_t i = 0; i < e.size(); ++i) {
    if (e[i] > gate) continue;
    p_W_in.push_back(p_W[i]);
    p_G_in.push_back(p_G[i]);
  }
  if (p_W_in.size() >= min_poses) *align = AlignPositions(type, p_W_in, p_G_in);
  ComputeErrors(*align, queries);
  return true;
}

std::string Percent(int n, int d) {
  std::ostringstream s;
  s << n << " / " << d << " (" << std::fixed << std::setprecision(1)
    << (d > 0 ? 100.0 * n / d : 0.0) << " %)";
  return s.str();
}

// The alignment the errors are computed with, its note, and the errors (summary->results).
void Align(DatasetLocalizationSummary* s) {
  const DatasetLocalizationOptions& o = s->options;
  s->errors_valid = s->with_ground_truth > 0;
  s->alignment = Alignment();  // identity
  s->alignment_note = "none (map frame G = ground-truth frame W)";
  if (!s->errors_valid) return;
  if (!o.align_from_path.empty()) {
    s->alignment = ReadAlignmentJson(o.align_from_path);
    s->alignment_note = "fixed, from " + o.align_from_path;
    ComputeErrors(s->alignment, &s->results);
  } else if (o.align != AlignmentType::kNone) {
    if (FitAlignment(o.align, &s->results, &s->alignment)) {
      const Eigen::Vector3d& t = s->alignment.T_G_E.translation();
      std::ostringstream n;
      n << std::fixed << std::setprecision(3) << AlignmentTypeName(o.align)
        << " fitted to the localized positions: translation (" << t.x() << ", " << t.y() << ", "
        << t.z() << ") m, rotation "
        << Eigen::AngleAxisd(s->alignment.T_G_E.rotation()).angle() * 180.0 / M_PI << " deg";
      s->alignment_note = n.str();
    } else {
      s->errors_valid = false;
      s->alignment_note = "not enough localized queries with ground truth to fit " +
                          std::string(AlignmentTypeName(o.align));
    }
  } else {
    ComputeErrors(s->alignment, &s->results);
  }
}

// Counts and time percentiles of the summary from its results.
void Summarize(DatasetLocalizationSummary* s) {
  std::vector<double> feat_ms, feat_cpu_ms, loc_ms, loc_cpu_ms;
  s->queries = static_cast<int>(s->results.size());
  for (const Query& q : s->results) {
    ++s->status_counts[static_cast<std::size_t>(q.status)];
    feat_ms.push_back(q.features_ms);
    feat_cpu_ms.push_back(q.features_cpu_ms);
    loc_ms.push_back(q.localize_ms);
    loc_cpu_ms.push_back(q.localize_cpu_ms);
    if (q.status == LocalizationStatus::kOk) ++s->localized;
    if (!q.has_error || !s->errors_valid) continue;
    if (q.position_error_m <= 0.5) ++s->within_05m;
    if (q.position_error_m <= 0.3 && q.rotation_error_deg <= 2.0) ++s->within_03m_2deg;
  }
  s->features_ms_p50 = Percentile(feat_ms, 0.5);
  s->features_ms_p90 = Percentile(feat_ms, 0.9);
  s->features_cpu_ms_p50 = Percentile(feat_cpu_ms, 0.5);
  s->features_cpu_ms_p90 = Percentile(feat_cpu_ms, 0.9);
  s->localize_ms_p50 = Percentile(loc_ms, 0.5);
  s->localize_ms_p90 = Percentile(loc_ms, 0.9);
  s->localize_cpu_ms_p50 = Percentile(loc_cpu_ms, 0.5);
  s->localize_cpu_ms_p90 = Percentile(loc_cpu_ms, 0.9);
}

}  // namespace

std::string DatasetLocalizationOptions::Validate() const {
  if (every < 1) return "every: expected an integer >= 1";
  if (camera < 0) return "camera: expected an index >= 0";
  if (!align_from_path.empty() && align != AlignmentType::kNone) {
    return "align: expected none with align_from (they exclude each other)";
  }
  if (align != AlignmentType::kNone && align != AlignmentType::kPosYaw &&
      align != AlignmentType::kSe3) {
    return "align: expected none, posyaw or se3";
  }
  return "";
}

bool GroundTruthAt(const std::vector<GroundTruthState>& gt, int64_t t, Transformation* T_W_I) {
  // EuRoC's ground truth is 200 Hz, or 20 Hz with stamp jitter (gaps of 50.0001 ms), and not
  // on the camera times; the simulator writes a sample at every frame time. A missing sample
  // (a 100 ms gap) is no ground truth.
  const auto it = std::lower_bound(
      gt.begin(), gt.end(), t, [](const GroundTruthState& g, int64_t tt) { return g.t_ns < tt; });
  if (it == gt.end()) return false;
  if (it->t_ns == t) {
    *T_W_I = Transformation(it->q_W_I, it->p_W_I);
    return true;
  }
  if (it == gt.begin()) return false;
  const GroundTruthState& a = *(it - 1);
  const GroundTruthState& b = *it;
  constexpr int64_t kMaxGapNs = 51'000'000;
  if (b.t_ns - a.t_ns > kMaxGapNs) return false;
  const double s = static_cast<double>(t - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  *T_W_I = Transformation(a.q_W_I.slerp(s, b.q_W_I), (1.0 - s) * a.p_W_I + s * b.p_W_I);
  return true;
}

void CheckDatasetCamera(const std::string& dataset_path, const AslDataset& dataset,
                        const SensorRig& rig, const std::string& rig_source, int camera) {
  const std::size_t cam = static_cast<std::size_t>(camera);
  if (camera < 0 || cam >= dataset.cameras().size()) {
    throw InputError(FormatInputError(dataset_path, "cam" + std::to_string(camera),
                                      "a camera folder with that index (--camera)"));
  }
  if (cam >= rig.cameras.size()) {
    throw InputError(FormatInputError(rig_source, "cameras[" + std::to_string(camera) + "]",
                                      "the camera given by --camera"));
  }
  if (dataset.cameras()[cam].frames.empty()) {
    throw InputError(FormatInputError(dataset_path, "cam" + std::to_string(camera) + "/data.csv",
                                      "images"));
  }
}

DatasetLocalizationSummary LocalizeDataset(const std::string& dataset_path,
                                           const AslDataset& dataset, const SensorRig& rig,
                                           const std::string& rig_source,
                                           const localizer::FeatureExtractor& extractor,
                                           const localizer::Localizer& localizer,
                                           const DatasetLocalizationOptions& options) {
  ThrowIfInvalid(options.Validate(), dataset_path, "localize options");
  const auto start = std::chrono::steady_clock::now();
  CheckDatasetCamera(dataset_path, dataset, rig, rig_source, options.camera);
  const std::size_t cam = static_cast<std::size_t>(options.camera);
  const auto& frames = dataset.cameras()[cam].frames;
  const Camera& camera = rig.cameras[cam].camera;
  const Transformation& T_I_C = rig.cameras[cam].T_I_C;
  const int64_t offset_ns = rig.cameras[cam].time_offset_ns;  // t_imu = t_cam + offset

  DatasetLocalizationSummary s;
  s.dataset_path = dataset_path;
  s.options = options;
  s.frames = frames.size();
  s.first_frame_t_ns = frames.front().t_ns;
  std::vector<Eigen::Vector2d> uv;
  for (std::size_t i = 0; i < frames.size(); i += static_cast<std::size_t>(options.every)) {
    Query q;
    q.frame = i;
    q.t_ns = frames[i].t_ns;
    q.has_gt = GroundTruthAt(dataset.ground_truth(), frames[i].t_ns + offset_ns, &q.T_W_I_gt);
    const cv::Mat image = AslDataset::LoadImage(frames[i].image_path);
    if (image.cols != camera.width() || image.rows != camera.height()) {
      throw InputError(FormatInputError(frames[i].image_path, "size",
                                        std::to_string(camera.width()) + "x" +
                                            std::to_string(camera.height()) +
                                            " as the rig's camera " +
                                            std::to_string(options.camera)));
    }
    auto t0 = std::chrono::steady_clock::now();
    const double cpu0 = ThreadCpuMs();
    const localizer::KeyframeFeatures f = extractor.Extract(image);
    q.features_cpu_ms = ThreadCpuMs() - cpu0;
    q.features_ms = MsSince(t0);
    uv.clear();
    for (const cv::KeyPoint& k : f.keypoints) uv.emplace_back(k.pt.x, k.pt.y);
    q.keypoints = f.size();
    t0 = std::chrono::steady_clock::now();
    const localizer::LocalizationResult r = localizer.Localize(
        camera, T_I_C, uv, f.keypoints.empty() ? nullptr : f.descriptors.ptr<uint8_t>());
    q.localize_ms = MsSince(t0);
    q.localize_cpu_ms = r.match_cpu_ms + r.pose_cpu_ms;
    q.status = r.status;
    q.raw_matches = r.num_raw_matches;
    q.matches = static_cast<int>(r.matches.size());
    q.inliers = static_cast<int>(r.inliers.size());
    q.ransac_iterations = r.ransac_iterations;
    q.rms_px = r.rms_reprojection_px;
    q.T_G_I = r.T_G_I;
    if (q.has_gt) ++s.with_ground_truth;
    s.results.push_back(q);
  }
  // Errors after the whole run: a fitted alignment needs every result.
  Align(&s);
  Summarize(&s);
  s.total_s = MsSince(start) * 1e-3;
  return s;
}

std::string DatasetLocalizationSummary::BriefReport() const {
  std::ostringstream s;
  s << queries << (queries == 1 ? " query" : " queries") << ", localized " << Percent(localized, queries);
  if (errors_valid) {
    s << ", within 0.3 m and 2 deg " << Percent(within_03m_2deg, with_ground_truth);
  } else {
    s << ", no errors (" << (with_ground_truth == 0 ? "no ground truth" : "no alignment") << ")";
  }
  s << std::fixed << std::setprecision(1) << ", features p50 " << features_ms_p50
    << " ms, Localize p50 " << localize_ms_p50 << " ms";
  return s.str();
}

std::string DatasetLocalizationSummary::FullReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(2) << "summary: " << queries << " queries\n  status     ";
  bool first = true;
  for (int st = 0; st < static_cast<int>(LocalizationStatus::kNumStatuses); ++st) {
    const int count = status_counts[static_cast<std::size_t>(st)];
    if (count == 0) continue;
    out << (first ? "" : ", ")
        << localizer::LocalizationStatusName(static_cast<LocalizationStatus>(st)) << " " << count;
    first = false;
  }
  out << "\n  localized  " << Percent(localized, queries) << "\n";
  if (with_ground_truth == 0) {
    out << "  errors     none: " << dataset_path << " has no ground truth"
        << " (mav0/state_groundtruth_estimate0/data.csv)\n";
  } else {
    out << "  alignment  " << alignment_note << "\n";
    if (errors_valid) {
      std::vector<double> e_p, e_r;
      for (const Query& q : results) {
        if (!q.has_error) continue;
        e_p.push_back(q.position_error_m);
        e_r.push_back(q.rotation_error_deg);
      }
      out << "  recall     within 0.5 m: " << Percent(within_05m, with_ground_truth)
          << "; within 0.3 m and 2 deg: " << Percent(within_03m_2deg, with_ground_truth)
          << " (of the queries with ground truth)\n"
          << std::setprecision(3) << "  position   median " << Percentile(e_p, 0.5) << " m, p90 "
          << Percentile(e_p, 0.9) << " m (localized queries)\n"
          << std::setprecision(2) << "  rotation   median " << Percentile(e_r, 0.5)
          << " deg, p90 " << Percentile(e_r, 0.9) << " deg\n";
      if (options.align == AlignmentType::kNone && options.align_from_path.empty() &&
          e_p.size() >= 3 && Percentile(e_p, 0.5) > 1.0) {
        out << "  note       the median error is over 1 m: if MAP was built by VIO (vilma vio\n"
               "             --save-map), its frame G is that run's odometry frame, not the\n"
               "             dataset's ground-truth frame: try --align posyaw\n";
      }
    }
  }
  // Wall and thread CPU time: on a loaded machine the difference is waiting for a core.
  out << std::setprecision(1) << "  features   p50 " << features_ms_p50 << " ms, p90 "
      << features_ms_p90 << " ms wall (CPU p50 " << features_cpu_ms_p50 << " ms, p90 "
      << features_cpu_ms_p90 << " ms)\n"
      << "  Localize   p50 " << localize_ms_p50 << " ms, p90 " << localize_ms_p90
      << " ms wall (CPU p50 " << localize_cpu_ms_p50 << " ms, p90 " << localize_cpu_ms_p90
      << " ms)\n";
  return out.str();
}

std::string DatasetLocalizationSummary::QueryTable() const {
  std::ostringstream out;
  out << std::fixed
      << "  frame      t[s]  status                     kpts   raw match  inl   e_p[m] e_R[deg]"
         "  feat_ms   loc_ms\n";
  for (const Query& q : results) {
    out << std::setw(7) << q.frame << std::setw(10) << std::setprecision(3)
        << static_cast<double>(q.t_ns - first_frame_t_ns) * 1e-9 << "  " << std::left
        << std::setw(24) << localizer::LocalizationStatusName(q.status) << std::right
        << std::setw(6) << q.keypoints << std::setw(6) << q.raw_matches << std::setw(6)
        << q.matches << std::setw(5) << q.inliers;
    if (q.has_error && errors_valid) {
      out << std::setw(9) << q.position_error_m << std::setw(9) << std::setprecision(2)
          << q.rotation_error_deg;
    } else {
      out << std::setw(9) << "-" << std::setw(9) << "-";
    }
    out << std::setprecision(1) << std::setw(9) << q.features_ms << std::setw(9) << q.localize_ms
        << "\n";
  }
  return out.str();
}

std::string DatasetLocalizationSummary::Csv() const {
  std::ostringstream s;
  s << "frame,t_ns,status,keypoints,raw_matches,matches,inliers,ransac_iterations,"
       "rms_reprojection_px,p_G_x,p_G_y,p_G_z,q_G_w,q_G_x,q_G_y,q_G_z,has_ground_truth,"
       "position_error_m,rotation_error_deg,features_ms,features_cpu_ms,localize_ms,"
       "localize_cpu_ms\n";
  s << std::setprecision(9);
  for (const Query& q : results) {
    const bool ok = q.status == LocalizationStatus::kOk;
    s << q.frame << "," << q.t_ns << "," << localizer::LocalizationStatusName(q.status) << ","
      << q.keypoints << "," << q.raw_matches << "," << q.matches << "," << q.inliers << ","
      << q.ransac_iterations << ",";
    if (ok) {
      const Eigen::Vector3d& p = q.T_G_I.translation();
      const Eigen::Quaterniond& r = q.T_G_I.rotation();
      s << q.rms_px << "," << p.x() << "," << p.y() << "," << p.z() << "," << r.w() << "," << r.x()
        << "," << r.y() << "," << r.z() << ",";
    } else {
      s << ",,,,,,,,";
    }
    s << (q.has_gt ? 1 : 0) << ",";
    if (q.has_error) {
      s << q.position_error_m << "," << q.rotation_error_deg << ",";
    } else {
      s << ",,";
    }
    s << q.features_ms << "," << q.features_cpu_ms << "," << q.localize_ms << ","
      << q.localize_cpu_ms << "\n";
  }
  return s.str();
}

}  // namespace vilma::eval

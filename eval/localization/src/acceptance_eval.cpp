#include "vilma/eval/localization/acceptance_eval.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numeric>
#include <random>
#include <sstream>
#include <unordered_set>

#include "vilma/core/error.h"

namespace vilma::eval {

using namespace localizer;  // the harness is written in the localizer's types
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double LargestSigma(const Eigen::Matrix3d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(covariance);
  return std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
}

// |reprojection error| of p_G seen at uv from T_G_C, -1 when it does not project.
double ReprojectionError(const Camera& camera, const Transformation& T_G_C,
                         const Eigen::Vector3d& p_G, const Eigen::Vector2d& uv) {
  const Eigen::Vector3d p_C = T_G_C.inverse() * p_G;
  Eigen::Vector2d projected;
  if (p_C.z() <= 1e-6 || camera.Project(p_C, &projected) != Camera::ProjectionResult::kValid) {
    return -1.0;
  }
  return (projected - uv).norm();
}

std::vector<MatchRecord> RecordMatches(const Camera& camera, const LocalizationMap& map,
                                       const std::vector<Eigen::Vector2d>& keypoints,
                                       const LocalizationResult& r,
                                       const Transformation& T_G_C_gt,
                                       const AcceptanceGates& gates) {
  std::vector<bool> is_inlier(r.matches.size(), false);
  for (int i : r.inliers) is_inlier[static_cast<std::size_t>(i)] = true;
  const Eigen::Matrix3d R_C_G_gt = T_G_C_gt.rotation().inverse().toRotationMatrix();
  std::vector<MatchRecord> records;
  for (std::size_t i = 0; i < r.matches.size(); ++i) {
    const Match2D3D& m = r.matches[i];
    MatchRecord rec;
    rec.keypoint = m.keypoint;
    rec.uv = keypoints[static_cast<std::size_t>(m.keypoint)];
    rec.inlier = is_inlier[i];
    const Eigen::Vector3d& p_G = map.p_G[m.landmark];
    rec.error_estimate_px = ReprojectionError(camera, r.T_G_C, p_G, rec.uv);
    rec.error_truth_px = ReprojectionError(camera, T_G_C_gt, p_G, rec.uv);
    rec.oracle = rec.error_truth_px >= 0.0 && rec.error_truth_px <= gates.oracle_threshold_px;
    if (!rec.inlier && !rec.oracle) continue;
    const Eigen::Vector3d p_C = T_G_C_gt.inverse() * p_G;
    rec.depth_m = p_C.z();
    rec.observers = static_cast<int>(map.observer_begin[m.landmark + 1] -
                                     map.observer_begin[m.landmark]);
    if (!map.p_G_covariance.empty()) {
      const Eigen::Matrix3d cov_C =
          R_C_G_gt * map.p_G_covariance[m.landmark].cast<double>() * R_C_G_gt.transpose();
      const Eigen::Vector3d ray = p_C.normalized();
      rec.sigma_ray_m = std::sqrt(std::max(0.0, ray.dot(cov_C * ray)));
      rec.sigma_max_m = LargestSigma(cov_C);
    }
    records.push_back(rec);
  }
  std::sort(records.begin(), records.end(),
            [](const MatchRecord& a, const MatchRecord& b) { return a.depth_m < b.depth_m; });
  return records;
}

}  // namespace

bool QueryPerturbation::IsIdentity() const {
  return box_min_x <= 0.0 && box_min_y <= 0.0 && box_max_x >= 1.0 && box_max_y >= 1.0 &&
         max_keypoints == 0 && swap_fraction == 0.0;
}

std::string QueryPerturbation::Validate() const {
  for (double v : {box_min_x, box_min_y, box_max_x, box_max_y}) {
    if (!(std::isfinite(v) && v >= 0.0 && v <= 1.0)) return "box: expected fractions in [0, 1]";
  }
  if (!(box_min_x < box_max_x && box_min_y < box_max_y)) return "box: expected min < max";
  if (max_keypoints < 0) return "max_keypoints: expected >= 0 (0: all)";
  if (!(std::isfinite(swap_fraction) && swap_fraction >= 0.0 && swap_fraction <= 1.0)) {
    return "swap_fraction: expected in [0, 1]";
  }
  return "";
}

void PerturbQuery(const QueryPerturbation& p, const Camera& camera,
                  std::vector<Eigen::Vector2d>* keypoints, std::vector<uint8_t>* descriptors,
                  int descriptor_bytes) {
  const std::string error = p.Validate();
  if (!error.empty()) throw InputError(FormatInputError("QueryPerturbation", "", error));
  const std::size_t bytes = static_cast<std::size_t>(descriptor_bytes);
  const double x0 = p.box_min_x * camera.width(), x1 = p.box_max_x * camera.width();
  const double y0 = p.box_min_y * camera.height(), y1 = p.box_max_y * camera.height();
  std::vector<Eigen::Vector2d> kept;
  std::vector<uint8_t> kept_descriptors;
  for (std::size_t i = 0; i < keypoints->size(); ++i) {
    const Eigen::Vector2d& uv = (*keypoints)[i];
    if (uv.x() < x0 || uv.x() > x1 || uv.y() < y0 || uv.y() > y1) continue;
    if (p.max_keypoints > 0 && static_cast<int>(kept.size()) >= p.max_keypoints) break;
    kept.push_back(uv);
    kept_descriptors.insert(kept_descriptors.end(), descriptors->begin() + i * bytes,
                            descriptors->begin() + (i + 1) * bytes);
  }
  const std::size_t n = kept.size();
  const std::size_t swapped = static_cast<std::size_t>(std::floor(p.swap_fraction * n + 0.5));
  if (swapped >= 2) {
    // A random subset, shifted cyclically: every chosen keypoint gets the descriptor of the
    // next chosen one, never its own.
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::mt19937_64 rng(p.seed);
    std::shuffle(order.begin(), order.end(), rng);
    order.resize(swapped);
    const std::vector<uint8_t> original = kept_descriptors;
    for (std::size_t k = 0; k < swapped; ++k) {
      const std::size_t to = order[k], from = order[(k + 1) % swapped];
      std::copy(original.begin() + from * bytes, original.begin() + (from + 1) * bytes,
                kept_descriptors.begin() + to * bytes);
    }
  }
  *keypoints = std::move(kept);
  *descriptors = std::move(kept_descriptors);
}

AcceptanceQuery EvaluateAcceptanceQuery(const Localizer& localizer, const Camera& camera,
                                        const Transformation& T_I_C,
                                        const std::vector<Eigen::Vector2d>& keypoints,
                                        const std::vector<uint8_t>& descriptors,
                                        const Transformation& T_G_I_gt,
                                        const AcceptanceGates& gates) {
  AcceptanceQuery q;
  q.keypoints = static_cast<int>(keypoints.size());
  const LocalizationResult r = localizer.Localize(
      camera, T_I_C, keypoints, keypoints.empty() ? nullptr : descriptors.data());
  q.localize_ms = r.match_cpu_ms + r.pose_cpu_ms;  // thread CPU: not the machine's load
  q.pose_ms = r.pose_cpu_ms;
  q.status = r.status;
  q.matches = static_cast<int>(r.matches.size());
  q.inliers = static_cast<int>(r.inliers.size());
  q.quality = r.quality;
  // Oracle on the RANSAC input: distinct keypoints whose landmark reprojects near them under
  // the ground truth.
  const Transformation T_C_G = (T_G_I_gt * T_I_C).inverse();
  std::unordered_set<int> agreeing;
  for (const Match2D3D& m : r.matches) {
    const Eigen::Vector3d p_C = T_C_G * localizer.map().p_G[m.landmark];
    Eigen::Vector2d uv;
    if (p_C.z() <= 1e-6 || camera.Project(p_C, &uv) != Camera::ProjectionResult::kValid) continue;
    if ((uv - keypoints[static_cast<std::size_t>(m.keypoint)]).norm() <= gates.oracle_threshold_px) {
      agreeing.insert(m.keypoint);
    }
  }
  q.oracle_matches = static_cast<int>(agreeing.size());
  q.possible = q.oracle_matches >= gates.oracle_min_matches;
  q.accepted = r.status == LocalizationStatus::kOk;
  // A pose reached the gates: accepted, or rejected after refinement by one of them.
  if (HasRefinedPose(r.status)) {
    q.judged_position_error_m = (r.T_G_I.translation() - T_G_I_gt.translation()).norm();
    q.judged_rotation_error_deg =
        AngleBetween(r.T_G_I.rotation(), T_G_I_gt.rotation()) * 180.0 / M_PI;
  }
  if (q.accepted) {
    q.position_error_m = q.judged_position_error_m;
    q.rotation_error_deg = q.judged_rotation_error_deg;
    q.wrong = !(q.position_error_m <= gates.max_position_error_m &&
                q.rotation_error_deg <= gates.max_rotation_error_deg);
    q.position_sigma_m = LargestSigma(r.covariance_I.topLeftCorner<3, 3>());
    q.rotation_sigma_deg = LargestSigma(r.covariance_I.bottomRightCorner<3, 3>()) * 180.0 / M_PI;
    if (!q.wrong) {
      q.residuals = InlierResidualSamples(camera, localizer.map(), keypoints, r,
                                          localizer.options().ransac.keypoint_sigma_px);
    }
    const Transformation T_G_C_gt = T_G_I_gt * T_I_C;
    q.position_error_C =
        T_G_C_gt.rotation().inverse() * (r.T_G_C.translation() - T_G_C_gt.translation());
    q.match_records = RecordMatches(camera, localizer.map(), keypoints, r, T_G_C_gt, gates);
  }
  return q;
}

std::string AcceptanceSummary::BriefReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(1) << (name.empty() ? "queries" : name) << ": accepted "
      << accepted << " of " << queries << " (wrong " << accepted_wrong << "), recall "
      << 100.0 * recall << " % of " << possible << " possible";
  return out.str();
}

std::string AcceptanceSummary::FullReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(3) << BriefReport() << "\n"
      << "  median error " << median_position_error_m << " m / " << median_rotation_error_deg
      << " deg (accepted)\n"
      << "  worst wrong " << max_wrong_position_error_m << " m / " << max_wrong_rotation_error_deg
      << " deg\n"
      << "  localize p50 " << p50_localize_ms << " ms, max " << max_localize_ms
      << " ms, pose p50 " << p50_pose_ms << " ms\n"
      << "  statuses: " << stats.BriefReport() << "\n";
  return out.str();
}

AcceptanceSummary SummarizeAcceptance(const std::string& name,
                                      const std::vector<AcceptanceQuery>& queries) {
  AcceptanceSummary s;
  s.name = name;
  std::vector<double> pos, rot, ms, pose_ms;
  std::vector<ResidualSample> residuals;
  double residual_dof = 0.0;
  int right_poses = 0;
  for (const AcceptanceQuery& q : queries) {
    ms.push_back(q.localize_ms);
    pose_ms.push_back(q.pose_ms);
    s.max_localize_ms = std::max(s.max_localize_ms, q.localize_ms);
    ++s.queries;
    ++s.stats.queries;
    ++s.stats.status_counts[static_cast<int>(q.status)];
    s.possible += q.possible ? 1 : 0;
    if (!q.accepted) continue;
    ++s.accepted;
    pos.push_back(q.position_error_m);
    rot.push_back(q.rotation_error_deg);
    if (q.wrong) {
      ++s.accepted_wrong;
      s.max_wrong_position_error_m = std::max(s.max_wrong_position_error_m, q.position_error_m);
      s.max_wrong_rotation_error_deg =
          std::max(s.max_wrong_rotation_error_deg, q.rotation_error_deg);
    } else if (q.possible) {
      ++s.accepted_correct;
    }
    if (!q.wrong && !q.residuals.empty()) {
      residuals.insert(residuals.end(), q.residuals.begin(), q.residuals.end());
      residual_dof += 2.0 * static_cast<double>(q.residuals.size()) - 6.0;
      ++right_poses;
    }
  }
  s.noise = FitNoiseComponents(residuals, residual_dof, right_poses);
  s.recall = s.possible > 0 ? static_cast<double>(s.accepted_correct) / s.possible : 0.0;
  s.p50_localize_ms = Median(ms);
  s.p50_pose_ms = Median(pose_ms);
  s.median_position_error_m = Median(pos);
  s.median_rotation_error_deg = Median(rot);
  return s;
}

void WriteAcceptanceHeader(std::ostream& out) {
  out << "| data set | queries | possible | accepted | accepted wrong (> 0.3 m or > 2 deg) | "
         "worst wrong [m / deg] | recall (correct / possible) | median error [m / deg] | "
         "rejections | Localize CPU p50 / max, pose p50 [ms] | right poses: chi2/dof, sigma_kp [px], "
         "Sigma_l scale |\n"
         "|---|---:|---:|---:|---:|---|---:|---|---|---|---|\n";
}

void WriteAcceptanceRow(std::ostream& out, const AcceptanceSummary& s) {
  std::ostringstream row;
  row << std::fixed << "| " << s.name << " | " << s.queries << " | " << s.possible << " | "
      << s.accepted << " | " << s.accepted_wrong << " | ";
  if (s.accepted_wrong > 0) {
    row << std::setprecision(2) << s.max_wrong_position_error_m << " / "
        << s.max_wrong_rotation_error_deg;
  } else {
    row << "-";
  }
  row << " | " << s.accepted_correct << " / " << s.possible << " = " << std::setprecision(1)
      << 100.0 * s.recall << " % | ";
  if (s.accepted > 0) {
    row << std::setprecision(3) << s.median_position_error_m << " / " << std::setprecision(2)
        << s.median_rotation_error_deg;
  } else {
    row << "-";
  }
  row << " | ";
  bool first = true;
  for (int k = 1; k < static_cast<int>(LocalizationStatus::kNumStatuses); ++k) {
    if (s.stats.status_counts[k] == 0) continue;
    row << (first ? "" : ", ") << LocalizationStatusName(static_cast<LocalizationStatus>(k)) << " "
        << s.stats.status_counts[k];
    first = false;
  }
  if (first) row << "-";
  row << " | " << std::setprecision(1) << s.p50_localize_ms << " / " << s.max_localize_ms << ", "
      << s.p50_pose_ms << " | ";
  if (s.noise.poses > 0) {
    row << std::setprecision(2) << s.noise.chi2_per_dof << ", " << s.noise.keypoint_sigma_px
        << ", ";
    if (s.noise.landmark_scale >= 0.0) {
      row << s.noise.landmark_scale;
    } else {
      row << "-";
    }
  } else {
    row << "-";
  }
  row << " |\n";
  out << row.str();
}

void WriteAcceptanceQueries(std::ostream& out, const std::vector<AcceptanceQuery>& queries) {
  std::ostringstream s;
  s << "frame  status                    kpts  match  inl  oracle  possible  pos[m]  rot[deg]"
       "  sigma_p[m]  sigma_R[deg]  verdict   ratio  med/p90[px]  cells  hull  sp[m] sR[deg] "
       "rival  rival_d[m/deg]  chi2/dof  split_img[m/deg/d2]  split_depth[m/deg/d2]  "
       "displaced[ratio m/deg]  judged_err[m/deg]  rival_margin[sigma]\n";
  for (const AcceptanceQuery& q : queries) {
    s << std::setw(5) << q.frame << "  " << std::left << std::setw(24)
      << LocalizationStatusName(q.status) << std::right << std::setw(6) << q.keypoints
      << std::setw(7) << q.matches << std::setw(5) << q.inliers << std::setw(8)
      << q.oracle_matches << std::setw(10) << (q.possible ? "y" : "n");
    if (q.accepted) {
      s << std::fixed << std::setprecision(3) << std::setw(8) << q.position_error_m
        << std::setw(10) << q.rotation_error_deg << std::setw(12) << q.position_sigma_m
        << std::setw(14) << q.rotation_sigma_deg << "  " << (q.wrong ? "WRONG" : "correct");
    } else {
      s << std::setw(8) << "-" << std::setw(10) << "-" << std::setw(12) << "-" << std::setw(14)
        << "-" << "  rejected";
    }
    const PoseQuality& g = q.quality;
    s << std::fixed << std::setprecision(2) << std::setw(8) << g.inlier_ratio << std::setw(7)
      << g.median_error_px << "/" << std::left << std::setw(5) << g.p90_error_px << std::right
      << std::setw(7) << g.cell_fraction << std::setw(6) << g.hull_fraction << std::setprecision(3)
      << std::setw(7) << g.position_sigma_m << std::setw(7) << g.rotation_sigma_deg
      << std::setprecision(2) << std::setw(6) << g.rival_ratio << std::setw(8)
      << g.rival_position_m << "/" << g.rival_rotation_deg << std::setw(8) << g.chi2_per_dof
      << std::setprecision(3) << std::setw(8) << g.split_image_position_m << "/"
      << std::setprecision(2) << g.split_image_rotation_deg << "/" << std::setprecision(1)
      << g.split_image_mahalanobis2 << std::setprecision(3) << std::setw(8)
      << g.split_depth_position_m << "/" << std::setprecision(2) << g.split_depth_rotation_deg
      << "/" << std::setprecision(1) << g.split_depth_mahalanobis2 << std::setprecision(2)
      << std::setw(7) << g.displaced_rival_ratio << " " << g.displaced_rival_position_m << "/"
      << g.displaced_rival_rotation_deg << (g.adopted_displaced_rival ? " adopted" : "")
      << std::setprecision(3) << "  " << q.judged_position_error_m << "/" << std::setprecision(2)
      << q.judged_rotation_error_deg << std::setprecision(1) << std::setw(6)
      << g.rival_margin_sigma;
    s << "\n";
  }
  out << s.str();
}

void WriteMatchRecords(std::ostream& out, const AcceptanceQuery& q) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(3) << "frame " << q.frame << " "
    << LocalizationStatusName(q.status) << ": position error in the true camera frame (x right, "
    << "y down, z forward) [" << q.position_error_C.x() << ", " << q.position_error_C.y() << ", "
    << q.position_error_C.z() << "] m, rotation error " << q.rotation_error_deg << " deg\n";
  s << "    u       v  inlier oracle  err_est[px] err_truth[px]  depth[m]  obs  sigma_ray[m] "
       "sigma_max[m]\n";
  std::vector<double> inlier_depths, inlier_truth_errors;
  for (const MatchRecord& m : q.match_records) {
    s << std::setprecision(1) << std::setw(6) << m.uv.x() << std::setw(8) << m.uv.y()
      << std::setw(6) << (m.inlier ? "y" : "n") << std::setw(7) << (m.oracle ? "y" : "n")
      << std::setprecision(2) << std::setw(13) << m.error_estimate_px << std::setw(14)
      << m.error_truth_px << std::setw(10) << m.depth_m << std::setw(5) << m.observers
      << std::setprecision(3) << std::setw(14) << m.sigma_ray_m << std::setw(13) << m.sigma_max_m
      << "\n";
    if (m.inlier) {
      inlier_depths.push_back(m.depth_m);
      inlier_truth_errors.push_back(m.error_truth_px);
    }
  }
  s << std::setprecision(2) << "inliers " << inlier_depths.size() << ": depth median "
    << Median(inlier_depths) << " m, error under the truth median " << Median(inlier_truth_errors)
    << " px\n";
  out << s.str();
}

}  // namespace vilma::eval

#include "vilma/localizer/pose_acceptance.h"

#include "vilma/localizer/pose_ambiguity.h"
#include "vilma/localizer/pose_consistency.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

namespace vilma::localizer {
namespace {

// Reprojection error of every match under T_G_C (infinity where it does not project).
std::vector<double> Errors(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                           const std::vector<Eigen::Vector3d>& p_G, const Transformation& T_G_C) {
  std::vector<double> e(p_G.size(), std::numeric_limits<double>::infinity());
  const Transformation T_C_G = T_G_C.inverse();
  for (std::size_t i = 0; i < p_G.size() && i < keypoints.size(); ++i) {
    const Eigen::Vector3d p_C = T_C_G * p_G[i];
    Eigen::Vector2d uv;
    if (p_C.z() <= 1e-6 || camera.Project(p_C, &uv) != Camera::ProjectionResult::kValid) continue;
    e[i] = (uv - keypoints[i]).norm();
  }
  return e;
}

std::vector<int> Below(const std::vector<double>& errors, double threshold) {
  std::vector<int> out;
  for (std::size_t i = 0; i < errors.size(); ++i) {
    if (errors[i] <= threshold) out.push_back(static_cast<int>(i));
  }
  return out;
}

// q-quantile by nearest rank of a non-empty vector.
double Quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double rank = std::ceil(q * static_cast<double>(v.size())) - 1.0;
  return v[static_cast<std::size_t>(std::clamp(rank, 0.0, static_cast<double>(v.size() - 1)))];
}

double Cross(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

// Area of the convex hull (Andrew's monotone chain, then the shoelace formula).
double ConvexHullArea(std::vector<Eigen::Vector2d> p) {
  if (p.size() < 3) return 0.0;
  std::sort(p.begin(), p.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  std::vector<Eigen::Vector2d> hull(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {  // lower hull
    while (k >= 2 && Cross(hull[k - 2], hull[k - 1], p[i]) <= 0.0) --k;
    hull[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i-- > 0;) {  // upper hull
    while (k >= t && Cross(hull[k - 2], hull[k - 1], p[i]) <= 0.0) --k;
    hull[k++] = p[i];
  }
  hull.resize(k - 1);
  double twice = 0.0;
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const Eigen::Vector2d& a = hull[i];
    const Eigen::Vector2d& b = hull[(i + 1) % hull.size()];
    twice += a.x() * b.y() - b.x() * a.y();
  }
  return 0.5 * std::abs(twice);
}

double LargestSigma(const Eigen::Matrix3d& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(covariance);
  return std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
}

}  // namespace

std::string PoseAcceptanceOptions::Validate() const {
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0)) {
    return "min_inlier_ratio: expected in [0, 1]";
  }
  if (refine_rounds < 1) return "refine_rounds: expected >= 1";
  if (!(max_median_error_ratio > 0.0 && max_median_error_ratio <= 1.0)) {
    return "max_median_error_ratio: expected in (0, 1] (1: off)";
  }
  if (!(max_p90_error_ratio > 0.0 && max_p90_error_ratio <= 1.0)) {
    return "max_p90_error_ratio: expected in (0, 1] (1: off)";
  }
  if (grid_cols < 1 || grid_rows < 1) return "grid_cols, grid_rows: expected >= 1";
  if (!(min_cell_fraction >= 0.0 && min_cell_fraction <= 1.0)) {
    return "min_cell_fraction: expected in [0, 1]";
  }
  if (!(min_hull_fraction >= 0.0 && min_hull_fraction <= 1.0)) {
    return "min_hull_fraction: expected in [0, 1]";
  }
  if (!(max_position_sigma_m > 0.0)) return "max_position_sigma_m: expected > 0";
  if (!(max_rotation_sigma_deg > 0.0)) return "max_rotation_sigma_deg: expected > 0";
  if (!(rival_exclusion_factor >= 1.0 && std::isfinite(rival_exclusion_factor))) {
    return "rival_exclusion_factor: expected >= 1";
  }
  if (!(max_rival_ratio > 0.0 && max_rival_ratio <= 1.0)) {
    return "max_rival_ratio: expected in (0, 1]";
  }
  if (!(max_outweighed_rival_ratio >= 0.0 && max_outweighed_rival_ratio <= 1.0)) {
    return "max_outweighed_rival_ratio: expected in [0, 1] (<= max_rival_ratio: off)";
  }
  if (!(min_rival_margin_sigma > 0.0 && std::isfinite(min_rival_margin_sigma))) {
    return "min_rival_margin_sigma: expected > 0";
  }
  if (rival_max_iterations < 1) return "rival_max_iterations: expected >= 1";
  if (!(rival_min_position_m >= 0.0)) return "rival_min_position_m: expected >= 0";
  if (!(rival_min_rotation_deg >= 0.0)) return "rival_min_rotation_deg: expected >= 0";
  if (!(max_displaced_rival_ratio > 0.0 && max_displaced_rival_ratio <= 100.0)) {
    return "max_displaced_rival_ratio: expected in (0, 100]";
  }
  if (displaced_rival_samples < 1) return "displaced_rival_samples: expected >= 1";
  return "";
}

const char* PoseVerdictName(PoseVerdict verdict) {
  switch (verdict) {
    case PoseVerdict::kAccepted: return "accepted";
    case PoseVerdict::kTooFewInliers: return "too_few_inliers";
    case PoseVerdict::kLowInlierRatio: return "low_inlier_ratio";
    case PoseVerdict::kHighReprojectionError: return "high_reprojection_error";
    case PoseVerdict::kClusteredInliers: return "clustered_inliers";
    case PoseVerdict::kUncertainPose: return "uncertain_pose";
    case PoseVerdict::kAmbiguousPose: return "ambiguous_pose";
  }
  return "unknown";
}

bool ReprojectionResidual(const Camera& camera, const Transformation& T_G_C,
                          const Eigen::Vector3d& p_G, const Eigen::Vector2d& uv,
                          Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 6>* d_e_d_xi,
                          Eigen::Matrix<double, 2, 3>* d_e_d_p_G) {
  // Right perturbation T_G_C Exp(xi): p_C = Exp(-xi) T_C_G p_G ~= p_C - rho - phi x p_C, so
  // d p_C / d rho = -I and d p_C / d phi = [p_C]x (as RefineCameraPose); d p_C / d p_G = R_C_G.
  const Transformation T_C_G = T_G_C.inverse();
  const Eigen::Vector3d p_C = T_C_G * p_G;
  if (p_C.z() <= 1e-6) return false;
  Eigen::Vector2d projected;
  Eigen::Matrix<double, 2, 3> J_uv_p;
  if (camera.Project(p_C, &projected, &J_uv_p) != Camera::ProjectionResult::kValid) return false;
  *residual = projected - uv;
  if (d_e_d_xi != nullptr) {
    Eigen::Matrix<double, 3, 6> J_p_xi;
    J_p_xi.leftCols<3>() = -Eigen::Matrix3d::Identity();
    J_p_xi.rightCols<3>() = Skew(p_C);
    *d_e_d_xi = J_uv_p * J_p_xi;
  }
  if (d_e_d_p_G != nullptr) *d_e_d_p_G = J_uv_p * T_C_G.rotation().toRotationMatrix();
  return true;
}

Eigen::Matrix2d ResidualCovariance(const Eigen::Matrix<double, 2, 3>& d_e_d_p_G,
                                   const Eigen::Matrix3d& covariance_G, double sigma_px) {
  return sigma_px * sigma_px * Eigen::Matrix2d::Identity() +
         d_e_d_p_G * covariance_G * d_e_d_p_G.transpose();
}

void RefineCameraPoseWeighted(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                              const std::vector<Eigen::Vector3d>& p_G,
                              const std::vector<Eigen::Matrix3d>& p_G_covariance,
                              const std::vector<int>& indices, int iterations, double sigma_px,
                              Transformation* T_G_C) {
  if (p_G_covariance.empty()) {
    RefineCameraPose(camera, keypoints, p_G, indices, iterations, sigma_px, T_G_C);
    return;
  }
  // Normal equations (sum J^T W J) dx = -sum J^T W e with W = Sigma_r^-1 at the current pose
  // (iteratively reweighted: Sigma_r depends on the pose through J_l), x <- x Exp(dx).
  for (int it = 0; it < iterations; ++it) {
    Matrix6d H = Matrix6d::Zero();
    Vector6d b = Vector6d::Zero();
    for (int i : indices) {
      Eigen::Vector2d e;
      Eigen::Matrix<double, 2, 6> J;
      Eigen::Matrix<double, 2, 3> J_l;
      if (!ReprojectionResidual(camera, *T_G_C, p_G[i], keypoints[i], &e, &J, &J_l)) continue;
      const Eigen::Matrix2d W =
          ResidualCovariance(J_l, p_G_covariance[static_cast<std::size_t>(i)], sigma_px).inverse();
      H += J.transpose() * W * J;
      b += J.transpose() * W * e;
    }
    const Eigen::LDLT<Matrix6d> ldlt(H);
    if (ldlt.info() != Eigen::Success) return;
    const Vector6d dx = -ldlt.solve(b);
    if (!dx.allFinite()) return;
    *T_G_C = *T_G_C * Transformation::Exp(dx);
    if (dx.norm() < 1e-10) return;
  }
}

bool PoseCovariance(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                    const std::vector<Eigen::Vector3d>& p_G, const std::vector<int>& indices,
                    const Transformation& T_G_C, double sigma_px, Matrix6d* covariance_C,
                    double* residual_sigma_px, const std::vector<Eigen::Matrix3d>& p_G_covariance,
                    CovarianceOf estimator, double* chi2_per_dof) {
  covariance_C->setZero();
  const bool with_landmarks = !p_G_covariance.empty();
  const double sigma2 = sigma_px * sigma_px;
  Matrix6d H = Matrix6d::Zero();    // sum J^T J
  Matrix6d Hw = Matrix6d::Zero();   // sum J^T Sigma_r^-1 J (information of the weighted estimate)
  Matrix6d M = Matrix6d::Zero();    // sum J^T Sigma_r J (noise of the unweighted normal equations)
  double sum2 = 0.0;                // sum |e|^2
  double chi2 = 0.0;                // sum e^T Sigma_r^-1 e
  int n = 0;
  for (int i : indices) {
    Eigen::Vector2d e;
    Eigen::Matrix<double, 2, 6> J;
    Eigen::Matrix<double, 2, 3> J_l;
    if (!ReprojectionResidual(camera, T_G_C, p_G[i], keypoints[i], &e, &J, &J_l)) continue;
    const Eigen::Matrix2d Sigma_r =
        with_landmarks
            ? ResidualCovariance(J_l, p_G_covariance[static_cast<std::size_t>(i)], sigma_px)
            : Eigen::Matrix2d(sigma2 * Eigen::Matrix2d::Identity());
    const Eigen::Matrix2d W = Sigma_r.inverse();
    H += J.transpose() * J;
    Hw += J.transpose() * W * J;
    M += J.transpose() * Sigma_r * J;
    chi2 += e.dot(W * e);
    sum2 += e.squaredNorm();
    ++n;
  }
  if (n < 4) return false;
  // 2n residuals, 6 parameters: the unbiased residual variance per coordinate.
  const double dof = 2.0 * n - 6.0;
  if (residual_sigma_px != nullptr) *residual_sigma_px = std::sqrt(sum2 / dof);
  if (chi2_per_dof != nullptr) *chi2_per_dof = chi2 / dof;
  // The a-posteriori variance factor chi^2 / dof (1 for a correct noise model) inflates the
  // covariance when the residuals are larger than the model says, never shrinks it. Without
  // landmark covariances f sigma^2 = max(sum|e|^2 / dof, sigma^2): the floored residual variance.
  const double f = std::max(1.0, chi2 / dof);
  if (estimator == CovarianceOf::kWeighted) {
    const Eigen::FullPivLU<Matrix6d> lu(Hw);
    if (!lu.isInvertible()) return false;
    *covariance_C = f * lu.inverse();
  } else {
    // x = x_true - H^-1 sum J^T e (one Gauss-Newton step of the unweighted problem), so
    // Cov(x) = H^-1 (sum J^T Sigma_r J) H^-1.
    const Eigen::FullPivLU<Matrix6d> lu(H);
    if (!lu.isInvertible()) return false;
    const Matrix6d H_inv = lu.inverse();
    *covariance_C = f * H_inv * M * H_inv;
    *covariance_C = 0.5 * (*covariance_C + covariance_C->transpose()).eval();
  }
  return covariance_C->allFinite();
}

void ImageSpread(const Camera& camera, const std::vector<Eigen::Vector2d>& points, int grid_cols,
                 int grid_rows, double* cell_fraction, double* hull_fraction) {
  std::vector<char> occupied(static_cast<std::size_t>(grid_cols * grid_rows), 0);
  for (const Eigen::Vector2d& p : points) {
    const int c = std::clamp(static_cast<int>(p.x() * grid_cols / camera.width()), 0, grid_cols - 1);
    const int r = std::clamp(static_cast<int>(p.y() * grid_rows / camera.height()), 0, grid_rows - 1);
    occupied[static_cast<std::size_t>(r * grid_cols + c)] = 1;
  }
  *cell_fraction = static_cast<double>(std::count(occupied.begin(), occupied.end(), 1)) /
                   static_cast<double>(occupied.size());
  *hull_fraction = ConvexHullArea(points) /
                   (static_cast<double>(camera.width()) * static_cast<double>(camera.height()));
}

namespace {

// AcceptPose; `may_adopt`: a displaced rival that explains more matches than the winner may
// replace it (once: the rival's own run has may_adopt false).
AcceptedPose AcceptPoseOnce(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                            const std::vector<Eigen::Vector3d>& p_G, const PoseResult& pose,
                            const PoseRansacOptions& ransac, const PoseAcceptanceOptions& options,
                            const std::vector<Eigen::Matrix3d>& p_G_covariance, bool may_adopt) {
  const std::vector<Eigen::Matrix3d> exact;  // the landmarks taken as exact
  const std::vector<Eigen::Matrix3d>& landmark_covariance =
      options.landmark_uncertainty && p_G_covariance.size() == p_G.size() ? p_G_covariance
                                                                         : exact;
  AcceptedPose out;
  PoseQuality& q = out.quality;
  q.matches = static_cast<int>(std::min(keypoints.size(), p_G.size()));
  out.T_G_C = pose.T_G_C;
  out.inliers = pose.inliers;
  // Refinement with all inliers until the inlier set repeats. Keypoint noise only: weighting
  // by the landmark covariances moved the daemon's fused global poses away from the truth
  // (docs/localizer.md, "Refinement unweighted"); they enter the covariance below.
  std::vector<double> errors = Errors(camera, keypoints, p_G, out.T_G_C);
  for (int round = 0; round < options.refine_rounds && out.inliers.size() >= 3; ++round) {
    Transformation T = out.T_G_C;
    RefineCameraPoseWeighted(camera, keypoints, p_G, exact, out.inliers,
                             std::max(1, ransac.refine_iterations), ransac.keypoint_sigma_px, &T);
    const std::vector<double> e = Errors(camera, keypoints, p_G, T);
    const std::vector<int> inliers = Below(e, ransac.threshold_px);
    ++q.refine_rounds;
    if (inliers.size() < 3) break;  // the refinement diverged: keep the last good pose
    out.T_G_C = T;
    errors = e;
    const bool same = inliers == out.inliers;
    out.inliers = inliers;
    if (same) break;
  }
  out.inliers = Below(errors, ransac.threshold_px);
  q.inliers = static_cast<int>(out.inliers.size());
  q.inlier_ratio = q.matches > 0 ? static_cast<double>(q.inliers) / q.matches : 0.0;
  q.required_inliers = std::max(
      ransac.min_inliers, static_cast<int>(std::ceil(options.min_inlier_ratio * q.matches - 1e-9)));
  std::vector<double> inlier_errors;
  double sum2 = 0.0;
  for (int i : out.inliers) {
    inlier_errors.push_back(errors[static_cast<std::size_t>(i)]);
    sum2 += errors[static_cast<std::size_t>(i)] * errors[static_cast<std::size_t>(i)];
  }
  out.rms_reprojection_px = out.inliers.empty() ? 0.0 : std::sqrt(sum2 / out.inliers.size());
  const bool have_covariance =
      PoseCovariance(camera, keypoints, p_G, out.inliers, out.T_G_C, ransac.keypoint_sigma_px,
                     &out.covariance_C, &q.residual_sigma_px, landmark_covariance,
                     options.unweighted_covariance ? CovarianceOf::kUnweighted
                                                   : CovarianceOf::kWeighted,
                     &q.chi2_per_dof);
  {
    const int iters = std::max(1, ransac.refine_iterations);
    const SplitConsistency si =
        SplitHalfConsistency(camera, keypoints, p_G, out.inliers, out.T_G_C, iters,
                             ransac.keypoint_sigma_px, landmark_covariance, SplitAxis::kImageAxis);
    if (si.valid) {
      q.split_image_position_m = si.position_m;
      q.split_image_rotation_deg = si.rotation_deg;
      q.split_image_mahalanobis2 = si.mahalanobis2;
    }
    const SplitConsistency sd =
        SplitHalfConsistency(camera, keypoints, p_G, out.inliers, out.T_G_C, iters,
                             ransac.keypoint_sigma_px, landmark_covariance, SplitAxis::kDepth);
    if (sd.valid) {
      q.split_depth_position_m = sd.position_m;
      q.split_depth_rotation_deg = sd.rotation_deg;
      q.split_depth_mahalanobis2 = sd.mahalanobis2;
    }
  }
  // Fail(v): the first failing gate sets the verdict; the checks stop there unless
  // options.measure_all_gates asks for every gate's value (diagnostics; the verdict is the same).
  bool failed = false;
  auto fail = [&](PoseVerdict verdict) {
    if (!failed) out.verdict = verdict;
    failed = true;
    return !options.measure_all_gates;
  };
  if (q.inliers < ransac.min_inliers && fail(PoseVerdict::kTooFewInliers)) return out;
  if (q.inliers < q.required_inliers && fail(PoseVerdict::kLowInlierRatio)) return out;
  if (inlier_errors.empty()) return out;  // measure_all_gates with no inlier: nothing to measure
  q.median_error_px = Quantile(inlier_errors, 0.5);
  q.p90_error_px = Quantile(inlier_errors, 0.9);
  if ((q.median_error_px > options.max_median_error_ratio * ransac.threshold_px ||
       q.p90_error_px > options.max_p90_error_ratio * ransac.threshold_px) &&
      fail(PoseVerdict::kHighReprojectionError)) {
    return out;
  }
  std::vector<Eigen::Vector2d> points;
  for (int i : out.inliers) points.push_back(keypoints[static_cast<std::size_t>(i)]);
  ImageSpread(camera, points, options.grid_cols, options.grid_rows, &q.cell_fraction,
              &q.hull_fraction);
  if ((q.cell_fraction < options.min_cell_fraction || q.hull_fraction < options.min_hull_fraction) &&
      fail(PoseVerdict::kClusteredInliers)) {
    return out;
  }
  if (have_covariance) {
    q.position_sigma_m = LargestSigma(out.covariance_C.topLeftCorner<3, 3>());
    q.rotation_sigma_deg = LargestSigma(out.covariance_C.bottomRightCorner<3, 3>()) * 180.0 / M_PI;
  }
  if ((!have_covariance || q.position_sigma_m > options.max_position_sigma_m ||
       q.rotation_sigma_deg > options.max_rotation_sigma_deg) &&
      fail(PoseVerdict::kUncertainPose)) {
    return out;
  }
  if (options.rival_check) {
    // The matches the winner does not explain (error beyond rival_exclusion_factor x the
    // threshold). Keypoints that are winner inliers stay in the pool with their OTHER
    // landmarks: repetitive structure is exactly one keypoint matched to two places.
    std::vector<Eigen::Vector2d> rival_keypoints;
    std::vector<Eigen::Vector3d> rival_points;
    for (std::size_t i = 0; i < static_cast<std::size_t>(q.matches); ++i) {
      if (errors[i] <= options.rival_exclusion_factor * ransac.threshold_px) continue;
      rival_keypoints.push_back(keypoints[i]);
      rival_points.push_back(p_G[i]);
    }
    q.rival_inliers = 0;
    PoseRansacOptions rival_options = ransac;
    rival_options.min_inliers = 4;
    // Only a rival at the gate matters: with r = its share of the pool, RANSAC finds such a
    // model with ransac.probability after log(1 - p) / log(1 - r^3) samples; no need for more.
    const double gate_inliers = std::max(4.0, std::ceil(options.max_rival_ratio * q.inliers));
    const double r = std::min(1.0, gate_inliers / std::max<std::size_t>(1, rival_keypoints.size()));
    const double needed = r >= 1.0 ? 1.0
                                   : std::ceil(std::log(1.0 - ransac.probability) /
                                               std::log(1.0 - r * r * r));
    rival_options.max_iterations =
        static_cast<int>(std::min<double>(options.rival_max_iterations, std::max(1.0, needed)));
    rival_options.seed = ransac.seed + 1;
    if (rival_keypoints.size() >= 4) {
      const PoseResult rival = EstimateCameraPose(camera, rival_keypoints, rival_points, rival_options);
      if (rival.status == PoseStatus::kOk || rival.status == PoseStatus::kTooFewInliers) {
        q.rival_position_m = (rival.T_G_C.translation() - out.T_G_C.translation()).norm();
        q.rival_rotation_deg =
            AngleBetween(rival.T_G_C.rotation(), out.T_G_C.rotation()) * 180.0 / M_PI;
        const bool same_answer = q.rival_position_m <= options.rival_min_position_m &&
                                 q.rival_rotation_deg <= options.rival_min_rotation_deg;
        q.rival_inliers = same_answer ? 0 : static_cast<int>(rival.inliers.size());
      }
    }
    q.rival_ratio = static_cast<double>(q.rival_inliers) / q.inliers;
    // Sign test (pose_acceptance.h): the winner's margin in standard deviations of n_w - n_r
    // under "both equally right".
    q.rival_margin_sigma = (q.inliers - q.rival_inliers) /
                           std::sqrt(static_cast<double>(std::max(1, q.inliers + q.rival_inliers)));
    const bool outweighed = q.rival_ratio <= options.max_outweighed_rival_ratio &&
                            q.rival_margin_sigma >= options.min_rival_margin_sigma;
    if (q.rival_ratio > options.max_rival_ratio && !outweighed &&
        fail(PoseVerdict::kAmbiguousPose)) {
      return out;
    }
  }
  if (options.displaced_rival_check) {
    DisplacedRivalOptions d;
    d.samples = options.displaced_rival_samples;
    d.threshold_px = ransac.threshold_px;
    d.min_position_m = options.rival_min_position_m;
    d.min_rotation_deg = options.rival_min_rotation_deg;
    d.refine_iterations = std::max(1, ransac.refine_iterations);
    d.seed = ransac.seed + 2;
    const DisplacedRival rival =
        FindDisplacedRival(camera, keypoints, p_G, out.inliers, errors, out.T_G_C, d);
    q.displaced_rival_inliers = rival.found ? rival.inliers : 0;
    q.displaced_rival_ratio = static_cast<double>(q.displaced_rival_inliers) / q.inliers;
    q.displaced_rival_position_m = rival.position_m;
    q.displaced_rival_rotation_deg = rival.rotation_deg;
    if (!failed && may_adopt && rival.found && q.displaced_rival_inliers > q.inliers) {
      // RANSAC's own criterion (most inliers) prefers the rival: the P3P samples missed it
      // (it needs a match the winner rejects, e.g. at another depth). It replaces the winner
      // and goes through every gate itself, the displaced-rival search included (the old
      // winner is now a displaced rival with fewer inliers).
      PoseResult adopted;
      adopted.status = PoseStatus::kOk;
      adopted.T_G_C = rival.T_G_C;
      adopted.inliers = Below(Errors(camera, keypoints, p_G, rival.T_G_C), ransac.threshold_px);
      AcceptedPose again = AcceptPoseOnce(camera, keypoints, p_G, adopted, ransac, options,
                                          p_G_covariance, /*may_adopt=*/false);
      again.quality.adopted_displaced_rival = true;
      return again;
    }
    // A tie (ratio 1 at the default) is ambiguous too: the data explain the displaced pose as
    // well as the winner, so they do not pick the winner (docs/localizer.md, "The simulated
    // sessions re-rendered": room-s4 frame 570, 2.05 deg off with a rival of equal support).
    if (q.displaced_rival_ratio >= options.max_displaced_rival_ratio &&
        fail(PoseVerdict::kAmbiguousPose)) {
      return out;
    }
  }
  if (!failed) out.verdict = PoseVerdict::kAccepted;
  return out;
}

}  // namespace

AcceptedPose AcceptPose(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                        const std::vector<Eigen::Vector3d>& p_G, const PoseResult& pose,
                        const PoseRansacOptions& ransac, const PoseAcceptanceOptions& options,
                        const std::vector<Eigen::Matrix3d>& p_G_covariance) {
  return AcceptPoseOnce(camera, keypoints, p_G, pose, ransac, options, p_G_covariance,
                        options.adopt_displaced_rival);
}

}  // namespace vilma::localizer

#include "vilma/estimator/vi_alignment.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "vilma/estimator/filter_state.h"

namespace vilma::estimator {
namespace {

using Mat11 = Eigen::Matrix<double, kAlignDim, kAlignDim>;
using Vec11 = Eigen::Matrix<double, kAlignDim, 1>;
using Mat11x3 = Eigen::Matrix<double, kAlignDim, 3>;

// A feature's 3x3 block is usable when it is well conditioned: its observations see it from
// different places (parallax), not along one ray.
bool Invertible(const Eigen::Matrix3d& H, Eigen::Matrix3d* H_inv) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(H);
  const Eigen::Vector3d d = eig.eigenvalues();
  if (!(d(0) > 1e-10 * d(2)) || !(d(2) > 0.0)) return false;
  *H_inv = eig.eigenvectors() * d.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
  return true;
}

std::vector<int> CountPerFeature(const AlignmentInput& input) {
  std::vector<int> count(static_cast<std::size_t>(input.num_features), 0);
  for (const AlignmentObservation& o : input.observations) {
    ++count[static_cast<std::size_t>(o.feature)];
  }
  return count;
}

// Normal equations of the refinement at the current parameters, features eliminated into the
// reduced 11x11 system S dc = s. Also returns the cost and per-feature blocks for the
// back-substitution.
struct Normal {
  double cost = 0.0;
  Mat11 S = Mat11::Zero();
  Vec11 s = Vec11::Zero();
  std::vector<Eigen::Matrix3d> H_ff_inv;
  std::vector<Mat11x3> H_cf;
  std::vector<Eigen::Vector3d> g_f;
  int inliers = 0;
  double inlier_sq = 0.0;
};

}  // namespace

Eigen::Vector3d MinimizeQuadraticOnSphere(const Eigen::Matrix3d& A, const Eigen::Vector3d& b,
                                          double radius) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A);
  const Eigen::Vector3d d = eig.eigenvalues();  // increasing
  const Eigen::Vector3d c = eig.eigenvectors().transpose() * b;
  // |g(lambda)|^2 = sum c_i^2 / (d_i + lambda)^2 decreases on (-d_0, inf) and is <= radius^2 at
  // lambda = -d_0 + |c| / radius: bisection between.
  auto norm2 = [&](double lambda) {
    return (c.array() / (d.array() + lambda)).square().sum();
  };
  const double r2 = radius * radius;
  double lo = -d(0), hi = -d(0) + c.norm() / radius + 1e-12;
  Eigen::Vector3d y;
  const double tiny = 1e-12 * (std::abs(d(0)) + std::abs(d(2)) + 1.0);
  if (norm2(lo + tiny) <= r2) {
    // "Hard case": b has (almost) no component along the smallest eigenvector; the minimizer
    // is lambda = -d_0 and the missing length goes along that eigenvector.
    y = c.array() / (d.array() - d(0));
    y(0) = 0.0;
    for (int i = 1; i < 3; ++i) {
      if (!(std::abs(d(i) - d(0)) > tiny)) y(i) = 0.0;
    }
    y(0) = std::sqrt(std::max(0.0, r2 - y.squaredNorm()));
    if (c(0) < 0.0) y(0) = -y(0);
  } else {
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (norm2(mid) > r2) {
        lo = mid;
      } else {
        hi = mid;
      }
    }
    const double lambda = 0.5 * (lo + hi);
    y = c.array() / (d.array() + lambda);
  }
  return eig.eigenvectors() * y;
}

bool AlignmentResidual(const Eigen::Vector3d& v_I0, const Eigen::Vector3d& u_I0, double G,
                       const PreintegratedImu& pre, const Transformation& T_I_C,
                       const Eigen::Vector3d& p_I0_f, const Eigen::Vector3d& bearing_C,
                       Eigen::Vector2d* r, Eigen::Matrix<double, 2, 14>* J) {
  const double t = pre.dt_s;
  const Eigen::Matrix3d R_0k = pre.q_0_k.toRotationMatrix();
  const Eigen::Matrix3d R_C_I = T_I_C.rotation().toRotationMatrix().transpose();
  const Eigen::Vector3d p_Ik = v_I0 * t + 0.5 * G * t * t * u_I0 + pre.alpha;
  const Eigen::Vector3d q = R_0k.transpose() * (p_I0_f - p_Ik);
  const Eigen::Vector3d p_C = R_C_I * (q - T_I_C.translation());
  const double depth = p_C.norm();
  if (!(depth > 1e-9)) return false;
  const Eigen::Vector3d n = p_C / depth;
  if (n.dot(bearing_C) <= 0.0) return false;  // behind the camera
  const Eigen::Matrix<double, 3, 2> B = BearingBasis(bearing_C);
  *r = B.transpose() * n;
  if (J == nullptr) return true;
  // d r / d q = B^T (I - n n^T) / |p_C| R_C_I.
  const Eigen::Matrix<double, 2, 3> D =
      B.transpose() * (Eigen::Matrix3d::Identity() - n * n.transpose()) / depth * R_C_I;
  const Eigen::Matrix<double, 2, 3> D_p = -D * R_0k.transpose();  // d r / d p_Ik
  J->block<2, 3>(0, kAlignV) = D_p * t;
  J->block<2, 2>(0, kAlignG) = D_p * (0.5 * G * t * t) * BearingBasis(u_I0);
  // R_0k(b_g + d) = R_0k Exp(J_R d): q -> Exp(-J_R d) q ~ q + [q]x J_R d.
  J->block<2, 3>(0, kAlignBg) = D * Skew(q) * pre.d_R_d_bg + D_p * pre.d_alpha_d_bg;
  J->block<2, 3>(0, kAlignBa) = D_p * pre.d_alpha_d_ba;
  J->block<2, 3>(0, 11) = D * R_0k.transpose();
  return true;
}

bool SolveLinearAlignment(const AlignmentInput& input, const std::vector<PreintegratedImu>& pre,
                          AlignmentSolution* solution, std::string* why_not) {
  const std::size_t nf = static_cast<std::size_t>(input.num_features);
  const std::vector<int> count = CountPerFeature(input);
  const Eigen::Matrix3d R_C_I = input.T_I_C.rotation().toRotationMatrix().transpose();
  const Eigen::Vector3d p_I_C = input.T_I_C.translation();
  // Unknowns c = (v_0, g) and p_f. Rows: M p_f - t M v_0 - t^2/2 M g = M alpha + B^T R_C_I p_I_C
  // with M = B^T R_C_I R_0k^T. Two passes: unit weights, then 1/depth (bearing-angle units).
  std::vector<double> inv_depth(input.observations.size(), 1.0);
  std::vector<Eigen::Matrix3d> H_ff(nf), H_ff_inv(nf);
  std::vector<Eigen::Matrix<double, 3, 6>> H_fc(nf);
  std::vector<Eigen::Vector3d> b_f(nf);
  solution->p_I0_f.assign(nf, Eigen::Vector3d::Zero());
  solution->feature_valid.assign(nf, false);
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t f = 0; f < nf; ++f) {
      H_ff[f].setZero();
      H_fc[f].setZero();
      b_f[f].setZero();
    }
    Eigen::Matrix<double, 6, 6> H_cc = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> b_c = Eigen::Matrix<double, 6, 1>::Zero();
    for (std::size_t i = 0; i < input.observations.size(); ++i) {
      const AlignmentObservation& o = input.observations[i];
      const std::size_t f = static_cast<std::size_t>(o.feature);
      if (count[f] < 2) continue;
      const PreintegratedImu& p = pre[static_cast<std::size_t>(o.frame)];
      const double t = p.dt_s;
      const Eigen::Matrix<double, 3, 2> B = BearingBasis(o.bearing_C);
      const Eigen::Matrix<double, 2, 3> M =
          inv_depth[i] * B.transpose() * R_C_I * p.q_0_k.toRotationMatrix().transpose();
      Eigen::Matrix<double, 2, 6> A_c;
      A_c << -t * M, -0.5 * t * t * M;
      const Eigen::Vector2d y = M * p.alpha + inv_depth[i] * B.transpose() * R_C_I * p_I_C;
      H_ff[f] += M.transpose() * M;
      H_fc[f] += M.transpose() * A_c;
      b_f[f] += M.transpose() * y;
      H_cc += A_c.transpose() * A_c;
      b_c += A_c.transpose() * y;
    }
    Eigen::Matrix<double, 6, 6> S = H_cc;
    Eigen::Matrix<double, 6, 1> s = b_c;
    int usable = 0;
    for (std::size_t f = 0; f < nf; ++f) {
      solution->feature_valid[f] = count[f] >= 2 && Invertible(H_ff[f], &H_ff_inv[f]);
      if (!solution->feature_valid[f]) continue;
      ++usable;
      S -= H_fc[f].transpose() * H_ff_inv[f] * H_fc[f];
      s -= H_fc[f].transpose() * H_ff_inv[f] * b_f[f];
    }
    if (usable < 3) {
      *why_not = "fewer than 3 features with parallax";
      return false;
    }
    // Eliminate v_0, then g on the sphere |g| = G.
    const Eigen::Matrix3d S_vv = S.topLeftCorner<3, 3>();
    const Eigen::LDLT<Eigen::Matrix3d> S_vv_ldlt(S_vv);
    if (S_vv_ldlt.info() != Eigen::Success || !(S_vv_ldlt.vectorD().minCoeff() > 0.0)) {
      *why_not = "velocity not observable (no translation)";
      return false;
    }
    const Eigen::Matrix3d S_gg = S.bottomRightCorner<3, 3>() -
                                 S.bottomLeftCorner<3, 3>() * S_vv_ldlt.solve(S.topRightCorner<3, 3>());
    const Eigen::Vector3d s_g =
        s.tail<3>() - S.bottomLeftCorner<3, 3>() * S_vv_ldlt.solve(s.head<3>());
    const Eigen::LDLT<Eigen::Matrix3d> S_gg_ldlt(S_gg);
    solution->unconstrained_gravity_norm =
        S_gg_ldlt.info() == Eigen::Success ? S_gg_ldlt.solve(s_g).norm() : 0.0;
    const Eigen::Vector3d g = MinimizeQuadraticOnSphere(S_gg, s_g, input.gravity_magnitude);
    if (!g.allFinite()) {
      *why_not = "gravity not observable";
      return false;
    }
    solution->g_I0 = g;
    solution->v_I0 = S_vv_ldlt.solve(s.head<3>() - S.topRightCorner<3, 3>() * g);
    Eigen::Matrix<double, 6, 1> c;
    c << solution->v_I0, g;
    for (std::size_t f = 0; f < nf; ++f) {
      if (solution->feature_valid[f]) {
        solution->p_I0_f[f] = H_ff_inv[f] * (b_f[f] - H_fc[f] * c);
      }
    }
    // Weights for the second pass: the residual B^T p_C is in metres at the point's depth.
    for (std::size_t i = 0; i < input.observations.size(); ++i) {
      const AlignmentObservation& o = input.observations[i];
      const std::size_t f = static_cast<std::size_t>(o.feature);
      if (!solution->feature_valid[f]) continue;
      const PreintegratedImu& p = pre[static_cast<std::size_t>(o.frame)];
      const double t = p.dt_s;
      const Eigen::Vector3d p_Ik = solution->v_I0 * t + 0.5 * t * t * g + p.alpha;
      const Eigen::Vector3d p_C =
          R_C_I * (p.q_0_k.conjugate() * (solution->p_I0_f[f] - p_Ik) - p_I_C);
      inv_depth[i] = 1.0 / std::max(0.1, p_C.norm());  // points closer than 10 cm: outliers
    }
  }
  return true;
}

namespace {

Normal BuildNormal(const AlignmentInput& input, const AlignmentOptions& options,
                   const std::vector<PreintegratedImu>& pre, const AlignmentSolution& x) {
  const std::size_t nf = static_cast<std::size_t>(input.num_features);
  const double G = input.gravity_magnitude;
  const Eigen::Vector3d u = x.g_I0 / x.g_I0.norm();
  Normal n;
  std::vector<Eigen::Matrix3d> H_ff(nf, Eigen::Matrix3d::Zero());
  n.H_cf.assign(nf, Mat11x3::Zero());
  n.g_f.assign(nf, Eigen::Vector3d::Zero());
  n.H_ff_inv.assign(nf, Eigen::Matrix3d::Zero());
  const double inv_sigma = 1.0 / options.bearing_sigma;
  Eigen::Vector2d r;
  Eigen::Matrix<double, 2, 14> J;
  for (const AlignmentObservation& o : input.observations) {
    const std::size_t f = static_cast<std::size_t>(o.feature);
    if (!x.feature_valid[f]) continue;
    if (!AlignmentResidual(x.v_I0, u, G, pre[static_cast<std::size_t>(o.frame)], input.T_I_C,
                           x.p_I0_f[f], o.bearing_C, &r, &J)) {
      // Behind the camera at this estimate: counts as a full outlier, no information.
      n.cost += options.huber_sigmas * (20.0 - 0.5 * options.huber_sigmas);
      continue;
    }
    const double e = r.norm() * inv_sigma;  // in sigmas
    double w = 1.0;                         // Huber: quadratic below k, linear above
    if (e <= options.huber_sigmas) {
      n.cost += 0.5 * e * e;
    } else {
      n.cost += options.huber_sigmas * (e - 0.5 * options.huber_sigmas);
      w = options.huber_sigmas / e;
    }
    if (e < 3.0) {
      ++n.inliers;
      n.inlier_sq += r.squaredNorm();
    }
    const double ws = w * inv_sigma * inv_sigma;
    const auto Jc = J.leftCols<kAlignDim>();
    const auto Jf = J.rightCols<3>();
    n.S += ws * Jc.transpose() * Jc;
    n.s -= ws * Jc.transpose() * r;
    n.H_cf[f] += ws * Jc.transpose() * Jf;
    H_ff[f] += ws * Jf.transpose() * Jf;
    n.g_f[f] -= ws * Jf.transpose() * r;
  }
  // Bias priors around 0.
  const double wg = 1.0 / (options.gyro_bias_sigma * options.gyro_bias_sigma);
  const double wa = 1.0 / (options.accel_bias_sigma * options.accel_bias_sigma);
  n.cost += 0.5 * (wg * x.b_g.squaredNorm() + wa * x.b_a.squaredNorm());
  n.S.block<3, 3>(kAlignBg, kAlignBg).diagonal().array() += wg;
  n.S.block<3, 3>(kAlignBa, kAlignBa).diagonal().array() += wa;
  n.s.segment<3>(kAlignBg) -= wg * x.b_g;
  n.s.segment<3>(kAlignBa) -= wa * x.b_a;
  for (std::size_t f = 0; f < nf; ++f) {
    if (!x.feature_valid[f]) continue;
    H_ff[f].diagonal().array() += 1e-9;  // a point seen only at this estimate's edge
    n.H_ff_inv[f] = H_ff[f].inverse();
    n.S -= n.H_cf[f] * n.H_ff_inv[f] * n.H_cf[f].transpose();
    n.s -= n.H_cf[f] * n.H_ff_inv[f] * n.g_f[f];
  }
  return n;
}

}  // namespace

bool RefineAlignment(const AlignmentInput& input, const AlignmentOptions& options,
                     AlignmentSolution* solution, std::string* why_not) {
  AlignmentSolution& x = *solution;
  const std::size_t nf = static_cast<std::size_t>(input.num_features);
  std::vector<PreintegratedImu> pre = PreintegrateImu(input.imu, input.frame_t_ns, x.b_g, x.b_a);
  Normal n = BuildNormal(input, options, pre, x);
  double lambda = 1e-4;
  x.iterations = 0;
  for (int it = 0; it < options.max_iterations; ++it) {
    ++x.iterations;
    // Levenberg-Marquardt on the reduced system: the damping acts on the core parameters.
    Mat11 S = n.S;
    S.diagonal() += lambda * n.S.diagonal().cwiseMax(1e-9);
    const Vec11 dc = S.ldlt().solve(n.s);
    if (!dc.allFinite()) break;
    AlignmentSolution trial = x;
    trial.v_I0 += dc.segment<3>(kAlignV);
    const Eigen::Vector3d u = BearingBoxPlus(x.g_I0 / x.g_I0.norm(), dc.segment<2>(kAlignG));
    trial.g_I0 = input.gravity_magnitude * u.normalized();
    trial.b_g += dc.segment<3>(kAlignBg);
    trial.b_a += dc.segment<3>(kAlignBa);
    for (std::size_t f = 0; f < nf; ++f) {
      if (!x.feature_valid[f]) continue;
      trial.p_I0_f[f] += n.H_ff_inv[f] * (n.g_f[f] - n.H_cf[f].transpose() * dc);
    }
    std::vector<PreintegratedImu> trial_pre =
        PreintegrateImu(input.imu, input.frame_t_ns, trial.b_g, trial.b_a);
    Normal trial_n = BuildNormal(input, options, trial_pre, trial);
    if (trial_n.cost < n.cost) {
      const double decrease = (n.cost - trial_n.cost) / std::max(1e-12, n.cost);
      x = trial;
      pre.swap(trial_pre);
      n = std::move(trial_n);
      lambda = std::max(1e-7, lambda * 0.3);
      if (decrease < 1e-6) break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e6) break;
    }
  }
  // Covariance of the core parameters: the inverse of the reduced information matrix.
  const Eigen::LDLT<Mat11> ldlt(n.S);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) {
    *why_not = "refinement: singular information matrix";
    return false;
  }
  x.covariance = ldlt.solve(Mat11::Identity());
  x.covariance = 0.5 * (x.covariance + x.covariance.transpose()).eval();
  x.inliers = n.inliers;
  x.observations_used = 0;
  for (const AlignmentObservation& o : input.observations) {
    if (x.feature_valid[static_cast<std::size_t>(o.feature)]) ++x.observations_used;
  }
  x.rms_inlier_rad = n.inliers > 0 ? std::sqrt(n.inlier_sq / (2.0 * n.inliers)) : 0.0;
  return true;
}

}  // namespace vilma::estimator

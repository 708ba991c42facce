#include "vilma/estimator/filter_state.h"

#include <algorithm>
#include <cmath>

#include "vilma/core/geometry.h"

namespace vilma::estimator {

Eigen::Matrix<double, 3, 2> BearingBasis(const Eigen::Vector3d& mu) {
  // Rodrigues for the rotation e_z -> mu: R = c I + [k]x + k k^T / (1 + c), k = e_z x mu,
  // c = mu_z (|k| = sin). Its columns 0 and 1 are R e_x and R e_y.
  const double c = mu.z();
  const double k0 = -mu.y(), k1 = mu.x();  // k = (-mu_y, mu_x, 0)
  const double f = 1.0 / (1.0 + c);
  Eigen::Matrix<double, 3, 2> B;
  B(0, 0) = c + k0 * k0 * f;
  B(1, 0) = k0 * k1 * f;
  B(2, 0) = -k1;
  B(0, 1) = k0 * k1 * f;
  B(1, 1) = c + k1 * k1 * f;
  B(2, 1) = k0;
  return B;
}

Eigen::Vector3d BearingBoxPlus(const Eigen::Vector3d& mu, const Eigen::Vector2d& d) {
  const Eigen::Vector3d u = BearingBasis(mu) * d;  // tangent direction, |u| = angle
  return (ExpSO3(mu.cross(u)) * mu).normalized();
}

Eigen::Vector2d BearingBoxMinus(const Eigen::Vector3d& mu1, const Eigen::Vector3d& mu0) {
  // Angle between the bearings along the great circle, direction projected into the tangent.
  const Eigen::Vector3d t = mu1 - mu0.dot(mu1) * mu0;
  const double s = t.norm();
  const double angle = std::atan2(s, mu0.dot(mu1));
  if (s < 1e-15) return Eigen::Vector2d::Zero();
  return BearingBasis(mu0).transpose() * (t * (angle / s));
}

int FilterState::num_active() const {
  int n = 0;
  for (const FeatureState& f : features) n += f.active ? 1 : 0;
  return n;
}

void BoxPlus(const FilterState& x, const Eigen::VectorXd& dx, FilterState* r) {
  if (r != &x) *r = x;
  r->p_M_I = x.p_M_I + dx.segment<3>(kIdxP);
  r->v_M = x.v_M + dx.segment<3>(kIdxV);
  r->q_M_I = (x.q_M_I * ExpSO3(dx.segment<3>(kIdxQ))).normalized();
  r->b_g = x.b_g + dx.segment<3>(kIdxBg);
  r->b_a = x.b_a + dx.segment<3>(kIdxBa);
  r->q_I_C = (x.q_I_C * ExpSO3(dx.segment<3>(kIdxQIC))).normalized();
  r->p_I_C = x.p_I_C + dx.segment<3>(kIdxPIC);
  r->td = x.td + dx[kIdxTd];
  for (std::size_t i = 0; i < x.features.size(); ++i) {
    if (!x.features[i].active) continue;
    const int k = FeatureIndex(static_cast<int>(i));
    r->features[i].mu_C = BearingBoxPlus(x.features[i].mu_C, dx.segment<2>(k));
    r->features[i].rho = x.features[i].rho + dx[k + 2];
  }
}

Eigen::VectorXd BoxMinus(const FilterState& a, const FilterState& b) {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(b.dim());
  d.segment<3>(kIdxP) = a.p_M_I - b.p_M_I;
  d.segment<3>(kIdxV) = a.v_M - b.v_M;
  d.segment<3>(kIdxQ) = LogSO3(b.q_M_I.conjugate() * a.q_M_I);
  d.segment<3>(kIdxBg) = a.b_g - b.b_g;
  d.segment<3>(kIdxBa) = a.b_a - b.b_a;
  d.segment<3>(kIdxQIC) = LogSO3(b.q_I_C.conjugate() * a.q_I_C);
  d.segment<3>(kIdxPIC) = a.p_I_C - b.p_I_C;
  d[kIdxTd] = a.td - b.td;
  for (std::size_t i = 0; i < b.features.size(); ++i) {
    if (!b.features[i].active) continue;
    const int k = FeatureIndex(static_cast<int>(i));
    d.segment<2>(k) = BearingBoxMinus(a.features[i].mu_C, b.features[i].mu_C);
    d[k + 2] = a.features[i].rho - b.features[i].rho;
  }
  return d;
}

bool MedianInverseDepth(const FilterState& x, const Eigen::MatrixXd& P, double max_ratio,
                        int min_count, double* rho) {
  std::vector<double> known;
  for (std::size_t i = 0; i < x.features.size(); ++i) {
    const FeatureState& f = x.features[i];
    if (!f.active || !(f.rho > 0.0)) continue;
    const int k = FeatureIndex(static_cast<int>(i)) + 2;
    if (std::sqrt(std::max(0.0, P(k, k))) <= max_ratio * f.rho) known.push_back(f.rho);
  }
  if (static_cast<int>(known.size()) < min_count || known.empty()) return false;
  const auto mid = known.begin() + static_cast<std::ptrdiff_t>(known.size() / 2);
  std::nth_element(known.begin(), mid, known.end());
  *rho = *mid;
  return true;
}

}  // namespace vilma::estimator

// Variance component estimation (variance_components.h).
#include "variance_components.h"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace vilma::mapping::vi_problem {

NoiseFactors EstimateVarianceComponents(ceres::Problem* problem,
                                        const std::vector<InertialBlock>& inertial,
                                        const std::vector<ceres::ResidualBlockId>& visual,
                                        int probes, double min_redundancy) {
  NoiseFactors out;
  // Rows: the inertial blocks (15 each) first, then the reprojection blocks, in this order.
  ceres::Problem::EvaluateOptions evaluate;
  for (const InertialBlock& b : inertial) evaluate.residual_blocks.push_back(b.residual);
  std::size_t visual_rows = 0;
  for (ceres::ResidualBlockId id : visual) {
    evaluate.residual_blocks.push_back(id);
    visual_rows +=
        static_cast<std::size_t>(problem->GetCostFunctionForResidualBlock(id)->num_residuals());
  }
  if (evaluate.residual_blocks.empty()) return out;
  // Raw whitened residuals; the robust loss enters as each observation's IRLS weight ρ'(s) on
  // its Jacobian rows (the information it gave the solve), and the visual chi² is taken robustly
  // (below).
  evaluate.apply_loss_function = false;
  evaluate.num_threads = 1;
  double cost = 0.0;
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(evaluate, &cost, &residuals, nullptr, &crs)) {
    throw std::runtime_error("variance components: the problem could not be evaluated");
  }
  const std::size_t inertial_rows = 15 * inertial.size();
  if (residuals.size() != inertial_rows + visual_rows) {
    throw std::logic_error("variance components: unexpected residual count");
  }

  // IRLS weights: ρ'(s) of each reprojection block's loss at s = |r|².
  std::vector<double> row_weight(residuals.size(), 1.0);
  {
    std::size_t row = inertial_rows;
    for (ceres::ResidualBlockId id : visual) {
      const int m = problem->GetCostFunctionForResidualBlock(id)->num_residuals();
      const ceres::LossFunction* loss = problem->GetLossFunctionForResidualBlock(id);
      double sq = 0.0;
      for (int i = 0; i < m; ++i) sq += residuals[row + i] * residuals[row + i];
      double rho[3] = {sq, 1.0, 0.0};
      if (loss != nullptr) loss->Evaluate(sq, rho);
      for (int i = 0; i < m; ++i) row_weight[row + i] = std::max(rho[1], 0.0);
      row += static_cast<std::size_t>(m);
    }
  }

  // The whitened (and weighted) Jacobian without the held (all-zero) columns.
  std::vector<int> column(static_cast<std::size_t>(crs.num_cols), -1);
  for (std::size_t k = 0; k < crs.values.size(); ++k) {
    if (crs.values[k] != 0.0) column[static_cast<std::size_t>(crs.cols[k])] = 0;
  }
  int n = 0;
  for (int& c : column) {
    if (c == 0) c = n++;
  }
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(crs.values.size());
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
      const int c = column[static_cast<std::size_t>(crs.cols[k])];
      if (c >= 0 && crs.values[k] != 0.0) {
        triplets.emplace_back(r, c,
                              std::sqrt(row_weight[static_cast<std::size_t>(r)]) * crs.values[k]);
      }
    }
  }
  Eigen::SparseMatrix<double> J(crs.num_rows, n);
  J.setFromTriplets(triplets.begin(), triplets.end());
  // N = Jᵀ J with Jacobi scaling D = diag(N)^-1/2 (units: metres, radians, m/s mixed). diag(N)
  // is the columns' squared norms, so only the scaled product is formed (the sparse product is
  // most of the estimate's time).
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
  for (int c = 0; c < n; ++c) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(J, c); it; ++it) {
      d[c] += it.value() * it.value();
    }
  }
  for (int c = 0; c < n; ++c) d[c] = 1.0 / std::sqrt(std::max(d[c], 1e-300));
  const Eigen::SparseMatrix<double> Js = J * d.asDiagonal();
  Eigen::SparseMatrix<double> Ns = (Js.transpose() * Js).pruned();
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> llt;
  llt.compute(Ns);
  if (llt.info() != Eigen::Success) {
    // A direction the gauge left free (e.g. optv without a far vertex): regularize slightly.
    Eigen::SparseMatrix<double> I(n, n);
    I.setIdentity();
    Ns += 1e-9 * I;
    llt.compute(Ns);
    if (llt.info() != Eigen::Success) {
      throw std::runtime_error("variance components: the normal matrix is not positive definite");
    }
  }

  // Per edge: G_k = U Σ_k Uᵀ with U the residual's square root information.
  constexpr int kImu = 4;
  std::vector<std::array<Eigen::Matrix<double, 15, 15>, kImu>> G(inertial.size());
  for (std::size_t e = 0; e < inertial.size(); ++e) {
    const ImuPreintegration& pre = *inertial[e].preintegration;
    const Eigen::Matrix<double, 15, 15> information = pre.full_covariance().inverse();
    const Eigen::Matrix<double, 15, 15> U = information.llt().matrixU();
    const auto parts = pre.NoiseComponents();
    for (int k = 0; k < kImu; ++k) G[e][k] = U * parts[k] * U.transpose();
  }

  // Numerators and tr(G_k) (inertial) / row count (visual).
  std::array<double, NoiseFactors::kCount> numerator{}, trace{}, hat{};
  const Eigen::Map<const Eigen::VectorXd> r(residuals.data(), static_cast<long>(residuals.size()));
  for (std::size_t e = 0; e < inertial.size(); ++e) {
    const Eigen::Matrix<double, 15, 1> re = r.segment<15>(static_cast<long>(15 * e));
    for (int k = 0; k < kImu; ++k) {
      numerator[1 + k] += re.dot(G[e][k] * re);
      trace[1 + k] += G[e][k].trace();
    }
  }
  // The visual chi² robustly: the components within 3 robust sigmas (1.4826 MAD) are the
  // inliers; their mean square, corrected for the truncation of a normal at 3 sigma (kept
  // 99.73 %, mean square 0.9733), times all rows. Outliers, down-weighted by the loss, do not
  // inflate it; a scale from the MAD alone would understate it (the residuals are a mixture of
  // variances (1 - h_ii) sigma²).
  if (visual_rows > 0) {
    std::vector<double> magnitude(visual_rows);
    for (std::size_t i = 0; i < visual_rows; ++i)
      magnitude[i] = std::abs(residuals[inertial_rows + i]);
    std::vector<double> sorted = magnitude;
    auto middle = sorted.begin() + static_cast<long>(visual_rows / 2);
    std::nth_element(sorted.begin(), middle, sorted.end());
    const double cut = 3.0 * 1.4826 * *middle;
    double sum = 0.0;
    std::size_t kept = 0;
    for (double m : magnitude) {
      if (m > cut) continue;
      sum += m * m;
      ++kept;
    }
    if (kept > 0) {
      numerator[0] = static_cast<double>(visual_rows) * sum / static_cast<double>(kept) / 0.9733;
    }
  }
  trace[0] = static_cast<double>(visual_rows);

  // Hutchinson: y = Pᵀ L⁻ᵀ z has covariance Ns⁻¹; u = Js y has covariance H.
  std::mt19937_64 rng(12);
  std::bernoulli_distribution coin(0.5);
  Eigen::VectorXd z(n);
  for (int p = 0; p < probes; ++p) {
    for (int c = 0; c < n; ++c) z[c] = coin(rng) ? 1.0 : -1.0;
    const Eigen::VectorXd w = llt.matrixU().solve(z);
    const Eigen::VectorXd y = llt.permutationPinv() * w;
    const Eigen::VectorXd u = Js * y;
    for (std::size_t e = 0; e < inertial.size(); ++e) {
      const Eigen::Matrix<double, 15, 1> ue = u.segment<15>(static_cast<long>(15 * e));
      for (int k = 0; k < kImu; ++k) hat[1 + k] += ue.dot(G[e][k] * ue) / probes;
    }
    hat[0] += u.tail(static_cast<long>(visual_rows)).squaredNorm() / probes;
  }
  out.rows = {static_cast<double>(visual_rows), trace[1], trace[2], trace[3], trace[4]};
  out.unknowns = n;
  for (int k = 0; k < NoiseFactors::kCount; ++k) {
    out.redundancy[k] = trace[k] - hat[k];
    out.chi2[k] = numerator[k];
    if (out.redundancy[k] >= min_redundancy && numerator[k] > 0.0) {
      out.factor[k] = numerator[k] / out.redundancy[k];
      out.estimated[k] = true;
    }
  }
  return out;
}

}  // namespace vilma::mapping::vi_problem

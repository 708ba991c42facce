// BRISK-like synthetic descriptors for localization tests. BRISK bits are intensity
// comparisons of a smooth patch, so they are strongly correlated. Model: a landmark has a latent
// appearance z ~ N(0, I_32); bit j of an observation is sign(w_j . (z + dz) + e_j) with fixed
// random w_j, viewpoint change dz ~ N(0, s_z^2 I) and pixel noise e_j ~ N(0, s_e^2). With
// s_z = s_e = 0.25 true matches differ in ~77 of 512 bits (15 %), as real BRISK matches do.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstring>
#include <random>

namespace vilma::localizer::testing {

constexpr int kDescriptorBytes = 64;

class BriskLikeDescriptors {
 public:
  BriskLikeDescriptors(uint64_t seed, double sigma_viewpoint, double sigma_pixel)
      : W_(512, 32), rng_(seed), s_z_(sigma_viewpoint), s_e_(sigma_pixel) {
    std::normal_distribution<double> n;
    for (int i = 0; i < W_.size(); ++i) W_.data()[i] = n(rng_);
    W_.rowwise().normalize();
  }

  // A new landmark's latent appearance.
  Eigen::VectorXd Latent() {
    std::normal_distribution<double> n;
    Eigen::VectorXd z(32);
    for (int i = 0; i < 32; ++i) z[i] = n(rng_);
    return z;
  }

  // One noisy observation of appearance z into out[0 .. 63].
  void Observe(const Eigen::VectorXd& z, uint8_t* out) {
    std::normal_distribution<double> n;
    Eigen::VectorXd zz = z;
    for (int i = 0; i < 32; ++i) zz[i] += s_z_ * n(rng_);
    const Eigen::VectorXd a = W_ * zz;
    std::memset(out, 0, kDescriptorBytes);
    for (int j = 0; j < 512; ++j) {
      if (a[j] + s_e_ * n(rng_) > 0) out[j / 8] |= static_cast<uint8_t>(1u << (j % 8));
    }
  }

 private:
  Eigen::MatrixXd W_;  // 512 x 32
  std::mt19937_64 rng_;
  double s_z_, s_e_;
};

}  // namespace vilma::localizer::testing

#include "vilma/localizer/descriptor_index.h"

#include <catch2/catch.hpp>
#include <cstring>
#include <iostream>
#include <random>

#include "localizer/synthetic_descriptors.h"

using namespace vilma::localizer;

namespace {

constexpr int kBytes = 64;

using SyntheticDescriptors = vilma::localizer::testing::BriskLikeDescriptors;

}  // namespace

TEST_CASE("descriptor index: Hamming distance and sign vectors", "[localization]") {
  uint8_t a[kBytes] = {}, b[kBytes] = {};
  b[0] = 0x0F;
  b[63] = 0x80;
  CHECK(HammingDistance(a, b, kBytes) == 5);
  CHECK(HammingDistance(a, a, kBytes) == 0);
  CHECK(HammingDistance(a, b, 3) == 4);
  float s[512];
  DescriptorToSigns(b, kBytes, s);
  CHECK(s[0] == 1.f);
  CHECK(s[4] == -1.f);
  CHECK(s[511] == 1.f);
  CHECK(s[504] == -1.f);
}

TEST_CASE("descriptor index: recall of the true landmark in the top k with noisy copies",
          "[localization]") {
  // A map of 10000 landmarks x 3 observations, queries: a fresh noisy observation of 1000.
  SyntheticDescriptors gen(3, 0.25, 0.25);
  const int landmarks = 10000, per = 3;
  std::vector<Eigen::VectorXd> latent;
  std::vector<uint8_t> map_desc(static_cast<std::size_t>(landmarks) * per * kBytes);
  std::vector<uint32_t> labels;
  for (int l = 0; l < landmarks; ++l) {
    latent.push_back(gen.Latent());
    for (int o = 0; o < per; ++o) {
      gen.Observe(latent[l], map_desc.data() + labels.size() * kBytes);
      labels.push_back(l);
    }
  }
  const Eigen::MatrixXf P = TrainProjectionMatrix(map_desc, kBytes, labels);
  REQUIRE(P.rows() == 16);
  REQUIRE(P.cols() == 512);
  const DescriptorIndex index(P, map_desc.data(), kBytes, labels.size());
  CHECK(index.k() == 8 + 30000 / 5000);
  int found = 0, found_exhaustive = 0;
  double hamming_true = 0.0;
  const int queries = 1000;
  std::vector<uint8_t> q(kBytes);
  for (int i = 0; i < queries; ++i) {
    const int l = (i * 7919) % landmarks;
    gen.Observe(latent[l], q.data());
    hamming_true += HammingDistance(q.data(), map_desc.data() + (l * per) * kBytes, kBytes);
    const std::vector<Neighbor> nn = index.Search(q.data());
    REQUIRE(nn.size() == static_cast<std::size_t>(index.k()));
    for (std::size_t j = 1; j < nn.size(); ++j) CHECK(nn[j - 1].distance2 <= nn[j].distance2);
    bool hit = false;
    for (const Neighbor& n : nn) hit |= labels[n.index] == static_cast<uint32_t>(l);
    found += hit;
    // Exhaustive search on the same projection: the index's loss vs the projection's.
    float y[16];
    index.Project(q.data(), y);
    const std::vector<Neighbor> all = index.SearchProjected(y, static_cast<int>(labels.size()));
    bool hit_all = false;
    for (int j = 0; j < index.k(); ++j) hit_all |= labels[all[j].index] == static_cast<uint32_t>(l);
    found_exhaustive += hit_all;
  }
  const double recall = static_cast<double>(found) / queries;
  std::cout << "[descriptor index] 30000 descriptors, mean true-match Hamming "
            << hamming_true / queries << " bits, recall@k=" << index.k() << " " << recall
            << " (exhaustive in projected space " << static_cast<double>(found_exhaustive) / queries
            << ")" << std::endl;
  CHECK(hamming_true / queries > 40.0);  // realistic noise, not a near copy
  CHECK(recall >= 0.95);
}

TEST_CASE("descriptor index: projection whitens the matching noise, bad input throws",
          "[localization]") {
  SyntheticDescriptors gen(5, 0.25, 0.25);
  std::vector<uint8_t> d(2000 * 2 * kBytes);
  std::vector<uint32_t> labels;
  for (int l = 0; l < 2000; ++l) {
    const Eigen::VectorXd z = gen.Latent();
    for (int o = 0; o < 2; ++o) {
      gen.Observe(z, d.data() + labels.size() * kBytes);
      labels.push_back(l);
    }
  }
  ProjectionTrainingOptions o;
  o.dimensions = 8;
  const Eigen::MatrixXf P = TrainProjectionMatrix(d, kBytes, labels, o);
  // Mean squared projected difference of matched pairs per dimension ~ 1 (v^T S_w v = 1 with
  // the regularized S_w slightly above the sample S_w).
  const DescriptorIndex index(P, d.data(), kBytes, labels.size());
  Eigen::VectorXf acc = Eigen::VectorXf::Zero(8);
  float ya[8], yb[8];
  for (int l = 0; l < 2000; ++l) {
    index.Project(d.data() + (2 * l) * kBytes, ya);
    index.Project(d.data() + (2 * l + 1) * kBytes, yb);
    for (int j = 0; j < 8; ++j) acc[j] += (ya[j] - yb[j]) * (ya[j] - yb[j]);
  }
  acc /= 2000.f;
  for (int j = 0; j < 8; ++j) CHECK(acc[j] == Approx(1.0).margin(0.2));
  CHECK_THROWS_AS(TrainProjectionMatrix(d, kBytes, std::vector<uint32_t>(3, 0)),
                  std::invalid_argument);
  CHECK_THROWS_AS(DescriptorIndex(Eigen::MatrixXf::Zero(3, 512), d.data(), kBytes, 10),
                  std::invalid_argument);
}

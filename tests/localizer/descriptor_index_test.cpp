#include "vilma/localizer/descriptor_index.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cstdint>
#include <cstring>
#include <iostream>
#include <random>

#include "localizer/synthetic_descriptors.h"

using namespace vilma::localizer;

namespace {

constexpr int kBytes = 64;

using SyntheticDescriptors = vilma::localizer::testing::BriskLikeDescriptors;

// `landmarks` latent landmarks, each observed `per` times: descriptor i belongs to landmark
// labels[i] (drawn in that order from `gen`, so a seed fixes the set).
struct SyntheticSet {
  std::vector<Eigen::VectorXd> latent;
  std::vector<uint8_t> descriptors;
  std::vector<uint32_t> labels;
};

SyntheticSet MakeSyntheticSet(SyntheticDescriptors* gen, int landmarks, int per) {
  SyntheticSet set;
  set.descriptors.resize(static_cast<std::size_t>(landmarks) * per * kBytes);
  for (int l = 0; l < landmarks; ++l) {
    set.latent.push_back(gen->Latent());
    for (int o = 0; o < per; ++o) {
      gen->Observe(set.latent.back(), set.descriptors.data() + set.labels.size() * kBytes);
      set.labels.push_back(static_cast<uint32_t>(l));
    }
  }
  return set;
}

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
  SyntheticSet set = MakeSyntheticSet(&gen, landmarks, per);
  const std::vector<Eigen::VectorXd>& latent = set.latent;
  const std::vector<uint8_t>& map_desc = set.descriptors;
  const std::vector<uint32_t>& labels = set.labels;
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
  SyntheticSet set = MakeSyntheticSet(&gen, 2000, 2);
  std::vector<uint8_t>& d = set.descriptors;
  std::vector<uint32_t>& labels = set.labels;
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

TEST_CASE("descriptor index: Hamming distance equals a bit-by-bit count", "[localization]") {
  // HammingDistance has a POPCNT and a portable build (target_clones) and a byte tail.
  std::mt19937 rng(13);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int bytes : {1, 7, 8, 13, 32, 64}) {
    for (int t = 0; t < 50; ++t) {
      std::vector<uint8_t> a(bytes), b(bytes);
      for (int i = 0; i < bytes; ++i) {
        a[i] = static_cast<uint8_t>(byte(rng));
        b[i] = static_cast<uint8_t>(byte(rng));
      }
      int expected = 0;
      for (int i = 0; i < 8 * bytes; ++i) expected += ((a[i / 8] ^ b[i / 8]) >> (i % 8)) & 1;
      REQUIRE(HammingDistance(a.data(), b.data(), bytes) == expected);
    }
  }
}

TEST_CASE("descriptor index: projections and distances match a double-precision reference",
          "[localization]") {
  // Random projections of several sizes exercise every branch of the distance summation (D < 4,
  // D % 4 tails, D % 8 == 4, the unrolled D = 16) and of the set-bit projection.
  const int dims = GENERATE(2, 6, 12, 16, 20);
  std::mt19937 rng(17);
  std::normal_distribution<float> gauss(0.f, 0.1f);
  std::uniform_int_distribution<int> byte(0, 255);
  Eigen::MatrixXf P(dims, 8 * kBytes);
  for (int i = 0; i < P.size(); ++i) P.data()[i] = gauss(rng);
  const int count = 3000;
  std::vector<uint8_t> desc(static_cast<std::size_t>(count) * kBytes);
  for (uint8_t& b : desc) b = static_cast<uint8_t>(byte(rng));
  DescriptorIndexOptions options;
  options.codebook_size = 8;
  const DescriptorIndex index(P, desc.data(), kBytes, count, options);
  REQUIRE(index.dimensions() == dims);
  // Reference projections y = P s in double precision.
  auto reference = [&](const uint8_t* d) {
    float s[8 * kBytes];
    DescriptorToSigns(d, kBytes, s);
    return Eigen::VectorXd(P.cast<double>() *
                           Eigen::Map<Eigen::VectorXf>(s, 8 * kBytes).cast<double>());
  };
  std::vector<Eigen::VectorXd> y_ref(count);
  for (int i = 0; i < count; ++i) {
    y_ref[i] = reference(desc.data() + i * kBytes);
    float y[64];
    index.Project(desc.data() + i * kBytes, y);
    for (int r = 0; r < dims; ++r) REQUIRE(y[r] == Approx(y_ref[i][r]).margin(1e-4));
  }
  // Exhaustive search from a fresh descriptor: every descriptor once, nearest first, each
  // squared distance as in double precision.
  std::vector<uint8_t> q(kBytes);
  for (uint8_t& b : q) b = static_cast<uint8_t>(byte(rng));
  const Eigen::VectorXd yq_ref = reference(q.data());
  float yq[64];
  index.Project(q.data(), yq);
  const std::vector<Neighbor> all = index.SearchProjected(yq, count);
  REQUIRE(all.size() == static_cast<std::size_t>(count));
  std::vector<int> seen(count, 0);
  for (std::size_t j = 0; j < all.size(); ++j) {
    ++seen[all[j].index];
    if (j > 0) {
      REQUIRE((all[j - 1].distance2 < all[j].distance2 ||
               (all[j - 1].distance2 == all[j].distance2 && all[j - 1].index < all[j].index)));
    }
    const double expected = (y_ref[all[j].index] - yq_ref).squaredNorm();
    REQUIRE(all[j].distance2 == Approx(expected).epsilon(1e-4).margin(1e-4));
  }
  CHECK(std::count(seen.begin(), seen.end(), 1) == count);
  // The k nearest of the index are the first k of the exhaustive ranking among the cells it
  // visited: at least they are consistent with it (same distances, same order rule).
  const std::vector<Neighbor> nn = index.Search(q.data());
  for (const Neighbor& n : nn) {
    const auto it =
        std::find_if(all.begin(), all.end(), [&](const Neighbor& a) { return a.index == n.index; });
    REQUIRE(it != all.end());
    CHECK(it->distance2 == n.distance2);
  }
}

TEST_CASE("descriptor index: reused search buffers give the results of fresh ones",
          "[localization]") {
  SyntheticDescriptors gen(19, 0.25, 0.25);
  const int landmarks = 3000;
  const SyntheticSet set = MakeSyntheticSet(&gen, landmarks, 2);
  const std::vector<Eigen::VectorXd>& latent = set.latent;
  const std::vector<uint8_t>& desc = set.descriptors;
  const std::vector<uint32_t>& labels = set.labels;
  const DescriptorIndex index(TrainProjectionMatrix(desc, kBytes, labels), desc.data(), kBytes,
                              labels.size());
  DescriptorSearchScratch scratch;
  std::vector<Neighbor> reused;
  std::vector<uint8_t> q(kBytes);
  float y[64];
  // Compares a search on the reused scratch with one on fresh buffers, and checks that every
  // indexed descriptor appears at most once (a cell visited twice would repeat its items).
  auto check_search = [&](int k) {
    index.SearchProjected(y, k, &scratch, &reused);
    const std::vector<Neighbor> fresh = index.SearchProjected(y, k);
    REQUIRE(reused.size() == fresh.size());
    std::vector<uint8_t> seen(labels.size(), 0);
    for (std::size_t j = 0; j < fresh.size(); ++j) {
      REQUIRE(reused[j].index == fresh[j].index);
      REQUIRE(reused[j].distance2 == fresh[j].distance2);
      REQUIRE(seen[reused[j].index]++ == 0);
    }
  };
  const int all = static_cast<int>(labels.size());
  // An exhaustive search marks every cell "popped" with stamp 1. Then the stamp jumps to its
  // wrap-around, passed by short searches (which overwrite few marks): the searches after it
  // must start from cleared marks. A stale mark equal to the current stamp would make the
  // multi-sequence traversal queue a cell twice, which an exhaustive search reveals.
  gen.Observe(latent[0], q.data());
  index.Project(q.data(), y);
  check_search(all);
  REQUIRE(scratch.search == 1u);
  scratch.search = UINT32_MAX - 1;
  for (int i = 0; i < 2; ++i) check_search(index.k());
  for (int i = 0; i < 3; ++i) check_search(all);
  CHECK(scratch.search < 10u);  // wrapped and restarted
  // Then many queries with varying k on the same buffers.
  for (int i = 0; i < 200; ++i) {
    gen.Observe(latent[(i * 37) % landmarks], q.data());
    index.Project(q.data(), y);
    check_search(i % 10 == 0 ? all : index.k() + i % 5);
    index.Search(q.data(), &scratch, &reused);
    const std::vector<Neighbor> fresh_search = index.Search(q.data());
    REQUIRE(reused.size() == fresh_search.size());
    for (std::size_t j = 0; j < fresh_search.size(); ++j) {
      REQUIRE(reused[j].index == fresh_search[j].index);
    }
  }
}

TEST_CASE("descriptor index: an exhaustive search is the exact ranking of every descriptor",
          "[localization]") {
  // Guards the ranking machinery (word distances, multi-sequence heap, candidate heap, lazy
  // sorts) against an independent brute force in the projected space: with k = every
  // descriptor the multi-index visits every cell, so the result must be all descriptors in
  // order of their projected distance (ties: lower index), with the right distances.
  SyntheticDescriptors gen(23, 0.25, 0.25);
  const int landmarks = 1500;
  const SyntheticSet set = MakeSyntheticSet(&gen, landmarks, 2);
  const std::vector<Eigen::VectorXd>& latent = set.latent;
  const std::vector<uint8_t>& desc = set.descriptors;
  const std::vector<uint32_t>& labels = set.labels;
  DescriptorIndexOptions options;
  options.codebook_size = 16;
  const DescriptorIndex index(TrainProjectionMatrix(desc, kBytes, labels), desc.data(), kBytes,
                              labels.size(), options);
  const int n = static_cast<int>(labels.size());
  const int d = index.dimensions();
  std::vector<float> projected(static_cast<std::size_t>(n) * d);
  for (int i = 0; i < n; ++i) index.Project(desc.data() + i * kBytes, &projected[i * d]);
  std::vector<uint8_t> q(kBytes);
  float y[64];
  for (int query = 0; query < 20; ++query) {
    gen.Observe(latent[(query * 71) % landmarks], q.data());
    index.Project(q.data(), y);
    // Brute force in double precision.
    std::vector<std::pair<double, uint32_t>> truth(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
      double s = 0.0;
      for (int c = 0; c < d; ++c) {
        const double e = static_cast<double>(y[c]) - projected[i * d + c];
        s += e * e;
      }
      truth[i] = {s, static_cast<uint32_t>(i)};
    }
    std::sort(truth.begin(), truth.end());
    const std::vector<Neighbor> all = index.SearchProjected(y, n);
    REQUIRE(static_cast<int>(all.size()) == n);
    for (int j = 0; j < n; ++j) {
      INFO("query " << query << ", rank " << j);
      if (j > 0) {
        // Non-decreasing distance, ties by index.
        REQUIRE((all[j - 1].distance2 < all[j].distance2 ||
                 (all[j - 1].distance2 == all[j].distance2 && all[j - 1].index < all[j].index)));
      }
      // The distance of what is at rank j is the brute-force distance of rank j (float
      // rounding may swap near-ties, never ranks that differ by more than that).
      const double tolerance = 1e-5 * std::max(1.0, truth[j].first);
      REQUIRE(std::abs(static_cast<double>(all[j].distance2) - truth[j].first) <= tolerance);
    }
    // The k nearest of a normal search are the exhaustive ranking's first ones whenever the
    // traversal collected them (the true match is among them: recall is tested above).
    const std::vector<Neighbor> top = index.SearchProjected(y, index.k());
    for (std::size_t j = 1; j < top.size(); ++j) REQUIRE(top[j - 1].distance2 <= top[j].distance2);
  }
}

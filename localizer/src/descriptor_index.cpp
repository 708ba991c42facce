#include "vilma/localizer/descriptor_index.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstring>
#include <numeric>
#include <queue>
#include <random>
#include <stdexcept>

namespace vilma::localizer {

void DescriptorToSigns(const uint8_t* descriptor, int bytes, float* signs) {
  for (int i = 0; i < bytes; ++i) {
    for (int b = 0; b < 8; ++b) signs[8 * i + b] = (descriptor[i] >> b) & 1 ? 1.f : -1.f;
  }
}

int HammingDistance(const uint8_t* a, const uint8_t* b, int bytes) {
  int d = 0;
  int i = 0;
  for (; i + 8 <= bytes; i += 8) {
    uint64_t x, y;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    d += __builtin_popcountll(x ^ y);
  }
  for (; i < bytes; ++i) d += __builtin_popcount(static_cast<unsigned>(a[i] ^ b[i]));
  return d;
}

std::string ProjectionTrainingOptions::Validate() const {
  if (dimensions < 2 || dimensions % 2 != 0 || dimensions > 64) {
    return "dimensions: expected an even number in 2..64";
  }
  if (max_pairs < 100) return "max_pairs: expected >= 100";
  if (!(regularization > 0.0)) return "regularization: expected > 0";
  return "";
}

Eigen::MatrixXf TrainProjectionMatrix(const std::vector<uint8_t>& descriptors, int bytes,
                                      const std::vector<uint32_t>& labels,
                                      const ProjectionTrainingOptions& options) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("ProjectionTrainingOptions: " + error);
  const std::size_t n = labels.size();
  const int bits = 8 * bytes;
  if (n < 2 || bytes <= 0 || descriptors.size() != n * bytes || options.dimensions > bits) {
    throw std::invalid_argument("TrainProjectionMatrix: expected >= 2 descriptors of " +
                                std::to_string(bytes) + " bytes, one label each");
  }
  std::mt19937_64 rng(options.seed);
  // Matched pairs: consecutive descriptors of one landmark (descriptors sorted by label).
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return labels[a] < labels[b]; });
  std::vector<std::pair<uint32_t, uint32_t>> within;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    if (labels[order[i]] == labels[order[i + 1]]) within.emplace_back(order[i], order[i + 1]);
  }
  std::shuffle(within.begin(), within.end(), rng);
  if (within.size() > static_cast<std::size_t>(options.max_pairs)) within.resize(options.max_pairs);
  const std::size_t num_between =
      std::max<std::size_t>(within.size(), std::min<std::size_t>(options.max_pairs, n));
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  std::vector<std::pair<uint32_t, uint32_t>> between;
  for (std::size_t tries = 0; between.size() < num_between && tries < 20 * num_between; ++tries) {
    const std::size_t a = pick(rng), b = pick(rng);
    if (labels[a] != labels[b]) between.emplace_back(a, b);
  }
  auto scatter = [&](const std::vector<std::pair<uint32_t, uint32_t>>& pairs) {
    Eigen::MatrixXf diffs(pairs.size(), bits);
    std::vector<float> sa(bits), sb(bits);
    for (std::size_t p = 0; p < pairs.size(); ++p) {
      DescriptorToSigns(descriptors.data() + pairs[p].first * bytes, bytes, sa.data());
      DescriptorToSigns(descriptors.data() + pairs[p].second * bytes, bytes, sb.data());
      for (int j = 0; j < bits; ++j) diffs(p, j) = sa[j] - sb[j];
    }
    Eigen::MatrixXf s = Eigen::MatrixXf::Zero(bits, bits);
    s.selfadjointView<Eigen::Lower>().rankUpdate(diffs.transpose());
    s = s.selfadjointView<Eigen::Lower>();
    return Eigen::MatrixXd(s.cast<double>() / std::max<double>(1.0, pairs.size()));
  };
  if (between.empty()) throw std::invalid_argument("TrainProjectionMatrix: expected >= 2 labels");
  const Eigen::MatrixXd s_b = scatter(between);
  Eigen::MatrixXd s_w = within.size() >= 10 ? scatter(within) : Eigen::MatrixXd::Identity(bits, bits);
  s_w.diagonal().array() += options.regularization * s_w.trace() / bits;
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> solver(s_b, s_w);
  if (solver.info() != Eigen::Success) {
    throw std::invalid_argument("TrainProjectionMatrix: eigen decomposition failed");
  }
  Eigen::MatrixXf projection(options.dimensions, bits);
  for (int r = 0; r < options.dimensions; ++r) {
    Eigen::VectorXd v = solver.eigenvectors().col(bits - 1 - r);  // eigenvalues ascend
    v /= std::sqrt(v.dot(s_w * v));
    projection.row(r) = v.transpose().cast<float>();
  }
  return projection;
}

std::string DescriptorIndexOptions::Validate() const {
  if (codebook_size < 1 || codebook_size > 1024) return "codebook_size: expected 1..1024";
  if (kmeans_iterations < 1) return "kmeans_iterations: expected >= 1";
  if (kmeans_max_samples < 1) return "kmeans_max_samples: expected >= 1";
  if (min_neighbors < 1) return "min_neighbors: expected >= 1";
  if (max_neighbors < min_neighbors) return "max_neighbors: expected >= min_neighbors";
  if (descriptors_per_extra_neighbor < 1) return "descriptors_per_extra_neighbor: expected >= 1";
  if (candidates_per_neighbor < 1) return "candidates_per_neighbor: expected >= 1";
  return "";
}

namespace {

// Lloyd's k-means on the columns of `points` (dims x n), seeded random initial centres.
Eigen::MatrixXf KMeans(const Eigen::MatrixXf& points, int k, int iterations, std::mt19937_64* rng) {
  const int n = static_cast<int>(points.cols());
  k = std::max(1, std::min(k, n));
  std::vector<int> idx(n);
  std::iota(idx.begin(), idx.end(), 0);
  std::shuffle(idx.begin(), idx.end(), *rng);
  Eigen::MatrixXf centres(points.rows(), k);
  for (int c = 0; c < k; ++c) centres.col(c) = points.col(idx[c]);
  std::vector<int> assign(n, 0);
  for (int it = 0; it < iterations; ++it) {
    for (int i = 0; i < n; ++i) {
      Eigen::Index best;
      (centres.colwise() - points.col(i)).colwise().squaredNorm().minCoeff(&best);
      assign[i] = static_cast<int>(best);
    }
    Eigen::MatrixXf sum = Eigen::MatrixXf::Zero(points.rows(), k);
    std::vector<int> count(k, 0);
    for (int i = 0; i < n; ++i) {
      sum.col(assign[i]) += points.col(i);
      ++count[assign[i]];
    }
    for (int c = 0; c < k; ++c) {
      // An empty cluster takes a random point (keeps k cells useful).
      centres.col(c) = count[c] > 0 ? Eigen::VectorXf(sum.col(c) / count[c])
                                    : Eigen::VectorXf(points.col(idx[(it * k + c) % n]));
    }
  }
  return centres;
}

int Nearest(const Eigen::MatrixXf& centres, const float* x) {
  Eigen::Map<const Eigen::VectorXf> v(x, centres.rows());
  Eigen::Index best;
  (centres.colwise() - v).colwise().squaredNorm().minCoeff(&best);
  return static_cast<int>(best);
}

}  // namespace

DescriptorIndex::DescriptorIndex(const Eigen::MatrixXf& projection, const uint8_t* descriptors,
                                 int bytes, std::size_t count,
                                 const DescriptorIndexOptions& options)
    : projection_(projection), options_(options), count_(count), bytes_(bytes) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("DescriptorIndexOptions: " + error);
  if (projection.rows() < 2 || projection.rows() % 2 != 0 || projection.cols() != 8 * bytes) {
    throw std::invalid_argument("DescriptorIndex: projection must be (even D) x (8 bytes)");
  }
  if (count == 0) throw std::invalid_argument("DescriptorIndex: no descriptors");
  const int dims = static_cast<int>(projection.rows());
  projection2_ = 2.f * projection_;
  column_sum_ = projection_.rowwise().sum();
  half_ = dims / 2;
  k_ = static_cast<int>(std::clamp<std::size_t>(
      options.min_neighbors + count / options.descriptors_per_extra_neighbor,
      options.min_neighbors, options.max_neighbors));
  projected_.resize(dims, count);
  for (std::size_t i = 0; i < count; ++i) Project(descriptors + i * bytes, projected_.col(i).data());
  std::mt19937_64 rng(options.seed);
  std::vector<int> sample(count);
  std::iota(sample.begin(), sample.end(), 0);
  std::shuffle(sample.begin(), sample.end(), rng);
  sample.resize(std::min<std::size_t>(count, options.kmeans_max_samples));
  for (int h = 0; h < 2; ++h) {
    Eigen::MatrixXf pts(half_, sample.size());
    for (std::size_t i = 0; i < sample.size(); ++i) {
      pts.col(i) = projected_.block(h * half_, sample[i], half_, 1);
    }
    codebook_[h] = KMeans(pts, options.codebook_size, options.kmeans_iterations, &rng);
  }
  words_ = static_cast<int>(codebook_[0].cols());
  // Both codebooks have min(codebook_size, samples) words.
  std::vector<uint32_t> cell(count);
  std::vector<uint32_t> counts(words_ * words_ + 1, 0);
  for (std::size_t i = 0; i < count; ++i) {
    const int w0 = Nearest(codebook_[0], projected_.col(i).data());
    const int w1 = Nearest(codebook_[1], projected_.col(i).data() + half_);
    cell[i] = static_cast<uint32_t>(w0 * words_ + w1);
    ++counts[cell[i] + 1];
  }
  cell_begin_.assign(counts.size(), 0);
  std::partial_sum(counts.begin(), counts.end(), cell_begin_.begin());
  cell_items_.resize(count);
  std::vector<uint32_t> fill(cell_begin_.begin(), cell_begin_.end() - 1);
  for (std::size_t i = 0; i < count; ++i) cell_items_[fill[cell[i]]++] = static_cast<uint32_t>(i);
}

void DescriptorIndex::Project(const uint8_t* descriptor, float* projected) const {
  // y = P s with s the +-1 signs: y = 2 P b - P 1; summing the columns of set bits is cheaper.
  const int dims = static_cast<int>(projection_.rows());
  Eigen::Map<Eigen::VectorXf> y(projected, dims);
  y = -column_sum_;
  for (int i = 0; i < bytes_; ++i) {
    for (unsigned byte = descriptor[i]; byte != 0; byte &= byte - 1) {
      y += projection2_.col(8 * i + __builtin_ctz(byte));
    }
  }
}

std::vector<Neighbor> DescriptorIndex::Search(const uint8_t* descriptor) const {
  float projected[64];
  Project(descriptor, projected);
  return SearchProjected(projected, k_);
}

std::vector<Neighbor> DescriptorIndex::SearchProjected(const float* y, int k) const {
  std::vector<Neighbor> result;
  if (count_ == 0 || k <= 0) return result;
  // Distances to the words of each half, sorted.
  std::vector<std::pair<float, int>> d[2];
  for (int h = 0; h < 2; ++h) {
    Eigen::Map<const Eigen::VectorXf> v(y + h * half_, half_);
    const Eigen::VectorXf dist = (codebook_[h].colwise() - v).colwise().squaredNorm();
    d[h].resize(words_);
    for (int w = 0; w < words_; ++w) d[h][w] = {dist[w], w};
    std::sort(d[h].begin(), d[h].end());
  }
  // Multi-sequence algorithm: cells (i, j) of the sorted lists popped in increasing
  // d0[i] + d1[j]; (i, j) enters the queue once both (i-1, j) and (i, j-1) were popped.
  using Entry = std::pair<float, uint32_t>;  // lower bound, i * words + j
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
  std::vector<uint8_t> popped(static_cast<std::size_t>(words_) * words_, 0);
  queue.push({d[0][0].first + d[1][0].first, 0});
  const std::size_t wanted = static_cast<std::size_t>(k) * options_.candidates_per_neighbor;
  for (std::size_t collected = 0; !queue.empty() && collected < wanted;) {
    const uint32_t ij = queue.top().second;
    queue.pop();
    const int i = static_cast<int>(ij) / words_, j = static_cast<int>(ij) % words_;
    popped[ij] = 1;
    const uint32_t c = static_cast<uint32_t>(d[0][i].second * words_ + d[1][j].second);
    for (uint32_t p = cell_begin_[c]; p < cell_begin_[c + 1]; ++p) {
      const uint32_t item = cell_items_[p];
      const Eigen::Map<const Eigen::VectorXf> v(y, projected_.rows());
      result.push_back({item, (projected_.col(item) - v).squaredNorm()});
    }
    collected += cell_begin_[c + 1] - cell_begin_[c];
    if (i + 1 < words_ && (j == 0 || popped[(i + 1) * words_ + j - 1])) {
      queue.push({d[0][i + 1].first + d[1][j].first, static_cast<uint32_t>((i + 1) * words_ + j)});
    }
    if (j + 1 < words_ && (i == 0 || popped[(i - 1) * words_ + j + 1])) {
      queue.push({d[0][i].first + d[1][j + 1].first, static_cast<uint32_t>(i * words_ + j + 1)});
    }
  }
  const std::size_t keep = std::min<std::size_t>(k, result.size());
  std::partial_sort(result.begin(), result.begin() + keep, result.end(),
                    [](const Neighbor& a, const Neighbor& b) {
                      return a.distance2 < b.distance2 ||
                             (a.distance2 == b.distance2 && a.index < b.index);
                    });
  result.resize(keep);
  return result;
}

}  // namespace vilma::localizer

#include "vilma/localizer/descriptor_index.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <functional>
#include <numeric>
#include <random>
#include <stdexcept>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace vilma::localizer {

void DescriptorToSigns(const uint8_t* descriptor, int bytes, float* signs) {
  for (int i = 0; i < bytes; ++i) {
    for (int b = 0; b < 8; ++b) signs[8 * i + b] = (descriptor[i] >> b) & 1 ? 1.f : -1.f;
  }
}

// The x86-64 baseline this project builds for (no -march flags) has no POPCNT instruction, so
// __builtin_popcountll compiles to a call into libgcc's bit-twiddling routine per 64-bit word
// (that was ~20 % of the matching time against a 50k-landmark map). target_clones also compiles
// a POPCNT copy and picks it once at load time (ifunc) on CPUs that have the instruction (every
// x86-64 CPU since about 2008); the result is the same either way.
#if defined(__x86_64__) && defined(__GNUC__) && defined(__linux__)
__attribute__((target_clones("popcnt", "default")))
#endif
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

// Squared Euclidean distance of two `dims`-vectors (kDims > 0: the size known at compile time,
// so the loops unroll; 0: runtime `dims`). The terms e_i = (a_i - b_i)^2 are summed in the order
// of Eigen 3.4's dynamic-size vectorized reduction with 4-float packets (the SSE2 baseline of
// this build): two interleaved 4-lane accumulators, s += e[8m .. 8m+3], t += e[8m+4 .. 8m+7],
// then s += t (+ one more packet when dims % 8 >= 4), then (s0 + s2) + (s1 + s3), then the
// dims % 4 tail in order. The index ranked candidates with Eigen's (a - b).squaredNorm() before;
// summing in the same order keeps every distance, hence every ranking, bit-identical to it
// (checked by the 50k-landmark benchmark's match checksum). Any order is an equally correct
// distance; the SSE2 and the scalar branches give the same floats.
template <int kDims>
inline float SquaredDistance(const float* a, const float* b, int dims) {
  const int n = kDims > 0 ? kDims : dims;
  auto e = [&](int i) {
    const float d = a[i] - b[i];
    return d * d;
  };
  if (n < 4) {
    float r = e(0);
    for (int i = 1; i < n; ++i) r += e(i);
    return r;
  }
  const int n4 = n & ~3, n8 = n & ~7;
#if defined(__SSE2__)
  auto e4 = [&](int i) {
    const __m128 d = _mm_sub_ps(_mm_loadu_ps(a + i), _mm_loadu_ps(b + i));
    return _mm_mul_ps(d, d);
  };
  __m128 s = e4(0);
  if (n4 > 4) {
    __m128 t = e4(4);
    for (int m = 8; m < n8; m += 8) {
      s = _mm_add_ps(s, e4(m));
      t = _mm_add_ps(t, e4(m + 4));
    }
    s = _mm_add_ps(s, t);
    if (n4 > n8) s = _mm_add_ps(s, e4(n8));
  }
  const __m128 h = _mm_add_ps(s, _mm_movehl_ps(s, s));  // (s0 + s2, s1 + s3, ..)
  float r = _mm_cvtss_f32(_mm_add_ss(h, _mm_shuffle_ps(h, h, 1)));
#else
  float s[4];
  for (int l = 0; l < 4; ++l) s[l] = e(l);
  if (n4 > 4) {
    float t[4];
    for (int l = 0; l < 4; ++l) t[l] = e(4 + l);
    for (int m = 8; m < n8; m += 8) {
      for (int l = 0; l < 4; ++l) s[l] += e(m + l);
      for (int l = 0; l < 4; ++l) t[l] += e(m + 4 + l);
    }
    for (int l = 0; l < 4; ++l) s[l] += t[l];
    if (n4 > n8) {
      for (int l = 0; l < 4; ++l) s[l] += e(n8 + l);
    }
  }
  float r = (s[0] + s[2]) + (s[1] + s[3]);
#endif
  for (int i = n4; i < n; ++i) r += e(i);
  return r;
}

// Sort key of a (non-negative squared distance, index) pair: the IEEE-754 bits of a float >= 0
// increase with its value, so (bits << 32 | index) orders exactly as (distance, then index).
// One integer comparison instead of two float ones with unordered checks: the selection and
// sorts below are branch-bound, and this halves their work.
inline uint64_t DistanceKey(float distance2, uint32_t index) {
  uint32_t bits;
  std::memcpy(&bits, &distance2, sizeof bits);
  return static_cast<uint64_t>(bits) << 32 | index;
}
inline float KeyDistance(uint64_t key) {
  const uint32_t bits = static_cast<uint32_t>(key >> 32);
  float distance2;
  std::memcpy(&distance2, &bits, sizeof distance2);
  return distance2;
}
inline uint32_t KeyIndex(uint64_t key) { return static_cast<uint32_t>(key); }

// Squared distances of x (`half` floats) to every word of a codebook stored transposed
// (codebook_t: words x half, column-major, so each dimension is a contiguous row of `words`
// floats): out[w] = sum_d (c_wd - x_d)^2, summed over d in order (the order of Eigen's
// colwise().squaredNorm() used before, so word rankings are unchanged). Vectorizes over w.
void WordDistances(const Eigen::MatrixXf& codebook_t, const float* x, float* out) {
  const int words = static_cast<int>(codebook_t.rows());
  const int half = static_cast<int>(codebook_t.cols());
  const float* c = codebook_t.data();
  for (int w = 0; w < words; ++w) {
    const float d = c[w] - x[0];
    out[w] = d * d;
  }
  for (int k = 1; k < half; ++k) {
    const float* row = c + static_cast<std::ptrdiff_t>(k) * words;
    for (int w = 0; w < words; ++w) {
      const float d = row[w] - x[k];
      out[w] += d * d;
    }
  }
}

// First index of the smallest of n values (the tie rule of Eigen's minCoeff).
int ArgMin(const float* v, int n) {
  int best = 0;
  for (int i = 1; i < n; ++i) {
    if (v[i] < v[best]) best = i;
  }
  return best;
}

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
  std::vector<float> dist(k);
  for (int it = 0; it < iterations; ++it) {
    const Eigen::MatrixXf centres_t = centres.transpose();
    for (int i = 0; i < n; ++i) {
      WordDistances(centres_t, points.col(i).data(), dist.data());
      assign[i] = ArgMin(dist.data(), k);
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

// y = -column_sum + sum over the set bits b of columns2[b] (columns2 = 2 P, column-major, D
// floats per column). Each element is accumulated in bit order, as Eigen's y += col did.
template <int kDims>
void ProjectSetBits(const float* columns2, const float* column_sum, const uint8_t* descriptor,
                    int bytes, int dims, float* y) {
  const int n = kDims > 0 ? kDims : dims;
  float acc[64];  // dims <= 64 (ProjectionTrainingOptions::Validate)
  for (int r = 0; r < n; ++r) acc[r] = -column_sum[r];
  for (int i = 0; i < bytes; ++i) {
    for (unsigned byte = descriptor[i]; byte != 0; byte &= byte - 1) {
      const float* column = columns2 + static_cast<std::ptrdiff_t>(8 * i + __builtin_ctz(byte)) * n;
      for (int r = 0; r < n; ++r) acc[r] += column[r];
    }
  }
  for (int r = 0; r < n; ++r) y[r] = acc[r];
}

constexpr int kFastDims = 16;  // the default projection: loops unrolled at compile time

}  // namespace

DescriptorIndex::DescriptorIndex(const Eigen::MatrixXf& projection, const uint8_t* descriptors,
                                 int bytes, std::size_t count,
                                 const DescriptorIndexOptions& options)
    : projection_(projection), options_(options), count_(count), bytes_(bytes) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("DescriptorIndexOptions: " + error);
  if (projection.rows() < 2 || projection.rows() % 2 != 0 || projection.rows() > 64 ||
      projection.cols() != 8 * bytes) {
    throw std::invalid_argument("DescriptorIndex: projection must be (even D <= 64) x (8 bytes)");
  }
  if (count == 0) throw std::invalid_argument("DescriptorIndex: no descriptors");
  if (count > UINT32_MAX) {
    throw std::invalid_argument("DescriptorIndex: more than 2^32 descriptors");
  }
  const int dims = static_cast<int>(projection.rows());
  projection2_ = 2.f * projection_;
  column_sum_ = projection_.rowwise().sum();
  half_ = dims / 2;
  k_ = static_cast<int>(std::clamp<std::size_t>(
      options.min_neighbors + count / options.descriptors_per_extra_neighbor,
      options.min_neighbors, options.max_neighbors));
  Eigen::MatrixXf projected(dims, count);  // by descriptor index
  for (std::size_t i = 0; i < count; ++i) Project(descriptors + i * bytes, projected.col(i).data());
  std::mt19937_64 rng(options.seed);
  std::vector<int> sample(count);
  std::iota(sample.begin(), sample.end(), 0);
  std::shuffle(sample.begin(), sample.end(), rng);
  sample.resize(std::min<std::size_t>(count, options.kmeans_max_samples));
  for (int h = 0; h < 2; ++h) {
    Eigen::MatrixXf pts(half_, sample.size());
    for (std::size_t i = 0; i < sample.size(); ++i) {
      pts.col(i) = projected.block(h * half_, sample[i], half_, 1);
    }
    codebook_[h] = KMeans(pts, options.codebook_size, options.kmeans_iterations, &rng);
    codebook_t_[h] = codebook_[h].transpose();
  }
  words_ = static_cast<int>(codebook_[0].cols());
  // Both codebooks have min(codebook_size, samples) words.
  std::vector<uint32_t> cell(count);
  std::vector<uint32_t> counts(words_ * words_ + 1, 0);
  std::vector<float> dist(words_);
  for (std::size_t i = 0; i < count; ++i) {
    WordDistances(codebook_t_[0], projected.col(i).data(), dist.data());
    const int w0 = ArgMin(dist.data(), words_);
    WordDistances(codebook_t_[1], projected.col(i).data() + half_, dist.data());
    const int w1 = ArgMin(dist.data(), words_);
    cell[i] = static_cast<uint32_t>(w0 * words_ + w1);
    ++counts[cell[i] + 1];
  }
  cell_begin_.assign(counts.size(), 0);
  std::partial_sum(counts.begin(), counts.end(), cell_begin_.begin());
  cell_items_.resize(count);
  cell_projected_.resize(dims, count);
  std::vector<uint32_t> fill(cell_begin_.begin(), cell_begin_.end() - 1);
  for (std::size_t i = 0; i < count; ++i) {
    const uint32_t slot = fill[cell[i]]++;
    cell_items_[slot] = static_cast<uint32_t>(i);
    cell_projected_.col(slot) = projected.col(i);
  }
}

void DescriptorIndex::Project(const uint8_t* descriptor, float* projected) const {
  // y = P s with s the +-1 signs: y = 2 P b - P 1 with b the 0/1 bits, so only the columns of
  // the set bits are added (~256 D-vector adds instead of D dot products of length 512). A
  // per-byte table of partial column sums would need 4x fewer adds, but it rounds every y
  // differently and so changes rankings; this is only ~5 % of a query.
  const int dims = static_cast<int>(projection_.rows());
  if (dims == kFastDims) {
    ProjectSetBits<kFastDims>(projection2_.data(), column_sum_.data(), descriptor, bytes_, dims,
                              projected);
  } else {
    ProjectSetBits<0>(projection2_.data(), column_sum_.data(), descriptor, bytes_, dims, projected);
  }
}

std::vector<Neighbor> DescriptorIndex::Search(const uint8_t* descriptor) const {
  DescriptorSearchScratch scratch;
  std::vector<Neighbor> neighbors;
  Search(descriptor, &scratch, &neighbors);
  return neighbors;
}

std::vector<Neighbor> DescriptorIndex::SearchProjected(const float* y, int k) const {
  DescriptorSearchScratch scratch;
  std::vector<Neighbor> neighbors;
  SearchProjected(y, k, &scratch, &neighbors);
  return neighbors;
}

void DescriptorIndex::Search(const uint8_t* descriptor, DescriptorSearchScratch* scratch,
                             std::vector<Neighbor>* neighbors) const {
  float projected[64];
  Project(descriptor, projected);
  SearchProjected(projected, k_, scratch, neighbors);
}

void DescriptorIndex::SearchProjected(const float* y, int k, DescriptorSearchScratch* scratch,
                                      std::vector<Neighbor>* neighbors) const {
  neighbors->clear();
  if (count_ == 0 || k <= 0) return;
  DescriptorSearchScratch& s = *scratch;
  const int dims = static_cast<int>(projection_.rows());
  // The words of each half in increasing distance to the query half, as sort keys
  // (distance bits << 32 | word). The traversal rarely goes past the first few words of either
  // list, so only the nearest kSortedPrefix are selected and sorted now (nth_element + sort of
  // 16: about a third of the comparisons of sorting 64); the rest is sorted the first time the
  // traversal reaches it. The sorted order is unique (total key order), so this is exactly a
  // full sort as far as the traversal can tell.
  constexpr int kSortedPrefix = 16;
  float word_distance[1024];  // words_ <= codebook_size <= 1024
  int sorted[2];
  for (int h = 0; h < 2; ++h) {
    WordDistances(codebook_t_[h], y + h * half_, word_distance);
    std::vector<uint64_t>& keys = s.words[h];
    keys.resize(words_);
    for (int w = 0; w < words_; ++w) keys[w] = DistanceKey(word_distance[w], w);
    sorted[h] = std::min(kSortedPrefix, words_);
    if (sorted[h] < words_) std::nth_element(keys.begin(), keys.begin() + sorted[h], keys.end());
    std::sort(keys.begin(), keys.begin() + sorted[h]);
  }
  // Entry r of sorted list h (sorting the remainder when first needed).
  auto word_key = [&](int h, int r) {
    if (r >= sorted[h]) {
      std::sort(s.words[h].begin() + sorted[h], s.words[h].end());
      sorted[h] = words_;
    }
    return s.words[h][r];
  };
  // Lower bound d0(i) + d1(j) of the cell (i, j) of the sorted lists, and its cell number.
  auto bound = [&](int i, int j) {
    return KeyDistance(word_key(0, i)) + KeyDistance(word_key(1, j));
  };
  auto cell_of = [&](int i, int j) {
    return KeyIndex(word_key(0, i)) * static_cast<uint32_t>(words_) + KeyIndex(word_key(1, j));
  };
  // "Popped" marks carry the number of the search that set them, so a new search starts with
  // none set without clearing words^2 entries.
  const std::size_t num_cells = static_cast<std::size_t>(words_) * words_;
  if (s.popped.size() != num_cells || s.search == UINT32_MAX) {
    s.popped.assign(num_cells, 0);
    s.search = 0;
  }
  const uint32_t stamp = ++s.search;
  // Multi-sequence algorithm: cells (i, j) of the sorted lists popped in increasing
  // d0[i] + d1[j]; (i, j) enters the queue once both (i-1, j) and (i, j-1) were popped.
  // A binary min-heap on (lower bound, i * words + j), as std::priority_queue with greater<>.
  using Entry = std::pair<float, uint32_t>;
  auto& queue = s.queue;
  queue.clear();
  const std::size_t bytes_per_slot = sizeof(float) * static_cast<std::size_t>(dims);
  auto push = [&](int i, int j) {
    queue.emplace_back(bound(i, j), static_cast<uint32_t>(i * words_ + j));
    std::push_heap(queue.begin(), queue.end(), std::greater<Entry>());
    // A queued cell is usually visited a few pops later: start loading the first lines of its
    // projected vectors now (the index does not fit in L2); the hardware prefetcher follows
    // the rest of the run once the scan below streams through it.
    const uint32_t c = cell_of(i, j);
    const char* first =
        reinterpret_cast<const char*>(cell_projected_.data()) + cell_begin_[c] * bytes_per_slot;
    const std::size_t run =
        std::min<std::size_t>(512, (cell_begin_[c + 1] - cell_begin_[c]) * bytes_per_slot);
    for (std::size_t b = 0; b < run; b += 64) __builtin_prefetch(first + b);
  };
  push(0, 0);
  auto& candidates = s.candidates;
  candidates.clear();
  const std::size_t wanted = static_cast<std::size_t>(k) * options_.candidates_per_neighbor;
  while (!queue.empty() && candidates.size() < wanted) {
    std::pop_heap(queue.begin(), queue.end(), std::greater<Entry>());
    const uint32_t ij = queue.back().second;
    queue.pop_back();
    const int i = static_cast<int>(ij) / words_, j = static_cast<int>(ij) % words_;
    s.popped[ij] = stamp;
    const uint32_t c = cell_of(i, j);
    // The cell's projected vectors are one contiguous run of slots.
    const uint32_t begin = cell_begin_[c], end = cell_begin_[c + 1];
    const float* v = cell_projected_.data() + static_cast<std::ptrdiff_t>(begin) * dims;
    if (dims == kFastDims) {
      for (uint32_t p = begin; p < end; ++p, v += kFastDims) {
        candidates.push_back(DistanceKey(SquaredDistance<kFastDims>(v, y, dims), cell_items_[p]));
      }
    } else {
      for (uint32_t p = begin; p < end; ++p, v += dims) {
        candidates.push_back(DistanceKey(SquaredDistance<0>(v, y, dims), cell_items_[p]));
      }
    }
    if (i + 1 < words_ && (j == 0 || s.popped[(i + 1) * words_ + j - 1] == stamp)) push(i + 1, j);
    if (j + 1 < words_ && (i == 0 || s.popped[(i - 1) * words_ + j + 1] == stamp)) push(i, j + 1);
  }
  // The k nearest, nearest first (ties: lower index): a max-heap of the k smallest keys seen.
  // Once it is full almost every further candidate fails the one comparison with its top (a
  // well-predicted branch), which beats nth_element's unpredictable partitioning here. The key
  // order is total, so the result is exactly the first k of a full sort.
  const std::size_t keep = std::min<std::size_t>(k, candidates.size());
  auto first = candidates.begin(), heap_end = first + keep;
  std::make_heap(first, heap_end);
  for (auto it = heap_end; it != candidates.end(); ++it) {
    if (*it < *first) {
      std::pop_heap(first, heap_end);
      *(heap_end - 1) = *it;
      std::push_heap(first, heap_end);
    }
  }
  std::sort_heap(first, heap_end);
  neighbors->resize(keep);
  for (std::size_t n = 0; n < keep; ++n) {
    (*neighbors)[n] = {KeyIndex(candidates[n]), KeyDistance(candidates[n])};
  }
}

}  // namespace vilma::localizer

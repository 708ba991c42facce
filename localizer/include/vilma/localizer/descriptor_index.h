// Descriptor retrieval for localization (docs/localizer.md, "Localization"): binary descriptors
// are projected to a low-dimensional float space by a learned linear map (as maplab's
// train_projection_matrix), indexed with an inverted multi-index (Babenko and Lempitsky,
// "The Inverted Multi-Index", CVPR 2012; used for localization by Lynen et al., "Get Out of My
// Lab", 3DV 2015), searched for the k nearest neighbours in the projected space, which are then
// checked with the exact Hamming distance.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace vilma::localizer {

// Descriptor bits as +-1 floats (bit b of byte i -> element 8 i + b; 1 -> +1, 0 -> -1).
void DescriptorToSigns(const uint8_t* descriptor, int bytes, float* signs);

int HammingDistance(const uint8_t* a, const uint8_t* b, int bytes);

struct ProjectionTrainingOptions {
  int dimensions = 16;             // projected dimensions (even: two halves for the index)
  int max_pairs = 5000;            // matched pairs used (subsampled, seeded)
  double regularization = 1e-2;    // added to the within-class covariance's diagonal
  uint64_t seed = 7;
  std::string Validate() const;
};

// Linear discriminant projection (dimensions x bits) learned from descriptors labelled by
// landmark (`labels[d]`): with s the +-1 sign vectors, the within-class scatter
// S_w = E[(s_a - s_b)(s_a - s_b)^T] over pairs of one landmark and the between-class scatter
// S_b = E[(s_a - s_b)(s_a - s_b)^T] over pairs of different landmarks, the rows are the
// generalized eigenvectors S_b v = lambda (S_w + eps I) v of the largest eigenvalues, scaled so
// that v^T S_w v = 1: projected distances are in units of the matching noise, and the first
// rows separate landmarks best. Without any matched pair (every label distinct) it falls back
// to PCA of the descriptors (S_w = I). Throws std::invalid_argument on empty input.
Eigen::MatrixXf TrainProjectionMatrix(const std::vector<uint8_t>& descriptors, int bytes,
                                      const std::vector<uint32_t>& labels,
                                      const ProjectionTrainingOptions& options = {});

struct DescriptorIndexOptions {
  int codebook_size = 64;         // k-means centres per half: codebook_size^2 cells
  int kmeans_iterations = 15;
  int kmeans_max_samples = 50000;  // points used to train the codebooks (seeded subsample)
  uint64_t seed = 11;
  // k nearest neighbours returned per query: k = clamp(min_neighbors + descriptors /
  // descriptors_per_extra_neighbor, min_neighbors, max_neighbors); false neighbours closer
  // than the true one grow with the map, so k grows with it.
  int min_neighbors = 8;
  int max_neighbors = 32;
  int descriptors_per_extra_neighbor = 5000;
  // Cells are visited in order of distance until this many times k candidates are collected.
  int candidates_per_neighbor = 20;
  std::string Validate() const;
};

struct Neighbor {
  uint32_t index = 0;     // descriptor index in the indexed set
  float distance2 = 0.f;  // squared projected distance
};

// Buffers reused by the searches of one caller (one per thread: the index stays const and
// shareable). With them a search allocates nothing once they have grown to the query's size.
struct DescriptorSearchScratch {
  // Per half, per word: float bits of the squared distance of the query half to the word << 32
  // | word (integer order = order of (distance, word)); sorted lazily, nearest first.
  std::vector<uint64_t> words[2];
  std::vector<std::pair<float, uint32_t>> queue;  // multi-sequence heap: (lower bound, i*W + j)
  std::vector<uint32_t> popped;  // (i*W + j) -> number of the search that popped it
  uint32_t search = 0;           // stamp of the current search (no per-search clearing)
  // Candidates as (squared distance bits << 32 | descriptor index): ordered like Neighbors.
  std::vector<uint64_t> candidates;
};

class DescriptorIndex {
 public:
  DescriptorIndex() = default;
  // Projects and indexes `count` descriptors of `bytes` bytes. `projection` is D x (8 bytes)
  // with D even and <= 64. Throws std::invalid_argument on inconsistent sizes.
  DescriptorIndex(const Eigen::MatrixXf& projection, const uint8_t* descriptors, int bytes,
                  std::size_t count, const DescriptorIndexOptions& options = {});

  void Project(const uint8_t* descriptor, float* projected) const;
  int dimensions() const { return static_cast<int>(projection_.rows()); }
  int k() const { return k_; }
  std::size_t size() const { return count_; }

  // Up to k() nearest indexed descriptors in the projected space, nearest first (ties: lower
  // index), among the candidates of the cells visited in increasing lower-bound distance
  // (multi-sequence algorithm). Thread-safe (const); the scratch overloads reuse the caller's
  // buffers and write into *neighbors (cleared first), the others allocate.
  std::vector<Neighbor> Search(const uint8_t* descriptor) const;
  std::vector<Neighbor> SearchProjected(const float* projected, int k) const;
  void Search(const uint8_t* descriptor, DescriptorSearchScratch* scratch,
              std::vector<Neighbor>* neighbors) const;
  void SearchProjected(const float* projected, int k, DescriptorSearchScratch* scratch,
                       std::vector<Neighbor>* neighbors) const;

 private:
  Eigen::MatrixXf projection_;
  Eigen::MatrixXf projection2_;  // 2 * projection_
  Eigen::VectorXf column_sum_;   // projection_ * 1
  DescriptorIndexOptions options_;
  std::size_t count_ = 0;
  int bytes_ = 0;
  int half_ = 0;
  int k_ = 0;
  int words_ = 0;
  Eigen::MatrixXf codebook_[2];  // half x words
  // codebook_[h] transposed (words x half, column-major): the distances of a query half to all
  // words are then a loop over dimensions of contiguous, vectorizable rows of `words` floats.
  Eigen::MatrixXf codebook_t_[2];
  // Cell c = w0 * words + w1: slots cell_begin_[c] .. cell_begin_[c + 1]); slot s holds the
  // descriptor cell_items_[s] and its projection cell_projected_.col(s). Storing the projected
  // vectors in slot (cell) order makes a search read each visited cell as one contiguous run
  // instead of gathering scattered columns of a 100k x D array.
  std::vector<uint32_t> cell_begin_;
  std::vector<uint32_t> cell_items_;
  Eigen::MatrixXf cell_projected_;  // D x count, by slot
};

}  // namespace vilma::localizer

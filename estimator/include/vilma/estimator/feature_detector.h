// Feature detection for the filter: FAST corners on several pyramid levels, scored by the
// Shi-Tomasi measure of the multilevel patch they would become, bucketed over the image so
// that new features spread out, and kept away from the features already tracked.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "vilma/estimator/image_pyramid.h"
#include "vilma/estimator/multilevel_patch.h"

namespace vilma::estimator {

struct FeatureDetectorOptions {
  int fast_threshold = 10;          // FAST intensity threshold [grey levels]
  int min_level = 0;                // detect on pyramid levels [min_level, max_level]
  int max_level = 2;
  int grid_cols = 8;                // buckets over the image; at most one new feature each
  int grid_rows = 6;
  double min_distance_px = 20.0;    // from tracked features and from each other [level-0 px]
  double min_shi_tomasi_score = 0.0;  // reject weaker candidates (see DetectFeatures)
  int border_px = 12;               // keep candidates this far from the image border [level-0 px]
  // The patch whose Shi-Tomasi score ranks a candidate (use the tracker's patch options).
  PatchOptions patch;
  // Only the strongest FAST responses of each bucket and level are scored (bounds the cost on
  // highly textured images); 0 scores all.
  int max_candidates_per_bucket = 8;

  // Empty if valid, else "field: expectation".
  std::string Validate() const;
};

struct FeatureCandidate {
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // level-0 pixel coordinates
  int level = 0;                                    // pyramid level it was detected on
  double score = 0.0;                               // Shi-Tomasi score (higher is better)
};

// Up to `max_new` candidates, best score first, at most one per free grid bucket (a bucket
// holding an `occupied` pixel is not free), each at least min_distance_px from `occupied` and
// from the others. Deterministic for a given image.
std::vector<FeatureCandidate> DetectFeatures(const ImagePyramid& pyramid,
                                             const std::vector<Eigen::Vector2d>& occupied,
                                             int max_new, const FeatureDetectorOptions& options);

// As above, with a test of each candidate before it is taken (e.g. a stereo match: the
// filter's stereo.candidates_per_slot): a candidate that `accept` refuses is passed over and its
// bucket stays free for the next-best candidate there, up to max_refusals times in this call;
// after that candidates are taken untested as above. `refusals` (optional) gets the count.
std::vector<FeatureCandidate> DetectFeatures(
    const ImagePyramid& pyramid, const std::vector<Eigen::Vector2d>& occupied, int max_new,
    const FeatureDetectorOptions& options,
    const std::function<bool(const FeatureCandidate&)>& accept, int max_refusals,
    int* refusals);

}  // namespace vilma::estimator

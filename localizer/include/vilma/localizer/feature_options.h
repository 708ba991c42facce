// Options of keyframe feature extraction and frame-to-frame tracking (docs/localizer.md,
// "Keyframe features"). Plain structs with in-class defaults, one comment per field, nested
// into KeyframeFeatureOptions and checked by Validate(). Loaded strictly from YAML: unknown
// and missing keys are errors (config/localizer.yaml-style sections `detector`, `descriptor`,
// `matcher`, `ransac`).
#pragma once

#include <cstdint>
#include <string>

#include "vilma/core/yaml_io.h"

namespace vilma::localizer {

// Gridded keypoint detection: the image is cut into grid_cols x grid_rows cells and each cell
// keeps at most max_per_cell keypoints, best score first, so that features spread over the
// whole image instead of piling up on the most textured spot.
struct DetectorOptions {
  // "fast": FAST-9 corners, scored by the FAST score, one image level.
  // "orb": cv::ORB's detector: FAST on a scale pyramid, scored by the Harris response.
  std::string type = "orb";
  int fast_threshold = 15;    // FAST intensity threshold [grey levels]
  // Pyramid levels ("orb" only; "fast" uses 1). One by default: keypoints of coarser levels are
  // only as precise as their level's pixel (1.2, 1.44 px ...), and between consecutive
  // keyframes the scale barely changes; more levels help matching across distances.
  int num_levels = 1;
  double scale_factor = 1.2;  // pyramid scale step ("orb" only)
  // Fill levels ("orb" only) for views so close to the texture that it is magnified and
  // blurred: when the first num_levels levels keep fewer than fill_below_keypoints keypoints
  // (after suppression and the cell caps, before max_keypoints), fill_levels coarser levels
  // (scales scale_factor^num_levels, ^(num_levels + 1), ..., detected on their own) add
  // theirs, which only fill what the first levels leave: a cell gets them after all of its
  // first-level keypoints and up to max_per_cell, the global cap after every first-level
  // keypoint, and a first-level keypoint suppresses a fill keypoint near it, never the other
  // way. They see the texture at the scale a map made from farther away saw it
  // (docs/localizer.md, "Fill levels for close-up queries"). 0: none.
  int fill_levels = 0;
  int fill_below_keypoints = 150;
  int grid_cols = 8;          // grid cells across the image
  int grid_rows = 6;          // grid cells down the image
  int max_per_cell = 15;      // keypoints kept per cell at most
  int max_keypoints = 600;    // keypoints kept per image at most (best score first)
  // Non-maximum suppression across pyramid levels: no keypoint closer than this to a better
  // one (ORB finds one corner on several levels) [px].
  double min_distance_px = 3.0;
  int border_px = 24;         // no keypoint closer than this to the image border [px]
  // Sub-pixel refinement of every kept keypoint on the original (level-0) image
  // (docs/localizer.md, "Sub-pixel keypoints"). "none": the detector's position, an integer
  // pixel (a multiple of scale_factor^level px): its error stays the same while a feature moves
  // by less than a pixel between keyframes, so it is correlated along a track
  // (docs/optimization.md, "Street"). "corner_subpix": cv::cornerSubPix (Foerstner's corner
  // point: where the image gradients of the window are orthogonal to the offsets from it).
  std::string subpixel = "none";
  int subpixel_window_px = 3;  // half size of cornerSubPix's window: (2 w + 1)^2 pixels [px]
  // A refinement that moves the keypoint farther than this (an edge or a blob, not a corner)
  // keeps the detector's position [px].
  double subpixel_max_shift_px = 3.0;
  std::string Validate() const;
};

// Binary descriptor. Only BRISK (512 bit = 64 bytes) exists in Debian's OpenCV 4.6 (no
// xfeatures2d, hence no FREAK); the type string is stored with the features so that maps can
// tell descriptor types apart when others are added.
struct DescriptorOptions {
  std::string type = "brisk";  // only "brisk"
  // Size handed to BRISK for keypoints of pyramid level 0 (times scale_factor^level above);
  // it selects BRISK's sampling-pattern scale: larger is more blur tolerant, less local, and
  // needs a wider image border (BRISK drops keypoints whose pattern leaves the image) [px].
  double keypoint_size_px = 12.0;
  // Scale the size with the pyramid level (scale invariance, for matching across distances).
  // Off by default: between consecutive keyframes the scale barely changes, and a corner
  // detected on another level than before then keeps the same descriptor.
  bool scale_with_level = false;
  std::string Validate() const;
};

// Descriptor matching between consecutive keyframes inside a window around the position
// predicted by rotating the previous bearing with the gyroscope rotation.
struct MatcherOptions {
  double window_radius_px = 25.0;  // search radius around the predicted position [px]
  int max_hamming_distance = 80;   // accept a match only at or below this distance [bits]
  // Lowe's ratio test: best < ratio * second best among the window's candidates (1 = off).
  double ratio = 0.85;
  bool mutual = true;              // keep a match only if it is also the best the other way
  std::string Validate() const;
};

// Outlier rejection: translation-only 2-point RANSAC on bearing vectors with the rotation
// known from the gyroscope (Kneip et al., "Robust real-time visual odometry with a single
// camera and an IMU", BMVC 2011; what maplab's feature tracking does through OpenGV).
struct RansacOptions {
  std::string method = "two_point";  // "two_point" or "none" (keep every descriptor match)
  // Inlier threshold: distance of the current bearing to the epipolar plane, as pixels at the
  // camera's mean focal length [px].
  double threshold_px = 2.0;
  int max_iterations = 300;   // upper bound; stops early when `confidence` is reached
  double confidence = 0.999;  // probability of drawing one outlier-free sample
  int min_matches = 8;        // with fewer matches nothing can be verified: all are kept
  // Model selection: the rotation-only model (t = 0, no parallax) wins unless the best
  // translation explains more than this fraction of the matches in addition. A translation
  // has 2 more degrees of freedom and fits some outliers by chance (an outlier that moves along
  // its epipolar line); this is the GRIC-like penalty for them.
  double rotation_only_margin = 0.02;
  // ... and unless it explains at least this fraction of the correspondences with parallax:
  // when most moving matches fit no common translation, they are outliers and the few that a
  // translation happens to fit are too.
  double min_translation_support = 0.5;
  int seed = 1;  // sample generator seed, >= 0 (the same seed gives the same result)
  std::string Validate() const;
};

struct KeyframeFeatureOptions {
  DetectorOptions detector;
  DescriptorOptions descriptor;
  MatcherOptions matcher;
  RansacOptions ransac;
  // Empty when usable, otherwise "section.field: expectation".
  std::string Validate() const;
};

// The keyframe-feature profile of localization queries (config/localization_features.yaml;
// vilma-estimatord's `localization.features: ""` and `vilma localize` without --features): the
// defaults above with a 3-level ORB pyramid and BRISK sizes scaled with the level. A query often
// sees the map's texture from another distance than the mapping run did (1.9x in the simulated
// room, docs/benchmarks.md "Localization in the daemon"), where single-level fixed-size
// descriptors stop matching; the map keeps the single-level features that frame-to-frame
// tracking wants. 4 levels matched as well, but their coarse, less precise keypoints gave more
// inliers at the same error, so that the min_inliers gate let 5-10 cm results through
// (docs/daemon.md "Query features"). Three fill levels (scales 1.73-2.49) join only for views
// whose first levels keep fewer than 150 keypoints, a camera so close to the texture that it
// is magnified and blurred (sim room-s4's revisit of a wall: 92.4 -> 96.6 % recall, every other
// row of the acceptance benchmark unchanged; docs/localizer.md "Fill levels for close-up queries").
KeyframeFeatureOptions LocalizationQueryFeatureOptions();

// Strict readers: unknown keys are errors, an absent key or section keeps its value in `base`
// (the built-in defaults unless given: docs/design.md "Options files"); throws InputError
// naming the file, the key and the expectation (also for Validate() failures).
KeyframeFeatureOptions ReadKeyframeFeatureOptions(const YamlNode& node,
                                                  const KeyframeFeatureOptions& base = {});
KeyframeFeatureOptions ParseKeyframeFeatureOptions(const std::string& yaml_text,
                                                   const std::string& source_name);
KeyframeFeatureOptions LoadKeyframeFeatureOptions(const std::string& path,
                                                  const KeyframeFeatureOptions& base = {});
// YAML text that ReadKeyframeFeatureOptions reads back to the same options.
std::string KeyframeFeatureOptionsToYaml(const KeyframeFeatureOptions& options);

}  // namespace vilma::localizer

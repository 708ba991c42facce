// Track-consistent sub-pixel keypoints for the map builder (docs/mapping.md "Track refinement";
// issue 12, docs/optimization.md "Street").
//
// The builder's tracker re-detects keypoints in every keyframe and matches descriptors, so each
// observation of a track carries the detector's own placement error for that view: an integer
// pixel (or cornerSubPix's point), ~1.5 px inside a corner, which stays while the feature moves
// by less than a pixel and then jumps. That error is correlated along the track and bends the
// optimized trajectory (optvi). Here every observation of a track after the first is moved to
// where the track's reference patch (sampled around its first observation) aligns in the
// current keyframe image, so that all observations of a track point at the same physical
// point: the first observation's placement error becomes part of the landmark's definition
// (a constant offset on the surface), and what is left is the alignment's own noise.
//
// Alignment: parameters the patch centre c in the current image, the 2x2 warp A (affine mode;
// identity in translation mode) and a gain g and offset b for the brightness; minimized over
// the patch's samples o in {-h..h}^2
//   E = sum_o ( I(c + A o) - (g T(o) + b) )^2
// with T the reference samples and I the current image, bilinear. Since min over (g, b) of E is
// || P I(c + A .) ||^2 with P the projection onto the complement of span{T, 1}, the solver
// (AlignPatchTemplate) is Lucas-Kanade in its inverse compositional, "project out" form (Baker &
// Matthews, IJCV 2004, sec. 3.2, and "Lucas-Kanade 20 years on, part 3", 2003, sec. 4.2): the
// template is the track's first observation, fixed, so its steepest-descent images
//   SD = P [T_x, T_y, T_x o_x, T_x o_y, T_y o_x, T_y o_y]   (grad T times dW/dp at p = 0)
// and the Gauss-Newton matrix H = SD^T SD are computed once per track (PatchTemplate::Extract);
// each iteration samples I once per sample (no image gradients) and takes
//   dp = H^-1 SD^T I(c + A o) / g,   (c, A) <- (c, A) o (dc, 1 + dA)^-1
// with g = <I, T - mean T> / |T - mean T|^2 the current gain (the template's gradient scaled by
// g; without the division the step would overshoot by g). At convergence it solves the same
// problem as the forward additive Gauss-Newton on (c, A, g, b) (dr/dc = grad I, dr/dA_ij =
// (grad I)_i o_j, dr/dg = -T(o), dr/db = -1), kept as AlignPatchTemplateForwardAdditive (the
// reference in tests and the benchmark): 0.0024 px apart at most on synthetic warps
// (tests/mapping/track_refinement_test.cpp).
// It starts from the previous observation's aligned centre moved by the detector's motion
// between the two keyframes (c0 = c_prev + u_det - u_det_prev: the detector's own offset
// cancels) and the previous warp. An alignment that fails (leaves the image, does not
// converge, moves farther than max_shift_px from c0, keeps a large photometric error, or
// degenerates the warp) is handled by `on_failure`: "keep" (the default) leaves the
// observation in its track at c0, the best estimate without alignment (consistent with the
// track up to the detector's noise, so the builder stores the detector's sigma with it), and
// the next continuation aligns against the same first template again, from c0; "reanchor"
// keeps it at c0 as well but samples a new template there (later observations align to it);
// "split" (the behaviour before 2026-11-28) starts a new track at the observation, with the
// detector's position and itself as the reference.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>

namespace vilma::mapping {

struct TrackRefinementOptions {
  // "none": the detector's positions (tracks as the tracker makes them); "translation": the
  // reference patch aligned by its centre only (warp held at identity); "affine": centre and a
  // 2x2 warp (the patch's perspective change along the track: scale, shear).
  std::string method = "affine";
  int patch_half_size_px = 7;    // the patch is (2 h + 1)^2 samples [px]
  int max_iterations = 30;       // Gauss-Newton iterations at most
  double convergence_px = 0.005; // stop when no patch corner moves farther in a step [px]
  // Split the track when the aligned centre lies farther than this from the start c0 [px].
  double max_shift_px = 2.0;
  // Split the track when the aligned position lies farther than this from the detector's
  // keypoint in the same keyframe [px] (0: no limit). At the first observation the two
  // coincide; the detector's offset from a physical point stays within its own placement
  // noise (integer FAST: up to ~1.4 px; cornerSubPix: ~0.1 px), so a larger offset means the
  // patch slides (a patch across two surfaces, whose one affine warp fits neither).
  double max_offset_px = 0.0;
  // Split the track when the RMS photometric error after gain and offset is above this
  // [grey levels].
  double max_error_grey = 12.0;
  // Split when a singular value of the warp A leaves [1 / max_warp_scale, max_warp_scale]
  // (the patch shrank or grew that much since the reference: a new reference is better).
  double max_warp_scale = 2.0;
  // Measurement noise stored with every keypoint of a refined keyframe (mapstore::Keypoint::
  // sigma_px; optvi and triangulation weight by it) [px]: the observations of a track agree
  // with its first to ~0.1 px (street: median 0.085, p90 0.36 px against the truth,
  // docs/optimization.md "Track-consistent keypoints"); 0.15 px leaves room for the tail.
  // Observations kept in their track after a failed alignment ("keep", "reanchor") carry the
  // detector's sigma instead (MapBuilderOptions::triangulation.keypoint_sigma_px).
  double keypoint_sigma_px = 0.15;
  // A failed alignment: "keep" the observation in its track at c0 = c_prev + (u_det -
  // u_det_prev) and align the next one against the track's first template again; "reanchor":
  // at c0 too, with a new template sampled there for the later ones; "split": a new track
  // starts at the detector's position (more, shorter tracks: docs/mapping.md).
  std::string on_failure = "keep";
  // Empty when valid, else "field: expectation".
  std::string Validate() const;
  bool enabled() const { return method != "none"; }
};

// An 8-bit grey image as float with its central-difference gradients, for sampling.
struct GradientImage {
  cv::Mat intensity;  // CV_32F
  cv::Mat grad_x;     // CV_32F, dI/du [grey/px]; empty unless made with gradients
  cv::Mat grad_y;     // CV_32F, dI/dv
  // Throws std::invalid_argument unless `grey` is a non-empty CV_8UC1 image. The inverse
  // compositional solver and PatchTemplate::Extract need the intensity only; the forward
  // additive solver needs the gradients.
  static GradientImage FromGrey(const cv::Mat& grey, bool with_gradients = true);
};

// The reference samples T(o) of a track, row-major over o = (x, y), x fastest, and what the
// inverse compositional solver precomputes from them (see the header comment).
struct PatchTemplate {
  int half_size = 0;
  std::vector<float> samples;
  std::vector<float> gradients;  // per sample dT/du, dT/dv (central differences) [grey/px]
  bool prepared = false;         // the members below are set (Prepare)
  // Per sample the six steepest-descent values P [T_x, T_y, T_x o_x, T_x o_y, T_y o_x,
  // T_y o_y] (translation uses the first two: P acts column by column).
  std::vector<float> steepest_descent;
  double mean = 0.0;         // mean of the samples [grey]
  double centered_sq = 0.0;  // sum of (T - mean)^2 [grey^2]
  // H^-1 with H = SD^T SD: affine (6x6) and translation (its top-left 2x2 block's inverse);
  // *_ok false when H is not positive definite (a flat or one-dimensional patch).
  Eigen::Matrix<double, 6, 6> hessian_inv_affine = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix2d hessian_inv_translation = Eigen::Matrix2d::Zero();
  bool affine_ok = false;
  bool translation_ok = false;
  // Samples `image` bilinearly at uv + o (and at uv + o +- 1 for the central-difference
  // gradient, equal to sampling the gradient images); false when a sample (with the gradient's
  // border) leaves the image.
  bool Extract(const GradientImage& image, const Eigen::Vector2d& uv, int half_size);
  // Extract in two steps: the samples and gradients (Sample; all the forward additive solver
  // needs), then what the inverse compositional solver precomputes (Prepare; the refiner
  // prepares a track's template at its first continuation only).
  bool Sample(const GradientImage& image, const Eigen::Vector2d& uv, int half_size);
  void Prepare();
};

struct PatchAlignment {
  enum class Status {
    kOk, kLeftImage, kNotConverged, kTooFar, kLargeError, kBadWarp, kSingular, kOffset
  };
  static constexpr int kNumStatuses = static_cast<int>(Status::kOffset) + 1;
  Status status = Status::kNotConverged;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  // in the current image [px]
  Eigen::Matrix2d warp = Eigen::Matrix2d::Identity();
  double gain = 1.0;
  double offset = 0.0;
  double rms_error = 0.0;  // RMS of the residuals at the solution [grey levels]
  int iterations = 0;
  bool ok() const { return status == Status::kOk; }
};
const char* PatchAlignmentStatusName(PatchAlignment::Status status);

// Aligns `patch` in `image` from centre c0 and warp A0 (see the header comment): inverse
// compositional; `image` needs no gradients.
PatchAlignment AlignPatchTemplate(const PatchTemplate& patch, const GradientImage& image,
                                  const Eigen::Vector2d& c0, const Eigen::Matrix2d& A0,
                                  const TrackRefinementOptions& options);
// The same problem by forward additive Gauss-Newton on (c, A, g, b), three bilinear samples and
// an 8x8 normal-equation update per sample and iteration (the solver before 2026-11-27 night;
// the reference of the tests and the benchmark). `image` needs its gradients.
PatchAlignment AlignPatchTemplateForwardAdditive(const PatchTemplate& patch,
                                                 const GradientImage& image,
                                                 const Eigen::Vector2d& c0,
                                                 const Eigen::Matrix2d& A0,
                                                 const TrackRefinementOptions& options);

struct TrackRefinementStats {
  int64_t refined = 0;  // observations moved to the aligned position
  int64_t splits = 0;   // alignments that failed and started a new track ("split")
  int64_t kept = 0;     // alignments that failed, the observation kept at c0 ("keep", "reanchor")
  int64_t failed_by_status[PatchAlignment::kNumStatuses] = {};  // the failed alignments per PatchAlignment::Status
  double shift_sum_px = 0.0;        // sum of |aligned - detected| over the refined ones
};

// What the refinement made of a keypoint (the builder stores the refinement's sigma with
// kReference and kAligned, the detector's with kUnaligned).
enum class RefinedKeypoint : uint8_t {
  kReference,  // a track's first observation, or the first of a split track: the template
  kAligned,    // aligned to its track's template
  kUnaligned,  // kept in its track without alignment: c0 (or, without a template, the
               // detector's position), consistent with the track up to the detector's noise
};

// The refinement of one camera's tracks, keyframe by keyframe (the map builder holds one per
// camera, next to its FeatureTracker). Track ids: a tracker id is kept as long as the track is
// not split; a split track ("split") continues under a new id from `split_id_base` upwards
// (which must not overlap the tracker's ids).
class TrackRefiner {
 public:
  TrackRefiner(const TrackRefinementOptions& options, int64_t split_id_base);

  // `image`: the keyframe (8-bit grey); `tracker_ids`: the tracker's track id per keypoint;
  // `uv`: the detector's positions, replaced by the aligned ones; `track_ids`: set to the
  // builder's track id per keypoint; `kinds` (optional): set to what each keypoint became.
  // Tracks that this keyframe does not continue are forgotten (the tracker continues tracks
  // from the previous keyframe only).
  void Refine(const cv::Mat& image, const std::vector<int64_t>& tracker_ids,
              std::vector<Eigen::Vector2d>* uv, std::vector<int64_t>* track_ids,
              std::vector<RefinedKeypoint>* kinds = nullptr);
  // Forgets every track (the tracker was reset).
  void Reset() { tracks_.clear(); }
  const TrackRefinementStats& stats() const { return stats_; }
  // The solver (tests and the benchmark compare the two; not an option: the inverse
  // compositional one is the refinement, the forward additive one its reference).
  enum class Solver { kInverseCompositional, kForwardAdditive };
  void set_solver(Solver solver) { solver_ = solver; }

 private:
  struct Track {
    int64_t id = 0;                  // the builder's track id
    bool has_patch = false;
    PatchTemplate patch;             // reference samples
    Eigen::Vector2d detected_uv;     // the detector's position in the last keyframe
    Eigen::Vector2d aligned_uv;      // the stored (aligned) position in the last keyframe
    Eigen::Matrix2d warp = Eigen::Matrix2d::Identity();
  };
  TrackRefinementOptions options_;
  int64_t next_split_id_;
  std::unordered_map<int64_t, Track> tracks_;  // by tracker id
  std::unordered_map<int64_t, Track> next_;    // the next keyframe's (kept: its buckets reused)
  TrackRefinementStats stats_;
  Solver solver_ = Solver::kInverseCompositional;
};

}  // namespace vilma::mapping

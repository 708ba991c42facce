#include "vilma/mapping/track_refinement.h"

#include <Eigen/LU>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

using namespace vilma::mapping;

namespace {

// A smooth texture defined everywhere: one Gaussian blob per 6 px cell (position, size and
// amplitude from a hash of the cell and the seed) on a grey base, so that an image of it under
// any affine map is exact: pixel (u, v) shows the texture at M^-1 ((u, v) - t).
struct BlobTexture {
  static constexpr double kCell = 6.0;
  uint64_t seed;
  explicit BlobTexture(int s) : seed(static_cast<uint64_t>(s) * 0x9E3779B97F4A7C15ULL + 1) {}
  static double Unit(uint64_t h) {  // splitmix64 -> [0, 1)
    h += 0x9E3779B97F4A7C15ULL;
    h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ULL;
    h = (h ^ (h >> 27)) * 0x94D049BB133111EBULL;
    h ^= h >> 31;
    return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0);
  }
  double operator()(double x, double y) const {
    double v = 128.0;
    const int cx = static_cast<int>(std::floor(x / kCell));
    const int cy = static_cast<int>(std::floor(y / kCell));
    for (int j = cy - 2; j <= cy + 2; ++j) {
      for (int i = cx - 2; i <= cx + 2; ++i) {
        const uint64_t h = seed ^ (static_cast<uint64_t>(static_cast<uint32_t>(i)) << 32) ^
                           static_cast<uint64_t>(static_cast<uint32_t>(j)) * 0x2545F4914F6CDD1DULL;
        const double bx = (i + Unit(h)) * kCell;
        const double by = (j + Unit(h + 1)) * kCell;
        const double sigma = 1.6 + 1.8 * Unit(h + 2);
        const double amplitude = -50.0 + 100.0 * Unit(h + 3);
        const double dx = x - bx, dy = y - by;
        v += amplitude * std::exp(-0.5 * (dx * dx + dy * dy) / (sigma * sigma));
      }
    }
    return v;
  }
};

// The texture seen through u = M x + t, brightness gain * I + offset, 8-bit.
cv::Mat Render(const BlobTexture& tex, int width, int height, const Eigen::Matrix2d& M,
               const Eigen::Vector2d& t, double gain = 1.0, double offset = 0.0) {
  cv::Mat image(height, width, CV_8UC1);
  const Eigen::Matrix2d M_inv = M.inverse();
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector2d x = M_inv * (Eigen::Vector2d(u, v) - t);
      const double value = gain * tex(x.x(), x.y()) + offset;
      image.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(std::lround(value));
    }
  }
  return image;
}

TrackRefinementOptions Options(const std::string& method) {
  TrackRefinementOptions o;
  o.method = method;
  return o;
}

}  // namespace

TEST_CASE("track refinement options: defaults valid, bad values named", "[mapping][refine]") {
  TrackRefinementOptions o;
  CHECK(o.Validate().empty());
  CHECK(o.enabled());  // "affine" with on_failure "keep" by default since 2026-11-28
  o.method = "none";
  CHECK(o.Validate().empty());
  CHECK_FALSE(o.enabled());
  o.method = "affine";
  CHECK(o.Validate().empty());
  CHECK(o.enabled());
  o.method = "klt";
  CHECK(o.Validate().find("method") == 0);
  o = TrackRefinementOptions();
  o.patch_half_size_px = 1;
  CHECK(o.Validate().find("patch_half_size_px") == 0);
  o = TrackRefinementOptions();
  o.max_warp_scale = 1.0;
  CHECK(o.Validate().find("max_warp_scale") == 0);
  o = TrackRefinementOptions();
  o.max_offset_px = -1.0;
  CHECK(o.Validate().find("max_offset_px") == 0);
  o = TrackRefinementOptions();
  o.convergence_px = 0.0;
  CHECK(o.Validate().find("convergence_px") == 0);
  o = TrackRefinementOptions();
  CHECK(o.on_failure == "keep");
  for (const char* ok : {"keep", "reanchor", "split"}) {
    o.on_failure = ok;
    CHECK(o.Validate().empty());
  }
  o.on_failure = "drop";
  CHECK(o.Validate().find("on_failure") == 0);
}

TEST_CASE("AlignPatchTemplate finds a sub-pixel shift under a brightness change",
          "[mapping][refine]") {
  const BlobTexture tex(3);
  const Eigen::Matrix2d I2 = Eigen::Matrix2d::Identity();
  const GradientImage ref = GradientImage::FromGrey(Render(tex, 200, 160, I2, {0, 0}));
  const Eigen::Vector2d shift(0.37, -0.61);
  const GradientImage cur =
      GradientImage::FromGrey(Render(tex, 200, 160, I2, shift, 1.15, -8.0));
  const TrackRefinementOptions o = Options("translation");
  double worst = 0.0;
  int aligned = 0;
  for (int y = 40; y <= 120; y += 20) {
    for (int x = 40; x <= 160; x += 20) {
      PatchTemplate patch;
      REQUIRE(patch.Extract(ref, Eigen::Vector2d(x, y), o.patch_half_size_px));
      // Start from the integer pixel nearest the truth, as a detector would report it.
      const Eigen::Vector2d truth = Eigen::Vector2d(x, y) + shift;
      const Eigen::Vector2d c0(std::round(truth.x()), std::round(truth.y()));
      const PatchAlignment a = AlignPatchTemplate(patch, cur, c0, I2, o);
      INFO("at " << x << "," << y << ": " << PatchAlignmentStatusName(a.status));
      REQUIRE(a.ok());
      ++aligned;
      worst = std::max(worst, (a.center - truth).norm());
      CHECK(a.gain == Approx(1.15).margin(0.07));  // bilinear sampling blurs: a lower contrast
    }
  }
  INFO(aligned << " patches, worst error " << worst << " px");
  // Bilinear interpolation of both images and 8-bit rounding: a few hundredths of a pixel.
  CHECK(worst < 0.05);
}

TEST_CASE("AlignPatchTemplate: affine follows a scaled and sheared patch, translation does not",
          "[mapping][refine]") {
  const BlobTexture tex(5);
  const Eigen::Matrix2d I2 = Eigen::Matrix2d::Identity();
  const GradientImage ref = GradientImage::FromGrey(Render(tex, 240, 200, I2, {0, 0}));
  Eigen::Matrix2d M;
  M << 1.35, 0.12, -0.05, 1.25;  // the surface approached and tilted
  const Eigen::Vector2d t(-30.3, -24.8);
  const GradientImage cur = GradientImage::FromGrey(Render(tex, 240, 200, M, t));
  const TrackRefinementOptions affine = Options("affine");
  const TrackRefinementOptions translation = Options("translation");
  double worst_affine = 0.0;
  int translation_ok_and_close = 0, n = 0;
  for (int y = 70; y <= 130; y += 15) {
    for (int x = 70; x <= 150; x += 20) {
      PatchTemplate patch;
      REQUIRE(patch.Extract(ref, Eigen::Vector2d(x, y), affine.patch_half_size_px));
      const Eigen::Vector2d truth = M * Eigen::Vector2d(x, y) + t;
      const Eigen::Vector2d c0 = truth + Eigen::Vector2d(0.8, -0.6);
      // The previous keyframe's warp: part of the way there.
      const Eigen::Matrix2d A0 = Eigen::Matrix2d::Identity() + 0.8 * (M - I2);
      const PatchAlignment a = AlignPatchTemplate(patch, cur, c0, A0, affine);
      INFO("at " << x << "," << y << ": " << PatchAlignmentStatusName(a.status));
      REQUIRE(a.ok());
      worst_affine = std::max(worst_affine, (a.center - truth).norm());
      CHECK((a.warp - M).norm() < 0.05);
      const PatchAlignment b = AlignPatchTemplate(patch, cur, c0, I2, translation);
      if (b.ok() && (b.center - truth).norm() < 0.05) ++translation_ok_and_close;
      ++n;
    }
  }
  INFO("affine worst " << worst_affine << " px; translation within 0.05 px: "
                       << translation_ok_and_close << " of " << n);
  CHECK(worst_affine < 0.05);
  CHECK(translation_ok_and_close < n / 2);
}

TEST_CASE("AlignPatchTemplate rejects another texture and a patch leaving the image",
          "[mapping][refine]") {
  const Eigen::Matrix2d I2 = Eigen::Matrix2d::Identity();
  const GradientImage ref = GradientImage::FromGrey(Render(BlobTexture(7), 160, 120, I2, {0, 0}));
  const GradientImage other =
      GradientImage::FromGrey(Render(BlobTexture(8), 160, 120, I2, {0, 0}));
  const TrackRefinementOptions o = Options("affine");
  int rejected = 0, n = 0;
  for (int y = 30; y <= 90; y += 15) {
    for (int x = 30; x <= 130; x += 25) {
      PatchTemplate patch;
      REQUIRE(patch.Extract(ref, Eigen::Vector2d(x, y), o.patch_half_size_px));
      if (!AlignPatchTemplate(patch, other, Eigen::Vector2d(x, y), I2, o).ok()) ++rejected;
      ++n;
    }
  }
  INFO(rejected << " of " << n << " rejected");
  CHECK(rejected >= n * 9 / 10);
  PatchTemplate patch;
  REQUIRE(patch.Extract(ref, Eigen::Vector2d(80, 60), o.patch_half_size_px));
  CHECK(AlignPatchTemplate(patch, ref, Eigen::Vector2d(5, 60), I2, o).status ==
        PatchAlignment::Status::kLeftImage);
  CHECK_FALSE(patch.Extract(ref, Eigen::Vector2d(3, 60), o.patch_half_size_px));
}

TEST_CASE("TrackRefiner: observations follow the track's first one, a failure splits the track "
          "(split)",
          "[mapping][refine]") {
  // A surface approached over 12 keyframes (scale 1 -> 1.5) and drifting sideways; keypoints
  // "detected" at the integer pixel nearest each point's image (a quantization error that
  // persists while the image moves by less than a pixel), tracker ids 10, 11, ...
  const BlobTexture tex(11);
  const int width = 320, height = 240;
  const std::vector<Eigen::Vector2d> points = {{120, 100}, {160, 120}, {200, 110}, {150, 140},
                                               {180, 90}};
  const int64_t split_base = int64_t{1} << 39;
  TrackRefinementOptions options = Options("affine");
  options.on_failure = "split";
  TrackRefiner refiner(options, split_base);
  std::vector<std::vector<Eigen::Vector2d>> stored;
  const Eigen::Vector2d center(160, 120);
  double worst = 0.0;
  for (int f = 0; f < 12; ++f) {
    const double s = 1.0 + 0.5 * f / 11.0;
    const Eigen::Matrix2d M = s * Eigen::Matrix2d::Identity();
    const Eigen::Vector2d t = center - M * center + Eigen::Vector2d(0.23 * f, -0.17 * f);
    const cv::Mat image = Render(tex, width, height, M, t);
    std::vector<int64_t> tracker_ids;
    std::vector<Eigen::Vector2d> uv;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d p = M * points[i] + t;
      tracker_ids.push_back(10 + static_cast<int64_t>(i));
      uv.emplace_back(std::round(p.x()), std::round(p.y()));
    }
    std::vector<int64_t> ids;
    refiner.Refine(image, tracker_ids, &uv, &ids);
    REQUIRE(ids == tracker_ids);  // no split
    for (std::size_t i = 0; i < points.size(); ++i) {
      // Where the first observation's (integer) pixel lies on the surface, seen now.
      const Eigen::Vector2d first(std::round(points[i].x()), std::round(points[i].y()));
      const Eigen::Vector2d truth = M * first + t;
      worst = std::max(worst, (uv[i] - truth).norm());
    }
  }
  INFO("worst error against the first observation's point: " << worst << " px");
  CHECK(worst < 0.05);
  CHECK(refiner.stats().refined == 11 * 5);
  CHECK(refiner.stats().splits == 0);

  // Another texture under the same tracks: every alignment fails, each track continues under a
  // new id from the split base, and the keypoints keep the detector's positions.
  const cv::Mat other = Render(BlobTexture(12), width, height, Eigen::Matrix2d::Identity(), {0, 0});
  std::vector<int64_t> tracker_ids = {10, 11, 12, 13, 14, 99};
  std::vector<Eigen::Vector2d> uv = {{120, 100}, {160, 120}, {200, 110}, {150, 140}, {180, 90},
                                     {100, 100}};
  const std::vector<Eigen::Vector2d> detected = uv;
  std::vector<int64_t> ids;
  refiner.Refine(other, tracker_ids, &uv, &ids);
  CHECK(uv == detected);
  for (std::size_t i = 0; i < 5; ++i) CHECK(ids[i] == split_base + static_cast<int64_t>(i));
  CHECK(ids[5] == 99);  // a new tracker track keeps its id
  CHECK(refiner.stats().splits == 5);
  // The split tracks continue under their new ids.
  refiner.Refine(other, tracker_ids, &uv, &ids);
  for (std::size_t i = 0; i < 5; ++i) CHECK(ids[i] == split_base + static_cast<int64_t>(i));
  CHECK(refiner.stats().splits == 5);
}

TEST_CASE("TrackRefiner: a failed alignment in the middle of a track keeps the track (keep, "
          "reanchor)",
          "[mapping][refine]") {
  // One surface drifting sideways by (0.31, -0.23) px per keyframe over 8 keyframes; keyframe
  // 4 shows another texture (an occlusion): its alignments fail. The detector reports each
  // point at the integer pixel nearest its image, in keyframe 4 too (it matched descriptors).
  const BlobTexture tex(31);
  const int width = 240, height = 180;
  const std::vector<Eigen::Vector2d> points = {{80, 70}, {120, 90}, {150, 60}};
  const Eigen::Matrix2d I2 = Eigen::Matrix2d::Identity();
  const Eigen::Vector2d drift(0.31, -0.23);
  const int kFailed = 4;
  for (const std::string mode : {"keep", "reanchor"}) {
    INFO("on_failure " << mode);
    TrackRefinementOptions o = Options("affine");
    o.on_failure = mode;
    TrackRefiner refiner(o, int64_t{1} << 39);
    std::vector<Eigen::Vector2d> stored_before(points.size());
    for (int f = 0; f < 8; ++f) {
      const Eigen::Vector2d t = drift * f;
      const cv::Mat image = f == kFailed ? Render(BlobTexture(32), width, height, I2, t)
                                         : Render(tex, width, height, I2, t);
      std::vector<int64_t> tracker_ids;
      std::vector<Eigen::Vector2d> uv, detected;
      for (std::size_t i = 0; i < points.size(); ++i) {
        const Eigen::Vector2d p = points[i] + t;
        tracker_ids.push_back(20 + static_cast<int64_t>(i));
        uv.emplace_back(std::round(p.x()), std::round(p.y()));
      }
      detected = uv;
      std::vector<int64_t> ids;
      std::vector<RefinedKeypoint> kinds;
      refiner.Refine(image, tracker_ids, &uv, &ids, &kinds);
      INFO("keyframe " << f);
      REQUIRE(ids == tracker_ids);  // one track each, the failed keyframe included
      for (std::size_t i = 0; i < points.size(); ++i) {
        const Eigen::Vector2d first(std::round(points[i].x()), std::round(points[i].y()));
        const Eigen::Vector2d truth = first + t;  // the first observation's point, seen now
        if (f == 0) {
          CHECK(kinds[i] == RefinedKeypoint::kReference);
          CHECK(uv[i] == detected[i]);
        } else if (f == kFailed) {
          // Kept at c0: the previous stored point moved by the detector's motion.
          CHECK(kinds[i] == RefinedKeypoint::kUnaligned);
          const Eigen::Vector2d detected_before =
              Eigen::Vector2d(std::round(points[i].x() + drift.x() * (f - 1)),
                              std::round(points[i].y() + drift.y() * (f - 1)));
          CHECK((uv[i] - (stored_before[i] + detected[i] - detected_before)).norm() < 1e-12);
          // Consistent with the track up to the detector's noise (quantization: < 1.5 px).
          CHECK((uv[i] - truth).norm() < 1.5);
        } else if (f < kFailed || mode == "keep") {
          // Aligned to the first template: on the first observation's point.
          CHECK(kinds[i] == RefinedKeypoint::kAligned);
          CHECK((uv[i] - truth).norm() < 0.05);
        } else {
          // reanchor: aligned to the template taken at c0 in the failed keyframe, which shows
          // the other texture: the alignment fails again and the observation stays at c0.
          CHECK(kinds[i] != RefinedKeypoint::kReference);
        }
        stored_before[i] = uv[i];
      }
    }
    CHECK(refiner.stats().splits == 0);
    CHECK(refiner.stats().kept >= 3);
    if (mode == "keep") {
      CHECK(refiner.stats().refined == 6 * 3);
      CHECK(refiner.stats().kept == 3);
    }
  }
}

TEST_CASE("TrackRefiner: after a detector jump, reanchor aligns to the template taken at c0",
          "[mapping][refine]") {
  // The surface moves by whole pixels (exact detections); from keyframe 1 on the detector
  // reports the point 2.5 px to the right (it settled on a neighbouring corner), so c0 (the
  // previous point moved by the detector's motion) lies 2.5 px off in keyframe 1 and the
  // alignment, which finds the first template's point, is too far from it. keep: the track
  // stays, every later c0 is 2.5 px off as well and its alignments to the first template fail
  // the same way; reanchor: a template at c0 in keyframe 1, to which the later ones align.
  const BlobTexture tex(41);
  const int width = 200, height = 160;
  const Eigen::Matrix2d I2 = Eigen::Matrix2d::Identity();
  const Eigen::Vector2d point(100, 80), drift(1, -1), jump(2.5, 0);
  for (const std::string mode : {"keep", "reanchor"}) {
    INFO("on_failure " << mode);
    TrackRefinementOptions o = Options("affine");
    o.on_failure = mode;
    o.max_shift_px = 1.0;
    TrackRefiner refiner(o, 1000);
    for (int f = 0; f < 4; ++f) {
      const Eigen::Vector2d truth = point + drift * f;
      const cv::Mat image = Render(tex, width, height, I2, drift * f);
      std::vector<Eigen::Vector2d> uv = {f == 0 ? truth : Eigen::Vector2d(truth + jump)};
      std::vector<int64_t> ids;
      std::vector<RefinedKeypoint> kinds;
      refiner.Refine(image, {5}, &uv, &ids, &kinds);
      INFO("keyframe " << f);
      REQUIRE(ids == std::vector<int64_t>{5});
      if (f == 0) {
        CHECK(kinds[0] == RefinedKeypoint::kReference);
      } else if (f == 1 || mode == "keep") {
        CHECK(kinds[0] == RefinedKeypoint::kUnaligned);
        CHECK((uv[0] - (truth + jump)).norm() < 1e-9);
      } else {
        CHECK(kinds[0] == RefinedKeypoint::kAligned);
        CHECK((uv[0] - (truth + jump)).norm() < 0.05);
      }
    }
    CHECK(refiner.stats().splits == 0);
    CHECK(refiner.stats().failed_by_status[static_cast<int>(PatchAlignment::Status::kTooFar)] ==
          (mode == "keep" ? 3 : 1));
  }
}

TEST_CASE("TrackRefiner with method none changes nothing", "[mapping][refine]") {
  TrackRefiner refiner(Options("none"), 1000);
  const cv::Mat image(100, 100, CV_8UC1, cv::Scalar(7));
  std::vector<Eigen::Vector2d> uv = {{10, 20}, {30.5, 40}};
  const std::vector<Eigen::Vector2d> before = uv;
  std::vector<int64_t> ids;
  refiner.Refine(image, {3, -1}, &uv, &ids);
  CHECK(uv == before);
  CHECK(ids == std::vector<int64_t>{3, -1});
}

TEST_CASE("TrackRefiner: max_offset_px splits a track whose aligned point leaves the detector's",
          "[mapping][refine]") {
  const BlobTexture tex(21);
  const Eigen::Matrix2d I2 = Eigen::Matrix2d::Identity();
  const cv::Mat first = Render(tex, 200, 160, I2, {0, 0});
  const Eigen::Vector2d shift(3.3, -2.2);
  const cv::Mat second = Render(tex, 200, 160, I2, shift);
  for (const double max_offset : {0.0, 2.0, 1.0}) {
    TrackRefinementOptions o = Options("affine");
    o.on_failure = "split";
    o.max_offset_px = max_offset;
    TrackRefiner refiner(o, 1000);
    std::vector<Eigen::Vector2d> uv = {{100, 80}};
    std::vector<int64_t> ids;
    refiner.Refine(first, {7}, &uv, &ids);
    // The detector reports the point 1.5 px off (a corner of another surface, or a slid one).
    const Eigen::Vector2d detected = Eigen::Vector2d(100, 80) + shift + Eigen::Vector2d(1.5, 0.0);
    uv = {detected};
    refiner.Refine(second, {7}, &uv, &ids);
    INFO("max_offset_px " << max_offset);
    if (max_offset == 1.0) {
      CHECK(ids[0] == 1000);
      CHECK(uv[0] == detected);
      CHECK(refiner.stats().failed_by_status[static_cast<int>(PatchAlignment::Status::kOffset)] ==
            1);
    } else {
      CHECK(ids[0] == 7);
      CHECK((uv[0] - (Eigen::Vector2d(100, 80) + shift)).norm() < 0.05);
    }
  }
}

TEST_CASE("AlignPatchTemplate (inverse compositional) matches the forward additive solver",
          "[mapping][refine]") {
  // Both solve the same problem (min over c, A, g, b of the photometric error): on exact
  // synthetic warps with a brightness change they must end at the same point, up to their
  // convergence tolerance (a step below convergence_px = 0.005 px at the patch corners). Only
  // where the warp model fits: the inverse compositional fixed point is the minimum when the
  // residual is small; "translation" on a scaled patch leaves a large one, and there the two
  // stop up to 0.3 px apart (measured; both within max_error_grey).
  const BlobTexture tex(9);
  const Eigen::Matrix2d I2 = Eigen::Matrix2d::Identity();
  const GradientImage ref = GradientImage::FromGrey(Render(tex, 260, 220, I2, {0, 0}));
  struct Case {
    Eigen::Matrix2d M;
    Eigen::Vector2d t;
    double gain, offset;
  };
  std::vector<Case> cases;
  cases.push_back({I2, {0.37, -0.61}, 1.15, -8.0});
  Eigen::Matrix2d M;
  M << 1.2, 0.08, -0.04, 1.1;
  cases.push_back({M, {-20.3, -11.8}, 0.9, 12.0});
  M << 0.85, -0.1, 0.06, 0.9;
  cases.push_back({M, {18.6, 15.1}, 1.0, 0.0});
  double worst_center = 0.0, worst_warp = 0.0, worst_rms = 0.0, worst_truth = 0.0;
  int compared = 0;
  for (const std::string method : {"translation", "affine"}) {
    const TrackRefinementOptions o = Options(method);
    for (const Case& c : cases) {
      if (method == "translation" && c.M != I2) continue;  // the model does not fit
      const GradientImage cur =
          GradientImage::FromGrey(Render(tex, 260, 220, c.M, c.t, c.gain, c.offset));
      for (int y = 70; y <= 150; y += 20) {
        for (int x = 70; x <= 190; x += 30) {
          PatchTemplate patch;
          REQUIRE(patch.Extract(ref, Eigen::Vector2d(x, y), o.patch_half_size_px));
          const Eigen::Vector2d truth = c.M * Eigen::Vector2d(x, y) + c.t;
          const Eigen::Vector2d c0 = truth + Eigen::Vector2d(0.6, -0.45);
          const Eigen::Matrix2d A0 = I2 + 0.7 * (c.M - I2);
          const PatchAlignment fa = AlignPatchTemplateForwardAdditive(patch, cur, c0, A0, o);
          const PatchAlignment ic = AlignPatchTemplate(patch, cur, c0, A0, o);
          INFO(method << " at " << x << "," << y << ": forward additive "
                      << PatchAlignmentStatusName(fa.status) << ", inverse compositional "
                      << PatchAlignmentStatusName(ic.status));
          CHECK(fa.status == ic.status);
          if (!fa.ok() || !ic.ok()) continue;
          ++compared;
          worst_center = std::max(worst_center, (fa.center - ic.center).norm());
          worst_warp = std::max(worst_warp, (fa.warp - ic.warp).norm());
          // The forward additive solver reports the residual of its last iteration's start
          // (with that iteration's gain and offset): one step stale, so never below the inverse
          // compositional one, which is the minimum over gain and offset at its solution
          // (translation, 2 iterations: 1.01 against 0.51 grey).
          worst_rms = std::max(worst_rms, ic.rms_error - fa.rms_error);
          if (method == "affine") worst_truth = std::max(worst_truth, (ic.center - truth).norm());
          CHECK(ic.gain == Approx(fa.gain).margin(0.01));
          CHECK(ic.offset == Approx(fa.offset).margin(1.5));
        }
      }
    }
  }
  INFO(compared << " alignments compared; worst centre difference " << worst_center
                << " px, warp " << worst_warp << ", RMS error above " << worst_rms
                << " grey; inverse compositional (affine) against the truth " << worst_truth
                << " px");
  CHECK(compared >= 60);
  CHECK(worst_center < 0.01);
  CHECK(worst_warp < 0.005);
  CHECK(worst_rms < 0.02);
  CHECK(worst_truth < 0.05);
}

TEST_CASE("PatchTemplate::Extract's steepest-descent images from the gradient images' samples",
          "[mapping][refine]") {
  // The inverse compositional solver differentiates the template by central differences of
  // bilinear samples of the intensity; that must equal sampling GradientImage::grad_x/y (what
  // the forward additive solver uses), so both solvers see one template. Rebuilt here from the
  // gradient images: SD = P [g_x, g_y, g_x o_x, g_x o_y, g_y o_x, g_y o_y], P projecting out
  // span{1, T - mean T}.
  const cv::Mat grey = Render(BlobTexture(4), 120, 100, Eigen::Matrix2d::Identity(), {0, 0});
  const GradientImage with = GradientImage::FromGrey(grey);
  const GradientImage without = GradientImage::FromGrey(grey, false);
  CHECK(without.grad_x.empty());
  const Eigen::Vector2d uv(40.3, 51.8);
  const int h = 5;
  PatchTemplate a, b;
  REQUIRE(a.Extract(with, uv, h));
  REQUIRE(b.Extract(without, uv, h));
  CHECK(a.samples == b.samples);
  CHECK(a.steepest_descent == b.steepest_descent);
  CHECK(a.affine_ok);
  CHECK(a.translation_ok);
  const auto bilinear = [](const cv::Mat& m, double u, double v) {
    const int x = static_cast<int>(std::floor(u)), y = static_cast<int>(std::floor(v));
    const double fx = u - x, fy = v - y;
    return (1 - fy) * ((1 - fx) * m.at<float>(y, x) + fx * m.at<float>(y, x + 1)) +
           fy * ((1 - fx) * m.at<float>(y + 1, x) + fx * m.at<float>(y + 1, x + 1));
  };
  const std::size_t n = a.samples.size();
  Eigen::MatrixXd sd(static_cast<Eigen::Index>(n), 6);
  Eigen::VectorXd t(static_cast<Eigen::Index>(n));
  std::size_t k = 0;
  for (int y = -h; y <= h; ++y) {
    for (int x = -h; x <= h; ++x, ++k) {
      const double gx = bilinear(with.grad_x, uv.x() + x, uv.y() + y);
      const double gy = bilinear(with.grad_y, uv.x() + x, uv.y() + y);
      sd.row(static_cast<Eigen::Index>(k)) << gx, gy, gx * x, gx * y, gy * x, gy * y;
      t(static_cast<Eigen::Index>(k)) = a.samples[k] - a.mean;
    }
  }
  const Eigen::VectorXd unit = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(n)) /
                               std::sqrt(static_cast<double>(n));
  const Eigen::VectorXd t_unit = t.normalized();
  double worst = 0.0, largest = 0.0;
  for (int j = 0; j < 6; ++j) {
    Eigen::VectorXd col = sd.col(j);
    col -= unit * unit.dot(col) + t_unit * t_unit.dot(col);
    for (std::size_t i = 0; i < n; ++i) {
      worst = std::max(worst, std::abs(col(static_cast<Eigen::Index>(i)) -
                                       a.steepest_descent[6 * i + static_cast<std::size_t>(j)]));
      largest = std::max(largest, std::abs(col(static_cast<Eigen::Index>(i))));
    }
  }
  INFO("worst difference " << worst << " of values up to " << largest);
  CHECK(worst < 1e-4 * largest);
  // The same image aligned onto itself stays put, in one iteration.
  const PatchAlignment self =
      AlignPatchTemplate(a, without, uv, Eigen::Matrix2d::Identity(), Options("affine"));
  REQUIRE(self.ok());
  CHECK((self.center - uv).norm() < 1e-3);
  CHECK(self.iterations == 1);
}

#include "vilma/estimator/multilevel_patch.h"

#include <catch2/catch.hpp>
#include <Eigen/Geometry>
#include <algorithm>
#include <functional>

#include "estimator/synthetic_images.h"
#include "vilma/estimator/feature_detector.h"
#include "test_skip.h"

namespace vilma::estimator {
namespace {

using JacobianN2 = Eigen::Matrix<double, Eigen::Dynamic, 2>;
constexpr int kWidth = 320;
constexpr int kHeight = 240;

const testing::SmoothTexture& Texture() {
  static const testing::SmoothTexture texture(kWidth, kHeight, 90, 42u);
  return texture;
}

// Interior test points, far enough from the border for a 4-level 6x6 patch under warps.
std::vector<Eigen::Vector2d> TestPoints() {
  std::vector<Eigen::Vector2d> points;
  for (double y : {80.0, 120.3, 160.0}) {
    for (double x : {90.2, 130.0, 160.7, 200.0, 235.5}) points.emplace_back(x, y);
  }
  return points;
}

Eigen::Matrix2d ScaledRotation(double scale, double angle_deg) {
  return scale * Eigen::Rotation2Dd(angle_deg * M_PI / 180.0).toRotationMatrix();
}

TEST_CASE("Patch options are validated", "[patch]") {
  PatchOptions o;
  CHECK(o.Validate().empty());
  o.patch_size = 1;
  CHECK(o.Validate().find("patch_size") != std::string::npos);
  o = PatchOptions();
  o.num_levels = 0;
  CHECK(o.Validate().find("num_levels") != std::string::npos);
}

TEST_CASE("Patch extraction on sample-aligned positions equals image pixels", "[patch]") {
  const cv::Mat image = Texture().Render(kWidth, kHeight);
  ImagePyramid pyramid;
  pyramid.Build(image, 4);
  // Odd size: samples on integer offsets, so an integer p_l hits pixels. Even size: offsets
  // are half-integers, so p_l must be half-integer.
  for (const int size : {5, 6}) {
    PatchOptions options;
    options.patch_size = size;
    options.num_levels = 4;
    const double half = 0.5 * (size - 1);
    for (int l = 0; l < 4; ++l) {
      const Eigen::Vector2d corner_l(17.0 - (48 >> l) % 3, 11.0);  // integer pixel, level l
      const Eigen::Vector2d p_l = corner_l + Eigen::Vector2d(half, half);
      const Eigen::Vector2d p_0 = ImagePyramid::BaseFromLevel(p_l, l);
      MultilevelPatch patch;
      REQUIRE(patch.Extract(pyramid, p_0, Eigen::Matrix2d::Identity(), options));
      REQUIRE(patch.level_valid(l));
      const cv::Mat& level = pyramid.level(l);
      for (int r = 0; r < size; ++r) {
        for (int c = 0; c < size; ++c) {
          const int x = static_cast<int>(corner_l.x()) + c;
          const int y = static_cast<int>(corner_l.y()) + r;
          const int k = r * size + c;
          INFO("size " << size << " level " << l << " sample " << c << "," << r);
          CHECK(patch.intensities(l)[k] == Approx(level.at<uchar>(y, x)).margin(1e-4));
          const double gx = 0.5 * (level.at<uchar>(y, x + 1) - level.at<uchar>(y, x - 1));
          const double gy = 0.5 * (level.at<uchar>(y + 1, x) - level.at<uchar>(y - 1, x));
          CHECK(patch.gradient_x(l)[k] == Approx(gx).margin(1e-4));
          CHECK(patch.gradient_y(l)[k] == Approx(gy).margin(1e-4));
        }
      }
    }
  }
}

TEST_CASE("Levels whose samples leave the image are invalid and skipped", "[patch]") {
  const cv::Mat image = Texture().Render(kWidth, kHeight);
  ImagePyramid pyramid;
  pyramid.Build(image, 4);
  PatchOptions options;
  MultilevelPatch patch;
  // 6x6 + border on level 3 spans +-3.5 level-3 px = +-28 level-0 px; level 2: +-14 px.
  const Eigen::Vector2d near_border(20.0, 120.0);
  REQUIRE(patch.Extract(pyramid, near_border, Eigen::Matrix2d::Identity(), options));
  CHECK(patch.level_valid(0));
  CHECK(patch.level_valid(1));
  CHECK(patch.level_valid(2));
  CHECK_FALSE(patch.level_valid(3));
  CHECK_FALSE(patch.Extract(pyramid, Eigen::Vector2d(1.0, 1.0), Eigen::Matrix2d::Identity(),
                            options));
  CHECK(patch.ShiTomasiScore() == 0.0);

  REQUIRE(patch.Extract(pyramid, near_border, Eigen::Matrix2d::Identity(), options));
  Eigen::VectorXd r;
  JacobianN2 J;
  PhotometricOptions photometric;
  REQUIRE(ComputePhotometricResidual(patch, pyramid, near_border, Eigen::Matrix2d::Identity(),
                                     photometric, &r, &J));
  CHECK(r.size() == 3 * 36);
  CHECK(J.rows() == 3 * 36);
  // Moving further out drops level 2 too (needs +-2.5 * 4 = 10 px without border).
  const Eigen::Vector2d closer(9.0, 120.0);
  REQUIRE(ComputePhotometricResidual(patch, pyramid, closer, Eigen::Matrix2d::Identity(),
                                     photometric, &r, &J));
  CHECK(r.size() == 2 * 36);
  CHECK_FALSE(ComputePhotometricResidual(patch, pyramid, Eigen::Vector2d(-5.0, 120.0),
                                         Eigen::Matrix2d::Identity(), photometric, &r, &J));
}

TEST_CASE("Identity warp at the true position gives zero residual, rows coarse first",
          "[patch]") {
  const cv::Mat image = Texture().Render(kWidth, kHeight);
  ImagePyramid pyramid;
  pyramid.Build(image, 4);
  PatchOptions options;
  const Eigen::Vector2d p(150.3, 101.8);
  MultilevelPatch patch;
  REQUIRE(patch.Extract(pyramid, p, Eigen::Matrix2d::Identity(), options));
  CHECK(patch.ShiTomasiScore() > 0.0);
  for (const bool compensate : {false, true}) {
    PhotometricOptions photometric;
    photometric.compensate_illumination = compensate;
    Eigen::VectorXd r;
    JacobianN2 J;
    REQUIRE(ComputePhotometricResidual(patch, pyramid, p, Eigen::Matrix2d::Identity(),
                                       photometric, &r, &J));
    REQUIRE(r.size() == 4 * 36);
    CHECK(r.cwiseAbs().maxCoeff() < 1e-9);

    // Stacking: at another position, the first 36 rows are level 3 and the last 36 level 0.
    const Eigen::Vector2d q = p + Eigen::Vector2d(1.7, -0.9);
    REQUIRE(ComputePhotometricResidual(patch, pyramid, q, Eigen::Matrix2d::Identity(),
                                       photometric, &r, &J));
    for (const int l : {0, 3}) {
      PhotometricOptions single = photometric;
      single.min_level = l;
      single.max_level = l;
      Eigen::VectorXd r_l;
      JacobianN2 J_l;
      REQUIRE(ComputePhotometricResidual(patch, pyramid, q, Eigen::Matrix2d::Identity(), single,
                                         &r_l, &J_l));
      REQUIRE(r_l.size() == 36);
      const Eigen::Index start = (l == 3) ? 0 : 3 * 36;
      CHECK((r.segment(start, 36) - r_l).norm() < 1e-12);
      CHECK((J.middleRows(start, 36) - J_l).norm() < 1e-12);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Jacobian tests. The analytic Jacobian is built from the patch gradients (central differences
// of the warped samples, mapped through W^-T and scaled by 2^-l, see multilevel_patch.cpp), not
// from the derivative of the bilinear interpolant. A numeric derivative with an arbitrary step
// therefore differentiates something else (a piecewise-linear function with kinks at pixel
// boundaries). The two tests below compare like with like, each exactly:
//  1. on the pixel grid: with samples on pixel centres and a numeric step of exactly one warp
//     step (|W| level-l px = |W| 2^l level-0 px), the central difference of the residual IS the
//     patch gradient mapped through W^-T, for warps that map the patch axes onto the pixel
//     axes (identity, 90 deg rotation, 2 x 90 deg rotation);
//  2. on a linear ramp, where bilinear interpolation is exact at any position and for any warp.
// The illumination projection is linear in the image, so both hold with compensation too.

// Central difference of the single-level residual w.r.t. the level-0 pixel, step h [px].
JacobianN2 NumericJacobian(const MultilevelPatch& patch, const ImagePyramid& pyramid,
                           const Eigen::Vector2d& p, const Eigen::Matrix2d& W,
                           const PhotometricOptions& o, double h) {
  JacobianN2 J_num;
  for (int i = 0; i < 2; ++i) {
    Eigen::VectorXd r_plus, r_minus;
    const Eigen::Vector2d e = h * Eigen::Vector2d::Unit(i);
    REQUIRE(ComputePhotometricResidual(patch, pyramid, p + e, W, o, &r_plus, nullptr));
    REQUIRE(ComputePhotometricResidual(patch, pyramid, p - e, W, o, &r_minus, nullptr));
    if (i == 0) J_num.resize(r_plus.size(), 2);
    J_num.col(i) = (r_plus - r_minus) / (2.0 * h);
  }
  return J_num;
}

PhotometricOptions SingleLevel(int level, bool compensate) {
  PhotometricOptions o;
  o.min_level = level;
  o.max_level = level;
  o.compensate_illumination = compensate;
  return o;
}

TEST_CASE("Residual Jacobian equals the one-pixel central difference on the pixel grid",
          "[patch]") {
  ImagePyramid pyramid;
  pyramid.Build(Texture().Render(kWidth, kHeight), 4);
  PatchOptions options;
  options.patch_size = 5;  // odd: integer offsets, so samples hit pixel centres
  const Eigen::Matrix2d R90 = ScaledRotation(1.0, 90.0).array().round().matrix();
  struct WarpCase {
    const char* name;
    Eigen::Matrix2d W;
    double step;  // level-l px per patch-axis step
  };
  const std::vector<WarpCase> warps = {{"identity", Eigen::Matrix2d::Identity(), 1.0},
                                       {"rotation 90", R90, 1.0},
                                       {"2 x rotation 90", 2.0 * R90, 2.0}};
  for (const WarpCase& w : warps) {
    for (int l = 0; l < 4; ++l) {
      // Integer pixel on level l (inside the 40 x 30 level 3 with the +-6 px bordered grid).
      const Eigen::Vector2d p_l(17.0 + l, 13.0 + (l % 2));
      const Eigen::Vector2d p_0 = ImagePyramid::BaseFromLevel(p_l, l);
      MultilevelPatch patch;
      REQUIRE(patch.Extract(pyramid, p_0, w.W, options));
      REQUIRE(patch.level_valid(l));
      for (const bool compensate : {false, true}) {
        const PhotometricOptions o = SingleLevel(l, compensate);
        Eigen::VectorXd r;
        JacobianN2 J;
        REQUIRE(ComputePhotometricResidual(patch, pyramid, p_0, w.W, o, &r, &J));
        const JacobianN2 J_num = NumericJacobian(patch, pyramid, p_0, w.W, o, w.step * (1 << l));
        INFO(w.name << ", level " << l << ", compensation " << compensate);
        REQUIRE(J_num.norm() > 1.0);  // the texture is not flat there
        CHECK((J - J_num).norm() < 1e-6 * J_num.norm());
      }
    }
  }
}

TEST_CASE("Residual Jacobian scales with the fitted gain", "[patch]") {
  // With compensation, J = (Id - H) gain 2^-l W^-T dP/do where the projector H depends on the
  // patch only: against a brighter image (1.5 * image - 20) at the same position, J must be
  // exactly the fitted gain (about 1.5) times J against the original image, whose exactness
  // the test above establishes. (A numeric comparison against the brighter image is limited
  // by its 8-bit rounding: the projection leaves only the curvature part of the gradient of a
  // 5x5 patch on a smooth texture, which the rounding noise swamps.)
  const cv::Mat image = Texture().Render(kWidth, kHeight);
  cv::Mat brighter;
  image.convertTo(brighter, CV_8U, 1.5, -20.0);
  ImagePyramid reference, pyramid;
  reference.Build(image, 4);
  pyramid.Build(brighter, 4);
  for (const Eigen::Vector2d& p : TestPoints()) {
    MultilevelPatch patch;
    REQUIRE(patch.Extract(reference, p, Eigen::Matrix2d::Identity(), PatchOptions()));
    for (int l = 0; l < 4; ++l) {
      const PhotometricOptions o = SingleLevel(l, true);
      Eigen::VectorXd r;
      JacobianN2 J, J_reference;
      REQUIRE(ComputePhotometricResidual(patch, reference, p, Eigen::Matrix2d::Identity(), o, &r,
                                         &J_reference));
      REQUIRE(ComputePhotometricResidual(patch, pyramid, p, Eigen::Matrix2d::Identity(), o, &r,
                                         &J));
      const double ratio = J.cwiseProduct(J_reference).sum() / J_reference.squaredNorm();
      INFO("level " << l << ", ratio " << ratio);
      // The fitted gain, not 1.5 exactly: 8-bit rounding on low-contrast fine-level patches.
      CHECK(ratio == Approx(1.5).margin(0.25));
      CHECK((J - ratio * J_reference).norm() < 1e-9 * J.norm());
    }
  }
}

TEST_CASE("Residual Jacobian is the exact derivative on a linear ramp", "[patch]") {
  // I(x, y) = 128 + x - y on level 0; 2x2 box averages of it are integers, so every pyramid
  // level is the exact ramp 128 + 2^l (x - y) and bilinear interpolation is exact anywhere.
  constexpr int kSize = 128;
  cv::Mat ramp(kSize, kSize, CV_8UC1);
  for (int y = 0; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) ramp.at<uchar>(y, x) = static_cast<uchar>(128 + x - y);
  }
  ImagePyramid pyramid;
  pyramid.Build(ramp, 4);
  for (int l = 0; l < 4; ++l) {
    const cv::Mat& level = pyramid.level(l);
    bool exact = true;
    for (int y = 0; y < level.rows; ++y) {
      for (int x = 0; x < level.cols; ++x) {
        exact = exact && level.at<uchar>(y, x) == 128 + (1 << l) * (x - y);
      }
    }
    REQUIRE(exact);
  }
  // Extraction with the same warp as the residual, so that dP/do = W^T grad I exactly.
  const Eigen::Matrix2d W = ScaledRotation(1.1, 10.0) * (Eigen::Matrix2d() << 1.0, 0.2, 0.0, 1.0).finished();
  const Eigen::Vector2d p(61.3, 66.8);
  MultilevelPatch patch;
  REQUIRE(patch.Extract(pyramid, p, W, PatchOptions()));
  for (int l = 0; l < 4; ++l) REQUIRE(patch.level_valid(l));
  const Eigen::Vector2d q = p + Eigen::Vector2d(0.7, -0.4);
  for (int l = 0; l < 4; ++l) {
    INFO("level " << l);
    Eigen::VectorXd r;
    JacobianN2 J;
    // Without compensation: every row is the image gradient 2^-l (1, -1) per level-0 px.
    const PhotometricOptions off = SingleLevel(l, false);
    REQUIRE(ComputePhotometricResidual(patch, pyramid, q, W, off, &r, &J));
    const JacobianN2 J_num = NumericJacobian(patch, pyramid, q, W, off, 2.0 * (1 << l));
    CHECK((J - J_num).norm() < 1e-4 * J_num.norm());
    const Eigen::RowVector2d expected(1.0, -1.0);  // per level-0 px on every level
    CHECK((J.rowwise() - expected).norm() < 1e-4 * J.norm());
    // With compensation the residual is the image minus its projection onto span{P, 1}; a
    // shifted ramp is in that span, so residual and Jacobian are exactly zero. An unprojected
    // Jacobian would be the constant gradient.
    const PhotometricOptions on = SingleLevel(l, true);
    REQUIRE(ComputePhotometricResidual(patch, pyramid, q, W, on, &r, &J));
    CHECK(r.cwiseAbs().maxCoeff() < 1e-3);
    CHECK(J.cwiseAbs().maxCoeff() < 1e-4);  // float samples; unprojected: 1
  }
}

// ---------------------------------------------------------------------------------------------
// Alignment tests.

struct AlignmentStats {
  std::vector<double> errors;  // |result - truth| [level-0 px], sorted
  int converged = 0;
  double mean_abs_error = 0.0;  // mean over points of the mean |r| at the solution [grey]
  double median() const { return errors[errors.size() / 2]; }
  double worst() const { return errors.back(); }
};

// Extracts a patch (identity warp) at every test point of `reference` and aligns it in `moved`
// with warp W from truth(p) + initial_error.
AlignmentStats Align(const ImagePyramid& reference, const ImagePyramid& moved,
                     const std::function<Eigen::Vector2d(const Eigen::Vector2d&)>& truth,
                     const Eigen::Matrix2d& W, const Eigen::Vector2d& initial_error,
                     bool compensate) {
  PhotometricOptions photometric;
  photometric.compensate_illumination = compensate;
  AlignmentStats stats;
  const auto points = TestPoints();
  for (const Eigen::Vector2d& p : points) {
    MultilevelPatch patch;
    REQUIRE(patch.Extract(reference, p, Eigen::Matrix2d::Identity(), PatchOptions()));
    const Eigen::Vector2d p_true = truth(p);
    const AlignmentResult result = AlignPatch(patch, moved, p_true + initial_error, W,
                                              photometric);
    if (result.converged) ++stats.converged;
    stats.errors.push_back((result.pixel - p_true).norm());
    stats.mean_abs_error += result.mean_abs_error / static_cast<double>(points.size());
  }
  std::sort(stats.errors.begin(), stats.errors.end());
  return stats;
}

const int kNumPoints = static_cast<int>(TestPoints().size());

// Sub-pixel motion on the smooth texture: the truth is exact (the moved image is rendered from
// the continuous texture), but bilinear interpolation of the samples is not. Bound: for a component of
// wavelength lambda_l (level-l px) the bilinear error is at most f''/8 = A pi^2 / (2 lambda_l^2)
// against a slope up to A 2 pi / lambda_l, i.e. a position bias up to pi / (4 lambda_l) level-l
// px = 4^l pi / (4 lambda_0) level-0 px. Below Nyquist the levels weigh about equally in
// J^T J (the 2^-l of the Jacobian cancels the 2^l larger gradient per level pixel), so the
// joint bias is at most the mean over levels 0..3: (1 + 4 + 16 + 64) / 4 * pi / (4 lambda_0)
// = 16.7 / lambda_0 px. The texture's structure has lambda_0 ~ 2 pi sigma = 31 .. 88 px
// (blobs, sigma 5 .. 14) and 83 .. 97 px (sinusoid); at the typical 60 px this gives 0.28 px
// with the worst phase on every level, and 0.5 px for the finest blobs (33 px): worst < 0.5.
// Phases are spread uniformly, which halves the typical bias: median < 0.2.
constexpr double kSubPixelMedianBound = 0.2;  // [px]
constexpr double kSubPixelWorstBound = 0.5;   // [px]

TEST_CASE("AlignPatch returns the extraction point in the same image", "[patch]") {
  // Self-consistency: the residual is exactly zero at p, so Gauss-Newton must land there.
  ImagePyramid pyramid;
  pyramid.Build(Texture().Render(kWidth, kHeight), 4);
  const auto same = [](const Eigen::Vector2d& p) { return p; };
  for (const bool compensate : {true, false}) {
    const AlignmentStats s =
        Align(pyramid, pyramid, same, Eigen::Matrix2d::Identity(), {1.6, -1.3}, compensate);
    INFO("compensation " << compensate << ": worst " << s.worst() << " px");
    CHECK(s.worst() < 0.01);
    CHECK(s.converged == kNumPoints);
    CHECK(s.mean_abs_error < 0.05);
  }

  SECTION("information is J^T J at the solution") {
    MultilevelPatch patch;
    const Eigen::Vector2d p(130.0, 120.3);
    REQUIRE(patch.Extract(pyramid, p, Eigen::Matrix2d::Identity(), PatchOptions()));
    const AlignmentResult result = AlignPatch(patch, pyramid, p + Eigen::Vector2d(1.6, -1.3),
                                              Eigen::Matrix2d::Identity(), PhotometricOptions());
    REQUIRE(result.converged);
    CHECK(result.iterations > 1);
    Eigen::VectorXd r;
    JacobianN2 J;
    REQUIRE(ComputePhotometricResidual(patch, pyramid, result.pixel, Eigen::Matrix2d::Identity(),
                                       PhotometricOptions(), &r, &J));
    CHECK((result.information - J.transpose() * J).norm() < 1e-9 * result.information.norm());
    CHECK(result.mean_abs_error == Approx(r.cwiseAbs().mean()));
    CHECK(result.information.determinant() > 0.0);
  }
}

// A shift of (8, -16) level-0 px is (1, -2) px on level 3: 2x2 box averaging stays aligned with
// the grid, so every level of the moved pyramid is an exact shifted copy and the truth is exact.
const Eigen::Vector2d kGridShift(8.0, -16.0);

TEST_CASE("AlignPatch recovers a shift that is whole pixels on every level", "[patch]") {
  ImagePyramid reference, moved;
  reference.Build(Texture().Render(kWidth, kHeight), 4);
  moved.Build(Texture().Render(kWidth, kHeight,
                               [](const Eigen::Vector2d& x) { return Eigen::Vector2d(x - kGridShift); }),
              4);
  // Precondition: level 3 of the moved pyramid is level 3 shifted by (1, -2) px.
  const cv::Mat& ref3 = reference.level(3);
  const cv::Mat& mov3 = moved.level(3);
  CHECK(cv::norm(mov3(cv::Rect(1, 0, ref3.cols - 1, ref3.rows - 2)),
                 ref3(cv::Rect(0, 2, ref3.cols - 1, ref3.rows - 2)), cv::NORM_INF) == 0.0);
  const auto truth = [](const Eigen::Vector2d& p) { return Eigen::Vector2d(p + kGridShift); };
  const AlignmentStats s =
      Align(reference, moved, truth, Eigen::Matrix2d::Identity(), {1.6, -1.3}, true);
  INFO("worst " << s.worst() << " px");
  CHECK(s.worst() < 0.01);
  CHECK(s.converged == kNumPoints);
}

TEST_CASE("AlignPatch compensates a brightness change", "[patch]") {
  // Gain 1.3, offset -20 on the grid shift above: up to 8-bit rounding (+-0.5 grey per pixel,
  // re-rounded on every level) the moved pyramid is gain * reference + offset, which the
  // compensation models exactly. The rounding is not negligible here: on this smooth texture a
  // 6x6 patch is nearly a ramp on the fine levels, and a shifted ramp is absorbed by the
  // per-level offset, so only the patch curvature constrains the position and the rounding
  // noise (std 0.29 grey) moves the solution by up to tenths of a pixel. The bounds are
  // therefore those of the sub-pixel test; without compensation the error is pixels.
  ImagePyramid reference, moved;
  reference.Build(Texture().Render(kWidth, kHeight), 4);
  moved.Build(Texture().Render(
                  kWidth, kHeight,
                  [](const Eigen::Vector2d& x) { return Eigen::Vector2d(x - kGridShift); }, 1.3,
                  -20.0),
              4);
  const auto truth = [](const Eigen::Vector2d& p) { return Eigen::Vector2d(p + kGridShift); };
  const AlignmentStats on =
      Align(reference, moved, truth, Eigen::Matrix2d::Identity(), {1.6, -1.3}, true);
  const AlignmentStats off =
      Align(reference, moved, truth, Eigen::Matrix2d::Identity(), {1.6, -1.3}, false);
  INFO("compensation on: median " << on.median() << " px, worst " << on.worst() << " px, mae "
                                  << on.mean_abs_error << "; off: median " << off.median()
                                  << " px, worst " << off.worst() << " px, mae "
                                  << off.mean_abs_error);
  CHECK(on.median() < kSubPixelMedianBound);
  CHECK(on.worst() < kSubPixelWorstBound);
  CHECK(on.converged == kNumPoints);
  CHECK(off.median() > 1.0);
  CHECK(off.mean_abs_error > 5.0 * on.mean_abs_error);
}

// Sub-pixel motion: see kSubPixelWorstBound.
TEST_CASE("AlignPatch recovers a sub-pixel shift within the interpolation bias", "[patch]") {
  const Eigen::Vector2d d(2.3, -1.7);
  ImagePyramid reference, moved;
  reference.Build(Texture().Render(kWidth, kHeight), 4);
  moved.Build(Texture().Render(kWidth, kHeight,
                               [&](const Eigen::Vector2d& x) { return Eigen::Vector2d(x - d); }),
              4);
  const auto truth = [&](const Eigen::Vector2d& p) { return Eigen::Vector2d(p + d); };
  const AlignmentStats s = Align(reference, moved, truth, Eigen::Matrix2d::Identity(), -d, true);
  INFO("median " << s.median() << " px, worst " << s.worst() << " px, mae " << s.mean_abs_error);
  CHECK(s.median() < kSubPixelMedianBound);
  CHECK(s.worst() < kSubPixelWorstBound);
  CHECK(s.converged == kNumPoints);
}

TEST_CASE("AlignPatch matches a rotated and scaled patch when the warp is given", "[patch]") {
  // The moved image is rendered from the continuous texture through the inverse warp around
  // c, so the truth c + M (p - c) is exact; the error is the interpolation bias bounded as for
  // the sub-pixel shift (the texture is magnified by 1.1, which only lowers its frequencies).
  const Eigen::Vector2d c(kWidth / 2.0, kHeight / 2.0);
  const Eigen::Matrix2d M = ScaledRotation(1.1, 10.0);
  const Eigen::Matrix2d M_inv = M.inverse();
  ImagePyramid reference, moved;
  reference.Build(Texture().Render(kWidth, kHeight), 4);
  moved.Build(Texture().Render(kWidth, kHeight,
                               [&](const Eigen::Vector2d& x) {
                                 return Eigen::Vector2d(c + M_inv * (x - c));
                               }),
              4);
  const auto truth = [&](const Eigen::Vector2d& p) { return Eigen::Vector2d(c + M * (p - c)); };
  const Eigen::Vector2d initial_error(1.5, -1.0);
  const AlignmentStats given = Align(reference, moved, truth, M, initial_error, true);
  const AlignmentStats identity =
      Align(reference, moved, truth, Eigen::Matrix2d::Identity(), initial_error, true);
  INFO("warp given: median " << given.median() << " px, worst " << given.worst() << " px, mae "
                             << given.mean_abs_error << "; identity: median "
                             << identity.median() << " px, worst " << identity.worst()
                             << " px, mae " << identity.mean_abs_error);
  CHECK(given.median() < kSubPixelMedianBound);
  CHECK(given.worst() < kSubPixelWorstBound);
  CHECK(given.converged == kNumPoints);
  CHECK(identity.mean_abs_error > 3.0 * given.mean_abs_error);
}

}  // namespace
}  // namespace vilma::estimator

#include "vilma/eval/localization/stereo_geometry.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <random>
#include <vector>

#include "test_skip.h"
#include "vilma/eval/localization/kitti_localization.h"

using namespace vilma;
using namespace vilma::eval;

namespace {

// A smooth random texture T(x, y): a sum of sinusoids with wavelengths of 5-25 px and random
// directions, 40-220 grey levels. The right image of a rectified pair with disparity d at
// every pixel is R(x, y) = T(x + d, y), so the left point (u, v) is at (u - d, v) on the right.
struct Texture {
  struct Wave {
    double kx, ky, phase, amplitude;
  };
  std::vector<Wave> waves;
  explicit Texture(uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int i = 0; i < 12; ++i) {
      // One draw per statement: the order is the same under every compiler.
      const double wavelength = 5.0 + 20.0 * unit(rng);
      const double angle = M_PI * unit(rng);
      const double phase = 2.0 * M_PI * unit(rng);
      const double k = 2.0 * M_PI / wavelength;
      waves.push_back({k * std::cos(angle), k * std::sin(angle), phase, 10.0});
    }
  }
  double operator()(double x, double y) const {
    double g = 130.0;
    for (const Wave& w : waves) g += w.amplitude * std::sin(w.kx * x + w.ky * y + w.phase);
    return g;
  }
};

// An 8-bit image of T(x + shift, y), with Gaussian noise of `noise` grey levels (seeded).
cv::Mat Render(const Texture& texture, double shift, double noise = 0.0, uint32_t seed = 1) {
  cv::Mat image(120, 200, CV_8UC1);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const double g = texture(x + shift, y) + (noise > 0.0 ? noise * n(rng) : 0.0);
      image.at<uint8_t>(y, x) = static_cast<uint8_t>(std::clamp(std::lround(g), 0L, 255L));
    }
  }
  return image;
}

const Camera kKitti(1226, 370, Eigen::Vector4d(718.856, 718.856, 607.193, 185.216),
                    DistortionModel::kNone, Eigen::VectorXd());
constexpr double kBaseline = 0.537;

// Left camera at `position` looking along W z, yawed by `yaw` [rad] about W y.
Transformation Camera_W(const Eigen::Vector3d& position, double yaw) {
  return Transformation(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix(),
                        position);
}

// The exact stereo view of p_W from T_W_C: left pixel and disparity.
StereoObservation ExactView(const Transformation& T_W_C, const Eigen::Vector3d& p_W) {
  const Eigen::Vector3d p_C = T_W_C.inverse() * p_W;
  Eigen::Vector2d uv;
  kKitti.Project(p_C, &uv);
  return {T_W_C, uv, kKitti.fx() * kBaseline / p_C.z()};
}

}  // namespace

TEST_CASE("stereo disparity: sub-pixel disparity of a synthetic rectified pair",
          "[localization][stereo]") {
  const Texture texture(5);
  const DisparityRefinementOptions options;
  for (const double d_true : {7.3, 12.5, 13.77, 31.06}) {
    const cv::Mat left = Render(texture, 0.0);
    const cv::Mat right = Render(texture, d_true);
    // Left points at whole and fractional pixels (keypoints of higher pyramid levels), starting
    // from the rounded disparity (what two whole-pixel keypoints give) and from 0.9 px off.
    for (const Eigen::Vector2d& uv : {Eigen::Vector2d(100, 60), Eigen::Vector2d(120.4, 40.7),
                                     Eigen::Vector2d(80.0, 85.25)}) {
      for (const double d0 : {std::round(d_true), d_true - 0.9, d_true + 0.9}) {
        const DisparityRefinement r = RefineDisparity(left, right, uv, d0, options);
        INFO("d " << d_true << " from " << d0 << " at " << uv.transpose() << ": "
                  << DisparityRefinementStatusName(r.status) << " " << r.disparity_px);
        REQUIRE(r.ok());
        // 8-bit quantization only: within 0.03 px (a whole-pixel disparity is up to 0.5 off).
        CHECK(std::abs(r.disparity_px - d_true) < 0.03);
        CHECK(r.zncc > 0.99);
        CHECK(r.sigma_px < 0.03);
        CHECK(r.iterations >= 1);
      }
    }
  }
}

TEST_CASE("stereo disparity: with image noise the error matches the predicted sigma",
          "[localization][stereo]") {
  const Texture texture(9);
  const double d_true = 15.4;
  const cv::Mat left = Render(texture, 0.0, 4.0, 11);
  const cv::Mat right = Render(texture, d_true, 4.0, 12);
  DisparityRefinementOptions options;
  std::vector<double> errors, sigmas;
  for (int y = 20; y <= 100; y += 8) {
    for (int x = 50; x <= 180; x += 13) {
      const DisparityRefinement r =
          RefineDisparity(left, right, Eigen::Vector2d(x, y), std::round(d_true), options);
      REQUIRE(r.ok());
      errors.push_back(r.disparity_px - d_true);
      sigmas.push_back(r.sigma_px);
    }
  }
  double ss = 0.0, mean_sigma2 = 0.0;
  for (std::size_t k = 0; k < errors.size(); ++k) {
    ss += errors[k] * errors[k];
    mean_sigma2 += sigmas[k] * sigmas[k];
  }
  const double rms = std::sqrt(ss / errors.size());
  const double predicted = std::sqrt(mean_sigma2 / sigmas.size());
  INFO(errors.size() << " points: rms error " << rms << " px, predicted " << predicted << " px");
  CHECK(errors.size() >= 100);
  CHECK(rms < 0.1);  // against up to 0.5 px (rms 0.29) of a whole-pixel disparity
  // The Gauss-Newton sigma predicts the scatter (ratio measured ~1; neighbouring patches
  // overlap, so the points are not independent).
  CHECK(rms / predicted > 0.5);
  CHECK(rms / predicted < 2.0);
}

TEST_CASE("stereo disparity: failures are named", "[localization][stereo]") {
  const Texture texture(5);
  const cv::Mat left = Render(texture, 0.0);
  const cv::Mat right = Render(texture, 12.5);
  const DisparityRefinementOptions options;
  REQUIRE(options.Validate().empty());
  // A patch leaving either image.
  CHECK(RefineDisparity(left, right, Eigen::Vector2d(2, 60), 12.0, options).status ==
        DisparityRefinementStatus::kOutside);
  CHECK(RefineDisparity(left, right, Eigen::Vector2d(100, 118), 12.0, options).status ==
        DisparityRefinementStatus::kOutside);
  CHECK(RefineDisparity(left, right, Eigen::Vector2d(14, 60), 12.0, options).status ==
        DisparityRefinementStatus::kOutside);
  // Flat left patch.
  const cv::Mat flat(120, 200, CV_8UC1, cv::Scalar(128));
  CHECK(RefineDisparity(flat, right, Eigen::Vector2d(100, 60), 12.0, options).status ==
        DisparityRefinementStatus::kTextureless);
  // A start 4 px off: the scan's best is at its end (or the alignment leaves the bound).
  const DisparityRefinement far = RefineDisparity(left, right, Eigen::Vector2d(100, 60), 16.5,
                                                  options);
  CHECK_FALSE(far.ok());
  // An unrelated right image: no correlation.
  const cv::Mat other = Render(Texture(77), 0.0);
  CHECK_FALSE(RefineDisparity(left, other, Eigen::Vector2d(100, 60), 12.0, options).ok());
  // Option checks.
  DisparityRefinementOptions bad = options;
  bad.half_window_px = 0;
  CHECK(bad.Validate().find("half_window_px") != std::string::npos);
  bad = options;
  bad.min_zncc = 1.5;
  CHECK(bad.Validate().find("min_zncc") != std::string::npos);
  bad = options;
  bad.max_change_px = 0.0;
  CHECK(bad.Validate().find("max_change_px") != std::string::npos);
}

TEST_CASE("stereo track: triangulation of several stereo views against the true point",
          "[localization][stereo]") {
  // A point 30 m ahead and 4 m to the side, seen from three frames 1.2 m apart (a car driving
  // towards it) with a small yaw, like consecutive KITTI map frames.
  const Eigen::Vector3d p_W(4.0, -1.0, 30.0);
  std::vector<StereoObservation> views;
  for (int k = 0; k < 3; ++k) {
    views.push_back(ExactView(Camera_W(Eigen::Vector3d(0.1 * k, 0.0, 1.2 * k), 0.02 * k), p_W));
  }
  StereoTrackOptions options;
  REQUIRE(options.Validate().empty());

  // Exact views: the true point, each view alone and all together.
  for (const StereoObservation& v : views) {
    const StereoTrackPoint one = TriangulateStereoTrack({v}, kKitti, kBaseline, options);
    REQUIRE(one.ok);
    CHECK((one.p_W - p_W).norm() < 1e-6);
    CHECK((one.p_W - v.T_W_C * StereoPoint_C(kKitti, kBaseline, v.uv_left, v.disparity_px))
              .norm() < 1e-6);
  }
  const StereoTrackPoint all = TriangulateStereoTrack(views, kKitti, kBaseline, options);
  REQUIRE(all.ok);
  CHECK(all.views_used == 3);
  CHECK((all.p_W - p_W).norm() < 1e-6);
  CHECK(all.rms_residual_px < 1e-6);

  // The covariance: one view's depth sigma is Z^2 sqrt(2) sigma / (f b) along the ray; three
  // views' is smaller (at least by sqrt(3) - the parallax of the motion adds a little).
  const StereoTrackPoint first = TriangulateStereoTrack({views[0]}, kKitti, kBaseline, options);
  const Eigen::Vector3d ray = (p_W - views[0].T_W_C.translation()).normalized();
  const double sigma_one = std::sqrt(ray.dot(first.covariance_W * ray));
  const double sigma_all = std::sqrt(ray.dot(all.covariance_W * ray));
  const double Z = (views[0].T_W_C.inverse() * p_W).z();
  // (along the ray: sigma_Z |p_C| / Z)
  const double range = (p_W - views[0].T_W_C.translation()).norm();
  CHECK(sigma_one ==
        Approx(Z * Z * std::sqrt(2.0) / (kKitti.fx() * kBaseline) * range / Z).epsilon(0.02));
  CHECK(sigma_all < sigma_one / std::sqrt(3.0) * 1.01);

  // Disparity noise of 0.2 px (sub-pixel alignment) against 0.5 px (whole pixels): the joint
  // point's error over 500 trials follows the covariance (sigma_px = the disparity noise /
  // sqrt(2), since the covariance puts it on both views), and shrinks with the noise.
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (const double sigma_d : {0.2, 0.5}) {
    StereoTrackOptions noisy = options;
    noisy.sigma_px = sigma_d / std::sqrt(2.0);
    double chi2 = 0.0;
    const int trials = 500;
    for (int t = 0; t < trials; ++t) {
      std::vector<StereoObservation> v = views;
      for (StereoObservation& o : v) {
        const double dd = sigma_d * n(rng);
        o.disparity_px += dd;
      }
      const StereoTrackPoint p = TriangulateStereoTrack(v, kKitti, kBaseline, noisy);
      REQUIRE(p.ok);
      REQUIRE(p.views_used == 3);
      const Eigen::Vector3d e = p.p_W - p_W;
      // Only the disparities are noisy: the error lies along the depth direction, whitened by
      // its own variance there.
      const double s2 = e.dot(p.covariance_W * e) / e.squaredNorm();
      chi2 += e.squaredNorm() / s2;
    }
    INFO("disparity sigma " << sigma_d << ": chi2 per trial " << chi2 / trials);
    // One effective dof (the depth), inflated by the left pixel's share of the covariance that
    // carries no noise here: between 0.5 and 1.5.
    CHECK(chi2 / trials > 0.5);
    CHECK(chi2 / trials < 1.5);
  }

  // A wrongly merged view (the left keypoint 6 px away): left out, the point stays exact.
  std::vector<StereoObservation> with_outlier = views;
  StereoObservation wrong = ExactView(Camera_W(Eigen::Vector3d(0.3, 0.0, 3.6), 0.06), p_W);
  wrong.uv_left.x() += 6.0;
  with_outlier.push_back(wrong);
  const StereoTrackPoint robust = TriangulateStereoTrack(with_outlier, kKitti, kBaseline, options);
  REQUIRE(robust.ok);
  CHECK(robust.views_used == 3);
  CHECK_FALSE(robust.used[3]);
  CHECK((robust.p_W - p_W).norm() < 1e-6);

  StereoTrackOptions bad = options;
  bad.max_residual_px = 0.0;
  CHECK(bad.Validate().find("max_residual_px") != std::string::npos);
  CHECK_FALSE(TriangulateStereoTrack({}, kKitti, kBaseline, options).ok);
}

TEST_CASE("stereo disparity: the KITTI map's stereo matches are refined (real images)",
          "[localization][stereo][kitti]") {
  const std::filesystem::path dir =
      std::filesystem::path(VILMA_SHARED_DATA_DIR) / "kitti_slices" / "KITTI_sequence_1";
  if (!std::filesystem::exists(dir / "calib.txt")) {
    VILMA_SKIP("KITTI slice absent at " << dir);
  }
  const KittiSequence seq = LoadKittiSequence(dir.string());
  KittiLocalizationOptions options;
  REQUIRE(options.refine_disparity);
  REQUIRE_FALSE(options.triangulate_tracks);
  KittiLocalizationReport report;
  BuildKittiFrameMap(seq, options, {0, 2, 4}, &report);
  const int matches = report.refined_disparities + report.unrefined_disparities;
  INFO(report.refined_disparities << " of " << matches << " refined");
  REQUIRE(matches > 500);
  // Measured over the 26 even frames: 6781 of 8173 (83 %); the rest keep the keypoints'
  // disparity (low correlation, no peak within 2 px: doubtful matches or occlusions).
  CHECK(report.refined_disparities > 0.75 * matches);
  CHECK(report.triangulated_tracks == 0);

  // With track triangulation: the merged landmarks (seen by 2-3 of these frames) are solved
  // from all their views; a few views are left out as inconsistent.
  options.triangulate_tracks = true;
  KittiLocalizationReport tracks;
  BuildKittiFrameMap(seq, options, {0, 2, 4}, &tracks);
  INFO(tracks.triangulated_tracks << " tracks, " << tracks.dropped_track_views << " views out");
  CHECK(tracks.triangulated_tracks > 0);
  CHECK(tracks.triangulated_tracks <= tracks.merged_observations);
  CHECK(tracks.dropped_track_views < tracks.triangulated_tracks);
}

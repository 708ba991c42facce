// Session 38's options for more stereo depths (estimator/src/vio_filter.cpp AddFeatures,
// estimator/src/vio_filter_stereo.cpp DeferredStereoMatches; docs/estimator.md "More stereo
// depths"): stereo.candidates_per_slot and stereo.deferred_match_frames, on the plane scene.
#include <Eigen/Eigenvalues>
#include <catch2/catch.hpp>
#include <cmath>
#include <functional>

#include "estimator/plane_scene.h"
#include "vilma/estimator/filter_state.h"
#include "vilma/estimator/vio_filter.h"

namespace vilma::estimator {
namespace {

using testing::PlaneScene;

using testing::PlaneStereoOptions;

// The scene's run (testing::RunPlaneScene) without resets; `second` makes the second camera's
// image from the render. Returns the final position error [m].
double Run(const PlaneScene& scene, double seconds, VioFilter* filter,
           const std::function<cv::Mat(const cv::Mat&)>& second) {
  int resets = 0;
  const double error = testing::RunPlaneScene(scene, seconds, filter, second, &resets);
  CHECK(resets == 0);
  return error;
}

// Active features whose inverse distance is more than `tolerance` (relative) off the plane's.
int WrongDepths(const VioFilter& filter, double tolerance) {
  int wrong = 0;
  for (const FeatureState& feature : filter.state().features) {
    if (!feature.active) continue;
    const Eigen::Vector3d mu_M = filter.state().q_M_I * feature.mu_C;
    const double rho_true = mu_M.z() / (PlaneScene::kPlaneZ - filter.state().p_M_I.z());
    if (std::abs(feature.rho - rho_true) > tolerance * rho_true) ++wrong;
  }
  return wrong;
}

// The left third of the second camera sees a blank wall (an occluder in front of C2 only):
// features of C1 there have no stereo match.
cv::Mat BlankLeftThird(const cv::Mat& image) {
  cv::Mat out = image.clone();
  out(cv::Rect(0, 0, PlaneScene::kWidth / 3, PlaneScene::kHeight)).setTo(cv::Scalar(128));
  return out;
}

TEST_CASE("stereo.candidates_per_slot fills the slots with matchable features") {
  const PlaneScene scene(2);
  FilterOptions options = PlaneStereoOptions();
  VioFilter plain(scene.rig(), 0, options);
  const double error_plain = Run(scene, 2.0, &plain, BlankLeftThird);
  options.stereo.candidates_per_slot = 2;
  VioFilter prefer(scene.rig(), 0, options);
  const double error_prefer = Run(scene, 2.0, &prefer, BlankLeftThird);
  const FilterStats& a = plain.stats();
  const FilterStats& b = prefer.stats();
  INFO("off: " << a.stereo_matches << " matched, " << a.stereo_match_failures
               << " not, error " << error_plain << " m; on: " << b.stereo_matches << " matched, "
               << b.stereo_match_failures << " not, " << b.stereo_candidates_skipped
               << " skipped, error " << error_prefer << " m");
  CHECK(a.stereo_candidates_skipped == 0);
  REQUIRE(a.stereo_match_failures >= 3);  // the blank third costs matches without the option
  CHECK(b.stereo_candidates_skipped > 0);
  CHECK(b.stereo_match_failures < a.stereo_match_failures / 2);
  CHECK(b.stereo_matches >= 8);
  CHECK(error_prefer < 0.05);
  CHECK(WrongDepths(prefer, 0.1) == 0);
  // Deterministic.
  VioFilter again(scene.rig(), 0, options);
  Run(scene, 2.0, &again, BlankLeftThird);
  CHECK(again.state().p_M_I == prefer.state().p_M_I);
}

// Without C2's photometric update and without the initial match, the features' depths come
// from C1's flow alone; before the motion starts (1 s) they stay at the wrong initial 1.5 1/m
// (the plane is at 3 m: 0.33). A deferred match on the next frame updates rho to the plane.
TEST_CASE("stereo.deferred_match_frames updates rho from a later match") {
  const PlaneScene scene(2);
  FilterOptions options = PlaneStereoOptions();
  options.stereo.init_depth = false;
  options.stereo.update = false;
  options.features.init_inverse_depth = 1.5;
  options.features.init_inverse_depth_sigma = 1.0;
  auto same = [](const cv::Mat& image) { return image; };
  options.stereo.deferred_match_frames = 0;  // off (the default is 10)
  VioFilter off(scene.rig(), 0, options);
  Run(scene, 0.8, &off, same);
  options.stereo.deferred_match_frames = 3;
  VioFilter on(scene.rig(), 0, options);
  Run(scene, 0.8, &on, same);
  const FilterStats& s = on.stats();
  INFO("deferred: " << s.deferred_matches << " applied, " << s.deferred_match_gated
                    << " gated, " << s.deferred_match_failures << " unmatched; wrong depths off "
                    << WrongDepths(off, 0.1) << " of " << off.state().num_active() << ", on "
                    << WrongDepths(on, 0.1) << " of " << on.state().num_active());
  CHECK(off.stats().deferred_matches == 0);
  CHECK(WrongDepths(off, 0.5) >= 8);
  CHECK(s.deferred_matches >= 8);
  CHECK(WrongDepths(on, 0.1) == 0);
  // The update is an EKF update, not an overwrite: the covariance stays symmetric and
  // positive semi-definite, and each matched feature's rho variance is below the match's
  // (C1's information is kept) and above zero.
  const Eigen::MatrixXd& P = on.covariance();
  CHECK((P - P.transpose()).cwiseAbs().maxCoeff() < 1e-12);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(P);
  CHECK(eig.eigenvalues().minCoeff() > -1e-9);
  for (int slot = 0; slot < static_cast<int>(on.state().features.size()); ++slot) {
    if (!on.state().features[static_cast<std::size_t>(slot)].active) continue;
    const int k = FeatureIndex(slot) + 2;
    CHECK(P(k, k) > 0.0);
    CHECK(P(k, k) < 0.1 * 0.1);
  }
  // Features with a C2 update are not searched again: with the C2 update on and a start near
  // enough for C2's alignment (0.4 1/m: 12 px disparity predicted, 10 px true), the update
  // catches the features first and no deferred match is made.
  options.stereo.update = true;
  options.features.init_inverse_depth = 0.4;
  options.features.init_inverse_depth_sigma = 0.5;
  VioFilter caught(scene.rig(), 0, options);
  Run(scene, 0.8, &caught, same);
  INFO("with the C2 update: " << caught.stats().deferred_matches << " deferred, "
                              << caught.stats().unmatched_taking_c2 << " caught by C2");
  CHECK(caught.stats().unmatched_taking_c2 >= 8);
  CHECK(caught.stats().deferred_matches == 0);
  CHECK(WrongDepths(caught, 0.1) == 0);
}

// features.median_depth_init: before the motion (1 s) nothing but a stereo match tells a
// feature's depth. The features of the left third (blank in C2) have none: without the option
// they stay at the wrong initial 1.5 1/m (the plane is at 3 m: ~0.33), with it they start at
// the median of the matched ones, i.e. near the plane.
TEST_CASE("features.median_depth_init starts unmatched features at the matched ones' median") {
  const PlaneScene scene(2);
  FilterOptions options = PlaneStereoOptions();
  options.stereo.deferred_match_frames = 0;  // no later match for the blank third either
  options.features.init_inverse_depth = 1.5;
  options.features.init_inverse_depth_sigma = 1.0;
  VioFilter off(scene.rig(), 0, options);
  Run(scene, 0.5, &off, BlankLeftThird);
  options.features.median_depth_init = true;
  VioFilter on(scene.rig(), 0, options);
  Run(scene, 0.5, &on, BlankLeftThird);
  INFO("off: " << off.stats().stereo_match_failures << " unmatched, wrong depths "
               << WrongDepths(off, 0.2) << "; on: " << on.stats().stereo_match_failures
               << " unmatched, " << on.stats().median_depth_inits << " at the median, wrong "
               << WrongDepths(on, 0.2) << " of " << on.state().num_active());
  CHECK(off.stats().median_depth_inits == 0);
  REQUIRE(off.stats().stereo_match_failures >= 3);
  CHECK(WrongDepths(off, 0.5) >= 3);
  CHECK(on.stats().median_depth_inits >= 3);
  CHECK(WrongDepths(on, 0.2) <= WrongDepths(off, 0.5) - 3);
  // The first candidates of the first detection have no matched neighbours yet: they fall back
  // to init_inverse_depth; at most median_depth_min_features - 1 + the unmatched of those can.
  CHECK(WrongDepths(on, 0.2) <= 2);
}

}  // namespace
}  // namespace vilma::estimator

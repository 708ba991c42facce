// elq, rtl, itl, rbl, rlq on a map with true geometry (geometric_map.h).
#include <catch2/catch.hpp>

#include "mapping_landmarks/geometric_map.h"
#include "test_random.h"
#include "vilma/mapping/landmarks/landmark_quality.h"
#include "vilma/mapping/landmarks/retriangulation.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::mapping {
namespace {

using mapstore::LandmarkQuality;
using testing::GeometricMap;
using testing::MakeGeometricMap;

std::size_t CountQuality(const mapstore::VIMap& map, LandmarkQuality q) {
  std::size_t n = 0;
  for (const auto& id : LandmarksOf(map, {})) n += map.landmark(id).quality == q;
  return n;
}

TEST_CASE("ObservationsInG gives each observer's T_G_C, also across missions") {
  GeometricMap g = MakeGeometricMap(4, 10, 0.0, true);
  const auto rays = ObservationsInG(g.map, g.landmarks[0]);
  REQUIRE(rays.size() == 8);  // 4 vertices of each mission
  for (std::size_t k = 0; k < rays.size(); ++k) {
    const auto& o = g.map.landmark(g.landmarks[0]).observations[k];
    const Transformation T_G_C =
        g.map.T_G_I(o.vertex_id) * g.map.mission(g.map.mission_ids()[0]).rig.cameras[0].T_I_C;
    CHECK((rays[k].T_M_C.translation() - T_G_C.translation()).norm() < 1e-12);
    // The landmark reprojects onto its keypoint.
    Eigen::Vector2d uv;
    rays[k].camera->Project(rays[k].T_M_C.inverse() * g.p_G_true[0], &uv);
    CHECK((uv - rays[k].uv).norm() < 1e-9);
  }
}

TEST_CASE("elq judges every landmark at its position by maplab's rules") {
  GeometricMap g = MakeGeometricMap(6, 40);
  LandmarkQualityOptions o;
  LandmarkQualitySummary s = EvaluateLandmarkQualities(o, &g.map, {});
  CHECK(s.landmarks == g.landmarks.size());
  CHECK(s.unknown_before == g.landmarks.size());
  CHECK(s.good_after == g.landmarks.size());  // 6 observers, >= 5 deg parallax, 0 px error
  CHECK(s.verdicts[static_cast<int>(LandmarkVerdict::kGood)] == g.landmarks.size());

  // One landmark moved 0.3 m sideways: large reprojection error. One with only 3 observers.
  // One moved behind the cameras.
  const Eigen::Vector3d p0 = g.map.LandmarkPosition_G(g.landmarks[0]);
  g.map.SetLandmarkPosition_M(g.landmarks[0], p0 + Eigen::Vector3d(0.3, 0.0, 0.0));
  auto& obs = g.map.landmark(g.landmarks[1]).observations;
  while (obs.size() > 3) g.map.RemoveObservation(g.landmarks[1], obs.back());
  const Transformation T_G_C0 = g.map.T_G_I(g.map.landmark(g.landmarks[2]).store_vertex_id) *
                                g.map.mission(g.map.mission_ids()[0]).rig.cameras[0].T_I_C;
  g.map.SetLandmarkPosition_M(g.landmarks[2], T_G_C0 * Eigen::Vector3d(0.1, 0.1, -3.0));
  s = EvaluateLandmarkQualities(o, &g.map, {});
  CHECK(s.verdicts[static_cast<int>(LandmarkVerdict::kLargeReprojectionError)] == 1);
  CHECK(s.verdicts[static_cast<int>(LandmarkVerdict::kTooFewObservers)] == 1);
  CHECK(s.verdicts[static_cast<int>(LandmarkVerdict::kTriangulationFailed)] == 1);
  CHECK(g.map.landmark(g.landmarks[0]).quality == LandmarkQuality::kBad);
  CHECK(g.map.landmark(g.landmarks[3]).quality == LandmarkQuality::kGood);
  CHECK(s.good_before == g.landmarks.size());
  CHECK(s.good_after == g.landmarks.size() - 3);

  // The thresholds are the flags: 3 observers are enough with min_observers 3.
  o.min_observers = 3;
  s = EvaluateLandmarkQualities(o, &g.map, {});
  CHECK(s.verdicts[static_cast<int>(LandmarkVerdict::kTooFewObservers)] == 0);
  o.min_observers = 0;
  CHECK_THROWS_WITH(EvaluateLandmarkQualities(o, &g.map, {}), Catch::Contains("min_observers"));
}

TEST_CASE("rtl restores perturbed landmarks from their observations, across missions") {
  for (const bool two_missions : {false, true}) {
    GeometricMap g = MakeGeometricMap(6, 40, 0.0, two_missions);
    std::mt19937_64 rng(5);
    std::normal_distribution<double> n(0.0, 0.2);
    for (const auto& id : g.landmarks) {
      g.map.SetLandmarkPosition_M(
          id, g.map.LandmarkPosition_M(id) + vilma::testing::DrawVector3([&] { return n(rng); }));
    }
    const RetriangulationSummary s = RetriangulateLandmarks(RetriangulationOptions{}, &g.map, {});
    CHECK(s.triangulated == g.landmarks.size());
    CHECK(s.failed == 0);
    CHECK(s.median_shift_m > 0.1);
    for (std::size_t j = 0; j < g.landmarks.size(); ++j) {
      CHECK((g.map.LandmarkPosition_G(g.landmarks[j]) - g.p_G_true[j]).norm() < 1e-6);
      CHECK(g.map.landmark(g.landmarks[j]).covariance.trace() > 0.0);
    }
    CHECK(CountQuality(g.map, LandmarkQuality::kGood) == g.landmarks.size());
    CHECK(mapstore::CheckMapConsistency(g.map).ok());
  }
}

TEST_CASE("rtl with pixel noise: millimetre landmarks, untriangulable ones kept and marked bad") {
  GeometricMap g = MakeGeometricMap(6, 40, 0.5);
  // Landmark 0 keeps a single observation: no triangulation.
  auto& obs = g.map.landmark(g.landmarks[0]).observations;
  while (obs.size() > 1) g.map.RemoveObservation(g.landmarks[0], obs.back());
  const Eigen::Vector3d kept = g.map.LandmarkPosition_G(g.landmarks[0]);
  RetriangulationOptions o;
  o.quality.min_observers = 2;
  const RetriangulationSummary s = RetriangulateLandmarks(o, &g.map, {});
  CHECK(s.failed == 1);
  CHECK(g.map.LandmarkPosition_G(g.landmarks[0]) == kept);
  CHECK(g.map.landmark(g.landmarks[0]).quality == LandmarkQuality::kBad);
  CHECK(s.quality.verdicts[static_cast<int>(LandmarkVerdict::kTriangulationFailed)] == 1);
  std::vector<double> errors;
  for (std::size_t j = 1; j < g.landmarks.size(); ++j) {
    errors.push_back((g.map.LandmarkPosition_G(g.landmarks[j]) - g.p_G_true[j]).norm());
  }
  std::sort(errors.begin(), errors.end());
  CHECK(errors[errors.size() / 2] < 0.02);  // 0.5 px at 4.5 m, 1.5 m baseline
  CHECK(errors[errors.size() / 2] > 0.0);
}

TEST_CASE("rlq, rbl, then itl makes the landmarks again from the tracks") {
  GeometricMap g = MakeGeometricMap(6, 40);
  EvaluateLandmarkQualities(LandmarkQualityOptions{}, &g.map, {});
  CHECK(ResetLandmarkQuality(&g.map, {}) == g.landmarks.size());
  CHECK(CountQuality(g.map, LandmarkQuality::kUnknown) == g.landmarks.size());
  for (std::size_t j = 0; j < 10; ++j) g.map.landmark(g.landmarks[j]).quality = LandmarkQuality::kBad;
  CHECK(RemoveBadLandmarks(&g.map, {}) == 10);
  CHECK(g.map.num_landmarks() == g.landmarks.size() - 10);
  CHECK(mapstore::CheckMapConsistency(g.map).ok());

  const mapstore::VIMap copy = g.map.Clone();
  const TrackLandmarkSummary s = InitializeTrackLandmarks(TrackLandmarkOptions{}, &g.map, {});
  CHECK(s.tracks_free == 10);
  CHECK(s.landmarks_created == 10);
  CHECK(s.landmarks_created_good == 10);
  CHECK(s.observations_created == 60);
  CHECK(g.map.num_landmarks() == g.landmarks.size());
  CHECK(mapstore::CheckMapConsistency(g.map).ok());
  // Each new landmark sits at its true position (noise-free keypoints).
  for (std::size_t j = 0; j < 10; ++j) {
    bool found = false;
    for (const auto& id : LandmarksOf(g.map, {})) {
      found = found || (g.map.LandmarkPosition_G(id) - g.p_G_true[j]).norm() < 1e-6;
    }
    CHECK(found);
  }
  // Deterministic: the same map gives the same ids.
  mapstore::VIMap again = copy.Clone();
  InitializeTrackLandmarks(TrackLandmarkOptions{}, &again, {});
  CHECK(LandmarksOf(again, {}) == LandmarksOf(g.map, {}));
  // Nothing left to do the second time.
  const TrackLandmarkSummary twice = InitializeTrackLandmarks(TrackLandmarkOptions{}, &g.map, {});
  CHECK(twice.landmarks_created == 0);
  CHECK(twice.observations_attached == 0);
}

TEST_CASE("itl adds a track's free keypoint to its landmark and skips short tracks") {
  GeometricMap g = MakeGeometricMap(6, 40);
  const auto id = g.landmarks[4];
  const auto dropped = g.map.landmark(id).observations.back();
  g.map.RemoveObservation(id, dropped);
  // Landmark 5 removed and all but one of its track's keypoints taken off the track.
  const auto observations5 = g.map.landmark(g.landmarks[5]).observations;
  g.map.RemoveLandmark(g.landmarks[5]);
  for (std::size_t k = 1; k < observations5.size(); ++k) {
    g.map.vertex(observations5[k].vertex_id).frames[0].track_ids[observations5[k].keypoint] = -1;
  }
  const TrackLandmarkSummary s = InitializeTrackLandmarks(TrackLandmarkOptions{}, &g.map, {});
  CHECK(s.observations_attached == 1);
  CHECK(g.map.landmark(id).observations.size() == 6);
  CHECK(s.tracks_free == 1);
  CHECK(s.too_short == 1);
  CHECK(s.landmarks_created == 0);
  CHECK(mapstore::CheckMapConsistency(g.map).ok());
  TrackLandmarkOptions bad;
  bad.min_track_length = 1;
  CHECK_THROWS_WITH(InitializeTrackLandmarks(bad, &g.map, {}), Catch::Contains("min_track_length"));
}

TEST_CASE("landmark commands work per mission") {
  GeometricMap g = MakeGeometricMap(4, 20, 0.0, true);
  const auto m1 = g.map.mission_ids()[1];
  // Mission 1 stores no landmark (all are stored in mission 0): nothing to judge there.
  CHECK(EvaluateLandmarkQualities(LandmarkQualityOptions{}, &g.map, {m1}).landmarks == 0);
  CHECK(CountQuality(g.map, LandmarkQuality::kUnknown) == g.landmarks.size());
  CHECK(EvaluateLandmarkQualities(LandmarkQualityOptions{}, &g.map, {g.map.mission_ids()[0]})
            .landmarks == g.landmarks.size());
}

}  // namespace
}  // namespace vilma::mapping

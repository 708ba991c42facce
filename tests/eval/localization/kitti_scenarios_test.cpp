#include "vilma/eval/localization/kitti_scenarios.h"

#include <catch2/catch.hpp>
#include <filesystem>

#include "test_skip.h"

using namespace vilma;
using namespace vilma::localizer;
using namespace vilma::eval;
namespace fs = std::filesystem;

namespace {

LocalizationMap TwoLandmarkMap() {
  LocalizationMap m;
  m.descriptor_bytes = 2;
  m.landmark_ids.resize(2);
  m.landmark_ids[1].lo = 7;
  m.p_G = {Eigen::Vector3d(0, 0, 5), Eigen::Vector3d(0, 0, 30)};
  m.observers.resize(2);
  m.observer_begin = {0, 1, 3};
  m.observer_index = {0, 0, 1};
  m.descriptor_landmark = {0, 1, 1};
  m.descriptors = {1, 2, 3, 4, 5, 6};
  return m;
}

}  // namespace

TEST_CASE("kitti scenarios: map edits keep descriptors and observers", "[localization]") {
  const LocalizationMap m = TwoLandmarkMap();
  REQUIRE(m.Validate().empty());
  const LocalizationMap far = KeepFarLandmarks(m, {Eigen::Vector3d::Zero()}, 10.0);
  REQUIRE(far.Validate().empty());
  REQUIRE(far.num_landmarks() == 1);
  CHECK(far.p_G[0].z() == 30.0);
  CHECK(far.landmark_ids[0].lo == 7);
  CHECK(far.descriptors == std::vector<uint8_t>{3, 4, 5, 6});
  CHECK(far.observer_index == std::vector<uint32_t>{0, 1});
  const LocalizationMap twice = RepeatLandmarks(m, Eigen::Vector3d(2.5, 0, 0));
  REQUIRE(twice.Validate().empty());
  REQUIRE(twice.num_landmarks() == 4);
  CHECK(twice.p_G[2] == Eigen::Vector3d(2.5, 0, 5));
  CHECK(twice.num_descriptors() == 6);
  CHECK(twice.observer_begin.back() == 6);  // the copies keep their observers
  CHECK(RepeatLandmarks(m, Eigen::Vector3d(1, 0, 0), 2).num_landmarks() == 3);
  CHECK(twice.p_G_covariance.empty());  // none in, none out

  // Landmark covariances go with their landmarks (the localizer's acceptance uses them).
  LocalizationMap with_covariances = m;
  with_covariances.p_G_covariance = {Eigen::Matrix3f::Identity() * 0.01f,
                                     Eigen::Matrix3f::Identity() * 4.0f};
  REQUIRE(with_covariances.Validate().empty());
  const LocalizationMap far_c = KeepFarLandmarks(with_covariances, {Eigen::Vector3d::Zero()}, 10.0);
  REQUIRE(far_c.Validate().empty());
  REQUIRE(far_c.p_G_covariance.size() == 1);
  CHECK(far_c.p_G_covariance[0](2, 2) == 4.0f);
  const LocalizationMap twice_c = RepeatLandmarks(with_covariances, Eigen::Vector3d(2.5, 0, 0));
  REQUIRE(twice_c.Validate().empty());
  REQUIRE(twice_c.p_G_covariance.size() == 4);
  CHECK(twice_c.p_G_covariance[2](0, 0) == 0.01f);
  CHECK(twice_c.p_G_covariance[3](0, 0) == 4.0f);
}

TEST_CASE("kitti scenarios: query perturbations", "[localization]") {
  const Camera cam(100, 100, Eigen::Vector4d(50, 50, 50, 50), DistortionModel::kNone,
                   Eigen::VectorXd());
  std::vector<Eigen::Vector2d> uv = {{10, 10}, {90, 10}, {10, 90}, {20, 20}, {30, 30}, {40, 40}};
  std::vector<uint8_t> d = {0, 1, 2, 3, 4, 5};  // one byte per keypoint
  QueryPerturbation box;
  box.box_max_x = 0.5;
  box.box_max_y = 0.5;
  box.max_keypoints = 3;
  std::vector<Eigen::Vector2d> u1 = uv;
  std::vector<uint8_t> d1 = d;
  PerturbQuery(box, cam, &u1, &d1, 1);
  CHECK(d1 == std::vector<uint8_t>{0, 3, 4});  // in the box, the first three
  QueryPerturbation swap;
  swap.swap_fraction = 1.0;
  std::vector<Eigen::Vector2d> u2 = uv;
  std::vector<uint8_t> d2 = d;
  PerturbQuery(swap, cam, &u2, &d2, 1);
  CHECK(u2 == uv);
  for (std::size_t i = 0; i < d.size(); ++i) CHECK(d2[i] != d[i]);  // nobody keeps its own
  std::vector<uint8_t> sorted = d2;
  std::sort(sorted.begin(), sorted.end());
  CHECK(sorted == d);  // a permutation
  QueryPerturbation bad;
  bad.swap_fraction = 1.5;
  CHECK_THROWS_AS(PerturbQuery(bad, cam, &u2, &d2, 1), InputError);
}

// The failure on real images: before the acceptance gates, queries of the second half
// of the slice against a map of the first half were accepted 23-30 m off (7 of 12, measured
// with vilma-loc-acceptance at commit d7660cb); the odd frames against the even frames' map
// localized 25 / 25.
TEST_CASE("kitti scenarios: no far-off pose accepted on the real slice", "[localization][kitti]") {
  const fs::path dir = fs::path(VILMA_SHARED_DATA_DIR) / "kitti_slices" / "KITTI_sequence_1";
  if (!fs::exists(dir / "calib.txt")) {
    VILMA_SKIP("KITTI slice absent at " << dir);
  }
  const KittiSequence seq = LoadKittiSequence(dir.string());
  const std::vector<KittiScenario> all = KittiScenarios(static_cast<int>(seq.size()));
  for (const char* name : {"even-odd", "other-part"}) {
    const auto it = std::find_if(all.begin(), all.end(),
                                 [&](const KittiScenario& s) { return s.name == name; });
    REQUIRE(it != all.end());
    const std::vector<AcceptanceQuery> q =
        RunKittiScenario(seq, KittiLocalizationOptions(), *it, AcceptanceGates());
    const AcceptanceSummary s = SummarizeAcceptance(name, q);
    INFO(name << ": accepted " << s.accepted << ", wrong " << s.accepted_wrong << ", recall "
              << s.accepted_correct << " / " << s.possible);
    if (std::string(name) == "even-odd") {
      CHECK(s.queries == 25);
      CHECK(s.accepted_wrong == 0);
      CHECK(s.accepted_correct >= 24);  // measured 25 / 25
    } else {
      CHECK(s.queries == 12);
      CHECK(s.possible <= 3);  // the map's part of the road is mostly out of sight
      // Measured: one accepted, frame 27 (2 frames past the map), 0.245 m / 0.51 deg off with
      // the sub-pixel stereo map; 0.303 m / 0.59 deg (wrong) with whole-pixel disparities
      // (docs/localizer.md, "Sub-pixel stereo"). Nothing near the 23-30 m of before the gates.
      CHECK(s.accepted <= 1);
      CHECK(s.accepted_wrong == 0);
    }
  }
}

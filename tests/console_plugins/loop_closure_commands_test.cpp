// loopclosure_all_missions / lc on a daemon-built map: loops within the mission, landmarks
// merged, edges added, consistent, deterministic; bad input changes nothing.
#include <catch2/catch.hpp>
#include <map>
#include <tuple>

#include "console_plugins/test_maps.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::console {
namespace {

using Fixture = test::ConsoleFixture;

std::size_t LoopEdges(const mapstore::VIMap& map) {
  std::size_t n = 0;
  for (const auto& m : map.mission_ids()) {
    for (const auto& id : map.edge_ids(m)) {
      n += map.edge(id).type == mapstore::EdgeType::kLoopClosure;
    }
  }
  return n;
}

TEST_CASE("lc within a mission merges re-observed landmarks and adds loop-closure edges") {
  const auto& maps = test::TestMaps();
  std::string reports[2];
  std::size_t landmarks_after[2] = {0, 0};
  for (int run = 0; run < 2; ++run) {
    Fixture f;
    REQUIRE(f.Run("load " + maps.session0_map).ok());
    const std::size_t landmarks = f.map().num_landmarks();
    f.out.str("");
    // A 10 s session: places seen again after 3 s count.
    REQUIRE(f.Run("lc --lc_min_time_gap_s=3").ok());
    reports[run] = f.out.str();
    INFO(reports[run]);
    CHECK(LoopEdges(f.map()) > 0);
    CHECK(f.map().num_landmarks() < landmarks);
    CHECK(mapstore::CheckMapConsistency(f.map()).ok());
    landmarks_after[run] = f.map().num_landmarks();
    // A loop edge joins two vertices at least the gap apart.
    for (const auto& id : f.map().edge_ids(f.map().mission_ids()[0])) {
      const auto& e = f.map().edge(id);
      if (e.type != mapstore::EdgeType::kLoopClosure) continue;
      CHECK(std::llabs(f.map().vertex(e.from).t_ns - f.map().vertex(e.to).t_ns) > 2'900'000'000LL);
    }
  }
  CHECK(landmarks_after[0] == landmarks_after[1]);
  // The report line (progress lines before it depend on timing).
  auto counts = [](const std::string& report) {
    const std::size_t line = report.rfind("\nlc: ");
    const std::size_t begin = line == std::string::npos ? 0 : line + 1;
    return report.substr(begin, report.find("edges;", begin) - begin);
  };
  CHECK(counts(reports[0]) == counts(reports[1]));
  CHECK_THAT(counts(reports[0]), Catch::Contains("loops verified"));
}

TEST_CASE("lc: keypoints that join another track's landmark get the detector's noise") {
  // Every keypoint as if refined (0.15 px, consistent with its own track only): the ones lc
  // ties to another track's landmark get lc_merged_keypoint_sigma_px (1 px by default), the
  // others keep theirs; 0 keeps every keypoint's.
  const auto& maps = test::TestMaps();
  mapstore::VIMap refined = mapstore::LoadMap(maps.session0_map);
  const mapstore::MissionId mission = refined.mission_ids().at(0);
  std::map<std::tuple<mapstore::VertexId, std::size_t, std::size_t>, mapstore::LandmarkId> before;
  for (const auto& v : refined.vertex_ids(mission)) {
    auto& frames = refined.vertex(v).frames;
    for (std::size_t c = 0; c < frames.size(); ++c) {
      for (std::size_t k = 0; k < frames[c].keypoints.size(); ++k) {
        frames[c].keypoints[k].sigma_px = 0.15;
        before[{v, c, k}] = frames[c].landmark_ids[k];
      }
    }
  }
  const std::string dir = test::ConsoleScratch("lc_sigma") + "/map";
  mapstore::SaveMap(refined, dir);
  for (const double merged_sigma : {1.0, 0.0}) {
    INFO("lc_merged_keypoint_sigma_px " << merged_sigma);
    Fixture f;
    REQUIRE(f.Run("load " + dir).ok());
    REQUIRE(f.Run("lc --lc_min_time_gap_s=3 --lc_merged_keypoint_sigma_px=" +
                  std::to_string(merged_sigma))
                .ok());
    const mapstore::VIMap& map = f.map();
    REQUIRE(LoopEdges(map) > 0);
    int joined = 0, wrong = 0;
    for (const auto& [key, landmark] : before) {
      const auto& [v, c, k] = key;
      const mapstore::VisualFrame& frame = map.vertex(v).frames[c];
      // Joined: observes a landmark now that it did not before (its own was merged away, or it
      // had none).
      const bool now = frame.landmark_ids[k].IsValid();
      const bool moved = now && (!landmark.IsValid() || !map.HasLandmark(landmark) ||
                                 frame.landmark_ids[k] != landmark);
      joined += moved;
      const double expected = moved && merged_sigma > 0 ? merged_sigma : 0.15;
      wrong += frame.keypoints[k].sigma_px != expected;
    }
    CHECK(joined > 0);
    CHECK(wrong == 0);
    CHECK(mapstore::CheckMapConsistency(map).ok());
  }
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  CHECK_FALSE(f.Run("lc --lc_merged_keypoint_sigma_px=-1").ok());
}

TEST_CASE("lc: a gap longer than the session finds nothing, bad input changes nothing") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const std::size_t landmarks = f.map().num_landmarks();
  REQUIRE(f.Run("lc --lc_min_time_gap_s=60").ok());
  CHECK(LoopEdges(f.map()) == 0);
  CHECK(f.map().num_landmarks() == landmarks);
  CommandResult r = f.Run("lc --lc_min_inliers=2");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("lc_min_inliers"));
  REQUIRE(f.Run("rlq").ok());
  r = f.Run("lc");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("no good landmarks"));
  CHECK(f.map().num_landmarks() == landmarks);
}

}  // namespace
}  // namespace vilma::console

namespace vilma::console {
namespace {

// T_W_M of a mission from its dataset's ground truth at the first vertex: T_W_I(gt) T_M_I^-1.
Transformation WorldFromMission(const mapstore::VIMap& map, const mapstore::MissionId& m,
                                const std::string& dataset) {
  const auto ds = AslDataset::Open(dataset);
  const auto& v = map.vertex(map.VertexChain(m).front());
  const GroundTruthState* best = nullptr;
  for (const auto& g : ds.ground_truth()) {
    if (best == nullptr || std::llabs(g.t_ns - v.t_ns) < std::llabs(best->t_ns - v.t_ns)) best = &g;
  }
  REQUIRE(best != nullptr);
  return Transformation(best->q_W_I, best->p_W_I) * v.T_M_I.inverse();
}

TEST_CASE("aam places the second session where the ground truth says, look-alikes stay unknown") {
  const auto& maps = test::TestMaps();
  {
    Fixture f;
    REQUIRE(f.Run("load_merge_all_maps " + maps.maps_folder).ok());
    const auto m0 = f.map().mission_ids()[0], m1 = f.map().mission_ids()[1];
    const Transformation expected = WorldFromMission(f.map(), m0, maps.session0_dataset).inverse() *
                                     WorldFromMission(f.map(), m1, maps.session1_dataset);
    REQUIRE(f.Run("aam").ok());
    INFO(f.out.str());
    CHECK(f.map().mission(m0).baseframe_known);
    REQUIRE(f.map().mission(m1).baseframe_known);
    const Transformation& got = f.map().mission(m1).T_G_M;
    CHECK((got.translation() - expected.translation()).norm() < 0.1);
    CHECK(AngleBetween(got.rotation(), expected.rotation()) * 180.0 / M_PI < 1.5);
    // Both anchored: lc across the missions finds loops and makes cross-mission landmarks.
    f.out.str("");
    REQUIRE(f.Run("lc").ok());
    CHECK_THAT(f.out.str(), !Catch::Contains(" 0 loops verified"));
    REQUIRE(f.Run("cmc").ok());
    // map_stats counts the landmarks seen from both missions, and the good ones among them.
    f.out.str("");
    REQUIRE(f.Run("ms").ok());
    CHECK_THAT(f.out.str(), Catch::Contains("% of the good ones") &&
                                !Catch::Contains("cross-mission landmarks 0 "));
  }
  {
    Fixture f;
    REQUIRE(f.Run("load_merge_all_maps " + maps.maps_folder).ok());
    // Session 1 with scrambled descriptors: a place that looks like nothing known.
    auto& map = *f.session.maps().Get(f.session.maps().selected()).map;
    const auto m1 = map.mission_ids()[1];
    uint8_t x = 17;
    for (const auto& id : map.vertex_ids(m1)) {
      for (auto& frame : map.vertex(id).frames) {
        for (auto& b : frame.descriptors) b = x = static_cast<uint8_t>(x * 73 + 41);
      }
    }
    REQUIRE(f.Run("aam").ok());
    CHECK_FALSE(f.map().mission(m1).baseframe_known);
    CHECK_THAT(f.out.str(), Catch::Contains("NOT anchored"));
    const CommandResult r = f.Run("aam --aam_min_support=0");
    CHECK(r.outcome == CommandOutcome::kFailed);
  }
}

}  // namespace
}  // namespace vilma::console

namespace vilma::console {
namespace {

TEST_CASE("aam on a map of one mission: it anchors G, a known baseframe is left as it is") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const auto m0 = f.map().mission_ids()[0];
  REQUIRE_FALSE(f.map().mission(m0).baseframe_known);
  REQUIRE(f.Run("aam").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("the first anchors G; 0 of 0 unknown missions anchored"));
  CHECK(f.map().mission(m0).baseframe_known);
  CHECK(f.map().mission(m0).T_G_M.translation().norm() == 0.0);
  // Known already (sbk with a moved baseframe): aam changes nothing.
  f.session.maps().Get(f.session.maps().selected()).map->mission(m0).T_G_M =
      Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1.0, 2.0, 3.0));
  f.out.str("");
  REQUIRE(f.Run("aam").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("0 of 0 unknown missions anchored"));
  CHECK(f.map().mission(m0).T_G_M.translation() == Eigen::Vector3d(1.0, 2.0, 3.0));
  REQUIRE(f.Run("cmc").ok());
}

}  // namespace
}  // namespace vilma::console

namespace vilma::console {
namespace {

TEST_CASE("missions with different rigs (mono and stereo): aam, lc and optvi use each its own") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map + " --map_key=mixed").ok());
  REQUIRE(f.Run("load_merge_map " + maps.stereo_map).ok());
  const auto m0 = f.map().mission_ids().at(0), m2 = f.map().mission_ids().at(1);
  REQUIRE(f.map().mission(m0).rig.cameras.size() == 1);
  REQUIRE(f.map().mission(m2).rig.cameras.size() == 2);
  const Transformation expected = WorldFromMission(f.map(), m0, maps.session0_dataset).inverse() *
                                   WorldFromMission(f.map(), m2, maps.stereo_dataset);
  REQUIRE(f.Run("aam").ok());
  INFO(f.out.str());
  REQUIRE(f.map().mission(m2).baseframe_known);
  const Transformation& got = f.map().mission(m2).T_G_M;
  CHECK((got.translation() - expected.translation()).norm() < 0.1);
  CHECK(AngleBetween(got.rotation(), expected.rotation()) * 180.0 / M_PI < 1.5);
  f.out.str("");
  REQUIRE(f.Run("lc").ok());
  CHECK_THAT(f.out.str(), !Catch::Contains(" 0 loops verified"));
  REQUIRE(f.Run("cmc").ok());
  // Observations of the stereo mission's second camera exist after the merge of landmarks.
  std::size_t camera1_observations = 0;
  for (const auto& m : f.map().mission_ids()) {
    for (const auto& l : f.map().landmark_ids(m)) {
      for (const auto& o : f.map().landmark(l).observations) camera1_observations += o.camera == 1;
    }
  }
  CHECK(camera1_observations > 0);
  REQUIRE(f.Run("optvi --ba_num_iterations=5").ok());
  REQUIRE(f.Run("cmc").ok());
}

}  // namespace
}  // namespace vilma::console

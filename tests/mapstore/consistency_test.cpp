#include <catch2/catch.hpp>

#include <cmath>

#include <filesystem>

#include "core/test_data.h"
#include "mapstore/synthetic_map.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"

using namespace vilma;
using namespace vilma::mapstore;
using namespace vilma::mapstore::testing;
using K = ConsistencyProblemKind;

namespace {
VIMap CleanMap() {
  SyntheticMapOptions o;
  o.images = true;
  return MakeSyntheticMap(o);
}
// The injected fault is reported (with the given text) and nothing else of another kind.
void RequireOnly(const VIMap& map, K kind, const std::string& text) {
  const ConsistencyReport report = CheckMapConsistency(map);
  INFO(report.FullReport());
  REQUIRE(report.Count(kind) >= 1);
  REQUIRE(report.Count(kind) == report.problems.size());
  bool mentioned = false;
  for (const auto& p : report.problems) mentioned = mentioned || p.message.find(text) != std::string::npos;
  CHECK(mentioned);
}
}  // namespace

TEST_CASE("a synthetic map is consistent", "[mapstore]") {
  const VIMap map = CleanMap();
  const ConsistencyReport report = CheckMapConsistency(map);
  INFO(report.FullReport());
  CHECK(report.ok());
  CHECK(report.FullReport() == "map is consistent\n");
}

TEST_CASE("consistency check catches each injected fault", "[mapstore]") {
  VIMap map = CleanMap();
  const MissionId m0 = map.mission_ids()[0];
  const MissionId m1 = map.mission_ids()[1];
  const auto& v0 = map.vertex_ids(m0);

  SECTION("duplicate id across kinds") {
    Landmark l = map.landmark(map.landmark_ids(m0)[0]);
    l.id = v0[5];  // a landmark with a vertex's id
    l.observations.clear();
    map.AddLandmark(l);
    const ConsistencyReport report = CheckMapConsistency(map);
    CHECK(report.Count(K::kDuplicateId) == 1);
    CHECK(report.Count(K::kOrphanLandmark) == 1);  // it also has no observations
    CHECK(report.problems.size() == 2);
    CHECK_THAT(report.FullReport(), Catch::Contains("duplicate_id: landmark " + v0[5].Hex()));
  }
  SECTION("vertex with a wrong mission id") {
    map.vertex(v0[4]).mission_id = m1;
    const ConsistencyReport report = CheckMapConsistency(map);
    INFO(report.FullReport());
    CHECK(report.Count(K::kMissionMismatch) == 1);
    // Its IMU edges now join vertices of two missions, which breaks the chain.
    CHECK(report.Count(K::kMissionMismatch) + report.Count(K::kBrokenChain) ==
          report.problems.size());
    CHECK_THAT(report.FullReport(), Catch::Contains("vertex " + v0[4].Hex() + " is listed in"));
  }
  SECTION("landmark observation without back-reference") {
    const Vertex& v = map.vertex(v0[3]);
    const LandmarkId lid = v.frames[0].landmark_ids[0];
    map.vertex(v0[3]).frames[0].landmark_ids[0] = LandmarkId();
    RequireOnly(map, K::kBackReference, lid.Hex());
  }
  SECTION("keypoint refers to a landmark that does not list it") {
    const LandmarkId lid = map.landmark_ids(m0)[0];
    map.landmark(lid).observations.pop_back();
    RequireOnly(map, K::kBackReference, "no observation back to it");
  }
  SECTION("observation of a missing keypoint") {
    const LandmarkId lid = map.landmark_ids(m0)[0];
    map.landmark(lid).observations.push_back({v0[9], 0, 100000});
    RequireOnly(map, K::kBackReference, "missing keypoint");
  }
  SECTION("edge to a missing vertex") {
    const EdgeId eid = map.edge_ids(m0)[0];
    map.edge(eid).to = IdGenerator(1234).Next();
    const ConsistencyReport report = CheckMapConsistency(map);
    INFO(report.FullReport());
    CHECK(report.Count(K::kBadReference) == 1);
    CHECK(report.Count(K::kBrokenChain) == 1);  // the chain stops at the root
    CHECK_THAT(report.FullReport(), Catch::Contains("ends at missing vertex"));
  }
  SECTION("chain broken by a missing IMU edge leaves an orphan vertex") {
    VIMap small = MakeSyntheticMap([] {
      SyntheticMapOptions o;
      o.missions = 1;
      o.extra_edges = false;
      o.vertices_per_mission = 5;
      return o;
    }());
    const MissionId mid = small.mission_ids()[0];
    // Re-point the last IMU edge so that it duplicates the previous one's start.
    const auto& edges = small.edge_ids(mid);
    small.edge(edges.back()).from = small.vertex_ids(mid)[2];
    small.edge(edges.back()).to = small.vertex_ids(mid)[3];
    const ConsistencyReport report = CheckMapConsistency(small);
    INFO(report.FullReport());
    CHECK(report.Count(K::kBrokenChain) >= 1);
    CHECK(report.Count(K::kOrphanVertex) == 1);
    CHECK_THAT(report.FullReport(), Catch::Contains(small.vertex_ids(mid)[4].Hex() + " has no edge"));
  }
  SECTION("IMU edge back in time") {
    std::swap(map.vertex(v0[6]).t_ns, map.vertex(v0[7]).t_ns);
    const ConsistencyReport report = CheckMapConsistency(map);
    INFO(report.FullReport());
    CHECK_THAT(report.FullReport(), Catch::Contains("goes back in time"));
    CHECK(report.Count(K::kBrokenChain) >= 1);
  }
  SECTION("IMU samples not covering the edge") {
    const EdgeId eid = map.edge_ids(m1)[2];
    map.edge(eid).imu_samples.pop_back();
    RequireOnly(map, K::kImuSamples, "do not cover");
  }
  SECTION("IMU samples out of order") {
    const EdgeId eid = map.edge_ids(m1)[2];
    std::swap(map.edge(eid).imu_samples[1], map.edge(eid).imu_samples[2]);
    RequireOnly(map, K::kImuSamples, "not strictly increasing");
  }
  SECTION("orphan landmark") {
    const LandmarkId lid = map.landmark_ids(m1).back();
    for (const LandmarkObservation& o : map.landmark(lid).observations) {
      map.vertex(o.vertex_id).frames[o.camera].landmark_ids[o.keypoint] = LandmarkId();
    }
    map.landmark(lid).observations.clear();
    RequireOnly(map, K::kOrphanLandmark, lid.Hex());
  }
  SECTION("bad root vertex") {
    map.mission(m1).root_vertex_id = v0[0];
    RequireOnly(map, K::kBadReference, "root vertex");
  }
  SECTION("visual frame arrays disagree") {
    map.vertex(v0[1]).frames[1].track_ids.pop_back();
    RequireOnly(map, K::kVisualFrame, "track_ids");
  }
  SECTION("keypoint sigma not positive or not finite") {
    map.vertex(v0[1]).frames[0].keypoints[2].sigma_px = GENERATE(0.0, -0.5, std::nan(""));
    RequireOnly(map, K::kVisualFrame, "keypoint 2: sigma_px expected finite and > 0");
  }
  SECTION("image resource not in the map") {
    map.vertex(v0[2]).frames[1].image_resource_id = IdGenerator(555).Next();
    RequireOnly(map, K::kMissingResource, "image resource");
  }
  SECTION("depth resource not in the map") {
    map.vertex(v0[2]).frames[1].depth_resource_id = IdGenerator(556).Next();
    RequireOnly(map, K::kMissingResource, "depth resource");
  }
  SECTION("resource file deleted from a saved map") {
    const vilma::testing::TempDir scratch;
    const std::string dir = scratch.File("consistency_resource");
    std::filesystem::remove_all(dir);
    SaveMap(map, dir);
    VIMap loaded = LoadMap(dir);
    const ResourceId rid = loaded.vertex(v0[2]).frames[1].image_resource_id;
    std::filesystem::remove(dir + "/" + loaded.resources().Info(ResourceType::kImage, rid).RelativePath());
    RequireOnly(loaded, K::kMissingResource, "has no file");
  }
}

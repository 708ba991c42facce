// SplitMissionDelta: parts under the size limit, every prefix of them a consistent map, all of
// them the same map as the delta.
#include <catch2/catch.hpp>

#include <algorithm>

#include "mapstore/synthetic_map.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/delta_split.h"

namespace vilma::mapstore {
namespace {

TEST_CASE("SplitMissionDelta: bounded parts, consistent prefixes, the same map", "[delta_split]") {
  testing::SyntheticMapOptions o;
  o.missions = 1;
  o.vertices_per_mission = 60;
  o.extra_edges = false;
  const VIMap source = testing::MakeSyntheticMap(o);
  const MissionId mission = source.mission_ids()[0];
  // The map builder's situation: vertices (without landmark ids) and edges streamed before;
  // the last delta re-sends every vertex with its landmark ids, and every landmark.
  // The last 8 vertices and their edges are new in the last delta (streamed every 10 vertices).
  const std::vector<VertexId> chain = source.VertexChain(mission);
  const std::size_t streamed = chain.size() - 8;
  VIMap before;
  before.AddMission(source.mission(mission));
  for (std::size_t i = 0; i < streamed; ++i) {
    Vertex bare = source.vertex(chain[i]);
    for (VisualFrame& f : bare.frames) f.landmark_ids.assign(f.size(), LandmarkId());
    before.AddVertex(bare);
  }
  MissionDelta last;
  last.mission = source.mission(mission);
  for (const EdgeId& e : source.edge_ids(mission)) {
    const std::size_t to = static_cast<std::size_t>(
        std::find(chain.begin(), chain.end(), source.edge(e).to) - chain.begin());
    if (to < streamed) {
      before.AddEdge(source.edge(e));
    } else {
      last.edges.push_back(source.edge(e));
    }
  }
  REQUIRE(CheckMapConsistency(before).ok());
  REQUIRE(last.edges.size() == 8);
  for (const VertexId& v : source.vertex_ids(mission)) last.vertices.push_back(source.vertex(v));
  for (const LandmarkId& l : source.landmark_ids(mission)) {
    last.landmarks.push_back(source.landmark(l));
  }
  const std::size_t whole = SerializeMissionDelta(last).size();
  const std::size_t limit = whole / 6;

  const std::vector<MissionDelta> parts = SplitMissionDelta(last, limit);
  CHECK(parts.size() >= 6);
  std::size_t largest_vertex = 0;
  for (const Vertex& v : last.vertices) {
    MissionDelta one;
    one.mission = last.mission;
    one.vertices.push_back(v);
    largest_vertex = std::max(largest_vertex, SerializeMissionDelta(one).size());
  }
  VIMap map = before.Clone();
  for (std::size_t i = 0; i < parts.size(); ++i) {
    INFO("part " << i << " of " << parts.size());
    CHECK(SerializeMissionDelta(parts[i]).size() <= limit + largest_vertex);
    // Through the wire format, as mapstored applies them.
    ApplyMissionDelta(ParseMissionDelta(SerializeMissionDelta(parts[i]), "part"), &map);
    const ConsistencyReport report = CheckMapConsistency(map);
    INFO(report.FullReport());
    CHECK(report.ok());
  }
  VIMap direct = before.Clone();
  ApplyMissionDelta(last, &direct);
  CHECK(map.num_landmarks() == direct.num_landmarks());
  for (const VertexId& v : direct.vertex_ids(mission)) {
    for (std::size_t c = 0; c < direct.vertex(v).frames.size(); ++c) {
      CHECK(map.vertex(v).frames[c].landmark_ids == direct.vertex(v).frames[c].landmark_ids);
    }
  }
  for (const LandmarkId& l : direct.landmark_ids(mission)) {
    CHECK(map.landmark(l).observations == direct.landmark(l).observations);
  }
  // Small enough: the delta itself.
  CHECK(SplitMissionDelta(last, whole).size() == 1);
}

}  // namespace
}  // namespace vilma::mapstore

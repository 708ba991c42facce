// The map builder's memory in long streamed missions (docs/daemon.md "Memory in long
// missions"): with MapBuilderMemory::kReleaseAcknowledged and a fake acknowledgement of the
// deltas, what the builder holds stays bounded over a long synthetic stream, every prefix of
// the deltas is a consistent map on the receiver's side, the last delta carries only what was
// not final, and the receiver's mission equals the whole-mission build of the same input (but
// for the landmark ids and their order).
#include <catch2/catch.hpp>
#include <map>
#include <opencv2/imgproc.hpp>
#include <random>

#include "vilma/mapping/map_builder.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"

namespace vilma {
namespace {

using mapping::FrameState;
using mapping::MapBuilder;
using mapping::MapBuilderMemory;

// A camera (320x240, f 300 px, looking along z of M = I = C) sliding along x in front of a
// textured plane at depth kDepthM: vertex i sees the texture's columns i * kShiftPx ... + 320,
// i.e. the camera is at x = i * kShiftPx * kDepthM / f (a pure translation shifts the plane's
// image by f dx / depth). Features leave the view on the left and enter on the right, so
// tracks open and close all the time, as in a long mission.
constexpr int kWidth = 320, kHeight = 240, kShiftPx = 8;
constexpr double kF = 300.0, kDepthM = 3.0;

struct SlidingStream {
  SensorRig rig;
  cv::Mat texture;
  explicit SlidingStream(int vertices) {
    CameraConfig camera;
    camera.camera = Camera(kWidth, kHeight, Eigen::Vector4d(kF, kF, kWidth / 2.0, kHeight / 2.0),
                           DistortionModel::kNone, Eigen::VectorXd());
    rig.cameras.push_back(camera);
    cv::Mat noise(kHeight, kWidth + kShiftPx * vertices, CV_8UC1);
    cv::RNG rng(11);
    rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
    cv::GaussianBlur(noise, texture, cv::Size(0, 0), 1.5);
    cv::normalize(texture, texture, 0, 255, cv::NORM_MINMAX);
  }
  static int64_t Time(int i) { return int64_t{1'000'000'000} + int64_t{100'000'000} * i; }
  FrameState State(int i) const {
    FrameState s;
    s.t_ns = Time(i);
    s.T_M_I = Transformation(Eigen::Quaterniond::Identity(),
                             Eigen::Vector3d(i * kShiftPx * kDepthM / kF, 0.0, 0.0));
    return s;
  }
  cv::Mat Image(int i) const { return texture(cv::Rect(i * kShiftPx, 0, kWidth, kHeight)).clone(); }
  // IMU at 200 Hz over (Time(i - 1), Time(i)]: at rest (the builder checks no physics).
  static void AddImu(MapBuilder* b, int i) {
    for (int64_t t = i == 0 ? Time(0) - 50'000'000 : Time(i - 1) + 5'000'000; t <= Time(i);
         t += 5'000'000) {
      ImuSample s;
      s.t_ns = t;
      s.a_I = Eigen::Vector3d(0, 0, 9.81);
      b->AddImu(s);
    }
  }
};

// Both maps' mission: equal vertices (ids, order, states, keypoints, descriptors, tracks),
// edges, and landmarks matched through the keypoints that observe them (positions,
// covariances, quality, store vertex, observations).
void CheckSameMission(const mapstore::VIMap& whole, const mapstore::VIMap& streamed,
                      const mapstore::MissionId& id) {
  REQUIRE(streamed.HasMission(id));
  CHECK(streamed.mission(id).complete == whole.mission(id).complete);
  CHECK(streamed.mission(id).root_vertex_id == whole.mission(id).root_vertex_id);
  REQUIRE(streamed.vertex_ids(id) == whole.vertex_ids(id));
  REQUIRE(streamed.edge_ids(id) == whole.edge_ids(id));
  REQUIRE(streamed.landmark_ids(id).size() == whole.landmark_ids(id).size());
  std::map<mapstore::Id, mapstore::Id> landmark_of;  // whole's id -> streamed id
  int mismatches = 0;
  for (const mapstore::VertexId& vid : whole.vertex_ids(id)) {
    const mapstore::Vertex& a = whole.vertex(vid);
    const mapstore::Vertex& b = streamed.vertex(vid);
    mismatches += !(a.t_ns == b.t_ns && a.T_M_I.translation() == b.T_M_I.translation() &&
                    a.T_M_I.rotation().coeffs() == b.T_M_I.rotation().coeffs() &&
                    a.frames.size() == b.frames.size());
    for (std::size_t c = 0; c < a.frames.size() && c < b.frames.size(); ++c) {
      const mapstore::VisualFrame& fa = a.frames[c];
      const mapstore::VisualFrame& fb = b.frames[c];
      if (fa.keypoints.size() != fb.keypoints.size() || fa.descriptors != fb.descriptors ||
          fa.track_ids != fb.track_ids) {
        ++mismatches;
        continue;
      }
      for (std::size_t k = 0; k < fa.keypoints.size(); ++k) {
        mismatches += !(fa.keypoints[k].uv == fb.keypoints[k].uv);
        const bool la = fa.landmark_ids[k].IsValid(), lb = fb.landmark_ids[k].IsValid();
        if (la != lb) {
          ++mismatches;
          continue;
        }
        if (!la) continue;
        const auto [it, inserted] = landmark_of.emplace(fa.landmark_ids[k], fb.landmark_ids[k]);
        mismatches += !inserted && it->second != fb.landmark_ids[k];
      }
    }
  }
  CHECK(mismatches == 0);
  for (const mapstore::EdgeId& eid : whole.edge_ids(id)) {
    const mapstore::Edge& a = whole.edge(eid);
    const mapstore::Edge& b = streamed.edge(eid);
    CHECK((a.from == b.from && a.to == b.to && a.imu_samples.size() == b.imu_samples.size()));
  }
  REQUIRE(landmark_of.size() == whole.landmark_ids(id).size());
  int landmark_mismatches = 0;
  for (const auto& [wid, sid] : landmark_of) {
    const mapstore::Landmark& a = whole.landmark(wid);
    const mapstore::Landmark& b = streamed.landmark(sid);
    landmark_mismatches += !(a.p_I == b.p_I && a.covariance == b.covariance &&
                             a.quality == b.quality && a.store_vertex_id == b.store_vertex_id &&
                             a.observations == b.observations);
  }
  CHECK(landmark_mismatches == 0);
}

TEST_CASE("map memory: a streamed mission releases acknowledged data and stays the same map",
          "[daemon][mapping][memory]") {
  constexpr int kVertices = 300;
  const SlidingStream stream(kVertices);
  mapping::MapBuilderOptions options;

  // The whole mission in memory, as --save-map builds it.
  MapBuilder whole(stream.rig, options, 7, "slide");
  for (int i = 0; i < kVertices; ++i) {
    SlidingStream::AddImu(&whole, i);
    REQUIRE(whole.AddFrame(stream.State(i), {stream.Image(i)}));
  }
  whole.Finish();
  const mapstore::MissionDelta whole_last = whole.TakeDelta();
  CHECK(static_cast<int>(whole_last.vertices.size()) == kVertices);  // Finish re-sends all

  // Streamed with release: a delta every 10 vertices, acknowledged 2 deltas later (the
  // receiver's journal lags), applied to the receiver's map in order.
  MapBuilder streamed(stream.rig, options, 7, "slide", MapBuilderMemory::kReleaseAcknowledged);
  REQUIRE(streamed.mission_id() == whole.mission_id());
  mapstore::VIMap receiver;
  int64_t held_max_first = 0, held_max_last = 0, bytes_max_last = 0;
  int consistency_checks = 0;
  for (int i = 0; i < kVertices; ++i) {
    SlidingStream::AddImu(&streamed, i);
    REQUIRE(streamed.AddFrame(stream.State(i), {stream.Image(i)}));
    if (i % 10 != 9) continue;
    mapstore::ApplyMissionDelta(streamed.TakeDelta(), &receiver);
    if (i % 50 == 49) {
      // Every prefix of the stream is a map that mapstored could finalize (a crash).
      const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(receiver);
      INFO("after vertex " << i << ": " << report.FullReport());
      CHECK(report.ok());
      ++consistency_checks;
    }
    streamed.ReleaseAcknowledged(streamed.delta_count() - 3);
    const mapping::MapBuilderHeld held = streamed.Held();
    if (i < kVertices / 3) held_max_first = std::max(held_max_first, held.vertices);
    if (i >= 2 * kVertices / 3) {
      held_max_last = std::max(held_max_last, held.vertices);
      bytes_max_last = std::max(bytes_max_last, held.bytes);
    }
  }
  CHECK(consistency_checks == kVertices / 50);
  const mapping::MapBuilderHeld before_finish = streamed.Held();
  INFO("held vertices: max " << held_max_first << " in the first third, " << held_max_last
                             << " in the last third; " << bytes_max_last << " bytes; "
                             << streamed.stats().landmarks << " landmarks");
  // Bounded: a track lives at most 320 / 8 = 40 vertices, and the oldest vertex of a landmark
  // waits for its last observer; plus the 30 vertices of the unacknowledged deltas.
  CHECK(held_max_last <= 130);
  CHECK(held_max_last <= held_max_first + 20);  // not growing with the mission
  CHECK(streamed.stats().landmarks > 300);
  CHECK(before_finish.bytes < 40 << 20);

  streamed.Finish();
  const mapstore::MissionDelta last = streamed.TakeDelta();
  // Finish sends only what was not final: at most the vertices of the open tracks.
  CHECK(last.vertices.size() <= static_cast<std::size_t>(before_finish.vertices));
  CHECK(last.vertices.size() < static_cast<std::size_t>(kVertices) / 5);
  mapstore::ApplyMissionDelta(last, &receiver);
  streamed.ReleaseAcknowledged(streamed.delta_count() - 1);
  CHECK(streamed.Held().vertices <= 1);  // the mission's root stays
  CHECK(streamed.Held().landmarks == 0);
  CHECK(streamed.Held().edges == 0);

  const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(receiver);
  INFO(report.FullReport());
  CHECK(report.ok());
  CheckSameMission(whole.map(), receiver, whole.mission_id());
  // The counters of the two builds agree.
  CHECK(streamed.stats().landmarks == whole.stats().landmarks);
  CHECK(streamed.stats().landmarks_good == whole.stats().landmarks_good);
  CHECK(streamed.stats().tracks == whole.stats().tracks);
  CHECK(streamed.stats().keypoints_dropped == whole.stats().keypoints_dropped);
}

TEST_CASE("map memory: the whole-mission mode keeps everything, images need a local copy",
          "[daemon][mapping][memory]") {
  const SlidingStream stream(40);
  MapBuilder whole(stream.rig, mapping::MapBuilderOptions(), 7, "slide");
  for (int i = 0; i < 40; ++i) {
    SlidingStream::AddImu(&whole, i);
    whole.AddFrame(stream.State(i), {stream.Image(i)});
    if (i % 10 == 9) {
      whole.TakeDelta();
      whole.ReleaseAcknowledged(whole.delta_count() - 1);
    }
  }
  CHECK(whole.Held().vertices == 40);
  mapping::MapBuilderOptions with_images;
  with_images.keep_images = true;
  CHECK_THROWS_WITH(MapBuilder(stream.rig, with_images, 7, "", MapBuilderMemory::kReleaseAcknowledged),
                    Catch::Contains("keep_images"));
}

}  // namespace
}  // namespace vilma

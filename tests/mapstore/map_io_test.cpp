#include <catch2/catch.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/test_data.h"
#include "mapstore/synthetic_map.h"
#include "vilma/core/error.h"
#include "vilma/mapstore/checksum.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"

namespace fs = std::filesystem;
using namespace vilma;
using namespace vilma::mapstore;
using namespace vilma::mapstore::testing;

namespace {

// One scratch folder per test process, removed at exit; each test takes a fresh subfolder.
const vilma::testing::TempDir& ScratchRoot() {
  static const vilma::testing::TempDir root;
  return root;
}

std::string FreshDir(const std::string& name) {
  const std::string dir = ScratchRoot().File(name);
  fs::remove_all(dir);
  return dir;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// Relative path -> bytes of every file under `dir`.
std::map<std::string, std::string> FolderContents(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = ReadFile(e.path().string());
  }
  return files;
}

std::string FirstChunk(const std::string& dir, const VIMap& map, const std::string& kind) {
  return dir + "/missions/" + map.mission_ids()[0].Hex() + "/g000001/" + kind + "_000000.pb";
}

}  // namespace

TEST_CASE("round trip of every element is bit-exact (multi-mission, cross-mission)", "[mapstore]") {
  SyntheticMapOptions o;
  o.missions = 3;
  o.images = true;
  const VIMap map = MakeSyntheticMap(o);
  REQUIRE(CheckMapConsistency(map).ok());
  const std::string dir = FreshDir("round_trip");
  MapSaveOptions save;
  save.vertices_per_chunk = 5;  // several chunks per mission
  save.edges_per_chunk = 4;
  save.landmarks_per_chunk = 7;
  const MapSaveSummary summary = SaveMap(map, dir, save);
  CHECK(summary.generation == 1);
  CHECK(fs::exists(dir + "/missions/" + map.mission_ids()[0].Hex() + "/g000001/vertices_000002.pb"));
  const VIMap loaded = LoadMap(dir);
  RequireMapsEqual(map, loaded);
  CHECK(CheckMapConsistency(loaded).ok());
  // Resources come back byte for byte.
  for (const ResourceInfo& info : map.resources().List()) {
    REQUIRE(*loaded.resources().Load(info.type, info.id) == *map.resources().Load(info.type, info.id));
  }
  // Landmark positions in G agree (cross-mission observations included).
  for (const MissionId& mid : map.mission_ids()) {
    for (const LandmarkId& lid : map.landmark_ids(mid)) {
      REQUIRE(BitEqual(map.LandmarkPosition_G(lid), loaded.LandmarkPosition_G(lid)));
    }
  }
}

TEST_CASE("keypoint sigmas: saved per keypoint, absent for default frames (old maps)",
          "[mapstore]") {
  SyntheticMapOptions o;
  o.missions = 1;
  o.vertices_per_mission = 4;
  VIMap map = MakeSyntheticMap(o);
  const MissionId m = map.mission_ids()[0];
  // The synthetic map varies camera 0's sigmas; a map written before the field existed has
  // none: every keypoint at the default, which saves as the old format did (no field).
  VIMap old_map = map.Clone();
  for (const VertexId& vid : old_map.vertex_ids(m)) {
    for (VisualFrame& f : old_map.vertex(vid).frames) {
      for (Keypoint& k : f.keypoints) k.sigma_px = kDefaultKeypointSigmaPx;
    }
  }
  const std::string dir = FreshDir("sigmas"), old_dir = FreshDir("sigmas_old");
  SaveMap(map, dir);
  SaveMap(old_map, old_dir);
  // The field costs bytes only where sigmas differ from the default (8 per keypoint + tags).
  const auto vertex_bytes = [&](const std::string& d) {
    return fs::file_size(FirstChunk(d, map, "vertices"));
  };
  CHECK(vertex_bytes(dir) > vertex_bytes(old_dir));
  const VIMap loaded = LoadMap(dir);
  RequireMapsEqual(map, loaded);
  const VIMap loaded_old = LoadMap(old_dir);
  RequireMapsEqual(old_map, loaded_old);
  CHECK(CheckMapConsistency(loaded_old).ok());
  const VertexId v = map.vertex_ids(m)[1];
  CHECK(loaded.vertex(v).frames[0].keypoints[0].sigma_px != kDefaultKeypointSigmaPx);
  CHECK(loaded_old.vertex(v).frames[0].keypoints[0].sigma_px == kDefaultKeypointSigmaPx);
  // A sigma that is not > 0 is not saved (the frame's Validate names it).
  map.vertex(v).frames[0].keypoints[1].sigma_px = 0.0;
  REQUIRE_THROWS_WITH(SaveMap(map, FreshDir("sigmas_bad")),
                      Catch::Contains("keypoint 1: sigma_px expected finite and > 0"));
}

TEST_CASE("special doubles survive bit-exactly", "[mapstore]") {
  SyntheticMapOptions o;
  o.missions = 1;
  o.vertices_per_mission = 3;
  VIMap map = MakeSyntheticMap(o);
  const VertexId vid = map.vertex_ids(map.mission_ids()[0])[1];
  map.vertex(vid).v_M = Eigen::Vector3d(-0.0, std::numeric_limits<double>::denorm_min(),
                                        std::numeric_limits<double>::quiet_NaN());
  map.vertex(vid).accel_bias = Eigen::Vector3d(std::numeric_limits<double>::infinity(), 1e308, -1e-308);
  const std::string dir = FreshDir("special_doubles");
  SaveMap(map, dir);
  RequireMapsEqual(map, LoadMap(dir));
}

TEST_CASE("a mission name of any bytes (not UTF-8) saves and loads back", "[mapstore]") {
  // Mission names come from the network (mapstored) and from users; proto3 refuses to parse a
  // `string` field that is not UTF-8, so such a name once made a map that saved but never loaded
  // (found by fuzz_mission_stream).
  SyntheticMapOptions o;
  o.missions = 2;
  o.vertices_per_mission = 3;
  VIMap map = MakeSyntheticMap(o);
  map.mission(map.mission_ids()[0]).name = std::string("bad\xff\xfe name\xc3", 12);
  map.mission(map.mission_ids()[1]).name = std::string("nul\0inside", 11);
  const std::string dir = FreshDir("non_utf8_name");
  SaveMap(map, dir);
  const VIMap loaded = LoadMap(dir);
  RequireMapsEqual(map, loaded);
  CHECK(loaded.mission(loaded.mission_ids()[0]).name == map.mission(map.mission_ids()[0]).name);
  CHECK(loaded.mission(loaded.mission_ids()[1]).name.size() == 11);
}

TEST_CASE("saving is deterministic: same map, identical files", "[mapstore]") {
  SyntheticMapOptions o;
  o.images = true;
  const std::string a = FreshDir("determinism_a"), b = FreshDir("determinism_b");
  SaveMap(MakeSyntheticMap(o), a);
  SaveMap(MakeSyntheticMap(o), b);
  const auto fa = FolderContents(a), fb = FolderContents(b);
  CHECK(fa.size() > 5);
  CHECK(fa == fb);
  // Load and save again: the same bytes (order and values preserved).
  const std::string c = FreshDir("determinism_c");
  SaveMap(LoadMap(a), c);
  CHECK(FolderContents(c) == fa);
}

TEST_CASE("loader errors name the file, the field and the expectation", "[mapstore]") {
  const VIMap map = MakeSyntheticMap({});
  const std::string dir = FreshDir("errors");
  SaveMap(map, dir);
  const std::string manifest = dir + "/manifest.yaml";

  SECTION("corrupted chunk: checksum mismatch") {
    const std::string path = FirstChunk(dir, map, "landmarks");
    std::string bytes = ReadFile(path);
    bytes[bytes.size() / 2] ^= 0x01;
    WriteFile(path, bytes);
    REQUIRE_THROWS_WITH(LoadMap(dir), Catch::StartsWith(path + ": crc32: expected 0x") &&
                                          Catch::Contains("checksum mismatch: corrupted file") &&
                                          Catch::Contains("computed 0x"));
  }
  SECTION("truncated chunk") {
    const std::string path = FirstChunk(dir, map, "vertices");
    const std::string bytes = ReadFile(path);
    WriteFile(path, bytes.substr(0, bytes.size() - 10));
    REQUIRE_THROWS_WITH(LoadMap(dir),
                        Catch::StartsWith(path + ": size: expected " + std::to_string(bytes.size()) +
                                          " bytes as listed in " + manifest + ", found " +
                                          std::to_string(bytes.size() - 10) + " (truncated file)"));
  }
  SECTION("missing chunk") {
    const std::string path = FirstChunk(dir, map, "edges");
    fs::remove(path);
    REQUIRE_THROWS_WITH(LoadMap(dir), path + ": expected the data file listed in " + manifest +
                                          " (missing chunk)");
  }
  SECTION("newer format version is rejected") {
    std::string text = ReadFile(manifest);
    const auto pos = text.find("format_version: 1");
    REQUIRE(pos != std::string::npos);
    text.replace(pos, 17, "format_version: 2");
    WriteFile(manifest, text);
    REQUIRE_THROWS_WITH(LoadMap(dir),
                        Catch::Contains(manifest) && Catch::Contains("format_version") &&
                            Catch::Contains("expected a version from 1 to 1") &&
                            Catch::Contains("found 2") &&
                            Catch::Contains("written by a newer vilma; update vilma"));
  }
  SECTION("chunk with a wrong format version (checksums fixed up)") {
    const std::string path = FirstChunk(dir, map, "vertices");
    std::string bytes = ReadFile(path);
    // Field 1 (format_version, varint) is the first byte pair: 0x08 0x01.
    REQUIRE(bytes.substr(0, 2) == std::string("\x08\x01", 2));
    bytes[1] = 0x07;
    WriteFile(path, bytes);
    std::string text = ReadFile(manifest);
    const std::string old_crc = Crc32Hex(Crc32(ReadFile(path).replace(1, 1, "\x01")));
    const auto pos = text.find(old_crc);
    REQUIRE(pos != std::string::npos);
    text.replace(pos, old_crc.size(), Crc32Hex(Crc32(bytes)));
    WriteFile(manifest, text);
    REQUIRE_THROWS_WITH(LoadMap(dir), path + ": format_version: expected 1 (the manifest's), found 7");
  }
  SECTION("garbage that is not a protobuf message (checksum verification off)") {
    const std::string path = FirstChunk(dir, map, "landmarks");
    const std::string bytes = ReadFile(path);
    WriteFile(path, std::string(bytes.size(), '\xff'));
    MapLoadOptions options;
    options.verify_checksums = false;
    REQUIRE_THROWS_WITH(LoadMap(dir, options),
                        path + ": expected a valid LandmarkChunk protobuf message");
  }
  SECTION("truncated manifest") {
    const std::string text = ReadFile(manifest);
    WriteFile(manifest, text.substr(0, text.find("missions:")));
    REQUIRE_THROWS_WITH(LoadMap(dir), Catch::StartsWith(manifest) && Catch::Contains("missions"));
  }
  SECTION("not a map folder") {
    fs::remove(manifest);
    REQUIRE_THROWS_WITH(LoadMap(dir), manifest + ": expected a map manifest (is this a vilma map folder?)");
  }
}

TEST_CASE("a failed save leaves the previous map intact", "[mapstore]") {
  const std::string dir = FreshDir("crash");
  SyntheticMapOptions o;
  o.images = true;
  const VIMap first = MakeSyntheticMap(o);
  SaveMap(first, dir);
  const std::string manifest_before = ReadFile(dir + "/manifest.yaml");

  // A different map, saved up to (not including) the manifest's rename; the crash also leaves
  // a half-written temporary manifest behind.
  o.seed = 8;
  o.vertices_per_mission = 20;
  const VIMap second = MakeSyntheticMap(o);
  MapSaveOptions crash;
  crash.stop_before_manifest = true;
  const MapSaveSummary summary = SaveMap(second, dir, crash);
  CHECK(summary.generation == 2);
  WriteFile(dir + "/manifest.yaml.tmp.12345", manifest_before.substr(0, 40));
  CHECK(ReadFile(dir + "/manifest.yaml") == manifest_before);
  {
    const VIMap loaded = LoadMap(dir);
    RequireMapsEqual(first, loaded);
  }

  // The next successful save commits, and removes the generations it does not list.
  SaveMap(second, dir);
  const VIMap loaded = LoadMap(dir);
  RequireMapsEqual(second, loaded);
  for (const MissionId& mid : second.mission_ids()) {
    CHECK_FALSE(fs::exists(dir + "/missions/" + mid.Hex() + "/g000001"));
    CHECK(fs::exists(dir + "/missions/" + mid.Hex() + "/g000002"));
  }
  // Missions of the first map that the second lacks are removed.
  for (const MissionId& mid : first.mission_ids()) {
    if (!second.HasMission(mid)) CHECK_FALSE(fs::exists(dir + "/missions/" + mid.Hex()));
  }
  // Re-saving a loaded map into its own folder keeps its resources.
  SaveMap(loaded, dir);
  const VIMap again = LoadMap(dir);
  for (const ResourceInfo& info : second.resources().List()) {
    REQUIRE(*again.resources().Load(info.type, info.id) == *second.resources().Load(info.type, info.id));
  }
  CHECK(CheckMapConsistency(again).ok());
}

TEST_CASE("a save removes the temporary manifest of a save killed before its rename",
          "[mapstore]") {
  // scripts/crash-campaign.sh: a kill -9 between the temporary manifest's creation and its
  // rename leaves ".manifest.yaml.XXXXXX" (mkstemp's name) in the map folder.
  const std::string dir = FreshDir("temporary-manifest");
  const VIMap map = MakeSyntheticMap(SyntheticMapOptions());
  SaveMap(map, dir);
  const std::string manifest = ReadFile(dir + "/manifest.yaml");
  WriteFile(dir + "/.manifest.yaml.Xq3k9Z", manifest.substr(0, manifest.size() / 2));
  WriteFile(dir + "/.manifest.yaml.kept", "not a temporary name");
  WriteFile(dir + "/notes.txt", "a user's file");
  RequireMapsEqual(map, LoadMap(dir));  // the leftover does not disturb loading

  SaveMap(map, dir);
  CHECK_FALSE(fs::exists(dir + "/.manifest.yaml.Xq3k9Z"));
  CHECK(fs::exists(dir + "/.manifest.yaml.kept"));
  CHECK(fs::exists(dir + "/notes.txt"));
  RequireMapsEqual(map, LoadMap(dir));
}

TEST_CASE("mission deltas rebuild the map incrementally", "[mapstore]") {
  SyntheticMapOptions o;
  o.missions = 1;
  o.extra_edges = false;
  const VIMap full = MakeSyntheticMap(o);
  const MissionId mid = full.mission_ids()[0];

  // Stream: one delta per vertex with its incoming IMU edge; landmarks (with all their
  // observations) and the completed mission in a final delta, as a map builder would.
  VIMap rebuilt;
  const auto& vertex_ids = full.vertex_ids(mid);
  const auto& edge_ids = full.edge_ids(mid);
  Mission mission = full.mission(mid);
  const bool complete = mission.complete;
  mission.complete = false;
  for (std::size_t i = 0; i < vertex_ids.size(); ++i) {
    MissionDelta delta;
    delta.mission = mission;
    Vertex v = full.vertex(vertex_ids[i]);
    for (VisualFrame& f : v.frames) f.landmark_ids.assign(f.size(), LandmarkId());
    delta.vertices.push_back(v);
    if (i > 0) delta.edges.push_back(full.edge(edge_ids[i - 1]));
    const std::string bytes = SerializeMissionDelta(delta);
    CHECK(bytes == SerializeMissionDelta(delta));  // deterministic
    ApplyMissionDelta(ParseMissionDelta(bytes, "delta " + std::to_string(i)), &rebuilt);
  }
  CHECK_FALSE(rebuilt.mission(mid).complete);
  MissionDelta final_delta;
  final_delta.mission = full.mission(mid);
  REQUIRE(final_delta.mission.complete == complete);
  for (const VertexId& id : vertex_ids) final_delta.vertices.push_back(full.vertex(id));  // upsert
  for (const LandmarkId& id : full.landmark_ids(mid)) final_delta.landmarks.push_back(full.landmark(id));
  ApplyMissionDelta(ParseMissionDelta(SerializeMissionDelta(final_delta), "final"), &rebuilt);
  RequireMapsEqual(full, rebuilt);
  CHECK(CheckMapConsistency(rebuilt).ok());

  REQUIRE_THROWS_WITH(ParseMissionDelta("\xff\xff\xff", "udp chunk 7"),
                      "udp chunk 7: expected a valid MissionDelta protobuf message");
}

TEST_CASE("save options are validated", "[mapstore]") {
  MapSaveOptions o;
  CHECK(o.Validate().empty());
  o.vertices_per_chunk = 0;
  CHECK(o.Validate() == "vertices_per_chunk: expected > 0");
  CHECK_THROWS_AS(SaveMap(VIMap(), FreshDir("options"), o), std::invalid_argument);
}

// Benchmark (hidden): 5k vertices, 100k landmarks with 5 observations each, 100 keypoints with
// 512-bit descriptors per vertex, 20 IMU samples per edge. Run with
//   vilma_mapstore_tests "[.benchmark]" -s
TEST_CASE("map store benchmark: 5k vertices, 100k landmarks", "[.benchmark][mapstore]") {
  using Clock = std::chrono::steady_clock;
  SyntheticMapOptions o;
  o.missions = 1;
  o.vertices_per_mission = 5000;
  o.cameras = 1;
  o.landmarks_per_vertex = 20;
  o.observations_per_landmark = 5;
  o.imu_samples_per_edge = 20;
  o.cross_mission = false;
  const auto t0 = Clock::now();
  const VIMap map = MakeSyntheticMap(o);
  const auto t1 = Clock::now();
  REQUIRE(map.num_landmarks() == 100000);
  const std::string dir = FreshDir("benchmark");
  const MapSaveSummary summary = SaveMap(map, dir);
  const auto t2 = Clock::now();
  const VIMap loaded = LoadMap(dir);
  const auto t3 = Clock::now();
  MapLoadOptions no_crc;
  no_crc.verify_checksums = false;
  const VIMap loaded_no_crc = LoadMap(dir, no_crc);
  const auto t4 = Clock::now();
  const ConsistencyReport report = CheckMapConsistency(loaded);
  const auto t5 = Clock::now();
  CHECK(report.ok());
  CHECK(loaded.num_vertices() == 5000);
  auto ms = [](Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); };
  std::printf(
      "mapstore benchmark: %zu vertices, %zu edges, %zu landmarks, %llu files, %.1f MB\n"
      "  build %.0f ms | save %.0f ms | load %.0f ms (checksums on) | load %.0f ms (off) | "
      "consistency check %.0f ms\n",
      map.num_vertices(), map.num_edges(), map.num_landmarks(),
      static_cast<unsigned long long>(summary.files_written), summary.bytes_written / 1e6,
      ms(t1 - t0), ms(t2 - t1), ms(t3 - t2), ms(t4 - t3), ms(t5 - t4));
}

TEST_CASE("saving over a folder whose manifest is unreadable picks a fresh generation", "[mapstore]") {
  const std::string dir = FreshDir("unreadable_manifest");
  const VIMap map = MakeSyntheticMap({});
  SaveMap(map, dir);
  WriteFile(dir + "/manifest.yaml", "format: [");
  CHECK_THROWS_AS(LoadMap(dir), InputError);
  CHECK(SaveMap(map, dir).generation == 2);
  RequireMapsEqual(map, LoadMap(dir));
}

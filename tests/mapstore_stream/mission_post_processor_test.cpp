// End-of-run processing in vilma-mapstored: every map folder without a marker is processed once
// by a child; markers say done / failed; an interrupted job runs again; a timeout stops it; the
// real console script turns a raw mission into a processed map and leaves the raw one alone.
#include <catch2/catch.hpp>

#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "mapstore/synthetic_map.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/stream/mission_post_processor.h"

namespace vilma::mapstore {
namespace {

namespace fs = std::filesystem;

std::string Fresh(const std::string& name) {
  const std::string dir = std::string(VILMA_BINARY_DIR) + "/test-cache/post_processor/" + name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A map folder with just a manifest (the fake program does not read it).
void FakeMapFolder(const std::string& dir) {
  fs::create_directories(dir);
  std::ofstream(dir + "/manifest.yaml") << "format: vilma-vi-map\n";
}

// A stand-in for `vilma`: records its arguments, then behaves as $MODE says.
std::string FakeProgram(const std::string& dir, const std::string& body) {
  const std::string path = dir + "/fake-vilma.sh";
  std::ofstream(path) << "#!/bin/sh\necho \"$@\" >> " << dir << "/calls.txt\n" << body << "\n";
  ::chmod(path.c_str(), 0755);
  return path;
}

std::string Read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Polls until nothing runs or is queued (at most `seconds`).
void RunAll(MissionPostProcessor* p, double seconds = 30.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  do {
    p->Poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  } while ((p->counters().running + p->counters().queued) > 0 &&
           std::chrono::steady_clock::now() < end);
}

TEST_CASE("post-processing: each unmarked map folder once, markers for ok and failed") {
  const std::string root = Fresh("markers");
  FakeMapFolder(root + "/a");
  FakeMapFolder(root + "/b");
  FakeMapFolder(root + "/a.processed");  // an output folder is never an input
  fs::create_directories(root + "/not_a_map");
  std::ofstream(root + "/script.vilma") << "load ${map}\n";
  PostProcessOptions o;
  o.script = root + "/script.vilma";
  // Fails for map b.
  o.vilma_program = FakeProgram(root, "case \"$*\" in *name=b*) exit 3;; esac\nexit 0");
  std::vector<std::string> log;
  MissionPostProcessor p(root, o, [&](const std::string& line) { log.push_back(line); });
  p.Scan();
  CHECK(p.counters().queued == 2);
  RunAll(&p);
  CHECK(p.counters().succeeded == 1);
  CHECK(p.counters().failed == 1);
  CHECK(fs::exists(root + "/a.processed.done"));
  CHECK_THAT(Read(root + "/b.processed.failed"), Catch::StartsWith("exit 3"));
  CHECK_THAT(Read(root + "/calls.txt"),
             Catch::Contains("console --script " + o.script + " --var map=" + root +
                             "/a --var out=" + root + "/a.processed --var name=a"));
  p.Scan();  // both marked now
  CHECK(p.counters().queued == 0);
}

TEST_CASE("post-processing: a stopped job has no marker and runs again, a timeout fails it") {
  const std::string root = Fresh("stop");
  FakeMapFolder(root + "/m");
  std::ofstream(root + "/script.vilma") << "load ${map}\n";
  PostProcessOptions o;
  o.script = root + "/script.vilma";
  o.vilma_program = FakeProgram(root, "sleep 30");
  {
    MissionPostProcessor p(root, o, [](const std::string&) {});
    p.Scan();
    p.Poll();
    CHECK(p.counters().running == 1);
    p.Stop();  // as at SIGTERM of mapstored
  }
  CHECK_FALSE(fs::exists(root + "/m.processed.done"));
  CHECK_FALSE(fs::exists(root + "/m.processed.failed"));
  o.timeout_s = 0.3;
  MissionPostProcessor again(root, o, [](const std::string&) {});
  again.Scan();
  CHECK(again.counters().queued == 1);
  RunAll(&again, 20.0);
  CHECK_THAT(Read(root + "/m.processed.failed"), Catch::StartsWith("timeout"));
}

TEST_CASE("post-processing options: a missing script or program is refused") {
  PostProcessOptions o;
  CHECK(o.Validate().empty());  // off
  o.script = "/nonexistent/script.vilma";
  CHECK_THAT(o.Validate(), Catch::StartsWith("script:"));
  CHECK_THROWS_AS(MissionPostProcessor("/tmp", o, [](const std::string&) {}),
                  std::invalid_argument);
}

TEST_CASE("post-processing with vilma console: the raw mission stays, the processed map loads") {
  const std::string vilma = std::string(VILMA_BINARY_DIR) + "/bin/vilma";
  REQUIRE(fs::exists(vilma));
  const std::string root = Fresh("real");
  testing::SyntheticMapOptions so;
  so.missions = 1;
  so.cross_mission = false;
  const VIMap raw = testing::MakeSyntheticMap(so);
  SaveMap(raw, root + "/mission0");
  const std::string raw_manifest = Read(root + "/mission0/manifest.yaml");
  std::ofstream(root + "/process.vilma")
      << "load ${map}\ncheck_map_consistency\nremove_mission " << raw.mission_ids()[0].Hex()
      << "\ncreate_new_map empty\nselect mission0\nsave --out=${out}\n";
  PostProcessOptions o;
  o.script = root + "/process.vilma";
  o.vilma_program = vilma;
  MissionPostProcessor p(root, o, [](const std::string&) {});
  p.Scan();
  RunAll(&p, 60.0);
  INFO(Read(root + "/mission0.processed.log"));
  REQUIRE(p.counters().succeeded == 1);
  CHECK(Read(root + "/mission0/manifest.yaml") == raw_manifest);  // untouched
  const VIMap processed = LoadMap(root + "/mission0.processed");
  CHECK(processed.mission_ids().empty());  // what the script did
  CHECK(LoadMap(root + "/mission0").num_vertices() == raw.num_vertices());
}

}  // namespace
}  // namespace vilma::mapstore

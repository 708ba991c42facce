// vilma-mapstored and vilma-mission-sender as real processes on LCM loopback (ttl=0, a port
// per test): kill -9 of either side in mid-mission (architecture.md section 9).
#include <catch2/catch.hpp>
#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <map>
#include <string>
#include <thread>

#include <vilma/status_t.hpp>

#include "integration/process_util.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/stream/synthetic_mission.h"
#include "test_skip.h"

using namespace vilma::test;
using namespace vilma::mapstore;

namespace {

const std::string kMapstored = std::string(VILMA_BINARY_DIR) + "/bin/vilma-mapstored";
const std::string kSender = std::string(VILMA_BINARY_DIR) + "/bin/vilma-mission-sender";

bool HaveBinaries() {
  if (HaveProgram(kMapstored) && HaveProgram(kSender)) return true;
  VILMA_SKIP_NOTE("build vilma-mapstored and vilma-mission-sender first");
  return false;
}

std::string FreshDir(const std::string& name) {
  const std::string dir = ScratchDir() + "/" + name;
  REQUIRE(std::system(("rm -rf '" + dir + "'").c_str()) == 0);
  ::mkdir(dir.c_str(), 0755);
  return dir;
}

// Highest "acked N" the sender printed (-1 if none).
long long LastAck(const std::string& output) {
  long long last = -1;
  std::size_t pos = 0;
  while ((pos = output.find("acked ", pos)) != std::string::npos) {
    pos += 6;
    last = std::max(last, std::atoll(output.c_str() + pos));
  }
  return last;
}

bool WaitForAck(const std::string& path, long long seq, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (LastAck(ReadTextFile(path)) >= seq) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

}  // namespace

TEST_CASE("kill -9 of mapstored in mid-mission: restart, retransmission, every vertex stored",
          "[integration][mapstore_stream]") {
  if (!HaveBinaries()) return;
  const std::string dir = FreshDir("mapstored_kill");
  const std::string root = dir + "/maps";
  const std::string url = UniqueLcmUrl(false);
  SyntheticMissionOptions mo;
  mo.name = "killed_store";
  mo.seed = 5;
  mo.vertices = 60;
  mo.keypoints_per_frame = 50;
  ChildProcess store1({kMapstored, "--root", root, "--lcm-url", url}, dir + "/mapstored1.log");
  REQUIRE(WaitForOutput(dir + "/mapstored1.log", "ready", 5.0));
  ChildProcess sender({kSender, "--lcm-url", url, "--name", mo.name, "--seed", "5", "--vertices", "60",
                       "--keypoints", "50", "--rate", "40", "--max-retransmit-timeout", "0.3",
                       "--end-timeout", "20"},
                      dir + "/sender.log");
  REQUIRE(WaitForAck(dir + "/sender.log", 10, 10.0));
  store1.Signal(SIGKILL);
  CHECK(store1.Wait(5.0) == 128 + SIGKILL);
  const long long acked_before = LastAck(ReadTextFile(dir + "/sender.log"));
  CHECK(acked_before < 60);  // mid-mission
  std::this_thread::sleep_for(std::chrono::milliseconds(400));  // the sender keeps sending
  ChildProcess store({kMapstored, "--root", root, "--lcm-url", url}, dir + "/mapstored2.log");
  const int sender_status = sender.Wait(25.0);
  INFO(ReadTextFile(dir + "/sender.log") << ReadTextFile(dir + "/mapstored2.log"));
  REQUIRE(sender_status == 0);
  CHECK(ReadTextFile(dir + "/mapstored2.log").find("recovered mission") != std::string::npos);
  store.Signal(SIGTERM);
  CHECK(store.Wait(5.0) == 0);

  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const VIMap expected = ApplyDeltas(deltas);
  const VIMap stored = LoadMap(root + "/" + mo.name);
  const MissionId id = deltas[0].mission.id;
  CHECK(stored.mission(id).complete);
  REQUIRE(stored.vertex_ids(id) == expected.vertex_ids(id));
  CHECK(stored.edge_ids(id) == expected.edge_ids(id));
  CHECK(stored.landmark_ids(id) == expected.landmark_ids(id));
  for (const VertexId& v : expected.vertex_ids(id)) {
    CHECK(stored.vertex(v).t_ns == expected.vertex(v).t_ns);
    CHECK(stored.vertex(v).frames[0].descriptors == expected.vertex(v).frames[0].descriptors);
  }
}

TEST_CASE("kill -9 of the sender: mapstored finalizes an incomplete mission that loads",
          "[integration][mapstore_stream]") {
  if (!HaveBinaries()) return;
  const std::string dir = FreshDir("sender_kill");
  const std::string root = dir + "/maps";
  const std::string url = UniqueLcmUrl(false);
  {
    std::ofstream config(dir + "/mapstored.yaml");
    config << "incomplete_timeout_s: 1.0\n";
  }
  ChildProcess store({kMapstored, "--root", root, "--lcm-url", url, "--config", dir + "/mapstored.yaml"},
                     dir + "/mapstored.log");
  REQUIRE(WaitForOutput(dir + "/mapstored.log", "ready", 5.0));
  SyntheticMissionOptions mo;
  mo.name = "killed_sender";
  mo.seed = 6;
  mo.vertices = 100;
  mo.keypoints_per_frame = 30;
  long long acked = -1;
  {
    ChildProcess sender({kSender, "--lcm-url", url, "--name", mo.name, "--seed", "6", "--vertices", "100",
                         "--keypoints", "30", "--rate", "50", "--no-end"},
                        dir + "/sender.log");
    REQUIRE(WaitForAck(dir + "/sender.log", 5, 10.0));
    sender.Signal(SIGKILL);
    sender.Wait(5.0);
    acked = LastAck(ReadTextFile(dir + "/sender.log"));
  }
  REQUIRE(WaitForOutput(dir + "/mapstored.log", "finalized as incomplete", 10.0));
  store.Signal(SIGTERM);
  CHECK(store.Wait(5.0) == 0);

  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  const VIMap stored = LoadMap(root + "/" + mo.name);
  CHECK_FALSE(stored.mission(id).complete);
  // Every acknowledged chunk (one vertex each) is there, in order: a prefix of the mission.
  const auto& vertices = stored.vertex_ids(id);
  REQUIRE(static_cast<long long>(vertices.size()) >= acked + 1);
  REQUIRE(vertices.size() < deltas.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) CHECK(vertices[i] == deltas[i].vertices[0].id);
}

TEST_CASE("vilma-mapstored rejects bad arguments and prints help", "[integration][mapstore_stream]") {
  if (!HaveBinaries()) return;
  const std::string dir = FreshDir("mapstored_args");
  ChildProcess help({kMapstored, "--help"}, dir + "/help.log");
  CHECK(help.Wait(5.0) == 0);
  CHECK(ReadTextFile(dir + "/help.log").find("--root DIR") != std::string::npos);
  ChildProcess no_root({kMapstored}, dir + "/noroot.log");
  CHECK(no_root.Wait(5.0) == 2);
  CHECK(ReadTextFile(dir + "/noroot.log").find("--root DIR is required") != std::string::npos);
  {
    std::ofstream config(dir + "/bad.yaml");
    config << "incomplete_timeout_s: 1\nunknown_key: 3\n";
  }
  ChildProcess bad_config({kMapstored, "--root", dir + "/m", "--config", dir + "/bad.yaml"}, dir + "/bad.log");
  CHECK(bad_config.Wait(5.0) == 2);
  CHECK(ReadTextFile(dir + "/bad.log").find("unknown_key") != std::string::npos);
}

TEST_CASE("mapstored post-processes a finished mission with a console script",
          "[integration][mapstore_stream]") {
  if (!HaveBinaries()) return;
  const std::string dir = FreshDir("mapstored_post_process");
  const std::string root = dir + "/maps";
  const std::string url = UniqueLcmUrl(false);
  // The synthetic mission is random data (no geometry for lc or optvi): a script that loads,
  // checks and saves it tests the mechanism; config/postprocess.vilma on a real mission is
  // tested in estimatord_mapping_test.cpp.
  std::ofstream(dir + "/check.vilma") << "load ${map} --map_key=mission\nmap_stats\n"
                                         "check_map_consistency\nsave --out=${out} --overwrite\n";
  const std::string config = dir + "/mapstored.yaml";
  std::ofstream(config) << "post_process_script: check.vilma\n";
  ChildProcess store({kMapstored, "--root", root, "--lcm-url", url, "--config", config},
                     dir + "/mapstored.log");
  REQUIRE(WaitForOutput(dir + "/mapstored.log", "ready", 5.0));
  ChildProcess sender({kSender, "--lcm-url", url, "--name", "processed_run", "--seed", "9",
                       "--vertices", "30", "--keypoints", "40", "--rate", "200",
                       "--end-timeout", "20"},
                      dir + "/sender.log");
  REQUIRE(sender.Wait(30.0) == 0);
  REQUIRE(WaitForOutput(dir + "/mapstored.log", "post-processing processed_run: ok", 30.0));
  const VIMap raw = LoadMap(root + "/processed_run");
  const VIMap processed = LoadMap(root + "/processed_run.processed");
  CHECK(processed.num_vertices() == raw.num_vertices());
  CHECK(ReadTextFile(root + "/processed_run.processed.log").find("> check_map_consistency") !=
        std::string::npos);
  CHECK(ReadTextFile(root + "/processed_run.processed.done").rfind("exit 0", 0) == 0);
  store.Signal(SIGTERM);
  CHECK(store.Wait(10.0) == 0);
}

TEST_CASE("vilma-mapstored's VILMA_STATUS carries its heap (mallinfo2) as metrics",
          "[integration][mapstore_stream]") {
  if (!HaveBinaries()) return;
  const std::string dir = FreshDir("mapstored_heap_status");
  const std::string url = UniqueLcmUrl(false);
  lcm::LCM lcm(url);
  REQUIRE(lcm.good());
  std::map<std::string, double> metrics;
  bool have_status = false;
  lcm.subscribeFunction(
      "VILMA_STATUS",
      +[](const lcm::ReceiveBuffer*, const std::string&, const vilma::status_t* s,
          std::pair<bool*, std::map<std::string, double>*> out) {
        if (s->node != "vilma-mapstored") return;
        *out.first = true;
        for (int i = 0; i < s->num_metrics; ++i) (*out.second)[s->metric_names[i]] = s->metric_values[i];
      },
      std::make_pair(&have_status, &metrics));
  ChildProcess store({kMapstored, "--root", dir + "/maps", "--lcm-url", url}, dir + "/mapstored.log");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!have_status && std::chrono::steady_clock::now() < deadline) lcm.handleTimeout(100);
  store.Signal(SIGTERM);
  CHECK(store.Wait(5.0) == 0);
  REQUIRE(have_status);
  REQUIRE(metrics.count("heap_in_use_mb") == 1);
  REQUIRE(metrics.count("heap_free_mb") == 1);
  REQUIRE(metrics.count("heap_mmapped_mb") == 1);
  // An idle mapstored holds well under 100 MB of heap, and not nothing (its server, liblcm).
  CHECK(metrics["heap_in_use_mb"] > 0.01);
  CHECK(metrics["heap_in_use_mb"] < 100.0);
  CHECK(metrics["heap_free_mb"] >= 0.0);
  CHECK(metrics["heap_mmapped_mb"] >= 0.0);
  CHECK(metrics["heap_mmapped_mb"] <= metrics["heap_in_use_mb"]);
}

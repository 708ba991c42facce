// Shared set-up of the mission stream server tests (map_store_server_test.cpp,
// map_store_server_recovery_test.cpp): a fresh store root per test, a sender that retransmits
// fast, and the map a delta sequence should give.
#pragma once

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "vilma/mapstore/stream/mission_stream_sender.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

namespace vilma::mapstore::server_test {

inline std::string FreshRoot(const std::string& name) {
  const std::string dir = "/tmp/vilma_mapstore_server_test_" + std::to_string(::getpid());
  ::mkdir(dir.c_str(), 0755);
  const std::string root = dir + "/" + name;
  REQUIRE(std::system(("rm -rf '" + root + "'").c_str()) == 0);
  return root;
}

inline MissionStreamSenderOptions FastSender() {
  MissionStreamSenderOptions o;
  o.retransmit_timeout_s = 0.002;
  o.max_retransmit_timeout_s = 0.01;
  o.max_in_flight_chunks = 16;
  return o;
}

inline VIMap Expected(const std::vector<MissionDelta>& deltas, bool complete) {
  VIMap map = ApplyDeltas(deltas);
  map.mission(deltas[0].mission.id).complete = complete;
  return map;
}

}  // namespace vilma::mapstore::server_test

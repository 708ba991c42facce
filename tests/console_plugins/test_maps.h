// Small real maps for the console tests: two 10 s sessions of the simulated room, each mapped by
// vilma-estimatord (make_test_maps.sh). Made once per build and shared by every test process
// (catch_discover_tests runs each test case in its own process): a lock file serializes the
// making, a `done` file marks a complete set, and the set is remade when vilma-sim,
// vilma-replay or vilma-estimatord changed since it was made.
#pragma once

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include <catch2/catch.hpp>
#include <stdexcept>
#include <string>

#include "integration/process_util.h"
#include "vilma/console/session.h"

namespace vilma::test {

struct ConsoleTestMaps {
  std::string root;
  std::string maps_folder;  // holds session0/ and session1/
  std::string session0_map, session1_map;
  std::string session0_dataset, session1_dataset;  // ASL with ground truth
  // Another rig: session 2 revisits session 0's path with a stereo camera pair (sessions 0 and
  // 1 are mono); its own folder, so that maps_folder keeps two missions.
  std::string stereo_map, stereo_dataset;
};

inline std::string BinDir() { return std::string(VILMA_BINARY_DIR) + "/bin"; }

// Seconds of the last change of the programs, script and configs that make the maps.
inline std::string ProgramStamp() {
  std::ostringstream stamp;
  for (const char* name : {"vilma-sim", "vilma-replay", "vilma-estimatord"}) {
    struct stat info {};
    const std::string path = BinDir() + "/" + name;
    if (::stat(path.c_str(), &info) != 0) throw std::runtime_error(path + " is not built");
    stamp << name << " " << info.st_mtime << "\n";
  }
  // ... and of what decides the maps' content besides the programs.
  for (const char* file : {"tests/console_plugins/make_test_maps.sh", "config/map_builder.yaml",
                           "config/daemon.yaml"}) {
    struct stat info {};
    const std::string path = std::string(VILMA_SOURCE_DIR) + "/" + file;
    if (::stat(path.c_str(), &info) == 0) stamp << file << " " << info.st_mtime << "\n";
  }
  return stamp.str();
}

inline const ConsoleTestMaps& TestMaps() {
  static const ConsoleTestMaps maps = [] {
    ConsoleTestMaps m;
    m.root = std::string(VILMA_BINARY_DIR) + "/test-cache/console-maps";
    m.maps_folder = m.root + "/maps";
    m.session0_map = m.maps_folder + "/session0";
    m.session1_map = m.maps_folder + "/session1";
    m.session0_dataset = m.root + "/datasets/session0";
    m.session1_dataset = m.root + "/datasets/session1";
    m.stereo_map = m.root + "/maps-stereo/session2";
    m.stereo_dataset = m.root + "/datasets/session2";
    ::mkdir((std::string(VILMA_BINARY_DIR) + "/test-cache").c_str(), 0755);
    const std::string lock_path = std::string(VILMA_BINARY_DIR) + "/test-cache/console-maps.lock";
    const int lock = ::open(lock_path.c_str(), O_CREAT | O_RDWR, 0644);
    if (lock < 0 || ::flock(lock, LOCK_EX) != 0) throw std::runtime_error("cannot lock " + lock_path);
    const std::string stamp = ProgramStamp();
    const bool fresh = FileExists(m.root + "/done") && ReadTextFile(m.root + "/stamp") == stamp;
    if (!fresh) {
      ChildProcess make({std::string(VILMA_SOURCE_DIR) + "/tests/console_plugins/make_test_maps.sh",
                         BinDir(), m.root},
                        std::string(VILMA_BINARY_DIR) + "/test-cache/console-maps.out");
      if (make.Wait(300.0) != 0) {
        ::close(lock);
        throw std::runtime_error("make_test_maps.sh failed: see " + std::string(VILMA_BINARY_DIR) +
                                 "/test-cache/console-maps.out");
      }
      std::ofstream(m.root + "/stamp") << stamp;
    }
    ::close(lock);
    return m;
  }();
  return maps;
}

// A console session with every plugin's commands; Run() executes one command line and, on
// failure, shows the line and the session's stderr in the test report.
struct ConsoleFixture {
  std::ostringstream out, err;
  console::ConsoleSession session{console::CommandRegistry::WithPlugins(), out, err};
  console::CommandResult Run(const std::string& line) {
    const console::CommandResult r = session.Execute(line);
    INFO(line << "\n" << err.str());
    return r;
  }
  const mapstore::VIMap& map() { return *session.maps().Get(session.maps().selected()).map; }
};

// A fresh empty scratch folder for one test.
inline std::string ConsoleScratch(const std::string& name) {
  const std::string dir = std::string(VILMA_BINARY_DIR) + "/test-cache/scratch/" + name;
  ChildProcess rm({"/bin/rm", "-rf", dir}, "/dev/null");
  rm.Wait(30.0);
  ChildProcess mk({"/bin/mkdir", "-p", dir}, "/dev/null");
  mk.Wait(30.0);
  return dir;
}

}  // namespace vilma::test

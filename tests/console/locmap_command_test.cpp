#include "vilma/console/locmap_command.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "mapstore/synthetic_map.h"
#include "vilma/mapping/locmap/localization_map_builder.h"
#include "vilma/localizer/localizer.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;

// A fresh scratch folder per test case, removed at the end.
struct Scratch {
  fs::path dir;
  explicit Scratch(const std::string& name) {
    dir = fs::temp_directory_path() / ("vilma_locmap_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~Scratch() { fs::remove_all(dir); }
  std::string operator/(const std::string& name) const { return (dir / name).string(); }
};

// A small VI-map folder: 2 missions, a third of the landmarks good, 3 observations each.
mapstore::VIMap SaveSyntheticMap(const std::string& folder) {
  mapstore::testing::SyntheticMapOptions o;
  o.vertices_per_mission = 20;
  o.landmarks_per_vertex = 6;
  mapstore::VIMap map = mapstore::testing::MakeSyntheticMap(o);
  mapstore::SaveMap(map, folder);
  return map;
}

int Run(const std::vector<std::string>& args, std::string* out_text, std::string* err_text) {
  std::ostringstream out, err;
  const int code = RunLocmapCommand(args, out, err);
  if (out_text != nullptr) *out_text = out.str();
  if (err_text != nullptr) *err_text = err.str();
  return code;
}

TEST_CASE("vilma locmap: help and usage errors") {
  std::string out, err;
  CHECK(Run({"--help"}, &out, &err) == kExitOk);
  CHECK_THAT(out, Catch::Contains("vilma locmap build VIMAP_DIR OUT.vlocmap"));
  CHECK(Run({"build", "--help"}, &out, &err) == kExitOk);
  CHECK(Run({}, &out, &err) == kExitUsage);
  CHECK_THAT(err, Catch::Contains("'build' or 'info'"));
  CHECK(Run({"convert", "x"}, &out, &err) == kExitUsage);
  CHECK_THAT(err, Catch::Contains("unknown verb 'convert'"));
  CHECK(Run({"build", "dir"}, &out, &err) == kExitUsage);
  CHECK_THAT(err, Catch::Contains("OUT.vlocmap"));
  CHECK(Run({"build", "dir", "out", "--projection", "8"}, &out, &err) == kExitUsage);
  CHECK_THAT(err, Catch::Contains("unknown option '--projection'"));
  CHECK(Run({"build", "dir", "out", "--config"}, &out, &err) == kExitUsage);
  CHECK(Run({"info"}, &out, &err) == kExitUsage);
  CHECK(Run({"info", "a", "b"}, &out, &err) == kExitUsage);
}

TEST_CASE("vilma locmap: build stores the Localizer's projection, info reads it back") {
  const Scratch s("roundtrip");
  const mapstore::VIMap vimap = SaveSyntheticMap(s / "vimap");
  const localizer::LocalizationMap expected = mapping::BuildLocalizationMap(vimap);
  REQUIRE(expected.num_landmarks() > 20);

  std::string out, err;
  REQUIRE(Run({"build", s / "vimap", s / "map.vlocmap"}, &out, &err) == kExitOk);
  INFO(out << err);
  CHECK_THAT(out, Catch::Contains("2 missions"));
  CHECK_THAT(out, Catch::Contains("landmarks        " + std::to_string(expected.num_landmarks())));
  CHECK_THAT(out, Catch::Contains("projection       16 x 512 (stored"));
  CHECK(err.empty());

  const localizer::LocalizationMap loaded = localizer::LoadLocalizationMap(s / "map.vlocmap");
  CHECK(loaded.num_landmarks() == expected.num_landmarks());
  CHECK(loaded.num_descriptors() == expected.num_descriptors());
  CHECK(loaded.descriptors == expected.descriptors);
  // The stored projection is exactly what the Localizer trains at load from the same map.
  const localizer::Localizer trained(std::make_shared<localizer::LocalizationMap>(expected),
                                     localizer::LocalizerOptions());
  REQUIRE(loaded.projection.rows() == 16);
  CHECK(loaded.projection == trained.projection());
  // No temporary file left beside the output.
  int files = 0;
  for (const auto& e : fs::directory_iterator(s.dir)) files += e.is_regular_file() ? 1 : 0;
  CHECK(files == 1);

  REQUIRE(Run({"info", s / "map.vlocmap"}, &out, &err) == kExitOk);
  CHECK_THAT(out, Catch::Contains("landmarks        " + std::to_string(expected.num_landmarks())));
  CHECK_THAT(out,
             Catch::Contains("descriptors      " + std::to_string(expected.num_descriptors())));
  CHECK_THAT(out, Catch::Contains("projection       stored, 16 x 512"));
  CHECK_THAT(out, Catch::Contains("p_G bounding box"));
  CHECK_THAT(out, Catch::Contains("bytes)"));

  // A file without projection says so.
  localizer::SaveLocalizationMap(expected, s / "plain.vlocmap");
  REQUIRE(Run({"info", s / "plain.vlocmap"}, &out, &err) == kExitOk);
  CHECK_THAT(out, Catch::Contains("projection       none"));
}

TEST_CASE("vilma locmap build: --config sections map and projection apply") {
  const Scratch s("config");
  SaveSyntheticMap(s / "vimap");
  {
    std::ofstream f(s / "loc.yaml");
    f << "map:\n  max_descriptors_per_landmark: 2\nprojection:\n  dimensions: 8\n";
  }
  std::string out, err;
  REQUIRE(Run({"build", s / "vimap", s / "map.vlocmap", "--config", s / "loc.yaml"}, &out, &err) ==
          kExitOk);
  const localizer::LocalizationMap loaded = localizer::LoadLocalizationMap(s / "map.vlocmap");
  CHECK(loaded.projection.rows() == 8);
  CHECK(loaded.num_descriptors() == 2 * loaded.num_landmarks());

  // A bad option names the file and key, and nothing is written.
  {
    std::ofstream f(s / "bad.yaml");
    f << "projection:\n  dimensionz: 8\n";
  }
  CHECK(Run({"build", s / "vimap", s / "bad.vlocmap", "--config", s / "bad.yaml"}, &out, &err) ==
        kExitInputError);
  CHECK_THAT(err, Catch::Contains("bad.yaml") && Catch::Contains("dimensionz"));
  CHECK_FALSE(fs::exists(s / "bad.vlocmap"));
}

TEST_CASE("vilma locmap: bad inputs exit 1 and name the file") {
  const Scratch s("bad");
  std::string out, err;
  // Missing folder.
  CHECK(Run({"build", s / "nope", s / "out.vlocmap"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(s / "nope"));
  CHECK_FALSE(fs::exists(s / "out.vlocmap"));
  // A folder that is not a map.
  fs::create_directories(s / "empty");
  CHECK(Run({"build", s / "empty", s / "out.vlocmap"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(s / "empty"));
  CHECK_FALSE(fs::exists(s / "out.vlocmap"));
  // A file given as VIMAP_DIR.
  { std::ofstream(s / "file.txt") << "x"; }
  CHECK(Run({"build", s / "file.txt", s / "out.vlocmap"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains("not a file"));
  // A map without good landmarks.
  {
    mapstore::testing::SyntheticMapOptions o;
    o.missions = 1;
    o.observations_per_landmark = 1;  // below min_observations
    mapstore::SaveMap(mapstore::testing::MakeSyntheticMap(o), s / "weak");
  }
  CHECK(Run({"build", s / "weak", s / "out.vlocmap"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(s / "weak") && Catch::Contains("landmarks"));

  // info: missing, garbage, truncated, a folder.
  CHECK(Run({"info", s / "missing.vlocmap"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(s / "missing.vlocmap"));
  { std::ofstream(s / "garbage.vlocmap") << "not a localization map at all"; }
  CHECK(Run({"info", s / "garbage.vlocmap"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(s / "garbage.vlocmap") && Catch::Contains("magic"));
  SaveSyntheticMap(s / "vimap");
  REQUIRE(Run({"build", s / "vimap", s / "good.vlocmap"}, &out, &err) == kExitOk);
  fs::resize_file(s / "good.vlocmap", fs::file_size(s / "good.vlocmap") / 2);
  CHECK(Run({"info", s / "good.vlocmap"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(s / "good.vlocmap"));
  CHECK(Run({"info", s / "vimap"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains("locmap build"));
}

}  // namespace
}  // namespace vilma::console

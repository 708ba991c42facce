// vilma-mapstored's --config: strict reading, validation, and a writer that round-trips.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <string>

#include "vilma/core/error.h"
#include "vilma/mapstore/stream/mapstored_config.h"

using namespace vilma;
using namespace vilma::mapstore;

namespace {
MapstoredConfig Parse(const std::string& text, const std::string& file = "/cfg/mapstored.yaml") {
  return ReadMapstoredConfig(YamlNode::LoadString(text, file));
}
}  // namespace

TEST_CASE("mapstored config: defaults, round trip, and the shipped file", "[mapstore][options]") {
  const MapstoredConfig defaults = Parse("{}");
  CHECK(defaults.incomplete_timeout_s == 0.0);
  CHECK(defaults.max_reorder_mib == 256);
  CHECK(defaults.ServerOptions("/r").max_reorder_bytes == std::size_t{256} << 20);
  CHECK(defaults.PostProcess("/usr/bin/vilma").vilma_program == "/usr/bin/vilma");
  CHECK(MapstoredConfigToYaml(Parse(MapstoredConfigToYaml(defaults))) ==
        MapstoredConfigToYaml(defaults));

  // Every field changed from its default survives the writer and the reader.
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "vilma_mapstored_config_test";
  std::filesystem::create_directories(dir);
  const std::string script = (dir / "post.vilma").string();
  std::ofstream(script) << "load_all\n";
  MapstoredConfig changed;
  changed.incomplete_timeout_s = 2.5;
  changed.finalize_incomplete_at_shutdown = true;
  changed.max_reorder_chunks = 77;
  changed.max_reorder_mib = 128;
  changed.max_ack_batch = 9;
  changed.post_process_script = script;  // absolute: kept as written
  changed.post_process_timeout_s = 0.1 + 0.2;
  changed.vilma_program = "/opt/vilma/bin/vilma";
  const std::string yaml = MapstoredConfigToYaml(changed);
  const MapstoredConfig back = Parse(yaml, (dir / "m.yaml").string());
  CHECK(MapstoredConfigToYaml(back) == yaml);
  CHECK(back.finalize_incomplete_at_shutdown);
  CHECK(back.max_reorder_chunks == 77);
  CHECK(back.post_process_timeout_s == changed.post_process_timeout_s);
  CHECK(back.ServerOptions("/r").max_reorder_bytes == std::size_t{128} << 20);
  CHECK(back.ServerOptions("/r").incomplete_timeout_s == 2.5);

  // A relative script is relative to the config file's folder.
  const MapstoredConfig relative =
      Parse("post_process_script: post.vilma\n", (dir / "m.yaml").string());
  CHECK(relative.post_process_script == script);
  std::filesystem::remove_all(dir);

  const MapstoredConfig shipped =
      LoadMapstoredConfig(std::string(VILMA_SOURCE_DIR) + "/config/mapstored.yaml");
  CHECK(MapstoredConfigToYaml(Parse(MapstoredConfigToYaml(shipped))) ==
        MapstoredConfigToYaml(shipped));
}

TEST_CASE("mapstored config: unknown keys and bad values name file and key",
          "[mapstore][options]") {
  CHECK_THROWS_WITH(Parse("incomplete_timeout: 1\n"),
                    Catch::Contains("mapstored.yaml") && Catch::Contains("incomplete_timeout") &&
                        Catch::Contains("incomplete_timeout_s"));
  CHECK_THROWS_WITH(Parse("max_reorder_mib: 8\n"),
                    Catch::Contains("mapstored.yaml") && Catch::Contains("max_reorder_mib"));
  CHECK_THROWS_WITH(Parse("max_ack_batch: 0\n"), Catch::Contains("max_ack_batch"));
  CHECK_THROWS_WITH(Parse("incomplete_timeout_s: -1\n"), Catch::Contains("incomplete_timeout_s"));
  CHECK_THROWS_WITH(Parse("max_reorder_chunks: lots\n"), Catch::Contains("max_reorder_chunks"));
  CHECK_THROWS_WITH(Parse("post_process_script: /nonexistent/x.vilma\n"),
                    Catch::Contains("post_process_script"));
  CHECK_THROWS_WITH(Parse("post_process_timeout_s: 0\n"),
                    Catch::Contains("post_process_timeout_s"));
  CHECK_THROWS_AS(Parse("- 1\n"), InputError);
}

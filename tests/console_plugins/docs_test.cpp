// docs/console.md documents every registered command (it fails when a new command is not
// described there) and README.md names the console.
#include <catch2/catch.hpp>

#include <sstream>

#include "integration/process_util.h"
#include "vilma/console/session.h"

namespace vilma::console {
namespace {

TEST_CASE("docs/console.md names every console command and alias") {
  const std::string doc = test::ReadTextFile(std::string(VILMA_SOURCE_DIR) + "/docs/console.md");
  std::ostringstream out, err;
  ConsoleSession session(CommandRegistry::WithPlugins(), out, err);
  for (const CommandSpec* command : session.registry().All()) {
    INFO("command " << command->name);
    CHECK(doc.find("`" + command->name) != std::string::npos);
    for (const std::string& alias : command->aliases) {
      INFO("alias " << alias);
      CHECK(doc.find("`" + alias + "`") != std::string::npos);
    }
  }
  const std::string readme = test::ReadTextFile(std::string(VILMA_SOURCE_DIR) + "/README.md");
  CHECK(readme.find("vilma console") != std::string::npos);
}

}  // namespace
}  // namespace vilma::console

// Test names must survive ctest's registration: catch_discover_tests hands each name through a
// CMake list, where ';' separates elements, so a name with ';' became two filters that matched
// no test and passed without running anything (44 tests, found 2026-11-26). This scans every
// TEST_CASE under tests/ at the source.
#include <catch2/catch.hpp>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

// The concatenated string literals that follow `at` (whitespace between them skipped); `end`
// is set after the last one.
std::string ReadLiterals(const std::string& text, std::size_t at, std::size_t* end) {
  std::string value;
  std::size_t i = at;
  while (true) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (i >= text.size() || text[i] != '"') break;
    for (++i; i < text.size() && text[i] != '"'; ++i) {
      if (text[i] == '\\' && i + 1 < text.size()) ++i;
      value += text[i];
    }
    ++i;  // closing quote
  }
  *end = i;
  return value;
}

}  // namespace

TEST_CASE("no test name holds a semicolon (ctest would split it and run nothing)", "[test_names]") {
  namespace fs = std::filesystem;
  const fs::path root = fs::path(VILMA_SOURCE_DIR) / "tests";
  REQUIRE(fs::is_directory(root));
  // Spelled in two parts, so that this file's own search string is not taken for a test.
  const std::string token = std::string("TEST_") + "CASE(";
  std::vector<std::string> bad;
  int names = 0;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file() || entry.path().extension() != ".cpp") continue;
    std::ifstream in(entry.path());
    std::stringstream buffer;
    buffer << in.rdbuf();
    const std::string text = buffer.str();
    for (std::size_t at = text.find(token); at != std::string::npos; at = text.find(token, at + 1)) {
      std::size_t end = 0;
      const std::string name = ReadLiterals(text, at + token.size(), &end);
      if (name.empty()) continue;  // the macro's own definition or a use in a comment
      ++names;
      if (name.find(';') != std::string::npos) {
        bad.push_back(fs::relative(entry.path(), root).string() + ": \"" + name + "\"");
      }
    }
  }
  INFO("test names with ';':\n" << [&] {
    std::string all;
    for (const std::string& b : bad) all += "  " + b + "\n";
    return all;
  }());
  CHECK(names > 500);  // the scan sees the suite
  CHECK(bad.empty());
}

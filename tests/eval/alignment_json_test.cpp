#include "vilma/eval/alignment_json.h"

#include <catch2/catch.hpp>

#include <string>

#include "vilma/core/error.h"

// The console's test (tests/console/eval_command_test.cpp) covers the messages of every field
// and the common syntax errors; these are the checks nlohmann-json does not make by itself.

namespace vilma {
namespace {

const std::string kTransform =
    R"("alignment_transform": {"scale": 2, "translation_m": [1, 2, 3], )"
    R"("quaternion_wxyz": [0, 0, 0, 1]})";

TEST_CASE("alignment JSON: a good document, keys in any order and extra keys", "[eval]") {
  const Alignment a = ParseAlignmentJson(
      "{" + kTransform + ", \"x\": {\"y\": [1, {\"z\": null}]}, \"schema_version\": 1}", "a.json");
  CHECK(a.type == AlignmentType::kFixed);
  CHECK(a.scale == 2.0);
  CHECK(a.T_G_E.translation() == Eigen::Vector3d(1, 2, 3));
  CHECK(std::abs(a.T_G_E.rotation().z()) == 1.0);
  // schema_version written as 1.0 is the number 1.
  CHECK_NOTHROW(ParseAlignmentJson("{\"schema_version\": 1.0, " + kTransform + "}", "a.json"));
}

TEST_CASE("alignment JSON: duplicate keys are an error at any depth, with their position",
          "[eval]") {
  CHECK_THROWS_WITH(
      ParseAlignmentJson("{\"schema_version\": 1, " + kTransform + ",\n \"o\": {\"k\": 1, \"k\": 2}}",
                         "a.json"),
      "a.json: expected valid JSON: no duplicate key \"k\" at line 2, column 19");
  // The same key in two different objects is fine.
  CHECK_NOTHROW(ParseAlignmentJson(
      "{\"schema_version\": 1, \"a\": {\"k\": 1}, \"b\": {\"k\": 1}, " + kTransform + "}",
      "a.json"));
  // An array of objects: each object has its own keys.
  CHECK_NOTHROW(ParseAlignmentJson(
      "{\"schema_version\": 1, \"a\": [{\"k\": 1}, {\"k\": 1}], " + kTransform + "}", "a.json"));
}

TEST_CASE("alignment JSON: numbers beyond a double are an error at their position", "[eval]") {
  CHECK_THROWS_WITH(ParseAlignmentJson("{\"a\":\n  [1,\n   -1e400]}", "a.json"),
                    "a.json: expected valid JSON: a number in the range of a double at line 3, "
                    "column 4");
  // At the very end of the text (the lexer stops without reading past the number).
  CHECK_THROWS_WITH(ParseAlignmentJson("1e999", "a.json"),
                    "a.json: expected valid JSON: a number in the range of a double at line 1, "
                    "column 1");
}

TEST_CASE("alignment JSON: comments and trailing commas are not JSON", "[eval]") {
  CHECK_THROWS_WITH(
      ParseAlignmentJson("{\"schema_version\": 1, // c\n" + kTransform + "}", "a.json"),
      Catch::StartsWith("a.json: expected valid JSON: ") && Catch::EndsWith("line 1, column 23"));
  CHECK_THROWS_WITH(ParseAlignmentJson("{\"schema_version\": 1, " + kTransform + ",}", "a.json"),
                    Catch::StartsWith("a.json: expected valid JSON: syntax error while parsing "
                                      "object key"));
  CHECK_THROWS_AS(ReadAlignmentJson("/nonexistent/a.json"), InputError);
}

}  // namespace
}  // namespace vilma

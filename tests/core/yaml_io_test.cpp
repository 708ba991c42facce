#include "vilma/core/yaml_io.h"

#include <catch2/catch.hpp>

namespace vilma {
namespace {

TEST_CASE("YamlNode reads typed values and names bad ones", "[yaml]") {
  const YamlNode root = YamlNode::LoadString(
      "a: 1.5\nb: 7\nc: hello\nd: true\nv: [1, 2, 3]\nm: [[1, 0], [0, 1]]\n"
      "section: {x: 2}\nlist: [{k: 1}, {k: 2}]\n",
      "test.yaml");
  CHECK(root.Get<double>("a") == 1.5);
  CHECK(root.Get<int>("b") == 7);
  CHECK(root.Get<int64_t>("b") == 7);
  CHECK(root.Get<std::string>("c") == "hello");
  CHECK(root.Get<bool>("d"));
  CHECK(root.GetOr<double>("missing", 3.0) == 3.0);
  CHECK(root.GetVector("v", 3) == Eigen::Vector3d(1, 2, 3));
  CHECK(root.GetMatrix("m", 2, 2) == Eigen::Matrix2d::Identity());
  CHECK(root.Child("section").Get<int>("x") == 2);
  CHECK(root.Child("list").Elements()[1].Get<int>("k") == 2);

  CHECK_THROWS_WITH(root.Get<int>("a"), Catch::Contains("test.yaml: a: an integer, got '1.5'"));
  CHECK_THROWS_WITH(root.Get<double>("c"), Catch::Contains("test.yaml: c: a number"));
  CHECK_THROWS_WITH(root.Get<double>("nope"), Catch::Contains("nope: a required key"));
  CHECK_THROWS_WITH(root.GetVector("v", 2), Catch::Contains("v: a list of 2 numbers, got 3"));
  CHECK_THROWS_WITH(root.Child("list").Elements()[0].Get<std::string>("j"),
                    Catch::Contains("list[0].j"));
}

TEST_CASE("YamlNode reports unknown keys and keeps line numbers of syntax errors", "[yaml]") {
  const YamlNode root = YamlNode::LoadString("known: 1\nunknwon: 2\n", "opts.yaml");
  CHECK(root.Get<int>("known") == 1);
  CHECK(root.GetOr<int>("absent", 3) == 3);  // asked for, so known, though not in the file
  CHECK_THROWS_WITH(root.CheckNoUnknownKeys(),
                    Catch::Contains("opts.yaml: unknwon: no such key") &&
                        Catch::EndsWith("(unknown key; check spelling; known keys here: absent, known)"));
  CHECK_THROWS_WITH(YamlNode::LoadString("a: 1\nb: [2\n", "bad.yaml"),
                    Catch::Contains("bad.yaml") && Catch::Contains("valid YAML"));
  CHECK_THROWS_WITH(YamlNode::LoadFile("/no/such/file.yaml"),
                    Catch::Contains("/no/such/file.yaml: cannot open"));
}

TEST_CASE("OpenCV-style %YAML:1.0 headers are accepted", "[yaml]") {
  const YamlNode root = YamlNode::LoadString("%YAML:1.0\nrate_hz: 20\n", "sensor.yaml");
  CHECK(root.Get<double>("rate_hz") == 20.0);
}

TEST_CASE("Non-finite numbers are rejected", "[yaml]") {
  const YamlNode root = YamlNode::LoadString("x: .nan\n", "n.yaml");
  CHECK_THROWS_WITH(root.Get<double>("x"), Catch::Contains("finite"));
}

TEST_CASE("MapChild returns a map section and names the key otherwise", "[yaml]") {
  const YamlNode root = YamlNode::LoadString(
      "outer: {inner: {x: 1}, list: [1, 2], scalar: 3}\n", "opts.yaml");
  const YamlNode outer = root.MapChild("outer");
  const YamlNode inner = outer.MapChild("inner");
  CHECK(inner.key_path() == "outer.inner");
  CHECK(inner.Get<int>("x") == 1);
  inner.CheckNoUnknownKeys();
  CHECK_THROWS_AS(outer.MapChild("list"), InputError);
  CHECK_THROWS_WITH(outer.MapChild("list"), "opts.yaml: outer.list: a map");
  // Missing and scalar children keep Child()'s messages.
  CHECK_THROWS_WITH(outer.MapChild("nope"), "opts.yaml: outer.nope: a required section");
  CHECK_THROWS_WITH(outer.MapChild("scalar"),
                    "opts.yaml: outer.scalar: a map or a list, got '3'");
  // MapChild counts as reading the key.
  CHECK_NOTHROW(root.CheckNoUnknownKeys());
}

TEST_CASE("ThrowIfInvalid turns a Validate() message into a located InputError", "[yaml]") {
  CHECK_NOTHROW(ThrowIfInvalid("", "opts.yaml"));
  CHECK_NOTHROW(ThrowIfInvalid("", "opts.yaml", "section"));
  CHECK_THROWS_AS(ThrowIfInvalid("rate_hz: expected > 0", "opts.yaml"), InputError);
  CHECK_THROWS_WITH(ThrowIfInvalid("rate_hz: expected > 0", "opts.yaml"),
                    "opts.yaml: rate_hz: expected > 0");
  CHECK_THROWS_WITH(ThrowIfInvalid("ransac.seed: expected >= 0", "filter options"),
                    "filter options: ransac.seed: expected >= 0");
  CHECK_THROWS_WITH(ThrowIfInvalid("rate_hz: expected > 0", "opts.yaml", "mapping.builder"),
                    "opts.yaml: mapping.builder.rate_hz: expected > 0");
  // The field ends at the first ": ", later ones belong to the expectation.
  CHECK_THROWS_WITH(ThrowIfInvalid("channels.imu: channel 'x' has 'x': expected A-Z", "d.yaml"),
                    "d.yaml: channels.imu: channel 'x' has 'x': expected A-Z");
  // A message without a field is all expectation.
  CHECK_THROWS_WITH(ThrowIfInvalid("no field here", "d.yaml"), "d.yaml: no field here");
  CHECK_THROWS_WITH(ThrowIfInvalid("no field here", "d.yaml", "sec"), "d.yaml: sec: no field here");
}

TEST_CASE("CheckValid names the node's file and key path", "[yaml]") {
  const YamlNode root = YamlNode::LoadString("builder: {features: {a: 1}}\n", "daemon.yaml");
  CHECK_NOTHROW(root.CheckValid(""));
  CHECK_THROWS_WITH(root.CheckValid("rate_hz: expected > 0"),
                    "daemon.yaml: rate_hz: expected > 0");
  const YamlNode features = root.MapChild("builder").MapChild("features");
  CHECK_THROWS_AS(features.CheckValid("detector.fast_threshold: expected > 0"), InputError);
  CHECK_THROWS_WITH(features.CheckValid("detector.fast_threshold: expected > 0"),
                    "daemon.yaml: builder.features.detector.fast_threshold: expected > 0");
}

}  // namespace
}  // namespace vilma

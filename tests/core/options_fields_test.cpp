// core/options_fields.h: one field list gives the strict reader and a writer that round-trips.
#include <catch2/catch.hpp>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"

namespace {

struct Inner {
  double sigma = 0.1;
  int count = 3;
};
struct Example {
  bool enabled = true;
  std::string name = "plain";
  uint64_t seed = 7;
  int64_t offset_ns = -5;
  Inner ransac;
  Inner nested_deep;  // written under "outer.deep"
};

template <typename Options, typename Visitor>
void VisitExample(Options& o, Visitor&& v) {
  v("", "enabled", o.enabled);
  v("", "name", o.name);
  v("", "seed", o.seed);
  v("", "offset_ns", o.offset_ns);
  v("ransac", "sigma", o.ransac.sigma);
  v("ransac", "count", o.ransac.count);
  v("outer.deep", "sigma", o.nested_deep.sigma);
  v("outer.deep", "count", o.nested_deep.count);
}

Example Read(const std::string& text, vilma::MissingKey missing) {
  Example e;
  vilma::ReadOptionFields(vilma::YamlNode::LoadString(text, "example.yaml"), missing, &e,
                          [](auto& o, auto&& v) { VisitExample(o, v); });
  return e;
}

std::string Write(const Example& e) {
  return vilma::OptionFieldsToYaml(e, [](auto& o, auto&& v) { VisitExample(o, v); });
}

}  // namespace

TEST_CASE("options fields: the writer's YAML reads back to equal values", "[core][options]") {
  Example e;
  e.enabled = false;
  e.name = "with \"quotes\", a \\ and: a colon";
  e.seed = std::numeric_limits<uint64_t>::max() / 2;
  e.offset_ns = -1234567890123;
  e.ransac.sigma = 0.1 + 0.2;  // not a short decimal: the shortest round-trip text is needed
  e.ransac.count = -4;
  e.nested_deep.sigma = 1e-300;
  e.nested_deep.count = 42;
  const std::string yaml = Write(e);
  CHECK(yaml ==
        "enabled: false\n"
        "name: \"with \\\"quotes\\\", a \\\\ and: a colon\"\n"
        "seed: 9223372036854775807\n"
        "offset_ns: -1234567890123\n"
        "ransac:\n"
        "  sigma: 0.30000000000000004\n"
        "  count: -4\n"
        "outer:\n"
        "  deep:\n"
        "    sigma: 1e-300\n"
        "    count: 42\n");
  for (const auto missing : {vilma::MissingKey::kRequired, vilma::MissingKey::kKeepDefault}) {
    const Example back = Read(yaml, missing);
    CHECK(back.enabled == e.enabled);
    CHECK(back.name == e.name);
    CHECK(back.seed == e.seed);
    CHECK(back.offset_ns == e.offset_ns);
    CHECK(back.ransac.sigma == e.ransac.sigma);
    CHECK(back.ransac.count == e.ransac.count);
    CHECK(back.nested_deep.sigma == e.nested_deep.sigma);
    CHECK(back.nested_deep.count == e.nested_deep.count);
    CHECK(Write(back) == yaml);
  }
}

TEST_CASE("options fields: missing keys are an error or keep the default, as asked",
          "[core][options]") {
  CHECK_THROWS_WITH(Read("enabled: true\n", vilma::MissingKey::kRequired),
                    Catch::Contains("example.yaml") && Catch::Contains("name"));
  CHECK_THROWS_WITH(Read("enabled: true\nname: x\nseed: 1\noffset_ns: 0\nouter: {deep: {}}\n",
                         vilma::MissingKey::kRequired),
                    Catch::Contains("ransac"));
  const Example kept = Read("ransac:\n  count: 9\n", vilma::MissingKey::kKeepDefault);
  CHECK(kept.ransac.count == 9);
  CHECK(kept.ransac.sigma == 0.1);
  CHECK(kept.enabled);
  CHECK(kept.name == "plain");
  CHECK(kept.nested_deep.count == 3);  // the whole absent section keeps its defaults
  CHECK(Read("", vilma::MissingKey::kKeepDefault).seed == 7);
}

TEST_CASE("options fields: unknown keys and wrong values name file, key and expectation",
          "[core][options]") {
  using vilma::MissingKey;
  CHECK_THROWS_WITH(Read("ransac:\n  sigmaa: 1\n", MissingKey::kKeepDefault),
                    Catch::Contains("example.yaml") && Catch::Contains("sigmaa") &&
                        Catch::Contains("sigma"));
  CHECK_THROWS_WITH(Read("rnsac: {}\n", MissingKey::kKeepDefault), Catch::Contains("rnsac"));
  CHECK_THROWS_WITH(Read("outer:\n  deep:\n    extra: 1\n", MissingKey::kKeepDefault),
                    Catch::Contains("outer.deep") && Catch::Contains("extra"));
  CHECK_THROWS_WITH(Read("ransac:\n  count: many\n", MissingKey::kKeepDefault),
                    Catch::Contains("ransac.count"));
  CHECK_THROWS_WITH(Read("seed: -1\n", MissingKey::kKeepDefault),
                    Catch::Contains("seed") && Catch::Contains("non-negative"));
  CHECK_THROWS_WITH(Read("ransac: 3\n", MissingKey::kKeepDefault),
                    Catch::Contains("ransac") && Catch::Contains("map"));
  CHECK_THROWS_AS(Read("- a\n- b\n", MissingKey::kKeepDefault), vilma::InputError);
}

namespace {

// Fields with their own YAML form, an embedded struct under a section, a list of strings.
enum class Mode { kFast, kSlow };
struct WithSpecialFields {
  Mode mode = Mode::kFast;
  double exposure_us = 0.0;  // 0 = "auto"
  std::vector<std::string> channels = {"CAM0", "CAM1"};
  Inner filter;  // its own field list, visited under "filter.inner"
  std::string note_a = "a";
  std::string note_b = "b";  // with note_a: one key "notes: a/b" sets both
};

template <typename Options, typename Visitor>
void VisitInner(Options& o, Visitor&& v) {
  v("", "sigma", o.sigma);
  v("", "count", o.count);
}

template <typename Options, typename Visitor>
void VisitSpecial(Options& o, Visitor&& v) {
  v("", "mode",
    vilma::WithCodec(
        o.mode,
        [](const vilma::YamlNode& node, const char* key, Mode* mode) {
          const std::string text = node.Get<std::string>(key);
          if (text != "fast" && text != "slow") node.Fail(key, "expected fast or slow");
          *mode = text == "fast" ? Mode::kFast : Mode::kSlow;
        },
        [](Mode mode) { return std::string(mode == Mode::kFast ? "fast" : "slow"); }));
  v("", "exposure",
    vilma::WithCodec(
        o.exposure_us,
        [](const vilma::YamlNode& node, const char* key, double* us) {
          const std::string text = node.Get<std::string>(key);
          *us = text == "auto" ? 0.0 : node.Get<double>(key);
        },
        [](double us) { return us > 0.0 ? vilma::FormatYamlScalar(us) : std::string("auto"); }));
  v("", "channels", o.channels);
  VisitInner(o.filter, vilma::InSection("filter.inner", v));
  // A key whose codec sets two members of the struct; written as a block (leading '\n').
  v("", "notes",
    vilma::WithCodec(
        o,
        [](const vilma::YamlNode& node, const char* key, WithSpecialFields* s) {
          const vilma::YamlNode notes = node.MapChild(key);
          s->note_a = notes.Get<std::string>("a");
          s->note_b = notes.Get<std::string>("b");
          notes.CheckNoUnknownKeys();
        },
        [](const WithSpecialFields& s) {
          return "\n# two members\na: " + vilma::FormatYamlScalar(s.note_a) +
                 "\nb: " + vilma::FormatYamlScalar(s.note_b) + "\n";
        }));
}

WithSpecialFields ReadSpecial(const std::string& text, vilma::MissingKey missing) {
  WithSpecialFields s;
  vilma::ReadOptionFields(vilma::YamlNode::LoadString(text, "special.yaml"), missing, &s,
                          [](auto& o, auto&& v) { VisitSpecial(o, v); });
  return s;
}

std::string WriteSpecial(const WithSpecialFields& s) {
  return vilma::OptionFieldsToYaml(s, [](auto& o, auto&& v) { VisitSpecial(o, v); });
}

}  // namespace

TEST_CASE("options fields: codecs, embedded sections and string lists round-trip",
          "[core][options]") {
  WithSpecialFields s;
  s.mode = Mode::kSlow;
  s.exposure_us = 1250.5;
  s.channels = {"LEFT", "with \"quote\""};
  s.filter.sigma = 0.25;
  s.filter.count = 11;
  s.note_a = "x: y";
  s.note_b = "";
  const std::string yaml = WriteSpecial(s);
  CHECK(yaml ==
        "mode: slow\n"
        "exposure: 1250.5\n"
        "channels: [\"LEFT\", \"with \\\"quote\\\"\"]\n"
        "filter:\n"
        "  inner:\n"
        "    sigma: 0.25\n"
        "    count: 11\n"
        "notes:\n"
        "  # two members\n"
        "  a: \"x: y\"\n"
        "  b: \"\"\n");
  for (const auto missing : {vilma::MissingKey::kRequired, vilma::MissingKey::kKeepDefault}) {
    const WithSpecialFields back = ReadSpecial(yaml, missing);
    CHECK(back.mode == Mode::kSlow);
    CHECK(back.exposure_us == 1250.5);
    CHECK(back.channels == s.channels);
    CHECK(back.filter.sigma == 0.25);
    CHECK(back.filter.count == 11);
    CHECK(back.note_a == "x: y");
    CHECK(back.note_b.empty());
    CHECK(WriteSpecial(back) == yaml);
  }
  // The defaults write "auto" and read back to 0.
  CHECK(ReadSpecial(WriteSpecial(WithSpecialFields()), vilma::MissingKey::kRequired).exposure_us ==
        0.0);
  // kKeepDefault: an absent codec key is not read (the codec is not called).
  const WithSpecialFields kept = ReadSpecial("channels: []\n", vilma::MissingKey::kKeepDefault);
  CHECK(kept.mode == Mode::kFast);
  CHECK(kept.channels.empty());
  CHECK(kept.note_a == "a");
}

TEST_CASE("options fields: codec and list errors name file and key", "[core][options]") {
  using vilma::MissingKey;
  CHECK_THROWS_WITH(ReadSpecial("mode: medium\n", MissingKey::kKeepDefault),
                    Catch::Contains("special.yaml: mode: expected fast or slow"));
  CHECK_THROWS_WITH(ReadSpecial("channels: CAM0\n", MissingKey::kKeepDefault),
                    Catch::Contains("special.yaml: channels: expected a list of strings"));
  CHECK_THROWS_WITH(ReadSpecial("channels: [[a]]\n", MissingKey::kKeepDefault),
                    Catch::Contains("channels: expected a list of strings"));
  CHECK_THROWS_WITH(ReadSpecial("filter:\n  inner:\n    sigmaa: 1\n", MissingKey::kKeepDefault),
                    Catch::Contains("filter.inner") && Catch::Contains("sigmaa"));
  CHECK_THROWS_WITH(ReadSpecial("notes: {a: x, b: y, c: z}\n", MissingKey::kKeepDefault),
                    Catch::Contains("notes") && Catch::Contains("c"));
  // A required codec key that is missing is named.
  CHECK_THROWS_WITH(ReadSpecial("mode: fast\nexposure: auto\nchannels: []\n"
                                "filter: {inner: {sigma: 1, count: 2}}\n",
                                MissingKey::kRequired),
                    Catch::Contains("notes"));
}

// core/options_fields.h: one field list gives the strict reader and a writer that round-trips.
#include <catch2/catch.hpp>

#include <cstdint>
#include <limits>
#include <string>

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

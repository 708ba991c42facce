#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/strict_parse.h"

namespace vilma {
namespace {

// Runs the cursor over `args` and returns the message of the UsageError the handler throws,
// or "" when none.
template <typename Handler>
std::string UsageErrorOf(const std::vector<std::string>& args, Handler handler) {
  try {
    for (ArgCursor arg(args); arg.Next();) handler(arg);
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("strict parsers take the whole text or throw the expectation", "[arg_cursor]") {
  CHECK(ParseStrictInt("42") == 42);
  CHECK(ParseStrictInt("-7") == -7);
  CHECK(ParseStrictDouble("2.5e-3") == Approx(2.5e-3));
  CHECK(ParseStrictBool("on"));
  CHECK_FALSE(ParseStrictBool("no"));
  for (const std::string bad : {"", " 5", "10x", "1.5", "0x10", "99999999999999999999"}) {
    INFO(bad);
    CHECK_THROWS_AS(ParseStrictInt(bad), std::invalid_argument);
  }
  CHECK_THROWS_WITH(ParseStrictInt("0", 1, 100), "an integer from 1 to 100");
  for (const std::string bad : {"", " 1", "1.5m", "nan", "inf", "1e400", "--3"}) {
    INFO(bad);
    CHECK_THROWS_AS(ParseStrictDouble(bad), std::invalid_argument);
  }
  CHECK_THROWS_WITH(ParseStrictBool("maybe"), "true or false");
}

TEST_CASE("ArgCursor numeric values name the flag and the text", "[arg_cursor]") {
  int frames = 0;
  double rate_hz = 0.0;
  int64_t start_ns = 0;
  const auto handler = [&](ArgCursor& arg) {
    if (arg.name() == "--frames") {
      frames = arg.IntValue(1);
    } else if (arg.name() == "--rate") {
      rate_hz = arg.DoubleValueIn(1e-3, 1e3);
    } else if (arg.name() == "--start") {
      start_ns = arg.Int64Value();
    } else {
      throw UsageError("unknown option " + arg.name());
    }
  };
  CHECK(UsageErrorOf({"--frames", "12", "--rate=20.5", "--start", "1403715273262142976"},
                     handler) == "");
  CHECK(frames == 12);
  CHECK(rate_hz == 20.5);
  CHECK(start_ns == 1403715273262142976);

  CHECK(UsageErrorOf({"--frames", "12x"}, handler) == "--frames: expected an integer, got '12x'");
  CHECK(UsageErrorOf({"--frames=0"}, handler) ==
        "--frames: expected an integer from 1 to 2147483647, got '0'");
  CHECK(UsageErrorOf({"--frames", "4294967296"}, handler) ==
        "--frames: expected an integer from 1 to 2147483647, got '4294967296'");
  CHECK(UsageErrorOf({"--rate", "fast"}, handler) == "--rate: expected a finite number, got 'fast'");
  CHECK(UsageErrorOf({"--rate", "0"}, handler) ==
        "--rate: expected a number from 0.001 to 1000, got 0");
  CHECK(UsageErrorOf({"--rate"}, handler) == "--rate: expected a value");
}

}  // namespace vilma

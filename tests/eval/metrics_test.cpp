#include "vilma/eval/metrics.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <string>


namespace vilma {
namespace {

TEST_CASE("ComputeErrorStats by hand", "[eval]") {
  const ErrorStats s = ComputeErrorStats({4.0, 1.0, 3.0, 2.0});
  CHECK(s.count == 4);
  CHECK(s.mean == 2.5);
  CHECK(s.median == 2.5);
  CHECK(s.rmse == Approx(std::sqrt(7.5)));
  CHECK(s.min == 1.0);
  CHECK(s.max == 4.0);
  CHECK(s.std_dev == Approx(std::sqrt(1.25)));
  CHECK(ComputeErrorStats({3.0, 1.0, 2.0}).median == 2.0);
  CHECK(ComputeErrorStats({}).count == 0);
}

}  // namespace
}  // namespace vilma

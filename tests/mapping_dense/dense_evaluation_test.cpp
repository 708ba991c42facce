#include "vilma/mapping/dense/dense_evaluation.h"

#include <catch2/catch.hpp>

#include "mapping_dense/dense_test_util.h"
#include "vilma/core/error.h"

using namespace vilma;
using namespace vilma::mapping;

TEST_CASE("depth views of a map: one per depth resource, with the depth view's pose", "[dense_evaluation]") {
  const testing::PlaneMap m = testing::MakePlaneMap();
  const testing::Pinhole k;
  const std::vector<DepthView> views = DepthViews(m.map, {});
  REQUIRE(views.size() == 5);
  for (std::size_t i = 0; i < views.size(); ++i) {
    CHECK(views[i].vertex == m.vertices[i]);
    CHECK(views[i].camera == 0);
    CHECK((views[i].T_G_D - m.T_G_D[i]).cwiseAbs().maxCoeff() < 1e-12);
    CHECK(views[i].fx == k.fx);
    CHECK(views[i].cy == k.cy);
    CHECK(views[i].width == k.width);
    CHECK(views[i].height == k.height);
  }
  CHECK(DepthViews(m.map, {m.mission}).size() == 5);
  testing::PlaneMapOptions none;
  none.depth = false;
  CHECK(DepthViews(testing::MakePlaneMap(none).map, {}).empty());
}

TEST_CASE("depth consistency of perfect depth maps of a plane is about zero", "[dense_evaluation]") {
  const testing::PlaneMap m = testing::MakePlaneMap();
  const DepthConsistency c = MeasureDepthConsistency(m.map, {});
  INFO(c.BriefReport());
  CHECK(c.pairs == 4);
  CHECK(c.overlapping_points > 4 * 600);
  // Depth quantized to 1 mm and compared at the nearest pixel of a tilted plane.
  CHECK(c.median_abs_m < 0.0015);
  CHECK(c.p90_abs_m < 0.004);
  CHECK(c.median_relative < 0.001);
  CHECK_THAT(c.BriefReport(), Catch::StartsWith("depth consistency over 4 neighbouring keyframe pairs"));

  // Every 8th pixel: about a quarter of the points of every 4th.
  DepthConsistencyOptions sparse;
  sparse.pixel_stride = 8;
  const DepthConsistency s = MeasureDepthConsistency(m.map, {m.mission}, sparse);
  CHECK(s.pairs == 4);
  CHECK(s.overlapping_points == Approx(c.overlapping_points / 4.0).epsilon(0.1));

  DepthConsistencyOptions bad;
  bad.pixel_stride = 0;
  CHECK(!bad.Validate().empty());
  CHECK_THROWS_AS(MeasureDepthConsistency(m.map, {}, bad), InputError);

  // No depth maps: no pairs, all zeros.
  testing::PlaneMapOptions none;
  none.depth = false;
  const DepthConsistency empty = MeasureDepthConsistency(testing::MakePlaneMap(none).map, {});
  CHECK(empty.pairs == 0);
  CHECK(empty.overlapping_points == 0);
  CHECK(empty.median_abs_m == 0.0);
}

TEST_CASE("depth consistency finds a depth map biased by 5 %", "[dense_evaluation]") {
  testing::PlaneMapOptions o;
  o.vertices = 2;
  SECTION("the first map biased: its points land 5 % deeper in the second view") {
    o.depth_scale = {1.05, 1.0};
    const DepthConsistency c = MeasureDepthConsistency(testing::MakePlaneMap(o).map, {});
    INFO(c.BriefReport());
    CHECK(c.pairs == 1);
    CHECK(c.overlapping_points > 600);
    CHECK(c.median_relative == Approx(0.05).margin(0.004));
    CHECK(c.median_abs_m == Approx(0.05 * 2.0).epsilon(0.15));
  }
  SECTION("the second map biased: relative to its (measured) depth, 0.05 / 1.05") {
    o.depth_scale = {1.0, 1.05};
    const DepthConsistency c = MeasureDepthConsistency(testing::MakePlaneMap(o).map, {});
    INFO(c.BriefReport());
    CHECK(c.pairs == 1);
    CHECK(c.median_relative == Approx(0.05 / 1.05).margin(0.003));
  }
}

// plot_map (map_plot.h): the picture has the asked size, vertices, landmarks and loop closures
// are drawn where the projection puts them, and the same map gives the same bytes.
#include "vilma/mapping/export/map_plot.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>

#include "mapping_export/map_plot_test_map.h"
#include "mapstore/synthetic_map.h"
#include "vilma/core/error.h"

namespace vilma::mapping {
namespace {

namespace fs = std::filesystem;
using testing::MakePictureTestMap;

cv::Vec3b Bgr(const std::array<uint8_t, 3>& rgb) { return cv::Vec3b(rgb[2], rgb[1], rgb[0]); }

cv::Vec3b PixelAt(const cv::Mat& image, const Eigen::Vector2d& px) {
  return image.at<cv::Vec3b>(static_cast<int>(std::lround(px.y())),
                             static_cast<int>(std::lround(px.x())));
}

// Largest per-channel difference to `color` in the (2r+1)^2 pixels around px, minimised.
int ClosestInWindow(const cv::Mat& image, const Eigen::Vector2d& px, const cv::Vec3b& color,
                    int r) {
  int best = 255;
  const int c0 = static_cast<int>(std::lround(px.x())), r0 = static_cast<int>(std::lround(px.y()));
  for (int dr = -r; dr <= r; ++dr) {
    for (int dc = -r; dc <= r; ++dc) {
      const cv::Vec3b p = image.at<cv::Vec3b>(r0 + dr, c0 + dc);
      int d = 0;
      for (int ch = 0; ch < 3; ++ch) d = std::max(d, std::abs(int(p[ch]) - int(color[ch])));
      best = std::min(best, d);
    }
  }
  return best;
}

std::string ScratchFolder() {
  const fs::path dir = fs::temp_directory_path() / ("vilma_map_plot_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir.string();
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace

TEST_CASE("plot_map puts every vertex at its projected pixel in its mission's colour",
          "[map_plot]") {
  const auto test_map = MakePictureTestMap();
  MapPlotOptions options;
  options.width_px = 900;
  options.height_px = 700;
  const MapPlot plot = RenderMapPlot(test_map.map, options);
  REQUIRE(plot.image.cols == 900);
  REQUIRE(plot.image.rows == 700);
  REQUIRE(plot.image.type() == CV_8UC3);
  REQUIRE(plot.views.size() == 2);
  CHECK(plot.views[0].axes == "xy");
  CHECK(plot.views[1].axes == "xz");
  // One scale for both views, x columns shared, the top view above the side view.
  CHECK(plot.views[0].px_per_m == plot.views[1].px_per_m);
  CHECK(plot.views[0].panel_px.x == plot.views[1].panel_px.x);
  CHECK(plot.views[0].min_m.x() == plot.views[1].min_m.x());
  CHECK(plot.views[0].panel_px.br().y < plot.views[1].panel_px.y);
  CHECK(plot.summary.missions == 2);
  CHECK(plot.summary.vertices == 80);
  CHECK(plot.summary.loop_closures == 1);
  CHECK(plot.summary.landmarks_total == test_map.good + test_map.bad + test_map.unknown);
  CHECK(plot.summary.landmarks_shown == test_map.good);
  CHECK(plot.summary.landmarks_drawn == test_map.good);

  int checked = 0;
  for (std::size_t mi = 0; mi < 2; ++mi) {
    const cv::Vec3b color = Bgr(MissionColorRgb(mi));
    for (std::size_t k = 0; k < test_map.vertices[mi].size(); k += 3) {
      const Eigen::Vector3d p_G = test_map.map.T_G_I(test_map.vertices[mi][k]).translation();
      for (const MapPlotView& view : plot.views) {
        const Eigen::Vector2d px = view.Project(p_G);
        REQUIRE(
            view.panel_px.contains(cv::Point(int(std::lround(px.x())), int(std::lround(px.y())))));
        INFO("mission " << mi << " vertex " << k << " view " << view.axes << " at "
                        << px.transpose());
        CHECK(PixelAt(plot.image, px) == color);
        ++checked;
      }
    }
  }
  CHECK(checked == 2 * 14 * 2);
  // A point of the top view far from everything drawn stays background.
  const Eigen::Vector2d empty = plot.views[0].Project(Eigen::Vector3d(10.7, 6.3, 0.0));
  CHECK(PixelAt(plot.image, empty) == cv::Vec3b(255, 255, 255));
  // The projection is metric: 10 m along x is 10 * px_per_m columns in both views.
  const Eigen::Vector2d a = plot.views[1].Project(Eigen::Vector3d(0, 0, 1));
  const Eigen::Vector2d b = plot.views[1].Project(Eigen::Vector3d(10, 3, 1));
  CHECK(b.x() - a.x() == Approx(10 * plot.views[1].px_per_m));
  CHECK(b.y() == Approx(a.y()));
}

TEST_CASE("plot_map draws loop-closure edges between their vertices", "[map_plot]") {
  const auto test_map = MakePictureTestMap();
  const mapstore::Edge& loop = test_map.map.edge(test_map.loop_id);
  const Eigen::Vector3d mid_G = 0.5 * (test_map.map.T_G_I(loop.from).translation() +
                                       test_map.map.T_G_I(loop.to).translation());
  const cv::Vec3b red = Bgr(LoopClosureColorRgb());
  MapPlotOptions options;
  options.width_px = 800;
  options.height_px = 600;
  const MapPlot with = RenderMapPlot(test_map.map, options);
  for (const MapPlotView& view : with.views) {
    // Along the edge (a quarter, half, three quarters), the line's colour is there.
    for (double f : {0.25, 0.5, 0.75}) {
      const Eigen::Vector3d p_G = test_map.map.T_G_I(loop.from).translation() * (1 - f) +
                                  test_map.map.T_G_I(loop.to).translation() * f;
      INFO("view " << view.axes << " fraction " << f);
      CHECK(ClosestInWindow(with.image, view.Project(p_G), red, 1) <= 8);
    }
  }
  options.show_loop_closures = false;
  const MapPlot without = RenderMapPlot(test_map.map, options);
  CHECK(without.summary.loop_closures == 0);
  for (const MapPlotView& view : without.views) {
    CHECK(ClosestInWindow(without.image, view.Project(mid_G), red, 2) > 100);
  }
  // A selection of one mission drops the edge (its other end is not drawn).
  options.show_loop_closures = true;
  options.mission = "beta";
  CHECK(RenderMapPlot(test_map.map, options).summary.loop_closures == 0);

  // The maps of the mapstore tests have one loop closure between random poses.
  const mapstore::VIMap random = mapstore::testing::MakeSyntheticMap({});
  CHECK(RenderMapPlot(random, MapPlotOptions{}).summary.loop_closures == 1);
}

TEST_CASE("plot_map draws landmarks of the chosen qualities and subsamples them", "[map_plot]") {
  const auto test_map = MakePictureTestMap();
  MapPlotOptions options;
  options.width_px = 800;
  options.height_px = 600;
  options.views = "xy";
  const cv::Vec3b grey(150, 150, 150), light_red(170, 170, 235);
  std::vector<Eigen::Vector3d> good, bad;
  for (const auto& id : test_map.map.landmark_ids(test_map.map.mission_ids()[0])) {
    const auto& l = test_map.map.landmark(id);
    (l.quality == mapstore::LandmarkQuality::kGood ? good : bad)
        .push_back(test_map.map.LandmarkPosition_G(id));
  }
  const MapPlot plot = RenderMapPlot(test_map.map, options);
  REQUIRE(plot.views.size() == 1);
  CHECK(PixelAt(plot.image, plot.views[0].Project(good[5])) == grey);
  options.landmarks = "bad";
  const MapPlot bad_only = RenderMapPlot(test_map.map, options);
  CHECK(bad_only.summary.landmarks_shown == test_map.bad);
  CHECK(PixelAt(bad_only.image, bad_only.views[0].Project(bad[3])) == light_red);
  options.landmarks = "none";
  const MapPlot none = RenderMapPlot(test_map.map, options);
  CHECK(none.summary.landmarks_drawn == 0);
  CHECK(PixelAt(none.image, none.views[0].Project(good[5])) == cv::Vec3b(255, 255, 255));

  options.landmarks = "good";
  options.max_landmarks = 25;
  const MapPlot sub = RenderMapPlot(test_map.map, options);
  CHECK(sub.summary.landmarks_shown == test_map.good);
  CHECK(sub.summary.landmarks_drawn == 25);
  CHECK(SubsampleIndices(10, 4) == std::vector<std::size_t>{0, 2, 5, 7});
  CHECK(SubsampleIndices(3, 4) == std::vector<std::size_t>{0, 1, 2});
  CHECK(SubsampleIndices(5, 0).empty());
}

TEST_CASE("plot_map writes the same PNG bytes for the same map", "[map_plot]") {
  const auto test_map = MakePictureTestMap();
  const std::string dir = ScratchFolder();
  MapPlotOptions options;
  options.width_px = 640;
  options.height_px = 480;
  const MapPlotSummary first = PlotMap(test_map.map, options, dir + "/a.png");
  const MapPlotSummary second = PlotMap(MakePictureTestMap().map, options, dir + "/b.png");
  CHECK(first.path == dir + "/a.png");
  CHECK(first.bytes == fs::file_size(dir + "/a.png"));
  const std::string a = ReadBytes(dir + "/a.png"), b = ReadBytes(dir + "/b.png");
  REQUIRE(!a.empty());
  CHECK(a == b);
  const cv::Mat decoded = cv::imread(dir + "/a.png", cv::IMREAD_UNCHANGED);
  REQUIRE(!decoded.empty());
  CHECK(decoded.cols == 640);
  CHECK(decoded.rows == 480);
  CHECK(decoded.channels() == 3);
  const MapPlot rendered = RenderMapPlot(test_map.map, options);
  CHECK(cv::norm(decoded, rendered.image, cv::NORM_INF) == 0.0);
  // A folder as --out gets map.png; no temporary file is left behind.
  CHECK(PlotMap(test_map.map, options, dir).path == dir + "/map.png");
  CHECK(ReadBytes(dir + "/map.png") == a);
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    (void)entry;
    ++files;
  }
  CHECK(files == 3);
  fs::remove_all(dir);
}

TEST_CASE("plot_map selects missions and views", "[map_plot]") {
  const auto test_map = MakePictureTestMap();
  MapPlotOptions options;
  options.width_px = 800;
  options.height_px = 600;
  options.mission = "beta";
  const MapPlot beta = RenderMapPlot(test_map.map, options);
  CHECK(beta.summary.missions == 1);
  CHECK(beta.summary.vertices == 40);
  CHECK(beta.summary.landmarks_total == 0);  // the landmarks are stored in alpha
  // Beta keeps its colour (the second mission of the map) when drawn alone.
  const Eigen::Vector3d p_G = test_map.map.T_G_I(test_map.vertices[1][7]).translation();
  CHECK(PixelAt(beta.image, beta.views[0].Project(p_G)) == Bgr(MissionColorRgb(1)));

  const std::string beta_hex = test_map.map.mission_ids()[1].Hex();
  CHECK(SelectMissions(test_map.map, beta_hex) ==
        std::vector<mapstore::MissionId>{test_map.map.mission_ids()[1]});
  CHECK(SelectMissions(test_map.map, beta_hex.substr(0, 6) + ", alpha") ==
        test_map.map.mission_ids());
  CHECK(SelectMissions(test_map.map, "").size() == 2);
  CHECK(SelectMissions(test_map.map, "alpha,,") ==
        std::vector<mapstore::MissionId>{test_map.map.mission_ids()[0]});
  CHECK_THROWS_WITH(SelectMissions(test_map.map, "gamma"),
                    Catch::Contains("--mission") && Catch::Contains("'gamma' matches none") &&
                        Catch::Contains("alpha"));

  // Alpha alone (in the y-z view beta's circle would cover parts of alpha's).
  options.mission = "alpha";
  options.views = "yz,xy,xz";
  const MapPlot three = RenderMapPlot(test_map.map, options);
  REQUIRE(three.views.size() == 3);
  CHECK(three.views[0].axes == "yz");
  const Eigen::Vector3d q_G = test_map.map.T_G_I(test_map.vertices[0][12]).translation();
  for (const MapPlotView& view : three.views) {
    CHECK(PixelAt(three.image, view.Project(q_G)) == Bgr(MissionColorRgb(0)));
  }
}

TEST_CASE("plot_map fits a long title and long mission names into the picture", "[map_plot]") {
  auto test_map = MakePictureTestMap();
  test_map.map.mission(test_map.map.mission_ids()[0]).name = std::string(150, 'n');
  MapPlotOptions options;
  options.width_px = 400;
  options.height_px = 400;
  options.title = std::string(120, 'T');
  const MapPlot plot = RenderMapPlot(test_map.map, options);
  // Nothing drawn in the last three columns above the first view (title and legend).
  const cv::Mat strip = plot.image(cv::Rect(397, 0, 3, plot.views[0].panel_px.y - 10));
  CHECK(cv::countNonZero(strip.reshape(1) != 255) == 0);
  // Without the long texts, the same region has text in it (the check can fail).
  const MapPlot normal = RenderMapPlot(MakePictureTestMap().map, MapPlotOptions{});
  CHECK(cv::countNonZero(
            normal.image(cv::Rect(0, 0, 400, normal.views[0].panel_px.y - 10)).reshape(1) != 255) >
        0);
}

TEST_CASE("plot_map refuses bad options and output paths with a clear message", "[map_plot]") {
  MapPlotOptions options;
  CHECK(options.Validate().empty());
  options.views = "xy,top";
  CHECK_THAT(options.Validate(), Catch::StartsWith("views:") && Catch::Contains("'top'"));
  options = MapPlotOptions{};
  options.width_px = 100;
  CHECK_THAT(options.Validate(), Catch::StartsWith("width_px:"));
  options = MapPlotOptions{};
  options.landmarks = "good,great";
  CHECK_THAT(options.Validate(), Catch::StartsWith("landmarks:") && Catch::Contains("'great'"));
  options = MapPlotOptions{};
  options.max_landmarks = -1;
  CHECK_THAT(options.Validate(), Catch::StartsWith("max_landmarks:"));

  const auto test_map = MakePictureTestMap();
  options = MapPlotOptions{};
  options.views = "zz";
  CHECK_THROWS_AS(RenderMapPlot(test_map.map, options), InputError);
  CHECK_THROWS_WITH(PlotMap(test_map.map, MapPlotOptions{}, "/tmp/map.jpg"),
                    Catch::Contains("/tmp/map.jpg") && Catch::Contains(".png"));
  CHECK_THROWS_WITH(PlotMap(test_map.map, MapPlotOptions{}, "/nonexistent_vilma/x.png"),
                    Catch::Contains("/nonexistent_vilma"));
  CHECK_THROWS_WITH(PlotMap(test_map.map, MapPlotOptions{}, ""), Catch::Contains("--out"));
  CHECK(ResolveOutputFile("/tmp", "map.png", ".png") == "/tmp/map.png");
  CHECK(ResolveOutputFile("x.PNG", "map.png", ".png") == "x.PNG");
  mapstore::VIMap empty;
  CHECK_THROWS_WITH(RenderMapPlot(empty, MapPlotOptions{}), Catch::Contains("no"));
}

}  // namespace vilma::mapping

// plot_map and export_html through the console on a real daemon-built map (test_maps.h): the
// files are written and readable (the PNG decodes at the asked size, the HTML draws in headless
// Chromium without a JavaScript error), and bad input fails with a message that names it.
#include <catch2/catch.hpp>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "console_plugins/test_maps.h"
#include "vilma/console/session.h"
#include "test_skip.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;

using Fixture = test::ConsoleFixture;

}  // namespace

TEST_CASE("plot_map writes a PNG of a daemon map, bad --out and options fail clearly") {
  const auto& maps = test::TestMaps();
  const std::string dir = test::ConsoleScratch("plot_map");
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  REQUIRE(f.Run("plot_map --out=" + dir + "/a.png --width_px=800 --height_px=600").ok());
  CHECK_THAT(f.out.str(),
             Catch::Contains("wrote " + dir + "/a.png") && Catch::Contains("1 mission(s)"));
  const cv::Mat image = cv::imread(dir + "/a.png", cv::IMREAD_COLOR);
  REQUIRE(!image.empty());
  CHECK(image.cols == 800);
  CHECK(image.rows == 600);
  // The positional form with a folder (map.png in it); the same map gives the same bytes.
  REQUIRE(f.Run("plot_map " + dir + " --width_px=800 --height_px=600").ok());
  CHECK(test::ReadTextFile(dir + "/map.png") == test::ReadTextFile(dir + "/a.png"));
  REQUIRE(f.Run("plot_map --out=" + dir + "/side.png --views=xz --landmarks=good,bad").ok());

  CommandResult r = f.Run("plot_map --out=" + dir + "/map.jpg");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains(dir + "/map.jpg") && Catch::Contains(".png"));
  r = f.Run("plot_map --out=/nonexistent_vilma_dir/map.png");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("/nonexistent_vilma_dir"));
  r = f.Run("plot_map");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("out:"));
  r = f.Run("plot_map --out=" + dir + "/x.png --width_px=wide");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("--width_px") && Catch::Contains("integer"));
  r = f.Run("plot_map --out=" + dir + "/x.png --views=front");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("views:") && Catch::Contains("'front'"));
  r = f.Run("plot_map --out=" + dir + "/x.png --map_mission=nosuchmission");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("'nosuchmission' matches none"));
  CHECK_FALSE(fs::exists(dir + "/x.png"));
}

TEST_CASE("export_html writes a page of a daemon map that draws in headless Chromium") {
  const auto& maps = test::TestMaps();
  const std::string dir = test::ConsoleScratch("export_html");
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());

  CommandResult r = f.Run("export_html --out=" + dir + "/map.html --three_js_path=" + dir +
                          "/missing/three.min.js");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message,
             Catch::Contains(dir + "/missing/three.min.js") && Catch::Contains("libjs-three"));
  CHECK_FALSE(fs::exists(dir + "/map.html"));
  r = f.Run("export_html --out=" + dir + "/map.txt");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains(".html"));

  if (!fs::exists("/usr/share/javascript/three/three.min.js")) {
    VILMA_SKIP("the page itself: Debian's libjs-three is not installed");
  }
  REQUIRE(f.Run("export_html " + dir).ok());
  CHECK_THAT(f.out.str(),
             Catch::Contains("wrote " + dir + "/map.html") && Catch::Contains("three.js r111"));
  if (!test::HaveProgram("chromium")) {
    VILMA_SKIP("loading the page: Debian's chromium is not installed");
  }
  test::ChildProcess chromium(
      {"chromium", "--headless=new", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
       "--enable-unsafe-swiftshader", "--no-first-run", "--user-data-dir=" + dir + "/profile",
       "--window-size=800,600", "--dump-dom", "file://" + dir + "/map.html"},
      dir + "/dom.html", {"HOME=" + dir});
  REQUIRE(chromium.Wait(90.0) == 0);
  const std::string dom = test::ReadTextFile(dir + "/dom.html");
  CHECK(dom.find("data-vilma-state=\"drawn\"") != std::string::npos);
  CHECK(dom.find("data-vilma-errors=\"0\"") != std::string::npos);
  CHECK(dom.find("<pre id=\"vilma-errors\"></pre>") != std::string::npos);
}

}  // namespace vilma::console

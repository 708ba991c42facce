// export_html (html_viewer.h): the page inlines three.js and the map, is deterministic, refuses
// missing libraries clearly, and — in headless Chromium with software WebGL (SwiftShader) —
// loads without a JavaScript error, draws the map and shows a clicked vertex's details.
#include "vilma/mapping/export/html_viewer.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "integration/process_util.h"
#include "mapping_export/map_plot_test_map.h"
#include "vilma/core/error.h"
#include "vilma/mapping/export/map_plot.h"
#include "test_skip.h"

namespace vilma::mapping {
namespace {

namespace fs = std::filesystem;
using testing::MakePictureTestMap;

bool HaveThreeJs() {
  const HtmlViewerOptions defaults;
  return fs::exists(defaults.three_js_path) && fs::exists(defaults.orbit_controls_path);
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::string Scratch() {
  const fs::path dir =
      fs::temp_directory_path() / ("vilma_html_viewer_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir.string();
}

// The text between the first `begin` and the next `end` after it ("" when absent).
std::string Between(const std::string& text, const std::string& begin, const std::string& end) {
  const std::size_t a = text.find(begin);
  if (a == std::string::npos) return "";
  const std::size_t b = text.find(end, a + begin.size());
  return b == std::string::npos ? "" : text.substr(a + begin.size(), b - a - begin.size());
}

// Runs headless Chromium on `url` with software WebGL; returns its exit status, its output
// (stdout and stderr) in *output.
int RunChromium(const std::vector<std::string>& mode_args, const std::string& url,
                const std::string& scratch, std::string* output) {
  std::vector<std::string> argv = {"chromium", "--headless=new", "--no-sandbox", "--disable-gpu",
                                   // WebGL in software: ANGLE on SwiftShader.
                                   "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                                   "--enable-logging=stderr", "--v=0", "--no-first-run",
                                   "--user-data-dir=" + scratch + "/chromium-profile",
                                   "--window-size=1024,768", "--hide-scrollbars"};
  argv.insert(argv.end(), mode_args.begin(), mode_args.end());
  argv.push_back(url);
  const std::string log = scratch + "/chromium.log";
  test::ChildProcess chromium(argv, log, {"HOME=" + scratch});
  const int status = chromium.Wait(90.0);
  *output = ReadText(log);
  return status;
}

// Pixels within `tolerance` (per channel) of an RGB colour.
int CountColor(const cv::Mat& bgr, const std::array<uint8_t, 3>& rgb, int tolerance) {
  int n = 0;
  for (int r = 0; r < bgr.rows; ++r) {
    for (int c = 0; c < bgr.cols; ++c) {
      const cv::Vec3b p = bgr.at<cv::Vec3b>(r, c);
      if (std::abs(p[2] - rgb[0]) <= tolerance && std::abs(p[1] - rgb[1]) <= tolerance &&
          std::abs(p[0] - rgb[2]) <= tolerance) {
        ++n;
      }
    }
  }
  return n;
}

}  // namespace

TEST_CASE("export_html inlines three.js and the map, deterministically", "[html_viewer]") {
  if (!HaveThreeJs()) {
    VILMA_SKIP("Debian's libjs-three is not installed (" << HtmlViewerOptions{}.three_js_path
                                                         << ")");
  }
  auto test_map = MakePictureTestMap();
  test_map.map.mission(test_map.map.mission_ids()[1]).name = "beta </script> & <b>";
  HtmlViewerOptions options;
  HtmlViewerSummary summary;
  const std::string html = RenderHtmlViewer(test_map.map, options, &summary);
  CHECK(summary.three_js_revision == "111");
  CHECK(summary.missions == 2);
  CHECK(summary.vertices == 80);
  CHECK(summary.loop_closures == 1);
  CHECK(summary.landmarks_total == test_map.good + test_map.bad + test_map.unknown);
  CHECK(summary.landmarks_embedded == test_map.good);
  CHECK(summary.bytes == html.size());
  // three.js and OrbitControls verbatim, no network reference anywhere.
  const std::string three = ReadText(options.three_js_path);
  CHECK(html.find(three) != std::string::npos);
  CHECK(html.find(ReadText(options.orbit_controls_path)) != std::string::npos);
  CHECK(html.find("src=\"http") == std::string::npos);
  CHECK(html.find("<link") == std::string::npos);
  // The map: alpha's vertex 0 at (5, 0, 1) m relative to the origin.
  const std::string json =
      Between(html, "<script type=\"application/json\" id=\"vilma-map-data\">", "</script>");
  REQUIRE(!json.empty());
  CHECK(json.find("\"format\":\"vilma-map-viewer\",\"version\":1") != std::string::npos);
  CHECK(json.find("\"origin_m\":[10,0,1]") != std::string::npos);
  CHECK(json.find("\"p_mm\":[5000,0,1000,") != std::string::npos);
  CHECK(json.find("\"t0_ns\":\"1600000000000000000\"") != std::string::npos);
  CHECK(json.find("\"" + test_map.vertices[1][10].Hex() + "\"") != std::string::npos);
  CHECK(json.find("\"loop_closures\":[[1,10,0,0]]") != std::string::npos);
  CHECK(json.find("\"color\":\"#1f77b4\"") != std::string::npos);
  // The hostile mission name stays inside its JSON string (no "<" at all in the data).
  CHECK(json.find('<') == std::string::npos);
  CHECK(json.find("beta \\u003c/script\\u003e \\u0026 \\u003cb\\u003e") != std::string::npos);
  // Same map, same bytes.
  CHECK(RenderHtmlViewer(MakePictureTestMap().map, options) ==
        RenderHtmlViewer(MakePictureTestMap().map, options));

  options.max_landmarks = 10;
  options.landmarks = "good,bad";
  RenderHtmlViewer(test_map.map, options, &summary);
  CHECK(summary.landmarks_shown == test_map.good + test_map.bad);
  CHECK(summary.landmarks_embedded == 10);
}

TEST_CASE("export_html names a missing or wrong three.js and a bad --out", "[html_viewer]") {
  const auto test_map = MakePictureTestMap();
  const std::string dir = Scratch();
  HtmlViewerOptions options;
  options.three_js_path = dir + "/no/three.min.js";
  CHECK_THROWS_WITH(RenderHtmlViewer(test_map.map, options),
                    Catch::Contains(dir + "/no/three.min.js") && Catch::Contains("libjs-three") &&
                        Catch::Contains("--three_js_path"));
  { std::ofstream(dir + "/fake.js") << "console.log('hello');"; }
  options.three_js_path = dir + "/fake.js";
  CHECK_THROWS_WITH(RenderHtmlViewer(test_map.map, options),
                    Catch::Contains("fake.js") && Catch::Contains("REVISION"));
  if (HaveThreeJs()) {
    options = HtmlViewerOptions{};
    options.orbit_controls_path = dir + "/missing.js";
    CHECK_THROWS_WITH(RenderHtmlViewer(test_map.map, options),
                      Catch::Contains("missing.js") && Catch::Contains("--orbit_controls_path"));
    CHECK_THROWS_WITH(ExportHtmlViewer(test_map.map, HtmlViewerOptions{}, dir + "/map.htm"),
                      Catch::Contains(".html"));
    const HtmlViewerSummary written = ExportHtmlViewer(test_map.map, HtmlViewerOptions{}, dir);
    CHECK(written.path == dir + "/map.html");
    CHECK(fs::file_size(written.path) == written.bytes);
  }
  options = HtmlViewerOptions{};
  options.landmarks = "all";
  CHECK_THAT(options.Validate(), Catch::StartsWith("landmarks:"));
  options = HtmlViewerOptions{};
  options.three_js_path = "";
  CHECK_THAT(options.Validate(), Catch::StartsWith("three_js_path:"));
  fs::remove_all(dir);
}

TEST_CASE("export_html's page draws the map in headless Chromium without errors",
          "[html_viewer][chromium]") {
  if (!test::HaveProgram("chromium")) {
    VILMA_SKIP("Debian's chromium is not installed (needed to load the page headless)");
  }
  if (!HaveThreeJs()) {
    VILMA_SKIP("Debian's libjs-three is not installed");
  }
  const auto test_map = MakePictureTestMap();
  const std::string dir = Scratch();
  const std::string page = dir + "/map.html";
  ExportHtmlViewer(test_map.map, HtmlViewerOptions{}, page);
  const mapstore::VertexId picked = test_map.vertices[1][10];
  const std::string picked_t_ns = std::to_string(test_map.map.vertex(picked).t_ns);

  // 1. The DOM after load, with a vertex picked through the URL fragment.
  std::string output;
  REQUIRE(RunChromium({"--dump-dom"}, "file://" + page + "#vertex=" + picked.Hex(), dir, &output) ==
          0);
  INFO(
      "chromium output (tail): " << output.substr(output.size() > 3000 ? output.size() - 3000 : 0));
  CHECK(output.find("data-vilma-state=\"drawn\"") != std::string::npos);
  CHECK(output.find("data-vilma-errors=\"0\"") != std::string::npos);
  CHECK(output.find("<pre id=\"vilma-errors\"></pre>") != std::string::npos);  // empty, hidden
  CHECK(output.find("Uncaught") == std::string::npos);
  const std::string details = Between(output, "<div id=\"details\"", "</div>");
  CHECK(details.find("data-vertex=\"" + picked.Hex() + "\"") != std::string::npos);
  CHECK(details.find("t_ns    " + picked_t_ns) != std::string::npos);
  CHECK(details.find("mission beta") != std::string::npos);
  // beta's vertex 10 sits at (16, 0, 1.5) in G.
  CHECK(details.find("p_G_I   [m]    16.000  0.000  1.500") != std::string::npos);
  CHECK(details.find("2 camera frustum(s)") != std::string::npos);

  // 2. A screenshot without the panels: WebGL drew both trajectories, landmarks and the loop.
  const std::string shot = dir + "/shot.png";
  REQUIRE(RunChromium({"--screenshot=" + shot}, "file://" + page + "#panels=0", dir, &output) == 0);
  CHECK(output.find("Uncaught") == std::string::npos);
  const cv::Mat image = cv::imread(shot, cv::IMREAD_COLOR);
  REQUIRE(!image.empty());
  CHECK(image.cols == 1024);
  CHECK(image.rows == 768);
  const cv::Mat centre = image(cv::Rect(256, 192, 512, 384));
  cv::Mat gray;
  cv::cvtColor(centre, gray, cv::COLOR_BGR2GRAY);
  const int drawn = cv::countNonZero(gray < 250);
  INFO("non-background pixels in the centre: " << drawn);
  CHECK(drawn > 2000);
  const int alpha = CountColor(image, MissionColorRgb(0), 3);
  const int beta = CountColor(image, MissionColorRgb(1), 3);
  const int loop = CountColor(image, LoopClosureColorRgb(), 30);
  INFO("alpha " << alpha << " beta " << beta << " loop " << loop);
  CHECK(alpha > 200);
  CHECK(beta > 200);
  CHECK(loop > 20);
  fs::remove_all(dir);
}

}  // namespace vilma::mapping

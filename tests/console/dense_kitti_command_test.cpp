// `vilma dense-kitti` (RunDenseKittiCommand): usage errors, a missing slice, an unwritable
// --out, and the shared KITTI slice every 5th frame (mesh PLY read back, depth consistency,
// the top-view picture, byte-identical output of two runs).
#include "vilma/console/dense_kitti_command.h"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/TriangleMeshIO.h>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "test_skip.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;
using Catch::Contains;

struct Result {
  int code;
  std::string out;
  std::string err;
};

Result Run(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = RunDenseKittiCommand(args, out, err);
  return {code, out.str(), err.str()};
}

fs::path KittiSlice() {
  return fs::path(VILMA_SHARED_DATA_DIR) / "kitti_slices" / "KITTI_sequence_1";
}

// A fresh empty folder for one test of this process.
fs::path Scratch(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("vilma_dense_kitti_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Removes a Scratch folder (and the process's folder once empty) when the test ends.
struct RemoveAtEnd {
  fs::path dir;
  ~RemoveAtEnd() {
    std::error_code ec;
    fs::remove_all(dir, ec);
    fs::remove(dir.parent_path(), ec);
  }
};

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The number after `label` in `text` (NaN when absent).
double NumberAfter(const std::string& text, const std::string& label) {
  const std::size_t at = text.find(label);
  if (at == std::string::npos) return std::nan("");
  return std::stod(text.substr(at + label.size()));
}

// N of the PLY header's "element <name> N" (-1 when absent).
long PlyElementCount(const std::string& bytes, const std::string& name) {
  const std::size_t header_end = bytes.find("end_header");
  const std::string header = bytes.substr(0, header_end);
  const std::size_t at = header.find("element " + name + " ");
  if (at == std::string::npos) return -1;
  return std::stol(header.substr(at + 9 + name.size()));
}

TEST_CASE("vilma dense-kitti: help and usage errors", "[dense_kitti_command]") {
  const Result help = Run({"--help"});
  CHECK(help.code == kExitOk);
  CHECK_THAT(help.out, Contains("usage: vilma dense-kitti KITTI_DIR --out MESH.ply"));

  const fs::path dir = Scratch("usage");
  const RemoveAtEnd remove{dir};
  const std::string out = (dir / "mesh.ply").string();
  const std::string kitti = (dir / "kitti").string();  // never read: the arguments fail first
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{}, "expected a KITTI_DIR"},
      {{kitti}, "--out: expected the PLY file to write"},
      {{kitti, "--out"}, "--out"},
      {{kitti, "--out", out, "--bogus"}, "unknown argument '--bogus'"},
      {{kitti, "other", "--out", out}, "unknown argument 'other'"},
      {{kitti, "--out", out, "--every", "0"}, "--every: expected N >= 1"},
      {{kitti, "--out", out, "--every", "-3"}, "--every: expected N >= 1"},
      {{kitti, "--out", out, "--every", "2x"}, "--every: expected an integer, got '2x'"},
      {{kitti, "--out", out, "--voxel", "nan"}, "--voxel: expected a finite number, got 'nan'"},
      {{kitti, "--out", out, "--num-disparities", "40"}, "num_disparities: a positive multiple of 16"},
      {{kitti, "--out", out, "--voxel", "0.5"}, "truncation_distance_m"},
      {{kitti, "--out", out, "--max-depth", "1.5"}, "--max-depth: expected more than 2.0 m"},
  };
  for (const Case& c : cases) {
    std::string line;
    for (const std::string& a : c.args) line += a + " ";
    INFO("args: " << line);
    const Result r = Run(c.args);
    CHECK(r.code == kExitUsage);
    CHECK_THAT(r.err, Contains("vilma dense-kitti: ") && Contains(c.message) && Contains("--help"));
    CHECK(r.out.empty());
  }
  CHECK(fs::is_empty(dir));

  // A folder that is not a KITTI slice: an input error naming the file it looked for.
  const Result missing = Run({"/nonexistent/kitti", "--out", out});
  CHECK(missing.code == kExitInputError);
  CHECK_THAT(missing.err, Contains("/nonexistent/kitti/calib.txt"));
  CHECK(fs::is_empty(dir));
}

TEST_CASE("vilma dense-kitti: the shared KITTI slice, every 5th frame", "[dense_kitti_command]") {
  const fs::path kitti = KittiSlice();
  if (!fs::exists(kitti / "poses.txt")) VILMA_SKIP("KITTI slice absent at " << kitti);
  const fs::path dir = Scratch("slice");
  const RemoveAtEnd remove{dir};
  const std::string mesh = (dir / "mesh.ply").string();
  const std::string picture = (dir / "top.png").string();

  // The caller's OpenMP thread count does not matter: the TSDF integrates with its own
  // (TsdfOptions::threads) and leaves the caller's as it was.
  omp_set_num_threads(2);
  const Result r = Run({kitti.string(), "--out", mesh, "--every", "5", "--render", picture});
  INFO(r.out << r.err);
  REQUIRE(r.code == kExitOk);
  CHECK(omp_get_max_threads() == 2);
  CHECK(r.err.empty());
  CHECK_THAT(r.out, Contains("frames                 11 of 51\n"));
  CHECK_THAT(r.out, Contains("(SGBM, 128 disparities)"));

  // Depth consistency of the 10 neighbouring pairs: KITTI's SGBM depth agrees to a few % of
  // the depth (2.25 % when written).
  CHECK_THAT(r.out, Contains("depth consistency      depth consistency over 10 neighbouring keyframe pairs"));
  const double relative = NumberAfter(r.out, "median relative ");
  CHECK(relative > 0.0);
  CHECK(relative < 3.0);
  const double overlapping = NumberAfter(r.out, "pairs, ");
  CHECK(overlapping > 1000);

  // The PLY: what the output says, read back by Open3D.
  REQUIRE(fs::is_regular_file(mesh));
  CHECK(!fs::exists(mesh + ".partial.ply"));
  const double vertices = NumberAfter(r.out, "mesh                   ");
  const double triangles = NumberAfter(r.out, " vertices, ");
  CHECK(vertices > 1000);
  CHECK(triangles > 1000);
  CHECK_THAT(r.out, Contains(" triangles -> " + mesh));
  const std::string bytes = ReadBytes(mesh);
  CHECK(bytes.rfind("ply\n", 0) == 0);
  CHECK(PlyElementCount(bytes, "vertex") == static_cast<long>(vertices));
  CHECK(PlyElementCount(bytes, "face") == static_cast<long>(triangles));
  open3d::geometry::TriangleMesh read;
  REQUIRE(open3d::io::ReadTriangleMesh(mesh, read));
  CHECK(read.vertices_.size() == static_cast<std::size_t>(vertices));
  CHECK(read.triangles_.size() == static_cast<std::size_t>(triangles));
  CHECK(read.HasVertexColors());
  // KITTI's world is the first left camera: the slice drives 60 m ahead (+z); the surface
  // reaches from near the first frames (seen twice, 11.9 m when written) to 30 m (--max-depth)
  // beyond the last frame (z = 59.8 m).
  const Eigen::Vector3d min = read.GetMinBound(), max = read.GetMaxBound();
  CHECK(min.z() > 2.0);
  CHECK(min.z() < 20.0);
  CHECK(max.z() > 60.0);
  CHECK(max.z() < 59.9 + 30.0 + 0.5);

  // The top view.
  REQUIRE(fs::is_regular_file(picture));
  const cv::Mat image = cv::imread(picture, cv::IMREAD_UNCHANGED);
  REQUIRE(!image.empty());
  CHECK(image.cols == 1024);
  CHECK(image.rows == 768);
  CHECK(NumberAfter(r.out, "picture                " + picture + " (") > 1000);

  // Deterministic: the same arguments give the same bytes (whatever the caller's threads).
  omp_set_num_threads(1);
  const std::string again = (dir / "again.ply").string();
  const Result r2 = Run({kitti.string(), "--out", again, "--every", "5"});
  REQUIRE(r2.code == kExitOk);
  CHECK(omp_get_max_threads() == 1);
  CHECK(ReadBytes(again) == bytes);
}

TEST_CASE("vilma dense-kitti: an unwritable --out leaves no file", "[dense_kitti_command]") {
  const fs::path kitti = KittiSlice();
  if (!fs::exists(kitti / "poses.txt")) VILMA_SKIP("KITTI slice absent at " << kitti);
  const fs::path dir = Scratch("unwritable");
  const RemoveAtEnd remove{dir};
  std::ofstream(dir / "blocker") << "a file, not a folder";
  const std::string mesh = (dir / "blocker" / "mesh.ply").string();
  // Every 10th frame is enough for a surface seen twice. --max-depth 80: beyond the 65.5 m of
  // 16-bit millimetres (stored depth resources), accepted (the depth maps stay in memory).
  // A folder that does not exist is refused before any computation.
  const Result early = Run({kitti.string(), "--out", mesh, "--every", "10"});
  CHECK(early.code == kExitInputError);
  CHECK_THAT(early.err, Contains("vilma dense-kitti: " + mesh + ": expected a file in an existing folder"));
  // A target the writer cannot replace (a folder) fails at the write, after the fusion.
  fs::create_directories(dir / "mesh.ply");
  const std::string folder_target = (dir / "mesh.ply").string();
  const Result r = Run({kitti.string(), "--out", folder_target, "--every", "10", "--max-depth", "80"});
  CHECK(r.code == kExitInputError);
  CHECK_THAT(r.err, Contains("vilma dense-kitti: " + folder_target + ": expected a writable file"));
  std::vector<fs::path> left;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) left.push_back(e.path());
  std::sort(left.begin(), left.end());
  CHECK(left == std::vector<fs::path>{dir / "blocker", dir / "mesh.ply"});
  CHECK(fs::is_empty(dir / "mesh.ply"));
  CHECK(ReadBytes(dir / "blocker") == "a file, not a folder");
}

}  // namespace
}  // namespace vilma::console

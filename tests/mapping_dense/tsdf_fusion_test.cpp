#include "vilma/mapping/dense/tsdf_fusion.h"

#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/TriangleMeshIO.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "mapping_dense/dense_test_util.h"
#include "vilma/core/error.h"
#include "vilma/mapping/dense/mesh_distance.h"

using namespace vilma;
using namespace vilma::mapping;
using vilma::mapping::testing::InputErrorOf;
using testing::Pinhole;
using testing::Plane;
namespace fs = std::filesystem;

namespace {

TsdfOptions PlaneOptions() {
  TsdfOptions o;
  o.voxel_size_m = 0.05;
  o.truncation_distance_m = 0.15;
  return o;
}

double WorstPlaneDistance(const TriangleMesh& mesh, const Plane& plane) {
  double worst = 0.0;
  for (const Eigen::Vector3d& p : mesh.vertices) worst = std::max(worst, plane.Distance(p));
  return worst;
}

struct Coverage {
  int seen = 0;     // plane samples seen well by at least two views
  int covered = 0;  // ... of them within 1 cm of the mesh
};

// Samples of the plane on a 5 cm grid that at least two of the views see at least `margin`
// pixels inside their image, and how many of them the mesh covers.
Coverage PlaneCoverage(const TriangleMesh& mesh, const Plane& plane, const Pinhole& k,
                       const std::vector<Eigen::Matrix4d>& views, double margin) {
  const Eigen::Vector3d e1 = plane.n.unitOrthogonal();
  const Eigen::Vector3d e2 = plane.n.cross(e1);
  const MeshDistanceIndex index(mesh, 0.05);
  Coverage c;
  for (int i = -40; i <= 40; ++i) {
    for (int j = -40; j <= 40; ++j) {
      const Eigen::Vector3d p_G = plane.d * plane.n + 0.05 * i * e1 + 0.05 * j * e2;
      int seen_by = 0;
      for (const Eigen::Matrix4d& T_G_D : views) {
        const Eigen::Vector3d p_D = T_G_D.topLeftCorner<3, 3>().transpose() *
                                    (p_G - T_G_D.topRightCorner<3, 1>());
        if (p_D.z() < 0.5 || p_D.z() > 5.0) continue;
        const double u = k.fx * p_D.x() / p_D.z() + k.cx;
        const double v = k.fy * p_D.y() / p_D.z() + k.cy;
        seen_by += u >= margin && v >= margin && u <= k.width - 1 - margin &&
                   v <= k.height - 1 - margin;
      }
      if (seen_by < 2) continue;
      ++c.seen;
      c.covered += std::isfinite(index.Distance(p_G, 0.01));
    }
  }
  return c;
}

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::path(VILMA_BINARY_DIR) / "test-data" /
                       ("tsdf_fusion_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

}  // namespace

TEST_CASE("TSDF of a tilted plane seen from several views is that plane", "[tsdf]") {
  const Pinhole k;
  const Plane plane = testing::TiltedPlane();
  std::vector<Eigen::Matrix4d> views;
  for (int i = 0; i < 5; ++i) views.push_back(testing::PlaneViewPose(i));
  TsdfVolume volume(PlaneOptions());
  CHECK(volume.volume_units() == 0);
  for (const Eigen::Matrix4d& T_G_D : views) {
    const cv::Mat depth = testing::RenderPlaneDepth(k, T_G_D, plane);
    REQUIRE(depth.isContinuous());
    volume.Integrate(depth.ptr<float>(), nullptr, k.width, k.height, k.fx, k.fy, k.cx, k.cy, T_G_D);
  }
  CHECK(volume.volume_units() > 0);
  CHECK(volume.memory_mb() > 0.0);
  const TriangleMesh mesh = volume.ExtractMesh();
  REQUIRE(mesh.vertices.size() > 1000);
  REQUIRE(mesh.triangles.size() > 1000);
  CHECK(mesh.colors.size() == mesh.vertices.size());
  const double worst = WorstPlaneDistance(mesh, plane);
  const Coverage c = PlaneCoverage(mesh, plane, k, views, 16.0);
  INFO(mesh.vertices.size() << " vertices, worst distance to the plane " << worst << " m; "
                            << c.covered << " of " << c.seen << " seen samples covered");
  CHECK(worst < 0.01);
  REQUIRE(c.seen > 500);
  CHECK(c.covered == c.seen);
  // Up to the image borders the surface is ragged (marching cubes needs weight at all eight
  // corners of a voxel), but most of it is there.
  const Coverage to_border = PlaneCoverage(mesh, plane, k, views, 0.0);
  INFO(to_border.covered << " of " << to_border.seen << " samples seen up to the borders covered");
  CHECK(to_border.covered >= 0.8 * to_border.seen);
  // Gray without an image: the constant 0.7.
  for (const Eigen::Vector3d& rgb : mesh.colors) CHECK(rgb.x() == Approx(0.7).margin(1e-4));

  // Depth outside [min_depth_m, max_depth_m] is not fused: a range that excludes the plane
  // leaves the volume empty.
  TsdfOptions near = PlaneOptions();
  near.max_depth_m = 1.0;
  TsdfVolume empty(near);
  const cv::Mat depth = testing::RenderPlaneDepth(k, views[0], plane);
  empty.Integrate(depth.ptr<float>(), nullptr, k.width, k.height, k.fx, k.fy, k.cx, k.cy, views[0]);
  CHECK(empty.volume_units() == 0);
  CHECK(empty.ExtractMesh().triangles.empty());
}

TEST_CASE("fusing a map's depth resources", "[tsdf]") {
  const testing::PlaneMap m = testing::MakePlaneMap();
  const Pinhole k;
  const Plane plane = testing::TiltedPlane();
  TsdfSummary summary;
  const TsdfVolume volume = FuseDepthResources(m.map, {}, PlaneOptions(), &summary);
  INFO(summary.BriefReport());
  CHECK(summary.depth_maps == 5);
  CHECK(summary.missions == 1);
  CHECK(summary.skipped_no_depth == 0);
  CHECK(summary.milliseconds_per_integration.size() == 5);
  CHECK(summary.volume_units == volume.volume_units());
  CHECK(summary.memory_mb == volume.memory_mb());
  // Neighbours confirm most pixels; those only one view sees are left out.
  CHECK(summary.pixels_fused > 4 * k.width * k.height);
  CHECK(summary.pixels_filtered > 0);
  CHECK(summary.pixels_filtered < summary.pixels_fused / 4);
  CHECK_THAT(summary.BriefReport(), Catch::Contains("5 depth maps of 1 mission(s) fused") &&
                                        Catch::Contains("not confirmed by a neighbouring view"));

  const TriangleMesh mesh = volume.ExtractMesh();
  const double worst = WorstPlaneDistance(mesh, plane);
  const Coverage c = PlaneCoverage(mesh, plane, k, m.T_G_D, 16.0);
  INFO(mesh.vertices.size() << " vertices, worst distance to the plane " << worst << " m; "
                            << c.covered << " of " << c.seen << " seen samples covered");
  REQUIRE(mesh.triangles.size() > 1000);
  // Depth quantized to 1 mm: still within 1 cm of the plane.
  CHECK(worst < 0.01);
  REQUIRE(c.seen > 500);
  CHECK(c.covered == c.seen);

  // The same again, and with the mission named: the identical mesh.
  TsdfSummary again_summary;
  const TriangleMesh again =
      FuseDepthResources(m.map, {m.mission}, PlaneOptions(), &again_summary).ExtractMesh();
  CHECK(again.vertices == mesh.vertices);
  CHECK(again.triangles == mesh.triangles);
  CHECK(again.colors == mesh.colors);
  CHECK(again_summary.pixels_fused == summary.pixels_fused);
  CHECK(again_summary.pixels_filtered == summary.pixels_filtered);

  // Without the neighbour filter every pixel is fused.
  TsdfOptions unfiltered = PlaneOptions();
  unfiltered.filter.neighbours = 0;
  TsdfSummary all;
  FuseDepthResources(m.map, {}, unfiltered, &all);
  CHECK(all.pixels_filtered == 0);
  CHECK(all.pixels_fused == summary.pixels_fused + summary.pixels_filtered);
}

TEST_CASE("fusion refuses a map without depth and a volume beyond the memory bound", "[tsdf]") {
  testing::PlaneMapOptions no_depth;
  no_depth.depth = false;
  const testing::PlaneMap bare = testing::MakePlaneMap(no_depth);
  TsdfSummary summary;
  CHECK_THAT(InputErrorOf([&] { FuseDepthResources(bare.map, {}, PlaneOptions(), &summary); }),
             Catch::Contains("no frame") && Catch::Contains("stereo_dense_reconstruction") &&
                 Catch::Contains("import_tum_depth"));

  const testing::PlaneMap m = testing::MakePlaneMap();
  TsdfOptions tiny = PlaneOptions();
  tiny.max_memory_mb = 0.01;
  CHECK_THAT(InputErrorOf([&] { FuseDepthResources(m.map, {}, tiny, &summary); }),
             Catch::Contains("max_memory_mb") && Catch::Contains("after 1 of 5 depth maps"));

  // Invalid options are an InputError before anything is fused.
  TsdfOptions bad = PlaneOptions();
  bad.truncation_distance_m = 0.01;
  CHECK_THAT(InputErrorOf([&] { FuseDepthResources(m.map, {}, bad, &summary); }),
             Catch::Contains("truncation_distance_m"));
}

TEST_CASE("TSDF options validation", "[tsdf]") {
  CHECK(TsdfOptions().Validate().empty());
  CHECK(PlaneOptions().Validate().empty());
  auto invalid = [](auto change) {
    TsdfOptions o;
    change(o);
    return o.Validate();
  };
  using Catch::StartsWith;
  CHECK_THAT(invalid([](TsdfOptions& o) { o.voxel_size_m = 0.0; }), StartsWith("voxel_size_m:"));
  CHECK_THAT(invalid([](TsdfOptions& o) { o.voxel_size_m = std::nan(""); }), StartsWith("voxel_size_m:"));
  CHECK_THAT(invalid([](TsdfOptions& o) { o.truncation_distance_m = 0.05; }),
             StartsWith("truncation_distance_m:"));
  CHECK_THAT(invalid([](TsdfOptions& o) { o.min_depth_m = -0.1; }), StartsWith("min_depth_m"));
  CHECK_THAT(invalid([](TsdfOptions& o) { o.max_depth_m = 0.1; }), StartsWith("min_depth_m"));
  CHECK_THAT(invalid([](TsdfOptions& o) { o.volume_unit_resolution = 3; }),
             StartsWith("volume_unit_resolution:"));
  CHECK_THAT(invalid([](TsdfOptions& o) { o.volume_unit_resolution = 65; }),
             StartsWith("volume_unit_resolution:"));
  CHECK_THAT(invalid([](TsdfOptions& o) { o.depth_sampling_stride = 0; }),
             StartsWith("depth_sampling_stride:"));
  CHECK_THAT(invalid([](TsdfOptions& o) { o.max_memory_mb = 0.0; }), StartsWith("max_memory_mb:"));
  CHECK_THAT(invalid([](TsdfOptions& o) { o.filter.relative_tolerance = -1.0; }),
             StartsWith("filter.relative_tolerance:"));
  TsdfOptions o;
  o.voxel_size_m = -1.0;
  CHECK_THAT(InputErrorOf([&] { TsdfVolume v(o); }), Catch::Contains("voxel_size_m"));
}

TEST_CASE("mesh PLY: written atomically, read back, errors name the file", "[tsdf]") {
  const fs::path dir = TempDir("ply");
  TriangleMesh mesh;
  mesh.vertices = {{0.0, 0.0, 0.0}, {1.25, 0.0, 0.125}, {0.0, 1.0, -0.3}, {1.0, 1.0, 0.7}};
  mesh.triangles = {{0, 1, 2}, {1, 3, 2}};
  mesh.colors = {{0.0, 0.5, 1.0}, {1.0, 1.0, 1.0}, {0.2, 0.4, 0.6}, {0.0, 0.0, 0.0}};
  const std::string path = (dir / "mesh.ply").string();
  WriteMeshPly(mesh, path);
  CHECK(fs::is_regular_file(path));
  CHECK(!fs::exists(path + ".partial.ply"));
  open3d::geometry::TriangleMesh read;
  REQUIRE(open3d::io::ReadTriangleMesh(path, read));
  REQUIRE(read.vertices_.size() == 4);
  REQUIRE(read.triangles_.size() == 2);
  for (std::size_t i = 0; i < 4; ++i) {
    CHECK((read.vertices_[i] - mesh.vertices[i]).norm() < 1e-6);
    REQUIRE(read.vertex_colors_.size() == 4);
    CHECK((read.vertex_colors_[i] - mesh.colors[i]).cwiseAbs().maxCoeff() <= 0.5 / 255.0 + 1e-9);
  }
  CHECK(read.triangles_[0] == mesh.triangles[0]);
  CHECK(read.triangles_[1] == mesh.triangles[1]);

  // Written over: the new content.
  mesh.colors.clear();
  mesh.vertices[3] = {2.0, 2.0, 2.0};
  WriteMeshPly(mesh, path);
  open3d::geometry::TriangleMesh reread;
  REQUIRE(open3d::io::ReadTriangleMesh(path, reread));
  CHECK(reread.vertices_[3].x() == Approx(2.0));
  CHECK(!reread.HasVertexColors());

  // Under a regular file: an InputError naming the file; nothing left behind.
  const std::string blocker = (dir / "file").string();
  std::ofstream(blocker) << "not a folder";
  const std::string bad = blocker + "/mesh.ply";
  CHECK_THAT(InputErrorOf([&] { WriteMeshPly(mesh, bad); }), Catch::StartsWith(bad + ": "));
  // A folder in the way of the rename.
  fs::create_directories(dir / "folder.ply" / "inside");
  const std::string folder = (dir / "folder.ply").string();
  CHECK_THAT(InputErrorOf([&] { WriteMeshPly(mesh, folder); }), Catch::StartsWith(folder + ": "));
  CHECK(!fs::exists(folder + ".partial.ply"));
  // An empty mesh is refused with a message that says so.
  CHECK_THAT(InputErrorOf([&] { WriteMeshPly(TriangleMesh(), (dir / "empty.ply").string()); }),
             Catch::Contains("empty.ply") && Catch::Contains("no vertices"));
  CHECK(!fs::exists(dir / "empty.ply"));
  fs::remove_all(dir);
}

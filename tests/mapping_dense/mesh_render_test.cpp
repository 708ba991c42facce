#include "vilma/mapping/dense/mesh_render.h"

#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/TriangleMeshIO.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "vilma/core/error.h"

using namespace vilma;
using namespace vilma::mapping;
namespace fs = std::filesystem;

namespace {

const cv::Vec3b kWhite(255, 255, 255);

// A square in the x-z plane at y (facing -y, the front view's camera), half size s.
void AddSquareXZ(double y, double s, const Eigen::Vector3d& rgb, TriangleMesh* mesh) {
  const int base = static_cast<int>(mesh->vertices.size());
  mesh->vertices.push_back({-s, y, -s});
  mesh->vertices.push_back({s, y, -s});
  mesh->vertices.push_back({s, y, s});
  mesh->vertices.push_back({-s, y, s});
  for (int k = 0; k < 4; ++k) mesh->colors.push_back(rgb);
  mesh->triangles.push_back({base, base + 1, base + 2});
  mesh->triangles.push_back({base, base + 2, base + 3});
}

TriangleMesh UnitCube() {
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i)
    mesh.vertices.push_back({double(i & 1), double((i >> 1) & 1), double((i >> 2) & 1)});
  // Two triangles per face (corner indices: bit 0 x, bit 1 y, bit 2 z).
  const int faces[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    mesh.triangles.push_back({f[0], f[1], f[2]});
    mesh.triangles.push_back({f[0], f[2], f[3]});
  }
  return mesh;
}

fs::path TempDir() {
  const fs::path dir =
      fs::path(VILMA_BINARY_DIR) / "test-data" / ("mesh_render_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

}  // namespace

TEST_CASE("render mesh: a square facing the camera covers its projected rectangle", "[dense]") {
  TriangleMesh mesh;
  AddSquareXZ(0.0, 1.0, Eigen::Vector3d(0.6, 0.6, 0.6), &mesh);
  MeshRenderOptions options;
  options.view = "front";
  options.width_px = 320;
  options.height_px = 240;
  options.shading = GENERATE(std::string("flat"), std::string("gouraud"));
  INFO("shading " << options.shading);
  const MeshRenderResult r = RenderMeshImage(mesh, options);
  REQUIRE(r.image.type() == CV_8UC3);
  REQUIRE(r.image.cols == 320);
  REQUIRE(r.image.rows == 240);
  CHECK(r.triangles_drawn == 2);

  // The rectangle from the pinhole projection of the corners (+x right, +z up).
  Eigen::Vector2d lo, hi;
  REQUIRE(r.camera.Project({-1, 0, 1}, &lo));
  REQUIRE(r.camera.Project({1, 0, -1}, &hi));
  CHECK(lo.x() < hi.x());
  CHECK(lo.y() < hi.y());
  // The camera fits the box with a 5 % margin: the square spans 95 % of the height.
  CHECK(hi.y() - lo.y() == Approx(0.95 * 240).margin(1e-6));
  CHECK(hi.x() - lo.x() == Approx(0.95 * 240).margin(1e-6));
  int64_t inside_wrong = 0, outside_wrong = 0, expected_area = 0;
  for (int v = 0; v < r.image.rows; ++v) {
    for (int u = 0; u < r.image.cols; ++u) {
      const bool background = r.image.at<cv::Vec3b>(v, u) == kWhite;
      const bool deep_inside = u > lo.x() + 1 && u < hi.x() - 1 && v > lo.y() + 1 && v < hi.y() - 1;
      const bool far_outside = u < lo.x() - 1 || u > hi.x() + 1 || v < lo.y() - 1 || v > hi.y() + 1;
      if (deep_inside && background) ++inside_wrong;
      if (far_outside && !background) ++outside_wrong;
      if (u >= lo.x() && u <= hi.x() && v >= lo.y() && v <= hi.y()) ++expected_area;
    }
  }
  CHECK(inside_wrong == 0);
  CHECK(outside_wrong == 0);
  CHECK(std::abs(r.pixels_covered - expected_area) <= 2 * (hi.x() - lo.x() + hi.y() - lo.y()));
  // Headlight along the viewing axis: a face towards the camera gets the full shade, its
  // colour (0.6 * 255 = 153) everywhere.
  const cv::Vec3b grey(153, 153, 153);
  CHECK(r.image.at<cv::Vec3b>(120, 160) == grey);
  CHECK(r.image.at<cv::Vec3b>(static_cast<int>(std::ceil(lo.y())) + 1,
                              static_cast<int>(std::ceil(lo.x())) + 1) == grey);

  // Turned by 60 deg about z: shade = ambient + (1 - ambient) cos 60 = 0.625 -> 0.6 * 0.625 *
  // 255 = 95.6.
  TriangleMesh turned = mesh;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 3.0, Eigen::Vector3d::UnitZ()).matrix();
  for (Eigen::Vector3d& v : turned.vertices) v = R * v;
  const MeshRenderResult t = RenderMeshImage(turned, options);
  const cv::Vec3b shaded = t.image.at<cv::Vec3b>(120, 160);
  for (int k = 0; k < 3; ++k) CHECK(std::abs(int(shaded[k]) - 96) <= 1);
}

TEST_CASE("render mesh: the nearer triangle wins, whatever the drawing order", "[dense]") {
  const Eigen::Vector3d red(1, 0, 0), blue(0, 0, 1);
  for (const bool near_first : {true, false}) {
    TriangleMesh mesh;
    // The front camera looks along +y: y = -0.5 is nearer than y = 0.5.
    if (near_first) AddSquareXZ(-0.5, 0.25, red, &mesh);
    AddSquareXZ(0.5, 1.0, blue, &mesh);
    if (!near_first) AddSquareXZ(-0.5, 0.25, red, &mesh);
    MeshRenderOptions options;
    options.view = "front";
    options.width_px = options.height_px = 200;
    const MeshRenderResult r = RenderMeshImage(mesh, options);
    INFO("near first " << near_first);
    const cv::Vec3b centre = r.image.at<cv::Vec3b>(100, 100);  // BGR
    CHECK(centre[2] > 200);
    CHECK(centre[0] == 0);
    // Beside the red square, inside the blue one: blue.
    Eigen::Vector2d edge;
    REQUIRE(r.camera.Project({0.9, 0.5, 0.0}, &edge));
    Eigen::Vector2d red_edge;
    REQUIRE(r.camera.Project({0.25, -0.5, 0.0}, &red_edge));
    REQUIRE(edge.x() > red_edge.x() + 5);
    const cv::Vec3b side = r.image.at<cv::Vec3b>(100, static_cast<int>(std::lround(edge.x())));
    CHECK(side[0] > 150);
    CHECK(side[2] == 0);
    CHECK(r.triangles_drawn == 4);
  }
}

TEST_CASE("render mesh: views and flat shading of a cube", "[dense]") {
  const TriangleMesh cube = UnitCube();
  MeshRenderOptions options;
  options.width_px = 400;
  options.height_px = 300;
  options.shading = "flat";
  const MeshRenderResult r = RenderMeshImage(cube, options);  // auto: 3/4 from above
  // Three faces in sight, each one flat shade: three colours besides the background (edge
  // pixels are whole pixels of one face, no anti-aliasing).
  std::set<std::array<uchar, 3>> colours;
  for (int v = 0; v < r.image.rows; ++v) {
    for (int u = 0; u < r.image.cols; ++u) {
      const cv::Vec3b p = r.image.at<cv::Vec3b>(v, u);
      if (p != kWhite) colours.insert({p[0], p[1], p[2]});
    }
  }
  CHECK(colours.size() == 3);
  CHECK(r.image.at<cv::Vec3b>(0, 0) == kWhite);
  CHECK(r.image.at<cv::Vec3b>(150, 200) != kWhite);
  CHECK(r.pixels_covered > 0.1 * 400 * 300);
  // The top face (z = 1) is seen: its centre projects to a covered pixel, the bottom's is hidden
  // behind the cube but also projects inside it.
  Eigen::Vector2d top;
  REQUIRE(r.camera.Project({0.5, 0.5, 1.0}, &top));
  CHECK(r.image.at<cv::Vec3b>(static_cast<int>(top.y()), static_cast<int>(top.x())) != kWhite);

  // Picture axes of the named views.
  struct Axes {
    std::string view;
    Eigen::Vector3d right, up;
  };
  for (const Axes& a : {Axes{"top", {1, 0, 0}, {0, 1, 0}}, Axes{"front", {1, 0, 0}, {0, 0, 1}},
                        Axes{"side", {0, 1, 0}, {0, 0, 1}}}) {
    options.view = a.view;
    const MeshRenderCamera cam = MakeMeshRenderCamera(cube, options);
    Eigen::Vector2d c, right, up;
    REQUIRE(cam.Project({0.5, 0.5, 0.5}, &c));
    REQUIRE(cam.Project(Eigen::Vector3d(0.5, 0.5, 0.5) + 0.3 * a.right, &right));
    REQUIRE(cam.Project(Eigen::Vector3d(0.5, 0.5, 0.5) + 0.3 * a.up, &up));
    INFO("view " << a.view);
    CHECK(c.x() == Approx(199.5));
    CHECK(c.y() == Approx(149.5));
    CHECK(right.x() > c.x() + 10);
    CHECK(std::abs(right.y() - c.y()) < 1e-6);
    CHECK(up.y() < c.y() - 10);
    CHECK(std::abs(up.x() - c.x()) < 1e-6);
  }
  // custom with the auto angles is auto.
  options.view = "custom";
  options.azimuth_deg = -60.0;
  options.elevation_deg = 35.0;
  const MeshRenderResult custom = RenderMeshImage(cube, options);
  options.view = "auto";
  CHECK(cv::norm(custom.image, RenderMeshImage(cube, options).image, cv::NORM_INF) == 0.0);
}

TEST_CASE("render mesh: PLY in, PNG out, and bad input", "[dense]") {
  const fs::path dir = TempDir();
  // A coloured PLY through Open3D.
  open3d::geometry::TriangleMesh o3d;
  TriangleMesh cube = UnitCube();
  o3d.vertices_ = cube.vertices;
  o3d.triangles_ = cube.triangles;
  o3d.vertex_colors_.assign(cube.vertices.size(), Eigen::Vector3d(0.2, 0.6, 0.9));
  const std::string ply = (dir / "cube.ply").string();
  REQUIRE(open3d::io::WriteTriangleMesh(ply, o3d));
  const TriangleMesh read = ReadMeshFile(ply);
  CHECK(read.vertices.size() == 8);
  CHECK(read.triangles.size() == 12);
  REQUIRE(read.colors.size() == 8);
  CHECK(read.colors[3].isApprox(Eigen::Vector3d(0.2, 0.6, 0.9), 1e-2));
  const MeshRenderResult r = RenderMeshImage(read, MeshRenderOptions());
  const std::string png = (dir / "cube.png").string();
  WritePngAtomically(png, r.image);
  const cv::Mat back = cv::imread(png, cv::IMREAD_UNCHANGED);
  REQUIRE(back.type() == CV_8UC3);
  CHECK(cv::norm(back, r.image, cv::NORM_INF) == 0.0);
  // Vertex colours multiply the shade: blue dominates.
  const cv::Vec3b centre = r.image.at<cv::Vec3b>(r.image.rows / 2, r.image.cols / 2);
  CHECK(centre[0] > centre[1]);
  CHECK(centre[1] > centre[2]);

  // Files: missing, not a mesh, a point cloud.
  const std::string missing = (dir / "missing.ply").string();
  CHECK_THROWS_AS(ReadMeshFile(missing), InputError);
  CHECK_THROWS_WITH(ReadMeshFile(missing), Catch::Contains("missing.ply"));
  const std::string garbage = (dir / "garbage.ply").string();
  std::ofstream(garbage) << "this is not a mesh\n";
  CHECK_THROWS_AS(ReadMeshFile(garbage), InputError);
  CHECK_THROWS_WITH(ReadMeshFile(garbage), Catch::Contains("garbage.ply"));
  const std::string cloud = (dir / "cloud.ply").string();
  std::ofstream(cloud) << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                          "property float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
  CHECK_THROWS_AS(ReadMeshFile(cloud), InputError);
  CHECK_THROWS_WITH(ReadMeshFile(cloud),
                    Catch::Contains("cloud.ply") && Catch::Contains("no triangle"));
  CHECK_THROWS_AS(WritePngAtomically((dir / "no-such-folder" / "x.png").string(), r.image),
                  InputError);

  // Meshes and options.
  TriangleMesh bad = cube;
  bad.triangles.push_back({0, 1, 8});
  CHECK_THAT(bad.Validate(), Catch::Contains("triangle 12"));
  CHECK_THROWS_AS(RenderMeshImage(bad, MeshRenderOptions()), std::invalid_argument);
  bad = cube;
  bad.colors.resize(3);
  CHECK_THAT(bad.Validate(), Catch::Contains("colors"));
  CHECK_THAT(TriangleMesh().Validate(), Catch::Contains("triangles"));
  bad = cube;
  bad.vertices[0].x() = std::nan("");
  CHECK_THAT(bad.Validate(), Catch::Contains("finite"));
  MeshRenderOptions o;
  o.view = "diagonal";
  CHECK_THAT(o.Validate(), Catch::Contains("view"));
  CHECK_THROWS_AS(RenderMeshImage(cube, o), std::invalid_argument);
  o = MeshRenderOptions();
  o.width_px = 0;
  CHECK_THAT(o.Validate(), Catch::Contains("width_px"));
  o = MeshRenderOptions();
  o.fov_deg = 180.0;
  CHECK_THAT(o.Validate(), Catch::Contains("fov_deg"));
  o = MeshRenderOptions();
  o.shading = "phong";
  CHECK_THAT(o.Validate(), Catch::Contains("shading"));
  fs::remove_all(dir);
}

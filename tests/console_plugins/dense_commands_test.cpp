// The dense chain in the console on the stereo test map (keyframed to a quarter of its vertices
// to keep the test short): attach_images, stereo_dense_reconstruction,
// create_tsdf_from_depth_resource, export_tsdf, eval_mesh, depth_consistency, render_mesh; and
// what must fail: stereo on a mono map (map unchanged), export_tsdf without a TSDF, after a
// command that changed the map, and to a path that cannot be written. attach_true_depth (ray-cast
// depth) fused and judged with eval_mesh --error_mesh_output_file; attach_true_depth without a
// simulated dataset or with a camera the rig lacks fails and leaves the map unchanged.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/TriangleMeshIO.h>

#include "console_plugins/test_maps.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;
using Catch::Contains;
using Fixture = test::ConsoleFixture;

// The number after `label` in `text` (NaN when absent).
double NumberAfter(const std::string& text, const std::string& label) {
  const std::size_t at = text.find(label);
  if (at == std::string::npos) return std::nan("");
  return std::stod(text.substr(at + label.size()));
}

// The output of one command line (the fixture's stdout since the call).
std::string RunOk(Fixture& f, const std::string& line) {
  const std::size_t before = f.out.str().size();
  const CommandResult r = f.Run(line);
  INFO(line << "\n" << f.err.str());
  REQUIRE(r.ok());
  return f.out.str().substr(before);
}

struct DepthState {
  std::size_t depth_frames = 0;
  std::size_t resources = 0;
  std::vector<mapstore::ResourceId> ids;
};

DepthState Depths(const mapstore::VIMap& map) {
  DepthState s;
  for (const mapstore::MissionId& m : map.mission_ids()) {
    for (const mapstore::VertexId& v : map.vertex_ids(m)) {
      for (const mapstore::VisualFrame& frame : map.vertex(v).frames) {
        s.ids.push_back(frame.depth_resource_id);
        s.depth_frames += frame.depth_resource_id.IsValid();
      }
    }
  }
  s.resources = map.resources().List().size();
  return s;
}

TEST_CASE("dense chain: stereo depth, TSDF, mesh export, evaluation and picture") {
  const auto& maps = test::TestMaps();
  const std::string dir = test::ConsoleScratch("dense_chain");
  Fixture f;
  REQUIRE(f.Run("load " + maps.stereo_map).ok());
  RunOk(f, "keyframe_heuristic --kf_every_nth_vertex 4 --kf_distance_threshold_m 100 "
           "--kf_rotation_threshold_deg 180");
  const std::size_t vertices = f.map().num_vertices();
  REQUIRE(vertices >= 15);
  REQUIRE(vertices <= 40);

  // Without a TSDF there is nothing to export.
  CommandResult r = f.Run("export_tsdf " + dir + "/early.ply");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Contains("no TSDF") && Contains("create_tsdf_from_depth_resource"));
  CHECK(!fs::exists(dir + "/early.ply"));

  RunOk(f, "attach_images " + maps.stereo_dataset);
  const std::string stereo = RunOk(f, "stereo_dense_reconstruction");
  CHECK_THAT(stereo, Contains(std::to_string(vertices) + " depth maps from 1 stereo pair(s)"));
  const DepthState depths = Depths(f.map());
  CHECK(depths.depth_frames == vertices);  // the left camera of each vertex
  CHECK(NumberAfter(stereo, " vertices (") > 50.0);  // % of pixels with depth

  const std::string tsdf = RunOk(f, "create_tsdf_from_depth_resource --dense_tsdf_voxel_size_m 0.1");
  CHECK_THAT(tsdf, Contains("TSDF: " + std::to_string(vertices) + " depth maps of 1 mission(s) fused"));

  const std::string mesh = dir + "/mesh.ply";
  const std::string exported = RunOk(f, "export_tsdf " + mesh);
  CHECK_THAT(exported, Contains("wrote " + mesh));
  const double mesh_vertices = NumberAfter(exported, mesh + ": ");
  CHECK(mesh_vertices > 1000);
  REQUIRE(fs::is_regular_file(mesh));
  CHECK(test::ReadTextFile(mesh).rfind("ply\n", 0) == 0);
  CHECK(!fs::exists(mesh + ".partial.ply"));
  // Where no file can be written: an error naming the path; the TSDF stays.
  std::ofstream(dir + "/blocker") << "a file, not a folder";
  r = f.Run("export_tsdf " + dir + "/blocker/mesh.ply");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Contains(dir + "/blocker/mesh.ply"));

  // The mesh against the simulated world (map aligned to ground truth by its vertices):
  // a 10 s VIO map with SGBM depth is good to centimetres and sees a fair part of the room.
  const std::string json = dir + "/eval.json";
  const std::string eval = RunOk(f, "eval_mesh " + maps.stereo_dataset + " --align posyaw --json " + json);
  INFO(eval);
  const double accuracy = NumberAfter(eval, "accuracy (to the true surfaces) median ");
  const double accuracy_p90 = NumberAfter(eval, " m, p90 ");
  const double completeness = NumberAfter(eval, "completeness ");
  CHECK(accuracy > 0.0);
  CHECK(accuracy < 0.10);
  CHECK(accuracy_p90 >= accuracy);
  CHECK(accuracy_p90 < 0.3);
  CHECK(completeness > 20.0);
  CHECK(completeness <= 100.0);
  CHECK(NumberAfter(eval, "mesh: ") == mesh_vertices);
  CHECK_THAT(test::ReadTextFile(json), Contains("\"accuracy_median_m\": ") && Contains("\"completeness\": "));
  // The exported file gives the same figures as the session's TSDF.
  const std::string from_file =
      RunOk(f, "eval_mesh " + maps.stereo_dataset + " --align posyaw --mesh " + mesh);
  CHECK(from_file.substr(0, from_file.find('\n')) == eval.substr(0, eval.find('\n')));

  const std::string consistency = RunOk(f, "depth_consistency");
  INFO(consistency);
  CHECK_THAT(consistency, Contains("over " + std::to_string(vertices - 1) + " neighbouring keyframe pairs"));
  CHECK(NumberAfter(consistency, "overlapping points: median ") < 0.1);
  CHECK(NumberAfter(consistency, "median relative ") < 5.0);

  const std::string picture = dir + "/mesh.png";
  const std::string rendered = RunOk(f, "render_mesh " + mesh + " " + picture);
  CHECK_THAT(rendered, Contains("triangles drawn"));
  CHECK(fs::file_size(picture) > 1000);

  // A command that changes the map drops the TSDF: export_tsdf and eval_mesh without --mesh
  // then refuse.
  RunOk(f, "reset_landmark_quality");
  r = f.Run("export_tsdf " + dir + "/late.ply");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Contains("no TSDF"));
  CHECK(!fs::exists(dir + "/late.ply"));
  r = f.Run("eval_mesh " + maps.stereo_dataset);
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Contains("create_tsdf_from_depth_resource"));
  // ... and a failed modifying command (the map unchanged) keeps it.
  RunOk(f, "create_tsdf_from_depth_resource --dense_tsdf_voxel_size_m 0.3");
  r = f.Run("stereo_dense_reconstruction --sgbm_block_size 4");
  CHECK(r.outcome == CommandOutcome::kFailed);
  RunOk(f, "export_tsdf " + dir + "/coarse.ply");
}

TEST_CASE("stereo_dense_reconstruction refuses a mono map and leaves it unchanged") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const DepthState before = Depths(f.map());
  const CommandResult r = f.Run("stereo_dense_reconstruction");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Contains("no camera pair"));
  const DepthState after = Depths(f.map());
  CHECK(after.depth_frames == 0);
  CHECK(after.ids == before.ids);
  CHECK(after.resources == before.resources);
  // No depth at all: fusion says where depth comes from.
  const CommandResult tsdf = f.Run("create_tsdf_from_depth_resource");
  CHECK(tsdf.outcome == CommandOutcome::kFailed);
  CHECK_THAT(tsdf.message, Contains("stereo_dense_reconstruction") && Contains("import_tum_depth"));
  const CommandResult consistency = f.Run("depth_consistency");
  CHECK(consistency.outcome == CommandOutcome::kFailed);
  CHECK_THAT(consistency.message, Contains("no two consecutive vertices have depth maps"));
}

TEST_CASE("attach_true_depth: true depth fused and judged with an error mesh, and what must fail") {
  const auto& maps = test::TestMaps();
  const std::string dir = test::ConsoleScratch("dense_true_depth");
  Fixture f;
  REQUIRE(f.Run("load " + maps.stereo_map).ok());
  // Ray-casting takes 0.4 s per depth map: every 10th vertex.
  RunOk(f, "keyframe_heuristic --kf_every_nth_vertex 10 --kf_distance_threshold_m 100 "
           "--kf_rotation_threshold_deg 180");
  const std::size_t vertices = f.map().num_vertices();
  REQUIRE(vertices >= 8);

  // Without a simulated dataset (none given, a folder without sim.yaml) or with a camera the
  // rig lacks: an error, the map unchanged.
  const DepthState before = Depths(f.map());
  CHECK(before.depth_frames == 0);
  for (const std::string& line :
       {std::string("attach_true_depth"), "attach_true_depth " + maps.stereo_map,
        "attach_true_depth " + dir + "/nowhere"}) {
    INFO(line);
    const CommandResult r = f.Run(line);
    CHECK(r.outcome == CommandOutcome::kFailed);
    CHECK_THAT(r.message, Contains("--dataset: expected a vilma-sim dataset folder (sim.yaml)"));
  }
  CommandResult r = f.Run("attach_true_depth " + maps.stereo_dataset + " --camera 2");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Contains("cameras: expected indices below 2, found 2"));
  r = f.Run("attach_true_depth " + maps.stereo_dataset + " --max_depth_m 0");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Contains("max_depth_m"));
  const DepthState unchanged = Depths(f.map());
  CHECK(unchanged.depth_frames == 0);
  CHECK(unchanged.ids == before.ids);
  CHECK(unchanged.resources == before.resources);

  // The test map is a VIO map (its frame G is not the simulator's world W), so the ray-cast
  // depth is not the true depth of what the cameras saw: only that the chain runs is checked.
  const std::string attached = RunOk(f, "attach_true_depth " + maps.stereo_dataset + " --camera 1");
  CHECK_THAT(attached, Contains(std::to_string(vertices) + " true depth maps attached (camera 1)"));
  const DepthState after = Depths(f.map());
  CHECK(after.depth_frames == vertices);
  CHECK(after.resources == before.resources + vertices);

  // Views 1 s apart: no neighbour filter, surface seen once kept.
  const std::string tsdf = RunOk(f, "create_tsdf_from_depth_resource --dense_tsdf_voxel_size_m 0.1 "
                                    "--dense_depth_filter_neighbours 0 --dense_mesh_min_weight 1");
  CHECK_THAT(tsdf, Contains("TSDF: " + std::to_string(vertices) + " depth maps of 1 mission(s) fused"));

  // The depth was cast from the map's poses as if G were W, so without alignment the fused
  // surface lies on the world's (1 mm median, 2.5 cm p90 with 10 cm voxels when written).
  const std::string exact = RunOk(f, "eval_mesh " + maps.stereo_dataset + " --align none");
  INFO(exact);
  CHECK(NumberAfter(exact, "accuracy (to the true surfaces) median ") < 0.01);
  CHECK(NumberAfter(exact, " m, p90 ") < 0.05);
  CHECK(NumberAfter(exact, "completeness ") > 50.0);

  const std::string error_mesh = dir + "/error.ply";
  const std::string eval = RunOk(f, "eval_mesh " + maps.stereo_dataset +
                                        " --align posyaw --error_mesh_output_file " + error_mesh +
                                        " --error_mesh_red_at_m 0.05");
  INFO(eval);
  CHECK_THAT(eval, Contains("wrote " + error_mesh));
  const double mesh_vertices = NumberAfter(eval, "mesh: ");
  CHECK(mesh_vertices > 1000);
  REQUIRE(fs::is_regular_file(error_mesh));
  CHECK(!fs::exists(error_mesh + ".partial.ply"));
  const std::string header = test::ReadTextFile(error_mesh).substr(0, 400);
  CHECK_THAT(header, Contains("property uchar red") && Contains("property uchar green") &&
                         Contains("property uchar blue"));
  open3d::geometry::TriangleMesh read;
  REQUIRE(open3d::io::ReadTriangleMesh(error_mesh, read));
  CHECK(static_cast<double>(read.vertices_.size()) == mesh_vertices);
  CHECK(!read.triangles_.empty());
  REQUIRE(read.vertex_colors_.size() == read.vertices_.size());
  // Green (0 error) to red (>= 5 cm) through yellow, a little blue: one of red and green is full.
  int off_scale = 0, green = 0, red = 0;
  for (const Eigen::Vector3d& c : read.vertex_colors_) {
    off_scale += std::abs(c.z() - 0.1) > 0.01 || std::max(c.x(), c.y()) < 0.99;
    green += c.x() < 0.5;
    red += c.y() < 0.5;
  }
  CHECK(off_scale == 0);
  CHECK(green + red > 0);
}

}  // namespace
}  // namespace vilma::console

// The dense chain in the console on the stereo test map (keyframed to a quarter of its vertices
// to keep the test short): attach_images, stereo_dense_reconstruction,
// create_tsdf_from_depth_resource, export_tsdf, eval_mesh, depth_consistency, render_mesh; and
// what must fail: stereo on a mono map (map unchanged), export_tsdf without a TSDF, after a
// command that changed the map, and to a path that cannot be written.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>

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

}  // namespace
}  // namespace vilma::console

#include "vilma/sim/world.h"
#include "vilma/sim/world_file.h"

#include <catch2/catch.hpp>
#include <cstdio>
#include <fstream>

#include "vilma/core/error.h"

using Eigen::Vector3d;
using vilma::sim::World;

TEST_CASE("presets are valid and deterministic", "[sim][world]") {
  for (const std::string& name : vilma::sim::PresetNames()) {
    INFO(name);
    const World a = vilma::sim::MakePresetWorld(name, 3);
    const World b = vilma::sim::MakePresetWorld(name, 3);
    CHECK(a.Validate().empty());
    REQUIRE(a.quads.size() == b.quads.size());
    for (size_t i = 0; i < a.quads.size(); ++i) CHECK(a.quads[i].origin_W == b.quads[i].origin_W);
    CHECK(a.quads.size() > 20);
  }
  CHECK_THROWS_AS(vilma::sim::MakePresetWorld("cave", 1), vilma::InputError);
}

TEST_CASE("box faces point outward and the room shell inward", "[sim][world]") {
  World w;
  w.AddRoomShell(Vector3d(-2, -2, 0), Vector3d(2, 2, 3), 0.05, 1);
  const Vector3d room_centre(0, 0, 1.5);
  for (const auto& q : w.quads) {
    const Vector3d c = q.origin_W + 0.5 * (q.edge_u_W + q.edge_v_W);
    CHECK(q.Normal().dot(room_centre - c) > 0.0);
  }
  const size_t n = w.quads.size();
  const Vector3d box_centre(0.5, -0.3, 0.4);
  w.AddBox(box_centre, Vector3d(0.6, 0.4, 0.8), 0.4, 0.05, 2, false);
  REQUIRE(w.quads.size() == n + 6);
  for (size_t i = n; i < w.quads.size(); ++i) {
    const auto& q = w.quads[i];
    const Vector3d c = q.origin_W + 0.5 * (q.edge_u_W + q.edge_v_W);
    CHECK(q.Normal().dot(c - box_centre) > 0.0);
  }
  // Ray casts: from the centre along +x hits the wall at x = 2 (the box is elsewhere).
  CHECK(w.RayCast(room_centre, Vector3d::UnitX()) == Approx(2.0));
  CHECK(w.RayCast(room_centre, -Vector3d::UnitZ()) == Approx(1.5));
  // Towards the box (top face at z = 0.8).
  CHECK(w.RayCast(Vector3d(0.5, -0.3, 2.0), -Vector3d::UnitZ()) == Approx(1.2));
  w.motion.free_space = Eigen::AlignedBox3d(Vector3d(-1.5, -1.5, 0.5), Vector3d(1.5, 1.5, 2.5));
  CHECK(w.IsFree(Vector3d(-1, 1, 1.5), 0.3));
  CHECK_FALSE(w.IsFree(Vector3d(0.5, -0.3, 1.0), 0.3));  // right above the box
  CHECK_FALSE(w.IsFree(Vector3d(0, 0, 3.0), 0.3));       // outside the free space
}

TEST_CASE("world YAML loads and rejects unknown keys", "[sim][world]") {
  const std::string path = "/tmp/vilma_sim_world_test.yaml";
  {
    std::ofstream f(path);
    f << "name: test\nbackground: 50\n"
         "rooms:\n  - {min: [-3, -3, 0], max: [3, 3, 2.5], texel_size: 0.05}\n"
         "boxes:\n  - {center: [1, 1, 0.5], size: [1, 1, 1]}\n"
         "quads:\n  - {origin: [0, -2.9, 1], edge_u: [0.5, 0, 0], edge_v: [0, 0, 0.5], texture: checker}\n"
         "free_space: {min: [-2, -2, 0.5], max: [2, 2, 2]}\n"
         "motion: {mean_speed: 0.5}\n";
  }
  const World w = vilma::sim::LoadWorldYaml(path, 1);
  CHECK(w.name == "test");
  CHECK(w.quads.size() == 6 + 5 + 1);
  CHECK(w.motion.mean_speed == 0.5);
  CHECK(w.texture_specs.back().kind == vilma::sim::TextureKind::kChecker);
  {
    std::ofstream f(path);
    f << "quads:\n  - {origin: [0, 0, 0], edge_u: [1, 0, 0], edge_v: [0, 1, 0], colour: 3}\n"
         "free_space: {min: [-2, -2, 0.5], max: [2, 2, 2]}\n";
  }
  CHECK_THROWS_AS(vilma::sim::LoadWorldYaml(path, 1), vilma::InputError);
  std::remove(path.c_str());
}

TEST_CASE("DistanceToQuad: inside, beside an edge, beyond a corner, DistanceToWorld the nearest") {
  vilma::sim::Quad q;  // the unit square in z = 0
  CHECK(vilma::sim::DistanceToQuad(q, Eigen::Vector3d(0.5, 0.5, 0.3)) == Approx(0.3));
  CHECK(vilma::sim::DistanceToQuad(q, Eigen::Vector3d(1.4, 0.5, 0.3)) == Approx(0.5));
  CHECK(vilma::sim::DistanceToQuad(q, Eigen::Vector3d(-0.3, -0.4, 0.0)) == Approx(0.5));
  vilma::sim::World world;
  world.quads.push_back(q);
  vilma::sim::Quad far = q;
  far.origin_W = Eigen::Vector3d(0, 0, 2);
  world.quads.push_back(far);
  CHECK(vilma::sim::DistanceToWorld(world, Eigen::Vector3d(0.5, 0.5, 1.5)) == Approx(0.5));
}

TEST_CASE("world file: a description round-trips and builds the same world",
          "[sim][world][options]") {
  const std::string text =
      "name: \"round trip\"\nbackground: 50.5\n"
      "rooms:\n  - {min: [-3, -3, 0], max: [3, 3, 2.5], texel_size: 0.05, ceiling: false}\n"
      "boxes:\n  - {center: [1, 1, 0.5], size: [1, 0.3, 1], yaw: 0.7}\n"
      "quads:\n  - {origin: [0, -2.9, 1], edge_u: [0.5, 0, 0], edge_v: [0, 0, 0.5], "
      "texture: checker, mean: 90, contrast: 0.3, two_sided: true}\n"
      "free_space: {min: [-2, -2, 0.5], max: [2, 2, 2]}\n"
      "route: [[0, 0, 1], [1, 0, 1], [1, 1, 1.1]]\n"
      "motion: {mean_speed: 0.5, clearance: 0.33333333333333331}\n";
  const auto description =
      vilma::sim::ReadWorldDescription(vilma::YamlNode::LoadString(text, "w.yaml"));
  const std::string yaml = vilma::sim::WorldDescriptionToYaml(description);
  const auto back = vilma::sim::ReadWorldDescription(vilma::YamlNode::LoadString(yaml, "w2.yaml"));
  CHECK(vilma::sim::WorldDescriptionToYaml(back) == yaml);
  CHECK(back.name == "round trip");
  CHECK(back.background == 50.5);
  REQUIRE(back.rooms.size() == 1);
  CHECK_FALSE(back.rooms[0].ceiling);
  REQUIRE(back.boxes.size() == 1);
  CHECK(back.boxes[0].yaw == 0.7);
  REQUIRE(back.quads.size() == 1);
  CHECK(back.quads[0].texture == "checker");
  CHECK(back.quads[0].two_sided);
  CHECK(back.motion.route_W.size() == 3);
  CHECK(back.motion.clearance == 1.0 / 3.0);
  CHECK(back.motion.free_space.max() == Vector3d(2, 2, 2));
  // The same description and seed: the same world, quad for quad and texture for texture.
  const World a = vilma::sim::BuildWorld(description, 5);
  const World b = vilma::sim::BuildWorld(back, 5);
  REQUIRE(a.quads.size() == b.quads.size());
  for (std::size_t i = 0; i < a.quads.size(); ++i) {
    CHECK(a.quads[i].origin_W == b.quads[i].origin_W);
    CHECK(a.quads[i].edge_u_W == b.quads[i].edge_u_W);
  }
  REQUIRE(a.texture_specs.size() == b.texture_specs.size());
  for (std::size_t i = 0; i < a.texture_specs.size(); ++i) {
    CHECK(a.texture_specs[i].seed == b.texture_specs[i].seed);
  }
  // Unknown keys at every level name the key.
  CHECK_THROWS_WITH(vilma::sim::ReadWorldDescription(vilma::YamlNode::LoadString(
                        text + "motion_x: 1\n", "w.yaml")),
                    Catch::Contains("w.yaml") && Catch::Contains("motion_x"));
  CHECK_THROWS_WITH(vilma::sim::ReadWorldDescription(vilma::YamlNode::LoadString(
                        "free_space: {min: [0, 0, 0], max: [1, 1, 1]}\nmotion: {speed: 1}\n",
                        "w.yaml")),
                    Catch::Contains("motion") && Catch::Contains("speed"));
}

// The world YAML file (vilma-sim --world FILE, docs/simulator.md "World files"): what a user
// declares (rooms, boxes, quads, free space, route, motion hints) as a plain description, read
// strictly (unknown key -> error naming file, key path and the known keys), written back by
// WorldDescriptionToYaml (a description round-trips), and built into a World by BuildWorld.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/yaml_io.h"
#include "vilma/sim/world.h"

namespace vilma::sim {

struct WorldRoomSpec {  // an inward-facing box: walls, floor and (optionally) ceiling
  Eigen::Vector3d min_W = Eigen::Vector3d::Zero();  // [m]
  Eigen::Vector3d max_W = Eigen::Vector3d::Ones();  // [m]
  double texel_size = 0.015;                         // [m]
  bool ceiling = true;
};

struct WorldBoxSpec {  // an obstacle: six outward faces, rotated by yaw about z
  Eigen::Vector3d center_W = Eigen::Vector3d::Zero();  // [m]
  Eigen::Vector3d size = Eigen::Vector3d::Ones();      // [m], > 0
  double yaw = 0.0;                                    // [rad]
  double texel_size = 0.015;                           // [m]
};

struct WorldQuadSpec {  // one textured parallelogram
  Eigen::Vector3d origin_W = Eigen::Vector3d::Zero();  // [m]
  Eigen::Vector3d edge_u_W = Eigen::Vector3d::UnitX();
  Eigen::Vector3d edge_v_W = Eigen::Vector3d::UnitY();
  double texel_size = 0.015;  // [m]
  double mean = 128.0;        // texture mean intensity
  double contrast = 1.0;
  bool two_sided = false;
  std::string texture = "natural";  // natural, checker or uniform
};

struct WorldDescription {
  std::string name = "custom";
  double background = 200.0;  // intensity of rays that hit nothing
  std::vector<WorldRoomSpec> rooms;
  std::vector<WorldBoxSpec> boxes;
  std::vector<WorldQuadSpec> quads;
  // free_space (required in a file), route_W and the motion hints.
  MotionHints motion;
};

// Reads a world file's root node; throws InputError naming file and key.
WorldDescription ReadWorldDescription(const YamlNode& root);
// YAML that ReadWorldDescription reads back to an equal description.
std::string WorldDescriptionToYaml(const WorldDescription& description);
// The world of a description; `seed` fixes the textures (the same seed, the same world).
// Throws InputError (naming `source`) when the world is not valid (World::Validate).
World BuildWorld(const WorldDescription& description, uint64_t seed,
                 const std::string& source = "world");

}  // namespace vilma::sim

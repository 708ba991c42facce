// The simulated world: a list of textured quads in the world frame W (z up, gravity -z).
// A box is six quads. Presets: `room` (EuRoC Vicon-room-like, 8 x 8 x 3 m), `hall`
// (machine-hall-like, 30 x 20 x 10 m with pillars and clutter) and `street` (a city block
// with a ~150 m walkable loop around it, facades, far depths). See docs/simulator.md.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vilma/sim/texture.h"

namespace vilma {
namespace sim {

// A planar parallelogram X(s, t) = origin + s * edge_u + t * edge_v, s, t in [0, 1], with
// texture coordinates (s * width, t * height). Visible from the side its normal
// edge_u x edge_v points to, or from both sides when two_sided.
struct Quad {
  Eigen::Vector3d origin_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d edge_u_W = Eigen::Vector3d::UnitX();  // [m]
  Eigen::Vector3d edge_v_W = Eigen::Vector3d::UnitY();  // [m]
  bool two_sided = false;
  int texture_index = 0;

  Eigen::Vector3d Normal() const { return edge_u_W.cross(edge_v_W).normalized(); }
};

// How trajectories move in this world (filled by the presets; the trajectory generator reads it).
struct MotionHints {
  // Region the body may occupy (already shrunk by the wall clearance).
  Eigen::AlignedBox3d free_space;
  // Closed route (polyline, world frame) to follow instead of a random walk; empty: random walk.
  std::vector<Eigen::Vector3d> route_W;
  double mean_speed = 1.0;        // [m/s]
  double max_yaw_rate = 1.0;      // [rad/s]
  double roll_pitch_amplitude = 0.12;  // [rad], random tilt
  double mean_pitch = 0.15;       // [rad], positive looks down
  double min_view_depth = 1.0;    // [m] the camera should not stare at a surface closer than this
  double max_view_depth = 8.0;    // [m] preferred upper bound of the depth ahead
  double clearance = 0.4;         // [m] distance kept from obstacles
};

class World {
 public:
  std::string name;
  std::vector<Quad> quads;
  std::vector<TextureSpec> texture_specs;  // one per texture index
  // Axis-aligned solid obstacles (boxes, pillars, the outside of walls) for collision checks.
  std::vector<Eigen::AlignedBox3d> obstacles;
  double background_intensity = 200.0;  // grey level where no quad is seen (sky)
  MotionHints motion;

  // Adds a quad with a natural texture of `texel_size` [m] and returns its index.
  int AddQuad(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& edge_u_W,
              const Eigen::Vector3d& edge_v_W, double texel_size, uint64_t seed, double mean,
              double contrast = 1.0, bool two_sided = false,
              TextureKind kind = TextureKind::kNatural);
  // Adds the six outward-facing faces of an axis-aligned box rotated by `yaw` about z around
  // its centre (and its bounding box as an obstacle). `skip_bottom` drops the face on the floor.
  void AddBox(const Eigen::Vector3d& center_W, const Eigen::Vector3d& size, double yaw,
              double texel_size, uint64_t seed, bool skip_bottom = true);
  // Adds an inward-facing box (walls, floor, ceiling of a room), no obstacle.
  void AddRoomShell(const Eigen::Vector3d& min_W, const Eigen::Vector3d& max_W, double texel_size,
                    uint64_t seed, bool with_ceiling = true);

  // Generates all textures and their mip pyramids (deterministic; a few hundred ms for a hall).
  void GenerateTextures();
  const MipTexture& texture(int index) const { return textures_[index]; }
  bool textures_ready() const { return textures_.size() == texture_specs.size(); }

  // Distance [m] along the unit ray (origin_W, direction_W) to the first quad, or +inf.
  double RayCast(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& direction_W) const;
  // True when p_W is inside free_space and at least `clearance` from every obstacle.
  bool IsFree(const Eigen::Vector3d& p_W, double clearance) const;

  // Empty if valid, otherwise the first problem.
  std::string Validate() const;

 private:
  std::vector<MipTexture> textures_;
};

// Distance [m] from p_W to the parallelogram (the closest point inside it, else on an edge).
double DistanceToQuad(const Quad& quad, const Eigen::Vector3d& p_W);
// Distance [m] from p_W to the nearest quad of the world (the true surfaces, for judging
// landmark positions).
double DistanceToWorld(const World& world, const Eigen::Vector3d& p_W);

// Names of the presets: room, room-fast, hall, street.
std::vector<std::string> PresetNames();
bool IsPresetName(const std::string& name);
// Builds a preset world; `seed` fixes its layout and textures (sessions share it).
// Throws InputError for unknown names.
World MakePresetWorld(const std::string& name, uint64_t seed);
// Loads a world YAML (format in docs/simulator.md); throws InputError naming file and key.
World LoadWorldYaml(const std::string& path, uint64_t seed);

}  // namespace sim
}  // namespace vilma

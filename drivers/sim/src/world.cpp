#include "vilma/sim/world.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "vilma/core/error.h"
#include "vilma/sim/random.h"

namespace vilma {
namespace sim {

using Eigen::Vector3d;

namespace {
constexpr int kMaxTextureSide = 4096;

int TexelsFor(double length_m, double texel_size) {
  // The tolerance keeps exact multiples (0.4 m / (0.4 m / 512)) from rounding up to 513.
  return std::clamp(static_cast<int>(std::ceil(length_m / texel_size - 1e-6)), 2, kMaxTextureSide);
}
}  // namespace

int World::AddQuad(const Vector3d& origin_W, const Vector3d& edge_u_W, const Vector3d& edge_v_W,
                   double texel_size, uint64_t seed, double mean, double contrast,
                   bool two_sided, TextureKind kind) {
  TextureSpec spec;
  spec.kind = kind;
  spec.width = TexelsFor(edge_u_W.norm(), texel_size);
  spec.height = TexelsFor(edge_v_W.norm(), texel_size);
  spec.texel_size_m = std::max(edge_u_W.norm() / spec.width, edge_v_W.norm() / spec.height);
  spec.mean = mean;
  spec.contrast = contrast;
  spec.seed = seed;
  texture_specs.push_back(spec);
  Quad quad;
  quad.origin_W = origin_W;
  quad.edge_u_W = edge_u_W;
  quad.edge_v_W = edge_v_W;
  quad.two_sided = two_sided;
  quad.texture_index = static_cast<int>(texture_specs.size()) - 1;
  quads.push_back(quad);
  return static_cast<int>(quads.size()) - 1;
}

void World::AddBox(const Vector3d& center_W, const Vector3d& size, double yaw, double texel_size,
                   uint64_t seed, bool skip_bottom) {
  Rng rng(seed);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  const Vector3d ex = R.col(0) * size.x(), ey = R.col(1) * size.y(), ez = R.col(2) * size.z();
  const Vector3d c0 = center_W - 0.5 * (ex + ey + ez);  // the (-,-,-) corner
  // Fixed light from above and one side: faces of one box differ in brightness, as under
  // real room lighting (Lambertian factor 0.6 .. 1.0).
  const double albedo = rng.Uniform(80.0, 180.0);
  auto shade = [&](const Vector3d& n) {
    const Vector3d light = Vector3d(0.3, 0.5, 0.81).normalized();
    return albedo * (0.8 + 0.2 * n.normalized().dot(light));
  };
  // Each face: origin, edge_u, edge_v with edge_u x edge_v pointing outward.
  AddQuad(c0, ez, ey, texel_size, rng.Next(), shade(-ex));        // -x face: ez x ey = -x
  AddQuad(c0 + ex, ey, ez, texel_size, rng.Next(), shade(ex));     // +x face: ey x ez = +x
  AddQuad(c0, ex, ez, texel_size, rng.Next(), shade(-ey));         // -y face: ex x ez = -y
  AddQuad(c0 + ey, ez, ex, texel_size, rng.Next(), shade(ey));     // +y face: ez x ex = +y
  AddQuad(c0 + ez, ex, ey, texel_size, rng.Next(), shade(ez));     // top: ex x ey = +z
  if (!skip_bottom) AddQuad(c0, ey, ex, texel_size, rng.Next(), shade(-ez));  // bottom: -z
  const Vector3d half = 0.5 * (R.cwiseAbs() * size);
  obstacles.emplace_back(center_W - half, center_W + half);
}

void World::AddRoomShell(const Vector3d& lo, const Vector3d& hi, double texel_size, uint64_t seed,
                         bool with_ceiling) {
  Rng rng(seed);
  const Vector3d d = hi - lo;
  const Vector3d ex(d.x(), 0, 0), ey(0, d.y(), 0), ez(0, 0, d.z());
  // Inward normals.
  AddQuad(lo, ex, ey, texel_size, rng.Next(), 110.0, 1.0);       // floor: ex x ey = +z
  if (with_ceiling) AddQuad(lo + ez, ey, ex, texel_size * 2.0, rng.Next(), 170.0, 0.6);  // -z
  AddQuad(lo, ey, ez, texel_size, rng.Next(), 140.0);            // x = lo: ey x ez = +x
  AddQuad(lo + ex, ez, ey, texel_size, rng.Next(), 140.0);       // x = hi: ez x ey = -x
  AddQuad(lo, ez, ex, texel_size, rng.Next(), 130.0);            // y = lo: ez x ex = +y
  AddQuad(lo + ey, ex, ez, texel_size, rng.Next(), 130.0);       // y = hi: ex x ez = -y
}

void World::GenerateTextures() {
  textures_.clear();
  textures_.reserve(texture_specs.size());
  for (const TextureSpec& spec : texture_specs) textures_.emplace_back(GenerateTexture(spec));
}

double World::RayCast(const Vector3d& o, const Vector3d& d) const {
  double best = std::numeric_limits<double>::infinity();
  for (const Quad& q : quads) {
    const Vector3d n = q.edge_u_W.cross(q.edge_v_W);
    const double denom = n.dot(d);
    if (std::abs(denom) < 1e-12) continue;
    const double lambda = n.dot(q.origin_W - o) / denom;
    if (lambda <= 1e-9 || lambda >= best) continue;
    const Vector3d r = o + lambda * d - q.origin_W;
    // Solve r = s u + t v in the plane (2x2 normal equations).
    const double uu = q.edge_u_W.squaredNorm(), vv = q.edge_v_W.squaredNorm();
    const double uv = q.edge_u_W.dot(q.edge_v_W);
    const double ru = r.dot(q.edge_u_W), rv = r.dot(q.edge_v_W);
    const double det = uu * vv - uv * uv;
    const double s = (ru * vv - rv * uv) / det, t = (rv * uu - ru * uv) / det;
    if (s >= 0.0 && s <= 1.0 && t >= 0.0 && t <= 1.0) best = lambda;
  }
  return best;
}

bool World::IsFree(const Vector3d& p_W, double clearance) const {
  if (!motion.free_space.contains(p_W)) return false;
  for (const Eigen::AlignedBox3d& box : obstacles) {
    if (box.exteriorDistance(p_W) < clearance) return false;
  }
  return true;
}

std::string World::Validate() const {
  if (quads.empty()) return "quads: expected at least one quad";
  for (size_t i = 0; i < quads.size(); ++i) {
    const Quad& q = quads[i];
    if (q.texture_index < 0 || q.texture_index >= static_cast<int>(texture_specs.size()))
      return "quads[" + std::to_string(i) + "]: texture index out of range";
    if (q.edge_u_W.cross(q.edge_v_W).norm() < 1e-9)
      return "quads[" + std::to_string(i) + "]: degenerate (edges parallel or zero)";
  }
  for (size_t i = 0; i < texture_specs.size(); ++i) {
    const std::string e = texture_specs[i].Validate();
    if (!e.empty()) return "textures[" + std::to_string(i) + "]: " + e;
  }
  if (motion.free_space.isEmpty()) return "free_space: expected a non-empty box";
  return "";
}

std::vector<std::string> PresetNames() { return {"room", "room-fast", "hall", "street"}; }

bool IsPresetName(const std::string& name) {
  const auto names = PresetNames();
  return std::find(names.begin(), names.end(), name) != names.end();
}

namespace {

// Room: EuRoC Vicon room-like, 8 x 8 x 3 m, boxes and panels along the walls, open centre.
World MakeRoom(uint64_t seed, bool fast) {
  World w;
  w.name = "room";
  Rng rng(DeriveSeed(seed, 100));
  const double texel = 0.012;
  w.AddRoomShell(Vector3d(-4, -4, 0), Vector3d(4, 4, 3), texel, rng.Next());
  // Clutter: boxes along the walls (like the mattresses, crates and tables of the Vicon room).
  for (int i = 0; i < 9; ++i) {
    // Draws z, y, x; then the texture seed before the yaw ("Draw order" in random.h).
    const double size_z = rng.Uniform(0.3, 1.6), size_y = rng.Uniform(0.3, 1.3),
                 size_x = rng.Uniform(0.3, 1.3);
    const Vector3d size(size_x, size_y, size_z);
    const int wall = i % 4;
    const double along = rng.Uniform(-3.2, 3.2);
    const double off = 4.0 - rng.Uniform(0.1, 0.8) - 0.5 * std::max(size.x(), size.y());
    Vector3d c;
    if (wall == 0) c = Vector3d(off, along, 0);
    if (wall == 1) c = Vector3d(-off, along, 0);
    if (wall == 2) c = Vector3d(along, off, 0);
    if (wall == 3) c = Vector3d(along, -off, 0);
    c.z() = 0.5 * size.z();
    const uint64_t texture_seed = rng.Next();
    const double yaw = rng.Uniform(-0.3, 0.3);
    w.AddBox(c, size, yaw, texel, texture_seed);
  }
  // Two free-standing obstacles (a stack of crates, a pole-like column) away from the centre.
  w.AddBox(Vector3d(1.6, -1.4, 0.6), Vector3d(0.6, 0.6, 1.2), 0.2, texel, rng.Next());
  w.AddBox(Vector3d(-1.8, 1.7, 1.5), Vector3d(0.25, 0.25, 3.0), 0.0, texel, rng.Next());
  // Posters / panels hanging on the walls (two-sided thin quads 2 cm in front of the wall).
  for (int i = 0; i < 6; ++i) {
    const double along = rng.Uniform(-3.0, 2.0), z = rng.Uniform(0.8, 1.8);
    const double pw = rng.Uniform(0.5, 1.2), ph = rng.Uniform(0.4, 1.0);
    // The albedo before the texture seed ("Draw order" in random.h).
    const double albedo = rng.Uniform(60, 200);
    const uint64_t texture_seed = rng.Next();
    if (i % 2 == 0) {
      w.AddQuad(Vector3d(-3.98, along, z), Vector3d(0, pw, 0), Vector3d(0, 0, ph), texel,
                texture_seed, albedo, 1.3);
    } else {
      w.AddQuad(Vector3d(along, 3.98, z), Vector3d(pw, 0, 0), Vector3d(0, 0, ph), texel,
                texture_seed, albedo, 1.3);
    }
  }
  w.background_intensity = 0.0;
  w.motion.free_space = Eigen::AlignedBox3d(Vector3d(-3.0, -3.0, 0.7), Vector3d(3.0, 3.0, 2.2));
  w.motion.clearance = 0.45;
  w.motion.min_view_depth = 1.3;
  w.motion.max_view_depth = 7.0;
  if (fast) {
    w.name = "room";  // same world as `room`; only the motion differs
    w.motion.mean_speed = 1.6;
    w.motion.max_yaw_rate = 1.5;
    w.motion.roll_pitch_amplitude = 0.3;
  } else {
    w.motion.mean_speed = 0.7;
    w.motion.max_yaw_rate = 0.7;
    w.motion.roll_pitch_amplitude = 0.12;
  }
  w.motion.mean_pitch = 0.2;
  return w;
}

// Hall: machine-hall-like, 30 x 20 x 10 m, two rows of pillars, machines and crates.
World MakeHall(uint64_t seed) {
  World w;
  w.name = "hall";
  Rng rng(DeriveSeed(seed, 200));
  const double texel = 0.025;
  w.AddRoomShell(Vector3d(-15, -10, 0), Vector3d(15, 10, 10), texel, rng.Next());
  for (double x = -10.0; x <= 10.01; x += 5.0) {
    for (double y : {-5.5, 5.5}) {
      w.AddBox(Vector3d(x, y, 5.0), Vector3d(0.6, 0.6, 10.0), 0.0, texel, rng.Next());
    }
  }
  // Machines and crates: along the walls and between the pillar rows' outer sides.
  for (int i = 0; i < 18; ++i) {
    // Each vector drawn z, y, x ("Draw order" in random.h).
    const double size_z = rng.Uniform(0.5, 4.5), size_y = rng.Uniform(0.8, 3.0),
                 size_x = rng.Uniform(0.8, 3.5);
    const Vector3d size(size_x, size_y, size_z);
    Vector3d c = Vector3d::Zero();
    const int zone = i % 3;
    if (zone == 0) {
      c.y() = rng.Uniform(7.0, 8.5);
      c.x() = rng.Uniform(-13, 13);
    } else if (zone == 1) {
      c.y() = rng.Uniform(-8.5, -7.0);
      c.x() = rng.Uniform(-13, 13);
    } else {
      c.y() = rng.Uniform(-4, 4);
      c.x() = rng.Uniform() < 0.5 ? rng.Uniform(-13.5, -12) : rng.Uniform(12, 13.5);
    }
    c.z() = 0.5 * size.z();
    w.AddBox(c, size, 0.0, texel, rng.Next());
  }
  // A gallery / mezzanine slab along one wall (two-sided, seen from below and above).
  w.AddQuad(Vector3d(-15, 8, 4.5), Vector3d(30, 0, 0), Vector3d(0, 2, 0), texel, rng.Next(), 100,
            1.0, true);
  w.background_intensity = 0.0;
  w.motion.free_space = Eigen::AlignedBox3d(Vector3d(-13, -6.5, 1.0), Vector3d(13, 6.5, 4.0));
  w.motion.mean_speed = 1.0;
  w.motion.max_yaw_rate = 0.8;
  w.motion.roll_pitch_amplitude = 0.12;
  w.motion.mean_pitch = 0.15;
  w.motion.clearance = 0.8;
  w.motion.min_view_depth = 2.0;
  w.motion.max_view_depth = 20.0;
  return w;
}

// Street: a city block (buildings of several heights around a 36 x 18 m footprint), a 12 m
// wide street around it, outer facades with side-street gaps, a distant skyline, ground tiles.
// The route loops around the block: ~156 m.
World MakeStreet(uint64_t seed) {
  World w;
  w.name = "street";
  Rng rng(DeriveSeed(seed, 300));
  const double texel = 0.04;
  // Inner block: 4 x 2 buildings.
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 2; ++j) {
      const double h = rng.Uniform(8, 25);
      w.AddBox(Vector3d(-13.5 + 9 * i, -4.5 + 9 * j, h / 2), Vector3d(9, 9, h), 0.0, texel,
               rng.Next());
    }
  }
  // Outer facades: street edges at |x| = 30, |y| = 21; gaps of 8 m (side streets).
  auto facade_run = [&](const Vector3d& start, const Vector3d& dir, double length,
                        const Vector3d& outward) {
    double s = 0;
    while (s < length) {
      const double bw = std::min(length - s, rng.Uniform(8, 18));
      const double h = rng.Uniform(6, 22), depth = 10.0;
      const Vector3d c = start + dir * (s + bw / 2) + outward * (depth / 2) + Vector3d(0, 0, h / 2);
      const Vector3d size = dir.cwiseAbs() * bw + outward.cwiseAbs() * depth + Vector3d(0, 0, h);
      w.AddBox(c, size, 0.0, texel, rng.Next());
      s += bw + (rng.Uniform() < 0.35 ? 8.0 : 0.0);
    }
  };
  facade_run(Vector3d(-30, 21, 0), Vector3d(1, 0, 0), 60, Vector3d(0, 1, 0));
  facade_run(Vector3d(-30, -21, 0), Vector3d(1, 0, 0), 60, Vector3d(0, -1, 0));
  facade_run(Vector3d(30, -13, 0), Vector3d(0, 1, 0), 26, Vector3d(1, 0, 0));
  facade_run(Vector3d(-30, -13, 0), Vector3d(0, 1, 0), 26, Vector3d(-1, 0, 0));
  // Ground: tiles of 15 x 14 m.
  for (double x = -45; x < 45; x += 15) {
    for (double y = -35; y < 35; y += 14) {
      w.AddQuad(Vector3d(x, y, 0), Vector3d(15, 0, 0), Vector3d(0, 14, 0), 0.03, rng.Next(), 95,
                0.8);
    }
  }
  // Distant skyline: large facades 90-110 m away, coarse texture.
  const double r = 100;
  for (int k = 0; k < 16; ++k) {
    const double a0 = 2 * M_PI * k / 16, a1 = 2 * M_PI * (k + 1) / 16;
    const double h = rng.Uniform(15, 45);
    const Vector3d p0(r * std::cos(a0), r * std::sin(a0), 0), p1(r * std::cos(a1), r * std::sin(a1), 0);
    w.AddQuad(p1, p0 - p1, Vector3d(0, 0, h), 0.25, rng.Next(), 120, 0.9);  // faces inward
  }
  w.background_intensity = 225.0;  // overcast sky
  const double z = 1.6;
  w.motion.route_W = {Vector3d(-24, -15, z), Vector3d(24, -15, z), Vector3d(24, 15, z),
                      Vector3d(-24, 15, z)};
  w.motion.free_space = Eigen::AlignedBox3d(Vector3d(-29, -20, 0.8), Vector3d(29, 20, 3.0));
  w.motion.mean_speed = 1.3;
  w.motion.max_yaw_rate = 0.6;
  w.motion.roll_pitch_amplitude = 0.08;
  w.motion.mean_pitch = 0.05;
  w.motion.clearance = 1.5;
  w.motion.min_view_depth = 3.0;
  w.motion.max_view_depth = 60.0;
  return w;
}

}  // namespace

World MakePresetWorld(const std::string& name, uint64_t seed) {
  if (name == "room") return MakeRoom(seed, false);
  if (name == "room-fast") return MakeRoom(seed, true);
  if (name == "hall") return MakeHall(seed);
  if (name == "street") return MakeStreet(seed);
  throw InputError(FormatInputError("world", "preset", "one of room, room-fast, hall, street (got '" +
                                                           name + "')"));
}

double DistanceToQuad(const Quad& quad, const Vector3d& p_W) {
  const Vector3d& u = quad.edge_u_W;
  const Vector3d& v = quad.edge_v_W;
  const Vector3d d = p_W - quad.origin_W;
  // Closest point of the plane: d = s u + t v + n, with the Gram matrix of (u, v).
  Eigen::Matrix2d gram;
  gram << u.dot(u), u.dot(v), u.dot(v), v.dot(v);
  const Eigen::Vector2d st = gram.inverse() * Eigen::Vector2d(u.dot(d), v.dot(d));
  if (st.x() >= 0 && st.x() <= 1 && st.y() >= 0 && st.y() <= 1) {
    return (d - st.x() * u - st.y() * v).norm();
  }
  // Outside: the nearest of the four edges.
  auto segment = [&p_W](const Vector3d& a, const Vector3d& e) {
    const double t = std::clamp((p_W - a).dot(e) / e.squaredNorm(), 0.0, 1.0);
    return (p_W - a - t * e).norm();
  };
  const Vector3d& o = quad.origin_W;
  return std::min({segment(o, u), segment(o, v), segment(o + u, v), segment(o + v, u)});
}

double DistanceToWorld(const World& world, const Vector3d& p_W) {
  double best = std::numeric_limits<double>::infinity();
  for (const Quad& q : world.quads) best = std::min(best, DistanceToQuad(q, p_W));
  return best;
}

}  // namespace sim
}  // namespace vilma

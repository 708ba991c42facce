#include "vilma/sim/world_file.h"

#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"
#include "vilma/sim/random.h"

namespace vilma::sim {
namespace {

using Eigen::Vector3d;

// The scalar keys of the file's root and its `motion` section (core/options_fields.h).
template <typename Description, typename Visitor>
void VisitWorldScalars(Description& d, Visitor&& v) {
  v("", "name", d.name);
  v("", "background", d.background);
  v("motion", "mean_speed", d.motion.mean_speed);
  v("motion", "max_yaw_rate", d.motion.max_yaw_rate);
  v("motion", "roll_pitch_amplitude", d.motion.roll_pitch_amplitude);
  v("motion", "mean_pitch", d.motion.mean_pitch);
  v("motion", "min_view_depth", d.motion.min_view_depth);
  v("motion", "max_view_depth", d.motion.max_view_depth);
  v("motion", "clearance", d.motion.clearance);
}

Vector3d ReadVec3(const YamlNode& node, const std::string& key) { return node.GetVector(key, 3); }

std::string Vec3ToYaml(const Vector3d& v) {
  return "[" + FormatYamlScalar(v.x()) + ", " + FormatYamlScalar(v.y()) + ", " +
         FormatYamlScalar(v.z()) + "]";
}

TextureKind TextureKindOf(const std::string& name) {
  if (name == "checker") return TextureKind::kChecker;
  if (name == "uniform") return TextureKind::kUniform;
  return TextureKind::kNatural;
}

}  // namespace

WorldDescription ReadWorldDescription(const YamlNode& root) {
  if (!root.IsMap()) root.Fail("", "a map describing the world");
  WorldDescription d;
  if (root.Has("rooms")) {
    for (const YamlNode& r : root.Child("rooms").Elements()) {
      WorldRoomSpec room;
      room.min_W = ReadVec3(r, "min");
      room.max_W = ReadVec3(r, "max");
      room.texel_size = r.GetOr<double>("texel_size", room.texel_size);
      room.ceiling = r.GetOr<bool>("ceiling", room.ceiling);
      r.CheckNoUnknownKeys();
      d.rooms.push_back(room);
    }
  }
  if (root.Has("boxes")) {
    for (const YamlNode& b : root.Child("boxes").Elements()) {
      WorldBoxSpec box;
      box.size = ReadVec3(b, "size");
      if (box.size.minCoeff() <= 0.0) b.Fail("size", "positive box dimensions [m]");
      box.center_W = ReadVec3(b, "center");
      box.yaw = b.GetOr<double>("yaw", box.yaw);
      box.texel_size = b.GetOr<double>("texel_size", box.texel_size);
      b.CheckNoUnknownKeys();
      d.boxes.push_back(box);
    }
  }
  if (root.Has("quads")) {
    for (const YamlNode& q : root.Child("quads").Elements()) {
      WorldQuadSpec quad;
      quad.texture = q.GetOr<std::string>("texture", quad.texture);
      if (quad.texture != "natural" && quad.texture != "checker" && quad.texture != "uniform") {
        q.Fail("texture", "natural, checker or uniform");
      }
      quad.origin_W = ReadVec3(q, "origin");
      quad.edge_u_W = ReadVec3(q, "edge_u");
      quad.edge_v_W = ReadVec3(q, "edge_v");
      quad.texel_size = q.GetOr<double>("texel_size", quad.texel_size);
      quad.mean = q.GetOr<double>("mean", quad.mean);
      quad.contrast = q.GetOr<double>("contrast", quad.contrast);
      quad.two_sided = q.GetOr<bool>("two_sided", quad.two_sided);
      q.CheckNoUnknownKeys();
      d.quads.push_back(quad);
    }
  }
  const YamlNode fs = root.Child("free_space");
  d.motion.free_space = Eigen::AlignedBox3d(ReadVec3(fs, "min"), ReadVec3(fs, "max"));
  fs.CheckNoUnknownKeys();
  if (root.Has("route")) {
    for (const YamlNode& p : root.Child("route").Elements()) {
      if (!p.IsSequence() || p.raw().size() != 3) p.Fail("", "a point [x, y, z]");
      d.motion.route_W.emplace_back(p.raw()[0].as<double>(), p.raw()[1].as<double>(),
                                    p.raw()[2].as<double>());
    }
  }
  // Last: it also checks the root for keys that nobody read.
  ReadOptionFields(root, MissingKey::kKeepDefault, &d,
                   [](auto& description, auto&& v) { VisitWorldScalars(description, v); });
  return d;
}

std::string WorldDescriptionToYaml(const WorldDescription& d) {
  std::ostringstream out;
  const std::string scalars =
      OptionFieldsToYaml(d, [](auto& description, auto&& v) { VisitWorldScalars(description, v); });
  out << scalars;
  if (!d.rooms.empty()) out << "rooms:\n";
  for (const WorldRoomSpec& r : d.rooms) {
    out << "  - min: " << Vec3ToYaml(r.min_W) << "\n    max: " << Vec3ToYaml(r.max_W)
        << "\n    texel_size: " << FormatYamlScalar(r.texel_size)
        << "\n    ceiling: " << FormatYamlScalar(r.ceiling) << "\n";
  }
  if (!d.boxes.empty()) out << "boxes:\n";
  for (const WorldBoxSpec& b : d.boxes) {
    out << "  - center: " << Vec3ToYaml(b.center_W) << "\n    size: " << Vec3ToYaml(b.size)
        << "\n    yaw: " << FormatYamlScalar(b.yaw)
        << "\n    texel_size: " << FormatYamlScalar(b.texel_size) << "\n";
  }
  if (!d.quads.empty()) out << "quads:\n";
  for (const WorldQuadSpec& q : d.quads) {
    out << "  - origin: " << Vec3ToYaml(q.origin_W) << "\n    edge_u: " << Vec3ToYaml(q.edge_u_W)
        << "\n    edge_v: " << Vec3ToYaml(q.edge_v_W)
        << "\n    texel_size: " << FormatYamlScalar(q.texel_size)
        << "\n    mean: " << FormatYamlScalar(q.mean)
        << "\n    contrast: " << FormatYamlScalar(q.contrast)
        << "\n    two_sided: " << FormatYamlScalar(q.two_sided)
        << "\n    texture: " << FormatYamlScalar(q.texture) << "\n";
  }
  out << "free_space:\n  min: " << Vec3ToYaml(d.motion.free_space.min())
      << "\n  max: " << Vec3ToYaml(d.motion.free_space.max()) << "\n";
  if (!d.motion.route_W.empty()) out << "route:\n";
  for (const Vector3d& p : d.motion.route_W) out << "  - " << Vec3ToYaml(p) << "\n";
  return out.str();
}

World BuildWorld(const WorldDescription& d, uint64_t seed, const std::string& source) {
  World w;
  // One stream for every element, in the file's order (rooms, boxes, quads): the same file and
  // seed give the same textures.
  Rng rng(DeriveSeed(seed, 400));
  w.name = d.name;
  w.background_intensity = d.background;
  for (const WorldRoomSpec& r : d.rooms) {
    w.AddRoomShell(r.min_W, r.max_W, r.texel_size, rng.Next(), r.ceiling);
  }
  for (const WorldBoxSpec& b : d.boxes) {
    w.AddBox(b.center_W, b.size, b.yaw, b.texel_size, rng.Next());
  }
  for (const WorldQuadSpec& q : d.quads) {
    w.AddQuad(q.origin_W, q.edge_u_W, q.edge_v_W, q.texel_size, rng.Next(), q.mean, q.contrast,
              q.two_sided, TextureKindOf(q.texture));
  }
  w.motion = d.motion;
  const std::string error = w.Validate();
  if (!error.empty()) throw InputError(FormatInputError(source, "", error));
  return w;
}

World LoadWorldYaml(const std::string& path, uint64_t seed) {
  return BuildWorld(ReadWorldDescription(YamlNode::LoadFile(path)), seed, path);
}

}  // namespace vilma::sim

// Pictures of triangle meshes (mapping/dense, docs/dense.md "Mesh pictures"): render_mesh. Needs
// no map.
#include "vilma/console/command_registry.h"
#include "vilma/mapping/dense/mesh_render.h"

namespace vilma::console {
namespace {

// clip_above_z_m at or beyond this: no clipping.
constexpr double kNoClip = 1e9;

struct RenderMeshCommandOptions {
  std::string mesh;  // PLY file
  std::string out;   // PNG file
  double clip_above_z_m = kNoClip;
  mapping::MeshRenderOptions render;
  std::string Validate() const {
    if (mesh.empty()) return "mesh: a triangle mesh file (PLY)";
    if (out.empty()) return "out: a .png file to write";
    return render.Validate();
  }
};

void Register(CommandRegistry* registry) {
  using R = RenderMeshCommandOptions;
  registry->Add(
      Command<R>("render_mesh")
          .Group("dense")
          .Summary("PNG picture of a triangle mesh file (software rasterizer: z-buffer, "
                   "Lambert shading with a headlight, vertex colours); needs no map")
          .Usage("[MESH.ply] [OUT.png]")
          .Access(MapAccess::kNone)
          .PathFlag("mesh", &R::mesh, "triangle mesh to draw (PLY; OBJ and OFF also read)")
          .Positional("mesh")
          .PathFlag("out", &R::out, "PNG file to write (atomically)")
          .Positional("out")
          .FlagAt(
              "view", [](R& o) -> std::string& { return o.render.view; },
              "auto (3/4 from above), top, front (from -y), side (from +x), or custom "
              "(azimuth_deg, elevation_deg)")
          .FlagAt(
              "azimuth_deg", [](R& o) -> double& { return o.render.azimuth_deg; },
              "custom view: camera direction from the centre, from +x towards +y [deg]")
          .FlagAt(
              "elevation_deg", [](R& o) -> double& { return o.render.elevation_deg; },
              "custom view: camera direction above the x-y plane [deg]")
          .FlagAt(
              "fov_deg", [](R& o) -> double& { return o.render.fov_deg; },
              "field of view across the smaller image side [deg]")
          .FlagAt(
              "width_px", [](R& o) -> int& { return o.render.width_px; }, "image width [px]")
          .FlagAt(
              "height_px", [](R& o) -> int& { return o.render.height_px; }, "image height [px]")
          .FlagAt(
              "shading", [](R& o) -> std::string& { return o.render.shading; },
              "flat (a normal per triangle) or gouraud (per vertex, interpolated)")
          .Flag("clip_above_z_m", &R::clip_above_z_m,
                "leave out triangles above this height, e.g. a room's ceiling [m] (default: "
                "none)")
          .Run([](CommandContext& c, const R& o) {
            mapping::TriangleMesh mesh = mapping::ReadMeshFile(o.mesh);
            if (o.clip_above_z_m < kNoClip) mesh = mapping::ClipAboveZ(mesh, o.clip_above_z_m);
            if (mesh.triangles.empty()) {
              throw CommandError("no triangle of " + o.mesh + " lies below --clip_above_z_m");
            }
            const mapping::MeshRenderResult result = mapping::RenderMeshImage(mesh, o.render);
            mapping::WritePngAtomically(o.out, result.image);
            c.out() << "render_mesh: " << o.out << ": " << mesh.vertices.size() << " vertices, "
                    << mesh.triangles.size() << " triangles of " << o.mesh << ", view "
                    << o.render.view << "; " << result.BriefReport() << "\n";
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)

// EvaluateMesh on a hand-built world: the world's own quads as the mesh are exact and complete,
// a shifted mesh is off by the shift, occluded, back-facing and too distant surfaces are not
// counted as seen, and an alignment S_W_G takes mesh and views into the world.
#include "vilma/mapping/evaluation/mesh_evaluation.h"

#include <catch2/catch.hpp>

#include "vilma/core/error.h"

namespace vilma::mapping {
namespace {

// One view at the origin of W looking along +x (D: x = -y_W, y = -z_W, z = x_W), 90 deg.
DepthView ViewAlongX() {
  DepthView v;
  Eigen::Matrix3d R_W_D;
  R_W_D << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  v.T_G_D.topLeftCorner<3, 3>() = R_W_D;
  v.fx = v.fy = 100.0;
  v.cx = v.cy = 99.5;
  v.width = v.height = 200;
  return v;
}

// Quads facing the view unless said otherwise; the samples each has at 5 cm spacing.
struct TestWorld {
  sim::World world;
  int front = -1;     // 1 x 1 m at x = 2 (400 samples)
  int hidden = -1;    // 0.4 x 0.4 m at x = 3, behind `front` (64)
  int side = -1;      // 0.6 x 0.6 m at x = 2.5, off to +y (144)
  int back = -1;      // 0.6 x 0.6 m at x = 2, off to -y, facing away (144)
  int distant = -1;   // 0.6 x 0.6 m at x = 8, beyond max_view_depth_m (144)
};

TestWorld MakeWorld(bool with_front = true) {
  TestWorld t;
  const Eigen::Vector3d ey = Eigen::Vector3d::UnitY(), ez = Eigen::Vector3d::UnitZ();
  // edge_u x edge_v is the normal: ez x ey = -x (towards the view).
  if (with_front) t.front = t.world.AddQuad({2.0, -0.5, -0.5}, ez, ey, 0.05, 1, 128.0);
  t.hidden = t.world.AddQuad({3.0, -0.2, -0.2}, 0.4 * ez, 0.4 * ey, 0.05, 2, 128.0);
  t.side = t.world.AddQuad({2.5, 1.0, -0.3}, 0.6 * ez, 0.6 * ey, 0.05, 3, 128.0);
  t.back = t.world.AddQuad({2.0, -1.6, -0.3}, 0.6 * ey, 0.6 * ez, 0.05, 4, 128.0);
  t.distant = t.world.AddQuad({8.0, -3.0, -0.3}, 0.6 * ez, 0.6 * ey, 0.05, 5, 128.0);
  return t;
}

// The quads as triangles (two each), moved by `shift`.
TriangleMesh QuadMesh(const sim::World& world, const std::vector<int>& quads,
                      const Eigen::Vector3d& shift = Eigen::Vector3d::Zero()) {
  TriangleMesh mesh;
  for (int q : quads) {
    const sim::Quad& quad = world.quads[q];
    const int base = static_cast<int>(mesh.vertices.size());
    mesh.vertices.push_back(quad.origin_W + shift);
    mesh.vertices.push_back(quad.origin_W + quad.edge_u_W + shift);
    mesh.vertices.push_back(quad.origin_W + quad.edge_u_W + quad.edge_v_W + shift);
    mesh.vertices.push_back(quad.origin_W + quad.edge_v_W + shift);
    mesh.triangles.push_back({base, base + 1, base + 2});
    mesh.triangles.push_back({base, base + 2, base + 3});
  }
  return mesh;
}

std::vector<int> AllQuads(const TestWorld& t) {
  std::vector<int> all;
  for (int q : {t.front, t.hidden, t.side, t.back, t.distant}) {
    if (q >= 0) all.push_back(q);
  }
  return all;
}

}  // namespace

TEST_CASE("mesh evaluation: the world's own quads are exact and complete", "[mesh_evaluation]") {
  const TestWorld t = MakeWorld();
  const MeshEvaluation e = EvaluateMesh(QuadMesh(t.world, AllQuads(t)), {ViewAlongX()}, t.world, Alignment());
  INFO(e.FullReport());
  CHECK(e.mesh_vertices == 20);
  CHECK(e.accuracy_m.count == 20);
  CHECK(e.accuracy_m.max < 1e-12);
  CHECK(e.accuracy_p90_m < 1e-12);
  CHECK(e.surface_samples == 400 + 64 + 144 + 144 + 144);
  // Seen: the front and the side quad; not the one behind the front, the one facing away or
  // the one beyond 6 m.
  CHECK(e.seen_samples == 400 + 144);
  CHECK(e.covered_samples == e.seen_samples);
  CHECK(e.completeness == 1.0);
  CHECK_THAT(e.BriefReport(), Catch::Contains("completeness 100.0 % (544 of 544 seen surface samples; "
                                         "896 in the world)"));

  // Without views nothing is seen.
  const MeshEvaluation blind = EvaluateMesh(QuadMesh(t.world, AllQuads(t)), {}, t.world, Alignment());
  CHECK(blind.seen_samples == 0);
  CHECK(blind.completeness == 0.0);
  // A longer depth range sees the distant quad; a two-sided quad is seen from behind.
  MeshEvaluationOptions far;
  far.max_view_depth_m = 10.0;
  CHECK(EvaluateMesh(QuadMesh(t.world, AllQuads(t)), {ViewAlongX()}, t.world, Alignment(), far)
            .seen_samples == 400 + 144 + 144);
  TestWorld two_sided = MakeWorld();
  two_sided.world.quads[two_sided.back].two_sided = true;
  CHECK(EvaluateMesh(QuadMesh(t.world, AllQuads(t)), {ViewAlongX()}, two_sided.world, Alignment())
            .seen_samples == 400 + 144 + 144);
}

TEST_CASE("mesh evaluation: a mesh 3 cm off the surface, a missing part", "[mesh_evaluation]") {
  const TestWorld t = MakeWorld();
  const std::vector<DepthView> views = {ViewAlongX()};
  // Both seen quads' normal is -x: shift towards the view.
  const TriangleMesh shifted = QuadMesh(t.world, {t.front, t.side}, Eigen::Vector3d(-0.03, 0.0, 0.0));
  const MeshEvaluation e = EvaluateMesh(shifted, views, t.world, Alignment());
  INFO(e.FullReport());
  CHECK(e.accuracy_m.median == Approx(0.03).margin(1e-12));
  CHECK(e.accuracy_p90_m == Approx(0.03).margin(1e-12));
  CHECK(e.accuracy_m.max == Approx(0.03).margin(1e-12));
  CHECK(e.completeness == 1.0);  // within the default 5 cm
  MeshEvaluationOptions strict;
  strict.completeness_threshold_m = 0.02;
  const MeshEvaluation s = EvaluateMesh(shifted, views, t.world, Alignment(), strict);
  CHECK(s.seen_samples == 544);
  CHECK(s.covered_samples == 0);

  // Only the front quad: the side quad's samples are seen but not covered.
  const MeshEvaluation part = EvaluateMesh(QuadMesh(t.world, {t.front}), views, t.world, Alignment());
  CHECK(part.seen_samples == 544);
  CHECK(part.covered_samples == 400);
  CHECK(part.completeness == Approx(400.0 / 544.0));
}

TEST_CASE("mesh evaluation: an occluded quad is seen once its occluder is gone", "[mesh_evaluation]") {
  const TestWorld without_front = MakeWorld(false);
  const MeshEvaluation e = EvaluateMesh(QuadMesh(without_front.world, AllQuads(without_front)),
                                        {ViewAlongX()}, without_front.world, Alignment());
  CHECK(e.seen_samples == 64 + 144);
  CHECK(e.completeness == 1.0);
  // A view standing between the front quad and the hidden one, looking at the hidden one.
  const TestWorld t = MakeWorld();
  DepthView between = ViewAlongX();
  between.T_G_D(0, 3) = 2.5;
  const MeshEvaluation b = EvaluateMesh(QuadMesh(t.world, AllQuads(t)), {between}, t.world, Alignment());
  // From there: the hidden quad 0.5 m ahead and the distant one now 5.5 m ahead; the side
  // quad is level with the view, the others behind it.
  CHECK(b.seen_samples == 64 + 144);
  // Seen by either view: the union.
  const MeshEvaluation both =
      EvaluateMesh(QuadMesh(t.world, AllQuads(t)), {ViewAlongX(), between}, t.world, Alignment());
  CHECK(both.seen_samples == 400 + 144 + 64 + 144);
}

TEST_CASE("mesh evaluation: the alignment takes mesh and views into the world", "[mesh_evaluation]") {
  const TestWorld t = MakeWorld();
  // S_W_G: p_W = s R p_G + p.
  Alignment S_W_G;
  S_W_G.type = AlignmentType::kSim3;
  S_W_G.T_G_E = Transformation(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, -0.5, 1.0).normalized())),
      Eigen::Vector3d(4.0, -1.0, 2.5));
  S_W_G.scale = 2.0;
  const Eigen::Matrix3d R_W_G = S_W_G.T_G_E.rotationMatrix();
  auto to_G = [&](const Eigen::Vector3d& p_W) -> Eigen::Vector3d {
    return R_W_G.transpose() * (p_W - S_W_G.T_G_E.translation()) / S_W_G.scale;
  };
  TriangleMesh mesh = QuadMesh(t.world, {t.front, t.side}, Eigen::Vector3d(-0.03, 0.0, 0.0));
  for (Eigen::Vector3d& p : mesh.vertices) p = to_G(p);
  DepthView view = ViewAlongX();
  view.T_G_D.topLeftCorner<3, 3>() = R_W_G.transpose() * view.T_G_D.topLeftCorner<3, 3>();
  view.T_G_D.topRightCorner<3, 1>() = to_G(Eigen::Vector3d::Zero());
  const MeshEvaluation e = EvaluateMesh(mesh, {view}, t.world, S_W_G);
  INFO(e.FullReport());
  CHECK(e.accuracy_m.median == Approx(0.03).margin(1e-9));  // in W's metres
  CHECK(e.seen_samples == 544);
  CHECK(e.covered_samples == 544);
  MeshEvaluationOptions strict;
  strict.completeness_threshold_m = 0.02;  // in W: the 3 cm shift is beyond it
  CHECK(EvaluateMesh(mesh, {view}, t.world, S_W_G, strict).covered_samples == 0);
  strict.completeness_threshold_m = 0.035;
  CHECK(EvaluateMesh(mesh, {view}, t.world, S_W_G, strict).covered_samples == 544);
}

TEST_CASE("mesh evaluation options", "[mesh_evaluation]") {
  CHECK(MeshEvaluationOptions().Validate().empty());
  MeshEvaluationOptions o;
  o.completeness_threshold_m = 0.0;
  CHECK_THAT(o.Validate(), Catch::StartsWith("completeness_threshold_m:"));
  o = MeshEvaluationOptions();
  o.sample_spacing_m = -1.0;
  CHECK_THAT(o.Validate(), Catch::StartsWith("sample_spacing_m:"));
  o = MeshEvaluationOptions();
  o.max_view_depth_m = o.min_view_depth_m;
  CHECK_THAT(o.Validate(), Catch::StartsWith("min_view_depth_m"));
  o = MeshEvaluationOptions();
  o.occlusion_tolerance_m = -0.1;
  CHECK_THAT(o.Validate(), Catch::StartsWith("occlusion_tolerance_m:"));
  const TestWorld t = MakeWorld();
  CHECK_THROWS_AS(EvaluateMesh(TriangleMesh(), {}, t.world, Alignment(), o), InputError);
}

}  // namespace vilma::mapping

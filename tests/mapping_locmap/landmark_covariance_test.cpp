// Calibrated landmark covariances (mapping/locmap/landmark_covariance.h): a map of known
// keypoint noise must give covariances that describe its landmarks' real errors.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <random>

#include "test_random.h"
#include "vilma/mapping/locmap/landmark_covariance.h"
#include "vilma/mapping/locmap/localization_map_builder.h"

namespace {

using namespace vilma;
using namespace vilma::mapping;

// A mission of `vertices` cameras on a 2 m line along x (a pinhole 640x480, f = 400 px, looking
// along z) and `landmarks` true points 3-8 m ahead; every camera sees every point with
// Gaussian keypoint noise sigma_px. Each landmark is triangulated (Gauss-Newton on its pixel
// residuals) and stored with the covariance of an ASSUMED 1-px noise, as the map builder does.
struct NoisyMap {
  mapstore::VIMap map;
  std::vector<Eigen::Vector3d> truth_G;
};

NoisyMap MakeNoisyMap(int vertices, int landmarks, double sigma_px, uint32_t seed) {
  NoisyMap out;
  mapstore::IdGenerator ids(seed);
  mapstore::Mission mission;
  mission.id = ids.Next();
  mission.baseframe_known = true;
  CameraConfig cam;
  cam.camera = Camera(640, 480, Eigen::Vector4d(400, 400, 320, 240), DistortionModel::kNone,
                      Eigen::VectorXd());
  mission.rig.cameras.push_back(cam);
  out.map.AddMission(mission);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_px);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int l = 0; l < landmarks; ++l) {
    const double z = 5.5 + 2.5 * u(rng);
    const double y = 0.35 * z * u(rng);  // y before x, as GCC drew them (tests/test_random.h)
    const double x = 1.0 + 0.45 * z * u(rng);
    out.truth_G.emplace_back(x, y, z);
  }
  std::vector<mapstore::VertexId> vertex_ids;
  for (int v = 0; v < vertices; ++v) {
    mapstore::Vertex vertex;
    vertex.id = ids.Next();
    vertex.mission_id = mission.id;
    vertex.T_M_I = Transformation(Eigen::Quaterniond::Identity(),
                                  Eigen::Vector3d(2.0 * v / (vertices - 1), 0, 0));
    mapstore::VisualFrame frame;
    for (int l = 0; l < landmarks; ++l) {
      Eigen::Vector2d uv;
      const Eigen::Vector3d p_C = out.truth_G[l] - vertex.T_M_I.translation();
      cam.camera.Project(p_C, &uv);
      mapstore::Keypoint k;
      k.uv = uv + vilma::testing::DrawVector2([&] { return noise(rng); });
      frame.keypoints.push_back(k);
      frame.descriptors.insert(frame.descriptors.end(), 64, static_cast<uint8_t>(l));
      frame.track_ids.push_back(l);
      frame.landmark_ids.emplace_back();
    }
    vertex.frames.push_back(frame);
    vertex_ids.push_back(vertex.id);
    out.map.AddVertex(vertex);
  }
  for (int l = 0; l < landmarks; ++l) {
    mapstore::Landmark lm;
    lm.id = ids.Next();
    lm.store_vertex_id = vertex_ids[0];  // at the origin, identity: p_I = p_G
    lm.quality = mapstore::LandmarkQuality::kGood;
    out.map.AddLandmark(lm);
    std::vector<mapstore::LandmarkObservation> observations;
    for (int v = 0; v < vertices; ++v) {
      observations.push_back({vertex_ids[v], 0, static_cast<uint32_t>(l)});
      out.map.AddObservation(lm.id, observations.back());
    }
    std::vector<const mapstore::LandmarkObservation*> obs;
    for (const auto& o : observations) obs.push_back(&o);
    // Gauss-Newton from a point 5 % off the truth.
    Eigen::Vector3d p = 1.05 * out.truth_G[l];
    for (int it = 0; it < 10; ++it) {
      Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      for (const auto* o : obs) {
        Eigen::Vector2d r;
        Eigen::Matrix<double, 2, 3> J;
        REQUIRE(ObservationResidual(out.map, *o, p, &r, &J));
        H += J.transpose() * J;
        b += J.transpose() * r;
      }
      p -= H.ldlt().solve(b);
    }
    Eigen::Matrix3d covariance_1px;
    REQUIRE(TriangulationCovariance_G(out.map, obs, p, 1.0, &covariance_1px));
    mapstore::Landmark& stored = out.map.landmark(lm.id);
    stored.p_I = p;
    stored.covariance = covariance_1px;
  }
  return out;
}

// Mean of e^T Sigma^-1 e / 3 over the landmarks, e = p_G - truth: 1 for calibrated covariances.
double WhitenedChi2PerDof(const localizer::LocalizationMap& map,
                          const std::vector<Eigen::Vector3d>& truth_G) {
  REQUIRE(map.p_G_covariance.size() == truth_G.size());
  double sum = 0.0;
  for (std::size_t l = 0; l < truth_G.size(); ++l) {
    const Eigen::Vector3d e = map.p_G[l] - truth_G[l];
    sum += e.dot(map.p_G_covariance[l].cast<double>().inverse() * e) / 3.0;
  }
  return sum / static_cast<double>(truth_G.size());
}

}  // namespace

TEST_CASE("landmark covariances calibrated to the map's measured keypoint noise",
          "[localization][calibration]") {
  // 0.5 px of real noise, 1 px assumed by the triangulation: the stored covariances are 4x too
  // large in variance (chi^2 / dof 0.25); the calibrated ones describe the errors (1).
  const NoisyMap noisy = MakeNoisyMap(6, 600, 0.5, 17);
  localizer::LocalizationMapOptions options;
  options.calibrate_landmark_covariances = false;
  const double stored = WhitenedChi2PerDof(BuildLocalizationMap(noisy.map, options), noisy.truth_G);
  CHECK(stored == Approx(0.25).margin(0.05));
  options.calibrate_landmark_covariances = true;
  LocalizationMapReport report;
  const localizer::LocalizationMap calibrated = BuildLocalizationMap(noisy.map, options, &report);
  CHECK(report.keypoint_noise.landmarks == 600);
  CHECK(report.keypoint_noise.observations == 3600);
  CHECK(report.keypoint_noise.sigma_px == Approx(0.5).margin(0.03));
  // 600 landmarks x 3 dof: the mean of chi^2_3 / 3 has a standard deviation of 0.033.
  CHECK(WhitenedChi2PerDof(calibrated, noisy.truth_G) == Approx(1.0).margin(0.12));
  // Gross errors in a few observations (wrong track associations) do not inflate the noise:
  // the estimate is a median.
  NoisyMap outliers = MakeNoisyMap(6, 600, 0.5, 18);
  for (const mapstore::VertexId& v : outliers.map.vertex_ids(outliers.map.mission_ids()[0])) {
    auto& keypoints = outliers.map.vertex(v).frames[0].keypoints;
    for (std::size_t k = 0; k < keypoints.size(); k += 20) keypoints[k].uv.x() += 15.0;
  }
  const localizer::LocalizationMap robust = BuildLocalizationMap(outliers.map, options, &report);
  CHECK(report.keypoint_noise.sigma_px < 0.6);
}

TEST_CASE("landmark covariance calibration: the residual Jacobian against central differences",
          "[localization][calibration]") {
  const NoisyMap noisy = MakeNoisyMap(3, 5, 0.5, 3);
  const mapstore::LandmarkId id = noisy.map.landmark_ids(noisy.map.mission_ids()[0])[2];
  const mapstore::LandmarkObservation& obs = noisy.map.landmark(id).observations[1];
  const Eigen::Vector3d p(0.7, -0.4, 6.0);
  Eigen::Vector2d r;
  Eigen::Matrix<double, 2, 3> J;
  REQUIRE(ObservationResidual(noisy.map, obs, p, &r, &J));
  for (int k = 0; k < 3; ++k) {
    const double h = 1e-6;
    Eigen::Vector2d rp, rm;
    REQUIRE(ObservationResidual(noisy.map, obs, p + h * Eigen::Vector3d::Unit(k), &rp, nullptr));
    REQUIRE(ObservationResidual(noisy.map, obs, p - h * Eigen::Vector3d::Unit(k), &rm, nullptr));
    CHECK(((rp - rm) / (2 * h) - J.col(k)).norm() < 1e-5 * J.norm());
  }
}

TEST_CASE("landmark covariance calibration: a map without a rig keeps its stored covariances",
          "[localization][calibration]") {
  NoisyMap noisy = MakeNoisyMap(4, 50, 0.5, 5);
  noisy.map.mission(noisy.map.mission_ids()[0]).rig.cameras.clear();
  LocalizationMapReport report;
  const localizer::LocalizationMap map = BuildLocalizationMap(noisy.map, {}, &report);
  CHECK(report.keypoint_noise.sigma_px < 0.0);
  localizer::LocalizationMapOptions stored;
  stored.calibrate_landmark_covariances = false;
  const localizer::LocalizationMap expected = BuildLocalizationMap(noisy.map, stored);
  for (std::size_t l = 0; l < map.num_landmarks(); ++l) {
    CHECK(map.p_G_covariance[l].isApprox(expected.p_G_covariance[l]));
  }
}

// The filter's C1 feature tracks against the simulator's geometry (issue 17, docs/estimator.md
// "The systematic rotation error", session 34). A diagnosis (hidden tag "[.diagnostic]"): runs
// `vilma vio`'s path (VioPipeline, default profile, mono or stereo) on a simulated data set of
// ~/.cache/vilma/datasets and, for every feature, takes the world point that its extraction
// pixel sees (sim::World::RayCast from the true camera pose of the detection frame); on every
// later frame that point is projected with the true camera pose, and the filter's pixel of the
// feature (its bearing mu projected, after the frame's update) is compared with it. A tracker
// that is unbiased gives errors that do not grow with the feature's age; a drift common to all
// features is an apparent rotation of the camera, which the filter can only explain by the gyro
// bias.
//
// Per-observation CSV (VILMA_DIAG_OUT, default ~/.cache/vilma/diag): t_s, feature id, frames
// since detection, true and filter pixel, true distance, the filter's inverse distance, whether
// the point is visible (not occluded) in the current true view, and the NEES of the feature's
// pixel (2 DoF, its bearing covariance through the camera) and inverse distance (1 DoF) against
// the truth (session 35). Summary printed per age bucket.
// Environment as in vio_consistency_sim_test.cpp: VILMA_DIAG_SETS, VILMA_DIAG_MODES,
// VILMA_DIAG_CONFIG, VILMA_DIAG_DATASETS.
//
// Second diagnosis, "IMU variants of a simulated set": every session-0 set of seed 1 (room-easy,
// room-fast, hall, street) has the same IMU noise and bias random walk (the IMU's random stream
// is DeriveSeed(seed, 2000 + session), whatever the world). To tell an error of the filter from
// one realization of the noise, this writes copies of a set with the same images (links) and
// the same trajectory but another IMU realization: VILMA_DIAG_IMU_VARIANTS, a comma-separated
// list of N (N = 0 reproduces the set's own IMU file, N >= 1 draws the IMU from
// DeriveSeed(DeriveSeed(seed, 2000 + session), N); `vilma-sim --imu-draw N --images-from DIR`
// writes the same copy), "exact" (no white noise, no random walk,
// zero biases), or one part of the noise model drawn from the set's own stream: "gyro" (the
// gyroscope's white noise, bias and walk; exact accelerometer), "accel" (the converse), "white"
// (white noise only), "walk" (biases and walk only), into VILMA_DIAG_OUT/<set>-imu<N>.
//
// Third, "feature dynamics against the simulator's geometry": the filter's propagation
// (PropagateMean, midpoint IMU measurement per interval as VioFilter::Propagate) started from
// the true state (pose, velocity, zero biases, exact IMU) with features on a pixel grid at their
// true distance (RayCast) predicts their pixels after one frame and after 1 s; the truth is the
// world point projected with the true pose. With exact inputs the only error is the
// discretization; a systematic part would be an apparent rotation.
#include <Eigen/Core>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "diag_env.h"
#include "test_skip.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/geometry.h"
#include "vilma/core/rig.h"
#include "vilma/estimator/filter_options.h"
#include "vilma/estimator/filter_state.h"
#include "vilma/estimator/propagation.h"
#include "vilma/estimator/vio_pipeline.h"
#include "vilma/sim/imu_sim.h"
#include "vilma/sim/random.h"
#include "vilma/sim/sim_yaml.h"
#include "vilma/sim/simulator.h"

namespace vilma::estimator {
namespace {

struct Observation {
  double t_s = 0.0;
  int64_t id = 0;
  int age = 0;  // frames since detection
  Eigen::Vector2d px_true, px_est;
  double distance_true = 0.0, rho_est = 0.0;
  bool visible = false;
  // The filter's own uncertainty of the feature (session 35): NEES of the pixel (2 DoF; the
  // bearing covariance through the camera model, J_pi B P_mu B^T J_pi^T) and of the inverse
  // distance (1 DoF) against the truth.
  double nees_px = 0.0, nees_rho = 0.0;
};

struct Landmark {
  Eigen::Vector3d p_W;
  int first_frame = 0;
};

std::vector<Observation> TrackAgainstTruth(const std::filesystem::path& dir, bool stereo,
                                           FilterOptions options) {
  const sim::SimOptions so = sim::ReadSimYaml((dir / "sim.yaml").string());
  sim::Simulator simulator(so);
  const AslDataset dataset = AslDataset::Open(dir.string());
  const SensorRig rig = LoadSensorRig((dir / "rig.yaml").string());
  const Camera& cam = rig.cameras[0].camera;
  const VioPipelineOptions po = diag::PipelineOptions(options, stereo);
  VioPipeline pipeline(rig, po);

  const std::vector<AslEvent> events = ArrivalOrder(dataset, po.cameras);

  std::map<int64_t, Landmark> landmarks;
  std::vector<Observation> observations;
  int frame = 0;
  int64_t t0_ns = -1;
  VioFrameOutput out;
  auto consume = [&](const VioFrameOutput& o) {
    if (!o.pose.tracking()) return;
    ++frame;
    const VioFilter& filter = pipeline.stage().filter();
    const FilterState& x = filter.state();
    const int64_t t_cam = x.t_ns - rig.cameras[0].time_offset_ns;
    if (t0_ns < 0) t0_ns = x.t_ns;
    const Transformation T_W_C = simulator.T_W_C(0, t_cam);
    const Eigen::Matrix3d R_W_C = T_W_C.rotationMatrix();
    for (int slot = 0; slot < static_cast<int>(x.features.size()); ++slot) {
      const FeatureState& f = x.features[static_cast<std::size_t>(slot)];
      if (!f.active) continue;
      const int64_t id = filter.feature_id(slot);
      Eigen::Vector2d px_est;
      if (cam.Project(f.mu_C, &px_est) != Camera::ProjectionResult::kValid) continue;
      auto it = landmarks.find(id);
      if (it == landmarks.end()) {
        // Detected on this frame: the world point its pixel sees.
        const Eigen::Vector3d d_W = R_W_C * f.mu_C.normalized();
        const double d = simulator.world().RayCast(T_W_C.translation(), d_W);
        if (!std::isfinite(d)) continue;
        landmarks[id] = {T_W_C.translation() + d * d_W, frame};
        continue;
      }
      Observation ob;
      ob.t_s = 1e-9 * static_cast<double>(x.t_ns - t0_ns);
      ob.id = id;
      ob.age = frame - it->second.first_frame;
      const Eigen::Vector3d p_C = T_W_C.inverse() * it->second.p_W;
      if (cam.Project(p_C, &ob.px_true) != Camera::ProjectionResult::kValid) continue;
      ob.px_est = px_est;
      ob.distance_true = p_C.norm();
      ob.rho_est = f.rho;
      {
        const Eigen::MatrixXd& P = filter.covariance();
        const int k = FeatureIndex(slot);
        Eigen::Vector2d px_unused;
        Eigen::Matrix<double, 2, 3> J_px;
        cam.Project(f.mu_C, &px_unused, &J_px);
        const Eigen::Matrix<double, 2, 2> J = J_px * BearingBasis(f.mu_C);
        const Eigen::Matrix2d S = J * P.block<2, 2>(k, k) * J.transpose();
        const Eigen::Vector2d d = ob.px_est - ob.px_true;
        ob.nees_px = d.dot(S.ldlt().solve(d));
        const double drho = f.rho - 1.0 / ob.distance_true;
        ob.nees_rho = drho * drho / P(k + 2, k + 2);
      }
      const double d = simulator.world().RayCast(
          T_W_C.translation(), (it->second.p_W - T_W_C.translation()).normalized());
      ob.visible = std::abs(d - ob.distance_true) < 0.01 * ob.distance_true + 0.01;
      observations.push_back(ob);
    }
  };
  for (const AslEvent& ev : events) {
    if (ev.stream < 0) {
      pipeline.AddImu(dataset.imu()[ev.index]);
    } else {
      const CameraFrame& fr =
          dataset.cameras()[static_cast<std::size_t>(ev.stream)].frames[ev.index];
      pipeline.AddImage(ev.stream, fr.t_ns, AslDataset::LoadImage(fr.image_path));
    }
    while (pipeline.NextOutput(&out)) consume(out);
  }
  return observations;
}

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

void Summarize(const std::string& title, const std::vector<Observation>& obs) {
  std::printf("%s\n%10s %7s %9s %9s %9s %9s %9s %9s %9s %9s %9s\n", title.c_str(), "age", "n",
              "mean dx", "mean dy", "med dx", "med dy", "med |d|", "NEESpx", "medNEESpx", "NEESrho",
              "medNEESrho");
  const int edges[] = {1, 2, 5, 10, 20, 40, 80, 160, 100000};
  for (int b = 0; b + 1 < static_cast<int>(std::size(edges)); ++b) {
    std::vector<double> dx, dy, dn, npx, nrho;
    for (const Observation& o : obs) {
      if (!o.visible || o.age < edges[b] || o.age >= edges[b + 1]) continue;
      const Eigen::Vector2d d = o.px_est - o.px_true;
      if (d.norm() > 5.0) continue;  // lost track (counted apart)
      dx.push_back(d.x());
      dy.push_back(d.y());
      dn.push_back(d.norm());
      npx.push_back(o.nees_px);
      nrho.push_back(o.nees_rho);
    }
    auto mean_of = [](const std::vector<double>& v) {
      double m = 0;
      for (double a : v) m += a;
      return v.empty() ? 0.0 : m / static_cast<double>(v.size());
    };
    double mx = 0, my = 0;
    for (std::size_t i = 0; i < dx.size(); ++i) {
      mx += dx[i];
      my += dy[i];
    }
    const double n = static_cast<double>(std::max<std::size_t>(1, dx.size()));
    std::printf("%4d-%-5d %7zu %+9.3f %+9.3f %+9.3f %+9.3f %9.3f %9.2f %9.2f %9.2f %9.2f\n",
                edges[b], edges[b + 1] - 1, dx.size(), mx / n, my / n, Median(dx), Median(dy),
                Median(dn), mean_of(npx), Median(npx), mean_of(nrho), Median(nrho));
  }
}

void WriteCsv(const std::filesystem::path& path, const std::vector<Observation>& obs) {
  std::ofstream f(path);
  f << "t_s,id,age,u_true,v_true,u_est,v_est,distance_true,rho_est,visible,nees_px,nees_rho\n";
  for (const Observation& o : obs) {
    f << o.t_s << "," << o.id << "," << o.age << "," << o.px_true.x() << "," << o.px_true.y() << ","
      << o.px_est.x() << "," << o.px_est.y() << "," << o.distance_true << "," << o.rho_est << ","
      << (o.visible ? 1 : 0) << "," << o.nees_px << "," << o.nees_rho << "\n";
  }
}

TEST_CASE("stereo diagnosis: feature tracks against the simulator's geometry", "[.diagnostic]") {
  const FilterOptions options = diag::Options();
  const std::filesystem::path out = diag::OutDir();
  for (const std::string& name : diag::SetNames("room-easy")) {
    const std::filesystem::path dir = diag::DatasetDir(name);
    if (!std::filesystem::exists(dir / "sim.yaml")) VILMA_SKIP(dir << " is not there");
    for (bool stereo : {false, true}) {
      if (!diag::WantsMode(stereo, "mono")) continue;
      const std::vector<Observation> obs = TrackAgainstTruth(dir, stereo, options);
      const std::string mode = stereo ? "stereo" : "mono";
      WriteCsv(out / (name + "-" + mode + "-tracks.csv"), obs);
      Summarize(name + " " + mode + ": filter pixel - true pixel [px] by frames since detection",
                obs);
    }
  }
}

// Writes `out` = the set `dir` with another IMU realization (see the header comment): the
// simulator's own IMU draws (`vilma-sim --imu-draw N --images-from DIR`, the same code), or one
// part of the noise model from the set's own stream.
void WriteImuVariant(const std::filesystem::path& dir, const std::string& variant,
                     const std::filesystem::path& out) {
  sim::SimOptions so = sim::ReadSimYaml((dir / "sim.yaml").string());
  sim::ImuSimOptions& imu_options = so.imu;
  if (variant == "exact") {
    imu_options = sim::ImuSimOptions::NoiseFree();
  } else if (variant == "gyro") {  // the gyroscope's noise, bias and walk; an exact accelerometer
    imu_options.noise.accelerometer_noise_density = 0.0;
    imu_options.noise.accelerometer_random_walk = 0.0;
    imu_options.initial_accel_bias_sigma = 0.0;
  } else if (variant == "accel") {  // the accelerometer's; an exact gyroscope
    imu_options.noise.gyroscope_noise_density = 0.0;
    imu_options.noise.gyroscope_random_walk = 0.0;
    imu_options.initial_gyro_bias_sigma = 0.0;
  } else if (variant == "white") {  // white noise only: zero biases, no walk
    imu_options.add_bias_random_walk = false;
    imu_options.initial_gyro_bias_sigma = 0.0;
    imu_options.initial_accel_bias_sigma = 0.0;
  } else if (variant == "walk") {  // biases and their walk, no white noise
    imu_options.add_white_noise = false;
  } else {
    so.imu_draw = std::stoi(variant);
  }
  sim::Simulator simulator(so);
  simulator.WriteDatasetWithImagesFrom(out.string(), dir.string());
  std::ofstream(out / "sim.yaml", std::ios::app)
      << "# IMU variant " << variant
      << " (tests/estimator/vio_tracking_truth_sim_test.cpp): same images, other IMU draws\n";
}

TEST_CASE("stereo diagnosis: IMU variants of a simulated set", "[.diagnostic]") {
  const std::string variants = diag::EnvOr("VILMA_DIAG_IMU_VARIANTS", "0");
  const std::filesystem::path out = diag::OutDir();
  for (const std::string& name : diag::SetNames("room-easy")) {
    const std::filesystem::path dir = diag::DatasetDir(name);
    if (!std::filesystem::exists(dir / "sim.yaml")) VILMA_SKIP(dir << " is not there");
    std::stringstream v(variants);
    for (std::string variant; std::getline(v, variant, ',');) {
      WriteImuVariant(dir, variant, out / (name + "-imu" + variant));
    }
  }
}

TEST_CASE("stereo diagnosis: feature dynamics against the simulator's geometry", "[.diagnostic]") {
  for (const std::string& name : diag::SetNames("room-easy")) {
    const std::filesystem::path dir = diag::DatasetDir(name);
    if (!std::filesystem::exists(dir / "sim.yaml")) VILMA_SKIP(dir << " is not there");
    sim::SimOptions so = sim::ReadSimYaml((dir / "sim.yaml").string());
    so.imu = sim::ImuSimOptions::NoiseFree();
    sim::Simulator simulator(so);
    const SensorRig& rig = simulator.rig();
    const Camera& cam = rig.cameras[0].camera;
    const Transformation& T_I_C = rig.cameras[0].T_I_C;
    const std::vector<ImuSample>& imu = simulator.imu().samples;
    const double g = rig.imu.gravity_magnitude;
    for (const int horizon_frames : {1, 20}) {
      std::vector<double> dx, dy, dn, yaw_err;
      PropagationJacobians J;
      J.Resize(48);
      for (int f0 = 40; f0 + horizon_frames < simulator.num_frames(); f0 += 10) {
        const int64_t t0 = simulator.frame_time_ns(f0),
                      t1 = simulator.frame_time_ns(f0 + horizon_frames);
        const sim::TrajectoryState s0 = simulator.trajectory().Evaluate(
            1e-9 * static_cast<double>(t0 - simulator.start_time_ns()));
        const Transformation T_W_C0 = s0.T_W_I * T_I_C;
        FilterState x;
        x.t_ns = t0;
        x.p_M_I = s0.T_W_I.translation();
        x.v_M = s0.v_W;
        x.q_M_I = s0.T_W_I.rotation();
        x.q_I_C = T_I_C.rotation();
        x.p_I_C = T_I_C.translation();
        std::vector<Eigen::Vector3d> points_W;
        for (int gy = 0; gy < 6; ++gy) {
          for (int gx = 0; gx < 8; ++gx) {
            const Eigen::Vector2d px(60.0 + gx * 90.0, 40.0 + gy * 80.0);
            Eigen::Vector3d mu;
            if (!cam.Unproject(px, &mu)) continue;
            mu.normalize();
            const double d =
                simulator.world().RayCast(T_W_C0.translation(), T_W_C0.rotationMatrix() * mu);
            if (!std::isfinite(d)) continue;
            FeatureState fs;
            fs.active = true;
            fs.mu_C = mu;
            fs.rho = 1.0 / d;
            x.features.push_back(fs);
            points_W.push_back(T_W_C0 * (mu * d));
          }
        }
        J.Resize(static_cast<int>(x.features.size()));
        // Samples are at t0 + k * 5 ms; each interval uses the mean of its two samples (the
        // linear interpolation at its midpoint).
        std::size_t k = 0;
        while (k < imu.size() && imu[k].t_ns < t0) ++k;
        for (; k + 1 < imu.size() && imu[k + 1].t_ns <= t1; ++k) {
          const double dt = 1e-9 * static_cast<double>(imu[k + 1].t_ns - imu[k].t_ns);
          PropagateMean(0.5 * (imu[k].omega_I + imu[k + 1].omega_I),
                        0.5 * (imu[k].a_I + imu[k + 1].a_I), dt, g, &x, &J);
        }
        const sim::TrajectoryState s1 = simulator.trajectory().Evaluate(
            1e-9 * static_cast<double>(t1 - simulator.start_time_ns()));
        const Transformation T_C1_W = (s1.T_W_I * T_I_C).inverse();
        const Eigen::Vector3d dtheta_W =
            s1.T_W_I.rotationMatrix() * LogSO3(s1.T_W_I.rotation().conjugate() * x.q_M_I);
        yaw_err.push_back(dtheta_W.z());
        for (std::size_t i = 0; i < x.features.size(); ++i) {
          Eigen::Vector2d truth, pred;
          if (cam.Project(T_C1_W * points_W[i], &truth) != Camera::ProjectionResult::kValid)
            continue;
          if (cam.Project(x.features[i].mu_C, &pred) != Camera::ProjectionResult::kValid) continue;
          dx.push_back(pred.x() - truth.x());
          dy.push_back(pred.y() - truth.y());
          dn.push_back((pred - truth).norm());
        }
      }
      auto mean = [](const std::vector<double>& v) {
        double m = 0;
        for (double a : v) m += a;
        return v.empty() ? 0.0 : m / static_cast<double>(v.size());
      };
      std::printf(
          "%s, horizon %d frame(s): %zu predictions, pixel error mean (%+.5f, %+.5f) px, median "
          "|e| %.5f px, max |e| %.5f px; body yaw error mean %+.3e rad\n",
          name.c_str(), horizon_frames, dx.size(), mean(dx), mean(dy), Median(dn),
          dn.empty() ? 0.0 : *std::max_element(dn.begin(), dn.end()), mean(yaw_err));
    }
  }
}

}  // namespace
}  // namespace vilma::estimator

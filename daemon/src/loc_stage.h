// The localization stage (LOC mode, docs/daemon.md "Localization"): a thread that extracts the
// keyframe features of the frames handed over and localizes them against the prior map
// (Localizer::Localize: retrieval, covisibility, P3P RANSAC). LocClient is its filter-thread
// side: the query scheduler (LocQueryScheduler), the T_G_M estimate fused from the results
// (estimator::GlobalFrameEstimator), every attempt to VILMA_LOC, and T_G_I for VILMA_POSE.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "pipeline.h"
#include "vilma/core/rig.h"
#include "vilma/daemon/daemon_options.h"
#include "vilma/estimator/global_frame_estimator.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/localizer/localizer.h"

namespace vilma::daemon {

// Which tracking frames are localized: every N-th, N = ceil(camera rate / max_rate_hz), so
// never more often than max_rate_hz (20 Hz / 2 Hz: every 10th; 25 Hz / 3 Hz: every 9th,
// 2.8 Hz). Counting frames (--input-log) is exact; live, the scheduler waits (N - 1/2) camera
// periods since the last query, so that stamp jitter neither advances nor delays the query by a
// frame. Without a camera rate: 1 / max_rate_hz since the last query.
class LocQueryScheduler {
 public:
  LocQueryScheduler(double camera_rate_hz, double max_rate_hz, bool count_frames);
  // For every tracking frame, in order: true when this one is to be localized.
  bool Wanted(int64_t t_ns);
  // A query went out for the frame at t_ns.
  void Queried(int64_t t_ns);
  int64_t every_n() const { return every_n_; }
  int64_t min_dt_ns() const { return min_dt_ns_; }

 private:
  bool count_frames_;
  int64_t every_n_ = 1;
  int64_t min_dt_ns_ = 0;
  int64_t tracked_frames_ = 0;
  bool has_query_ = false;
  int64_t last_query_ns_ = 0;
};

class LocStage {
 public:
  // Loads the map (a localization map file, or a VI-map folder it is built from), the localizer
  // and the query features. Throws InputError for a missing or empty map.
  LocStage(const LocalizationOptions& options, const CameraConfig& camera, Pipeline* pipeline);
  ~LocStage();

  Spsc<LocItem>& queue() { return *queue_; }
  Spsc<LocResultItem>& results() { return *results_; }
  std::atomic<int>& in_flight() { return in_flight_; }  // queries queued or running (0 or 1)
  const std::string& report() const { return report_; }  // the map, as loaded
  // The thread loop: until the filter is done and the queue is empty. Sets loc_done.
  void Run();

 private:
  const CameraConfig& camera_;
  Pipeline& p_;
  std::unique_ptr<localizer::Localizer> localizer_;          // const, used by the loc thread
  std::unique_ptr<localizer::FeatureExtractor> extractor_;  // loc thread only
  std::unique_ptr<Spsc<LocItem>> queue_;                    // filter -> localizer
  std::unique_ptr<Spsc<LocResultItem>> results_;            // localizer -> filter
  std::atomic<int> in_flight_{0};
  std::string report_;
};

// The filter thread's side of LOC mode.
class LocClient {
 public:
  LocClient(const LocalizationOptions& options, double camera_rate_hz, Pipeline* pipeline,
            LocStage* stage, Spsc<OutputItem>* output);

  // The filter's M frame starts anew (restart, reset): results of the old M are stale and
  // T_G_M is unknown again.
  void NewMFrame();
  // Applies the results that came back (live: since the last frame).
  void ApplyResults();
  // A tracking frame (pose valid, no reset): localized when the scheduler wants it and the
  // localizer is free (live) / after the previous query (--input-log: then waits for the
  // result and applies it at this very frame, on every run the same).
  void OnTrackedFrame(int64_t t_ns, const Transformation& T_M_I, const cv::Mat& image);
  bool initialized() const { return global_frame_.initialized(); }
  // VILMA_POSE of a tracked frame once T_G_M is known: T_G_I = T_G_M T_M_I, v_G = R_G_M v_M.
  void FillGlobalPose(const Transformation& T_M_I, const Eigen::Vector3d& v_M, OutputItem* out) const;
  // The global covariance from the odometry's C_M (position, rotation; global left errors):
  // rotated into G with R_G_M, plus the T_G_M uncertainty (position block; yaw on the z
  // rotation). Cross terms between both are neglected.
  void FillGlobalCovariance(const Matrix6d& C_M, OutputItem* out) const;
  // End of the run: waits (bounded) for a query still in the localizer and applies it.
  void Drain();

 private:
  LocDecision Decide(const LocResultItem& res);
  void Apply(const LocResultItem& res);

  const LocalizationOptions& options_;
  Pipeline& p_;
  LocStage& stage_;
  Spsc<OutputItem>& output_;
  estimator::GlobalFrameEstimator global_frame_;
  LocQueryScheduler scheduler_;
  uint64_t epoch_ = 0;  // M frame generation: results of an older M are stale
  OutputItem loc_out_;  // reused: plain data, no allocation
  LocResultItem result_;
};

}  // namespace vilma::daemon

#include "loc_stage.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/daemon/latency_window.h"
#include "vilma/mapping/locmap/localization_map_file.h"

namespace vilma::daemon {
namespace {

// Covariance of (R a, R b) when (a, b) has covariance C: A C A^T with A = diag(R, R) (a
// position and a rotation error moved into another frame).
Matrix6d RotateCovariance(const Eigen::Matrix3d& R, const Matrix6d& C) {
  Matrix6d A = Matrix6d::Zero();
  A.block<3, 3>(0, 0) = R;
  A.block<3, 3>(3, 3) = R;
  return A * C * A.transpose();
}

}  // namespace

// ---------------------------------------------------------------- LocQueryScheduler

LocQueryScheduler::LocQueryScheduler(double camera_rate_hz, double max_rate_hz, bool count_frames)
    : count_frames_(count_frames) {
  every_n_ = std::max<int64_t>(
      1, camera_rate_hz > 0.0 ? static_cast<int64_t>(std::ceil(camera_rate_hz / max_rate_hz - 1e-9))
                              : 1);
  min_dt_ns_ = camera_rate_hz > 0.0
                   ? std::llround((static_cast<double>(every_n_) - 0.5) / camera_rate_hz * 1e9)
                   : std::llround(1e9 / max_rate_hz);
}

bool LocQueryScheduler::Wanted(int64_t t_ns) {
  const bool wanted = count_frames_ ? tracked_frames_ % every_n_ == 0
                                    : !has_query_ || t_ns - last_query_ns_ >= min_dt_ns_;
  ++tracked_frames_;
  return wanted;
}

void LocQueryScheduler::Queried(int64_t t_ns) {
  has_query_ = true;
  last_query_ns_ = t_ns;
}

// ---------------------------------------------------------------- LocStage

LocStage::LocStage(const LocalizationOptions& lo, const CameraConfig& camera, Pipeline* pipeline)
    : camera_(camera), p_(*pipeline) {
  const auto t0 = std::chrono::steady_clock::now();
  // Options loaded once; the map opened the one way every program opens it (mapping/locmap):
  // a .vlocmap file, or a VI-map folder summarized now.
  const localizer::LocalizerOptions lopt = lo.localizer_file.empty()
                                               ? localizer::LocalizerOptions()
                                               : localizer::LoadLocalizerOptions(lo.localizer_file);
  const mapping::OpenedLocalizationMap opened =
      mapping::OpenLocalizationMap(lo.map, lopt.map, "localization.map / --localization-map");
  if (opened.from_vimap && opened.missions.missions_skipped > 0) {
    std::fprintf(stderr,
                 "vilma-estimatord: localization map %s: %d of %zu missions used (the others "
                 "are not anchored: their frames are unknown in G)\n",
                 lo.map.c_str(), opened.missions.missions_used, opened.vimap_missions);
  }
  const std::shared_ptr<localizer::LocalizationMap>& map = opened.map;
  localizer_ = std::make_unique<localizer::Localizer>(map, lopt);
  // The query profile (localization.features): by default the map builder's features with a
  // scale pyramid, so that the query matches the map across distances.
  extractor_ = std::make_unique<localizer::FeatureExtractor>(lo.features);
  queue_ = std::make_unique<Spsc<LocItem>>(4);
  results_ = std::make_unique<Spsc<LocResultItem>>(4);
  std::ostringstream r;
  r << "localization map " << lo.map << ": " << map->num_landmarks() << " landmarks, "
    << map->num_descriptors() << " descriptors, loaded and indexed in "
    << static_cast<int>(
           std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count())
    << " ms; query features "
    << (lo.features_file.empty() ? std::string("built-in profile") : lo.features_file) << " ("
    << lo.features.detector.num_levels << " levels, " << lo.features.detector.max_keypoints
    << " keypoints at most)";
  report_ = r.str();
  std::fprintf(stderr, "vilma-estimatord: %s\n", report_.c_str());
}

LocStage::~LocStage() = default;

// The result goes back to the filter thread, which owns the T_G_M estimate.
void LocStage::Run() {
  LatencyWindow stage_ms;
  double max_us = 0.0;
  std::vector<Eigen::Vector2d> uv;
  LocItem item;
  while (true) {
    bool any = false;
    while (queue_->pop(item)) {
      any = true;
      const int64_t t0 = SteadyNs();
      const localizer::KeyframeFeatures f = extractor_->Extract(item.image);
      item.image.release();  // back to the pool
      uv.clear();
      for (const cv::KeyPoint& k : f.keypoints) uv.emplace_back(k.pt.x, k.pt.y);
      LocResultItem out;
      out.t_ns = item.t_ns;
      out.epoch = item.epoch;
      out.T_M_I = item.T_M_I;
      out.num_keypoints = static_cast<int>(uv.size());
      if (uv.empty()) {
        out.status = localizer::LocalizationStatus::kNoKeypoints;
      } else {
        const localizer::LocalizationResult r =
            localizer_->Localize(camera_.camera, camera_.T_I_C, uv, f.descriptors.ptr<uint8_t>());
        out.status = r.status;
        out.T_G_I = r.T_G_I;
        out.covariance_I = r.covariance_I;
        out.inliers = static_cast<int>(r.inliers.size());
        out.num_matches = static_cast<int>(r.matches.size());
      }
      const double ms = static_cast<double>(SteadyNs() - t0) * 1e-6;
      out.stage_ms = ms;
      stage_ms.Add(ms);
      max_us = std::max(max_us, ms * 1e3);
      p_.counters.Set(kLocStageUsP50, static_cast<int64_t>(stage_ms.Percentile(0.5) * 1e3));
      p_.counters.Set(kLocStageUsMax, static_cast<int64_t>(max_us));
      // Capacity 4 with at most one query in flight: never full.
      while (!results_->push(out) && !p_.stop.load()) {
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
      in_flight_.fetch_sub(1);
      p_.filter_wake.Notify();
    }
    if (!any) {
      if (p_.filter_done.load() && queue_->read_available() == 0) break;
      p_.loc_wake.Wait(50 * kMs);
    }
  }
  p_.loc_done.store(true);
}

// ---------------------------------------------------------------- LocClient (filter thread)

LocClient::LocClient(const LocalizationOptions& options, double camera_rate_hz, Pipeline* pipeline,
                     LocStage* stage, Spsc<OutputItem>* output)
    : options_(options),
      p_(*pipeline),
      stage_(*stage),
      output_(*output),
      global_frame_(options.global_frame),
      scheduler_(camera_rate_hz, options.max_rate_hz, pipeline->log_mode) {
  loc_out_.kind = OutputItem::Kind::kLoc;
}

void LocClient::NewMFrame() {
  ++epoch_;
  if (global_frame_.initialized()) p_.counters.Add(kLocTgmResets);
  global_frame_.Reset();
  p_.counters.Set(kLocInitialized, 0);
}

LocDecision LocClient::Decide(const LocResultItem& res) {
  using localizer::LocalizationStatus;
  Counters& c = p_.counters;
  c.Add(LocStatusCounter(res.status));
  if (res.status != LocalizationStatus::kOk) return LocDecision::kFailed;
  if (res.epoch != epoch_) {
    c.Add(kLocRejectedStale);
    return LocDecision::kRejectedStale;
  }
  if (res.inliers < options_.min_inliers) {
    c.Add(kLocRejectedInliers);
    return LocDecision::kRejectedInliers;
  }
  LocDecision d = LocDecision::kAccepted;
  switch (global_frame_.Update(res.T_G_I, res.covariance_I, res.T_M_I, res.t_ns)) {
    case estimator::GlobalFrameUpdate::kAccepted: c.Add(kLocTgmUpdates); break;
    case estimator::GlobalFrameUpdate::kRejectedGravity:
      c.Add(kLocRejectedGravity);
      d = LocDecision::kRejectedGravity;
      break;
    case estimator::GlobalFrameUpdate::kRejectedJump:
      c.Add(kLocRejectedJump);
      d = LocDecision::kRejectedJump;
      break;
    case estimator::GlobalFrameUpdate::kReinitialized:
      // Gated, but the gated results in a row outvoted the estimate: it restarts from this
      // one, which is thus accepted (loc_rejected_jump counts only results left unused).
      c.Add(kLocTgmResets);
      c.Add(kLocTgmUpdates);
      break;
  }
  c.Set(kLocInitialized, global_frame_.initialized() ? 1 : 0);
  return d;
}

// Every result, used or not, goes out on VILMA_LOC through the publisher queue.
void LocClient::Apply(const LocResultItem& res) {
  LocRecord& rec = loc_out_.loc;
  rec = LocRecord();
  rec.decision = Decide(res);
  rec.t_ns = res.t_ns;
  rec.status = res.status;
  rec.num_keypoints = res.num_keypoints;
  rec.num_matches = res.num_matches;
  rec.num_inliers = res.inliers;
  rec.stage_ms = res.stage_ms;
  if (res.status == localizer::LocalizationStatus::kOk) {
    const Eigen::Vector3d& p = res.T_G_I.translation();
    const Eigen::Quaterniond& q = res.T_G_I.rotation();
    for (int i = 0; i < 3; ++i) rec.position[i] = p[i];
    rec.orientation[0] = q.w();
    rec.orientation[1] = q.x();
    rec.orientation[2] = q.y();
    rec.orientation[3] = q.z();
    // The localizer's covariance is of xi = [rho; phi] in T_G_I Exp(xi) (body, right). To
    // first order p = p_G_I + R rho and R_G_I Exp(phi) = Exp(R phi) R_G_I, so pose_t's
    // global (left) errors are (R rho, R phi): Cov = A C A^T with A = diag(R_G_I, R_G_I).
    CopyRowMajor(RotateCovariance(q.toRotationMatrix(), res.covariance_I), rec.covariance);
  }
  if (!Push(p_, output_, loc_out_)) {
    p_.counters.Add(kLocMessagesDropped);
  } else {
    p_.output_wake.Notify();
  }
}

void LocClient::ApplyResults() {
  while (stage_.results().pop(result_)) Apply(result_);
}

void LocClient::OnTrackedFrame(int64_t t_ns, const Transformation& T_M_I, const cv::Mat& image) {
  if (!scheduler_.Wanted(t_ns)) {
    p_.counters.Add(kLocThinned);
    return;
  }
  std::atomic<int>& in_flight = stage_.in_flight();
  if (!p_.log_mode && in_flight.load() > 0) {
    p_.counters.Add(kLocBusy);  // the next frame tries again
    return;
  }
  LocItem q;
  q.t_ns = t_ns;
  q.epoch = epoch_;
  q.T_M_I = T_M_I;
  q.image = image;
  in_flight.fetch_add(1);
  if (!stage_.queue().push(q)) {
    in_flight.fetch_sub(1);
    p_.counters.Add(kLocBusy);
    return;
  }
  p_.counters.Add(kLocAttempts);
  scheduler_.Queried(t_ns);
  p_.loc_wake.Notify();
  if (p_.log_mode) {
    // Deterministic: the result is applied at this very frame on every run.
    while (in_flight.load() > 0 && !p_.stop.load()) {
      p_.notifier.PetWatchdog(SteadyNs());
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
    ApplyResults();
  }
}

void LocClient::FillGlobalPose(const Transformation& T_M_I, const Eigen::Vector3d& v_M,
                               OutputItem* out) const {
  const Transformation T_G_M = global_frame_.T_G_M();
  const Transformation T_G_I = T_G_M * T_M_I;
  const Eigen::Quaterniond& qg = T_G_I.rotation();
  const Eigen::Vector3d v_G = T_G_M.rotation() * v_M;
  out->global = true;
  for (int i = 0; i < 3; ++i) {
    out->g_position[i] = T_G_I.translation()[i];
    out->g_velocity[i] = v_G[i];
  }
  out->g_orientation[0] = qg.w();
  out->g_orientation[1] = qg.x();
  out->g_orientation[2] = qg.y();
  out->g_orientation[3] = qg.z();
}

void LocClient::FillGlobalCovariance(const Matrix6d& C_M, OutputItem* out) const {
  Matrix6d G = RotateCovariance(global_frame_.T_G_M().rotation().toRotationMatrix(), C_M);
  const Eigen::Matrix4d P_gm = global_frame_.covariance();
  G.block<3, 3>(0, 0) += P_gm.block<3, 3>(0, 0);
  G(5, 5) += P_gm(3, 3);
  CopyRowMajor(G, out->g_covariance);
}

void LocClient::Drain() {
  // Live: a query may still be in the localizer. Its result is reported too (every attempt
  // gets its VILMA_LOC); bounded, the localizer runs at most one query (tens of ms). Not cut
  // short by `stop`: live input ends by SIGTERM, which sets it, and the localizer thread
  // finishes its query whatever `stop` says (it runs until filter_done).
  const int64_t deadline = SteadyNs() + 5 * 1000 * kMs;
  while (stage_.in_flight().load() > 0 && SteadyNs() < deadline) {
    p_.notifier.PetWatchdog(SteadyNs());
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  ApplyResults();
}

}  // namespace vilma::daemon

// Offline map check on a recorded session (`vilma localize`, docs/localizer.md "Command line"):
// every Nth image of one camera of an ASL/EuRoC dataset is localized against a localization map
// with a given query feature profile, and the results are compared with the dataset's ground
// truth when it has some. The console command only reads its inputs (options, rig, map) and
// prints what this returns.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/geometry.h"
#include "vilma/core/rig.h"
#include "vilma/eval/alignment.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/localizer/localizer.h"

namespace vilma::eval {

struct DatasetLocalizationOptions {
  int every = 10;  // query every Nth frame (>= 1)
  int camera = 0;  // camera index in both the rig and the dataset (>= 0)
  // How the map frame G relates to the dataset's ground-truth frame W: kNone (G = W, e.g. a map
  // from vilma-locmap-gt or an anchored map), or kPosYaw / kSe3 fitted to the localized
  // positions themselves (a map built by VIO has G = that run's odometry frame).
  AlignmentType align = AlignmentType::kNone;
  // Instead of `align`: a fixed S_W_G from `vilma eval --json` (alignment_transform).
  std::string align_from_path;
  // Empty when valid, else "field: expected ...".
  std::string Validate() const;
};

// One localized frame.
struct DatasetLocalizationQuery {
  std::size_t frame = 0;  // index in the camera's data.csv
  int64_t t_ns = 0;       // image time (camera clock)
  localizer::LocalizationStatus status = localizer::LocalizationStatus::kNoKeypoints;
  int keypoints = 0, raw_matches = 0, matches = 0, inliers = 0, ransac_iterations = 0;
  double rms_px = 0.0;  // RMS reprojection error of the inliers [px]
  Transformation T_G_I;
  bool has_gt = false;  // ground truth at the image time (IMU clock)
  Transformation T_W_I_gt;
  bool has_error = false;  // localized and has ground truth (errors below are set)
  double position_error_m = 0.0, rotation_error_deg = 0.0;
  // Wall and thread CPU time of the feature extraction and of Localize [ms].
  double features_ms = 0.0, features_cpu_ms = 0.0, localize_ms = 0.0, localize_cpu_ms = 0.0;
};

// The result of one check, in the shape of Ceres's Solver::Summary: what went in, counts,
// times, the per-query results, a one-line and a full report.
struct DatasetLocalizationSummary {
  // What went in.
  std::string dataset_path;
  DatasetLocalizationOptions options;
  std::size_t frames = 0;  // images of the camera
  int64_t first_frame_t_ns = 0;
  // Counts.
  int queries = 0;
  int localized = 0;          // status kOk
  int with_ground_truth = 0;  // queries with a ground-truth pose
  int within_05m = 0;         // localized within 0.5 m (of those with ground truth)
  int within_03m_2deg = 0;    // localized within 0.3 m and 2 deg
  std::array<int, static_cast<int>(localizer::LocalizationStatus::kNumStatuses)> status_counts{};
  // Errors: valid when there is ground truth and the alignment could be had.
  bool errors_valid = false;
  Alignment alignment;         // S_W_G the errors were computed with
  std::string alignment_note;  // how it was had, for the report
  // Times [ms]: percentiles of the per-query wall and thread CPU times.
  double features_ms_p50 = 0.0, features_ms_p90 = 0.0;
  double features_cpu_ms_p50 = 0.0, features_cpu_ms_p90 = 0.0;
  double localize_ms_p50 = 0.0, localize_ms_p90 = 0.0;
  double localize_cpu_ms_p50 = 0.0, localize_cpu_ms_p90 = 0.0;
  double total_s = 0.0;  // wall time of the whole check
  std::vector<DatasetLocalizationQuery> results;

  // One line: "40 queries, localized 37 (92.5 %), within 0.3 m and 2 deg 35 / 40, features p50
  // 12.0 ms, Localize p50 3.1 ms".
  std::string BriefReport() const;
  // The summary `vilma localize` prints: status counts, localized, alignment, recall, errors,
  // query times (docs/localizer.md "Command line").
  std::string FullReport() const;
  // The per-query table (a column header, then one line per query).
  std::string QueryTable() const;
  // One CSV row per query with a header (the columns of `vilma localize --out`).
  std::string Csv() const;
};

// Ground truth T_W_I at t (IMU clock): the sample at t, else linear / slerp interpolation between
// the two samples around t when they are at most 51 ms apart. False: no ground truth at t.
bool GroundTruthAt(const std::vector<GroundTruthState>& gt, int64_t t_ns, Transformation* T_W_I);

// The checks LocalizeDataset makes first, for callers that check their inputs before they load
// a map: throws InputError naming the dataset or the rig when camera `camera` is missing in
// either or has no images.
void CheckDatasetCamera(const std::string& dataset_path, const AslDataset& dataset,
                        const SensorRig& rig, const std::string& rig_source, int camera);

// Localizes every options.every-th image of camera options.camera of `dataset` (opened from
// dataset_path) with `extractor` and `localizer`, in the rig's camera model and T_I_C (rig read
// from rig_source). Single-threaded and deterministic (timings aside). Throws InputError naming
// the dataset, the rig or the image when the camera is missing, has no images, or an image does
// not have the rig camera's size; and for a bad --align-from file.
DatasetLocalizationSummary LocalizeDataset(const std::string& dataset_path,
                                           const AslDataset& dataset, const SensorRig& rig,
                                           const std::string& rig_source,
                                           const localizer::FeatureExtractor& extractor,
                                           const localizer::Localizer& localizer,
                                           const DatasetLocalizationOptions& options);

}  // namespace vilma::eval

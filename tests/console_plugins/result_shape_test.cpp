// Every result type that a console command prints has the one shape of core/report.h (Ceres's
// Solver::Summary): BriefReport() one line, FullReport() lines ending in '\n'. Checked at compile
// time (HasReports) and on a default-constructed value (nothing done: the reports still read).
#include <catch2/catch.hpp>

#include "vilma/core/report.h"
#include "vilma/eval/trajectory_evaluation.h"
#include "vilma/mapping/dense/dense_evaluation.h"
#include "vilma/mapping/dense/image_attachment.h"
#include "vilma/mapping/dense/mesh_render.h"
#include "vilma/mapping/dense/stereo_depth.h"
#include "vilma/mapping/dense/tsdf_fusion.h"
#include "vilma/mapping/dense/tum_depth_import.h"
#include "vilma/mapping/evaluation/map_evaluation.h"
#include "vilma/mapping/evaluation/mesh_evaluation.h"
#include "vilma/mapping/export/calibration_export.h"
#include "vilma/mapping/export/colmap_export.h"
#include "vilma/mapping/export/csv_export.h"
#include "vilma/mapping/export/html_viewer.h"
#include "vilma/mapping/export/map_plot.h"
#include "vilma/mapping/export/ply_export.h"
#include "vilma/mapping/export/pmvs_export.h"
#include "vilma/mapping/export/trajectory_export.h"
#include "vilma/mapping/from_poses/map_from_poses.h"
#include "vilma/mapping/from_poses/map_from_target.h"
#include "vilma/mapping/inspection/map_statistics.h"
#include "vilma/mapping/keyframing/keyframe_heuristic.h"
#include "vilma/mapping/landmarks/landmark_quality.h"
#include "vilma/mapping/landmarks/retriangulation.h"
#include "vilma/mapping/loop_closure/anchoring.h"
#include "vilma/mapping/loop_closure/loop_closure.h"
#include "vilma/mapping/optimization/pose_graph.h"
#include "vilma/mapping/optimization/vi_optimization.h"
#include "vilma/mapping/summarization/landmark_sparsification.h"

using namespace vilma;

TEMPLATE_TEST_CASE("result types: one-line BriefReport and a FullReport of whole lines",
                   "[console][report]", TrajectoryEvalSummary, mapping::DepthConsistency,
                   mapping::ImageAttachmentSummary, mapping::MeshRenderResult,
                   mapping::StereoDenseSummary, mapping::TsdfSummary,
                   mapping::TumDepthImportSummary, mapping::MapEvaluation,
                   mapping::MeshEvaluation, mapping::CalibrationExportSummary,
                   mapping::ColmapExportSummary, mapping::CsvExportSummary,
                   mapping::HtmlViewerSummary, mapping::MapPlotSummary,
                   mapping::PlyExportSummary, mapping::PmvsExportSummary,
                   mapping::TrajectoryExportSummary, mapping::MapFromPosesSummary,
                   mapping::KeyframingSummary, mapping::LandmarkQualitySummary,
                   mapping::RetriangulationSummary, mapping::TrackLandmarkSummary,
                   mapping::AnchoringSummary, mapping::LoopClosureSummary,
                   mapping::ViOptimizationSummary, mapping::LandmarkSparsificationSummary,
                   mapping::RelaxSummary, mapping::MapFromTargetSummary,
                   mapping::MapStatistics, mapping::TargetPnpComparison) {
  STATIC_REQUIRE(HasReports<TestType>::value);
  const TestType result{};
  CHECK(ReportShapeError(result) == "");
}

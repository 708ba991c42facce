// Landmark quality and triangulation commands (mapping/landmarks, docs/landmarks.md):
// evaluate_landmark_quality / elq, retriangulate_landmarks / rtl, initialize_track_landmarks /
// itl, remove_bad_landmarks / rbl, reset_landmark_quality / rlq.
#include "vilma/console/command_registry.h"
#include "vilma/mapping/inspection/map_statistics.h"
#include "vilma/mapping/landmarks/landmark_quality.h"
#include "vilma/mapping/landmarks/retriangulation.h"

namespace vilma::console {
namespace {

constexpr const char* kMissionHelp = "mission ids, unique prefixes or names, comma separated "
                                     "(default: every mission)";

std::vector<mapstore::MissionId> Missions(const mapstore::VIMap& map, const std::string& list) {
  return mapping::ResolveMissions(map, list);
}

// The elq flags (maplab's names), bound to a LandmarkQualityOptions reached through `quality`.
template <typename Options, typename Access>
Command<Options> QualityFlags(Command<Options> command, Access quality) {
  return std::move(
      command
          .FlagAt("elq_min_observers",
                  [quality](Options& o) -> int& { return quality(o).min_observers; },
                  "good needs at least this many observations")
          .FlagAt("elq_min_observation_angle_deg",
                  [quality](Options& o) -> double& {
                    return quality(o).min_observation_angle_deg;
                  },
                  "good needs a largest ray angle at the landmark of at least this [deg]")
          .FlagAt("elq_min_distance_m",
                  [quality](Options& o) -> double& { return quality(o).min_distance_m; },
                  "good needs the closest observer at least this far [m]")
          .FlagAt("elq_max_distance_m",
                  [quality](Options& o) -> double& { return quality(o).max_distance_m; },
                  "good needs the closest observer at most this far [m]")
          .FlagAt("elq_max_reprojection_error_px",
                  [quality](Options& o) -> double& {
                    return quality(o).max_reprojection_error_px;
                  },
                  "good needs an RMS reprojection error of at most this [px]"));
}

template <typename Options, typename Access>
Command<Options> TriangulationFlags(Command<Options> command, Access triangulation) {
  return std::move(
      command
          .FlagAt("triangulation_max_iterations",
                  [triangulation](Options& o) -> int& { return triangulation(o).max_iterations; },
                  "Gauss-Newton iterations after the linear solution (0: linear only)")
          .FlagAt("triangulation_keypoint_sigma_px",
                  [triangulation](Options& o) -> double& {
                    return triangulation(o).keypoint_sigma_px;
                  },
                  "keypoint noise for the landmark covariance [px]"));
}

struct ElqOptions : mapping::LandmarkQualityOptions {
  std::string map_mission;
};
struct RtlOptions : mapping::RetriangulationOptions {
  std::string map_mission;
};
struct ItlOptions : mapping::TrackLandmarkOptions {
  std::string map_mission;
};
struct MissionOnly {
  std::string map_mission;
};

void Register(CommandRegistry* registry) {
  registry->Add(
      QualityFlags(Command<ElqOptions>("evaluate_landmark_quality")
                       .Alias("elq")
                       .Group("landmarks")
                       .Summary("set every landmark good or bad by maplab's rules (observers, "
                                "ray angle, distance, reprojection error) at its position")
                       .Access(MapAccess::kModify),
                   [](ElqOptions& o) -> mapping::LandmarkQualityOptions& { return o; })
          .Flag("map_mission", &ElqOptions::map_mission, kMissionHelp, {"mission"})
          .Run([](CommandContext& c, const ElqOptions& o) {
            c.out() << mapping::EvaluateLandmarkQualities(o, &c.map(),
                                                          Missions(c.map(), o.map_mission),
                                                          c.progress())
                           .FullReport();
          }));

  registry->Add(
      TriangulationFlags(
          QualityFlags(Command<RtlOptions>("retriangulate_landmarks")
                           .Alias("rtl")
                           .Group("landmarks")
                           .Summary("triangulate every landmark again in G from all its "
                                    "observations (linear + Gauss-Newton), then elq")
                           .Access(MapAccess::kModify),
                       [](RtlOptions& o) -> mapping::LandmarkQualityOptions& {
                         return o.quality;
                       }),
          [](RtlOptions& o) -> mapping::TriangulationOptions& { return o.triangulation; })
          .Flag("evaluate_quality", &RtlOptions::evaluate_quality,
                "set the quality by the elq rules afterwards")
          .Flag("map_mission", &RtlOptions::map_mission, kMissionHelp, {"mission"})
          .Run([](CommandContext& c, const RtlOptions& o) {
            c.out() << mapping::RetriangulateLandmarks(o, &c.map(),
                                                       Missions(c.map(), o.map_mission),
                                                       c.progress())
                           .FullReport();
          }));

  registry->Add(
      TriangulationFlags(
          QualityFlags(Command<ItlOptions>("initialize_track_landmarks")
                           .Alias("init_track_landmarks")
                           .Alias("itl")
                           .Group("landmarks")
                           .Summary("a landmark per feature track whose keypoints have none "
                                    "(triangulated, quality by elq rules)")
                           .Access(MapAccess::kModify),
                       [](ItlOptions& o) -> mapping::LandmarkQualityOptions& {
                         return o.quality;
                       }),
          [](ItlOptions& o) -> mapping::TriangulationOptions& { return o.triangulation; })
          .Flag("min_track_length", &ItlOptions::min_track_length,
                "keypoints a track needs to become a landmark")
          .Flag("map_mission", &ItlOptions::map_mission, kMissionHelp, {"mission"})
          .Run([](CommandContext& c, const ItlOptions& o) {
            c.out() << mapping::InitializeTrackLandmarks(o, &c.map(),
                                                         Missions(c.map(), o.map_mission),
                                                         c.progress())
                           .FullReport();
          }));

  registry->Add(Command<MissionOnly>("remove_bad_landmarks")
                    .Alias("rbl")
                    .Group("landmarks")
                    .Summary("remove the landmarks of bad quality (their keypoints become free)")
                    .Access(MapAccess::kModify)
                    .Flag("map_mission", &MissionOnly::map_mission, kMissionHelp, {"mission"})
                    .Run([](CommandContext& c, const MissionOnly& o) {
                      const std::size_t n =
                          mapping::RemoveBadLandmarks(&c.map(), Missions(c.map(), o.map_mission));
                      c.out() << "removed " << n << " bad landmarks, " << c.map().num_landmarks()
                              << " left\n";
                    }));

  registry->Add(Command<MissionOnly>("reset_landmark_quality")
                    .Alias("rlq")
                    .Group("landmarks")
                    .Summary("set every landmark's quality to unknown")
                    .Access(MapAccess::kModify)
                    .Flag("map_mission", &MissionOnly::map_mission, kMissionHelp, {"mission"})
                    .Run([](CommandContext& c, const MissionOnly& o) {
                      const std::size_t n = mapping::ResetLandmarkQuality(
                          &c.map(), Missions(c.map(), o.map_mission));
                      c.out() << n << " landmarks set to unknown quality\n";
                    }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)

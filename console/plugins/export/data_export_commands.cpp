// Data exports of the selected map (docs/export.md): export_trajectory_to_csv (ettc),
// export_ncamera_calibration (encc), csv_export, export_landmarks_ply, export_colmap. Each
// takes --out PATH (maplab's flag name as an alias where maplab has one) and --mission (ids,
// unique id prefixes or names, comma separated; default all), writes its files atomically and
// prints which frame they are in.
#include "vilma/console/command_registry.h"
#include "vilma/mapping/export/calibration_export.h"
#include "vilma/mapping/export/colmap_export.h"
#include "vilma/mapping/export/csv_export.h"
#include "vilma/mapping/export/map_plot.h"
#include "vilma/mapping/export/ply_export.h"
#include "vilma/mapping/export/trajectory_export.h"

namespace vilma::console {
namespace {

constexpr const char* kMissionHelp =
    kMissionListHelp;

// Options of a data export command: the library's options plus the mission selector, resolved
// against the selected map when the command runs.
template <typename LibraryOptions>
struct ExportCommandOptions {
  std::string out;  // LibraryOptions::out (a path flag: completed as a path)
  std::string mission;
  LibraryOptions export_options;
  std::string Validate() const {
    LibraryOptions o = export_options;
    o.out = out;
    return o.Validate();
  }
  LibraryOptions Resolve(const mapstore::VIMap& map) const {
    LibraryOptions resolved = export_options;
    resolved.out = out;
    resolved.missions = mapping::SelectMissions(map, mission, "mission");
    return resolved;
  }
};

using TrajectoryCommandOptions = ExportCommandOptions<mapping::TrajectoryExportOptions>;
using CalibrationCommandOptions = ExportCommandOptions<mapping::CalibrationExportOptions>;
using CsvCommandOptions = ExportCommandOptions<mapping::CsvExportOptions>;
using PlyCommandOptions = ExportCommandOptions<mapping::PlyExportOptions>;
using ColmapCommandOptions = ExportCommandOptions<mapping::ColmapExportOptions>;

// --out (with maplab's alias) as a positional path, and --mission, for every export command.
template <typename O>
Command<O> ExportCommand(const std::string& name, const std::string& out_help,
                         std::vector<std::string> out_aliases) {
  Command<O> command(name);
  command.Group("export")
      .Access(MapAccess::kRead)
      .PathFlag("out", &O::out, out_help, std::move(out_aliases))
      .Positional("out")
      .Flag("mission", &O::mission, kMissionHelp, {"map_mission"});
  return command;
}

void Register(CommandRegistry* registry) {
  using T = TrajectoryCommandOptions;
  registry->Add(
      ExportCommand<T>("export_trajectory_to_csv",
                       "file or folder; several missions: one file per mission "
                       "(<name>_<mission id><ext>)",
                       {"pose_export_file"})
          .Alias("ettc")
          .Summary("vertex IMU poses per mission as TUM, EuRoC/ASL (t, p, q, v, biases), rpg or "
                   "KITTI trajectories, in frame G or M (vilma eval, evo)")
          .FlagAt("format", [](T& o) -> std::string& { return o.export_options.format; },
                  "tum, asl (euroc: 17 columns), rpg or kitti", {"csv_export_format"})
          .FlagAt(
              "frame", [](T& o) -> std::string& { return o.export_options.frame; },
              "G (global: T_G_M T_M_I) or M (mission: T_M_I)")
          .Run([](CommandContext& c, const T& o) {
            c.out() << mapping::ExportTrajectories(c.map(), o.Resolve(c.map()), c.progress())
                           .FullReport();
          }));

  using K = CalibrationCommandOptions;
  registry->Add(
      ExportCommand<K>("export_ncamera_calibration",
                       "rig YAML file or folder (rig.yaml; several missions: "
                       "rig_<mission id>.yaml)",
                       {"ncamera_calibration_export_folder"})
          .Alias("encc")
          .Summary("each mission's sensor rig (cameras, T_I_C, IMU) as vilma's rig YAML")
          .Run([](CommandContext& c, const K& o) {
            c.out() << mapping::ExportCalibrations(c.map(), o.Resolve(c.map())).FullReport();
          }));

  using S = CsvCommandOptions;
  registry->Add(
      ExportCommand<S>("csv_export", "folder for the CSV files (created)", {"csv_export_path"})
          .Summary("missions, vertices, edges, landmarks, observations (and keypoints, "
                   "descriptors, IMU) as CSV files with a header row")
          .FlagAt("export_keypoints", [](S& o) -> bool& { return o.export_options.keypoints; },
                  "write keypoints.csv (every keypoint: uv, track, landmark)",
                  {"csv_export_tracks_and_keypoints"})
          .FlagAt("export_descriptors", [](S& o) -> bool& { return o.export_options.descriptors; },
                  "write descriptors.csv (descriptor bytes as hex)", {"csv_export_descriptors"})
          .FlagAt("export_imu", [](S& o) -> bool& { return o.export_options.imu; },
                  "write imu.csv (every IMU sample of every IMU edge)", {"csv_export_imu_data"})
          .Run([](CommandContext& c, const S& o) {
            c.out() << mapping::ExportCsv(c.map(), o.Resolve(c.map()), c.progress()).FullReport();
          }));

  using P = PlyCommandOptions;
  registry->Add(
      ExportCommand<P>("export_landmarks_ply", ".ply file, or a folder (landmarks.ply in it)", {})
          .Summary("landmark positions in G as a PLY point cloud coloured by mission or quality")
          .FlagAt(
              "color_by", [](P& o) -> std::string& { return o.export_options.color_by; },
              "mission or quality (good green, bad red, unknown grey)")
          .FlagAt(
              "good_only", [](P& o) -> bool& { return o.export_options.good_only; },
              "only landmarks of quality good")
          .FlagAt(
              "binary", [](P& o) -> bool& { return o.export_options.binary; },
              "binary little-endian PLY (false: ASCII)")
          .Run([](CommandContext& c, const P& o) {
            c.out() << mapping::ExportLandmarksPly(c.map(), o.Resolve(c.map()), c.progress())
                           .FullReport();
          }));

  using C = ColmapCommandOptions;
  registry->Add(
      ExportCommand<C>("export_colmap",
                       "model folder (created): cameras.txt, images.txt, points3D.txt, images/", {})
          .Summary("COLMAP text model (world = G): cameras, vertex x camera images with "
                   "keypoints, landmarks with tracks; images where the map has them")
          .FlagAt(
              "camera_model", [](C& o) -> std::string& { return o.export_options.camera_model; },
              "auto (OPENCV / OPENCV_FISHEYE / PINHOLE as calibrated) or pinhole "
              "(undistorted cameras, keypoints and images)")
          .FlagAt(
              "undistort_alpha", [](C& o) -> double& { return o.export_options.undistort_alpha; },
              "pinhole: 0 keeps valid pixels only, 1 every source pixel")
          .FlagAt(
              "export_images", [](C& o) -> bool& { return o.export_options.images; },
              "write images/ from the map's image resources")
          .FlagAt(
              "landmarks", [](C& o) -> std::string& { return o.export_options.landmarks; },
              "landmark qualities that become points: good, unknown, bad (comma separated)")
          .FlagAt(
              "min_track_length", [](C& o) -> int& { return o.export_options.min_track_length; },
              "points need this many observations from exported images")
          .Run([](CommandContext& c, const C& o) {
            c.out()
                << mapping::ExportColmap(c.map(), o.Resolve(c.map()), c.progress()).FullReport();
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)

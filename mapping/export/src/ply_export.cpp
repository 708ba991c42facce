#include "vilma/mapping/export/ply_export.h"

#include <cstring>
#include <sstream>

#include "export_files.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/mapping/export/map_plot.h"

namespace vilma::mapping {

using mapstore::LandmarkId;
using mapstore::LandmarkQuality;
using mapstore::MissionId;
using mapstore::VIMap;

namespace {

// Little-endian bytes of an unsigned integer of `bytes` bytes (PLY binary_little_endian,
// whatever the host's order).
void AppendLittleEndian(uint64_t value, int bytes, std::string* out) {
  for (int i = 0; i < bytes; ++i) out->push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}
void AppendDouble(double value, std::string* out) {
  uint64_t bits;
  std::memcpy(&bits, &value, sizeof(bits));
  AppendLittleEndian(bits, 8, out);
}

// A header comment holds one line: line breaks in mission names become spaces.
std::string OneLine(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}

}  // namespace

std::string PlyExportOptions::Validate() const {
  if (out.empty()) return "out: expected the path of a .ply file or a folder to write";
  if (color_by != "mission" && color_by != "quality") {
    return "color_by: expected mission or quality, found '" + color_by + "'";
  }
  return "";
}

std::string PlyExportSummary::BriefReport() const {
  std::ostringstream s;
  s << "ply: " << points << " landmarks of " << missions
    << (missions == 1 ? " mission" : " missions") << " in frame G -> " << path << " (" << bytes
    << " bytes)";
  if (skipped_not_good > 0) s << ", " << skipped_not_good << " not good left out";
  return s.str();
}

std::string PlyExportSummary::FullReport() const { return BriefReport() + "\n"; }

std::array<uint8_t, 3> LandmarkQualityColorRgb(LandmarkQuality quality) {
  switch (quality) {
    case LandmarkQuality::kGood:
      return {44, 160, 44};
    case LandmarkQuality::kBad:
      return {214, 39, 40};
    case LandmarkQuality::kUnknown:
      break;
  }
  return {150, 150, 150};
}

std::string MakeLandmarksPly(const VIMap& map, const PlyExportOptions& options,
                             PlyExportSummary* summary, ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "export_landmarks_ply");
  const std::vector<MissionId> missions =
      export_files::MissionsToExport(map, options.missions, "mission");
  if (missions.size() > 65535) {
    throw InputError(FormatInputError("map", "missions", "expected at most 65535 missions"));
  }
  struct Point {
    Eigen::Vector3d p_G;
    std::array<uint8_t, 3> rgb;
    uint8_t quality;
    uint16_t mission;
    uint32_t observations;
  };
  std::vector<Point> points;
  PlyExportSummary s;
  s.missions = missions.size();
  std::size_t total = 0;
  for (const MissionId& m : missions) total += map.landmark_ids(m).size();
  BeginProgress(progress, "landmarks", total);
  std::size_t done = 0;
  for (std::size_t mi = 0; mi < missions.size(); ++mi) {
    for (const LandmarkId& id : map.landmark_ids(missions[mi])) {
      const mapstore::Landmark& l = map.landmark(id);
      if (++done % 4096 == 0) ReportProgress(progress, done);
      if (options.good_only && l.quality != LandmarkQuality::kGood) {
        ++s.skipped_not_good;
        continue;
      }
      Point p;
      p.p_G = map.LandmarkPosition_G(id);
      p.rgb =
          options.color_by == "quality" ? LandmarkQualityColorRgb(l.quality) : MissionColorRgb(mi);
      p.quality = static_cast<uint8_t>(l.quality);
      p.mission = static_cast<uint16_t>(mi);
      p.observations = static_cast<uint32_t>(l.observations.size());
      points.push_back(p);
    }
  }
  ReportProgress(progress, total);

  std::string ply = "ply\nformat ";
  ply += options.binary ? "binary_little_endian 1.0\n" : "ascii 1.0\n";
  ply += "comment vilma landmarks, positions p_G [m] in the global frame G, coloured by " +
         options.color_by + (options.good_only ? ", good landmarks only" : "") + "\n";
  ply += "comment quality: 0 unknown, 1 bad, 2 good; mission: index of the mission lines\n";
  for (std::size_t mi = 0; mi < missions.size(); ++mi) {
    const mapstore::Mission& mission = map.mission(missions[mi]);
    ply += "comment mission " + std::to_string(mi) + " " + mission.id.Hex() + " baseframe " +
           (mission.baseframe_known ? "known" : "unknown") +
           (mission.name.empty() ? "" : " " + OneLine(mission.name)) + "\n";
  }
  ply += "element vertex " + std::to_string(points.size()) + "\n";
  ply +=
      "property double x\nproperty double y\nproperty double z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "property uchar quality\nproperty ushort mission\nproperty uint observations\n"
      "end_header\n";
  for (const Point& p : points) {
    if (options.binary) {
      for (int k = 0; k < 3; ++k) AppendDouble(p.p_G[k], &ply);
      for (uint8_t c : p.rgb) ply.push_back(static_cast<char>(c));
      ply.push_back(static_cast<char>(p.quality));
      AppendLittleEndian(p.mission, 2, &ply);
      AppendLittleEndian(p.observations, 4, &ply);
    } else {
      ply += export_files::Exact(p.p_G.x()) + " " + export_files::Exact(p.p_G.y()) + " " +
             export_files::Exact(p.p_G.z()) + " " + std::to_string(p.rgb[0]) + " " +
             std::to_string(p.rgb[1]) + " " + std::to_string(p.rgb[2]) + " " +
             std::to_string(p.quality) + " " + std::to_string(p.mission) + " " +
             std::to_string(p.observations) + "\n";
    }
  }
  s.points = points.size();
  s.bytes = ply.size();
  if (summary != nullptr) *summary = s;
  return ply;
}

PlyExportSummary ExportLandmarksPly(const VIMap& map, const PlyExportOptions& options,
                                    ProgressObserver* progress) {
  PlyExportSummary summary;
  const std::string ply = MakeLandmarksPly(map, options, &summary, progress);
  summary.path = export_files::SingleFile(options.out, "out", "landmarks.ply");
  WriteFileAtomically(summary.path, ply);
  return summary;
}

}  // namespace vilma::mapping

// The parts of map_plot.h shared with the HTML viewer: mission colours, mission selection,
// vertex order, landmark subsampling, output paths, landmark quality lists.
#include <algorithm>
#include <filesystem>
#include <system_error>

#include "map_plot_util.h"
#include "vilma/core/error.h"
#include "vilma/mapping/export/map_plot.h"

namespace vilma::mapping {

namespace fs = std::filesystem;
using internal::IsHex;
using internal::Lower;
using internal::SplitComma;
using internal::Trim;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

std::array<uint8_t, 3> MissionColorRgb(std::size_t index) {
  static constexpr std::array<std::array<uint8_t, 3>, 8> kPalette = {{{31, 119, 180},
                                                                      {255, 127, 14},
                                                                      {44, 160, 44},
                                                                      {148, 103, 189},
                                                                      {140, 86, 75},
                                                                      {227, 119, 194},
                                                                      {188, 189, 34},
                                                                      {23, 190, 207}}};
  return kPalette[index % kPalette.size()];
}

std::array<uint8_t, 3> LoopClosureColorRgb() { return {214, 39, 40}; }

std::string ParseLandmarkQualities(const std::string& text, std::array<bool, 3>* keep) {
  keep->fill(false);
  const std::vector<std::string> words = SplitComma(text);
  if (words.size() == 1 && words[0] == "none") return "";
  if (words.empty()) return "comma separated good, unknown, bad, or none (not empty)";
  for (const std::string& w : words) {
    if (w == "good") {
      (*keep)[static_cast<int>(mapstore::LandmarkQuality::kGood)] = true;
    } else if (w == "bad") {
      (*keep)[static_cast<int>(mapstore::LandmarkQuality::kBad)] = true;
    } else if (w == "unknown") {
      (*keep)[static_cast<int>(mapstore::LandmarkQuality::kUnknown)] = true;
    } else {
      return "comma separated good, unknown, bad, or none (not '" + w + "')";
    }
  }
  return "";
}

std::vector<MissionId> SelectMissions(const VIMap& map, const std::string& selector,
                                      const std::string& flag) {
  const std::vector<MissionId>& all = map.mission_ids();
  if (Trim(selector).empty()) return all;
  std::vector<bool> chosen(all.size(), false);
  for (const std::string& word : SplitComma(selector)) {
    if (word.empty()) continue;  // "a,,b" or a trailing comma (an empty name selects nothing)
    std::vector<std::size_t> matches;
    for (std::size_t i = 0; i < all.size(); ++i) {
      if (map.mission(all[i]).name == word) matches.push_back(i);
    }
    if (matches.empty() && IsHex(word) && word.size() >= 4) {
      for (std::size_t i = 0; i < all.size(); ++i) {
        if (all[i].Hex().compare(0, word.size(), Lower(word)) == 0) matches.push_back(i);
      }
      if (matches.size() > 1) {
        throw InputError(FormatInputError("--" + flag, "",
                                          "an id prefix of one mission ('" + word + "' starts " +
                                              std::to_string(matches.size()) + " mission ids)"));
      }
    }
    if (matches.empty()) {
      std::string known;
      for (const MissionId& id : all) {
        known +=
            (known.empty() ? "" : ", ") + id.Hex().substr(0, 8) + " '" + map.mission(id).name + "'";
      }
      throw InputError(FormatInputError(
          "--" + flag, "",
          "a mission id, id prefix (>= 4 hex digits) or name; '" + word +
              "' matches none (missions: " + (known.empty() ? "none" : known) + ")"));
    }
    for (std::size_t i : matches) chosen[i] = true;
  }
  std::vector<MissionId> selected;
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (chosen[i]) selected.push_back(all[i]);
  }
  return selected;
}

std::size_t MissionIndex(const VIMap& map, const MissionId& mission_id) {
  const std::vector<MissionId>& all = map.mission_ids();
  return static_cast<std::size_t>(std::find(all.begin(), all.end(), mission_id) - all.begin());
}

std::vector<VertexId> VerticesInTimeOrder(const VIMap& map, const MissionId& mission_id) {
  std::vector<VertexId> ids = map.vertex_ids(mission_id);
  std::stable_sort(ids.begin(), ids.end(), [&map](const VertexId& a, const VertexId& b) {
    return map.vertex(a).t_ns < map.vertex(b).t_ns;
  });
  return ids;
}

std::vector<std::size_t> SubsampleIndices(std::size_t count, std::size_t max_count) {
  std::vector<std::size_t> indices;
  if (count <= max_count) {
    indices.resize(count);
    for (std::size_t i = 0; i < count; ++i) indices[i] = i;
    return indices;
  }
  indices.reserve(max_count);
  for (std::size_t i = 0; i < max_count; ++i) {
    // No overflow: i < max_count < count < 2^32 in any map, so i * count < 2^64.
    indices.push_back(static_cast<std::size_t>(static_cast<uint64_t>(i) * count / max_count));
  }
  return indices;
}

std::string ResolveOutputFile(const std::string& out, const std::string& default_name,
                              const std::string& extension, const std::string& flag) {
  if (out.empty()) {
    throw InputError(
        FormatInputError("--" + flag, "", "a " + extension + " file or an existing folder"));
  }
  std::error_code ec;
  if (fs::is_directory(out, ec)) return (fs::path(out) / default_name).string();
  const std::string ext = Lower(fs::path(out).extension().string());
  if (ext != extension) {
    throw InputError(FormatInputError(
        out, "--" + flag, "a file name ending in " + extension + " or an existing folder"));
  }
  const fs::path parent = fs::path(out).parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec)) {
    throw InputError(FormatInputError(
        out, "--" + flag, "an existing folder to write into (no folder " + parent.string() + ")"));
  }
  return out;
}

}  // namespace vilma::mapping

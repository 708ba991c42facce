// Map management (maplab's vi-map-basic-plugin): load, load_all, load_merge_map,
// load_merge_all_maps, join_all_maps, merge_map, save, save_all, list, select, delete, rename,
// copy_map, create_new_map, remove_mission. Merging only accumulates missions (no alignment;
// anchoring and loop closure align them), as in maplab.
#include <algorithm>
#include <filesystem>
#include <iomanip>

#include "vilma/console/command_registry.h"
#include "vilma/console/session.h"
#include "vilma/mapping/inspection/map_statistics.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;
using mapstore::VIMap;

bool IsMapFolder(const fs::path& folder) {
  std::error_code error;
  return fs::is_regular_file(folder / "manifest.yaml", error);
}

// Map folders under `root` (a folder with manifest.yaml is a map; its subfolders are not
// searched), sorted by path so that the order — and merged maps — are deterministic.
std::vector<std::string> FindMapFolders(const std::string& root) {
  std::error_code error;
  if (!fs::is_directory(root, error)) {
    throw CommandError(root + ": expected a folder of map folders");
  }
  std::vector<std::string> found;
  std::vector<fs::path> pending = {fs::path(root)};
  for (int depth = 0; depth < 4 && !pending.empty(); ++depth) {
    std::vector<fs::path> next;
    for (const fs::path& folder : pending) {
      for (const auto& entry : fs::directory_iterator(folder, error)) {
        if (!entry.is_directory(error)) continue;
        if (IsMapFolder(entry.path())) {
          found.push_back(entry.path().string());
        } else {
          next.push_back(entry.path());
        }
      }
    }
    pending = next;
  }
  std::sort(found.begin(), found.end());
  if (found.empty()) {
    throw CommandError(root + ": no map folder (a folder with manifest.yaml) found below it");
  }
  return found;
}

VIMap LoadOrFail(const std::string& folder) {
  if (folder.empty()) throw CommandError("--map_folder: expected a map folder");
  std::error_code error;
  if (!fs::is_directory(folder, error)) throw CommandError(folder + ": no such map folder");
  return mapstore::LoadMap(folder);
}

std::string Summary(const VIMap& map) {
  return std::to_string(map.mission_ids().size()) + " missions, " +
         std::to_string(map.num_vertices()) + " vertices, " +
         std::to_string(map.num_landmarks()) + " landmarks";
}

struct LoadOptions {
  std::string map_folder;
  std::string map_key;  // empty: from the folder's name
};
struct FolderOptions {
  std::string maps_folder;
  std::string map_key;
};
struct SaveOptions {
  std::string out;         // empty: the folder the map came from
  bool overwrite = false;  // replace an existing map folder
};
struct KeyOptions {
  std::string map_key;  // empty: the selected map
};
struct TargetOptions {
  std::string map_key;         // source (empty: the selected map)
  std::string target_map_key;  // destination
};
struct MissionOptions {
  std::string map_mission;
};

// Saves a store entry atomically (map_io: new generation, manifest last) and points its
// resources at the new folder.
void SaveEntry(MapStore::Entry* entry, const std::string& out, bool overwrite,
               std::ostream& report) {
  const std::string folder = out.empty() ? entry->folder : out;
  if (folder.empty()) {
    throw CommandError("--out: expected a map folder (the map was not loaded from one)");
  }
  std::error_code error;
  if (fs::exists(folder, error)) {
    if (!fs::is_directory(folder, error)) throw CommandError(folder + ": exists and is not a folder");
    if (IsMapFolder(folder) && !overwrite) {
      throw CommandError(folder + ": a map exists there; add --overwrite to replace it");
    }
    if (!IsMapFolder(folder) && !fs::is_empty(folder, error) && !overwrite) {
      throw CommandError(folder + ": the folder is not empty; add --overwrite to save into it");
    }
  }
  const mapstore::MapSaveSummary summary = mapstore::SaveMap(*entry->map, folder);
  entry->map->resources().set_folder(folder);
  entry->map->resources().ClearPending();
  entry->folder = folder;
  report << "saved to " << folder << ": generation " << summary.generation << ", "
         << summary.files_written << " files, " << std::fixed << std::setprecision(2)
         << summary.bytes_written / 1e6 << std::defaultfloat << " MB\n";
}

void Register(CommandRegistry* registry) {
  registry->Add(
      Command<LoadOptions>("load")
          .Group("maps")
          .Summary("load a map folder under a key and select it")
          .PathFlag("map_folder", &LoadOptions::map_folder, "map folder to load")
          .Flag("map_key", &LoadOptions::map_key, "key of the loaded map (default: folder name)")
          .Positional("map_folder")
          .Run([](CommandContext& c, const LoadOptions& o) {
            VIMap map = LoadOrFail(o.map_folder);
            const std::string key = o.map_key.empty() ? c.maps().KeyForFolder(o.map_folder) : o.map_key;
            c.out() << "loaded " << key << ": " << Summary(map) << "\n";
            c.maps().Add(key, std::move(map), o.map_folder);
            c.maps().Select(key);
          }));
  registry->Add(
      Command<FolderOptions>("load_all")
          .Group("maps")
          .Summary("load every map folder below a folder, each under its own key")
          .PathFlag("maps_folder", &FolderOptions::maps_folder, "folder with map folders")
          .Positional("maps_folder")
          .Run([](CommandContext& c, const FolderOptions& o) {
            const auto folders = FindMapFolders(o.maps_folder);
            // Load all first: a broken map loads none (the store stays as it was).
            std::vector<VIMap> maps;
            BeginProgress(c.progress(), "load_all", folders.size());
            for (const std::string& folder : folders) {
              maps.push_back(LoadOrFail(folder));
              ReportProgress(c.progress(), maps.size());
            }
            for (std::size_t i = 0; i < folders.size(); ++i) {
              const std::string key = c.maps().KeyForFolder(folders[i]);
              c.out() << "loaded " << key << ": " << Summary(maps[i]) << "\n";
              c.maps().Add(key, std::move(maps[i]), folders[i]);
            }
          }));
  registry->Add(
      Command<FolderOptions>("load_merge_all_maps")
          .Group("maps")
          .Summary("load every map folder below a folder into one map (missions accumulate)")
          .PathFlag("maps_folder", &FolderOptions::maps_folder, "folder with map folders")
          .Flag("map_key", &FolderOptions::map_key, "key of the merged map (default: folder name)")
          .Positional("maps_folder")
          .Run([](CommandContext& c, const FolderOptions& o) {
            const auto folders = FindMapFolders(o.maps_folder);
            VIMap merged;
            BeginProgress(c.progress(), "load_merge_all_maps", folders.size());
            std::size_t done = 0;
            for (const std::string& folder : folders) {
              VIMap map = LoadOrFail(folder);
              try {
                merged.MergeFrom(std::move(map));
              } catch (const std::invalid_argument& e) {
                throw CommandError(folder + ": " + e.what());
              }
              ReportProgress(c.progress(), ++done);
            }
            const std::string key =
                o.map_key.empty() ? c.maps().KeyForFolder(o.maps_folder) : o.map_key;
            c.out() << "merged " << folders.size() << " maps into " << key << ": "
                    << Summary(merged) << "\n";
            c.maps().Add(key, std::move(merged), "");
            c.maps().Select(key);
          }));
  registry->Add(
      Command<LoadOptions>("load_merge_map")
          .Group("maps")
          .Summary("load a map folder and merge its missions into the selected map")
          .Access(MapAccess::kModify)
          .PathFlag("map_folder", &LoadOptions::map_folder, "map folder to load")
          .Positional("map_folder")
          .Run([](CommandContext& c, const LoadOptions& o) {
            VIMap map = LoadOrFail(o.map_folder);
            c.map().MergeFrom(std::move(map));
            c.out() << c.map_key() << ": " << Summary(c.map()) << "\n";
          }));
  registry->Add(
      Command<TargetOptions>("merge_map")
          .Group("maps")
          .Summary("copy the missions of another loaded map into the selected one")
          .Access(MapAccess::kModify)
          .Flag("map_key", &TargetOptions::map_key,
                "map whose missions are merged in (it stays loaded: `delete` it when done)")
          .Positional("map_key")
          .Run([](CommandContext& c, const TargetOptions& o) {
            if (o.map_key.empty()) throw CommandError("--map_key: expected the map to merge");
            if (o.map_key == c.map_key()) throw CommandError("cannot merge a map into itself");
            // A copy: the source stays as it is whatever happens to this command.
            c.map().MergeFrom(c.maps().Get(o.map_key).map->Clone());
            c.out() << c.map_key() << ": " << Summary(c.map()) << "\n";
          }));
  registry->Add(
      Command<TargetOptions>("join_all_maps")
          .Group("maps")
          .Summary("merge every loaded map into one (the others are deleted)")
          .Flag("target_map_key", &TargetOptions::target_map_key,
                "key of the joined map (default: the selected map's)")
          .Positional("target_map_key")
          .Run([](CommandContext& c, const TargetOptions& o) {
            MapStore& maps = c.maps();
            if (maps.empty()) throw CommandError("no map is loaded");
            const std::string target = o.target_map_key.empty() ? maps.selected() : o.target_map_key;
            VIMap joined;
            const std::vector<std::string> keys = maps.Keys();
            for (const std::string& key : keys) {  // on copies: a failure changes nothing
              try {
                joined.MergeFrom(maps.Get(key).map->Clone());
              } catch (const std::invalid_argument& e) {
                throw CommandError(key + ": " + e.what());
              }
            }
            for (const std::string& key : keys) maps.Remove(key);
            maps.Add(target, std::move(joined), "");
            maps.Select(target);
            c.out() << "joined " << keys.size() << " maps into " << target << ": "
                    << Summary(*maps.Get(target).map) << "\n";
          }));
  registry->Add(
      Command<SaveOptions>("save")
          .Group("maps")
          .Summary("save the selected map (atomic: a crash leaves the previous map loadable)")
          .PathFlag("out", &SaveOptions::out, "map folder (default: where the map came from)",
                    {"map_folder"})
          .Flag("overwrite", &SaveOptions::overwrite, "replace an existing map folder")
          .Positional("out")
          .Run([](CommandContext& c, const SaveOptions& o) {
            if (c.maps().selected().empty()) throw CommandError("no map selected");
            SaveEntry(&c.maps().Get(c.maps().selected()), o.out, o.overwrite, c.out());
          }));
  registry->Add(
      Command<SaveOptions>("save_all")
          .Group("maps")
          .Summary("save every loaded map into <out>/<key>")
          .PathFlag("out", &SaveOptions::out, "folder for the map folders", {"maps_folder"})
          .Flag("overwrite", &SaveOptions::overwrite, "replace existing map folders")
          .Positional("out")
          .Run([](CommandContext& c, const SaveOptions& o) {
            if (o.out.empty()) throw CommandError("--out: expected a folder");
            for (const std::string& key : c.maps().Keys()) {
              SaveEntry(&c.maps().Get(key), (fs::path(o.out) / key).string(), o.overwrite, c.out());
            }
          }));
  registry->Add(
      Command<NoOptions>("list")
          .Alias("ls")
          .Group("maps")
          .Summary("list the loaded maps (* selected)")
          .Run([](CommandContext& c, const NoOptions&) {
            if (c.maps().empty()) c.out() << "no map is loaded\n";
            for (const std::string& key : c.maps().Keys()) {
              const MapStore::Entry& e = c.maps().Get(key);
              c.out() << (key == c.maps().selected() ? "* " : "  ") << key << ": "
                      << Summary(*e.map) << (e.folder.empty() ? "" : "  [" + e.folder + "]")
                      << "\n";
            }
          }));
  registry->Add(Command<KeyOptions>("select_map")
                    .Alias("select")
                    .Group("maps")
                    .Summary("select the map the commands work on")
                    .Flag("map_key", &KeyOptions::map_key, "key of a loaded map")
                    .Positional("map_key")
                    .Run([](CommandContext& c, const KeyOptions& o) {
                      if (o.map_key.empty()) throw CommandError("--map_key: expected a map key");
                      c.maps().Select(o.map_key);
                    }));
  registry->Add(Command<KeyOptions>("delete_map")
                    .Alias("delete")
                    .Group("maps")
                    .Summary("unload a map (the files on disk stay)")
                    .Flag("map_key", &KeyOptions::map_key, "map key (default: the selected map)")
                    .Positional("map_key")
                    .Run([](CommandContext& c, const KeyOptions& o) {
                      const std::string key = o.map_key.empty() ? c.maps().selected() : o.map_key;
                      if (key.empty()) throw CommandError("no map selected");
                      c.maps().Remove(key);
                      c.out() << "deleted " << key << "\n";
                    }));
  registry->Add(Command<TargetOptions>("rename_map")
                    .Alias("rename")
                    .Group("maps")
                    .Summary("give a loaded map another key (rename NEW, or rename OLD NEW)")
                    .Flag("map_key", &TargetOptions::map_key, "map key (default: the selected map)")
                    .Flag("target_map_key", &TargetOptions::target_map_key, "new key")
                    .Run([](CommandContext& c, const TargetOptions& o) {
                      std::string from = o.map_key, to = o.target_map_key;
                      const auto& p = c.positional();
                      if (p.size() == 1 && to.empty()) to = p[0];
                      if (p.size() == 2 && from.empty() && to.empty()) {
                        from = p[0];
                        to = p[1];
                      }
                      if (from.empty()) from = c.maps().selected();
                      if (from.empty() || to.empty()) throw CommandError("usage: rename [OLD] NEW");
                      c.maps().Rename(from, to);
                    }));
  registry->Add(Command<TargetOptions>("copy_map")
                    .Group("maps")
                    .Summary("copy the selected map under another key")
                    .Flag("target_map_key", &TargetOptions::target_map_key, "key of the copy")
                    .Positional("target_map_key")
                    .Run([](CommandContext& c, const TargetOptions& o) {
                      if (c.maps().selected().empty()) throw CommandError("no map selected");
                      if (o.target_map_key.empty()) throw CommandError("--target_map_key: expected a key");
                      c.maps().Add(o.target_map_key,
                                   c.maps().Get(c.maps().selected()).map->Clone(), "");
                    }));
  registry->Add(Command<KeyOptions>("create_new_map")
                    .Group("maps")
                    .Summary("add an empty map under a key")
                    .Flag("map_key", &KeyOptions::map_key, "key")
                    .Positional("map_key")
                    .Run([](CommandContext& c, const KeyOptions& o) {
                      if (o.map_key.empty()) throw CommandError("--map_key: expected a key");
                      c.maps().Add(o.map_key, VIMap(), "");
                    }));
  registry->Add(
      Command<MissionOptions>("remove_mission")
          .Alias("rm")
          .Group("maps")
          .Summary("remove a mission with its vertices, edges and landmarks from the selected map")
          .Access(MapAccess::kModify)
          .Flag("map_mission", &MissionOptions::map_mission,
                "mission id, unique id prefix (>= 4 hex digits) or name")
          .Positional("map_mission")
          .Run([](CommandContext& c, const MissionOptions& o) {
            if (o.map_mission.empty()) throw CommandError("--map_mission: expected a mission");
            const mapstore::MissionId id = mapping::ResolveMission(c.map(), o.map_mission);
            c.map().RemoveMission(id);
            c.out() << "removed mission " << id.Hex() << "; " << Summary(c.map()) << "\n";
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)

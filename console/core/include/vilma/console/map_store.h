// The console's loaded maps, by key, with one selected map (maplab's VIMapManager, without the
// global): commands work on the selected map.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "vilma/mapstore/vi_map.h"

namespace vilma::console {

class MapStore {
 public:
  struct Entry {
    std::unique_ptr<mapstore::VIMap> map;
    std::string folder;  // where it was loaded from or last saved to ("" for none)
    // Products computed from the map that later commands use (the TSDF volume of
    // create_tsdf_from_depth_resource for export_tsdf), by name, type-erased (the console core
    // knows no algorithm). They describe the map as it was: Replace drops them.
    std::map<std::string, std::shared_ptr<void>> derived;
  };

  // Adds a map under `key` (a non-empty word without spaces); selects it when nothing is
  // selected. Throws CommandError when the key is taken or malformed.
  void Add(const std::string& key, mapstore::VIMap map, const std::string& folder);
  bool Has(const std::string& key) const { return maps_.count(key) > 0; }
  // Throws CommandError naming the key (and the loaded keys) when it is not loaded.
  Entry& Get(const std::string& key);
  const Entry& Get(const std::string& key) const;
  // Removes a map; the selection moves to the first remaining key (or none).
  void Remove(const std::string& key);
  void Rename(const std::string& old_key, const std::string& new_key);
  // Replaces the map of an existing key (a modifying command's result) and drops its derived
  // products.
  void Replace(const std::string& key, mapstore::VIMap map);

  std::vector<std::string> Keys() const;  // sorted
  bool empty() const { return maps_.empty(); }
  const std::string& selected() const { return selected_; }
  void Select(const std::string& key);

  // A key derived from a folder name ("room" for /x/room/), made unique with _2, _3, ...
  std::string KeyForFolder(const std::string& folder) const;
  static bool IsValidKey(const std::string& key);

 private:
  std::map<std::string, Entry> maps_;
  std::string selected_;
};

}  // namespace vilma::console

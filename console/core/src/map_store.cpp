#include "vilma/console/map_store.h"

#include <filesystem>

#include "vilma/console/command_registry.h"

namespace vilma::console {

bool MapStore::IsValidKey(const std::string& key) {
  if (key.empty() || key.size() > 64) return false;
  for (char c : key) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) {
      return false;
    }
  }
  return true;
}

void MapStore::Add(const std::string& key, mapstore::VIMap map, const std::string& folder) {
  if (!IsValidKey(key)) {
    throw CommandError("map key '" + key +
                       "': expected 1-64 characters of letters, digits, '_', '-', '.'");
  }
  if (Has(key)) {
    throw CommandError("map key '" + key + "' is taken (choose another with --map_key)");
  }
  Entry entry;
  entry.map = std::make_unique<mapstore::VIMap>(std::move(map));
  entry.folder = folder;
  maps_.emplace(key, std::move(entry));
  if (selected_.empty()) selected_ = key;
}

namespace {
std::string LoadedKeys(const std::map<std::string, MapStore::Entry>& maps) {
  if (maps.empty()) return "no map is loaded";
  std::string keys = "loaded:";
  for (const auto& entry : maps) keys += " " + entry.first;
  return keys;
}
}  // namespace

MapStore::Entry& MapStore::Get(const std::string& key) {
  auto it = maps_.find(key);
  if (it == maps_.end()) throw CommandError("no map '" + key + "' (" + LoadedKeys(maps_) + ")");
  return it->second;
}

const MapStore::Entry& MapStore::Get(const std::string& key) const {
  auto it = maps_.find(key);
  if (it == maps_.end()) throw CommandError("no map '" + key + "' (" + LoadedKeys(maps_) + ")");
  return it->second;
}

void MapStore::Remove(const std::string& key) {
  Get(key);
  maps_.erase(key);
  if (selected_ == key) selected_ = maps_.empty() ? "" : maps_.begin()->first;
}

void MapStore::Rename(const std::string& old_key, const std::string& new_key) {
  if (old_key == new_key) return;
  Entry& entry = Get(old_key);
  if (!IsValidKey(new_key)) {
    throw CommandError("map key '" + new_key +
                       "': expected 1-64 characters of letters, digits, '_', '-', '.'");
  }
  if (Has(new_key)) throw CommandError("map key '" + new_key + "' is taken");
  Entry moved = std::move(entry);
  maps_.erase(old_key);
  maps_.emplace(new_key, std::move(moved));
  if (selected_ == old_key) selected_ = new_key;
}

void MapStore::Replace(const std::string& key, mapstore::VIMap map) {
  Entry& entry = Get(key);
  *entry.map = std::move(map);
  entry.derived.clear();
}

std::vector<std::string> MapStore::Keys() const {
  std::vector<std::string> keys;
  for (const auto& entry : maps_) keys.push_back(entry.first);
  return keys;
}

void MapStore::Select(const std::string& key) {
  Get(key);
  selected_ = key;
}

std::string MapStore::KeyForFolder(const std::string& folder) const {
  std::filesystem::path path(folder);
  while (!path.empty() && path.filename().empty()) path = path.parent_path();
  std::string base;
  for (char c : path.filename().string()) {
    base += (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')
                ? c
                : '_';
  }
  if (base.empty() || base == "." || base == "..") base = "map";
  if (base.size() > 60) base.resize(60);
  if (!Has(base)) return base;
  for (int n = 2;; ++n) {
    const std::string key = base + "_" + std::to_string(n);
    if (!Has(key)) return key;
  }
}

}  // namespace vilma::console

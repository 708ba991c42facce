#include "vilma/mapstore/resources.h"

#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "file_util.h"
#include "vilma/core/error.h"
#include "vilma/mapstore/checksum.h"

namespace vilma {
namespace mapstore {

bool ReadWholeFile(const std::string& path, std::string* content) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) return false;
  in.seekg(0, std::ios::beg);
  content->resize(static_cast<std::size_t>(size));
  if (size > 0 && !in.read(&(*content)[0], size)) return false;
  return true;
}

const char* ResourceTypeName(ResourceType type) {
  switch (type) {
    case ResourceType::kImage: return "image";
    case ResourceType::kDepthMap: return "depth_map";
    case ResourceType::kPointCloud: return "point_cloud";
    case ResourceType::kMesh: return "mesh";
  }
  return "unknown";
}

bool ParseResourceType(const std::string& name, ResourceType* type) {
  for (ResourceType t : {ResourceType::kImage, ResourceType::kDepthMap,
                         ResourceType::kPointCloud, ResourceType::kMesh}) {
    if (name == ResourceTypeName(t)) {
      *type = t;
      return true;
    }
  }
  return false;
}

std::string ResourceInfo::RelativePath() const {
  return std::string("resources/") + ResourceTypeName(type) + "/" + id.Hex() + "." + extension;
}

std::string ResourceCacheOptions::Validate() const {
  if (capacity_bytes == 0) return "capacity_bytes: expected > 0";
  return "";
}

ResourceStore::ResourceStore(const ResourceCacheOptions& options) : options_(options) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("ResourceCacheOptions: " + problem);
}

void ResourceStore::Add(ResourceType type, const ResourceId& id, const std::string& extension,
                        std::string bytes) {
  if (!id.IsValid()) throw std::invalid_argument("ResourceStore::Add: invalid resource id");
  if (extension.empty() || extension.find('/') != std::string::npos ||
      extension.find('.') != std::string::npos) {
    throw std::invalid_argument("ResourceStore::Add: extension must be a plain suffix: " +
                                extension);
  }
  ResourceInfo info;
  info.type = type;
  info.id = id;
  info.extension = extension;
  info.size_bytes = bytes.size();
  info.crc32 = Crc32(bytes);
  const Key key(static_cast<uint8_t>(type), id);
  std::lock_guard<std::mutex> lock(mutex_);
  index_[key] = info;
  pending_[key] = std::make_shared<const std::string>(std::move(bytes));
  // A stale cached copy of a replaced resource must not be served.
  auto it = lru_index_.find(key);
  if (it != lru_index_.end()) {
    stats_.cached_bytes -= it->second->second->size();
    --stats_.cached_entries;
    lru_.erase(it->second);
    lru_index_.erase(it);
  }
}

void ResourceStore::Register(const ResourceInfo& info) {
  std::lock_guard<std::mutex> lock(mutex_);
  index_[Key(static_cast<uint8_t>(info.type), info.id)] = info;
}

bool ResourceStore::Has(ResourceType type, const ResourceId& id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return index_.count(Key(static_cast<uint8_t>(type), id)) > 0;
}

bool ResourceStore::Has(const ResourceId& id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& entry : index_) {
    if (entry.first.second == id) return true;
  }
  return false;
}

const ResourceInfo& ResourceStore::Info(ResourceType type, const ResourceId& id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return index_.at(Key(static_cast<uint8_t>(type), id));
}

std::vector<ResourceInfo> ResourceStore::List() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<ResourceInfo> out;
  out.reserve(index_.size());
  for (const auto& entry : index_) out.push_back(entry.second);
  return out;
}

void ResourceStore::ClearPending() {
  std::lock_guard<std::mutex> lock(mutex_);
  pending_.clear();
  source_folders_.clear();  // everything is in folder_ now
}

void ResourceStore::SetCacheOptions(const ResourceCacheOptions& options) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("ResourceCacheOptions: " + problem);
  std::lock_guard<std::mutex> lock(mutex_);
  options_ = options;
  while (stats_.cached_bytes > options_.capacity_bytes && !lru_.empty()) {
    stats_.cached_bytes -= lru_.back().second->size();
    --stats_.cached_entries;
    ++stats_.evictions;
    lru_index_.erase(lru_.back().first);
    lru_.pop_back();
  }
}

std::unique_ptr<ResourceStore> ResourceStore::Clone() const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto copy = std::make_unique<ResourceStore>(options_);
  copy->folder_ = folder_;
  copy->index_ = index_;
  copy->pending_ = pending_;
  copy->source_folders_ = source_folders_;
  return copy;
}

void ResourceStore::MergeFrom(const ResourceStore& other) {
  if (&other == this) return;
  std::scoped_lock lock(mutex_, other.mutex_);
  for (const auto& [key, info] : other.index_) {
    auto mine = index_.find(key);
    if (mine != index_.end() &&
        (mine->second.crc32 != info.crc32 || mine->second.size_bytes != info.size_bytes)) {
      throw std::invalid_argument("ResourceStore::MergeFrom: resource " + info.id.Hex() +
                                  " exists in both maps with different content");
    }
  }
  for (const auto& [key, info] : other.index_) {
    if (index_.count(key) > 0) continue;  // identical resource already here
    index_[key] = info;
    auto pending = other.pending_.find(key);
    if (pending != other.pending_.end()) {
      pending_[key] = pending->second;
      continue;
    }
    auto source = other.source_folders_.find(key);
    source_folders_[key] = source != other.source_folders_.end() ? source->second : other.folder_;
  }
}

ResourceCacheStats ResourceStore::cache_stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

void ResourceStore::InsertIntoCacheLocked(const Key& key,
                                          std::shared_ptr<const std::string> bytes) const {
  if (bytes->size() > options_.capacity_bytes) return;  // would evict everything for nothing
  if (lru_index_.count(key) > 0) return;                // loaded concurrently by another thread
  lru_.emplace_front(key, bytes);
  lru_index_[key] = lru_.begin();
  stats_.cached_bytes += bytes->size();
  ++stats_.cached_entries;
  while (stats_.cached_bytes > options_.capacity_bytes) {
    stats_.cached_bytes -= lru_.back().second->size();
    --stats_.cached_entries;
    ++stats_.evictions;
    lru_index_.erase(lru_.back().first);
    lru_.pop_back();
  }
}

std::shared_ptr<const std::string> ResourceStore::Load(ResourceType type,
                                                       const ResourceId& id) const {
  const Key key(static_cast<uint8_t>(type), id);
  ResourceInfo info;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    info = index_.at(key);
    auto pending = pending_.find(key);
    if (pending != pending_.end()) return pending->second;
    auto it = lru_index_.find(key);
    if (it != lru_index_.end()) {
      ++stats_.hits;
      lru_.splice(lru_.begin(), lru_, it->second);  // most recently used to the front
      return it->second->second;
    }
    ++stats_.misses;
  }
  // Disk read outside the lock so that other threads' cache hits are not blocked.
  std::string folder = folder_;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto source = source_folders_.find(key);
    if (source != source_folders_.end()) folder = source->second;
  }
  const std::string path = (std::filesystem::path(folder) / info.RelativePath()).string();
  auto bytes = std::make_shared<std::string>();
  if (folder.empty() || !ReadWholeFile(path, bytes.get())) {
    throw InputError(FormatInputError(path, "", "an existing resource file (listed in manifest.yaml)"));
  }
  if (bytes->size() != info.size_bytes) {
    throw InputError(FormatInputError(
        path, "size", "expected " + std::to_string(info.size_bytes) + " bytes, found " +
                          std::to_string(bytes->size()) + " (truncated or overwritten file)"));
  }
  const uint32_t crc = Crc32(*bytes);
  if (crc != info.crc32) {
    throw InputError(FormatInputError(path, "crc32",
                                      "checksum mismatch: expected " + Crc32Hex(info.crc32) +
                                          ", computed " + Crc32Hex(crc) + " (corrupted file)"));
  }
  std::shared_ptr<const std::string> result = std::move(bytes);
  std::lock_guard<std::mutex> lock(mutex_);
  InsertIntoCacheLocked(key, result);
  return result;
}

}  // namespace mapstore
}  // namespace vilma

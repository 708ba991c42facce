// Resources: data-heavy objects kept beside the map (images as PNG, depth maps, point clouds,
// meshes), stored as `<map>/resources/<type>/<id hex>.<extension>` and loaded on demand through
// a bounded LRU cache. The store holds opaque encoded bytes (callers encode / decode, e.g.
// cv::imencode / cv::imdecode); the manifest records each resource's size and CRC-32, checked
// when it is read.
#pragma once

#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "vilma/mapstore/id.h"

namespace vilma {
namespace mapstore {

enum class ResourceType : uint8_t { kImage = 0, kDepthMap = 1, kPointCloud = 2, kMesh = 3 };
// Folder name: "image", "depth_map", "point_cloud", "mesh".
const char* ResourceTypeName(ResourceType type);
// Inverse of ResourceTypeName; false if unknown.
bool ParseResourceType(const std::string& name, ResourceType* type);

struct ResourceInfo {
  ResourceType type = ResourceType::kImage;
  ResourceId id;
  std::string extension = "png";  // without the dot
  uint64_t size_bytes = 0;
  uint32_t crc32 = 0;
  // Path relative to the map folder: resources/<type>/<id>.<extension>.
  std::string RelativePath() const;
};

struct ResourceCacheOptions {
  // Bytes of resource data the cache keeps; least recently used entries are evicted beyond
  // it. A resource larger than the whole capacity is returned but not cached.
  uint64_t capacity_bytes = 256ull << 20;
  // Empty if valid, else "field: expectation".
  std::string Validate() const;
};

struct ResourceCacheStats {
  uint64_t hits = 0;
  uint64_t misses = 0;   // loads from disk
  uint64_t evictions = 0;
  uint64_t cached_bytes = 0;
  uint64_t cached_entries = 0;
};

// Index of a map's resources plus the LRU cache. Resources added in memory are "pending" until
// the map is saved; loaded maps read theirs from their folder. Thread-safe (one mutex; loading
// from disk happens outside it).
class ResourceStore {
 public:
  explicit ResourceStore(const ResourceCacheOptions& options = {});

  // Adds a resource held in memory (written by the next SaveMap). Replaces an existing one.
  void Add(ResourceType type, const ResourceId& id, const std::string& extension,
           std::string bytes);
  // Registers a resource that exists in `folder` (used by the loader).
  void Register(const ResourceInfo& info);
  bool Has(ResourceType type, const ResourceId& id) const;
  bool Has(const ResourceId& id) const;  // of any type
  // Throws std::out_of_range if unknown.
  const ResourceInfo& Info(ResourceType type, const ResourceId& id) const;
  // All resources sorted by (type, id): the order the manifest lists them in.
  std::vector<ResourceInfo> List() const;

  // The resource's bytes: pending data, a cache hit, or read from the map folder (then
  // cached). Throws InputError naming the file when it is missing, truncated or its checksum
  // does not match the manifest; std::out_of_range if the resource is unknown.
  std::shared_ptr<const std::string> Load(ResourceType type, const ResourceId& id) const;

  // Folder the saved resources are read from ("" while nothing was saved or loaded).
  const std::string& folder() const { return folder_; }
  void set_folder(const std::string& folder) { folder_ = folder; }
  // Drops pending in-memory data once it is on disk in `folder()`.
  void ClearPending();

  void SetCacheOptions(const ResourceCacheOptions& options);
  // Copies index, folder and pending bytes (shared, immutable) into a new store with an empty
  // cache.
  std::unique_ptr<ResourceStore> Clone() const;
  // Takes over `other`'s index and pending bytes; `other`'s saved resources keep being read
  // from `other`'s folder until the merged map is saved. Throws std::invalid_argument
  // (nothing changed) when a resource id exists in both with other content.
  void MergeFrom(const ResourceStore& other);
  ResourceCacheStats cache_stats() const;

 private:
  using Key = std::pair<uint8_t, Id>;
  struct KeyHash {
    std::size_t operator()(const Key& k) const { return IdHash()(k.second) ^ k.first; }
  };
  void InsertIntoCacheLocked(const Key& key, std::shared_ptr<const std::string> bytes) const;

  ResourceCacheOptions options_;
  std::string folder_;
  std::map<Key, ResourceInfo> index_;
  std::map<Key, std::shared_ptr<const std::string>> pending_;
  // Resources that came from another map folder by MergeFrom: read from there, not folder_.
  std::map<Key, std::string> source_folders_;

  mutable std::mutex mutex_;
  // LRU: most recently used at the front.
  mutable std::list<std::pair<Key, std::shared_ptr<const std::string>>> lru_;
  mutable std::unordered_map<Key, decltype(lru_)::iterator, KeyHash> lru_index_;
  mutable ResourceCacheStats stats_;
};

}  // namespace mapstore
}  // namespace vilma

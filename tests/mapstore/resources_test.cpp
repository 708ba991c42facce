#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "core/test_data.h"
#include "vilma/core/error.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/resources.h"

namespace fs = std::filesystem;
using namespace vilma::mapstore;

namespace {
std::string Bytes(std::size_t n, char c) { return std::string(n, c); }
}  // namespace

TEST_CASE("resource cache evicts least recently used by size", "[mapstore]") {
  const vilma::testing::TempDir scratch;
  const std::string dir = scratch.File("resource_cache");
  fs::remove_all(dir);
  VIMap map;
  IdGenerator ids(3);
  std::vector<ResourceId> r;
  for (int i = 0; i < 5; ++i) {
    r.push_back(ids.Next());
    map.resources().Add(ResourceType::kImage, r.back(), "png", Bytes(1000, static_cast<char>('a' + i)));
  }
  SaveMap(map, dir);
  MapLoadOptions options;
  options.resource_cache.capacity_bytes = 2500;  // room for two 1000-byte resources
  VIMap loaded = LoadMap(dir, options);
  ResourceStore& store = loaded.resources();
  CHECK(*store.Load(ResourceType::kImage, r[0]) == Bytes(1000, 'a'));
  CHECK(*store.Load(ResourceType::kImage, r[1]) == Bytes(1000, 'b'));
  CHECK(store.cache_stats().misses == 2);
  CHECK(store.cache_stats().cached_bytes == 2000);
  // A hit makes r0 the most recent, so loading r2 evicts r1.
  store.Load(ResourceType::kImage, r[0]);
  CHECK(store.cache_stats().hits == 1);
  store.Load(ResourceType::kImage, r[2]);
  CHECK(store.cache_stats().evictions == 1);
  CHECK(store.cache_stats().cached_bytes == 2000);
  store.Load(ResourceType::kImage, r[0]);
  CHECK(store.cache_stats().hits == 2);  // r0 survived
  store.Load(ResourceType::kImage, r[1]);
  CHECK(store.cache_stats().misses == 4);  // r1 was evicted and is read again
  CHECK(store.cache_stats().cached_entries == 2);
  // A resource larger than the whole cache is served but not cached.
  store.SetCacheOptions({500});
  CHECK(store.cache_stats().cached_bytes == 0);
  CHECK(*store.Load(ResourceType::kImage, r[3]) == Bytes(1000, 'd'));
  CHECK(store.cache_stats().cached_bytes == 0);
}

TEST_CASE("resource files are checked against the manifest", "[mapstore]") {
  const vilma::testing::TempDir scratch;
  const std::string dir = scratch.File("resource_check");
  fs::remove_all(dir);
  VIMap map;
  const ResourceId id = IdGenerator(9).Next();
  map.resources().Add(ResourceType::kDepthMap, id, "exr", Bytes(100, 'x'));
  SaveMap(map, dir);
  const std::string path = dir + "/resources/depth_map/" + id.Hex() + ".exr";
  REQUIRE(fs::exists(path));
  {
    VIMap loaded = LoadMap(dir);
    CHECK(loaded.resources().Info(ResourceType::kDepthMap, id).size_bytes == 100);
    CHECK(*loaded.resources().Load(ResourceType::kDepthMap, id) == Bytes(100, 'x'));
  }
  {
    std::ofstream(path, std::ios::binary) << Bytes(99, 'x');
    VIMap loaded = LoadMap(dir);  // resources are checked when read, not at load
    REQUIRE_THROWS_WITH(loaded.resources().Load(ResourceType::kDepthMap, id),
                        Catch::Contains(path) && Catch::Contains("expected 100 bytes, found 99"));
  }
  {
    std::ofstream(path, std::ios::binary) << Bytes(99, 'x') << 'y';
    VIMap loaded = LoadMap(dir);
    REQUIRE_THROWS_WITH(loaded.resources().Load(ResourceType::kDepthMap, id),
                        Catch::Contains(path) && Catch::Contains("checksum mismatch"));
  }
  {
    fs::remove(path);
    VIMap loaded = LoadMap(dir);
    REQUIRE_THROWS_AS(loaded.resources().Load(ResourceType::kDepthMap, id), vilma::InputError);
  }
}

TEST_CASE("resource type names", "[mapstore]") {
  for (ResourceType t : {ResourceType::kImage, ResourceType::kDepthMap, ResourceType::kPointCloud,
                         ResourceType::kMesh}) {
    ResourceType back;
    REQUIRE(ParseResourceType(ResourceTypeName(t), &back));
    CHECK(back == t);
  }
  ResourceType back;
  CHECK_FALSE(ParseResourceType("video", &back));
  CHECK_FALSE(ResourceCacheOptions{0}.Validate().empty());
}

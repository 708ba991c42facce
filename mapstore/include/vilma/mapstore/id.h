// 128-bit ids of VI-map objects (missions, vertices, edges, landmarks, resources), as maplab's
// aslam::Id. Zero is the invalid id. Ids look random (so that maps from different robots can be
// merged without renumbering) but are produced by a seeded generator, so that offline runs are
// deterministic: a mission's generator is seeded from its mission id (IdGenerator::ForMission),
// so adding objects to one mission never changes the ids of another.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace vilma {
namespace mapstore {

struct Id {
  uint64_t hi = 0;
  uint64_t lo = 0;

  bool IsValid() const { return hi != 0 || lo != 0; }
  // 32 lowercase hex digits (hi first).
  std::string Hex() const;
  // Parses 32 hex digits; false (and *id untouched) on anything else.
  static bool FromHex(const std::string& hex, Id* id);

  bool operator==(const Id& o) const { return hi == o.hi && lo == o.lo; }
  bool operator!=(const Id& o) const { return !(*this == o); }
  bool operator<(const Id& o) const { return hi != o.hi ? hi < o.hi : lo < o.lo; }
};

// Typed aliases for readability; they are the same type.
using MissionId = Id;
using VertexId = Id;
using EdgeId = Id;
using LandmarkId = Id;
using ResourceId = Id;

struct IdHash {
  std::size_t operator()(const Id& id) const {
    // The halves are already well mixed (splitmix64 output).
    return static_cast<std::size_t>(id.hi ^ (id.lo * 0x9E3779B97F4A7C15ULL));
  }
};

// A seed for IdGenerator from a file's content (CRC-32 of its first `max_bytes` bytes and its
// size), never 0: offline runs of the same input give the same ids, runs of different inputs
// (two sessions replayed from their logs) give different ones. Throws InputError naming the
// file when it cannot be read.
uint64_t SeedFromFileContent(const std::string& path, uint64_t max_bytes = 4u << 20);

// Deterministic generator of well-mixed ids: splitmix64 (Steele et al., "Fast splittable
// pseudorandom number generators", OOPSLA 2014) over a 64-bit counter state.
class IdGenerator {
 public:
  explicit IdGenerator(uint64_t seed) : state_(seed) {}
  // Generator for the objects of one mission, seeded by its id.
  static IdGenerator ForMission(const MissionId& mission_id);
  // Non-deterministic seed (std::random_device) for live runs that do not need reproducibility.
  static IdGenerator FromRandomDevice();

  // Next id; never invalid.
  Id Next();

 private:
  uint64_t NextWord();
  uint64_t state_;
};

}  // namespace mapstore
}  // namespace vilma

template <>
struct std::hash<vilma::mapstore::Id> {
  std::size_t operator()(const vilma::mapstore::Id& id) const {
    return vilma::mapstore::IdHash()(id);
  }
};

// Consistency check of a VI-map (maplab's check_map_consistency): usable from code and from
// the console. It reports every problem it finds, it does not stop at the first.
#pragma once

#include <string>
#include <vector>

#include "vilma/mapstore/vi_map.h"

namespace vilma {
namespace mapstore {

enum class ConsistencyProblemKind {
  kDuplicateId,          // one id used by two objects (of different kinds)
  kMissionMismatch,      // a vertex's mission_id is not the mission that lists it
  kBadReference,         // an id that points to nothing (edge end, store vertex, root vertex)
  kBackReference,        // landmark observation <-> vertex keypoint landmark id disagree
  kVisualFrame,          // a visual frame's parallel arrays disagree
  kBrokenChain,          // a mission's vertices are not one time-ordered chain of IMU edges
  kImuSamples,           // IMU samples of an edge not sorted or not covering the edge
  kOrphanLandmark,       // landmark without observations
  kOrphanVertex,         // vertex without any edge (in a mission with more than one vertex)
  kMissingResource,      // referenced resource not in the index, or its file is missing
};
const char* ConsistencyProblemKindName(ConsistencyProblemKind kind);

struct ConsistencyProblem {
  ConsistencyProblemKind kind;
  std::string message;  // names the objects by id
};

struct ConsistencyReport {
  std::vector<ConsistencyProblem> problems;
  bool ok() const { return problems.empty(); }
  std::size_t Count(ConsistencyProblemKind kind) const;
  // "map is consistent" or "N problem(s), first: kind: message" (core/report.h's shape).
  std::string BriefReport() const;
  // One line per problem ("kind: message") after a count line, or "map is consistent".
  std::string FullReport() const;
};

ConsistencyReport CheckMapConsistency(const VIMap& map);

}  // namespace mapstore
}  // namespace vilma

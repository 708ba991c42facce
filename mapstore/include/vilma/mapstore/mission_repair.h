#pragma once

// Assembling a streamed mission that may not come from vilma-estimatord (docs/mapstore.md,
// "Forged or inconsistent streams"). vilma-mapstored journals whatever chunk passes its CRC
// and size checks; at finalization it replays the journal's deltas into a map. A delta from
// another sender (or a chunk whose bytes were changed before the CRC was computed) may refer
// to elements that were never sent, break the IMU chain or disagree with itself. Before this,
// such a delta either failed the whole finalization (retried every few seconds, forever) or
// gave a folder that check_map_consistency rejects. Here every element that can be kept is
// kept, every reference that cannot be resolved is dropped, and every change is counted, so
// that the folder always loads and is consistent and nothing that was consistent is lost.

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma {
namespace mapstore {

// What was left out or changed; all zero for a stream from vilma-estimatord.
struct MissionRepairReport {
  std::size_t deltas_unreadable = 0;   // journal records whose bytes are not a delta
  std::size_t headers_refused = 0;     // mission headers of another mission
  std::size_t vertices_refused = 0;    // of another mission, an id used by another element, ...
  std::size_t edges_refused = 0;       // from a vertex never sent, an id used by another element
  std::size_t landmarks_refused = 0;   // stored in a vertex never sent, an id used elsewhere
  std::size_t frames_cleared = 0;      // keypoint arrays of different lengths: keypoints removed
  std::size_t observations_dropped = 0;         // landmark -> keypoint without the way back
  std::size_t keypoint_references_cleared = 0;  // keypoint -> landmark without the way back
  std::size_t resource_references_cleared = 0;  // images / depth maps the map does not hold
  std::size_t landmarks_dropped = 0;   // left without any observation
  std::size_t edges_dropped = 0;       // missing end, back in time, IMU samples, a second edge
  std::size_t root_replaced = 0;       // the root vertex was not the start of a chain
  std::size_t missions_split_off = 0;  // chain pieces saved as missions of their own
  // The first few changes, one line each, for the log.
  std::vector<std::string> examples;

  std::size_t Total() const;
  // "2 edges refused, 1 mission split off" (only the non-zero counts); "no repairs" if none.
  std::string Summary() const;
  void Note(const std::string& example);
};

// Applies one delta of the mission `mission_id` to `map` element by element, in the order of
// ApplyMissionDelta (header, vertices, edges, landmarks). An element the map cannot take (of
// another mission, referring to a vertex the map does not hold, an id already used by another
// kind of element) is skipped and counted; the rest of the delta is applied. The mission must
// already be in `map` (the caller adds it, with its name, before the first delta).
void ApplyStreamedDelta(const MissionDelta& delta, const MissionId& mission_id, VIMap* map,
                        MissionRepairReport* report);

// Makes the mission consistent (CheckMapConsistency passes) with the fewest changes:
//   - a visual frame whose parallel arrays disagree loses its keypoints;
//   - a landmark observation and a keypoint's landmark id are kept only when both directions
//     agree; landmarks left without observations are removed; resource ids the map does not
//     hold are cleared;
//   - edges with a missing end, a unary edge joining two vertices, IMU edges that go back in
//     time or whose samples are unsorted or do not cover the edge, and a second IMU edge out
//     of or into a vertex (the first in stream order is kept) are removed;
//   - the IMU edges then form disjoint chains (at most one in and one out per vertex, time
//     increasing). The root becomes the start of its chain (or of the earliest chain when it
//     is not one of the mission's vertices); every other chain becomes a mission of its own,
//     "<name> (part k)", with the same rig, baseframe and completeness and a new id drawn
//     from a generator seeded by the mission id, so that no vertex is lost.
// Does nothing to a map that is already consistent.
void RepairStreamedMission(const MissionId& mission_id, VIMap* map, MissionRepairReport* report);

}  // namespace mapstore
}  // namespace vilma

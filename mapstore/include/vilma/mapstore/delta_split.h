// Splitting a large mission delta into parts that each fit one stream chunk (docs/mapstore.md
// "Large deltas"). The map builder's last delta re-sends every vertex of the mission with its
// landmark ids and every landmark (tens of MB for a minute of stereo mapping); one LCM message
// of that size never fits a UDP receive buffer, so it would be retransmitted forever.
//
// The parts keep every intermediate state consistent, so that mapstored finalizing after any
// prefix of them (the daemon killed mid-way) saves a map whose references hold both ways:
//   part 0: the mission header, the edges, and the vertices no landmark of the delta touches;
//   part k: a group of landmarks (in the delta's order) and every vertex that observes one of
//           them, each vertex with the landmark ids of the landmarks sent so far only.
// After the last part that touches it, a vertex is exactly the delta's; applying all parts in
// order gives the same map as applying the delta.
#pragma once

#include <cstddef>
#include <vector>

#include "vilma/mapstore/map_io.h"

namespace vilma::mapstore {

// Parts of at most about max_bytes serialized each (a single vertex bigger than that is a part
// of its own); the delta itself when it is small enough.
std::vector<MissionDelta> SplitMissionDelta(const MissionDelta& delta, std::size_t max_bytes);

}  // namespace vilma::mapstore

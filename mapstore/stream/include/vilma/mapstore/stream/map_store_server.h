// Receiver side of the reliable mission stream: the logic of vilma-mapstored, without LCM
// (chunks in through OnChunk, acks out through a callback; docs/mapstore.md).
//
//   in-order chunk  -> appended to the mission's journal; acked after the next Flush()
//   duplicate       -> re-acked (the earlier ack was lost)
//   gap (seq ahead) -> kept in a bounded reorder buffer; the last in-order seq is acked, so a
//                      lost chunk is retransmitted by the sender's timer
//   END             -> after fsync: all deltas applied, SaveMap into <root>/<name or id>/,
//                      mission complete, journal replaced by a done marker, ack COMPLETE
// Flush() fsyncs every journal written since the last Flush() once and then acks: the caller
// batches all chunks that are waiting (one fsync per batch, not per chunk). A failed write or
// fsync (ENOSPC -> DISK_FULL, anything else -> ERROR) is counted, logged and reported on the
// ack, whose ack_seq stays at the last durable chunk; the sender keeps those chunks.
//
// Layout under the root: <root>/.journal/<mission id>.journal (open missions),
// <root>/.journal/<mission id>.done (finished: folder, last seq, complete), <root>/<folder>/.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include <vilma/mission_ack_t.hpp>
#include <vilma/mission_chunk_t.hpp>

#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/stream/mission_journal.h"

namespace vilma {
namespace mapstore {

struct MapStoreServerOptions {
  std::string root;                      // map folders and journals go here
  // A mission without any chunk for this long is finalized as incomplete (complete=false);
  // 0: never (wait for the sender forever; a restart keeps the journal).
  double incomplete_timeout_s = 0.0;     // [s]
  bool finalize_incomplete_at_shutdown = false;
  std::size_t max_reorder_chunks = 1024; // out-of-order chunks kept per mission
  // Size limits on what a sender (an untrusted LCM publisher) makes mapstored hold or write
  // (docs/reliability.md "Size limits"). A chunk's payload above kMaxChunkPayloadBytes is
  // malformed: the daemon's deltas are split at mapping.stream.max_delta_bytes (1 MiB by
  // default), so 64 MiB leaves room for any sane setting, while LCM itself delivers up to
  // 256 MiB. Out-of-order chunks are kept up to max_reorder_bytes of payload per mission
  // (beyond: dropped, the sender retransmits them), so that 1024 large chunks cannot take
  // 1024 x 256 MiB.
  static constexpr std::size_t kMaxChunkPayloadBytes = std::size_t{64} << 20;
  std::size_t max_reorder_bytes = std::size_t{256} << 20;  // [bytes of payload] per mission
  MapSaveOptions save;
  JournalFaultHook fault_hook;           // tests only: simulate write/fsync errors
  std::string Validate() const;          // "" or "field: expectation"
};

struct MapStoreServerCounters {
  uint64_t chunks_received = 0;
  uint64_t chunks_journaled = 0;
  uint64_t chunks_duplicate = 0;
  uint64_t keepalives = 0;        // KEEPALIVE chunks of open missions (re-acknowledged)
  uint64_t chunks_out_of_order = 0;
  uint64_t chunks_malformed = 0;   // bad id, checksum, flags or session
  uint64_t chunks_unknown_mission = 0;  // seq > 0 of a mission without journal (its BEGIN
                                        // was lost, or the journal is gone): ERROR ack -1
  uint64_t bytes_journaled = 0;
  uint64_t acks_sent = 0;
  uint64_t fsyncs = 0;
  uint64_t disk_full_errors = 0;
  uint64_t io_errors = 0;
  uint64_t missions_completed = 0;
  uint64_t missions_incomplete = 0;
  uint64_t missions_recovered = 0;
  uint64_t finalize_errors = 0;
  uint64_t stream_repairs = 0;  // elements refused or references dropped while finalizing a
                                // stream not from vilma-estimatord (mapstore/mission_repair.h)

  // Every counter with its name (the names of mapstored's status_t counters), in this order.
  template <typename Visitor>
  void VisitCounters(Visitor&& v) const {
    v("missions_completed", missions_completed);
    v("missions_incomplete", missions_incomplete);
    v("missions_recovered", missions_recovered);
    v("chunks_received", chunks_received);
    v("chunks_journaled", chunks_journaled);
    v("chunks_duplicate", chunks_duplicate);
    v("keepalives", keepalives);
    v("chunks_out_of_order", chunks_out_of_order);
    v("chunks_malformed", chunks_malformed);
    v("chunks_unknown_mission", chunks_unknown_mission);
    v("bytes_journaled", bytes_journaled);
    v("acks_sent", acks_sent);
    v("fsyncs", fsyncs);
    v("disk_full_errors", disk_full_errors);
    v("io_errors", io_errors);
    v("finalize_errors", finalize_errors);
    v("stream_repairs", stream_repairs);
  }
  // "N chunks received, J journaled, D duplicate, O out of order, F fsyncs, A acks"
  std::string BriefReport() const;
  // One "name value" line per counter.
  std::string FullReport() const;
};

class MapStoreServer {
 public:
  using Clock = std::chrono::steady_clock;
  using AckPublisher = std::function<void(const vilma::mission_ack_t&)>;
  using Logger = std::function<void(const std::string&)>;

  // Throws std::invalid_argument for invalid options.
  MapStoreServer(const MapStoreServerOptions& options, AckPublisher publish_ack, Logger log);
  ~MapStoreServer();

  // Creates the root if needed, loads done markers and recovers the journals of open
  // missions (torn tails cut). Throws InputError when the root is unusable.
  void Start();
  void OnChunk(const vilma::mission_chunk_t& chunk, Clock::time_point now = Clock::now());
  // fsync + ack + finalize ended missions (see the header comment).
  void Flush();
  // Finalizes missions idle for incomplete_timeout_s as incomplete.
  void FinalizeStale(Clock::time_point now = Clock::now());
  // Flush(), then (if finalize_incomplete_at_shutdown) finalizes every open mission.
  void Shutdown();
  // Finalizes one open mission as incomplete now; false if not open or on error.
  bool FinalizeIncomplete(const MissionId& mission_id);

  std::size_t missions_open() const { return missions_.size(); }
  // State held for missions in flight, for tests that a long mission's state stays bounded
  // (issue 18): chunks waiting in reorder buffers, their payload bytes, done-mission records.
  std::size_t reorder_chunks_held() const;
  std::size_t reorder_bytes_held() const;
  std::size_t done_missions_remembered() const { return done_.size(); }
  const MapStoreServerCounters& counters() const { return counters_; }
  // Folder of a finished mission ("" if not finished).
  std::string MissionFolder(const MissionId& mission_id) const;

 private:
  struct OpenMission;
  struct DoneMission {
    std::string folder;
    int64_t last_seq = -1;
    bool complete = false;
    int64_t session_id = 0;
  };
  void Ack(const std::string& mission_hex, int64_t session, int64_t seq, int8_t status,
           const std::string& message);
  void AppendInOrder(OpenMission& m, const vilma::mission_chunk_t& chunk);
  bool Finalize(const MissionId& id, bool complete);
  std::string ChooseFolder(const std::string& name, const MissionId& id) const;
  std::string JournalDir() const;

  MapStoreServerOptions options_;
  AckPublisher publish_ack_;
  Logger log_;
  std::map<MissionId, std::unique_ptr<OpenMission>> missions_;
  std::map<MissionId, DoneMission> done_;
  MapStoreServerCounters counters_;
};

}  // namespace mapstore
}  // namespace vilma

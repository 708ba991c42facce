// Sender side of the reliable mission stream (used by vilma-estimatord; docs/mapstore.md).
//
// Each Send() serializes a MissionDelta into one chunk with the next sequence number, publishes
// it and keeps it in a bounded in-memory window until mapstored acknowledges it (cumulative
// acks: "all of 0..ack_seq are on disk"). When no ack progress is seen for the retransmit
// timeout, the oldest unacknowledged chunks are sent again (go-back-N, at most a burst per
// round) and the timeout doubles up to a maximum (exponential backoff: a dead or restarting
// mapstored costs little bandwidth); any progress resets it. End() queues the END marker;
// the mission is finished when the END chunk is acknowledged. An idle sender (everything
// acknowledged) publishes a KEEPALIVE chunk every keepalive_period_s.
//
// Thread safety: every method may be called from any thread (one mutex); the publisher is
// called with the mutex held and must not call back into the sender.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>

#include <vilma/mission_ack_t.hpp>
#include <vilma/mission_chunk_t.hpp>

#include "vilma/mapstore/map_io.h"

namespace lcm {
class LCM;
class Subscription;
}  // namespace lcm

namespace vilma {
namespace mapstore {

struct MissionStreamSenderOptions {
  std::size_t max_window_chunks = 4096;          // unacknowledged chunks kept
  std::size_t max_window_bytes = 256u << 20;     // their payload bytes [B]
  double retransmit_timeout_s = 0.25;            // first timeout without ack progress [s]
  double max_retransmit_timeout_s = 2.0;         // backoff cap [s]
  std::size_t max_retransmit_burst = 256;        // chunks resent per timeout
  // Chunks transmitted but not acknowledged at most (flow control: the rest of the window
  // waits for acks, so that a burst does not overrun mapstored's UDP receive buffer).
  std::size_t max_in_flight_chunks = 64;
  // With every chunk acknowledged and nothing sent for this long, a KEEPALIVE chunk tells
  // mapstored the sender lives (its incomplete_timeout_s finalizes silent missions: a robot
  // that stops mapping for a while must not lose the rest of its mission) [s]; 0: never.
  double keepalive_period_s = 1.0;
  std::string Validate() const;                  // "" or "field: expectation"
};

struct MissionStreamSenderCounters {
  uint64_t sent = 0;            // chunks queued (each is transmitted once, then resent)
  uint64_t retransmitted = 0;   // further transmissions
  uint64_t acked = 0;           // chunks acknowledged
  uint64_t window_full = 0;     // Send()/End() refused because the window was full
  uint64_t disk_full_acks = 0;  // acks with status DISK_FULL
  uint64_t error_acks = 0;      // acks with status ERROR
  uint64_t ignored_acks = 0;    // acks of another mission or session, or stale
  uint64_t bytes_sent = 0;      // payload bytes, first transmissions [B]
  uint64_t keepalives = 0;      // KEEPALIVE chunks sent while idle
};

class MissionStreamSender {
 public:
  using Clock = std::chrono::steady_clock;
  using ChunkPublisher = std::function<void(const vilma::mission_chunk_t&)>;

  // `session_id` 0: drawn from std::random_device. Throws std::invalid_argument for invalid
  // options or an invalid mission id.
  MissionStreamSender(const MissionId& mission_id, const std::string& mission_name,
                      const MissionStreamSenderOptions& options, ChunkPublisher publisher,
                      int64_t session_id = 0);

  // Queues and publishes one delta. False (nothing queued, counted in window_full) when the
  // window is full or End() was called: the caller keeps the delta and tries again later.
  bool Send(const MissionDelta& delta);
  bool SendSerialized(const std::string& delta_bytes);
  // Queues and publishes the END marker (false when the window is full; call again).
  bool End();
  // Handles an ack from VILMA_MISSION_ACK (other missions and sessions are ignored).
  void OnAck(const vilma::mission_ack_t& ack);
  // Retransmits on timeout; call every few ms to 100 ms.
  void Poll(Clock::time_point now = Clock::now());

  bool ended() const;
  bool finished() const;          // END acknowledged (status COMPLETE): the map folder is written
  // END acknowledged as journaled and fsynced (status OK or COMPLETE): the whole mission is
  // durable in mapstored, which finalizes it (also after its own crash, from the journal).
  // A sender that must stop may stop here; finished() may come much later for a long mission.
  bool end_durable() const;
  int64_t next_seq() const;       // seq of the next chunk
  int64_t acked_seq() const;      // -1: nothing acknowledged yet
  std::size_t window_chunks() const;
  int last_status() const;        // status of the last ack (mission_ack_t constants)
  std::string last_message() const;
  MissionStreamSenderCounters counters() const;
  int64_t session_id() const { return session_id_; }
  const MissionId& mission_id() const { return mission_id_; }

 private:
  bool Enqueue(std::string payload, int8_t flags);
  void Transmit(vilma::mission_chunk_t& chunk);
  void TransmitNew();  // first transmissions allowed by max_in_flight_chunks
  void SendKeepaliveIfIdle(Clock::time_point now);

  const MissionId mission_id_;
  const std::string mission_id_hex_;
  const std::string mission_name_;
  const MissionStreamSenderOptions options_;
  const ChunkPublisher publisher_;
  int64_t session_id_ = 0;

  mutable std::mutex mutex_;
  std::deque<vilma::mission_chunk_t> window_;  // seq acked_seq_+1 .. next_seq_-1
  std::size_t window_bytes_ = 0;
  int64_t next_seq_ = 0;
  int64_t acked_seq_ = -1;
  int64_t transmitted_seq_ = -1;  // highest seq transmitted at least once
  bool ended_ = false;
  bool finished_ = false;
  bool end_durable_ = false;
  int last_status_ = vilma::mission_ack_t::OK;
  std::string last_message_;
  double rto_s_ = 0.0;
  Clock::time_point last_progress_;  // last ack progress or retransmission round
  Clock::time_point last_transmit_;  // last chunk published (any kind)
  MissionStreamSenderCounters counters_;
};

// The sender bound to LCM: publishes on `chunk_channel`, subscribes to `ack_channel`.
// The caller keeps handling `lcm` (its own thread or loop) and calls sender().Poll(), or uses
// EndAndWait(), which handles `lcm` itself (do not call it while another thread handles it).
class LcmMissionStreamSender {
 public:
  LcmMissionStreamSender(lcm::LCM* lcm, const std::string& chunk_channel,
                         const std::string& ack_channel, const MissionId& mission_id,
                         const std::string& mission_name,
                         const MissionStreamSenderOptions& options = {}, int64_t session_id = 0);
  ~LcmMissionStreamSender();
  LcmMissionStreamSender(const LcmMissionStreamSender&) = delete;
  LcmMissionStreamSender& operator=(const LcmMissionStreamSender&) = delete;

  MissionStreamSender& sender() { return sender_; }
  // End() (retried while the window is full), then handles LCM and retransmits until the END
  // is acknowledged or `timeout_s` passes. True when finished.
  bool EndAndWait(double timeout_s);
  // Handles LCM and retransmits until every queued chunk is acknowledged or `timeout_s`.
  bool WaitAcked(double timeout_s);

 private:
  lcm::LCM* lcm_;
  MissionStreamSender sender_;
  lcm::Subscription* subscription_ = nullptr;
};

}  // namespace mapstore
}  // namespace vilma

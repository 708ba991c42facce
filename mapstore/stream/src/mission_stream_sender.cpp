#include "vilma/mapstore/stream/mission_stream_sender.h"

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "vilma/core/time.h"
#include "vilma/drivers/lcm_safe_decode.h"
#include "vilma/mapstore/checksum.h"

namespace vilma {
namespace mapstore {
namespace {

int64_t RandomSession() {
  std::random_device rd;
  int64_t s = 0;
  while (s <= 0) s = static_cast<int64_t>((static_cast<uint64_t>(rd()) << 31) ^ rd());
  return s;
}

}  // namespace

std::string MissionStreamSenderOptions::Validate() const {
  if (max_window_chunks < 1) return "max_window_chunks: expected >= 1";
  if (max_window_bytes < 1) return "max_window_bytes: expected >= 1";
  if (!(retransmit_timeout_s > 0.0)) return "retransmit_timeout_s: expected > 0";
  if (!(max_retransmit_timeout_s >= retransmit_timeout_s)) {
    return "max_retransmit_timeout_s: expected >= retransmit_timeout_s";
  }
  if (max_retransmit_burst < 1) return "max_retransmit_burst: expected >= 1";
  if (max_in_flight_chunks < 1) return "max_in_flight_chunks: expected >= 1";
  if (!(std::isfinite(keepalive_period_s) && keepalive_period_s >= 0.0 && keepalive_period_s <= 3600.0)) {
    return "keepalive_period_s: expected 0 (never) .. 3600";
  }
  return "";
}

MissionStreamSender::MissionStreamSender(const MissionId& mission_id,
                                         const std::string& mission_name,
                                         const MissionStreamSenderOptions& options,
                                         ChunkPublisher publisher, int64_t session_id)
    : mission_id_(mission_id),
      mission_id_hex_(mission_id.Hex()),
      mission_name_(mission_name),
      options_(options),
      publisher_(std::move(publisher)),
      session_id_(session_id != 0 ? session_id : RandomSession()),
      rto_s_(options.retransmit_timeout_s),
      last_progress_(Clock::now()),
      last_transmit_(last_progress_) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("MissionStreamSenderOptions: " + error);
  if (!mission_id.IsValid()) throw std::invalid_argument("MissionStreamSender: invalid mission id");
  if (!publisher_) throw std::invalid_argument("MissionStreamSender: no publisher");
}

bool MissionStreamSender::Send(const MissionDelta& delta) {
  return SendSerialized(SerializeMissionDelta(delta));
}

bool MissionStreamSender::SendSerialized(const std::string& delta_bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (ended_) {
    ++counters_.window_full;
    return false;
  }
  return Enqueue(delta_bytes, vilma::mission_chunk_t::FLAG_DATA);
}

bool MissionStreamSender::End() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (ended_) return true;
  if (!Enqueue(std::string(), vilma::mission_chunk_t::FLAG_END)) return false;
  ended_ = true;
  return true;
}

bool MissionStreamSender::Enqueue(std::string payload, int8_t flags) {
  if (window_.size() >= options_.max_window_chunks ||
      (!window_.empty() && window_bytes_ + payload.size() > options_.max_window_bytes)) {
    ++counters_.window_full;
    return false;
  }
  if (window_.empty()) last_progress_ = Clock::now();  // the timer runs from the oldest chunk
  vilma::mission_chunk_t chunk;
  chunk.mission_id = mission_id_hex_;
  chunk.mission_name = mission_name_;
  chunk.session_id = session_id_;
  chunk.seq = next_seq_++;
  chunk.flags = static_cast<int8_t>(flags | (chunk.seq == 0 ? vilma::mission_chunk_t::FLAG_BEGIN : 0));
  chunk.checksum = static_cast<int32_t>(Crc32(payload));
  chunk.payload.assign(payload.begin(), payload.end());
  chunk.payload_size = static_cast<int32_t>(chunk.payload.size());
  window_bytes_ += chunk.payload.size();
  window_.push_back(std::move(chunk));
  ++counters_.sent;
  counters_.bytes_sent += payload.size();
  TransmitNew();
  return true;
}

void MissionStreamSender::TransmitNew() {
  for (vilma::mission_chunk_t& chunk : window_) {
    if (chunk.seq <= transmitted_seq_) continue;
    if (chunk.seq - acked_seq_ > static_cast<int64_t>(options_.max_in_flight_chunks)) break;
    Transmit(chunk);
    transmitted_seq_ = chunk.seq;
  }
}

void MissionStreamSender::Transmit(vilma::mission_chunk_t& chunk) {
  chunk.utime = WallClockUtime();
  publisher_(chunk);
  last_transmit_ = Clock::now();
}

// Idle: every chunk acknowledged (at least seq 0, so mapstored knows the mission) and nothing
// published for keepalive_period_s. The keepalive names the last acknowledged seq, which
// mapstored holds durably: it can only be re-acknowledged, never journaled.
void MissionStreamSender::SendKeepaliveIfIdle(Clock::time_point now) {
  if (options_.keepalive_period_s <= 0.0 || !window_.empty() || finished_ || acked_seq_ < 0) return;
  if (now - last_transmit_ < std::chrono::duration<double>(options_.keepalive_period_s)) return;
  vilma::mission_chunk_t chunk;
  chunk.mission_id = mission_id_hex_;
  chunk.mission_name = mission_name_;
  chunk.session_id = session_id_;
  chunk.seq = acked_seq_;
  chunk.flags = vilma::mission_chunk_t::FLAG_KEEPALIVE;
  chunk.checksum = static_cast<int32_t>(Crc32(std::string()));
  chunk.payload_size = 0;
  Transmit(chunk);
  last_transmit_ = now;
  ++counters_.keepalives;
}

void MissionStreamSender::OnAck(const vilma::mission_ack_t& ack) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (ack.mission_id != mission_id_hex_ || ack.session_id != session_id_) {
    ++counters_.ignored_acks;
    return;
  }
  last_status_ = ack.status;
  last_message_ = ack.message;
  if (ack.status == vilma::mission_ack_t::DISK_FULL) ++counters_.disk_full_acks;
  if (ack.status == vilma::mission_ack_t::ERROR) ++counters_.error_acks;
  if (ack.ack_seq >= next_seq_) {  // acknowledges what was never sent: not ours
    ++counters_.ignored_acks;
    return;
  }
  if (ack.ack_seq <= acked_seq_) {  // duplicate ack (a gap or a re-ack): the timer decides
    if (ended_ && window_.empty() && ack.status == vilma::mission_ack_t::COMPLETE) {
      finished_ = true;
      end_durable_ = true;
    }
    return;
  }
  while (!window_.empty() && window_.front().seq <= ack.ack_seq) {
    window_bytes_ -= window_.front().payload.size();
    window_.pop_front();
    ++counters_.acked;
  }
  acked_seq_ = ack.ack_seq;
  if (ended_ && window_.empty() && (ack.status == vilma::mission_ack_t::OK ||
                                    ack.status == vilma::mission_ack_t::COMPLETE)) {
    end_durable_ = true;
  }
  rto_s_ = options_.retransmit_timeout_s;
  last_progress_ = Clock::now();
  if (ended_ && window_.empty() && ack.status == vilma::mission_ack_t::COMPLETE) finished_ = true;
  TransmitNew();
}

void MissionStreamSender::Poll(Clock::time_point now) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (window_.empty()) {
    SendKeepaliveIfIdle(now);
    return;
  }
  if (now - last_progress_ < std::chrono::duration<double>(rto_s_)) return;
  const std::size_t n = std::min(options_.max_retransmit_burst, window_.size());
  for (std::size_t i = 0; i < n && window_[i].seq <= transmitted_seq_; ++i) {
    Transmit(window_[i]);
    ++counters_.retransmitted;
  }
  rto_s_ = std::min(2.0 * rto_s_, options_.max_retransmit_timeout_s);
  last_progress_ = now;
}

bool MissionStreamSender::ended() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return ended_;
}
bool MissionStreamSender::finished() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return finished_;
}
bool MissionStreamSender::end_durable() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return end_durable_;
}
int64_t MissionStreamSender::next_seq() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return next_seq_;
}
int64_t MissionStreamSender::acked_seq() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return acked_seq_;
}
std::size_t MissionStreamSender::window_chunks() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return window_.size();
}
int MissionStreamSender::last_status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_status_;
}
std::string MissionStreamSender::last_message() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_message_;
}
MissionStreamSenderCounters MissionStreamSender::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

// --- LCM binding ---

LcmMissionStreamSender::LcmMissionStreamSender(lcm::LCM* lcm, const std::string& chunk_channel,
                                               const std::string& ack_channel,
                                               const MissionId& mission_id,
                                               const std::string& mission_name,
                                               const MissionStreamSenderOptions& options,
                                               int64_t session_id)
    : lcm_(lcm),
      sender_(mission_id, mission_name, options,
              [lcm, chunk_channel](const vilma::mission_chunk_t& chunk) {
                lcm->publish(chunk_channel, &chunk);
              },
              session_id) {
  subscription_ = lcm_->subscribeFunction(
      ack_channel,
      // Raw: lcm-gen's decoder would throw out of the handler on a malformed length field
      // (lcm_safe_decode.h); an undecodable ack is dropped like a lost one.
      +[](const lcm::ReceiveBuffer* rbuf, const std::string&, MissionStreamSender* sender) {
        vilma::mission_ack_t ack;
        if (vilma::DecodeMissionAck(rbuf->data, static_cast<int>(rbuf->data_size), &ack)
                .empty()) {
          sender->OnAck(ack);
        }
      },
      &sender_);
  subscription_->setQueueCapacity(1024);  // LCM's default of 30 would drop acks in bursts
}

LcmMissionStreamSender::~LcmMissionStreamSender() {
  if (subscription_) lcm_->unsubscribe(subscription_);
}

bool LcmMissionStreamSender::WaitAcked(double timeout_s) {
  const auto deadline = MissionStreamSender::Clock::now() + std::chrono::duration<double>(timeout_s);
  while (sender_.window_chunks() > 0) {
    if (MissionStreamSender::Clock::now() > deadline) return false;
    lcm_->handleTimeout(10);
    sender_.Poll();
  }
  return true;
}

bool LcmMissionStreamSender::EndAndWait(double timeout_s) {
  const auto deadline = MissionStreamSender::Clock::now() + std::chrono::duration<double>(timeout_s);
  while (!sender_.finished()) {
    if (MissionStreamSender::Clock::now() > deadline) return false;
    if (!sender_.ended()) sender_.End();
    lcm_->handleTimeout(10);
    sender_.Poll();
  }
  return true;
}

}  // namespace mapstore
}  // namespace vilma

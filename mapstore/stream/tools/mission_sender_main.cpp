// vilma-mission-sender: streams a synthetic mission (synthetic_mission.h) to vilma-mapstored
// over the reliable mission stream; for tests, benchmarks and trying out a mapstored.
#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/drivers/lcm_url.h"
#include "vilma/mapstore/stream/mission_stream_sender.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

namespace {

constexpr const char kUsage[] =
    "usage: vilma-mission-sender [options]\n"
    "\n"
    "Streams a deterministic synthetic mission to vilma-mapstored (VILMA_MISSION), retransmits\n"
    "what is not acknowledged (VILMA_MISSION_ACK), ends it and waits for the final ack.\n"
    "Exit 0 when the mission is stored, 1 on timeout or error, 2 on bad arguments.\n"
    "\n"
    "  --lcm-url URL            LCM provider (default $LCM_DEFAULT_URL or the vilma default)\n"
    "  --channel-suffix S       appended to the channel names\n"
    "  --name NAME              mission name (default synthetic)\n"
    "  --seed N                 seed of the mission and its id (default 1)\n"
    "  --vertices N             vertices (default 50)\n"
    "  --vertices-per-delta N   vertices per chunk (default 1)\n"
    "  --keypoints N            keypoints per vertex (default 100)\n"
    "  --rate HZ                deltas per second, 0: as fast as the window allows (default 0)\n"
    "  --retransmit-timeout S   first retransmit timeout [s] (default 0.25)\n"
    "  --max-retransmit-timeout S  backoff cap [s] (default 2)\n"
    "  --end-timeout S          wait for the final ack at most this long [s] (default 30)\n"
    "  --no-end                 stream the deltas but never send the END marker; wait forever\n"
    "  --help                   this text\n";

}  // namespace

int main(int argc, char** argv) {
  std::string url, suffix;
  vilma::mapstore::SyntheticMissionOptions mission;
  vilma::mapstore::MissionStreamSenderOptions options;
  double rate_hz = 0.0, end_timeout_s = 30.0;
  bool send_end = true;
  try {
    const std::vector<std::string> args(argv + 1, argv + argc);
    for (vilma::ArgCursor arg(args); arg.Next();) {
      const std::string& a = arg.name();
      if (a == "--help" || a == "-h") {
        std::cout << kUsage;
        return 0;
      } else if (a == "--lcm-url") {
        url = arg.Value();
      } else if (a == "--channel-suffix") {
        suffix = arg.Value();
      } else if (a == "--name") {
        mission.name = arg.Value();
      } else if (a == "--seed") {
        mission.seed = static_cast<uint64_t>(arg.Int64Value(0));
      } else if (a == "--vertices") {
        mission.vertices = arg.IntValue();
      } else if (a == "--vertices-per-delta") {
        mission.vertices_per_delta = arg.IntValue();
      } else if (a == "--keypoints") {
        mission.keypoints_per_frame = arg.IntValue();
        if (mission.landmarks_per_vertex > mission.keypoints_per_frame) {
          mission.landmarks_per_vertex = mission.keypoints_per_frame;
        }
      } else if (a == "--rate") {
        rate_hz = arg.DoubleValue();
      } else if (a == "--retransmit-timeout") {
        options.retransmit_timeout_s = arg.DoubleValue();
      } else if (a == "--max-retransmit-timeout") {
        options.max_retransmit_timeout_s = arg.DoubleValue();
      } else if (a == "--end-timeout") {
        end_timeout_s = arg.DoubleValue();
      } else if (a == "--no-end") {
        send_end = !arg.Flag();
      } else {
        throw vilma::UsageError("unknown argument " + arg.word());
      }
    }
    std::string error = mission.Validate();
    if (error.empty()) error = options.Validate();
    if (!error.empty()) throw std::invalid_argument(error);
  } catch (const std::exception& e) {
    std::cerr << "vilma-mission-sender: " << e.what() << "\n" << kUsage;
    return 2;
  }

  const std::vector<vilma::mapstore::MissionDelta> deltas =
      vilma::mapstore::MakeSyntheticMissionDeltas(mission);
  // udpm delivers every datagram of the group to every member, this sender's own chunks
  // included: without a large receive buffer they crowd out the acks (lcm_url.h).
  const std::string lcm_url = vilma::WithDefaultRecvBufSize(vilma::ResolveLcmUrl(url));
  lcm::LCM lcm(lcm_url);
  if (!lcm.good()) {
    std::cerr << "vilma-mission-sender: cannot open LCM provider " << lcm_url << "\n";
    return 1;
  }
  const vilma::mapstore::MissionId id = deltas.empty()
                                            ? vilma::mapstore::IdGenerator(mission.seed).Next()
                                            : deltas[0].mission.id;
  vilma::mapstore::LcmMissionStreamSender stream(
      &lcm, vilma::ChannelName("VILMA_MISSION", suffix), vilma::ChannelName("VILMA_MISSION_ACK", suffix),
      id, mission.name, options);
  auto& sender = stream.sender();
  std::printf("mission %s (%s): %zu deltas, session %lld\n", id.Hex().c_str(), mission.name.c_str(),
              deltas.size(), static_cast<long long>(sender.session_id()));
  std::fflush(stdout);

  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const auto period = rate_hz > 0 ? std::chrono::duration<double>(1.0 / rate_hz)
                                  : std::chrono::duration<double>(0.0);
  auto next_send = t0;
  int64_t last_reported_ack = -1;
  std::size_t i = 0;
  while (i < deltas.size()) {
    if (Clock::now() >= next_send) {
      if (sender.Send(deltas[i])) {
        ++i;
        next_send += std::chrono::duration_cast<Clock::duration>(period);
      }
    }
    // Handle every waiting ack, then block briefly only when there is nothing to send.
    while (lcm.handleTimeout(0) > 0) {
    }
    if (rate_hz > 0 || sender.window_chunks() >= options.max_in_flight_chunks) lcm.handleTimeout(1);
    sender.Poll();
    if (sender.acked_seq() != last_reported_ack) {
      last_reported_ack = sender.acked_seq();
      std::printf("acked %lld\n", static_cast<long long>(last_reported_ack));
      std::fflush(stdout);
    }
  }
  if (!send_end) {
    while (true) {
      lcm.handleTimeout(10);
      sender.Poll();
    }
  }
  const bool ok = stream.EndAndWait(end_timeout_s);
  const double elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto c = sender.counters();
  std::printf("%s after %.3f s: sent %llu, retransmitted %llu, acked %llu, window_full %llu, "
              "disk_full_acks %llu, bytes %llu (%.2f MB/s, %.0f chunks/s); last ack: %s\n",
              ok ? "mission stored" : "NOT STORED", elapsed, (unsigned long long)c.sent,
              (unsigned long long)c.retransmitted, (unsigned long long)c.acked,
              (unsigned long long)c.window_full, (unsigned long long)c.disk_full_acks,
              (unsigned long long)c.bytes_sent, c.bytes_sent / elapsed / 1e6, c.sent / elapsed,
              sender.last_message().c_str());
  return ok ? 0 : 1;
}

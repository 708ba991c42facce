// vilma-mapstored: receives mission streams on VILMA_MISSION, journals them (fsync before ack),
// acknowledges on VILMA_MISSION_ACK and finalizes map folders under --root (docs/mapstore.md).
#include <lcm/lcm-cpp.hpp>
#include <signal.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <filesystem>
#include <string>
#include <vector>

#include <vilma/status_t.hpp>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/core/heap.h"
#include "vilma/core/time.h"
#include "vilma/drivers/lcm_safe_decode.h"
#include "vilma/drivers/lcm_url.h"
#include "vilma/core/yaml_io.h"
#include "vilma/mapstore/stream/map_store_server.h"
#include "vilma/mapstore/stream/mapstored_config.h"
#include "vilma/mapstore/stream/mission_post_processor.h"

#ifdef VILMA_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace {

std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }

constexpr const char kUsage[] =
    "usage: vilma-mapstored --root DIR [--lcm-url URL] [--channel-suffix S] [--config FILE]\n"
    "       vilma-mapstored [--config FILE] --print-config\n"
    "\n"
    "Receives mission streams (VILMA_MISSION), journals every chunk with fsync before it is\n"
    "acknowledged (VILMA_MISSION_ACK) and writes each finished mission as a map folder\n"
    "<DIR>/<mission name>/. Open missions are recovered from <DIR>/.journal on start.\n"
    "Health on VILMA_STATUS at 1 Hz. SIGTERM/SIGINT: journal what arrived, exit 0.\n"
    "\n"
    "  --root DIR           map folders and journals (created if needed)\n"
    "  --lcm-url URL        LCM provider (default $LCM_DEFAULT_URL or udpm://239.255.76.67:7667?ttl=0)\n"
    "  --channel-suffix S   appended to every channel name (VILMA_MISSION_S ...)\n"
    "  --config FILE        YAML with any of (defaults shown):\n"
    "                         incomplete_timeout_s: 0     # finalize a silent mission as\n"
    "                                                     # incomplete after this [s]; 0 never\n"
    "                         finalize_incomplete_at_shutdown: false\n"
    "                         max_reorder_chunks: 1024\n"
    "                         max_reorder_mib: 256        # out-of-order payload kept per\n"
    "                                                     # mission [MiB], >= 64\n"
    "                         max_ack_batch: 256          # chunks per fsync + ack\n"
    "                         post_process_script: \"\"     # console script run on every\n"
    "                                                     # mission folder (docs/mapstore.md)\n"
    "                         post_process_timeout_s: 3600\n"
    "                         vilma_program: \"\"           # default: vilma beside this program\n"
    "  --print-config       print the configuration in effect (--config FILE and the defaults)\n"
    "                       as YAML that --config reads back, and exit\n"
    "  --help               this text\n";

// `vilma` beside this executable (the build tree and an installed prefix both have it there).
std::string DefaultVilmaProgram() {
  std::error_code error;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", error);
  return error ? std::string("vilma") : (self.parent_path() / "vilma").string();
}

void Log(const std::string& text) {
  std::fprintf(stderr, "vilma-mapstored: %s\n", text.c_str());
  std::fflush(stderr);
}

}  // namespace

int main(int argc, char** argv) {
  std::string root, url, suffix, config_path;
  bool print_config = false;
  const std::vector<std::string> args(argv + 1, argv + argc);
  try {
    for (vilma::ArgCursor arg(args); arg.Next();) {
      const std::string& a = arg.name();
      if (a == "--help" || a == "-h") {
        std::cout << kUsage;
        return 0;
      } else if (a == "--root") {
        root = arg.Value();
      } else if (a == "--lcm-url") {
        url = arg.Value();
      } else if (a == "--channel-suffix") {
        suffix = arg.Value();
      } else if (a == "--config") {
        config_path = arg.Value();
      } else if (a == "--print-config") {
        print_config = true;
      } else {
        throw vilma::UsageError("unknown argument " + arg.word());
      }
    }
  } catch (const vilma::UsageError& e) {
    std::cerr << "vilma-mapstored: " << e.what() << "\n" << kUsage;
    return 2;
  }
  if (root.empty() && !print_config) {
    std::cerr << "vilma-mapstored: --root DIR is required\n" << kUsage;
    return 2;
  }
  vilma::mapstore::MapstoredConfig config;
  try {
    if (!config_path.empty()) config = vilma::mapstore::LoadMapstoredConfig(config_path);
  } catch (const vilma::InputError& e) {
    std::cerr << "vilma-mapstored: " << e.what() << "\n";
    return 2;
  }
  if (print_config) {
    std::cout << vilma::mapstore::MapstoredConfigToYaml(config);
    return 0;
  }
  const vilma::mapstore::MapStoreServerOptions server_options = config.ServerOptions(root);
  const vilma::mapstore::PostProcessOptions post_options =
      config.PostProcess(DefaultVilmaProgram());
  // Checked here, before the server recovers journals: a configuration error exits 2 naming
  // the file, as every other config error does (the program is only known at this point).
  if (const std::string error = post_options.Validate(); !error.empty()) {
    std::cerr << "vilma-mapstored: " << (config_path.empty() ? "" : config_path + ": ")
              << "post-processing: " << error << "\n";
    return 2;
  }
  const std::string chunk_channel = vilma::ChannelName("VILMA_MISSION", suffix);
  const std::string ack_channel = vilma::ChannelName("VILMA_MISSION_ACK", suffix);
  const std::string status_channel = vilma::ChannelName("VILMA_STATUS", suffix);
  for (const std::string& c : {chunk_channel, ack_channel, status_channel}) {
    const std::string error = vilma::ValidateChannelName(c);
    if (!error.empty()) {
      std::cerr << "vilma-mapstored: --channel-suffix: " << error << "\n";
      return 2;
    }
  }
  // Buffers of 256 KiB and more are mmapped, and so go back to the kernel when freed: LCM
  // fragments and chunk payloads (up to 1 MiB, ~0.1-0.8 MB in a daemon's mission) are allocated
  // and freed once per chunk; with glibc's dynamic threshold they came from the arenas, and in a
  // soak under load (2026-11-27) a thread arena (most likely liblcm's receive thread's) held
  // ~6 MB resident with 2.4 MB of heap in use in total (vilma/core/heap.h; the measured effect
  // in docs/reliability.md "Soak").
  vilma::FixMallocMmapThreshold();
  // Chunks arrive in bursts of up to max_in_flight_chunks: a large receive buffer (lcm_url.h).
  const std::string lcm_url = vilma::WithDefaultRecvBufSize(vilma::ResolveLcmUrl(url));
  lcm::LCM lcm(lcm_url);
  if (!lcm.good()) {
    std::cerr << "vilma-mapstored: cannot open LCM provider " << lcm_url << "\n";
    return 1;
  }
  struct sigaction sa;
  std::memset(&sa, 0, sizeof(sa));
  sa.sa_handler = OnSignal;
  ::sigaction(SIGTERM, &sa, nullptr);
  ::sigaction(SIGINT, &sa, nullptr);

  std::unique_ptr<vilma::mapstore::MapStoreServer> server;
  std::unique_ptr<vilma::mapstore::MissionPostProcessor> post;
  try {
    server = std::make_unique<vilma::mapstore::MapStoreServer>(
        server_options,
        [&](const vilma::mission_ack_t& ack) { lcm.publish(ack_channel, &ack); }, Log);
    server->Start();
    post = std::make_unique<vilma::mapstore::MissionPostProcessor>(root, post_options, Log);
    post->Scan();  // missions finished (or interrupted while processed) before this start
  } catch (const std::exception& e) {
    std::cerr << "vilma-mapstored: " << e.what() << "\n";
    return 1;
  }
  uint64_t handler_errors = 0;
  uint64_t chunks_undecodable = 0;
  struct Context {
    vilma::mapstore::MapStoreServer* server;
    int handled;
    uint64_t* errors;
    uint64_t* undecodable;
  } context{server.get(), 0, &handler_errors, &chunks_undecodable};
  // Raw subscription: lcm-gen's decoder would throw out of the handler on a malformed length
  // field (lcm_safe_decode.h); undecodable datagrams are counted as chunks_undecodable.
  lcm::Subscription* subscription = lcm.subscribeFunction(
      chunk_channel,
      +[](const lcm::ReceiveBuffer* rbuf, const std::string&, Context* ctx) {
        ++ctx->handled;
        vilma::mission_chunk_t chunk;
        const std::string decode_error =
            vilma::DecodeMissionChunk(rbuf->data, static_cast<int>(rbuf->data_size), &chunk);
        if (!decode_error.empty()) {
          ++*ctx->undecodable;
          if (*ctx->undecodable <= 10 || *ctx->undecodable % 1000 == 0) {
            Log("undecodable chunk (" + std::to_string(*ctx->undecodable) +
                " so far): " + decode_error);
          }
          return;
        }
        try {  // handlers never throw into LCM
          ctx->server->OnChunk(chunk);
        } catch (const std::exception& e) {
          ++*ctx->errors;
          Log(std::string("chunk handler error: ") + e.what());
        }
      },
      &context);
  // LCM drops messages beyond a subscription's queue capacity (default 30): room for a full
  // flight of chunks from several senders.
  subscription->setQueueCapacity(4096);
  Log("root " + root + ", LCM " + lcm_url + ", channels " + chunk_channel + " / " + ack_channel +
      ", incomplete_timeout_s " + std::to_string(config.incomplete_timeout_s) +
      ", max_ack_batch " + std::to_string(config.max_ack_batch) + "; ready");
#ifdef VILMA_HAVE_SYSTEMD
  sd_notify(0, "READY=1");
#endif

  auto publish_status = [&](int32_t state, const std::string& message) {
    const auto& c = server->counters();
    vilma::status_t s;
    s.utime = vilma::WallClockUtime();
    s.node = "vilma-mapstored";
    s.state = state;
    s.message = message;
    auto add = [&s](const char* name, uint64_t value) {
      s.counter_names.push_back(name);
      s.counter_values.push_back(static_cast<int64_t>(value));
    };
    add("missions_open", server->missions_open());
    c.VisitCounters(add);
    add("handler_errors", handler_errors);
    add("chunks_undecodable", chunks_undecodable);
    add("post_process_queued", post->counters().queued);
    add("post_process_running", post->counters().running);
    add("post_process_succeeded", post->counters().succeeded);
    add("post_process_failed", post->counters().failed);
    s.num_counters = static_cast<int32_t>(s.counter_names.size());
    // The heap over every malloc arena (mallinfo2): bytes in use (live allocations, mmapped
    // blocks included), free bytes malloc still holds, mmapped blocks [MB]. A growing RSS with
    // a flat heap_in_use_mb is allocator fragmentation, not state that mapstored keeps (soak
    // diagnostics, docs/reliability.md).
    const vilma::HeapUsage heap = vilma::ReadHeapUsage();
    auto metric = [&s](const char* name, double value) {
      s.metric_names.push_back(name);
      s.metric_values.push_back(value);
    };
    metric("heap_in_use_mb", heap.in_use_mb);
    metric("heap_free_mb", heap.free_mb);
    metric("heap_mmapped_mb", heap.mmapped_mb);
    s.num_metrics = static_cast<int32_t>(s.metric_names.size());
    lcm.publish(status_channel, &s);
  };

  auto next_status = std::chrono::steady_clock::now();
  uint64_t status_ticks = 0;
  uint64_t missions_finished = 0;
  while (!g_stop) {
    // Handle what is waiting (up to a batch), then one fsync per journal and one ack each.
    context.handled = 0;
    if (lcm.handleTimeout(20) > 0) {
      while (context.handled < config.max_ack_batch && !g_stop && lcm.handleTimeout(0) > 0) {
      }
    }
    try {
      server->Flush();
      server->FinalizeStale();
    } catch (const std::exception& e) {
      ++handler_errors;
      Log(std::string("error: ") + e.what());
    }
    // A mission finished: queue it for post-processing (off the receiving path: a child).
    const uint64_t finished =
        server->counters().missions_completed + server->counters().missions_incomplete;
    if (finished != missions_finished) {
      missions_finished = finished;
      post->Scan();
    }
    post->Poll();
    const auto now = std::chrono::steady_clock::now();
    if (now >= next_status) {
      const auto& c = server->counters();
      const bool degraded = c.disk_full_errors + c.io_errors + c.finalize_errors > 0;
      publish_status(degraded ? int32_t{vilma::status_t::DEGRADED} : int32_t{vilma::status_t::OK},
                     degraded ? "storage errors (see counters)" : "ok");
#ifdef VILMA_HAVE_SYSTEMD
      sd_notify(0, "WATCHDOG=1");
#endif
      next_status = now + std::chrono::seconds(1);
      // Every 10 s, give freed heap pages back to the kernel. liblcm's UDP receive thread
      // (started by liblcm, not by us) allocates and frees each packet's buffer in its own
      // malloc arena; glibc returns an arena's free pages only from its top, so that arena's
      // RSS ratchets up with fragmentation although nothing is held (an hour soak: its arena
      // 1.4 -> 2.8 MB while mapstored's own state stayed bounded, docs/reliability.md).
      // malloc_trim(0) releases the free pages of every arena (madvise), called
      // once per 10 s, outside the receive-and-acknowledge loop.
      if (++status_ticks % 10 == 0) vilma::ReleaseFreeHeap();
    }
  }
  Log("stopping");
  post->Stop();  // an interrupted job has no marker: it runs again at the next start
#ifdef VILMA_HAVE_SYSTEMD
  sd_notify(0, "STOPPING=1");
#endif
  try {
    server->Shutdown();
  } catch (const std::exception& e) {
    Log(std::string("error at shutdown: ") + e.what());
  }
  publish_status(vilma::status_t::STOPPING, "stopped");
  Log("stopped: " + std::to_string(server->missions_open()) + " missions left open in journals; " +
      server->counters().BriefReport());
  return 0;
}

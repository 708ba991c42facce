#include "vilma/mapstore/stream/map_store_server.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "vilma/core/atomic_file.h"
#include "vilma/core/error.h"
#include "vilma/core/time.h"
#include "vilma/mapstore/checksum.h"
#include "vilma/mapstore/mission_repair.h"

namespace vilma {
namespace mapstore {
namespace {

bool IsDir(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}
bool Exists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
}

void MakeDir(const std::string& path) {
  if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST) {
    throw InputError(FormatInputError(path, "", std::string("a directory that can be created (") +
                                                    std::strerror(errno) + ")"));
  }
  if (!IsDir(path)) throw InputError(FormatInputError(path, "", "a directory"));
}

std::vector<std::string> ListDir(const std::string& dir) {
  std::vector<std::string> names;
  if (DIR* d = ::opendir(dir.c_str())) {
    while (dirent* e = ::readdir(d)) {
      const std::string name = e->d_name;
      if (name != "." && name != "..") names.push_back(name);
    }
    ::closedir(d);
  }
  std::sort(names.begin(), names.end());
  return names;
}

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Small "key=value" lines (journal header records and done markers).
std::map<std::string, std::string> ParseKeyValues(const std::string& text) {
  std::map<std::string, std::string> kv;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t eq = line.find('=');
    if (eq != std::string::npos) kv[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return kv;
}

bool IsFolderChar(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '-' || c == '.';
}

}  // namespace

struct MapStoreServer::OpenMission {
  MissionId id;
  std::string hex;
  std::string name;
  int64_t session_id = 0;
  std::unique_ptr<MissionJournal> journal;
  int64_t next_seq = 0;         // next in-order seq expected
  int64_t durable_seq = -1;     // last seq fsynced
  uint64_t durable_size = 0;    // journal size at the last successful fsync [B]
  bool dirty = false;           // appended since the last fsync
  bool need_ack = false;
  bool end_received = false;    // END journaled (maybe not yet durable)
  // A finalization of the complete mission failed: retried from this time on (the END is
  // already acknowledged as durable, so the sender no longer resends it to trigger a retry).
  bool finalize_failed = false;
  Clock::time_point finalize_retry_at{};
  int8_t status = vilma::mission_ack_t::OK;
  std::string status_message;
  std::map<int64_t, vilma::mission_chunk_t> reorder;  // seq > next_seq
  std::size_t reorder_bytes = 0;                       // payload bytes held in `reorder`
  Clock::time_point last_activity;
};

std::string MapStoreServerOptions::Validate() const {
  if (root.empty()) return "root: expected a directory path";
  if (!(incomplete_timeout_s >= 0.0)) return "incomplete_timeout_s: expected >= 0";
  if (max_reorder_chunks < 1) return "max_reorder_chunks: expected >= 1";
  if (max_reorder_bytes < kMaxChunkPayloadBytes) {
    return "max_reorder_bytes: expected >= " + std::to_string(kMaxChunkPayloadBytes) +
           " (one chunk of the largest payload)";
  }
  const std::string save_error = save.Validate();
  if (!save_error.empty()) return "save." + save_error;
  return "";
}

MapStoreServer::MapStoreServer(const MapStoreServerOptions& options, AckPublisher publish_ack,
                               Logger log)
    : options_(options), publish_ack_(std::move(publish_ack)), log_(std::move(log)) {
  const std::string error = options_.Validate();
  if (!error.empty()) throw std::invalid_argument("MapStoreServerOptions: " + error);
  if (!log_) log_ = [](const std::string&) {};
}

MapStoreServer::~MapStoreServer() = default;

std::string MapStoreServer::JournalDir() const { return options_.root + "/.journal"; }

std::size_t MapStoreServer::reorder_chunks_held() const {
  std::size_t n = 0;
  for (const auto& kv : missions_) n += kv.second->reorder.size();
  return n;
}

std::size_t MapStoreServer::reorder_bytes_held() const {
  std::size_t n = 0;
  for (const auto& kv : missions_) n += kv.second->reorder_bytes;
  return n;
}

std::string MapStoreServer::MissionFolder(const MissionId& mission_id) const {
  const auto it = done_.find(mission_id);
  return it == done_.end() ? std::string() : options_.root + "/" + it->second.folder;
}

void MapStoreServer::Start() {
  MakeDir(options_.root);
  MakeDir(JournalDir());
  const std::vector<std::string> names = ListDir(JournalDir());
  for (const std::string& name : names) {
    if (!EndsWith(name, ".done")) continue;
    MissionId id;
    if (!Id::FromHex(name.substr(0, name.size() - 5), &id)) continue;
    std::ifstream in(JournalDir() + "/" + name);
    std::stringstream ss;
    ss << in.rdbuf();
    const auto kv = ParseKeyValues(ss.str());
    DoneMission done;
    try {
      done.folder = kv.at("folder");
      done.last_seq = std::stoll(kv.at("last_seq"));
      done.complete = kv.at("complete") == "1";
      done.session_id = std::stoll(kv.at("session"));
    } catch (const std::exception&) {
      log_("ignoring unreadable done marker " + JournalDir() + "/" + name);
      continue;
    }
    done_[id] = done;
  }
  const auto now = Clock::now();
  for (const std::string& name : names) {
    if (!EndsWith(name, ".journal")) continue;
    const std::string path = JournalDir() + "/" + name;
    MissionId id;
    if (!Id::FromHex(name.substr(0, name.size() - 8), &id)) continue;
    if (done_.count(id)) {  // crashed between the done marker and the unlink
      ::unlink(path.c_str());
      continue;
    }
    std::vector<JournalRecord> records;
    JournalRecovery recovery;
    std::unique_ptr<MissionJournal> journal;
    try {
      journal = MissionJournal::Recover(path, &records, &recovery, options_.fault_hook);
    } catch (const InputError& e) {
      log_(std::string("cannot recover journal: ") + e.what() + " (left in place)");
      ++counters_.io_errors;
      continue;
    }
    if (records.empty() || records[0].type != JournalRecordType::kHeader) {
      log_("journal " + path + " has no header record (left in place)");
      ++counters_.io_errors;
      continue;
    }
    auto m = std::make_unique<OpenMission>();
    const auto kv = ParseKeyValues(records[0].payload);
    m->id = id;
    m->hex = id.Hex();
    m->name = kv.count("name") ? kv.at("name") : std::string();
    m->session_id = kv.count("session") ? std::stoll(kv.at("session")) : 0;
    m->next_seq = records.size() > 1 ? records.back().seq + 1 : 0;
    m->durable_seq = m->next_seq - 1;
    m->durable_size = journal->size();
    m->end_received = records.back().type == JournalRecordType::kEnd;
    m->need_ack = m->end_received;  // finalize on the next Flush()
    m->last_activity = now;
    m->journal = std::move(journal);
    std::ostringstream msg;
    msg << "recovered mission " << m->hex << " (" << m->name << "): " << m->next_seq
        << " chunks on disk";
    if (recovery.discarded_bytes > 0) {
      msg << "; cut " << recovery.discarded_bytes << " bytes: " << recovery.reason;
    }
    log_(msg.str());
    ++counters_.missions_recovered;
    missions_[id] = std::move(m);
  }
  Flush();
}

void MapStoreServer::Ack(const std::string& mission_hex, int64_t session, int64_t seq,
                         int8_t status, const std::string& message) {
  vilma::mission_ack_t ack;
  ack.utime = WallClockUtime();
  ack.mission_id = mission_hex;
  ack.session_id = session;
  ack.ack_seq = seq;
  ack.status = status;
  ack.message = message;
  publish_ack_(ack);
  ++counters_.acks_sent;
}

void MapStoreServer::OnChunk(const vilma::mission_chunk_t& chunk, Clock::time_point now) {
  ++counters_.chunks_received;
  MissionId id;
  auto malformed = [&](const std::string& why) {
    ++counters_.chunks_malformed;
    // Rate limited: the first ten, then every 1000th.
    if (counters_.chunks_malformed <= 10 || counters_.chunks_malformed % 1000 == 0) {
      log_("malformed chunk (" + std::to_string(counters_.chunks_malformed) + " so far): " + why);
    }
  };
  if (!Id::FromHex(chunk.mission_id, &id)) return malformed("mission_id is not 32 hex digits");
  if (chunk.payload_size != static_cast<int32_t>(chunk.payload.size()) ||
      static_cast<uint32_t>(chunk.checksum) != Crc32(chunk.payload.data(), chunk.payload.size())) {
    return malformed("checksum mismatch, mission " + chunk.mission_id + " seq " + std::to_string(chunk.seq));
  }
  if (chunk.payload.size() > MapStoreServerOptions::kMaxChunkPayloadBytes) {
    return malformed("payload of " + std::to_string(chunk.payload.size()) + " bytes, expected <= " +
                     std::to_string(MapStoreServerOptions::kMaxChunkPayloadBytes) + ", mission " +
                     chunk.mission_id + " seq " + std::to_string(chunk.seq));
  }
  // A keepalive is KEEPALIVE alone with an empty payload; anything else holds DATA or END.
  const bool keepalive = chunk.flags == vilma::mission_chunk_t::FLAG_KEEPALIVE;
  if (chunk.seq < 0 || (keepalive && !chunk.payload.empty()) ||
      (!keepalive &&
       (chunk.flags & (vilma::mission_chunk_t::FLAG_DATA | vilma::mission_chunk_t::FLAG_END)) == 0)) {
    return malformed("bad seq or flags, mission " + chunk.mission_id);
  }
  const auto done = done_.find(id);
  if (done != done_.end()) {  // finished already: the sender missed the final ack
    const bool ours = done->second.session_id == chunk.session_id;
    Ack(chunk.mission_id, chunk.session_id, ours ? done->second.last_seq : -1,
        done->second.complete && ours ? vilma::mission_ack_t::COMPLETE : vilma::mission_ack_t::ERROR,
        done->second.complete ? "mission stored in " + options_.root + "/" + done->second.folder
                              : "mission was finalized as incomplete in " + options_.root + "/" +
                                    done->second.folder);
    return;
  }
  auto it = missions_.find(id);
  if (it == missions_.end()) {
    if (chunk.seq != 0 || keepalive) {  // a keepalive never opens a mission
      // Normal when seq 0 was lost (the sender resends it); an error when the journal is gone.
      ++counters_.chunks_unknown_mission;
      if (counters_.chunks_unknown_mission <= 10 || counters_.chunks_unknown_mission % 1000 == 0) {
        log_("chunk of unknown mission " + chunk.mission_id + " at seq " + std::to_string(chunk.seq) +
             " (" + std::to_string(counters_.chunks_unknown_mission) + " so far): waiting for seq 0");
      }
      Ack(chunk.mission_id, chunk.session_id, -1, vilma::mission_ack_t::ERROR,
          "unknown mission: its journal is not here (expected seq 0 first)");
      return;
    }
    auto m = std::make_unique<OpenMission>();
    m->id = id;
    m->hex = id.Hex();  // canonical lowercase: file names and acks
    m->name = chunk.mission_name;
    for (char& c : m->name) {
      if (c == '\n' || c == '\r' || c == '\0') c = '_';  // one line in the header record
    }
    m->session_id = chunk.session_id;
    std::ostringstream header;
    header << "mission_id=" << m->hex << "\nname=" << m->name << "\nsession=" << m->session_id << "\n";
    int err = 0;
    m->journal = MissionJournal::Create(JournalDir() + "/" + m->hex + ".journal", header.str(),
                                        options_.fault_hook, &err);
    if (!m->journal) {
      const bool full = err == ENOSPC || err == EDQUOT;
      ++(full ? counters_.disk_full_errors : counters_.io_errors);
      log_("cannot create the journal of mission " + m->hex + ": " + std::strerror(err));
      Ack(chunk.mission_id, chunk.session_id, -1,
          full ? vilma::mission_ack_t::DISK_FULL : vilma::mission_ack_t::ERROR, std::strerror(err));
      return;
    }
    m->durable_size = m->journal->size();
    log_("new mission " + m->hex + " (" + m->name + ")");
    it = missions_.emplace(id, std::move(m)).first;
  }
  OpenMission& m = *it->second;
  if (chunk.session_id != m.session_id) {
    malformed("mission " + m.hex + " belongs to another session");
    Ack(chunk.mission_id, chunk.session_id, -1, vilma::mission_ack_t::ERROR,
        "mission belongs to another sender session");
    return;
  }
  m.last_activity = now;
  m.need_ack = true;
  if (keepalive) {  // the sender lives: re-acknowledge, journal nothing
    ++counters_.keepalives;
    return;
  }
  if (chunk.seq < m.next_seq || m.end_received) {
    ++counters_.chunks_duplicate;
    return;
  }
  if (chunk.seq > m.next_seq) {
    ++counters_.chunks_out_of_order;
    if (m.reorder.size() < options_.max_reorder_chunks &&
        m.reorder_bytes + chunk.payload.size() <= options_.max_reorder_bytes &&
        m.reorder.emplace(chunk.seq, chunk).second) {
      m.reorder_bytes += chunk.payload.size();
    }
    return;
  }
  AppendInOrder(m, chunk);
  // Drain what the reorder buffer now continues.
  while (!m.reorder.empty() && !m.end_received) {
    auto first = m.reorder.begin();
    m.reorder_bytes -= first->second.payload.size();
    if (first->first < m.next_seq) {
      m.reorder.erase(first);
      continue;
    }
    if (first->first != m.next_seq) {
      m.reorder_bytes += first->second.payload.size();
      break;
    }
    const vilma::mission_chunk_t next = std::move(first->second);
    m.reorder.erase(first);
    AppendInOrder(m, next);
    if (m.status != vilma::mission_ack_t::OK) break;
  }
}

void MapStoreServer::AppendInOrder(OpenMission& m, const vilma::mission_chunk_t& chunk) {
  const bool end = (chunk.flags & vilma::mission_chunk_t::FLAG_END) != 0;
  const std::string payload(chunk.payload.begin(), chunk.payload.end());
  const int err = m.journal->Append(chunk.seq, end ? JournalRecordType::kEnd : JournalRecordType::kData,
                                    payload);
  if (err != 0) {
    const bool full = err == ENOSPC || err == EDQUOT;
    ++(full ? counters_.disk_full_errors : counters_.io_errors);
    m.status = full ? vilma::mission_ack_t::DISK_FULL : vilma::mission_ack_t::ERROR;
    m.status_message = std::string("journal write failed: ") + std::strerror(err);
    log_("mission " + m.hex + " seq " + std::to_string(chunk.seq) + ": " + m.status_message);
    return;
  }
  m.status = vilma::mission_ack_t::OK;
  m.status_message.clear();
  ++m.next_seq;
  m.dirty = true;
  m.end_received = end;
  ++counters_.chunks_journaled;
  counters_.bytes_journaled += payload.size();
}

void MapStoreServer::Flush() {
  std::vector<MissionId> to_finalize;
  for (auto& entry : missions_) {
    OpenMission& m = *entry.second;
    if (m.dirty) {
      const int err = m.journal->Sync();
      ++counters_.fsyncs;
      m.dirty = false;
      if (err == 0) {
        m.durable_seq = m.next_seq - 1;
        m.durable_size = m.journal->size();
      } else {
        // The written records are not known to be on disk: cut them and have them resent.
        const bool full = err == ENOSPC || err == EDQUOT;
        ++(full ? counters_.disk_full_errors : counters_.io_errors);
        m.status = full ? vilma::mission_ack_t::DISK_FULL : vilma::mission_ack_t::ERROR;
        m.status_message = std::string("journal fsync failed: ") + std::strerror(err);
        log_("mission " + m.hex + ": " + m.status_message);
        m.journal->TruncateTo(m.durable_size);
        m.next_seq = m.durable_seq + 1;
        m.end_received = false;
        m.reorder.clear();
        m.reorder_bytes = 0;
      }
    }
    const bool end_durable = m.end_received && m.durable_seq == m.next_seq - 1;
    if (end_durable && m.finalize_failed && Clock::now() >= m.finalize_retry_at) {
      to_finalize.push_back(entry.first);
      continue;
    }
    if (!m.need_ack) continue;
    m.need_ack = false;
    if (end_durable) {
      // The END is on disk: the mission is safe (a crash now recovers and finalizes it from
      // the journal), so the sender is told before the finalization, which replays the whole
      // journal and writes the map folder: ~2 min for an hour of mapping (3 GB of journal, a
      // 552 MB folder; soak 2026-11-26), far above the sender's end_timeout_s. COMPLETE
      // follows when the folder is written.
      Ack(m.hex, m.session_id, m.durable_seq, vilma::mission_ack_t::OK,
          "END journaled: writing the map folder");
      to_finalize.push_back(entry.first);
    } else {
      Ack(m.hex, m.session_id, m.durable_seq, m.status, m.status_message);
    }
  }
  for (const MissionId& id : to_finalize) Finalize(id, true);
}

std::string MapStoreServer::ChooseFolder(const std::string& name, const MissionId& id) const {
  const std::string hex = id.Hex();
  bool usable = !name.empty() && name[0] != '.' && name.size() <= 128;
  for (char c : name) usable = usable && IsFolderChar(c);
  std::vector<std::string> candidates;
  if (usable) {
    candidates.push_back(name);
    candidates.push_back(name + "_" + hex.substr(0, 8));
  }
  candidates.push_back(hex);
  for (const std::string& c : candidates) {
    if (!Exists(options_.root + "/" + c)) return c;
  }
  return hex;  // a previous finalization of this very mission (crash before its done marker)
}

namespace {
// A failed finalization (disk full, I/O) is retried this often [s]: each attempt replays the
// whole journal, so not in a tight loop.
constexpr int kFinalizeRetryS = 5;

}  // namespace

bool MapStoreServer::Finalize(const MissionId& id, bool complete) {
  const auto it = missions_.find(id);
  if (it == missions_.end()) return false;
  OpenMission& m = *it->second;
  const std::string journal_path = m.journal->path();
  std::string folder;
  int64_t last_seq = -1;
  try {
    JournalRecovery recovery;
    std::vector<JournalRecord> records = MissionJournal::Read(journal_path, &recovery);
    // Deltas from any sender: every element that can be kept is kept, the rest counted
    // (mapstore/mission_repair.h). A record that is not a delta is skipped: retrying cannot
    // change its bytes, and failing the finalization for it would lose the whole mission.
    VIMap map;
    Mission header;
    header.id = id;
    header.name = m.name;  // the first delta's header replaces it
    map.AddMission(header);
    MissionRepairReport repairs;
    for (JournalRecord& r : records) {
      if (r.type == JournalRecordType::kHeader) continue;
      last_seq = r.seq;
      // Each record's bytes are released once parsed: the journal (the last delta re-sends
      // every vertex, so it is larger than the map) and the map are not held whole together.
      const std::string payload = std::move(r.payload);
      r.payload = std::string();
      if (payload.empty()) continue;
      const std::string source = journal_path + ": seq " + std::to_string(r.seq);
      MissionDelta delta;
      try {
        delta = ParseMissionDelta(payload, source);
      } catch (const InputError& e) {
        ++repairs.deltas_unreadable;
        repairs.Note(e.what());
        continue;
      }
      ApplyStreamedDelta(delta, id, &map, &repairs);
    }
    map.mission(id).complete = complete;
    RepairStreamedMission(id, &map, &repairs);
    if (repairs.Total() > 0) {
      std::string examples;
      for (std::size_t i = 0; i < repairs.examples.size() && i < 3; ++i) examples += "; " + repairs.examples[i];
      log_("mission " + m.hex + ": the stream needed repairs: " + repairs.Summary() + examples);
    }
    // The folder appears whole or not at all: saved into a staging folder beside the journals
    // (same file system), then renamed into place. A kill -9 during SaveMap left a
    // manifest-less folder under the mission's name before (crash campaign, daemon run 55):
    // it did not load, and the recovered mission went to <name>_<id>. A staging folder left by
    // such a crash is this mission's own unfinished output and is removed first.
    const std::string staging = JournalDir() + "/" + m.hex + ".staging";
    std::filesystem::remove_all(staging);
    SaveMap(map, staging, options_.save);
    folder = ChooseFolder(m.name, id);
    if (::rename(staging.c_str(), (options_.root + "/" + folder).c_str()) != 0) {
      throw std::runtime_error("cannot move " + staging + " to " + options_.root + "/" + folder +
                               ": " + std::strerror(errno));
    }
    SyncDirectory(options_.root);
    SyncDirectory(JournalDir());
    counters_.stream_repairs += repairs.Total();  // once per saved folder, not per retry
  } catch (const std::exception& e) {
    ++counters_.finalize_errors;
    const bool full = std::strstr(e.what(), std::strerror(ENOSPC)) != nullptr;
    if (full) ++counters_.disk_full_errors;
    log_("cannot finalize mission " + m.hex + ": " + e.what() + " (journal kept)");
    Ack(m.hex, m.session_id, m.durable_seq - (complete ? 1 : 0),
        full ? vilma::mission_ack_t::DISK_FULL : vilma::mission_ack_t::ERROR,
        std::string("finalization failed: ") + e.what());
    // Retried by Flush() after kFinalizeRetryS (the END was acknowledged as durable before the
    // finalization, so no resent END triggers it); an incomplete one after another timeout.
    m.last_activity = Clock::now();
    m.finalize_failed = complete;
    m.finalize_retry_at = Clock::now() + std::chrono::seconds(kFinalizeRetryS);
    return false;
  }
  std::ostringstream marker;
  marker << "folder=" << folder << "\nlast_seq=" << last_seq << "\ncomplete=" << (complete ? 1 : 0)
         << "\nsession=" << m.session_id << "\n";
  const int err = TryWriteFileAtomically(JournalDir() + "/" + m.hex + ".done", marker.str());
  if (err != 0) {
    ++counters_.finalize_errors;
    ++(err == ENOSPC ? counters_.disk_full_errors : counters_.io_errors);
    log_("cannot write the done marker of mission " + m.hex + ": " + std::strerror(err));
    m.finalize_failed = complete;
    m.finalize_retry_at = Clock::now() + std::chrono::seconds(kFinalizeRetryS);
    Ack(m.hex, m.session_id, m.durable_seq - (complete ? 1 : 0),
        err == ENOSPC ? vilma::mission_ack_t::DISK_FULL : vilma::mission_ack_t::ERROR,
        std::string("done marker: ") + std::strerror(err));
    return false;
  }
  DoneMission done;
  done.folder = folder;
  done.last_seq = last_seq;
  done.complete = complete;
  done.session_id = m.session_id;
  done_[id] = done;
  const std::string hex = m.hex;
  const int64_t session = m.session_id;
  missions_.erase(it);  // closes the journal
  ::unlink(journal_path.c_str());
  SyncDirectory(JournalDir());
  ++(complete ? counters_.missions_completed : counters_.missions_incomplete);
  const std::string where = options_.root + "/" + folder;
  log_(std::string(complete ? "mission complete: " : "mission finalized as incomplete: ") + hex +
       " -> " + where);
  Ack(hex, session, last_seq, complete ? vilma::mission_ack_t::COMPLETE : vilma::mission_ack_t::ERROR,
      complete ? "mission stored in " + where : "mission finalized as incomplete in " + where);
  return true;
}

bool MapStoreServer::FinalizeIncomplete(const MissionId& mission_id) {
  Flush();
  return Finalize(mission_id, false);
}

void MapStoreServer::FinalizeStale(Clock::time_point now) {
  if (options_.incomplete_timeout_s <= 0.0) return;
  std::vector<MissionId> stale;
  for (const auto& entry : missions_) {
    if (now - entry.second->last_activity > std::chrono::duration<double>(options_.incomplete_timeout_s)) {
      stale.push_back(entry.first);
    }
  }
  if (stale.empty()) return;
  Flush();
  for (const MissionId& id : stale) {
    log_("mission " + id.Hex() + ": no chunk for " + std::to_string(options_.incomplete_timeout_s) +
         " s, the sender is gone");
    Finalize(id, false);
  }
}

void MapStoreServer::Shutdown() {
  Flush();
  if (!options_.finalize_incomplete_at_shutdown) return;
  std::vector<MissionId> open;
  for (const auto& entry : missions_) open.push_back(entry.first);
  for (const MissionId& id : open) Finalize(id, false);
}

std::string MapStoreServerCounters::BriefReport() const {
  return std::to_string(chunks_received) + " chunks received, " +
         std::to_string(chunks_journaled) + " journaled, " + std::to_string(chunks_duplicate) +
         " duplicate, " + std::to_string(chunks_out_of_order) + " out of order, " +
         std::to_string(fsyncs) + " fsyncs, " + std::to_string(acks_sent) + " acks";
}

std::string MapStoreServerCounters::FullReport() const {
  std::string text;
  VisitCounters([&text](const char* name, uint64_t value) {
    text += std::string(name) + " " + std::to_string(value) + "\n";
  });
  return text;
}

}  // namespace mapstore
}  // namespace vilma

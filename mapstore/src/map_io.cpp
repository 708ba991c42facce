#include "vilma/mapstore/map_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "file_util.h"
#include "proto_conversion.h"
#include "vi_map.pb.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/atomic_file.h"
#include "vilma/core/error.h"
#include "vilma/core/yaml_io.h"
#include "vilma/mapstore/checksum.h"

namespace fs = std::filesystem;

namespace vilma {
namespace mapstore {
namespace {

using proto::FromProto;
using proto::Reader;
using proto::ToProto;

constexpr char kManifestName[] = "manifest.yaml";
constexpr char kFormatName[] = "vilma-vi-map";

// ---------------------------------------------------------------- manifest

struct FileEntry {
  std::string path;  // relative to the map folder
  uint64_t size = 0;
  uint32_t crc32 = 0;
};

struct MissionManifest {
  MissionId id;
  FileEntry mission_file;
  std::vector<FileEntry> vertex_chunks, edge_chunks, landmark_chunks;
};

struct Manifest {
  uint32_t format_version = kMapFormatVersion;
  uint64_t generation = 0;
  std::vector<MissionManifest> missions;
  std::vector<ResourceInfo> resources;
};

std::string FileEntryYaml(const FileEntry& f) {
  return "{path: " + f.path + ", size: " + std::to_string(f.size) + ", crc32: \"" +
         Crc32Hex(f.crc32) + "\"}";
}

std::string ManifestToYaml(const Manifest& m) {
  std::ostringstream out;
  out << "# vilma VI-map manifest (docs/vi-map.md). Written last by every save.\n";
  out << "format: " << kFormatName << "\n";
  out << "format_version: " << m.format_version << "\n";
  out << "generation: " << m.generation << "\n";
  out << "missions:" << (m.missions.empty() ? " []" : "") << "\n";
  auto list = [&](const char* key, const std::vector<FileEntry>& files) {
    out << "    " << key << ":" << (files.empty() ? " []" : "") << "\n";
    for (const FileEntry& f : files) out << "      - " << FileEntryYaml(f) << "\n";
  };
  for (const MissionManifest& mm : m.missions) {
    out << "  - id: \"" << mm.id.Hex() << "\"\n";
    out << "    mission_file: " << FileEntryYaml(mm.mission_file) << "\n";
    list("vertex_chunks", mm.vertex_chunks);
    list("edge_chunks", mm.edge_chunks);
    list("landmark_chunks", mm.landmark_chunks);
  }
  out << "resources:" << (m.resources.empty() ? " []" : "") << "\n";
  for (const ResourceInfo& r : m.resources) {
    out << "  - {type: " << ResourceTypeName(r.type) << ", id: \"" << r.id.Hex()
        << "\", extension: " << r.extension << ", size: " << r.size_bytes << ", crc32: \""
        << Crc32Hex(r.crc32) << "\"}\n";
  }
  return out.str();
}

uint32_t ParseCrcHex(const YamlNode& node, const std::string& key) {
  const std::string s = node.Get<std::string>(key);
  if (s.size() != 10 || s.compare(0, 2, "0x") != 0 ||
      s.find_first_not_of("0123456789abcdef", 2) != std::string::npos) {
    node.Fail(key, "expected \"0x\" and 8 lowercase hex digits, found \"" + s + "\"");
  }
  return static_cast<uint32_t>(std::stoul(s.substr(2), nullptr, 16));
}

uint64_t ParseSize(const YamlNode& node, const std::string& key) {
  const int64_t size = node.Get<int64_t>(key);
  if (size < 0) node.Fail(key, "expected a size >= 0");
  return static_cast<uint64_t>(size);
}

Id ParseIdHex(const YamlNode& node, const std::string& key) {
  Id id;
  const std::string s = node.Get<std::string>(key);
  if (!Id::FromHex(s, &id) || !id.IsValid()) {
    node.Fail(key, "expected a non-zero id of 32 hex digits, found \"" + s + "\"");
  }
  return id;
}

FileEntry ParseFileEntry(const YamlNode& node) {
  FileEntry f;
  f.path = node.Get<std::string>("path");
  // Relative paths inside the map folder only.
  if (f.path.empty() || f.path[0] == '/' || f.path.find("..") != std::string::npos) {
    node.Fail("path", "expected a relative path inside the map folder, found \"" + f.path + "\"");
  }
  f.size = ParseSize(node, "size");
  f.crc32 = ParseCrcHex(node, "crc32");
  node.CheckNoUnknownKeys();
  return f;
}

Manifest ParseManifest(const std::string& path) {
  const YamlNode root = YamlNode::LoadFile(path);
  if (!root.IsMap()) root.Fail("", "expected a YAML map (a vilma map manifest)");
  const std::string format = root.Get<std::string>("format");
  if (format != kFormatName) {
    root.Fail("format", std::string("expected \"") + kFormatName + "\", found \"" + format + "\"");
  }
  Manifest m;
  const int64_t version = root.Get<int64_t>("format_version");
  // The version is checked before anything else so that a newer map gives this message and
  // not a confusing one about a field this reader does not know.
  if (version > static_cast<int64_t>(kMapFormatVersion)) {
    root.Fail("format_version",
              "expected a version from 1 to " + std::to_string(kMapFormatVersion) +
                  " (the newest this vilma reads), found " + std::to_string(version) +
                  ": the map was written by a newer vilma; update vilma to load it");
  }
  if (version < 1) {
    root.Fail("format_version", "expected a version from 1 to " +
                                    std::to_string(kMapFormatVersion) + ", found " +
                                    std::to_string(version));
  }
  m.format_version = static_cast<uint32_t>(version);
  const int64_t generation = root.Get<int64_t>("generation");
  if (generation < 1) root.Fail("generation", "expected a generation >= 1");
  m.generation = static_cast<uint64_t>(generation);
  for (const YamlNode& mn : root.Child("missions").Elements()) {
    MissionManifest mm;
    mm.id = ParseIdHex(mn, "id");
    mm.mission_file = ParseFileEntry(mn.Child("mission_file"));
    for (const YamlNode& f : mn.Child("vertex_chunks").Elements()) {
      mm.vertex_chunks.push_back(ParseFileEntry(f));
    }
    for (const YamlNode& f : mn.Child("edge_chunks").Elements()) {
      mm.edge_chunks.push_back(ParseFileEntry(f));
    }
    for (const YamlNode& f : mn.Child("landmark_chunks").Elements()) {
      mm.landmark_chunks.push_back(ParseFileEntry(f));
    }
    mn.CheckNoUnknownKeys();
    m.missions.push_back(std::move(mm));
  }
  for (const YamlNode& rn : root.Child("resources").Elements()) {
    ResourceInfo r;
    const std::string type = rn.Get<std::string>("type");
    if (!ParseResourceType(type, &r.type)) {
      rn.Fail("type", "expected image, depth_map, point_cloud or mesh, found \"" + type + "\"");
    }
    r.id = ParseIdHex(rn, "id");
    r.extension = rn.Get<std::string>("extension");
    if (r.extension.empty() || r.extension.find_first_of("/.") != std::string::npos) {
      rn.Fail("extension", "expected a plain file suffix such as png");
    }
    r.size_bytes = ParseSize(rn, "size");
    r.crc32 = ParseCrcHex(rn, "crc32");
    rn.CheckNoUnknownKeys();
    m.resources.push_back(r);
  }
  root.CheckNoUnknownKeys();
  return m;
}

// ---------------------------------------------------------------- saving

std::string GenerationDirName(uint64_t generation) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "g%06llu", static_cast<unsigned long long>(generation));
  return buf;
}

std::string ChunkName(const char* kind, std::size_t index) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%s_%06zu.pb", kind, index);
  return buf;
}

class Writer {
 public:
  Writer(std::string folder, MapSaveSummary* summary)
      : folder_(std::move(folder)), summary_(summary) {}

  FileEntry Write(const std::string& relative_path, const google::protobuf::Message& message) {
    std::string bytes;
    if (!message.SerializeToString(&bytes)) {
      throw std::invalid_argument("SaveMap: cannot serialize " + relative_path);
    }
    return WriteBytes(relative_path, bytes);
  }

  FileEntry WriteBytes(const std::string& relative_path, const std::string& bytes) {
    FileEntry f;
    f.path = relative_path;
    f.size = bytes.size();
    f.crc32 = Crc32(bytes);
    WriteFileAtomically((fs::path(folder_) / relative_path).string(), bytes);
    ++summary_->files_written;
    summary_->bytes_written += bytes.size();
    return f;
  }

 private:
  std::string folder_;
  MapSaveSummary* summary_;
};

template <typename Chunk, typename Element, typename Fill>
std::vector<FileEntry> WriteChunks(Writer* writer, const std::string& dir, const char* kind,
                                   const MissionId& mission_id,
                                   const std::vector<Element>& ids, uint32_t per_chunk,
                                   Fill fill) {
  std::vector<FileEntry> files;
  for (std::size_t begin = 0, index = 0; begin < ids.size(); begin += per_chunk, ++index) {
    Chunk chunk;
    chunk.set_format_version(kMapFormatVersion);
    ToProto(mission_id, chunk.mutable_mission_id());
    chunk.set_chunk_index(static_cast<uint32_t>(index));
    const std::size_t end = std::min<std::size_t>(ids.size(), begin + per_chunk);
    for (std::size_t i = begin; i < end; ++i) fill(ids[i], &chunk);
    files.push_back(writer->Write(dir + "/" + ChunkName(kind, index), chunk));
  }
  return files;
}

// ---------------------------------------------------------------- loading

// Reads a data file listed in the manifest and checks its size and checksum.
std::string ReadListedFile(const std::string& folder, const FileEntry& entry,
                           const std::string& manifest_path, bool verify_checksum) {
  const std::string path = (fs::path(folder) / entry.path).string();
  std::string bytes;
  if (!ReadWholeFile(path, &bytes)) {
    throw InputError(FormatInputError(
        path, "", "expected the data file listed in " + manifest_path + " (missing chunk)"));
  }
  if (bytes.size() != entry.size) {
    throw InputError(FormatInputError(
        path, "size",
        "expected " + std::to_string(entry.size) + " bytes as listed in " + manifest_path +
            ", found " + std::to_string(bytes.size()) +
            (bytes.size() < entry.size ? " (truncated file)" : " (file grew)")));
  }
  if (verify_checksum) {
    const uint32_t crc = Crc32(bytes);
    if (crc != entry.crc32) {
      throw InputError(FormatInputError(
          path, "crc32",
          "expected " + Crc32Hex(entry.crc32) + " as listed in " + manifest_path +
              ", computed " + Crc32Hex(crc) + " (checksum mismatch: corrupted file)"));
    }
  }
  return bytes;
}

template <typename Message>
Message ParseListed(const std::string& bytes, const Reader& in, const char* type_name,
                    const MissionId& mission_id) {
  Message message;
  if (!message.ParseFromString(bytes)) {
    in.Fail("", std::string("expected a valid ") + type_name + " protobuf message");
  }
  if (message.format_version() != kMapFormatVersion) {
    in.Fail("format_version", "expected " + std::to_string(kMapFormatVersion) +
                                  " (the manifest's), found " +
                                  std::to_string(message.format_version()));
  }
  (void)mission_id;
  return message;
}

template <typename Fn>
void AddOrFail(const Reader& in, const std::string& field, Fn fn) {
  try {
    fn();
  } catch (const std::invalid_argument& e) {
    // VIMap rejects duplicate ids and dangling store vertices with invalid_argument.
    in.Fail(field, std::string("expected a consistent element: ") + e.what());
  }
}

}  // namespace

std::string MapSaveOptions::Validate() const {
  if (vertices_per_chunk == 0) return "vertices_per_chunk: expected > 0";
  if (edges_per_chunk == 0) return "edges_per_chunk: expected > 0";
  if (landmarks_per_chunk == 0) return "landmarks_per_chunk: expected > 0";
  return "";
}

std::string MapLoadOptions::Validate() const {
  const std::string problem = resource_cache.Validate();
  return problem.empty() ? "" : "resource_cache." + problem;
}

MapSaveSummary SaveMap(const VIMap& map, const std::string& folder,
                       const MapSaveOptions& options) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("MapSaveOptions: " + problem);
  const fs::path root(folder);
  // Durably (each new folder's parent synced): the map, mission and generation folders must
  // survive a power loss together with the files fsynced in them.
  CreateDirectoriesDurably(root.string());
  const std::string manifest_path = (root / kManifestName).string();

  // The new generation follows the one the current manifest lists; a generation folder left
  // by a crashed save (not listed) is cleared and reused.
  Manifest manifest;
  manifest.generation = 1;
  if (fs::exists(manifest_path)) {
    try {
      manifest.generation = ParseManifest(manifest_path).generation + 1;
    } catch (const InputError&) {
      // Unreadable previous manifest: nothing of it can be kept safe anyway; pick a
      // generation above every folder present.
      std::error_code ec;
      for (const auto& mission_dir : fs::directory_iterator(root / "missions", ec)) {
        for (const auto& gen : fs::directory_iterator(mission_dir.path(), ec)) {
          const std::string name = gen.path().filename().string();
          if (name.size() == 7 && name[0] == 'g' &&
              name.find_first_not_of("0123456789", 1) == std::string::npos) {
            manifest.generation =
                std::max<uint64_t>(manifest.generation, std::stoull(name.substr(1)) + 1);
          }
        }
      }
    }
  }

  MapSaveSummary summary;
  summary.generation = manifest.generation;
  Writer writer(folder, &summary);
  const std::string generation_dir = GenerationDirName(manifest.generation);

  for (const MissionId& mission_id : map.mission_ids()) {
    MissionManifest mm;
    mm.id = mission_id;
    const std::string dir = "missions/" + mission_id.Hex() + "/" + generation_dir;
    std::error_code ec;
    fs::remove_all(root / dir, ec);
    CreateDirectoriesDurably((root / dir).string());

    pb::MissionFile mission_file;
    mission_file.set_format_version(kMapFormatVersion);
    ToProto(map.mission(mission_id), mission_file.mutable_mission());
    mm.mission_file = writer.Write(dir + "/mission.pb", mission_file);

    mm.vertex_chunks = WriteChunks<pb::VertexChunk>(
        &writer, dir, "vertices", mission_id, map.vertex_ids(mission_id),
        options.vertices_per_chunk, [&](const VertexId& id, pb::VertexChunk* chunk) {
          ToProto(map.vertex(id), chunk->add_vertices());
        });
    mm.edge_chunks = WriteChunks<pb::EdgeChunk>(
        &writer, dir, "edges", mission_id, map.edge_ids(mission_id), options.edges_per_chunk,
        [&](const EdgeId& id, pb::EdgeChunk* chunk) { ToProto(map.edge(id), chunk->add_edges()); });
    mm.landmark_chunks = WriteChunks<pb::LandmarkChunk>(
        &writer, dir, "landmarks", mission_id, map.landmark_ids(mission_id),
        options.landmarks_per_chunk, [&](const LandmarkId& id, pb::LandmarkChunk* chunk) {
          ToProto(map.landmark(id), chunk->add_landmarks());
        });
    manifest.missions.push_back(std::move(mm));
  }

  // Resources are immutable per id and written in place (atomically): a resource that is
  // already in this folder and not pending is not rewritten.
  const ResourceStore& resources = map.resources();
  const bool same_folder =
      !resources.folder().empty() && fs::exists(resources.folder()) &&
      fs::equivalent(fs::path(resources.folder()), root);
  for (const ResourceInfo& info : resources.List()) {
    const fs::path target = root / info.RelativePath();
    std::shared_ptr<const std::string> bytes;
    if (same_folder && fs::exists(target)) {
      // Pending (replaced) resources must still be written; others are already here.
      bytes = resources.Load(info.type, info.id);
      if (fs::file_size(target) == bytes->size()) {
        std::string on_disk;
        if (ReadWholeFile(target.string(), &on_disk) && on_disk == *bytes) {
          manifest.resources.push_back(info);
          continue;
        }
      }
    } else {
      bytes = resources.Load(info.type, info.id);
    }
    CreateDirectoriesDurably(target.parent_path().string());
    writer.WriteBytes(info.RelativePath(), *bytes);
    manifest.resources.push_back(info);
  }

  if (options.stop_before_manifest) return summary;
  // The commit point: the manifest's atomic rename switches readers to the new generation.
  WriteFileAtomically(manifest_path, ManifestToYaml(manifest));
  ++summary.files_written;

  // Cleanup of what the new manifest no longer lists: older generations and removed missions.
  std::error_code ec;
  for (const auto& mission_dir : fs::directory_iterator(root / "missions", ec)) {
    Id id;
    const bool listed =
        Id::FromHex(mission_dir.path().filename().string(), &id) && map.HasMission(id);
    if (!listed) {
      fs::remove_all(mission_dir.path(), ec);
      continue;
    }
    for (const auto& gen : fs::directory_iterator(mission_dir.path(), ec)) {
      if (gen.path().filename().string() != generation_dir) fs::remove_all(gen.path(), ec);
    }
  }
  // A save killed between the temporary manifest's creation and its rename left it behind:
  // nothing else removes it (12 of 200 kills of scripts/crash-campaign.sh, 2026-11-27).
  RemoveLeftoverTemporaryFiles(manifest_path);
  return summary;
}

VIMap LoadMap(const std::string& folder, const MapLoadOptions& options) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("MapLoadOptions: " + problem);
  const fs::path root(folder);
  const std::string manifest_path = (root / kManifestName).string();
  if (!fs::is_directory(root)) {
    throw InputError(FormatInputError(folder, "", "expected a map folder"));
  }
  if (!fs::exists(manifest_path)) {
    throw InputError(FormatInputError(manifest_path, "",
                                      "expected a map manifest (is this a vilma map folder?)"));
  }
  const Manifest manifest = ParseManifest(manifest_path);

  VIMap map;
  map.resources().SetCacheOptions(options.resource_cache);
  // Pass 1: missions and vertices of every mission (edges and landmarks may refer to vertices
  // of other missions). Pass 2: edges. Pass 3: landmarks.
  for (const MissionManifest& mm : manifest.missions) {
    const std::string path = (root / mm.mission_file.path).string();
    const Reader in(path);
    const auto file = ParseListed<pb::MissionFile>(
        ReadListedFile(folder, mm.mission_file, manifest_path, options.verify_checksums), in,
        "MissionFile", mm.id);
    Mission mission = FromProto(file.mission(), in, "mission");
    if (mission.id != mm.id) {
      in.Fail("mission.id", "expected " + mm.id.Hex() + " (the manifest's), found " +
                                mission.id.Hex());
    }
    AddOrFail(in, "mission.id", [&] { map.AddMission(mission); });
  }
  auto for_each_chunk = [&](auto chunk_tag, const char* type_name,
                            const std::vector<FileEntry> MissionManifest::*files, auto handle) {
    using Chunk = decltype(chunk_tag);
    for (const MissionManifest& mm : manifest.missions) {
      const std::vector<FileEntry>& list = mm.*files;
      for (std::size_t index = 0; index < list.size(); ++index) {
        const Reader in((root / list[index].path).string());
        const Chunk chunk = ParseListed<Chunk>(
            ReadListedFile(folder, list[index], manifest_path, options.verify_checksums), in,
            type_name, mm.id);
        if (in.ReadId(chunk.mission_id()) != mm.id || chunk.chunk_index() != index) {
          in.Fail("chunk_index", "expected chunk " + std::to_string(index) + " of mission " +
                                     mm.id.Hex() + ", found chunk " +
                                     std::to_string(chunk.chunk_index()) + " of mission " +
                                     in.ReadId(chunk.mission_id()).Hex());
        }
        handle(chunk, in, mm.id);
      }
    }
  };
  for_each_chunk(pb::VertexChunk(), "VertexChunk", &MissionManifest::vertex_chunks,
                 [&](const pb::VertexChunk& chunk, const Reader& in, const MissionId& mission_id) {
                   for (int i = 0; i < chunk.vertices_size(); ++i) {
                     const std::string field = "vertices[" + std::to_string(i) + "]";
                     Vertex v = FromProto(chunk.vertices(i), in, field);
                     if (v.mission_id != mission_id) {
                       in.Fail(field + ".mission_id", "expected " + mission_id.Hex() +
                                                          ", found " + v.mission_id.Hex());
                     }
                     AddOrFail(in, field + ".id", [&] { map.AddVertex(std::move(v)); });
                   }
                 });
  for_each_chunk(pb::EdgeChunk(), "EdgeChunk", &MissionManifest::edge_chunks,
                 [&](const pb::EdgeChunk& chunk, const Reader& in, const MissionId&) {
                   for (int i = 0; i < chunk.edges_size(); ++i) {
                     const std::string field = "edges[" + std::to_string(i) + "]";
                     Edge e = FromProto(chunk.edges(i), in, field);
                     AddOrFail(in, field, [&] { map.AddEdge(std::move(e)); });
                   }
                 });
  for_each_chunk(pb::LandmarkChunk(), "LandmarkChunk", &MissionManifest::landmark_chunks,
                 [&](const pb::LandmarkChunk& chunk, const Reader& in, const MissionId&) {
                   for (int i = 0; i < chunk.landmarks_size(); ++i) {
                     const std::string field = "landmarks[" + std::to_string(i) + "]";
                     Landmark l = FromProto(chunk.landmarks(i), in, field);
                     AddOrFail(in, field, [&] { map.AddLandmark(std::move(l)); });
                   }
                 });

  for (const ResourceInfo& info : manifest.resources) map.resources().Register(info);
  map.resources().set_folder(folder);
  return map;
}

// ---------------------------------------------------------------- mission stream

std::string SerializeMissionDelta(const MissionDelta& delta) {
  pb::MissionDelta message;
  message.set_format_version(kMapFormatVersion);
  ToProto(delta.mission, message.mutable_mission());
  for (const Vertex& v : delta.vertices) ToProto(v, message.add_vertices());
  for (const Edge& e : delta.edges) ToProto(e, message.add_edges());
  for (const Landmark& l : delta.landmarks) ToProto(l, message.add_landmarks());
  std::string bytes;
  if (!message.SerializeToString(&bytes)) {
    throw std::invalid_argument("SerializeMissionDelta: cannot serialize");
  }
  return bytes;
}

MissionDelta ParseMissionDelta(const std::string& bytes, const std::string& source_name) {
  const Reader in(source_name);
  pb::MissionDelta message;
  if (!message.ParseFromString(bytes)) in.Fail("", "expected a valid MissionDelta protobuf message");
  if (message.format_version() < 1 || message.format_version() > kMapFormatVersion) {
    in.Fail("format_version", "expected a version from 1 to " +
                                  std::to_string(kMapFormatVersion) + ", found " +
                                  std::to_string(message.format_version()));
  }
  MissionDelta delta;
  delta.mission = FromProto(message.mission(), in, "mission");
  for (int i = 0; i < message.vertices_size(); ++i) {
    delta.vertices.push_back(FromProto(message.vertices(i), in, "vertices[" + std::to_string(i) + "]"));
  }
  for (int i = 0; i < message.edges_size(); ++i) {
    delta.edges.push_back(FromProto(message.edges(i), in, "edges[" + std::to_string(i) + "]"));
  }
  for (int i = 0; i < message.landmarks_size(); ++i) {
    delta.landmarks.push_back(
        FromProto(message.landmarks(i), in, "landmarks[" + std::to_string(i) + "]"));
  }
  return delta;
}

void ApplyMissionDelta(const MissionDelta& delta, VIMap* map) {
  map->UpsertMission(delta.mission);
  for (const Vertex& v : delta.vertices) map->UpsertVertex(v);
  for (const Edge& e : delta.edges) map->UpsertEdge(e);
  for (const Landmark& l : delta.landmarks) map->UpsertLandmark(l);
}

}  // namespace mapstore
}  // namespace vilma

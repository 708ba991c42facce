#include "vilma/localizer/localization_map.h"

#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <unordered_map>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/mapstore/checksum.h"

namespace vilma::localizer {
namespace {

constexpr char kMagic[8] = {'V', 'L', 'O', 'C', 'M', 'A', 'P', '1'};

class Writer {
 public:
  template <typename T>
  void Pod(const T& v) {
    out_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <typename T>
  void Array(const std::vector<T>& v) {
    Pod(static_cast<uint64_t>(v.size()));
    out_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string& bytes() { return out_; }

 private:
  std::string out_;
};

class Reader {
 public:
  Reader(const std::string& bytes, std::size_t end, const std::string& path)
      : bytes_(bytes), end_(end), path_(path) {}
  template <typename T>
  T Pod(const char* field) {
    T v;
    Need(sizeof(T), field);
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  template <typename T>
  std::vector<T> Array(const char* field, uint64_t expected_size) {
    const uint64_t n = Pod<uint64_t>(field);
    if (n != expected_size) {
      Fail(field, "expected " + std::to_string(expected_size) + " elements, found " +
                      std::to_string(n));
    }
    if (n > (end_ - pos_) / sizeof(T)) Fail(field, "expected " + std::to_string(n) +
                                                       " elements, file is truncated");
    std::vector<T> v(n);
    // memcpy from/to a null pointer is undefined even for 0 bytes (found by fuzz_vlocmap).
    if (n > 0) std::memcpy(static_cast<void*>(v.data()), bytes_.data() + pos_, n * sizeof(T));
    pos_ += n * sizeof(T);
    return v;
  }
  void Raw(const char* field, void* out, std::size_t n) {
    Need(n, field);
    if (n > 0) std::memcpy(out, bytes_.data() + pos_, n);
    pos_ += n;
  }
  [[noreturn]] void Fail(const std::string& field, const std::string& expectation) const {
    throw InputError(FormatInputError(path_, field, expectation));
  }
  std::size_t pos() const { return pos_; }

 private:
  void Need(std::size_t n, const char* field) const {
    if (end_ - pos_ < n) Fail(field, "expected more data, file is truncated");
  }
  const std::string& bytes_;
  std::size_t end_;
  std::size_t pos_ = 0;
  std::string path_;
};

}  // namespace

std::string LocalizationMapOptions::Validate() const {
  if (max_descriptors_per_landmark < 1) return "max_descriptors_per_landmark: expected >= 1";
  if (min_observations < 1) return "min_observations: expected >= 1";
  return "";
}

std::string LocalizationMap::Validate() const {
  const std::size_t n = p_G.size();
  if (descriptor_bytes == 0 || descriptor_bytes > 256) return "descriptor_bytes: expected 1..256";
  if (landmark_ids.size() != n) return "landmark_ids: expected one per landmark";
  if (observer_begin.size() != n + 1) return "observer_begin: expected landmarks + 1 entries";
  if (observer_begin.front() != 0 || observer_begin.back() != observer_index.size()) {
    return "observer_begin: expected 0 .. observer_index size";
  }
  for (std::size_t l = 0; l < n; ++l) {
    if (observer_begin[l] > observer_begin[l + 1]) return "observer_begin: expected sorted";
  }
  for (uint32_t o : observer_index) {
    if (o >= observers.size()) return "observer_index: expected < number of observers";
  }
  if (descriptors.size() != descriptor_landmark.size() * descriptor_bytes) {
    return "descriptors: expected descriptor_bytes per descriptor";
  }
  for (uint32_t l : descriptor_landmark) {
    if (l >= n) return "descriptor_landmark: expected < number of landmarks";
  }
  if (projection.size() != 0 && projection.cols() != 8 * static_cast<int>(descriptor_bytes)) {
    return "projection: expected one column per descriptor bit";
  }
  for (const Eigen::Vector3d& p : p_G) {
    if (!p.allFinite()) return "p_G: expected finite positions";
  }
  return "";
}

std::vector<mapstore::MissionId> MissionsInCommonFrame(const mapstore::VIMap& map) {
  std::vector<mapstore::MissionId> anchored;
  for (const mapstore::MissionId& id : map.mission_ids()) {
    if (map.mission(id).baseframe_known) anchored.push_back(id);
  }
  if (!anchored.empty()) return anchored;
  if (map.mission_ids().empty()) return {};
  return {map.mission_ids().front()};
}

LocalizationMap BuildLocalizationMap(const mapstore::VIMap& map,
                                     const LocalizationMapOptions& options,
                                     LocalizationMapReport* report) {
  const std::vector<mapstore::MissionId> missions = MissionsInCommonFrame(map);
  if (report != nullptr) {
    report->missions_used = static_cast<int>(missions.size());
    report->missions_skipped = static_cast<int>(map.mission_ids().size() - missions.size());
  }
  return BuildLocalizationMapOfMissions(map, missions, options);
}

LocalizationMap BuildLocalizationMapOfMissions(const mapstore::VIMap& map,
                                               const std::vector<mapstore::MissionId>& missions,
                                               const LocalizationMapOptions& options) {
  const std::string error = options.Validate();
  if (!error.empty()) throw InputError(FormatInputError("LocalizationMapOptions", "", error));
  LocalizationMap out;
  out.observer_begin.push_back(0);
  std::unordered_map<mapstore::VertexId, uint32_t, mapstore::IdHash> observer_of;
  bool bytes_known = false;
  for (const mapstore::MissionId& mission_id : missions) {
    for (const mapstore::LandmarkId& landmark_id : map.landmark_ids(mission_id)) {
      const mapstore::Landmark& landmark = map.landmark(landmark_id);
      if (landmark.quality != mapstore::LandmarkQuality::kGood) continue;
      // Observations whose vertex, frame and keypoint exist (after loop closure some may
      // point into missions that are not loaded).
      std::vector<const mapstore::LandmarkObservation*> valid;
      for (const mapstore::LandmarkObservation& obs : landmark.observations) {
        if (!map.HasVertex(obs.vertex_id)) continue;
        const mapstore::Vertex& v = map.vertex(obs.vertex_id);
        if (obs.camera >= v.frames.size() || obs.keypoint >= v.frames[obs.camera].size()) continue;
        const mapstore::VisualFrame& frame = v.frames[obs.camera];
        if (frame.descriptors.size() < (obs.keypoint + 1) * std::size_t{frame.descriptor_size_bytes}) {
          continue;
        }
        if (!bytes_known) {
          out.descriptor_bytes = frame.descriptor_size_bytes;
          bytes_known = true;
        }
        if (frame.descriptor_size_bytes != out.descriptor_bytes) continue;
        valid.push_back(&obs);
      }
      if (static_cast<int>(valid.size()) < options.min_observations || valid.empty()) continue;
      const uint32_t l = static_cast<uint32_t>(out.p_G.size());
      out.landmark_ids.push_back(landmark_id);
      out.p_G.push_back(map.LandmarkPosition_G(landmark_id));
      const std::size_t first_observer = out.observer_index.size();
      for (const mapstore::LandmarkObservation* obs : valid) {
        auto [it, inserted] =
            observer_of.emplace(obs->vertex_id, static_cast<uint32_t>(out.observers.size()));
        if (inserted) out.observers.push_back(obs->vertex_id);
        bool seen = false;
        for (std::size_t i = first_observer; i < out.observer_index.size(); ++i) {
          seen |= out.observer_index[i] == it->second;
        }
        if (!seen) out.observer_index.push_back(it->second);
      }
      out.observer_begin.push_back(static_cast<uint32_t>(out.observer_index.size()));
      // Evenly spread subset: indices round(i * (n - 1) / (m - 1)).
      const std::size_t n = valid.size();
      const std::size_t m =
          std::min(n, static_cast<std::size_t>(options.max_descriptors_per_landmark));
      for (std::size_t i = 0; i < m; ++i) {
        const std::size_t k = m == 1 ? 0 : (i * (n - 1) + (m - 1) / 2) / (m - 1);
        const mapstore::LandmarkObservation& obs = *valid[k];
        const uint8_t* d = map.vertex(obs.vertex_id).frames[obs.camera].descriptor(obs.keypoint);
        out.descriptors.insert(out.descriptors.end(), d, d + out.descriptor_bytes);
        out.descriptor_landmark.push_back(l);
      }
    }
  }
  return out;
}

void SaveLocalizationMap(const LocalizationMap& map, const std::string& path) {
  const std::string error = map.Validate();
  if (!error.empty()) throw InputError(FormatInputError(path, "", "cannot save: " + error));
  Writer w;
  w.bytes().append(kMagic, sizeof(kMagic));
  w.Pod(LocalizationMap::kFormatVersion);
  w.Pod(map.descriptor_bytes);
  w.Pod(static_cast<uint64_t>(map.num_landmarks()));
  w.Pod(static_cast<uint64_t>(map.num_descriptors()));
  w.Pod(static_cast<uint64_t>(map.observers.size()));
  w.Pod(static_cast<uint64_t>(map.observer_index.size()));
  w.Array(map.landmark_ids);
  w.Array(map.p_G);
  w.Array(map.observer_begin);
  w.Array(map.observer_index);
  w.Array(map.observers);
  w.Array(map.descriptor_landmark);
  w.Array(map.descriptors);
  w.Pod(static_cast<uint32_t>(map.projection.rows()));
  w.Pod(static_cast<uint32_t>(map.projection.cols()));
  w.bytes().append(reinterpret_cast<const char*>(map.projection.data()),
                   sizeof(float) * map.projection.size());
  const uint32_t crc = mapstore::Crc32(w.bytes());
  w.Pod(crc);
  WriteFileAtomically(path, w.bytes());
}

LocalizationMap LoadLocalizationMap(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(FormatInputError(path, "", "expected a readable localization map file"));
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < sizeof(kMagic) + 8 || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    throw InputError(FormatInputError(path, "magic", "expected \"VLOCMAP1\" (a localization map)"));
  }
  Reader r(bytes, bytes.size() - 4, path);
  r.Pod<uint64_t>("magic");
  const uint32_t version = r.Pod<uint32_t>("version");
  if (version != LocalizationMap::kFormatVersion) {
    r.Fail("version", "expected " + std::to_string(LocalizationMap::kFormatVersion) +
                          ", found " + std::to_string(version));
  }
  uint32_t stored_crc;
  std::memcpy(&stored_crc, bytes.data() + bytes.size() - 4, 4);
  if (mapstore::Crc32(bytes.data(), bytes.size() - 4) != stored_crc) {
    r.Fail("crc32", "expected the checksum to match (file is corrupt or truncated)");
  }
  LocalizationMap map;
  map.descriptor_bytes = r.Pod<uint32_t>("descriptor_bytes");
  if (map.descriptor_bytes == 0 || map.descriptor_bytes > 256) {
    r.Fail("descriptor_bytes", "expected 1..256");
  }
  const uint64_t n_landmarks = r.Pod<uint64_t>("num_landmarks");
  const uint64_t n_descriptors = r.Pod<uint64_t>("num_descriptors");
  const uint64_t n_observers = r.Pod<uint64_t>("num_observers");
  const uint64_t n_observer_index = r.Pod<uint64_t>("num_observer_index");
  map.landmark_ids = r.Array<mapstore::LandmarkId>("landmark_ids", n_landmarks);
  map.p_G = r.Array<Eigen::Vector3d>("p_G", n_landmarks);
  map.observer_begin = r.Array<uint32_t>("observer_begin", n_landmarks + 1);
  map.observer_index = r.Array<uint32_t>("observer_index", n_observer_index);
  map.observers = r.Array<mapstore::VertexId>("observers", n_observers);
  map.descriptor_landmark = r.Array<uint32_t>("descriptor_landmark", n_descriptors);
  map.descriptors =
      r.Array<uint8_t>("descriptors", n_descriptors * uint64_t{map.descriptor_bytes});
  const uint32_t rows = r.Pod<uint32_t>("projection.rows");
  const uint32_t cols = r.Pod<uint32_t>("projection.cols");
  // What DescriptorIndex accepts: an even number of rows (two halves for the multi-index) up
  // to 64, one column per descriptor bit; 0 rows = no projection stored (trained at load).
  if (rows > 64 || rows % 2 != 0 || (rows > 0 && cols != 8 * map.descriptor_bytes)) {
    r.Fail("projection", "expected 0 or an even number up to 64 of rows, one column per "
                         "descriptor bit (got " + std::to_string(rows) + " x " +
                         std::to_string(cols) + ")");
  }
  map.projection.resize(rows, rows > 0 ? cols : 0);
  r.Raw("projection", map.projection.data(), sizeof(float) * map.projection.size());
  if (!map.projection.allFinite()) r.Fail("projection", "expected finite values");
  if (r.pos() != bytes.size() - 4) r.Fail("", "expected the file to end after the projection");
  const std::string error = map.Validate();
  if (!error.empty()) r.Fail("", error);
  return map;
}

}  // namespace vilma::localizer

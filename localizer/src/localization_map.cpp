#include "vilma/localizer/localization_map.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <zlib.h>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"

namespace vilma::localizer {
namespace {

constexpr char kMagic[8] = {'V', 'L', 'O', 'C', 'M', 'A', 'P', '1'};

// CRC-32 (IEEE 802.3 polynomial, reflected, initial and final XOR 0xFFFFFFFF: zlib's crc32,
// the same checksum as the VI-map's files) of `size` bytes.
uint32_t Crc32(const void* data, std::size_t size) {
  uLong crc = crc32(0L, Z_NULL, 0);
  const auto* bytes = static_cast<const Bytef*>(data);
  while (size > 0) {  // zlib takes uInt lengths
    const uInt n = static_cast<uInt>(std::min<std::size_t>(size, 1u << 30));
    crc = crc32(crc, bytes, n);
    bytes += n;
    size -= n;
  }
  return static_cast<uint32_t>(crc);
}

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
  template <typename T>
  T Peek(const char* field) {
    const T v = Pod<T>(field);
    pos_ -= sizeof(T);
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
  if (!p_G_covariance.empty() && p_G_covariance.size() != n) {
    return "p_G_covariance: expected none or one per landmark";
  }
  for (const Eigen::Matrix3f& c : p_G_covariance) {
    if (!c.allFinite() || (c - c.transpose()).cwiseAbs().maxCoeff() > 1e-6f * c.cwiseAbs().maxCoeff() ||
        c.diagonal().minCoeff() < 0.0f) {
      return "p_G_covariance: expected finite symmetric matrices with a non-negative diagonal";
    }
  }
  return "";
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
  w.Array(map.p_G_covariance);
  w.Array(map.observer_begin);
  w.Array(map.observer_index);
  w.Array(map.observers);
  w.Array(map.descriptor_landmark);
  w.Array(map.descriptors);
  w.Pod(static_cast<uint32_t>(map.projection.rows()));
  w.Pod(static_cast<uint32_t>(map.projection.cols()));
  w.bytes().append(reinterpret_cast<const char*>(map.projection.data()),
                   sizeof(float) * map.projection.size());
  const uint32_t crc = Crc32(w.bytes().data(), w.bytes().size());
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
  if (version != 1 && version != LocalizationMap::kFormatVersion) {
    r.Fail("version", "expected 1 or " + std::to_string(LocalizationMap::kFormatVersion) +
                          ", found " + std::to_string(version));
  }
  uint32_t stored_crc;
  std::memcpy(&stored_crc, bytes.data() + bytes.size() - 4, 4);
  if (Crc32(bytes.data(), bytes.size() - 4) != stored_crc) {
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
  map.landmark_ids = r.Array<MapObjectId>("landmark_ids", n_landmarks);
  map.p_G = r.Array<Eigen::Vector3d>("p_G", n_landmarks);
  if (version >= 2) {
    // None (unknown) or one per landmark: peek at the count.
    const uint64_t n_covariances = r.Peek<uint64_t>("p_G_covariance");
    map.p_G_covariance = r.Array<Eigen::Matrix3f>(
        "p_G_covariance", n_covariances == 0 ? uint64_t{0} : n_landmarks);
  }
  map.observer_begin = r.Array<uint32_t>("observer_begin", n_landmarks + 1);
  map.observer_index = r.Array<uint32_t>("observer_index", n_observer_index);
  map.observers = r.Array<MapObjectId>("observers", n_observers);
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

#include "vilma/mapstore/id.h"

#include <fstream>
#include <vector>

#include "vilma/core/error.h"
#include "vilma/mapstore/checksum.h"

#include <random>

namespace vilma {
namespace mapstore {

std::string Id::Hex() const {
  static const char* kDigits = "0123456789abcdef";
  std::string s(32, '0');
  for (int i = 0; i < 16; ++i) {
    s[15 - i] = kDigits[(hi >> (4 * i)) & 0xF];
    s[31 - i] = kDigits[(lo >> (4 * i)) & 0xF];
  }
  return s;
}

bool Id::FromHex(const std::string& hex, Id* id) {
  if (hex.size() != 32) return false;
  uint64_t halves[2] = {0, 0};
  for (int i = 0; i < 32; ++i) {
    const char c = hex[i];
    int v;
    if (c >= '0' && c <= '9') v = c - '0';
    else if (c >= 'a' && c <= 'f') v = c - 'a' + 10;
    else if (c >= 'A' && c <= 'F') v = c - 'A' + 10;
    else return false;
    halves[i / 16] = (halves[i / 16] << 4) | static_cast<uint64_t>(v);
  }
  id->hi = halves[0];
  id->lo = halves[1];
  return true;
}

IdGenerator IdGenerator::ForMission(const MissionId& mission_id) {
  // Mix both halves so that missions differing in either half get unrelated streams.
  IdGenerator mixer(mission_id.hi ^ 0x6A09E667F3BCC909ULL);
  const uint64_t a = mixer.NextWord();
  return IdGenerator(a ^ mission_id.lo);
}

IdGenerator IdGenerator::FromRandomDevice() {
  std::random_device device;
  const uint64_t seed = (static_cast<uint64_t>(device()) << 32) ^ device();
  return IdGenerator(seed);
}

uint64_t IdGenerator::NextWord() {
  // splitmix64: Weyl sequence step followed by a 64-bit finalizer (bijective mixing).
  uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

Id IdGenerator::Next() {
  Id id;
  do {
    id.hi = NextWord();
    id.lo = NextWord();
  } while (!id.IsValid());
  return id;
}

uint64_t SeedFromFileContent(const std::string& path, uint64_t max_bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(FormatInputError(path, "", "a readable file (to seed the mission ids)"));
  in.seekg(0, std::ios::end);
  const uint64_t size = static_cast<uint64_t>(in.tellg());
  in.seekg(0, std::ios::beg);
  std::vector<char> head(static_cast<std::size_t>(std::min(size, max_bytes)));
  if (!head.empty() && !in.read(head.data(), static_cast<std::streamsize>(head.size()))) {
    throw InputError(FormatInputError(path, "", "a readable file (to seed the mission ids)"));
  }
  // splitmix64 finalizer over (crc, size) so that the seed's bits are all mixed.
  uint64_t z = (static_cast<uint64_t>(Crc32(head.data(), head.size())) << 32) ^ size;
  z += 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return z == 0 ? 1 : z;
}

}  // namespace mapstore
}  // namespace vilma

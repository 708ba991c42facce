#include <catch2/catch.hpp>

#include <random>
#include <string>

#include "vilma/mapstore/checksum.h"

using vilma::mapstore::Crc32;
using vilma::mapstore::Crc32Hex;

namespace {
// Bitwise reference implementation (no tables), to check the sliced one on every length.
uint32_t ReferenceCrc32(const std::string& s) {
  uint32_t c = 0xFFFFFFFFu;
  for (unsigned char byte : s) {
    c ^= byte;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
  }
  return ~c;
}
}  // namespace

TEST_CASE("crc32 check values", "[mapstore]") {
  CHECK(Crc32(std::string("123456789")) == 0xCBF43926u);  // the standard check value
  CHECK(Crc32(std::string()) == 0u);
  CHECK(Crc32(std::string("The quick brown fox jumps over the lazy dog")) == 0x414FA339u);
  CHECK(Crc32Hex(0xCBF43926u) == "0xcbf43926");
  CHECK(Crc32Hex(0x1u) == "0x00000001");
}

TEST_CASE("crc32 matches the bitwise reference on every length and continues", "[mapstore]") {
  std::mt19937 rng(5);
  std::string data;
  for (int i = 0; i < 300; ++i) data.push_back(static_cast<char>(rng()));
  for (std::size_t n = 0; n <= data.size(); ++n) {
    const std::string s = data.substr(0, n);
    REQUIRE(Crc32(s) == ReferenceCrc32(s));
  }
  const std::string a = data.substr(0, 123), b = data.substr(123);
  CHECK(Crc32(b, Crc32(a)) == Crc32(data));
  // A single flipped bit changes the checksum.
  std::string flipped = data;
  flipped[77] ^= 0x10;
  CHECK(Crc32(flipped) != Crc32(data));
}

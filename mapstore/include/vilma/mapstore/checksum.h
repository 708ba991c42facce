// CRC-32 (IEEE 802.3 / zlib / PNG polynomial 0x04C11DB7, reflected 0xEDB88320, initial and
// final XOR 0xFFFFFFFF) of the map's data files. Check value: Crc32("123456789") == 0xCBF43926.
// Slicing-by-8 tables (Intel's method) process 8 bytes per step.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace vilma {
namespace mapstore {

// CRC of `size` bytes continued from `crc` (0 for a fresh start): Crc32(ab) ==
// Crc32(b, Crc32(a)).
uint32_t Crc32(const void* data, std::size_t size, uint32_t crc = 0);
inline uint32_t Crc32(const std::string& bytes, uint32_t crc = 0) {
  return Crc32(bytes.data(), bytes.size(), crc);
}
// "0x" and 8 lowercase hex digits.
std::string Crc32Hex(uint32_t crc);

}  // namespace mapstore
}  // namespace vilma

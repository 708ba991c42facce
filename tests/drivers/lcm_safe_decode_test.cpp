#include "vilma/drivers/lcm_safe_decode.h"

#include <catch2/catch.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/drivers/lcm_convert.h"

namespace vilma {
namespace {

template <typename Msg>
std::vector<uint8_t> Encode(const Msg& msg) {
  std::vector<uint8_t> bytes(static_cast<std::size_t>(msg.getEncodedSize()));
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

void PutInt32(std::vector<uint8_t>* bytes, std::size_t at, int32_t value) {
  const auto v = static_cast<uint32_t>(value);
  (*bytes)[at] = static_cast<uint8_t>(v >> 24);
  (*bytes)[at + 1] = static_cast<uint8_t>(v >> 16);
  (*bytes)[at + 2] = static_cast<uint8_t>(v >> 8);
  (*bytes)[at + 3] = static_cast<uint8_t>(v);
}

mission_chunk_t MakeChunk() {
  mission_chunk_t chunk;
  chunk.utime = 123;
  chunk.mission_id = "0123456789abcdef0123456789abcdef";
  chunk.mission_name = "room";
  chunk.session_id = 42;
  chunk.seq = 3;
  chunk.flags = mission_chunk_t::FLAG_DATA;
  chunk.payload = {1, 2, 3, 4, 5};
  chunk.payload_size = 5;
  chunk.checksum = 99;
  return chunk;
}

// Offsets in the chunk's encoding: hash 8, utime 8, mission_id (4 + 33), mission_name (4 + 5),
// session_id 8, seq 8, flags 1, payload_size.
constexpr std::size_t kMissionIdLengthAt = 16;
constexpr std::size_t kMissionNameLengthAt = kMissionIdLengthAt + 4 + 33;
constexpr std::size_t kPayloadSizeAt = kMissionNameLengthAt + 4 + 5 + 8 + 8 + 1;

std::string Decode(const std::vector<uint8_t>& bytes) {
  mission_chunk_t chunk;
  return DecodeMissionChunk(bytes.data(), static_cast<int>(bytes.size()), &chunk);
}

}  // namespace

TEST_CASE("DecodeMissionChunk: a valid chunk round-trips", "[lcm][safe_decode]") {
  const std::vector<uint8_t> bytes = Encode(MakeChunk());
  mission_chunk_t decoded;
  REQUIRE(DecodeMissionChunk(bytes.data(), static_cast<int>(bytes.size()), &decoded) == "");
  CHECK(decoded.mission_id == MakeChunk().mission_id);
  CHECK(decoded.mission_name == "room");
  CHECK(decoded.payload == MakeChunk().payload);
  CHECK(decoded.checksum == 99);
  // An empty payload (the END chunk) is legal.
  mission_chunk_t end = MakeChunk();
  end.payload.clear();
  end.payload_size = 0;
  CHECK(Decode(Encode(end)) == "");
}

TEST_CASE("DecodeMissionChunk: bad length fields are errors, never exceptions",
          "[lcm][safe_decode]") {
  const std::vector<uint8_t> good = Encode(MakeChunk());
  struct Case {
    std::size_t at;
    int32_t value;
    std::string expected;
  };
  // lcm-gen's decoder throws std::length_error on the first three (std::terminate inside an
  // LCM handler) and allocates 2 GB on the fourth.
  const Case cases[] = {
      {kPayloadSizeAt, -1, "mission_chunk_t: payload: count -1 < 0"},
      {kMissionIdLengthAt, 0, "mission_chunk_t: mission_id: string length 0 < 1"},
      {kMissionNameLengthAt, -5, "mission_chunk_t: mission_name: string length -5 < 1"},
      {kPayloadSizeAt, 0x7fffffff, "mission_chunk_t: payload: count 2147483647 beyond the message"},
      {kMissionIdLengthAt, 0x7fffffff,
       "mission_chunk_t: mission_id: string length 2147483647 beyond the message"},
  };
  for (const Case& c : cases) {
    std::vector<uint8_t> bytes = good;
    PutInt32(&bytes, c.at, c.value);
    INFO(c.expected);
    CHECK(Decode(bytes) == c.expected);
  }
  // Truncated anywhere and extended: errors.
  for (std::size_t size = 0; size < good.size(); ++size) {
    const std::vector<uint8_t> truncated(good.begin(), good.begin() + static_cast<long>(size));
    INFO(size);
    CHECK_FALSE(Decode(truncated).empty());
  }
  std::vector<uint8_t> longer = good;
  longer.push_back(0);
  CHECK(Decode(longer) == "mission_chunk_t: 1 bytes after the last field");
  // Another type's bytes: the walk may pass, the type hash does not.
  imu_t imu{};
  CHECK_FALSE(Decode(Encode(imu)).empty());
  mission_chunk_t unused;
  CHECK_FALSE(DecodeMissionChunk(nullptr, 10, &unused).empty());
}

TEST_CASE("DecodeMissionAck: valid, truncated and bad string lengths", "[lcm][safe_decode]") {
  mission_ack_t ack;
  ack.utime = 5;
  ack.mission_id = "0123456789abcdef0123456789abcdef";
  ack.session_id = 42;
  ack.ack_seq = 17;
  ack.status = mission_ack_t::OK;
  ack.message = "maps/room";
  const std::vector<uint8_t> good = Encode(ack);
  mission_ack_t decoded;
  REQUIRE(DecodeMissionAck(good.data(), static_cast<int>(good.size()), &decoded) == "");
  CHECK(decoded.ack_seq == 17);
  CHECK(decoded.message == "maps/room");
  std::vector<uint8_t> bad = good;
  PutInt32(&bad, 16, -1);  // mission_id's length
  CHECK(DecodeMissionAck(bad.data(), static_cast<int>(bad.size()), &decoded) ==
        "mission_ack_t: mission_id: string length -1 < 1");
  for (std::size_t size = 0; size < good.size(); ++size) {
    INFO(size);
    CHECK_FALSE(DecodeMissionAck(good.data(), static_cast<int>(size), &decoded).empty());
  }
}

TEST_CASE("image and IMU stamps that overflow int64 nanoseconds are rejected", "[lcm]") {
  // Found by fuzz_lcm_messages: UtimeToNs overflowed (undefined behaviour) on such stamps.
  CHECK(ValidateUtime("imu_t", 1700000000000000) == "");
  CHECK(ValidateUtime("imu_t", -1) == "");
  CHECK(ValidateUtime("imu_t", INT64_MAX / 1000) == "");
  CHECK_FALSE(ValidateUtime("imu_t", INT64_MAX / 1000 + 1).empty());
  CHECK_FALSE(ValidateUtime("imu_t", INT64_MIN).empty());
  ImuSample sample;
  imu_t msg = ImuToMessage(sample, 1);
  msg.utime = 18858823439613957;  // the fuzzer's input
  const std::vector<uint8_t> bytes = Encode(msg);
  imu_t decoded;
  CHECK(DecodeImuMessage(bytes.data(), static_cast<int>(bytes.size()), &decoded, &sample) ==
        "imu_t: utime 18858823439613957 us is out of range (|utime| <= 9223372036854775)");
  cv::Mat gray(2, 2, CV_8UC1, cv::Scalar(1));
  image_t image;
  REQUIRE(MakeImageMessage(gray, image_t::GRAY8, 0, 0, 0, &image) == "");
  image.utime = INT64_MIN;
  CHECK_FALSE(ValidateImageMessage(image).empty());
}

}  // namespace vilma

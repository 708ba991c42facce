// MIP protocol of vilma-usb-imu: checksums and packet encoding against the manual's examples,
// the framer on good, split, garbage-laden, corrupted and truncated streams (every error class
// counted, resync), a fuzz loop over mutated streams, IMU data and command-reply decoding.
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_USB_IMU

#include <cstdio>
#include <fstream>
#include <random>
#include <vector>

#include "drivers/usb_imu_sim_device.h"
#include "integration/process_util.h"
#include "vilma/drivers/usb_imu/mip_protocol.h"
#include "vilma/drivers/usb_imu/transport.h"

namespace vilma::usb_imu {
namespace {

using Bytes = std::vector<uint8_t>;

// `count` data packets of a GX5 at 200 Hz, one after another.
std::vector<Bytes> DataPackets(int count, MipFamily family = MipFamily::kGx5) {
  test::SimMipDeviceOptions o;
  o.family = family;
  test::SimMipDevice device(o);
  std::vector<Bytes> packets;
  for (int k = 0; k < count; ++k) packets.push_back(device.DataPacket(k, o.device_start_ns + k * 5000000LL));
  return packets;
}

Bytes Concat(const std::vector<Bytes>& parts) {
  Bytes out;
  for (const Bytes& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

// Pushes `stream` in chunks of `chunk` bytes (0: all at once) and flushes.
std::vector<MipPacket> Frame(const Bytes& stream, MipFramer* framer, std::size_t chunk = 0) {
  std::vector<MipPacket> out;
  const std::size_t step = chunk == 0 ? std::max<std::size_t>(stream.size(), 1) : chunk;
  for (std::size_t at = 0; at < stream.size(); at += step) {
    const std::size_t n = std::min(step, stream.size() - at);
    for (MipPacket& p : framer->Push(stream.data() + at, n)) out.push_back(std::move(p));
  }
  for (MipPacket& p : framer->Flush()) out.push_back(std::move(p));
  return out;
}

int64_t PacketBytes(const std::vector<MipPacket>& packets) {
  int64_t total = 0;
  for (const MipPacket& p : packets) total += static_cast<int64_t>(EncodeMipPacket(p).size());
  return total;
}

TEST_CASE("MIP checksum and encoding match the manual's ping and idle packets", "[usb_imu]") {
  // DCP manuals, "Ping" and "Set to Idle" examples.
  CHECK(EncodeMipPacket(MipPingCommand()) == Bytes{0x75, 0x65, 0x01, 0x02, 0x02, 0x01, 0xE0, 0xC6});
  CHECK(EncodeMipPacket(MipSetToIdleCommand()) ==
        Bytes{0x75, 0x65, 0x01, 0x02, 0x02, 0x02, 0xE1, 0xC7});
  CHECK(MipChecksum(nullptr, 0) == 0);
  MipPacket too_long;
  too_long.descriptor_set = 0x80;
  too_long.fields.push_back(MipField{0x01, Bytes(254, 0)});
  CHECK_THROWS_AS(EncodeMipPacket(too_long), std::invalid_argument);
}

TEST_CASE("MIP configuration commands encode the documented payloads", "[usb_imu]") {
  // GX5: IMU message format (0x0C,0x08) [write, 3, (0x04, 5), (0x05, 5), (0x12, 5)].
  MipPacket gx5 = MipImuMessageFormatCommand(MipFamily::kGx5, 5);
  CHECK(gx5.descriptor_set == 0x0C);
  CHECK(gx5.fields.at(0).descriptor == 0x08);
  CHECK(gx5.fields.at(0).data == Bytes{0x01, 0x03, 0x04, 0x00, 0x05, 0x05, 0x00, 0x05, 0x12, 0x00, 0x05});
  // CV7: message format (0x0C,0x0F) [write, 0x80, 3, (0x04, 0x0102), (0x05, ..), (0xD5, ..)].
  MipPacket cv7 = MipImuMessageFormatCommand(MipFamily::kCv7, 0x0102);
  CHECK(cv7.fields.at(0).descriptor == 0x0F);
  CHECK(cv7.fields.at(0).data ==
        Bytes{0x01, 0x80, 0x03, 0x04, 0x01, 0x02, 0x05, 0x01, 0x02, 0xD5, 0x01, 0x02});
  CHECK(MipGetBaseRateCommand(MipFamily::kGx5).fields.at(0).descriptor == 0x06);
  CHECK(MipGetBaseRateCommand(MipFamily::kCv7).fields.at(0).data == Bytes{0x80});
  CHECK(MipEnableImuStreamCommand(MipFamily::kGx5, true).fields.at(0).data == Bytes{1, 0x01, 1});
  CHECK(MipEnableImuStreamCommand(MipFamily::kCv7, false).fields.at(0).data == Bytes{1, 0x80, 0});
  // GX5 low-pass (0x0C,0x50) [write, field, enable, manual, u16 Hz, reserved].
  CHECK(MipLowpassFilterCommand(MipFamily::kGx5, 0x05, true, true, 100.0).fields.at(0).data ==
        Bytes{1, 0x05, 1, 1, 0x00, 0x64, 0});
  // CV7 low-pass (0x0C,0x54) [write, 0x80, field, enable, manual, float Hz]: 50.0f = 0x42480000.
  CHECK(MipLowpassFilterCommand(MipFamily::kCv7, 0x04, true, true, 50.0).fields.at(0).data ==
        Bytes{1, 0x80, 0x04, 1, 1, 0x42, 0x48, 0x00, 0x00});
  CHECK(MipResumeCommand().fields.at(0).descriptor == 0x06);
}

TEST_CASE("MIP replies: ACK/NACK and base rate fields", "[usb_imu]") {
  MipPacket reply;
  reply.descriptor_set = 0x0C;
  reply.fields = {MipField{0xF1, {0x06, 0x00}}, MipField{0x83, {0x03, 0xE8}}};
  uint8_t code = 0xFF;
  CHECK(FindMipAck(reply, 0x0C, 0x06, &code));
  CHECK(code == 0);
  CHECK_FALSE(FindMipAck(reply, 0x0C, 0x08, &code));  // the ACK of another command
  CHECK_FALSE(FindMipAck(reply, 0x01, 0x06, &code));  // of another set
  uint16_t rate = 0;
  CHECK(DecodeMipBaseRate(reply, MipFamily::kGx5, &rate));
  CHECK(rate == 1000);
  CHECK_FALSE(DecodeMipBaseRate(reply, MipFamily::kCv7, &rate));
  reply.fields = {MipField{0xF1, {0x0E, 0x00}}, MipField{0x8E, {0x80, 0x02, 0x58}}};
  CHECK(DecodeMipBaseRate(reply, MipFamily::kCv7, &rate));
  CHECK(rate == 600);
  CHECK(MipErrorName(0) == "ACK");
  CHECK(MipErrorName(3) == "NACK: invalid parameter");
  CHECK(MipErrorName(0x42) == "NACK: code 66");
}

TEST_CASE("MIP IMU data decodes to the sample, both timestamp fields", "[usb_imu]") {
  for (MipFamily family : {MipFamily::kGx5, MipFamily::kCv7}) {
    const int64_t device_ns = 3 * kGpsWeekNs + 123456789012345LL;  // a time in week 3
    test::SimMipDeviceOptions o;
    o.family = family;
    test::SimMipDevice device(o);
    const Bytes bytes = device.DataPacket(17, device_ns);
    MipFramer framer;
    const std::vector<MipPacket> packets = Frame(bytes, &framer);
    REQUIRE(packets.size() == 1);
    MipImuSample s;
    MipDecodeStats stats;
    REQUIRE(DecodeMipImuSample(packets[0], &s, &stats));
    CHECK(s.has_accel);
    CHECK(s.has_gyro);
    CHECK(s.has_timestamp);
    // GX5: tow is a double of seconds: exact to well below a microsecond in a week.
    CHECK(std::abs(s.device_ns - device_ns) < (family == MipFamily::kGx5 ? 1000 : 1));
    double accel[3];
    double gyro[3];
    test::SimReadings(17, accel, gyro);
    for (int i = 0; i < 3; ++i) {
      CHECK(s.accel_g[i] == Approx(accel[i]).margin(1e-6));
      CHECK(s.gyro_rad_s[i] == Approx(gyro[i]).margin(1e-5));
    }
    CHECK(stats.unknown_fields == 0);
  }
}

TEST_CASE("MIP GPS timestamps stay continuous across a week rollover", "[usb_imu]") {
  // The GX5's 0x12 field at 1 kHz around the end of week 2300: tow wraps to 0, week + 1.
  const int64_t end_of_week_ns = 2301 * kGpsWeekNs;
  int64_t last = 0;
  for (int64_t k = -3; k <= 3; ++k) {
    const int64_t device_ns = end_of_week_ns + k * 1000000;
    MipPacket p;
    p.descriptor_set = 0x80;
    Bytes t;
    const int64_t week = device_ns / kGpsWeekNs;
    AppendDouble(&t, static_cast<double>(device_ns - week * kGpsWeekNs) * 1e-9);
    AppendU16(&t, static_cast<uint16_t>(week));
    AppendU16(&t, 0x1F);
    p.fields = {MipField{0x12, t}};
    MipImuSample s;
    MipDecodeStats stats;
    REQUIRE(DecodeMipImuSample(p, &s, &stats));
    REQUIRE(s.has_timestamp);
    CHECK(s.gps_flags == 0x1F);
    CHECK(std::abs(s.device_ns - device_ns) < 1000);
    if (k > -3) CHECK(s.device_ns - last == Approx(1000000).margin(1000));
    last = s.device_ns;
  }
}

TEST_CASE("MIP IMU decoding counts wrong lengths, bad values and unknown fields",
          "[usb_imu]") {
  MipPacket p;
  p.descriptor_set = 0x80;
  Bytes nan_accel;
  for (int i = 0; i < 3; ++i) AppendFloat(&nan_accel, i == 1 ? NAN : 1.0f);
  Bytes bad_tow;
  AppendDouble(&bad_tow, 700000.0);  // more than a week
  AppendU16(&bad_tow, 1);
  AppendU16(&bad_tow, 0);
  p.fields = {MipField{0x04, Bytes(11, 0)}, MipField{0x05, nan_accel}, MipField{0x12, bad_tow},
              MipField{0x06, Bytes(12, 0)}};
  MipImuSample s;
  MipDecodeStats stats;
  REQUIRE(DecodeMipImuSample(p, &s, &stats));
  CHECK_FALSE(s.has_accel);
  CHECK_FALSE(s.has_gyro);
  CHECK_FALSE(s.has_timestamp);
  CHECK(stats.bad_field_lengths == 1);
  CHECK(stats.bad_values == 2);
  CHECK(stats.unknown_fields == 1);
  p.descriptor_set = 0x0C;
  CHECK_FALSE(DecodeMipImuSample(p, &s, &stats));
}

TEST_CASE("MIP framer: a clean stream split at every chunk size", "[usb_imu]") {
  const std::vector<Bytes> packets = DataPackets(40);
  const Bytes stream = Concat(packets);
  for (std::size_t chunk : {0, 1, 2, 3, 5, 7, 13, 31, 64, 500}) {
    MipFramer framer;
    const std::vector<MipPacket> out = Frame(stream, &framer, chunk);
    INFO("chunk " << chunk);
    REQUIRE(out.size() == packets.size());
    for (std::size_t i = 0; i < out.size(); ++i) CHECK(EncodeMipPacket(out[i]) == packets[i]);
    CHECK(framer.stats().packets == 40);
    CHECK(framer.stats().garbage_bytes == 0);
    CHECK(framer.stats().checksum_errors == 0);
    CHECK(framer.stats().truncated_packets == 0);
    CHECK(framer.stats().resyncs == 0);
  }
}

TEST_CASE("MIP framer: garbage, corrupted and truncated packets are counted and skipped",
          "[usb_imu]") {
  std::vector<Bytes> packets = DataPackets(10);
  Bytes stream;
  const Bytes garbage = {0x00, 0x11, 0x75, 0x00, 0x65, 0xFF, 0x75};  // incl. lone sync bytes
  stream.insert(stream.end(), garbage.begin(), garbage.end());       // before the first packet
  for (int k = 0; k < 10; ++k) {
    Bytes p = packets[k];
    if (k == 2) p[10] ^= 0x40;              // corrupted payload byte -> checksum error
    if (k == 4) p.resize(p.size() / 2);     // cut short, the next packet follows -> truncated
    if (k == 6) p[3] = static_cast<uint8_t>(p[3] + 3);  // corrupted length -> checksum error
    stream.insert(stream.end(), p.begin(), p.end());
    if (k == 7) stream.insert(stream.end(), {0x01, 0x02, 0x03});  // noise between packets
  }
  const Bytes tail(packets[9].begin(), packets[9].begin() + 9);  // cut by the end of the stream
  stream.insert(stream.end(), tail.begin(), tail.end());
  for (std::size_t chunk : {0, 1, 9, 40}) {
    MipFramer framer;
    const std::vector<MipPacket> out = Frame(stream, &framer, chunk);
    INFO("chunk " << chunk);
    const MipFramerStats& s = framer.stats();
    CHECK(out.size() == 7);  // 0 1 3 5 7 8 9
    CHECK(s.checksum_errors == 2);
    CHECK(s.truncated_packets == 2);  // packet 4, and the tail at the end of the stream
    CHECK(s.malformed_packets == 0);
    CHECK(s.resyncs == 4);
    // Conservation: every byte is in a good packet or counted as garbage.
    CHECK(s.bytes == static_cast<int64_t>(stream.size()));
    CHECK(s.bytes == PacketBytes(out) + s.garbage_bytes);
    CHECK(EncodeMipPacket(out[2]) == packets[3]);
    CHECK(EncodeMipPacket(out[3]) == packets[5]);
    CHECK(EncodeMipPacket(out[6]) == packets[9]);
  }
}

TEST_CASE("MIP framer: right checksum around impossible fields is malformed", "[usb_imu]") {
  // Payload "05 04 00 00" declares a 5-byte field in a 4-byte payload.
  Bytes bad = {0x75, 0x65, 0x80, 0x04, 0x05, 0x04, 0x00, 0x00};
  const uint16_t c = MipChecksum(bad.data(), bad.size());
  bad.push_back(static_cast<uint8_t>(c >> 8));
  bad.push_back(static_cast<uint8_t>(c));
  Bytes zero_set = {0x75, 0x65, 0x00, 0x00};  // descriptor set 0 is invalid
  const uint16_t c0 = MipChecksum(zero_set.data(), zero_set.size());
  zero_set.push_back(static_cast<uint8_t>(c0 >> 8));
  zero_set.push_back(static_cast<uint8_t>(c0));
  const Bytes stream = Concat({bad, DataPackets(1)[0], zero_set});
  MipFramer framer;
  const std::vector<MipPacket> out = Frame(stream, &framer);
  CHECK(out.size() == 1);
  CHECK(framer.stats().malformed_packets == 2);
  CHECK(framer.stats().bytes == PacketBytes(out) + framer.stats().garbage_bytes);
}

// A few thousand mutated streams: flipped, inserted and deleted bytes, cuts, random chunking.
// The framer never crashes, conserves bytes, emits only checksum-valid packets, loses only
// the packets a mutation touched, and its result does not depend on how reads split the stream.
TEST_CASE("MIP framer: fuzz over mutated streams", "[usb_imu]") {
  const std::vector<Bytes> packets = DataPackets(30, MipFamily::kCv7);
  const Bytes clean = Concat(packets);
  std::mt19937 rng(20261126);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int iteration = 0; iteration < 3000; ++iteration) {
    Bytes stream = clean;
    const int mutations = 1 + iteration % 6;
    for (int m = 0; m < mutations; ++m) {
      const std::size_t at = std::uniform_int_distribution<std::size_t>(0, stream.size() - 1)(rng);
      switch (byte(rng) % 4) {
        case 0: stream[at] = static_cast<uint8_t>(byte(rng)); break;
        case 1: stream.insert(stream.begin() + static_cast<std::ptrdiff_t>(at), static_cast<uint8_t>(byte(rng))); break;
        case 2: stream.erase(stream.begin() + static_cast<std::ptrdiff_t>(at)); break;
        default: {  // a sender reset: drop a run of bytes
          const std::size_t n = std::min<std::size_t>(stream.size() - at, 1 + byte(rng) % 40);
          stream.erase(stream.begin() + static_cast<std::ptrdiff_t>(at),
                       stream.begin() + static_cast<std::ptrdiff_t>(at + n));
        }
      }
      if (stream.empty()) stream.push_back(0);
    }
    MipFramer whole;
    const std::vector<MipPacket> a = Frame(stream, &whole);
    MipFramer chunked;
    std::vector<MipPacket> b;
    for (std::size_t at = 0; at < stream.size();) {
      const std::size_t n = std::min<std::size_t>(stream.size() - at, 1 + byte(rng) % 70);
      for (MipPacket& p : chunked.Push(stream.data() + at, n)) b.push_back(std::move(p));
      at += n;
    }
    for (MipPacket& p : chunked.Flush()) b.push_back(std::move(p));
    INFO("iteration " << iteration);
    REQUIRE(a.size() == b.size());
    REQUIRE(whole.stats().bytes == PacketBytes(a) + whole.stats().garbage_bytes);
    REQUIRE(whole.stats().checksum_errors == chunked.stats().checksum_errors);
    REQUIRE(whole.stats().truncated_packets == chunked.stats().truncated_packets);
    REQUIRE(whole.stats().garbage_bytes == chunked.stats().garbage_bytes);
    // A mutation touches at most two packets (a dropped run of <= 40 bytes, packets of 44).
    REQUIRE(static_cast<int>(a.size()) >= static_cast<int>(packets.size()) - 2 * mutations);
    for (std::size_t i = 0; i < a.size(); ++i) REQUIRE(EncodeMipPacket(a[i]) == EncodeMipPacket(b[i]));
  }
}

TEST_CASE("MIP framer on a recorded byte stream read through ReplayTransport", "[usb_imu]") {
  std::vector<Bytes> packets = DataPackets(25);
  packets[12][20] ^= 0x01;
  const Bytes stream = Concat(packets);
  const std::string path = vilma::test::ScratchDir() + "/mip_recorded.bin";
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(stream.data()), static_cast<std::streamsize>(stream.size()));
  }
  ReplayTransport transport(path, 17);
  transport.Open();
  MipFramer framer;
  std::size_t got = 0;
  uint8_t buffer[64];
  while (!transport.AtEnd()) {
    const std::size_t n = transport.Read(buffer, sizeof(buffer), 0);
    CHECK(n <= 17);
    got += framer.Push(buffer, n).size();
  }
  CHECK(got == 24);
  CHECK(framer.stats().checksum_errors == 1);
  ReplayTransport missing(path + ".absent");
  CHECK_THROWS_AS(missing.Open(), TransportError);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace vilma::usb_imu

#else

TEST_CASE("vilma-usb-imu MIP protocol", "[usb_imu]") {
  VILMA_SKIP("vilma-usb-imu is not built here (pkg-config finds no libusb-1.0: libusb-1.0-0-dev)");
}

#endif

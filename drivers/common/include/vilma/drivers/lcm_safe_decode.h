// Decoding of LCM messages with strings and variable-length arrays from untrusted bytes.
//
// lcm-gen's C++ decoders trust the length fields: a string length <= 0 or a negative array
// length makes them throw std::length_error, which escapes the LCM handler and terminates the
// process; a large length allocates what it claims before the buffer is checked (found by
// fuzz/fuzz_mission_stream: one malformed datagram on VILMA_MISSION stopped vilma-mapstored).
// These functions walk the encoding first (every length non-negative and within the buffer,
// the whole buffer used), then decode. They return "" or what is wrong; they never throw.
// Subscribe raw (lcm::ReceiveBuffer) and call them instead of typed subscriptions.
#pragma once

#include <string>

#include <vilma/mission_ack_t.hpp>
#include <vilma/mission_chunk_t.hpp>
#include <vilma/status_t.hpp>

namespace vilma {

std::string DecodeMissionChunk(const void* data, int size, mission_chunk_t* msg);
std::string DecodeMissionAck(const void* data, int size, mission_ack_t* msg);
// status_t's decoder resizes its name/value arrays to the counts it reads before checking
// them against the buffer: a count of 2^31 - 1 in a 100-byte message allocates 2^31 strings.
std::string DecodeStatusMessage(const void* data, int size, status_t* msg);

}  // namespace vilma

// Sensor faults injected into a replay (vilma-replay --fault, docs/reliability.md "Sensor
// faults"): the daemon's handling of a silent camera, an IMU gap, a clock that jumps, a
// duplicated burst and a camera at half rate is measured on the same data as a clean run.
//
// A fault acts on the messages whose dataset stamp t lies in [t_first + start_s,
// t_first + start_s + duration_s), t_first being the dataset's first stamp (as --start/--end).
// Pacing stays on the dataset's stamps: a clock jump changes the stamps the messages carry, not
// when they are sent. Dropped messages still consume their stream's seq number (a gap, as a
// lost message shows on the bus); a duplicate repeats the message byte for byte.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace vilma {

enum class ReplayFaultKind {
  kCameraDrop,      // "camera-drop:START:DURATION": no image of any camera (the camera silent)
  kImuGap,          // "imu-gap:START:DURATION": no IMU sample
  kTimeJump,        // "time-jump:START:DURATION:OFFSET": every stamp + OFFSET [s] (may be < 0)
                    // during the window, then back: a jump forward and one back (or back and
                    // forward for a negative OFFSET)
  kDuplicate,       // "duplicate:START:DURATION": every message sent twice
  kCameraHalfRate,  // "camera-half-rate:START:DURATION": every second frame of each camera dropped
};

struct ReplayFault {
  ReplayFaultKind kind = ReplayFaultKind::kCameraDrop;
  double start_s = 0.0;     // from the dataset's first stamp [s], >= 0
  double duration_s = 0.0;  // > 0 [s]
  double offset_s = 0.0;    // kTimeJump only [s], non-zero, |offset| <= kMaxTimeJumpS

  static constexpr double kMaxTimeJumpS = 1e6;  // keeps utime + offset far from int64 limits

  // Empty if valid, else what is wrong.
  std::string Validate() const;
  // The option text ("imu-gap:10:0.5"), as ParseReplayFault reads it.
  std::string ToString() const;
};

// Parses one --fault value. Returns an error naming the expected form, empty on success.
std::string ParseReplayFault(const std::string& text, ReplayFault* fault);

// What happens to one message of the merged sequence.
struct ReplayFaultAction {
  int copies = 1;              // 0 = dropped, 2 = duplicated
  int64_t stamp_offset_ns = 0;  // added to the stamp the message carries
};

// The action for a message of stream `stream` (-1 = IMU, else the camera index) stamped t_ns,
// the `frame_index`-th message of its stream (half rate drops the odd ones). Several faults
// compose: drops win, offsets add, duplicates double.
ReplayFaultAction ReplayFaultActionFor(const std::vector<ReplayFault>& faults, int64_t t_first_ns,
                                       int stream, int64_t t_ns, int64_t frame_index);

}  // namespace vilma

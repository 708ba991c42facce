// What a vilma-usb-imu run did, in the one shape of core/report.h: counts of the samples, of the
// framer's and decoder's error classes, of reconnects, and the clock mapping's state.
#pragma once

#include <cstdint>
#include <string>

namespace vilma::usb_imu {

struct UsbImuRunSummary {
  int64_t published = 0;          // imu_t messages published
  int64_t dropped = 0;            // samples missing from the device-time sequence
  int64_t packets = 0;            // good MIP packets framed
  int64_t checksum_errors = 0;    // framer candidates with a wrong checksum
  int64_t truncated_packets = 0;  // candidates cut short by a new packet
  int64_t malformed_packets = 0;  // checksum right, fields not filling the payload
  int64_t garbage_bytes = 0;      // bytes skipped while looking for a sync pair
  int64_t bad_fields = 0;         // fields of a wrong length or with non-finite values
  int64_t incomplete = 0;         // packets without accel, gyro or timestamp
  int64_t reconnects = 0;         // transport reopened after a loss
  int64_t clock_resets = 0;       // device-to-host clock mapping restarted
  double skew_ppm = 0.0;          // the device clock's rate against the host [ppm]

  // "published N samples, dropped D, packets P, checksum errors C, ... skew S ppm"
  std::string BriefReport() const;
  // `program` + ": " + BriefReport() + "\n" (the line the driver prints when it stops).
  std::string FullReport(const std::string& program = "vilma-usb-imu") const;
};

}  // namespace vilma::usb_imu

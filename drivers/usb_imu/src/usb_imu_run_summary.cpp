#include "vilma/drivers/usb_imu/usb_imu_run_summary.h"

#include <sstream>

namespace vilma::usb_imu {

std::string UsbImuRunSummary::BriefReport() const {
  std::ostringstream out;
  out << "published " << published << " samples, dropped " << dropped << ", packets " << packets
      << ", checksum errors " << checksum_errors << ", truncated " << truncated_packets
      << ", malformed " << malformed_packets << ", garbage bytes " << garbage_bytes
      << ", bad fields " << bad_fields << ", incomplete " << incomplete << ", reconnects "
      << reconnects << ", clock resets " << clock_resets << ", skew " << skew_ppm << " ppm";
  return out.str();
}

std::string UsbImuRunSummary::FullReport(const std::string& program) const {
  return program + ": " + BriefReport() + "\n";
}

}  // namespace vilma::usb_imu

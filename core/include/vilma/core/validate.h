// Small checks that options' Validate() methods share. Each returns "" when the value is
// acceptable, else "field: expectation" (the format of vilma's input errors, see error.h).
#pragma once

#include <cmath>
#include <sstream>
#include <string>

namespace vilma {

inline std::string ValidatePositive(const char* field, double value) {
  if (!(std::isfinite(value) && value > 0.0)) return std::string(field) + ": expected > 0";
  return "";
}

inline std::string ValidateNonNegative(const char* field, double value) {
  if (!(std::isfinite(value) && value >= 0.0)) return std::string(field) + ": expected >= 0";
  return "";
}

inline std::string ValidateAtLeast(const char* field, double value, double minimum) {
  if (!(std::isfinite(value) && value >= minimum)) {
    std::ostringstream s;
    s << field << ": expected >= " << minimum;
    return s.str();
  }
  return "";
}

}  // namespace vilma

// Returns the message of the first failing check from the enclosing Validate().
#define VILMA_RETURN_IF_ERROR(expr)        \
  do {                                     \
    const std::string vilma_error_ = (expr); \
    if (!vilma_error_.empty()) return vilma_error_; \
  } while (false)

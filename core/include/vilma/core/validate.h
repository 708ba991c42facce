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

// LCM channel names (architecture.md section 2): upper case, digits and '_', no regex
// metacharacters, at most 63 characters. Returns "" or what is wrong with `name`.
inline std::string ValidateChannelName(const std::string& name) {
  if (name.empty()) return "channel name is empty";
  if (name.size() > 63) return "channel name '" + name + "' is longer than 63 characters";
  for (char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
    if (!ok) {
      return "channel name '" + name + "' has '" + std::string(1, c) +
             "': expected upper-case letters, digits and '_' only";
    }
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

#include "vilma/console/flag_value.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

namespace vilma::console {

const char* FlagTypeName(FlagType type) {
  switch (type) {
    case FlagType::kBool: return "bool";
    case FlagType::kInt: return "int";
    case FlagType::kDouble: return "double";
    case FlagType::kString: return "string";
    case FlagType::kPath: return "path";
  }
  return "unknown";
}

const char* FlagTypeExpectation(FlagType type) {
  switch (type) {
    case FlagType::kBool: return "true or false";
    case FlagType::kInt: return "an integer";
    case FlagType::kDouble: return "a number";
    case FlagType::kString: return "a word";
    case FlagType::kPath: return "a path";
  }
  return "a value";
}

bool ParseFlagBool(const std::string& text) {
  if (text == "true" || text == "1" || text == "yes" || text == "on") return true;
  if (text == "false" || text == "0" || text == "no" || text == "off") return false;
  throw std::invalid_argument(FlagTypeExpectation(FlagType::kBool));
}

int64_t ParseFlagInt(const std::string& text, int64_t min, int64_t max) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0]))) {
    throw std::invalid_argument(FlagTypeExpectation(FlagType::kInt));
  }
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (end == nullptr || *end != '\0' || errno == ERANGE) {
    throw std::invalid_argument(FlagTypeExpectation(FlagType::kInt));
  }
  if (value < min || value > max) {
    throw std::invalid_argument("an integer from " + std::to_string(min) + " to " +
                                std::to_string(max));
  }
  return value;
}

double ParseFlagDouble(const std::string& text) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0]))) {
    throw std::invalid_argument(FlagTypeExpectation(FlagType::kDouble));
  }
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == nullptr || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
    throw std::invalid_argument("a finite number");
  }
  return value;
}

std::string FormatFlagDouble(double value) {
  char buffer[64];
  for (int precision = 1; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof(buffer), "%.*g", precision, value);
    if (std::strtod(buffer, nullptr) == value) break;
  }
  return buffer;
}

void CheckFlagValue(FlagType type, const std::string& text) {
  switch (type) {
    case FlagType::kBool: ParseFlagBool(text); return;
    case FlagType::kInt: ParseFlagInt(text, INT64_MIN, INT64_MAX); return;
    case FlagType::kDouble: ParseFlagDouble(text); return;
    case FlagType::kString:
    case FlagType::kPath: return;
  }
}

}  // namespace vilma::console

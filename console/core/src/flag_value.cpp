#include "vilma/console/flag_value.h"

#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "vilma/core/strict_parse.h"

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

bool ParseFlagBool(const std::string& text) { return ParseStrictBool(text); }

int64_t ParseFlagInt(const std::string& text, int64_t min, int64_t max) {
  return ParseStrictInt(text, min, max);
}

double ParseFlagDouble(const std::string& text) { return ParseStrictDouble(text); }

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

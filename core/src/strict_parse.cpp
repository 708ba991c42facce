#include "vilma/core/strict_parse.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace vilma {
namespace {

// strtoll/strtod skip leading white space; a flag value that starts with it is a typo.
bool StartsWithValueCharacter(const std::string& text) {
  return !text.empty() && !std::isspace(static_cast<unsigned char>(text[0]));
}

}  // namespace

int64_t ParseStrictInt(const std::string& text, int64_t min, int64_t max) {
  if (!StartsWithValueCharacter(text)) throw std::invalid_argument("an integer");
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(text.c_str(), &end, 10);
  if (end == nullptr || *end != '\0' || errno == ERANGE) {
    throw std::invalid_argument("an integer");
  }
  if (value < min || value > max) {
    throw std::invalid_argument("an integer from " + std::to_string(min) + " to " +
                                std::to_string(max));
  }
  return value;
}

double ParseStrictDouble(const std::string& text) {
  if (!StartsWithValueCharacter(text)) throw std::invalid_argument("a number");
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == nullptr || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
    throw std::invalid_argument("a finite number");
  }
  return value;
}

bool ParseStrictBool(const std::string& text) {
  if (text == "true" || text == "1" || text == "yes" || text == "on") return true;
  if (text == "false" || text == "0" || text == "no" || text == "off") return false;
  throw std::invalid_argument("true or false");
}

}  // namespace vilma

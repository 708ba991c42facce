// Strict parsing of numbers and booleans given as text (command-line flags, console flags):
// the whole text must be the value, so "10x", " 5", "1e400" and "nan" are errors instead of
// the prefix std::stoi/std::stod would silently take. Errors are std::invalid_argument whose
// message is the expectation ("an integer", "an integer from 1 to 100", "a finite number",
// "true or false"), for the caller to put behind the name of what it parsed.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

namespace vilma {

// Decimal integer in [min, max].
int64_t ParseStrictInt(const std::string& text,
                       int64_t min = std::numeric_limits<int64_t>::min(),
                       int64_t max = std::numeric_limits<int64_t>::max());
// Finite floating-point number (decimal or exponent notation).
double ParseStrictDouble(const std::string& text);
// true/false, 1/0, yes/no, on/off.
bool ParseStrictBool(const std::string& text);

}  // namespace vilma

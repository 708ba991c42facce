// Errors by audience (style.md): bad input from a user is an InputError that says which file,
// which field and what was expected; libraries throw it and never exit().
#pragma once

#include <stdexcept>
#include <string>

namespace vilma {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

// "FILE: FIELD: expected EXPECTATION" (FIELD may be empty), the one format of loader errors.
inline std::string FormatInputError(const std::string& file, const std::string& field,
                                    const std::string& expectation) {
  std::string msg = file;
  if (!field.empty()) msg += ": " + field;
  msg += ": " + expectation;
  return msg;
}

}  // namespace vilma

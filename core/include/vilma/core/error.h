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

// Throws the InputError for a non-empty options Validate() message "field: expectation" (the
// format of validate.h), naming `source` (a file, or what the options came from) and the field
// under `key_prefix` ("section.field" when the options were read from a nested section). The
// field is the text before the first ": "; a message without one is all expectation (no
// field). Does nothing when `validate_error` is empty.
inline void ThrowIfInvalid(const std::string& validate_error, const std::string& source,
                           const std::string& key_prefix = "") {
  if (validate_error.empty()) return;
  const std::size_t colon = validate_error.find(": ");
  const std::string field = colon == std::string::npos ? "" : validate_error.substr(0, colon);
  const std::string expectation =
      colon == std::string::npos ? validate_error : validate_error.substr(colon + 2);
  std::string path = key_prefix;
  if (!field.empty()) path = path.empty() ? field : path + "." + field;
  throw InputError(FormatInputError(source, path, expectation));
}

}  // namespace vilma

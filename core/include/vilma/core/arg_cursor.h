// Walking a program's command line, the same way in every program (`vilma` subcommands,
// vilma-estimatord): options take their value as "--name value" or "--name=value"; a flag given
// a value ("--print-config=no") is an error, not a yes.
//   for (ArgCursor arg(args); arg.Next();) {
//     if (arg.name() == "--out") o.out = arg.Value();
//     else if (arg.name() == "--frames") o.frames = arg.IntValue(1);  // strict: "10x" is an error
//     else ...
//   }
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "vilma/core/strict_parse.h"

namespace vilma {

// A bad command line (unknown option, missing value, ...): programs exit with code 2 and a
// usage hint.
class UsageError : public std::runtime_error {
 public:
  explicit UsageError(const std::string& message) : std::runtime_error(message) {}
};

class ArgCursor {
 public:
  explicit ArgCursor(const std::vector<std::string>& args) : args_(args) {}

  // Moves to the next word (after the value Value() took); false after the last.
  bool Next() {
    index_ = next_;
    if (index_ >= args_.size()) return false;
    next_ = index_ + 1;
    name_ = args_[index_];
    inline_value_.clear();
    has_inline_value_ = false;
    const std::size_t eq = name_.find('=');
    if (name_.rfind("--", 0) == 0 && eq != std::string::npos) {
      inline_value_ = name_.substr(eq + 1);
      name_.resize(eq);
      has_inline_value_ = true;
    }
    return true;
  }
  // The word, or of "--name=value" the part before '='.
  const std::string& name() const { return name_; }
  // The word as given.
  const std::string& word() const { return args_[index_]; }
  bool is_option() const { return name_.rfind("-", 0) == 0; }
  // The option's value: the inline one, else the next word (which Next() then skips).
  // UsageError "<name>: expected a value" when there is none.
  std::string Value() {
    if (has_inline_value_) return inline_value_;
    if (next_ >= args_.size()) throw UsageError(name_ + ": expected a value");
    return args_[next_++];
  }
  // Numeric and boolean values, parsed strictly (strict_parse.h): UsageError
  // "<name>: expected an integer from 1 to 100, got '0'" when the text is not one.
  int64_t Int64Value(int64_t min = std::numeric_limits<int64_t>::min(),
                     int64_t max = std::numeric_limits<int64_t>::max()) {
    const std::string text = Value();
    try {
      return ParseStrictInt(text, min, max);
    } catch (const std::invalid_argument& e) {
      throw UsageError(name_ + ": expected " + e.what() + ", got '" + text + "'");
    }
  }
  // An int-sized value (the common case of counts and indices).
  int IntValue(int min = std::numeric_limits<int>::min(),
               int max = std::numeric_limits<int>::max()) {
    return static_cast<int>(Int64Value(min, max));
  }
  double DoubleValue() {
    const std::string text = Value();
    try {
      return ParseStrictDouble(text);
    } catch (const std::invalid_argument& e) {
      throw UsageError(name_ + ": expected " + e.what() + ", got '" + text + "'");
    }
  }
  // A value in [min, max] (e.g. a rate > 0 given as DoubleValueIn(1e-9, inf)).
  double DoubleValueIn(double min, double max) {
    const double value = DoubleValue();
    if (value < min || value > max) {
      throw UsageError(name_ + ": expected a number from " + FormatNumber(min) + " to " +
                       FormatNumber(max) + ", got " + FormatNumber(value));
    }
    return value;
  }

  // For a flag (an option without a value): true, or UsageError "<name>: takes no value" when
  // it came as "--name=value" (so that "--quiet=no" is not read as --quiet).
  bool Flag() const {
    if (has_inline_value_) throw UsageError(name_ + ": takes no value");
    return true;
  }

 private:
  static std::string FormatNumber(double value) {
    std::ostringstream out;
    out << value;
    return out.str();
  }

  const std::vector<std::string>& args_;
  std::size_t index_ = 0;
  std::size_t next_ = 0;
  std::string name_;
  std::string inline_value_;
  bool has_inline_value_ = false;
};

}  // namespace vilma

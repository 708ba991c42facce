// Typed flag values of console commands: parsing and formatting per C++ type. A wrong value is
// a CommandError-style std::invalid_argument whose message says what was expected ("an
// integer", "a number", "true or false").
#pragma once

#include <cstdint>
#include <string>

namespace vilma::console {

enum class FlagType { kBool, kInt, kDouble, kString, kPath };
// "bool", "int", "double", "string", "path".
const char* FlagTypeName(FlagType type);
// What a value of the type looks like, for error messages ("an integer", ...).
const char* FlagTypeExpectation(FlagType type);

// Strict parsers: the whole text must be the value. Throw std::invalid_argument with the
// expectation as message.
bool ParseFlagBool(const std::string& text);  // true/false, 1/0, yes/no, on/off
int64_t ParseFlagInt(const std::string& text, int64_t min, int64_t max);
double ParseFlagDouble(const std::string& text);  // finite numbers only
// Shortest text that parses back to the same double.
std::string FormatFlagDouble(double value);
// Throws std::invalid_argument when `text` is not a valid value of `type`.
void CheckFlagValue(FlagType type, const std::string& text);

template <typename T>
struct FlagTraits;

template <>
struct FlagTraits<bool> {
  static constexpr FlagType kType = FlagType::kBool;
  static bool Parse(const std::string& t) { return ParseFlagBool(t); }
  static std::string Format(bool v) { return v ? "true" : "false"; }
};
template <>
struct FlagTraits<int> {
  static constexpr FlagType kType = FlagType::kInt;
  static int Parse(const std::string& t) {
    return static_cast<int>(ParseFlagInt(t, INT32_MIN, INT32_MAX));
  }
  static std::string Format(int v) { return std::to_string(v); }
};
template <>
struct FlagTraits<int64_t> {
  static constexpr FlagType kType = FlagType::kInt;
  static int64_t Parse(const std::string& t) { return ParseFlagInt(t, INT64_MIN, INT64_MAX); }
  static std::string Format(int64_t v) { return std::to_string(v); }
};
template <>
struct FlagTraits<uint32_t> {
  static constexpr FlagType kType = FlagType::kInt;
  static uint32_t Parse(const std::string& t) {
    return static_cast<uint32_t>(ParseFlagInt(t, 0, UINT32_MAX));
  }
  static std::string Format(uint32_t v) { return std::to_string(v); }
};
template <>
struct FlagTraits<uint64_t> {
  static constexpr FlagType kType = FlagType::kInt;
  static uint64_t Parse(const std::string& t) {
    return static_cast<uint64_t>(ParseFlagInt(t, 0, INT64_MAX));
  }
  static std::string Format(uint64_t v) { return std::to_string(v); }
};
template <>
struct FlagTraits<double> {
  static constexpr FlagType kType = FlagType::kDouble;
  static double Parse(const std::string& t) { return ParseFlagDouble(t); }
  static std::string Format(double v) { return FormatFlagDouble(v); }
};
template <>
struct FlagTraits<std::string> {
  static constexpr FlagType kType = FlagType::kString;
  static std::string Parse(const std::string& t) { return t; }
  static std::string Format(const std::string& v) { return v; }
};

}  // namespace vilma::console

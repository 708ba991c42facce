#include "vilma/eval/alignment_json.h"

#include <cmath>
#include <cstddef>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "vilma/core/error.h"
#include "vilma/core/json.h"

namespace vilma {
namespace {

using nlohmann::json;

// "line L, column C" of the character at 0-based `offset` of `text` (both 1-based).
std::string LineColumn(const std::string& text, std::size_t offset) {
  std::size_t line = 1, column = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

[[noreturn]] void FailSyntax(const std::string& path, const std::string& text,
                             const std::string& expectation, std::size_t offset) {
  throw InputError(FormatInputError(
      path, "", "expected valid JSON: " + expectation + " at " + LineColumn(text, offset)));
}

// An input iterator over the text that counts the characters nlohmann-json has taken: its
// lexer pulls one character at a time (and at most one beyond a token, to see where a number
// ends), so the count locates what the parser callback and the number-overflow error do not
// (they carry no position).
class CountingIterator {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  CountingIterator(const char* p, std::size_t* taken) : p_(p), taken_(taken) {}
  reference operator*() const { return *p_; }
  CountingIterator& operator++() {
    ++p_;
    ++*taken_;
    return *this;
  }
  CountingIterator operator++(int) {
    CountingIterator old = *this;
    ++*this;
    return old;
  }
  bool operator==(const CountingIterator& other) const { return p_ == other.p_; }
  bool operator!=(const CountingIterator& other) const { return p_ != other.p_; }

 private:
  const char* p_;
  std::size_t* taken_;
};

// Strict RFC 8259 (nlohmann-json: no comments, no trailing commas, no NaN, no leading zeros)
// plus what nlohmann lets through: duplicate keys (it keeps the last) and numbers beyond a
// double's range (an out_of_range exception without a position).
json ParseStrictJson(const std::string& text, const std::string& path) {
  std::size_t taken = 0;
  std::vector<std::set<std::string>> keys_per_object;
  const json::parser_callback_t check_keys = [&](int, json::parse_event_t event,
                                                 json& parsed) {
    if (event == json::parse_event_t::object_start) {
      keys_per_object.emplace_back();
    } else if (event == json::parse_event_t::object_end) {
      keys_per_object.pop_back();
    } else if (event == json::parse_event_t::key) {
      const std::string key = parsed.get<std::string>();
      // The lexer has taken the key up to its closing quote.
      if (!keys_per_object.back().insert(key).second) {
        FailSyntax(path, text, "no duplicate key \"" + key + "\"", taken);
      }
    }
    return true;
  };
  const CountingIterator first(text.data(), &taken);
  const CountingIterator last(text.data() + text.size(), &taken);
  try {
    return json::parse(first, last, check_keys, /*allow_exceptions=*/true,
                       /*ignore_comments=*/false);
  } catch (const json::parse_error& e) {
    // e.byte: 1-based index of the character where the parser stopped.
    const std::string what = e.what();
    const std::size_t colon = what.find(": ", what.find("parse error"));
    const std::string reason = colon == std::string::npos ? what : what.substr(colon + 2);
    FailSyntax(path, text, reason, e.byte > 0 ? e.byte - 1 : 0);
  } catch (const json::out_of_range& e) {
    // 406 "number overflow parsing '1e999'": located by searching the number back from where
    // the lexer stopped.
    const std::string what = e.what();
    const std::size_t open = what.find('\'');
    const std::size_t close = what.rfind('\'');
    std::size_t offset = taken;
    if (open != std::string::npos && close > open) {
      const std::string number = what.substr(open + 1, close - open - 1);
      const std::size_t at = text.rfind(number, taken);
      if (at != std::string::npos) offset = at;
    }
    FailSyntax(path, text, "a number in the range of a double", offset);
  }
}

const char* JsonKindName(const json& v) {
  switch (v.type()) {
    case json::value_t::null:
    case json::value_t::discarded:
      return "null";
    case json::value_t::boolean:
      return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float:
      return "a number";
    case json::value_t::string:
      return "a string";
    case json::value_t::array:
      return "an array";
    case json::value_t::object:
      return "an object";
    case json::value_t::binary:
      return "binary";
  }
  return "?";
}

bool IsKind(const json& v, json::value_t kind) {
  return kind == json::value_t::number_float ? v.is_number() : v.type() == kind;
}

// The member `key` of `object` of `kind` (number_float stands for any number), else an
// InputError "PATH: FIELD: expected EXPECTATION, missing | got KIND".
const json& RequireMember(const json& object, const std::string& key, json::value_t kind,
                          const std::string& path, const std::string& field,
                          const std::string& expectation) {
  const auto it = object.find(key);
  if (it == object.end()) {
    throw InputError(FormatInputError(path, field, "expected " + expectation + ", missing"));
  }
  if (!IsKind(*it, kind)) {
    throw InputError(FormatInputError(path, field,
                                      "expected " + expectation + ", got " + JsonKindName(*it)));
  }
  return *it;
}

// An array of exactly n numbers.
std::vector<double> RequireNumbers(const json& object, const std::string& key, std::size_t n,
                                   const std::string& path, const std::string& field) {
  const std::string expectation = "an array of " + std::to_string(n) + " numbers";
  const json& a = RequireMember(object, key, json::value_t::array, path, field, expectation);
  if (a.size() != n) {
    throw InputError(FormatInputError(
        path, field,
        "expected " + expectation + ", got " + std::to_string(a.size()) + " elements"));
  }
  std::vector<double> values;
  for (std::size_t i = 0; i < n; ++i) {
    if (!a[i].is_number()) {
      throw InputError(FormatInputError(path, field + "[" + std::to_string(i) + "]",
                                        std::string("expected a number, got ") +
                                            JsonKindName(a[i])));
    }
    values.push_back(a[i].get<double>());
  }
  return values;
}

}  // namespace

Alignment ParseAlignmentJson(const std::string& text, const std::string& path) {
  const json root = ParseStrictJson(text, path);
  if (!root.is_object()) {
    throw InputError(FormatInputError(path, "",
                                      std::string("expected a JSON object (the file of "
                                                  "`vilma eval --json`), got ") +
                                          JsonKindName(root)));
  }
  const json& version = RequireMember(root, "schema_version", json::value_t::number_float, path,
                                      "schema_version", "1 (a `vilma eval --json` file)");
  if (version.get<double>() != 1.0) {
    throw InputError(FormatInputError(
        path, "schema_version",
        "expected 1 (a `vilma eval --json` file), got " + JsonNumber(version.get<double>())));
  }
  const json& t =
      RequireMember(root, "alignment_transform", json::value_t::object, path,
                    "alignment_transform", "an object {scale, translation_m, quaternion_wxyz}");
  const double scale = RequireMember(t, "scale", json::value_t::number_float, path,
                                     "alignment_transform.scale", "a number > 0")
                           .get<double>();
  if (!(scale > 0.0)) {
    throw InputError(FormatInputError(path, "alignment_transform.scale",
                                      "expected a number > 0, got " + JsonNumber(scale)));
  }
  const std::vector<double> p =
      RequireNumbers(t, "translation_m", 3, path, "alignment_transform.translation_m");
  const std::vector<double> q =
      RequireNumbers(t, "quaternion_wxyz", 4, path, "alignment_transform.quaternion_wxyz");
  const Eigen::Quaterniond q_G_E(q[0], q[1], q[2], q[3]);
  // --json writes 10 significant digits, so a written unit quaternion has |norm - 1| ~ 1e-10;
  // 1e-6 accepts any such file and rejects a quaternion that is not a rotation.
  const double norm = q_G_E.norm();
  if (std::abs(norm - 1.0) > 1e-6) {
    throw InputError(
        FormatInputError(path, "alignment_transform.quaternion_wxyz",
                         "expected a unit quaternion (w, x, y, z), got norm " + JsonNumber(norm)));
  }
  Alignment a;
  a.type = AlignmentType::kFixed;
  a.scale = scale;
  a.T_G_E = Transformation(q_G_E, Eigen::Vector3d(p[0], p[1], p[2]));  // normalizes q
  return a;
}

Alignment ReadAlignmentJson(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(FormatInputError(path, "", "expected a readable JSON file"));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(FormatInputError(path, "", "expected a readable JSON file"));
  return ParseAlignmentJson(text.str(), path);
}

}  // namespace vilma

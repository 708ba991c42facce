#include "vilma/console/alignment_json.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include "vilma/core/error.h"
#include "vilma/core/json.h"

namespace vilma::console {
namespace {

// A strict JSON reader: RFC 8259 without extensions: no comments, no trailing commas, no
// NaN/Infinity, no leading zeros or '+', strings without raw control characters, duplicate keys
// rejected, nothing after the top-level value. Enough for the files `vilma eval --json` writes; the tree has no JSON
// library and this is the only reader.

struct JsonValue {
  enum class Kind { kNull, kBool, kNumber, kString, kArray, kObject };
  Kind kind = Kind::kNull;
  bool boolean = false;
  double number = 0.0;
  std::string string;
  std::vector<JsonValue> items;                            // kArray
  std::vector<std::pair<std::string, JsonValue>> members;  // kObject, in file order

  const JsonValue* Find(const std::string& key) const {
    for (const auto& m : members) {
      if (m.first == key) return &m.second;
    }
    return nullptr;
  }
};

const char* JsonKindName(JsonValue::Kind kind) {
  switch (kind) {
    case JsonValue::Kind::kNull:
      return "null";
    case JsonValue::Kind::kBool:
      return "a boolean";
    case JsonValue::Kind::kNumber:
      return "a number";
    case JsonValue::Kind::kString:
      return "a string";
    case JsonValue::Kind::kArray:
      return "an array";
    case JsonValue::Kind::kObject:
      return "an object";
  }
  return "?";
}

class JsonParser {
 public:
  JsonParser(const std::string& text, const std::string& path) : text_(text), path_(path) {}

  JsonValue ParseDocument() {
    SkipSpace();
    JsonValue v = ParseValue(0);
    SkipSpace();
    if (pos_ != text_.size()) Fail("the end of the file after the top-level value");
    return v;
  }

 private:
  static constexpr int kMaxDepth = 64;

  [[noreturn]] void Fail(const std::string& expectation) const {
    std::size_t line = 1, column = 1;
    for (std::size_t i = 0; i < pos_ && i < text_.size(); ++i) {
      if (text_[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
    throw InputError(FormatInputError(path_, "",
                                      "expected valid JSON: " + expectation + " at line " +
                                          std::to_string(line) + ", column " +
                                          std::to_string(column)));
  }

  void SkipSpace() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t' ||
                                   text_[pos_] == '\n' || text_[pos_] == '\r')) {
      ++pos_;
    }
  }

  bool Peek(char c) const { return pos_ < text_.size() && text_[pos_] == c; }

  void Expect(char c) {
    if (!Peek(c)) Fail(std::string("'") + c + "'");
    ++pos_;
  }

  bool Literal(const char* word) {
    const std::size_t n = std::strlen(word);
    if (text_.compare(pos_, n, word) != 0) return false;
    pos_ += n;
    return true;
  }

  JsonValue ParseValue(int depth) {
    if (depth > kMaxDepth) Fail("at most " + std::to_string(kMaxDepth) + " nested levels");
    JsonValue v;
    if (pos_ >= text_.size()) Fail("a value");
    const char c = text_[pos_];
    if (c == '{') {
      v.kind = JsonValue::Kind::kObject;
      ++pos_;
      SkipSpace();
      if (Peek('}')) {
        ++pos_;
        return v;
      }
      while (true) {
        SkipSpace();
        if (!Peek('"')) Fail("a string key");
        std::string key = ParseString();
        for (const auto& m : v.members) {
          if (m.first == key) Fail("no duplicate key \"" + key + "\"");
        }
        SkipSpace();
        Expect(':');
        SkipSpace();
        JsonValue member = ParseValue(depth + 1);
        v.members.emplace_back(std::move(key), std::move(member));
        SkipSpace();
        if (Peek(',')) {
          ++pos_;
          continue;
        }
        Expect('}');
        return v;
      }
    }
    if (c == '[') {
      v.kind = JsonValue::Kind::kArray;
      ++pos_;
      SkipSpace();
      if (Peek(']')) {
        ++pos_;
        return v;
      }
      while (true) {
        SkipSpace();
        v.items.push_back(ParseValue(depth + 1));
        SkipSpace();
        if (Peek(',')) {
          ++pos_;
          continue;
        }
        Expect(']');
        return v;
      }
    }
    if (c == '"') {
      v.kind = JsonValue::Kind::kString;
      v.string = ParseString();
      return v;
    }
    if (c == '-' || (c >= '0' && c <= '9')) {
      v.kind = JsonValue::Kind::kNumber;
      v.number = ParseNumber();
      return v;
    }
    if (Literal("true")) {
      v.kind = JsonValue::Kind::kBool;
      v.boolean = true;
      return v;
    }
    if (Literal("false")) {
      v.kind = JsonValue::Kind::kBool;
      return v;
    }
    if (Literal("null")) return v;
    Fail("a value (object, array, string, number, true, false or null)");
  }

  static bool IsDigit(char c) { return c >= '0' && c <= '9'; }

  // -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?, finite.
  double ParseNumber() {
    const std::size_t start = pos_;
    if (Peek('-')) ++pos_;
    if (Peek('0')) {
      ++pos_;
      if (pos_ < text_.size() && IsDigit(text_[pos_])) Fail("no leading zero in a number");
    } else if (pos_ < text_.size() && IsDigit(text_[pos_])) {
      while (pos_ < text_.size() && IsDigit(text_[pos_])) ++pos_;
    } else {
      Fail("a digit");
    }
    if (Peek('.')) {
      ++pos_;
      if (pos_ >= text_.size() || !IsDigit(text_[pos_])) Fail("a digit after '.'");
      while (pos_ < text_.size() && IsDigit(text_[pos_])) ++pos_;
    }
    if (Peek('e') || Peek('E')) {
      ++pos_;
      if (Peek('+') || Peek('-')) ++pos_;
      if (pos_ >= text_.size() || !IsDigit(text_[pos_])) Fail("a digit in the exponent");
      while (pos_ < text_.size() && IsDigit(text_[pos_])) ++pos_;
    }
    const std::string word = text_.substr(start, pos_ - start);
    errno = 0;
    const double v = std::strtod(word.c_str(), nullptr);
    if (!std::isfinite(v)) {
      pos_ = start;
      Fail("a number in the range of a double");
    }
    return v;
  }

  unsigned ParseHex4() {
    if (pos_ + 4 > text_.size()) Fail("four hex digits after \\u");
    unsigned code = 0;
    for (int i = 0; i < 4; ++i) {
      const char h = text_[pos_++];
      code <<= 4;
      if (h >= '0' && h <= '9') {
        code |= static_cast<unsigned>(h - '0');
      } else if (h >= 'a' && h <= 'f') {
        code |= static_cast<unsigned>(h - 'a' + 10);
      } else if (h >= 'A' && h <= 'F') {
        code |= static_cast<unsigned>(h - 'A' + 10);
      } else {
        --pos_;
        Fail("four hex digits after \\u");
      }
    }
    return code;
  }

  static void AppendUtf8(unsigned code, std::string* out) {
    if (code < 0x80) {
      *out += static_cast<char>(code);
    } else if (code < 0x800) {
      *out += static_cast<char>(0xC0 | (code >> 6));
      *out += static_cast<char>(0x80 | (code & 0x3F));
    } else if (code < 0x10000) {
      *out += static_cast<char>(0xE0 | (code >> 12));
      *out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
      *out += static_cast<char>(0x80 | (code & 0x3F));
    } else {
      *out += static_cast<char>(0xF0 | (code >> 18));
      *out += static_cast<char>(0x80 | ((code >> 12) & 0x3F));
      *out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
      *out += static_cast<char>(0x80 | (code & 0x3F));
    }
  }

  std::string ParseString() {
    Expect('"');
    std::string out;
    while (true) {
      if (pos_ >= text_.size()) Fail("a closing '\"'");
      const unsigned char c = static_cast<unsigned char>(text_[pos_]);
      if (c == '"') {
        ++pos_;
        return out;
      }
      if (c < 0x20) Fail("no raw control character in a string (escape it)");
      if (c != '\\') {
        out += static_cast<char>(c);
        ++pos_;
        continue;
      }
      ++pos_;
      if (pos_ >= text_.size()) Fail("an escape after '\\'");
      const char e = text_[pos_++];
      switch (e) {
        case '"':
        case '\\':
        case '/':
          out += e;
          break;
        case 'b':
          out += '\b';
          break;
        case 'f':
          out += '\f';
          break;
        case 'n':
          out += '\n';
          break;
        case 'r':
          out += '\r';
          break;
        case 't':
          out += '\t';
          break;
        case 'u': {
          unsigned code = ParseHex4();
          if (code >= 0xD800 && code <= 0xDBFF) {  // high surrogate: a low one must follow
            if (!Literal("\\u")) Fail("a low surrogate \\uDC00-\\uDFFF after a high one");
            const unsigned low = ParseHex4();
            if (low < 0xDC00 || low > 0xDFFF) Fail("a low surrogate \\uDC00-\\uDFFF");
            code = 0x10000 + ((code - 0xD800) << 10) + (low - 0xDC00);
          } else if (code >= 0xDC00 && code <= 0xDFFF) {
            Fail("no lone low surrogate");
          }
          AppendUtf8(code, &out);
          break;
        }
        default:
          --pos_;
          Fail("an escape \\\" \\\\ \\/ \\b \\f \\n \\r \\t or \\uXXXX");
      }
    }
  }

  const std::string& text_;
  const std::string& path_;
  std::size_t pos_ = 0;
};

const JsonValue& RequireMember(const JsonValue& object, const std::string& key,
                               JsonValue::Kind kind, const std::string& path,
                               const std::string& field, const std::string& expectation) {
  const JsonValue* v = object.Find(key);
  if (v == nullptr) {
    throw InputError(FormatInputError(path, field, "expected " + expectation + ", missing"));
  }
  if (v->kind != kind) {
    throw InputError(FormatInputError(
        path, field, "expected " + expectation + ", got " + JsonKindName(v->kind)));
  }
  return *v;
}

// An array of exactly n finite numbers.
std::vector<double> RequireNumbers(const JsonValue& object, const std::string& key, std::size_t n,
                                   const std::string& path, const std::string& field) {
  const std::string expectation = "an array of " + std::to_string(n) + " numbers";
  const JsonValue& a =
      RequireMember(object, key, JsonValue::Kind::kArray, path, field, expectation);
  if (a.items.size() != n) {
    throw InputError(FormatInputError(
        path, field,
        "expected " + expectation + ", got " + std::to_string(a.items.size()) + " elements"));
  }
  std::vector<double> values;
  for (std::size_t i = 0; i < n; ++i) {
    if (a.items[i].kind != JsonValue::Kind::kNumber) {
      throw InputError(
          FormatInputError(path, field + "[" + std::to_string(i) + "]",
                           std::string("expected a number, got ") + JsonKindName(a.items[i].kind)));
    }
    values.push_back(a.items[i].number);
  }
  return values;
}

}  // namespace

Alignment ParseAlignmentJson(const std::string& text, const std::string& path) {
  const JsonValue root = JsonParser(text, path).ParseDocument();
  if (root.kind != JsonValue::Kind::kObject) {
    throw InputError(FormatInputError(path, "",
                                      std::string("expected a JSON object (the file of "
                                                  "`vilma eval --json`), got ") +
                                          JsonKindName(root.kind)));
  }
  const JsonValue& version = RequireMember(root, "schema_version", JsonValue::Kind::kNumber, path,
                                           "schema_version", "1 (a `vilma eval --json` file)");
  if (version.number != 1.0) {
    throw InputError(FormatInputError(
        path, "schema_version",
        "expected 1 (a `vilma eval --json` file), got " + JsonNumber(version.number)));
  }
  const JsonValue& t =
      RequireMember(root, "alignment_transform", JsonValue::Kind::kObject, path,
                    "alignment_transform", "an object {scale, translation_m, quaternion_wxyz}");
  const JsonValue& scale = RequireMember(t, "scale", JsonValue::Kind::kNumber, path,
                                         "alignment_transform.scale", "a number > 0");
  if (!(scale.number > 0.0)) {
    throw InputError(FormatInputError(path, "alignment_transform.scale",
                                      "expected a number > 0, got " + JsonNumber(scale.number)));
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
  a.scale = scale.number;
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

}  // namespace vilma::console

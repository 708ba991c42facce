// One field list per options struct, and the strict reader and the writer made from it.
//
// An options struct lists its fields once, in a visit function
//
//   template <typename Options, typename Visitor>   // Options = Foo or const Foo
//   void VisitFooFields(Options& o, Visitor&& v) {
//     v("", "enabled", o.enabled);                   // top-level key
//     v("ransac", "threshold_px", o.ransac.threshold_px);
//     v("init.dynamic", "window_s", o.init.dynamic.window_s);  // nested section, dotted path
//   }
//
// (fields of one section next to each other), and gets from it
//   ReadOptionFields(root, missing, &options, visit)   -> the strict reader (yaml_io.h's rules:
//       an unknown key anywhere names file, key path and the known keys; a value of the wrong
//       type names file, key and the expectation), and
//   OptionFieldsToYaml(options, visit)                 -> YAML text that reads back to equal
//       values (doubles as their shortest round-trip text, strings quoted).
// So reader and writer cannot drift apart, and every options file round-trips.
// Field types: bool, int, int64_t, uint64_t (written and read as a non-negative integer),
// double, std::string, std::vector<int> (a flow list "[1, 0]"), std::vector<std::string> (a flow
// list of quoted strings), and any field with its own YAML form through WithCodec (below: an
// enum by name, "auto" or a number, a path resolved against the file's folder, a section that
// may also be the name of a file). A struct that another one embeds lists its fields once and
// is visited under a section with InSection(section, v).
#pragma once

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <exception>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "vilma/core/yaml_io.h"

namespace vilma {

// What a key absent from the file means.
enum class MissingKey {
  kRequired,     // an error naming file and key: the file lists every option
  kKeepDefault,  // the field keeps the value it had (the struct's default); a whole absent
                 // section keeps all of its defaults
};

// A field with its own YAML form: `read(node, key, value)` reads `key` of the section `node`
// into *value (through node.Get/Child/Fail, so that the key counts as known and errors name
// file and key; with MissingKey::kKeepDefault it is called only when the key is there), and
// `write(value)` gives its YAML text: one line, or, when the text starts with '\n', a block
// that the writer puts one level deeper than the key (a nested map; comment lines allowed).
// The field may be a whole struct when one key sets several of its members.
template <typename Field, typename Read, typename Write>
struct CodecField {
  Field* value;
  Read read;
  Write write;
};

template <typename Field, typename Read, typename Write>
CodecField<Field, Read, Write> WithCodec(Field& value, Read read, Write write) {
  return {&value, std::move(read), std::move(write)};
}

// The visitor `v` with `section` put in front of every field's section: an embedded struct's
// field list visited as a section of the outer file, e.g.
//   VisitClockSyncFields(o.clock_sync, InSection("clock_sync", v));
template <typename Visitor>
auto InSection(std::string section, Visitor& v) {
  return [section = std::move(section), &v](const char* inner, const char* key, auto&& field) {
    const std::string path =
        section.empty() ? std::string(inner)
                        : (*inner == '\0' ? section : section + "." + inner);
    v(path.c_str(), key, std::forward<decltype(field)>(field));
  };
}

namespace options_fields_detail {

template <typename T>
struct IsCodec : std::false_type {};
template <typename Field, typename Read, typename Write>
struct IsCodec<CodecField<Field, Read, Write>> : std::true_type {};

}  // namespace options_fields_detail

// The list under `key` of the section `node` (the key then counts as known); a missing key or
// anything but a list fails with "file: path.key: <expectation>". For codecs that read lists.
inline YAML::Node SequenceOrFail(const YamlNode& node, const char* key, const char* expectation) {
  if (!node.Has(key)) node.Fail(key, expectation);
  const YAML::Node list = node.raw()[key];
  if (!list.IsSequence()) node.Fail(key, expectation);
  return list;
}

namespace options_fields_detail {

template <typename T>
void ReadField(const YamlNode& node, const char* key, MissingKey missing, T* field) {
  if (missing == MissingKey::kKeepDefault && !node.Has(key)) return;
  if constexpr (IsCodec<T>::value) {
    field->read(node, key, field->value);
  } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
    const YAML::Node list = SequenceOrFail(node, key, "expected a list of strings ([] for none)");
    field->clear();
    for (const YAML::Node& element : list) {
      if (!element.IsScalar()) node.Fail(key, "expected a list of strings");
      field->push_back(element.Scalar());
    }
  } else if constexpr (std::is_same_v<T, uint64_t>) {
    const int64_t value = node.Get<int64_t>(key);
    if (value < 0) node.Fail(key, "expected a non-negative integer");
    *field = static_cast<uint64_t>(value);
  } else if constexpr (std::is_same_v<T, std::vector<int>>) {
    const YAML::Node list = SequenceOrFail(node, key, "expected a list of integers ([] for none)");
    field->clear();
    for (const YAML::Node& element : list) {
      try {
        field->push_back(element.as<int>());
      } catch (const std::exception&) {
        node.Fail(key, "expected a list of integers");
      }
    }
  } else {
    *field = node.Get<T>(key);
  }
}

// "a\"b" for a"b: YAML double-quoted scalar with the two characters it must escape.
inline std::string QuoteYamlString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

template <typename T>
std::string FormatField(const T& field) {
  if constexpr (IsCodec<T>::value) {
    return field.write(*field.value);
  } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
    std::string text = "[";
    for (std::size_t i = 0; i < field.size(); ++i) {
      text += (i ? ", " : "") + QuoteYamlString(field[i]);
    }
    return text + "]";
  } else if constexpr (std::is_same_v<T, bool>) {
    return field ? "true" : "false";
  } else if constexpr (std::is_same_v<T, std::string>) {
    return QuoteYamlString(field);
  } else if constexpr (std::is_same_v<T, std::vector<int>>) {
    std::string text = "[";
    for (std::size_t i = 0; i < field.size(); ++i) {
      text += (i ? ", " : "") + std::to_string(field[i]);
    }
    return text + "]";
  } else if constexpr (std::is_same_v<T, double>) {
    // The shortest text that reads back to the same double (std::to_chars' guarantee).
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof(buffer), field);
    return std::string(buffer, result.ptr);
  } else {
    static_assert(std::is_integral_v<T>, "options fields are bool, integers, double or string");
    return std::to_string(field);
  }
}

}  // namespace options_fields_detail

// A scalar as YAML text that yaml_io reads back to the same value (for hand-written writers of
// lists and vectors beside OptionFieldsToYaml).
template <typename T>
std::string FormatYamlScalar(const T& value) {
  return options_fields_detail::FormatField(value);
}
inline std::string FormatYamlScalar(const char* value) {
  return options_fields_detail::QuoteYamlString(value);
}

// Reads every field that `visit` lists from `root` into `*options`, then checks that no section
// (and `root`) holds a key nobody read. Throws InputError ("file: key.path: expected ...").
// Validation of the values stays with the caller (Options::Validate + root.CheckValid).
template <typename Options, typename Visit>
void ReadOptionFields(const YamlNode& root, MissingKey missing, Options* options, Visit&& visit) {
  // An empty file (a null document) is "every key missing".
  if (missing == MissingKey::kKeepDefault && root.raw().IsNull()) return;
  if (!root.IsMap()) root.Fail("", "expected a map of options");
  // Section nodes by dotted path; std::nullopt: the section is absent (kKeepDefault only).
  std::vector<std::pair<std::string, std::optional<YamlNode>>> sections;
  sections.emplace_back("", root);
  // Index, not reference: the vector grows while nested sections are looked up.
  auto section_index = [&](const std::string& path, auto& self) -> std::size_t {
    for (std::size_t i = 0; i < sections.size(); ++i) {
      if (sections[i].first == path) return i;
    }
    const std::size_t dot = path.rfind('.');
    const std::string parent = dot == std::string::npos ? "" : path.substr(0, dot);
    const std::string key = dot == std::string::npos ? path : path.substr(dot + 1);
    const std::optional<YamlNode> parent_node = sections[self(parent, self)].second;
    std::optional<YamlNode> node;
    if (parent_node && (missing == MissingKey::kRequired || parent_node->Has(key))) {
      node = parent_node->MapChild(key);
    }
    sections.emplace_back(path, node);
    return sections.size() - 1;
  };
  visit(*options, [&](const char* section, const char* key, auto&& field) {
    using T = std::decay_t<decltype(field)>;
    const std::optional<YamlNode> node = sections[section_index(section, section_index)].second;
    if (node) options_fields_detail::ReadField<T>(*node, key, missing, &field);
  });
  for (const auto& entry : sections) {
    if (entry.second) entry.second->CheckNoUnknownKeys();
  }
}

// The fields of `options` as YAML: sections as nested maps (two spaces per level), in the
// order `visit` lists them.
template <typename Options, typename Visit>
std::string OptionFieldsToYaml(const Options& options, Visit&& visit) {
  std::ostringstream out;
  std::string current;  // the section of the last line written
  visit(options, [&](const char* section_name, const char* key, const auto& field) {
    const std::string section = section_name;
    if (section != current) {
      // Headers of every level of `section` that `current` did not open already.
      std::size_t start = 0;
      while (!section.empty()) {
        const std::size_t dot = section.find('.', start);
        const std::string prefix = section.substr(0, dot);
        const bool open = current == prefix || current.rfind(prefix + ".", 0) == 0;
        if (!open) {
          const auto depth = static_cast<std::size_t>(std::count(prefix.begin(), prefix.end(), '.'));
          const std::size_t last_dot = prefix.rfind('.');
          out << std::string(2 * depth, ' ')
              << (last_dot == std::string::npos ? prefix : prefix.substr(last_dot + 1)) << ":\n";
        }
        if (dot == std::string::npos) break;
        start = dot + 1;
      }
      current = section;
    }
    const std::size_t depth =
        section.empty() ? 0 : 1 + static_cast<std::size_t>(std::count(section.begin(), section.end(), '.'));
    const std::string text = options_fields_detail::FormatField(field);
    if (text.empty() || text[0] != '\n') {
      out << std::string(2 * depth, ' ') << key << ": " << text << "\n";
      return;
    }
    // A block: every line of it one level deeper than the key.
    out << std::string(2 * depth, ' ') << key << ":\n";
    std::istringstream lines(text.substr(1));
    for (std::string line; std::getline(lines, line);) {
      out << std::string(2 * (depth + 1), ' ') << line << "\n";
    }
  });
  return out.str();
}

// Reads one field the way ReadOptionFields does, from `node`, without the unknown-key check
// (for a struct whose keys share a section with others: the caller checks once at the end).
template <typename T>
void ReadOptionField(const YamlNode& node, const char* key, MissingKey missing, T* field) {
  options_fields_detail::ReadField(node, key, missing, field);
}

}  // namespace vilma

// Strict YAML reading for options and configs (style.md): every error names the file, the key
// path and what was expected; keys that nobody read are reported as unknown.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "vilma/core/error.h"

namespace vilma {

class YamlNode {
 public:
  // Parses `path`; throws InputError when the file is missing or is not valid YAML.
  static YamlNode LoadFile(const std::string& path);
  // Parses YAML text; `source_name` stands for the file name in error messages.
  static YamlNode LoadString(const std::string& text, const std::string& source_name);

  YamlNode(YAML::Node node, std::string file, std::string key_path);

  const std::string& file() const { return file_; }
  const std::string& key_path() const { return key_path_; }
  const YAML::Node& raw() const { return node_; }

  bool Has(const std::string& key) const;
  bool IsMap() const { return node_.IsMap(); }
  bool IsSequence() const { return node_.IsSequence(); }

  // Required scalar; InputError if missing or of the wrong type.
  template <typename T>
  T Get(const std::string& key) const;
  // Optional scalar with a default; InputError if present but of the wrong type.
  template <typename T>
  T GetOr(const std::string& key, const T& default_value) const {
    return Has(key) ? Get<T>(key) : default_value;
  }
  // Required list of numbers; `expected_size` < 0 accepts any length.
  Eigen::VectorXd GetVector(const std::string& key, int expected_size = -1) const;
  // Required row-major rows x cols matrix, written either as a flat list or as a list of rows.
  Eigen::MatrixXd GetMatrix(const std::string& key, int rows, int cols) const;

  // Required map or sequence child.
  YamlNode Child(const std::string& key) const;
  // Required child that must be a map (an options section): "file: path.key: a map" otherwise.
  YamlNode MapChild(const std::string& key) const;
  // Elements of this node, which must be a sequence.
  std::vector<YamlNode> Elements() const;

  // Throws InputError naming the first key of this map that no Get/Has/Child call asked for,
  // and the keys that were asked for (the known ones: "... known keys here: a, b, c)").
  void CheckNoUnknownKeys() const;
  // ThrowIfInvalid (error.h) for options read from this node: a non-empty Validate() message
  // "field: expectation" becomes "file: key_path.field: expectation".
  void CheckValid(const std::string& validate_error) const {
    ThrowIfInvalid(validate_error, file_, key_path_);
  }

  // Throws InputError "file: key_path.key: expected ..." (key may be empty: this node).
  [[noreturn]] void Fail(const std::string& key, const std::string& expectation) const;

  std::string PathOf(const std::string& key) const;

 private:
  YAML::Node Lookup(const std::string& key) const;

  YAML::Node node_;
  std::string file_;
  std::string key_path_;
  // Keys read so far (shared by copies of the node so that checks see every access).
  std::shared_ptr<std::set<std::string>> used_keys_;
};

// Explicit instantiations exist for these types.
extern template double YamlNode::Get<double>(const std::string&) const;
extern template int YamlNode::Get<int>(const std::string&) const;
extern template int64_t YamlNode::Get<int64_t>(const std::string&) const;
extern template bool YamlNode::Get<bool>(const std::string&) const;
extern template std::string YamlNode::Get<std::string>(const std::string&) const;

}  // namespace vilma

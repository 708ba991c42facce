#include "vilma/core/yaml_io.h"

#include <cmath>
#include <fstream>
#include <sstream>

namespace vilma {
namespace {

template <typename T>
const char* TypeName();
template <>
const char* TypeName<double>() { return "a number"; }
template <>
const char* TypeName<int>() { return "an integer"; }
template <>
const char* TypeName<int64_t>() { return "an integer"; }
template <>
const char* TypeName<bool>() { return "true or false"; }
template <>
const char* TypeName<std::string>() { return "a string"; }

std::string Describe(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "nothing";
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  return "a map";
}

}  // namespace

YamlNode YamlNode::LoadFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(FormatInputError(path, "", "cannot open the file"));
  std::stringstream buffer;
  buffer << in.rdbuf();
  return LoadString(buffer.str(), path);
}

YamlNode YamlNode::LoadString(const std::string& text_in, const std::string& source_name) {
  // OpenCV's FileStorage (and so Kalibr/EuRoC files) start with "%YAML:1.0", which is not a
  // valid YAML 1.2 directive: blank that first line (keeping line numbers) before parsing.
  std::string text = text_in;
  if (text.rfind("%YAML:", 0) == 0) {
    const std::size_t eol = text.find('\n');
    text.replace(0, eol == std::string::npos ? text.size() : eol, "");
  }
  try {
    YAML::Node root = YAML::Load(text);
    return YamlNode(root, source_name, "");
  } catch (const YAML::Exception& e) {
    throw InputError(FormatInputError(source_name, "",
                                      "valid YAML (line " + std::to_string(e.mark.line + 1) +
                                          ", column " + std::to_string(e.mark.column + 1) +
                                          ": " + e.msg + ")"));
  }
}

YamlNode::YamlNode(YAML::Node node, std::string file, std::string key_path)
    : node_(std::move(node)),
      file_(std::move(file)),
      key_path_(std::move(key_path)),
      used_keys_(std::make_shared<std::set<std::string>>()) {}

std::string YamlNode::PathOf(const std::string& key) const {
  if (key.empty()) return key_path_.empty() ? "(top level)" : key_path_;
  return key_path_.empty() ? key : key_path_ + "." + key;
}

void YamlNode::Fail(const std::string& key, const std::string& expectation) const {
  throw InputError(FormatInputError(file_, PathOf(key), expectation));
}

YAML::Node YamlNode::Lookup(const std::string& key) const {
  if (!node_.IsMap()) Fail("", "a map with the key '" + key + "', got " + Describe(node_));
  used_keys_->insert(key);
  return node_[key];
}

bool YamlNode::Has(const std::string& key) const {
  if (!node_.IsMap()) return false;
  used_keys_->insert(key);
  const YAML::Node child = node_[key];
  return child.IsDefined() && !child.IsNull();
}

template <typename T>
T YamlNode::Get(const std::string& key) const {
  const YAML::Node child = Lookup(key);
  if (!child.IsDefined() || child.IsNull()) Fail(key, std::string("a required key: ") + TypeName<T>());
  if (!child.IsScalar()) Fail(key, std::string(TypeName<T>()) + ", got " + Describe(child));
  T value{};
  if (!YAML::convert<T>::decode(child, value)) {
    Fail(key, std::string(TypeName<T>()) + ", got " + Describe(child));
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(value)) Fail(key, "a finite number, got " + Describe(child));
  }
  return value;
}

template double YamlNode::Get<double>(const std::string&) const;
template int YamlNode::Get<int>(const std::string&) const;
template int64_t YamlNode::Get<int64_t>(const std::string&) const;
template bool YamlNode::Get<bool>(const std::string&) const;
template std::string YamlNode::Get<std::string>(const std::string&) const;

Eigen::VectorXd YamlNode::GetVector(const std::string& key, int expected_size) const {
  const YAML::Node child = Lookup(key);
  const std::string what =
      expected_size >= 0 ? "a list of " + std::to_string(expected_size) + " numbers"
                         : std::string("a list of numbers");
  if (!child.IsDefined() || child.IsNull()) Fail(key, "a required key: " + what);
  if (!child.IsSequence()) Fail(key, what + ", got " + Describe(child));
  if (expected_size >= 0 && static_cast<int>(child.size()) != expected_size) {
    Fail(key, what + ", got " + std::to_string(child.size()) + " elements");
  }
  Eigen::VectorXd v(child.size());
  for (std::size_t i = 0; i < child.size(); ++i) {
    double x = 0.0;
    if (!child[i].IsScalar() || !YAML::convert<double>::decode(child[i], x) || !std::isfinite(x)) {
      Fail(key + "[" + std::to_string(i) + "]", "a finite number, got " + Describe(child[i]));
    }
    v[static_cast<Eigen::Index>(i)] = x;
  }
  return v;
}

Eigen::MatrixXd YamlNode::GetMatrix(const std::string& key, int rows, int cols) const {
  const YAML::Node child = Lookup(key);
  const std::string what = "a " + std::to_string(rows) + "x" + std::to_string(cols) +
                           " matrix (a flat row-major list or a list of rows)";
  if (!child.IsDefined() || child.IsNull()) Fail(key, "a required key: " + what);
  if (!child.IsSequence()) Fail(key, what + ", got " + Describe(child));
  Eigen::MatrixXd m(rows, cols);
  const bool nested = child.size() > 0 && child[0].IsSequence();
  if (nested) {
    if (static_cast<int>(child.size()) != rows) Fail(key, what);
    for (int r = 0; r < rows; ++r) {
      const YAML::Node row = child[r];
      if (!row.IsSequence() || static_cast<int>(row.size()) != cols) {
        Fail(key + "[" + std::to_string(r) + "]", "a row of " + std::to_string(cols) + " numbers");
      }
      for (int c = 0; c < cols; ++c) {
        double x = 0.0;
        if (!YAML::convert<double>::decode(row[c], x) || !std::isfinite(x)) {
          Fail(key + "[" + std::to_string(r) + "][" + std::to_string(c) + "]", "a finite number");
        }
        m(r, c) = x;
      }
    }
    return m;
  }
  const Eigen::VectorXd flat = GetVector(key, rows * cols);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) m(r, c) = flat[r * cols + c];
  }
  return m;
}

YamlNode YamlNode::Child(const std::string& key) const {
  const YAML::Node child = Lookup(key);
  if (!child.IsDefined() || child.IsNull()) Fail(key, "a required section");
  if (!child.IsMap() && !child.IsSequence()) {
    Fail(key, "a map or a list, got " + Describe(child));
  }
  return YamlNode(child, file_, PathOf(key));
}

YamlNode YamlNode::MapChild(const std::string& key) const {
  const YamlNode child = Child(key);
  if (!child.IsMap()) Fail(key, "a map");
  return child;
}

std::vector<YamlNode> YamlNode::Elements() const {
  if (!node_.IsSequence()) Fail("", "a list, got " + Describe(node_));
  std::vector<YamlNode> out;
  for (std::size_t i = 0; i < node_.size(); ++i) {
    out.emplace_back(node_[i], file_, key_path_ + "[" + std::to_string(i) + "]");
  }
  return out;
}

void YamlNode::CheckNoUnknownKeys() const {
  if (!node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string key = kv.first.as<std::string>();
    if (used_keys_->count(key) > 0) continue;
    // The keys the reader asked for (read or looked up) are the ones it knows: a misspelling is
    // then fixed without opening the code or the docs.
    std::string known;
    for (const std::string& k : *used_keys_) known += (known.empty() ? "" : ", ") + k;
    Fail(key, "no such key here (unknown key; check spelling; known keys here: " +
                  (known.empty() ? std::string("none") : known) + ")");
  }
}

}  // namespace vilma

// The key paths of a YAML text ("section.key", nested maps recursed, lists and scalars are
// leaves), for tests that check a config file lists every option: the readers keep defaults
// for absent keys (docs/design.md "Options files"), so equal values alone would not show it.
#pragma once

#include <yaml-cpp/yaml.h>

#include <set>
#include <string>

namespace vilma::testing {

inline void CollectYamlKeyPaths(const YAML::Node& node, const std::string& prefix,
                                std::set<std::string>* paths) {
  for (const auto& entry : node) {
    const std::string path = prefix.empty() ? entry.first.Scalar()
                                            : prefix + "." + entry.first.Scalar();
    paths->insert(path);
    if (entry.second.IsMap()) CollectYamlKeyPaths(entry.second, path, paths);
  }
}

inline std::set<std::string> YamlKeyPaths(const std::string& yaml_text) {
  std::set<std::string> paths;
  const YAML::Node root = YAML::Load(yaml_text);
  if (root.IsMap()) CollectYamlKeyPaths(root, "", &paths);
  return paths;
}

}  // namespace vilma::testing

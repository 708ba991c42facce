#include "vilma/console/completion.h"

#include <algorithm>
#include <filesystem>
#include <set>

namespace vilma::console {

std::vector<std::string> CompletePath(const std::string& prefix) {
  namespace fs = std::filesystem;
  std::string dir_part, name_part = prefix;
  const std::size_t slash = prefix.rfind('/');
  if (slash != std::string::npos) {
    dir_part = prefix.substr(0, slash + 1);
    name_part = prefix.substr(slash + 1);
  }
  std::vector<std::string> out;
  std::error_code error;
  const fs::path dir = dir_part.empty() ? fs::path(".") : fs::path(dir_part);
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(name_part, 0) != 0) continue;
    if (name_part.empty() && !name.empty() && name[0] == '.') continue;
    out.push_back(dir_part + name + (entry.is_directory(error) ? "/" : ""));
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::string> CompleteWord(const ConsoleSession& session,
                                      const std::string& line_before, const std::string& word) {
  std::set<std::string> candidates;
  const std::vector<std::string> words = [&] {
    try {
      return SplitWords(line_before);
    } catch (const CommandError&) {
      return std::vector<std::string>();
    }
  }();
  // A command after ';' starts again.
  std::vector<std::string> current;
  for (const std::string& w : words) {
    if (w == ";") {
      current.clear();
    } else {
      current.push_back(w);
    }
  }
  if (current.empty()) {
    for (const std::string& name : session.registry().Names()) {
      if (name.rfind(word, 0) == 0) candidates.insert(name);
    }
    return {candidates.begin(), candidates.end()};
  }
  const CommandSpec* spec = session.registry().Find(current[0]);
  if (spec == nullptr) return {};
  if (word.rfind("--", 0) == 0) {
    const std::size_t eq = word.find('=');
    if (eq != std::string::npos) {  // --flag=partial value
      const FlagSpec* flag = spec->FindFlag(word.substr(2, eq - 2));
      if (flag != nullptr && flag->type == FlagType::kPath) {
        for (const std::string& p : CompletePath(word.substr(eq + 1))) {
          candidates.insert(word.substr(0, eq + 1) + p);
        }
      } else if (flag != nullptr && flag->type == FlagType::kBool) {
        for (const char* v : {"true", "false"}) {
          const std::string c = word.substr(0, eq + 1) + v;
          if (c.rfind(word, 0) == 0) candidates.insert(c);
        }
      }
      return {candidates.begin(), candidates.end()};
    }
    for (const FlagSpec& flag : spec->flags) {
      std::vector<std::string> names = flag.aliases;
      names.insert(names.begin(), flag.name);
      for (const std::string& name : names) {
        const std::string c = "--" + name + (flag.type == FlagType::kBool ? "" : "=");
        if (c.rfind(word, 0) == 0) candidates.insert(c);
      }
    }
    return {candidates.begin(), candidates.end()};
  }
  // A value after "--flag " (space-separated).
  if (current.size() >= 2 && current.back().rfind("--", 0) == 0 &&
      current.back().find('=') == std::string::npos) {
    const FlagSpec* flag = spec->FindFlag(current.back().substr(2));
    if (flag != nullptr && flag->type == FlagType::kPath) {
      const auto paths = CompletePath(word);
      return paths;
    }
  }
  // Positional: map keys for commands whose first positional is a map key, else paths for a
  // path positional.
  std::size_t positional_index = 0;
  for (std::size_t i = 1; i < current.size(); ++i) {
    if (current[i].rfind("--", 0) != 0) ++positional_index;
  }
  if (positional_index < spec->positional_flags.size()) {
    const FlagSpec* flag = spec->FindFlag(spec->positional_flags[positional_index]);
    if (flag != nullptr && (flag->name == "map_key" || flag->name == "target_map_key")) {
      for (const std::string& key : session.maps().Keys()) {
        if (key.rfind(word, 0) == 0) candidates.insert(key);
      }
      return {candidates.begin(), candidates.end()};
    }
    if (flag != nullptr && flag->type == FlagType::kPath) return CompletePath(word);
  }
  if (word.find('/') != std::string::npos || word.rfind('.', 0) == 0 || word.rfind('~', 0) == 0) {
    return CompletePath(word);
  }
  return {};
}

}  // namespace vilma::console

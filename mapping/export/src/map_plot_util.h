// Small text helpers shared by map_plot.cpp and map_plot_selection.cpp.
#pragma once

#include <algorithm>
#include <cctype>
#include <sstream>
#include <string>
#include <vector>

namespace vilma::mapping::internal {

inline std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t") - b + 1);
}

// Comma separated words, each trimmed (empty words kept).
inline std::vector<std::string> SplitComma(const std::string& text) {
  std::vector<std::string> words;
  std::stringstream ss(text);
  std::string word;
  while (std::getline(ss, word, ',')) words.push_back(Trim(word));
  return words;
}

inline bool IsHex(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
  });
}

inline std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace vilma::mapping::internal

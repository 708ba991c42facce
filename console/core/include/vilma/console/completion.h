// Tab completion of the console (pure functions, tested without a terminal): command names for
// the first word, a command's flags for words starting with "--", map keys for the commands
// that take one, and paths for path flags (`--map_folder=`, a path positional) or words that
// look like paths.
#pragma once

#include <string>
#include <vector>

#include "vilma/console/session.h"

namespace vilma::console {

// Candidates that complete `word`, the word being typed, whose line so far is `line_before`
// (the text before the word). Sorted, unique. Flag candidates end with '=' when the flag takes
// a value.
std::vector<std::string> CompleteWord(const ConsoleSession& session,
                                      const std::string& line_before, const std::string& word);

// Paths starting with `prefix` (folders end with '/').
std::vector<std::string> CompletePath(const std::string& prefix);

}  // namespace vilma::console

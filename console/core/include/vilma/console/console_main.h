// `vilma console`: the interactive console (libedit line editing, history, completion) or a
// batch run (--script FILE, -c "a; b", or commands on a non-terminal stdin), over a session
// with every plugin's commands (docs/console.md).
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace vilma::console {

// args: the words after `vilma console`. Exit codes: 0 ok, 1 a command failed (named on
// stderr), 2 bad command line, 130 interrupted batch.
int RunConsoleCommand(const std::vector<std::string>& args, std::ostream& out,
                      std::ostream& err);

}  // namespace vilma::console

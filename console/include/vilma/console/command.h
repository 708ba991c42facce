// What every `vilma` subcommand shares: its signature, exit codes and the usage error.
#pragma once

#include <cstddef>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "vilma/core/arg_cursor.h"

namespace vilma::console {

// Exit codes of `vilma` and its subcommands.
constexpr int kExitOk = 0;
constexpr int kExitInputError = 1;  // bad or unreadable input files, failed output
constexpr int kExitUsage = 2;       // bad command line

// The command-line walker and its error, shared with the other programs (core/arg_cursor.h).
using vilma::ArgCursor;
using vilma::UsageError;

// A subcommand: args are the words after the subcommand's name; report to `out`, errors to
// `err`; returns an exit code. Never exits the process, so tests can call it directly.
using CommandFunction = int (*)(const std::vector<std::string>& args, std::ostream& out,
                                std::ostream& err);

}  // namespace vilma::console

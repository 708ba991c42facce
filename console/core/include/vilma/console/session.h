// A console session: the registry, the loaded maps, the session's flag defaults (`set`,
// `--flagfile`), and the runner that parses a command line, checks its flags, runs the command
// (modifying commands on a copy of the map, swapped in only on success) and reports its time.
// The interactive console (repl.h), `--script FILE` and `-c "a; b"` all go through Execute /
// RunScript, and so do the tests:
//
//   ConsoleSession session(CommandRegistry::WithPlugins(), out, err);
//   REQUIRE(session.Execute("load --map_folder " + dir).ok());
//   REQUIRE(session.Execute("kfh --kf_every_nth_vertex=5").ok());
#pragma once

#include <atomic>
#include <chrono>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "vilma/console/command_registry.h"
#include "vilma/console/map_store.h"

namespace vilma::console {

struct SessionOptions {
  // Echo every command ("> cmd") and its wall time ("  (cmd: 0.42 s)") as batch runs do.
  bool echo_commands = false;
  // Draw the progress bar with carriage returns (a terminal); otherwise one line per 10 %.
  bool terminal_progress = false;
  // After a modifying command, check the working copy with CheckMapConsistency and refuse to
  // keep it if it is inconsistent (the loaded map stays as it was).
  bool verify_modifications = true;
};

enum class CommandOutcome { kOk, kFailed, kCancelled, kQuit };

struct CommandResult {
  CommandOutcome outcome = CommandOutcome::kOk;
  std::string command;  // the name as typed ("" for an empty line)
  std::string message;  // the error for kFailed
  double seconds = 0.0;
  bool ok() const { return outcome == CommandOutcome::kOk || outcome == CommandOutcome::kQuit; }
};

struct ScriptResult {
  bool ok = true;
  int commands_run = 0;
  std::string failed_command;  // the whole command line that failed
  std::string source_line;     // "FILE:LINE" of it
  bool quit = false;           // a `quit` ended the script
};

class ConsoleSession {
 public:
  // `cancel_flag`: set (by a SIGINT handler) to cancel the running command; nullptr: none.
  ConsoleSession(CommandRegistry registry, std::ostream& out, std::ostream& err,
                 SessionOptions options = {}, std::atomic<bool>* cancel_flag = nullptr);

  // Runs one command line (words; quotes group words; no ';' splitting). Errors go to `err`
  // as "COMMAND: error: MESSAGE".
  CommandResult Execute(const std::string& line);
  // Runs commands separated by newlines or ';' ('#' starts a comment outside quotes), stopping
  // at the first failure; `source_name` names the script in messages.
  ScriptResult RunScript(const std::string& text, const std::string& source_name);

  MapStore& maps() { return maps_; }
  const MapStore& maps() const { return maps_; }
  const CommandRegistry& registry() const { return registry_; }
  SessionOptions& options() { return options_; }

  // Session defaults of flags (by canonical name). SetDefault checks that some command has the
  // flag (by name or alias) and that the value has its type; throws CommandError otherwise.
  void SetDefault(const std::string& flag, const std::string& value);
  void UnsetDefault(const std::string& flag);
  const std::map<std::string, std::string>& defaults() const { return defaults_; }
  // Reads `--name=value` lines ('#' comments, blank lines) into the session defaults; throws
  // CommandError naming file, line and flag.
  void LoadFlagFile(const std::string& path);

 private:
  void RegisterBuiltins();
  void RunCommand(const CommandSpec& spec, const std::vector<std::string>& words,
                  CommandResult* result);

  CommandRegistry registry_;
  std::ostream& out_;
  std::ostream& err_;
  SessionOptions options_;
  std::atomic<bool>* cancel_flag_;
  MapStore maps_;
  std::map<std::string, std::string> defaults_;
};

// Splits a command line into words: whitespace separates, '...' and "..." group, backslash
// escapes the next character. Throws CommandError on an unterminated quote.
std::vector<std::string> SplitWords(const std::string& line);
// Splits a script into commands at newlines and ';' (outside quotes), dropping '#' comments and
// blank commands; each with its 1-based line number.
std::vector<std::pair<int, std::string>> SplitScript(const std::string& text);
// Replaces every ${NAME} in a script by its value (`vilma console --var NAME=VALUE`); "$$"
// stands for "$". Throws CommandError naming the line for an undefined or unterminated name.
std::string ExpandVariables(const std::string& text,
                            const std::map<std::string, std::string>& variables);
// The names in `candidates` closest to `word` (edit distance <= 2, or a common prefix).
std::vector<std::string> SimilarNames(const std::string& word,
                                      const std::vector<std::string>& candidates);

}  // namespace vilma::console

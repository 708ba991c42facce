#include "vilma/console/console_main.h"

#include <editline/readline.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <iostream>
#include <sstream>

#include "vilma/console/completion.h"
#include "vilma/console/session.h"

namespace vilma::console {
namespace {

// SIGINT sets this flag; the running command sees it at its next safe point. A signal handler
// can only reach static storage: this is the one process-wide variable of the console, and
// the session reads it through the pointer it is given.
std::atomic<bool> g_cancel_requested{false};
static_assert(std::atomic<bool>::is_always_lock_free, "signal-safe flag");

extern "C" void OnSigint(int) { g_cancel_requested.store(true); }

void InstallSigintHandler() {
  struct sigaction action;
  std::memset(&action, 0, sizeof(action));
  action.sa_handler = &OnSigint;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGINT, &action, nullptr);
}

// libedit calls completion through C function pointers without a user pointer: the session
// being edited is reachable only through this pointer, set while the REPL runs.
const ConsoleSession* g_completion_session = nullptr;
std::vector<std::string> g_completions;

char* CompletionGenerator(const char* /*text*/, int state) {
  if (state < 0 || static_cast<std::size_t>(state) >= g_completions.size()) return nullptr;
  return strdup(g_completions[static_cast<std::size_t>(state)].c_str());
}

char** AttemptCompletion(const char* text, int start, int /*end*/) {
  if (g_completion_session == nullptr) return nullptr;
  const std::string line(rl_line_buffer, static_cast<std::size_t>(start));
  g_completions = CompleteWord(*g_completion_session, line, text);
  // No space after a flag waiting for its value or a folder.
  rl_completion_append_character =
      (g_completions.size() == 1 &&
       (g_completions[0].back() == '=' || g_completions[0].back() == '/'))
          ? '\0'
          : ' ';
  return rl_completion_matches(text, &CompletionGenerator);
}

std::string HistoryPath() {
  if (const char* path = std::getenv("VILMA_CONSOLE_HISTORY")) return path;
  if (const char* home = std::getenv("HOME")) return std::string(home) + "/.vilma_console_history";
  return "";
}

void PrintUsage(std::ostream& out) {
  out << "usage: vilma console [MAP_DIR...] [--script FILE | -c \"CMD; CMD\"] [--flagfile FILE]\n"
         "                     [--var NAME=VALUE ...] [--history FILE | --no-history]\n"
         "                     [--progress-bar]\n"
         "\n"
         "The maplab-style console over VI-maps (docs/console.md). Each MAP_DIR is loaded first\n"
         "(`load`). Without --script or -c: an interactive prompt (line editing, history, tab\n"
         "completion of commands, flags, map keys and paths) on a terminal, or the commands of\n"
         "standard input otherwise. `help` inside lists every command.\n"
         "\n"
         "  --script FILE    run the commands of FILE (newlines or ';'; '#' comments), echo each\n"
         "                   with its wall time, stop at the first failing one\n"
         "  -c \"A; B\"        the same for commands on the command line\n"
         "  --flagfile FILE  --name=value lines: session defaults (as `set NAME VALUE`)\n"
         "  --var NAME=VALUE ${NAME} in the script (or -c) becomes VALUE ($$ is a $), so that one\n"
         "                   script serves many maps: --var map=maps/a --var out=maps/a-kf\n"
         "  --history FILE   history file (default $VILMA_CONSOLE_HISTORY or\n"
         "                   ~/.vilma_console_history, 1000 entries); --no-history: none\n"
         "  --progress-bar   draw progress bars in place even when stdout is not a terminal\n"
         "\n"
         "Ctrl-C cancels the running command at a safe point; commands that modify the map roll\n"
         "back (the loaded map stays as it was). Exit codes: 0 ok, 1 a command failed (named on\n"
         "stderr), 2 bad command line, 130 a batch interrupted by Ctrl-C.\n";
}

int RunRepl(ConsoleSession* session, const std::string& history_path, std::ostream& out) {
  g_completion_session = session;
  rl_attempted_completion_function = &AttemptCompletion;
  rl_basic_word_break_characters = " \t\n;";
  stifle_history(1000);
  if (!history_path.empty()) read_history(history_path.c_str());
  out << "vilma console — `help` lists the commands, Tab completes, Ctrl-D leaves.\n";
  int exit_code = 0;
  while (true) {
    const std::string key = session->maps().selected();
    const std::string prompt = "vilma:" + (key.empty() ? std::string("-") : key) + "> ";
    g_cancel_requested.store(false);
    char* raw = readline(prompt.c_str());
    if (raw == nullptr && g_cancel_requested.load()) {  // Ctrl-C at the prompt: a new line
      out << "\n";
      continue;
    }
    if (raw == nullptr) {  // Ctrl-D
      out << "\n";
      break;
    }
    if (g_cancel_requested.load()) {  // Ctrl-C while typing: drop the line
      std::free(raw);
      out << "\n";
      continue;
    }
    const std::string line(raw);
    std::free(raw);
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    add_history(line.c_str());
    if (!history_path.empty()) {
      write_history(history_path.c_str());
      history_truncate_file(history_path.c_str(), 1000);
    }
    const ScriptResult result = session->RunScript(line, "input");
    if (result.quit) break;
    exit_code = result.ok ? 0 : 1;  // the last command's outcome
  }
  g_completion_session = nullptr;
  (void)exit_code;
  return 0;  // an interactive session that ends normally succeeded
}

}  // namespace

int RunConsoleCommand(const std::vector<std::string>& args, std::ostream& out,
                      std::ostream& err) {
  std::vector<std::string> map_folders;
  std::string script_file, inline_commands, flagfile;
  std::string history_path = HistoryPath();
  std::map<std::string, std::string> variables;
  bool have_script = false, have_inline = false, progress_bar = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&](const char* name) -> std::string {
      const std::size_t eq = a.find('=');
      if (eq != std::string::npos && a.rfind("--", 0) == 0) return a.substr(eq + 1);
      if (i + 1 >= args.size()) throw std::invalid_argument(std::string(name) + ": expected a value");
      return args[++i];
    };
    try {
      if (a == "--help" || a == "-h") {
        PrintUsage(out);
        return 0;
      } else if (a == "--script" || a.rfind("--script=", 0) == 0) {
        script_file = value("--script");
        have_script = true;
      } else if (a == "-c") {
        inline_commands = value("-c");
        have_inline = true;
      } else if (a == "--flagfile" || a.rfind("--flagfile=", 0) == 0) {
        flagfile = value("--flagfile");
      } else if (a == "--history" || a.rfind("--history=", 0) == 0) {
        history_path = value("--history");
      } else if (a == "--var" || a.rfind("--var=", 0) == 0) {
        const std::string v = value("--var");
        const std::size_t eq = v.find('=');
        if (eq == std::string::npos || eq == 0) {
          throw std::invalid_argument("--var: expected NAME=VALUE, got '" + v + "'");
        }
        variables[v.substr(0, eq)] = v.substr(eq + 1);
      } else if (a == "--no-history") {
        history_path.clear();
      } else if (a == "--progress-bar") {
        progress_bar = true;
      } else if (a.rfind("-", 0) == 0) {
        throw std::invalid_argument("unknown option " + a);
      } else {
        map_folders.push_back(a);
      }
    } catch (const std::invalid_argument& e) {
      err << "vilma console: " << e.what() << " (see --help)\n";
      return 2;
    }
  }
  if (have_script && have_inline) {
    err << "vilma console: --script and -c exclude each other\n";
    return 2;
  }
  const bool interactive = !have_script && !have_inline && isatty(STDIN_FILENO);
  SessionOptions options;
  options.echo_commands = !interactive;
  options.terminal_progress = progress_bar || isatty(STDOUT_FILENO);
  InstallSigintHandler();
  ConsoleSession session(CommandRegistry::WithPlugins(), out, err, options, &g_cancel_requested);
  try {
    if (!flagfile.empty()) session.LoadFlagFile(flagfile);
  } catch (const CommandError& e) {
    err << "vilma console: " << e.what() << "\n";
    return 2;
  }
  for (const std::string& folder : map_folders) {
    const CommandResult r = session.Execute("load --map_folder '" + folder + "'");
    if (!r.ok()) {
      err << "vilma console: could not load " << folder << "\n";
      return 1;
    }
  }
  if (interactive) return RunRepl(&session, history_path, out);

  std::string text, source = "-c";
  if (have_script) {
    std::ifstream in(script_file);
    if (!in) {
      err << "vilma console: " << script_file << ": expected a readable script file\n";
      return 2;
    }
    std::stringstream buffer;
    buffer << in.rdbuf();
    text = buffer.str();
    source = script_file;
  } else if (have_inline) {
    text = inline_commands;
  } else {
    std::stringstream buffer;
    buffer << std::cin.rdbuf();
    text = buffer.str();
    source = "stdin";
  }
  try {
    text = ExpandVariables(text, variables);
  } catch (const CommandError& e) {
    err << "vilma console: " << source << ": " << e.what() << "\n";
    return 2;
  }
  const auto start = std::chrono::steady_clock::now();
  const ScriptResult result = session.RunScript(text, source);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!result.ok) {
    const bool interrupted = g_cancel_requested.load();
    err << "vilma console: " << (interrupted ? "cancelled" : "failed") << " at "
        << result.source_line << ": " << result.failed_command << "\n";
    return interrupted ? 130 : 1;
  }
  out << "vilma console: " << result.commands_run << " commands ok in " << std::fixed
      << std::setprecision(2) << seconds << " s\n";
  return 0;
}

}  // namespace vilma::console

// The console's command registry (architecture.md section 10, docs/console.md): every command is
// a name with aliases, typed flags bound to the fields of an options struct, the kind of access
// it needs to the selected map, and a function. Plugins (console/plugins/<family>/*.cpp) add
// their commands with VILMA_CONSOLE_COMMANDS; the console core knows no algorithm.
//
// A command file reads:
//
//   void Register(CommandRegistry* registry) {
//     registry->Add(Command<mapping::KeyframingOptions>("keyframe_heuristic")
//         .Alias("kfh")
//         .Group("keyframing")
//         .Summary("keep keyframes by distance, rotation, every n-th vertex, shared landmarks")
//         .Access(MapAccess::kModify)
//         .Flag("kf_distance_threshold_m", &mapping::KeyframingOptions::kf_distance_threshold_m,
//               "a vertex is kept when this far from the last keyframe [m]")
//         .Run([](CommandContext& context, const mapping::KeyframingOptions& options) {
//           const auto summary = mapping::KeyframeHeuristic(options, &context.map(),
//                                                            context.progress());
//           context.out() << summary.BriefReport() << "\n";
//         }));
//   }
//   VILMA_CONSOLE_COMMANDS(Register)
//
// Flag values come, in this order of precedence, from the command line (`--name=value`, or
// `--name value`, a bare `--name` for booleans), the session (`set NAME VALUE`, `--flagfile`),
// and the options struct's in-class default. The options are checked with their Validate()
// (when the struct has one) before the command runs.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "vilma/console/flag_value.h"
#include "vilma/console/map_store.h"
#include "vilma/core/progress.h"

namespace vilma::console {

// What a command does with the selected map.
enum class MapAccess {
  kNone,    // does not use a map (or manages the store itself: load, delete, join, ...)
  kRead,    // reads the selected map
  kModify,  // changes the selected map: runs on a copy that replaces it on success, so that a
            // failure or Ctrl-C leaves the loaded map as it was ("rolls back" in help)
};

// A user-facing failure of a command (bad argument, nothing to do, refused operation). The
// runner prints "COMMAND: error: MESSAGE" and stops a batch.
class CommandError : public std::runtime_error {
 public:
  explicit CommandError(const std::string& message) : std::runtime_error(message) {}
};

// Thrown by the `quit` command to end the session (not an error).
class QuitRequested : public std::exception {};

// Help of the usual --mission / --map_mission flag (mapping::ResolveMissions reads its value).
inline constexpr const char* kMissionListHelp =
    "missions (ids, unique id prefixes or names, comma separated; default: all)";

struct FlagSpec {
  std::string name;                  // without "--"
  std::vector<std::string> aliases;  // maplab's names for the same flag
  FlagType type = FlagType::kString;
  std::string default_text;          // the options struct's default, as text
  std::string help;
};

class ConsoleSession;

// What a running command sees.
class CommandContext {
 public:
  CommandContext(ConsoleSession* session, std::string command_name,
                 std::vector<std::string> positional, mapstore::VIMap* map, std::string map_key,
                 ProgressObserver* progress, std::ostream* out);

  // The map store (all loaded maps); commands with MapAccess::kNone that manage maps use it.
  MapStore& maps();
  // The selected map (for kModify: the working copy). CommandError when none is selected.
  mapstore::VIMap& map();
  const std::string& map_key() const { return map_key_; }
  // Words of the command line that are not flags, after the ones bound with Positional().
  const std::vector<std::string>& positional() const { return positional_; }
  // Progress bar and Ctrl-C: pass to library calls, or call ReportProgress at safe points.
  ProgressObserver* progress() const { return progress_; }
  std::ostream& out() { return *out_; }
  ConsoleSession& session() { return *session_; }
  const std::string& command_name() const { return command_name_; }

 private:
  ConsoleSession* session_;
  std::string command_name_;
  std::vector<std::string> positional_;
  mapstore::VIMap* map_;
  std::string map_key_;
  ProgressObserver* progress_;
  std::ostream* out_;
};

// A registered command, type-erased.
struct CommandSpec {
  std::string name;
  std::vector<std::string> aliases;
  std::string group = "other";  // help sections: "maps", "inspection", "keyframing", ...
  std::string summary;          // one line
  std::string usage;            // positional part, e.g. "[MISSION_ID]"
  MapAccess access = MapAccess::kNone;
  std::vector<FlagSpec> flags;
  // Flags that the first positional words fill, in order (e.g. load's map_folder).
  std::vector<std::string> positional_flags;
  // Every word is positional, "--x=y" included (for `set --name=value`).
  bool raw_words = false;
  // Runs with the flag values given on the command line or by the session, by flag name
  // (already type-checked); flags that are absent take the options struct's default.
  std::function<void(CommandContext&, const std::map<std::string, std::string>&)> run;

  const FlagSpec* FindFlag(const std::string& name_or_alias) const;
  bool Matches(const std::string& name_or_alias) const;
};

// Builds a CommandSpec for commands whose flags fill the fields of `Options` (a plain options
// struct with in-class defaults and, optionally, `std::string Validate() const`).
template <typename Options>
class Command {
 public:
  explicit Command(std::string name) { spec_.name = std::move(name); }

  Command& Alias(std::string alias) {
    spec_.aliases.push_back(std::move(alias));
    return *this;
  }
  Command& Group(std::string group) {
    spec_.group = std::move(group);
    return *this;
  }
  Command& Summary(std::string summary) {
    spec_.summary = std::move(summary);
    return *this;
  }
  Command& Usage(std::string usage) {
    spec_.usage = std::move(usage);
    return *this;
  }
  Command& Access(MapAccess access) {
    spec_.access = access;
    return *this;
  }
  // The next positional word fills this flag (declared with Flag before or after).
  Command& Positional(std::string flag_name) {
    spec_.positional_flags.push_back(std::move(flag_name));
    return *this;
  }

  // Words starting with "--" are not this command's flags but positional words.
  Command& RawWords() {
    spec_.raw_words = true;
    return *this;
  }

  // A flag bound to a field: `--name=value` parses as the field's type (bool, int, int64,
  // uint32, uint64, double, std::string) into it. The field may belong to a base of Options
  // (a command's options that extend an algorithm's options struct).
  template <typename T, typename Base,
            typename = std::enable_if_t<std::is_base_of_v<Base, Options>>>
  Command& Flag(const std::string& name, T Base::*field, const std::string& help,
                std::vector<std::string> aliases = {}) {
    return FlagAt(
        name, [field](Options& o) -> T& { return static_cast<Base&>(o).*field; }, help,
        std::move(aliases));
  }
  // A flag bound to a field reached through `access` (for nested options):
  //   .FlagAt("ba_num_iterations", [](Options& o) -> int& { return o.solver.max_iterations; }, ...)
  template <typename Accessor>
  Command& FlagAt(const std::string& name, Accessor access, const std::string& help,
                  std::vector<std::string> aliases = {}) {
    using T = std::remove_reference_t<decltype(access(std::declval<Options&>()))>;
    FlagSpec flag;
    flag.name = name;
    flag.aliases = std::move(aliases);
    flag.type = FlagTraits<T>::kType;
    // Value-initialized with `Options()`: `Options defaults{};` (aggregate initialization of an
    // options struct with a base) gave GCC 12 a false -Wmaybe-uninitialized.
    Options defaults = Options();
    flag.default_text = FlagTraits<T>::Format(access(defaults));
    flag.help = help;
    spec_.flags.push_back(flag);
    setters_.emplace_back(name, [access](Options& o, const std::string& text) {
      access(o) = FlagTraits<T>::Parse(text);
    });
    return *this;
  }
  // A path flag (completed as a path in the interactive console).
  template <typename Base, typename = std::enable_if_t<std::is_base_of_v<Base, Options>>>
  Command& PathFlag(const std::string& name, std::string Base::*field, const std::string& help,
                    std::vector<std::string> aliases = {}) {
    Flag(name, field, help, std::move(aliases));
    spec_.flags.back().type = FlagType::kPath;
    return *this;
  }

  // The command's function; builds the options from defaults and flag values, validates them.
  Command& Run(std::function<void(CommandContext&, const Options&)> function) {
    auto setters = setters_;
    spec_.run = [setters, function](CommandContext& context,
                                    const std::map<std::string, std::string>& values) {
      Options options{};
      for (const auto& [name, set] : setters) {
        auto value = values.find(name);
        if (value != values.end()) set(options, value->second);
      }
      if constexpr (HasValidate<Options>::value) {
        const std::string problem = options.Validate();
        if (!problem.empty()) throw CommandError("invalid options: " + problem);
      }
      function(context, options);
    };
    return *this;
  }

  const CommandSpec& spec() const { return spec_; }

 private:
  template <typename O, typename = void>
  struct HasValidate : std::false_type {};
  template <typename O>
  struct HasValidate<O, std::void_t<decltype(std::declval<const O&>().Validate())>>
      : std::true_type {};

  CommandSpec spec_;
  std::vector<std::pair<std::string, std::function<void(Options&, const std::string&)>>> setters_;
};

// For commands without options.
struct NoOptions {};

class CommandRegistry {
 public:
  // Throws std::logic_error when the name or an alias is taken (a programming error).
  template <typename Options>
  void Add(const Command<Options>& command) {
    AddSpec(command.spec());
  }
  void AddSpec(CommandSpec spec);

  // By name or alias; nullptr if unknown.
  const CommandSpec* Find(const std::string& name_or_alias) const;
  // All commands sorted by group, then name.
  std::vector<const CommandSpec*> All() const;
  // Names and aliases (for completion and "did you mean").
  std::vector<std::string> Names() const;

  // A registry with every plugin's commands (those registered with VILMA_CONSOLE_COMMANDS
  // in the objects linked into the program).
  static CommandRegistry WithPlugins();

 private:
  std::vector<CommandSpec> commands_;
};

using RegisterCommandsFunction = void (*)(CommandRegistry*);

// Adds a plugin's registration function to the list WithPlugins() calls. The only process-wide
// state of the console: an append-only list of function pointers filled during static
// initialization (before main); it holds no command state.
bool AddPluginRegistration(RegisterCommandsFunction function);

}  // namespace vilma::console

#define VILMA_CONSOLE_CONCAT_INNER(a, b) a##b
#define VILMA_CONSOLE_CONCAT(a, b) VILMA_CONSOLE_CONCAT_INNER(a, b)
// In a plugin's .cpp file (at namespace scope): registers `function` (void(CommandRegistry*)).
#define VILMA_CONSOLE_COMMANDS(function)                                          \
  namespace {                                                                     \
  const bool VILMA_CONSOLE_CONCAT(vilma_console_registered_, __LINE__) =          \
      ::vilma::console::AddPluginRegistration(&function);                         \
  }

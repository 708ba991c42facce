#include "vilma/console/command_registry.h"

#include <algorithm>
#include <stdexcept>

#include "vilma/console/session.h"

namespace vilma::console {

namespace {
std::vector<RegisterCommandsFunction>& PluginRegistrations() {
  static std::vector<RegisterCommandsFunction> functions;
  return functions;
}
}  // namespace

bool AddPluginRegistration(RegisterCommandsFunction function) {
  PluginRegistrations().push_back(function);
  return true;
}

const FlagSpec* CommandSpec::FindFlag(const std::string& name_or_alias) const {
  for (const FlagSpec& flag : flags) {
    if (flag.name == name_or_alias) return &flag;
  }
  for (const FlagSpec& flag : flags) {
    for (const std::string& alias : flag.aliases) {
      if (alias == name_or_alias) return &flag;
    }
  }
  return nullptr;
}

bool CommandSpec::Matches(const std::string& name_or_alias) const {
  return name == name_or_alias ||
         std::find(aliases.begin(), aliases.end(), name_or_alias) != aliases.end();
}

void CommandRegistry::AddSpec(CommandSpec spec) {
  if (!spec.run) throw std::logic_error("console command '" + spec.name + "' has no Run()");
  std::vector<std::string> names = spec.aliases;
  names.push_back(spec.name);
  for (const std::string& name : names) {
    if (Find(name) != nullptr) {
      throw std::logic_error("console command name '" + name + "' registered twice");
    }
  }
  for (const std::string& flag : spec.positional_flags) {
    if (spec.FindFlag(flag) == nullptr) {
      throw std::logic_error("console command '" + spec.name + "': positional flag '" + flag +
                             "' is not a flag");
    }
  }
  commands_.push_back(std::move(spec));
}

const CommandSpec* CommandRegistry::Find(const std::string& name_or_alias) const {
  for (const CommandSpec& command : commands_) {
    if (command.Matches(name_or_alias)) return &command;
  }
  return nullptr;
}

std::vector<const CommandSpec*> CommandRegistry::All() const {
  std::vector<const CommandSpec*> all;
  for (const CommandSpec& command : commands_) all.push_back(&command);
  std::sort(all.begin(), all.end(), [](const CommandSpec* a, const CommandSpec* b) {
    return a->group != b->group ? a->group < b->group : a->name < b->name;
  });
  return all;
}

std::vector<std::string> CommandRegistry::Names() const {
  std::vector<std::string> names;
  for (const CommandSpec& command : commands_) {
    names.push_back(command.name);
    names.insert(names.end(), command.aliases.begin(), command.aliases.end());
  }
  std::sort(names.begin(), names.end());
  return names;
}

CommandRegistry CommandRegistry::WithPlugins() {
  CommandRegistry registry;
  // Registration order does not matter (All() sorts); it is link order.
  for (RegisterCommandsFunction function : PluginRegistrations()) function(&registry);
  return registry;
}

CommandContext::CommandContext(ConsoleSession* session, std::string command_name,
                               std::vector<std::string> positional, mapstore::VIMap* map,
                               std::string map_key, ProgressObserver* progress,
                               std::ostream* out)
    : session_(session),
      command_name_(std::move(command_name)),
      positional_(std::move(positional)),
      map_(map),
      map_key_(std::move(map_key)),
      progress_(progress),
      out_(out) {}

MapStore& CommandContext::maps() { return session_->maps(); }

mapstore::VIMap& CommandContext::map() {
  if (map_ == nullptr) throw CommandError("no map selected (load one first: load --map_folder DIR)");
  return *map_;
}

}  // namespace vilma::console

// The console's own commands: help, set, unset, flags, source, quit. Map and algorithm commands
// are plugins (console/plugins/).
#include <algorithm>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "vilma/console/session.h"
#include "vilma/core/error.h"

namespace vilma::console {
namespace {

std::string AccessText(MapAccess access) {
  switch (access) {
    case MapAccess::kNone: return "";
    case MapAccess::kRead: return "reads the selected map";
    case MapAccess::kModify:
      return "modifies the selected map; rolls back (the map stays as it was) on failure or "
             "Ctrl-C";
  }
  return "";
}

void PrintCommandHelp(const CommandSpec& c, const ConsoleSession& session, std::ostream& out) {
  out << c.name;
  for (const std::string& a : c.aliases) out << ", " << a;
  out << "\n  " << c.summary << "\n";
  out << "  usage: " << c.name;
  for (const std::string& p : c.positional_flags) out << " [" << p << "]";
  if (!c.usage.empty()) out << " " << c.usage;
  if (!c.flags.empty()) out << " [--flag=value ...]";
  out << "\n";
  const std::string access = AccessText(c.access);
  if (!access.empty()) out << "  " << access << "\n";
  if (c.flags.empty()) return;
  out << "  flags:\n";
  for (const FlagSpec& f : c.flags) {
    std::string names = "--" + f.name;
    for (const std::string& a : f.aliases) names += ", --" + a;
    out << "    " << names << " (" << FlagTypeName(f.type) << ", default "
        << (f.default_text.empty() ? "\"\"" : f.default_text);
    auto set = session.defaults().find(f.name);
    if (set != session.defaults().end()) out << ", set to " << set->second;
    out << ")\n      " << f.help << "\n";
  }
}

void PrintCommandList(const CommandRegistry& registry, std::ostream& out) {
  std::string group;
  for (const CommandSpec* c : registry.All()) {
    if (c->group != group) {
      group = c->group;
      out << "\n" << group << ":\n";
    }
    std::string names = c->name;
    for (const std::string& a : c->aliases) names += ", " + a;
    out << "  " << std::left << std::setw(40) << names << " " << c->summary
        << (c->access == MapAccess::kModify ? " [rolls back]" : "") << "\n";
  }
  out << "\n`help COMMAND` shows a command's flags and defaults; [rolls back]: a failure or\n"
         "Ctrl-C leaves the map as it was. Flags: --name=value (or --name value); `set NAME\n"
         "VALUE` changes a default for the rest of the session.\n";
}

struct HelpOptions {
  std::string command;
};
struct SetOptions {
  std::string name;
  std::string value;
};
struct SourceOptions {
  std::string file;
};

}  // namespace

void ConsoleSession::RegisterBuiltins() {
  registry_.Add(Command<HelpOptions>("help")
                    .Alias("h")
                    .Group("console")
                    .Summary("list the commands, or show one command's flags and defaults")
                    .Flag("command", &HelpOptions::command, "command to describe")
                    .Positional("command")
                    .Run([](CommandContext& context, const HelpOptions& o) {
                      const CommandRegistry& registry = context.session().registry();
                      if (o.command.empty()) {
                        PrintCommandList(registry, context.out());
                        return;
                      }
                      const CommandSpec* c = registry.Find(o.command);
                      if (c == nullptr) {
                        throw CommandError("unknown command '" + o.command + "'");
                      }
                      PrintCommandHelp(*c, context.session(), context.out());
                    }));
  registry_.Add(Command<NoOptions>("set")
                    .Group("console")
                    .Summary("set a flag's default for the rest of the session: set NAME VALUE "
                             "or set --NAME=VALUE")
                    .Usage("NAME VALUE")
                    .RawWords()
                    .Run([](CommandContext& context, const NoOptions&) {
                      const auto& words = context.positional();
                      if (words.empty() || words.size() > 2) {
                        throw CommandError("usage: set NAME VALUE");
                      }
                      std::string name = words[0];
                      std::string value = words.size() > 1 ? words[1] : "";
                      if (name.rfind("--", 0) == 0) name = name.substr(2);
                      const std::size_t eq = name.find('=');
                      if (eq != std::string::npos) {  // set --name=value
                        if (words.size() > 1) throw CommandError("usage: set NAME VALUE");
                        value = name.substr(eq + 1);
                        name.resize(eq);
                      } else if (words.size() < 2) {
                        throw CommandError("usage: set NAME VALUE");
                      }
                      context.session().SetDefault(name, value);
                      context.out() << "--" << name << "=" << value << " for this session\n";
                    }));
  registry_.Add(Command<SetOptions>("unset")
                    .Group("console")
                    .Summary("drop a session default set with `set`")
                    .Flag("name", &SetOptions::name, "flag name (without --)")
                    .Positional("name")
                    .Run([](CommandContext& context, const SetOptions& o) {
                      if (o.name.empty()) throw CommandError("usage: unset NAME");
                      context.session().UnsetDefault(o.name);
                    }));
  registry_.Add(Command<NoOptions>("flags")
                    .Group("console")
                    .Summary("list the session's flag defaults (from set and --flagfile)")
                    .Run([](CommandContext& context, const NoOptions&) {
                      if (context.session().defaults().empty()) {
                        context.out() << "no session defaults\n";
                      }
                      for (const auto& [name, value] : context.session().defaults()) {
                        context.out() << "--" << name << "=" << value << "\n";
                      }
                    }));
  registry_.Add(Command<SourceOptions>("source")
                    .Group("console")
                    .Summary("run the commands of a script file (stops at the first failure)")
                    .Flag("file", &SourceOptions::file, "script file")
                    .Positional("file")
                    .Run([](CommandContext& context, const SourceOptions& o) {
                      std::ifstream in(o.file);
                      if (!in) throw CommandError(FormatInputError(o.file, "", "a readable script"));
                      std::stringstream text;
                      text << in.rdbuf();
                      const ScriptResult r = context.session().RunScript(text.str(), o.file);
                      if (r.quit) throw QuitRequested();
                      if (!r.ok) {
                        throw CommandError("stopped at " + r.source_line + ": " + r.failed_command);
                      }
                    }));
  registry_.Add(Command<NoOptions>("quit")
                    .Alias("exit")
                    .Alias("q")
                    .Group("console")
                    .Summary("leave the console (unsaved changes are lost)")
                    .Run([](CommandContext&, const NoOptions&) { throw QuitRequested(); }));
}

}  // namespace vilma::console

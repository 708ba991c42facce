#include "vilma/console/session.h"

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "console_progress.h"
#include "vilma/core/error.h"
#include "vilma/core/timing.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::console {

// ------------------------------------------------------------------ words and scripts

std::vector<std::string> SplitWords(const std::string& line) {
  std::vector<std::string> words;
  std::string word;
  bool in_word = false;
  char quote = 0;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quote != 0) {
      if (c == quote) {
        quote = 0;
      } else if (c == '\\' && quote == '"' && i + 1 < line.size()) {
        word += line[++i];
      } else {
        word += c;
      }
      continue;
    }
    if (c == '\'' || c == '"') {
      quote = c;
      in_word = true;
    } else if (c == '\\' && i + 1 < line.size()) {
      word += line[++i];
      in_word = true;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      if (in_word) words.push_back(word);
      word.clear();
      in_word = false;
    } else {
      word += c;
      in_word = true;
    }
  }
  if (quote != 0) throw CommandError(std::string("unterminated ") + quote + " quote");
  if (in_word) words.push_back(word);
  return words;
}

std::vector<std::pair<int, std::string>> SplitScript(const std::string& text) {
  std::vector<std::pair<int, std::string>> commands;
  int line_number = 1;
  std::string current;
  char quote = 0;
  bool comment = false;
  auto flush = [&] {
    const auto first = current.find_first_not_of(" \t\r");
    if (first != std::string::npos) {
      const auto last = current.find_last_not_of(" \t\r");
      commands.emplace_back(line_number, current.substr(first, last - first + 1));
    }
    current.clear();
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      if (quote == 0 || true) {  // a quote never spans lines
        quote = 0;
        flush();
        comment = false;
        ++line_number;
      }
      continue;
    }
    if (comment) continue;
    if (quote != 0) {
      if (c == quote) quote = 0;
      if (c == '\\' && i + 1 < text.size() && text[i + 1] != '\n') current += text[i++];
      current += c;
      continue;
    }
    if (c == '\\' && i + 1 < text.size() && text[i + 1] != '\n') {
      current += c;
      current += text[++i];
    } else if (c == '\'' || c == '"') {
      quote = c;
      current += c;
    } else if (c == '#' && (current.empty() || std::isspace(static_cast<unsigned char>(current.back())))) {
      comment = true;
    } else if (c == ';') {
      flush();
    } else {
      current += c;
    }
  }
  flush();
  return commands;
}

namespace {

std::size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1] ? 1u : 0u)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

std::string Join(const std::vector<std::string>& words, const std::string& separator) {
  std::string joined;
  for (const std::string& w : words) joined += (joined.empty() ? "" : separator) + w;
  return joined;
}

std::string ReadTextFile(const std::string& path, const char* what) {
  std::ifstream in(path);
  if (!in) throw CommandError(FormatInputError(path, "", std::string("a readable ") + what));
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace

std::string ExpandVariables(const std::string& text,
                            const std::map<std::string, std::string>& variables) {
  std::string out;
  int line = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') ++line;
    if (c != '$' || i + 1 >= text.size()) {
      out += c;
      continue;
    }
    if (text[i + 1] == '$') {
      out += '$';
      ++i;
      continue;
    }
    if (text[i + 1] != '{') {
      out += c;
      continue;
    }
    const std::size_t close = text.find('}', i + 2);
    const std::size_t newline = text.find('\n', i + 2);
    if (close == std::string::npos || (newline != std::string::npos && newline < close)) {
      throw CommandError("line " + std::to_string(line) + ": unterminated ${");
    }
    const std::string name = text.substr(i + 2, close - i - 2);
    auto value = variables.find(name);
    if (value == variables.end()) {
      throw CommandError("line " + std::to_string(line) + ": ${" + name +
                         "} is not defined (vilma console --var " + name + "=VALUE)");
    }
    out += value->second;
    i = close;
  }
  return out;
}

std::vector<std::string> SimilarNames(const std::string& word,
                                      const std::vector<std::string>& candidates) {
  std::vector<std::string> similar;
  for (const std::string& c : candidates) {
    const bool prefix = word.size() >= 2 && c.rfind(word, 0) == 0;
    if (prefix || EditDistance(word, c) <= 2) similar.push_back(c);
  }
  if (similar.size() > 6) similar.resize(6);
  return similar;
}

// ------------------------------------------------------------------ session

ConsoleSession::ConsoleSession(CommandRegistry registry, std::ostream& out, std::ostream& err,
                               SessionOptions options, std::atomic<bool>* cancel_flag)
    : registry_(std::move(registry)),
      out_(out),
      err_(err),
      options_(options),
      cancel_flag_(cancel_flag) {
  RegisterBuiltins();
}

void ConsoleSession::SetDefault(const std::string& flag, const std::string& value) {
  std::string canonical;
  for (const CommandSpec* command : registry_.All()) {
    const FlagSpec* spec = command->FindFlag(flag);
    if (spec == nullptr) continue;
    try {
      CheckFlagValue(spec->type, value);
    } catch (const std::invalid_argument& e) {
      throw CommandError("--" + flag + ": expected " + e.what() + " (flag of " + command->name +
                         "), got '" + value + "'");
    }
    canonical = spec->name;
  }
  if (canonical.empty()) {
    std::vector<std::string> all_flags;
    for (const CommandSpec* command : registry_.All()) {
      for (const FlagSpec& f : command->flags) all_flags.push_back(f.name);
    }
    const auto similar = SimilarNames(flag, all_flags);
    throw CommandError("no command has a flag --" + flag +
                       (similar.empty() ? "" : " (did you mean --" + Join(similar, ", --") + "?)"));
  }
  defaults_[canonical] = value;
}

void ConsoleSession::UnsetDefault(const std::string& flag) {
  for (const CommandSpec* command : registry_.All()) {
    if (const FlagSpec* spec = command->FindFlag(flag)) {
      defaults_.erase(spec->name);
      return;
    }
  }
  throw CommandError("no command has a flag --" + flag);
}

void ConsoleSession::LoadFlagFile(const std::string& path) {
  const std::string text = ReadTextFile(path, "flag file");
  std::istringstream lines(text);
  std::string line;
  for (int number = 1; std::getline(lines, line); ++number) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t\r");
    const std::string entry = line.substr(first, last - first + 1);
    const std::size_t eq = entry.find('=');
    if (entry.rfind("--", 0) != 0 || eq == std::string::npos) {
      throw CommandError(path + ":" + std::to_string(number) + ": expected --name=value, got '" +
                         entry + "'");
    }
    try {
      SetDefault(entry.substr(2, eq - 2), entry.substr(eq + 1));
    } catch (const CommandError& e) {
      throw CommandError(path + ":" + std::to_string(number) + ": " + e.what());
    }
  }
}

CommandResult ConsoleSession::Execute(const std::string& line) {
  CommandResult result;
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::string> words;
  try {
    words = SplitWords(line);
  } catch (const CommandError& e) {
    result.outcome = CommandOutcome::kFailed;
    result.message = e.what();
    err_ << "error: " << e.what() << "\n";
    return result;
  }
  if (words.empty()) return result;
  result.command = words[0];
  if (options_.echo_commands) out_ << "> " << line << std::endl;
  const CommandSpec* spec = registry_.Find(words[0]);
  if (spec == nullptr) {
    const auto similar = SimilarNames(words[0], registry_.Names());
    result.outcome = CommandOutcome::kFailed;
    result.message = "unknown command '" + words[0] + "'" +
                     (similar.empty() ? "" : " (did you mean: " + Join(similar, ", ") + "?)") +
                     "; `help` lists the commands";
    err_ << result.message << "\n";
    return result;
  }
  RunCommand(*spec, words, &result);
  result.seconds = MsSince(start) / 1000.0;
  if (options_.echo_commands && result.outcome != CommandOutcome::kQuit) {
    out_ << "  (" << words[0] << ": " << std::fixed << std::setprecision(2) << result.seconds
         << " s" << (result.outcome == CommandOutcome::kOk ? "" : ", failed") << ")"
         << std::defaultfloat << std::endl;
  }
  return result;
}

void ConsoleSession::RunCommand(const CommandSpec& spec, const std::vector<std::string>& words,
                                CommandResult* result) {
  const std::string& name = words[0];
  auto fail = [&](const std::string& message) {
    result->outcome = CommandOutcome::kFailed;
    result->message = message;
    err_ << name << ": error: " << message << "\n";
  };

  // Flags: session defaults first, then the command line (which wins).
  std::map<std::string, std::string> values;
  for (const FlagSpec& flag : spec.flags) {
    auto d = defaults_.find(flag.name);
    if (d != defaults_.end()) values[flag.name] = d->second;
  }
  std::vector<std::string> positional;
  std::map<std::string, std::string> given;
  try {
    auto set_flag = [&](const std::string& flag_name, const std::string& value,
                        bool has_value) {
      const FlagSpec* flag = spec.FindFlag(flag_name);
      if (flag == nullptr) {
        std::vector<std::string> names;
        for (const FlagSpec& f : spec.flags) names.push_back(f.name);
        const auto similar = SimilarNames(flag_name, names);
        throw CommandError(
            "unknown flag --" + flag_name +
            (similar.empty() ? "" : " (did you mean --" + Join(similar, ", --") + "?)") +
            (names.empty() ? "; the command takes no flags" : "; `help " + spec.name + "` lists its flags"));
      }
      std::string text = value;
      if (!has_value) {
        if (flag->type != FlagType::kBool) {
          throw CommandError("--" + flag_name + ": expected a value (" +
                             FlagTypeExpectation(flag->type) + ")");
        }
        text = "true";
      }
      try {
        CheckFlagValue(flag->type, text);
      } catch (const std::invalid_argument& e) {
        throw CommandError("--" + flag_name + ": expected " + e.what() + ", got '" + text + "'");
      }
      given[flag->name] = text;
    };
    for (std::size_t i = 1; i < words.size(); ++i) {
      const std::string& w = words[i];
      if (spec.raw_words || w.rfind("--", 0) != 0 || w.size() == 2) {
        positional.push_back(w);
        continue;
      }
      const std::size_t eq = w.find('=');
      const std::string flag_name = w.substr(2, eq == std::string::npos ? std::string::npos : eq - 2);
      if (flag_name == "flagfile") {  // per command: its lines apply to this command only
        const std::string path =
            eq != std::string::npos ? w.substr(eq + 1) : (i + 1 < words.size() ? words[++i] : "");
        if (path.empty()) throw CommandError("--flagfile: expected a file");
        std::istringstream lines(ReadTextFile(path, "flag file"));
        std::string entry;
        for (int number = 1; std::getline(lines, entry); ++number) {
          const auto first = entry.find_first_not_of(" \t\r");
          if (first == std::string::npos || entry[first] == '#') continue;
          entry = entry.substr(first, entry.find_last_not_of(" \t\r") - first + 1);
          const std::size_t e = entry.find('=');
          if (entry.rfind("--", 0) != 0) {
            throw CommandError(path + ":" + std::to_string(number) + ": expected --name=value");
          }
          try {
            set_flag(entry.substr(2, e == std::string::npos ? std::string::npos : e - 2),
                     e == std::string::npos ? "" : entry.substr(e + 1), e != std::string::npos);
          } catch (const CommandError& error) {
            throw CommandError(path + ":" + std::to_string(number) + ": " + error.what());
          }
        }
        continue;
      }
      if (eq != std::string::npos) {
        set_flag(flag_name, w.substr(eq + 1), true);
        continue;
      }
      const FlagSpec* flag = spec.FindFlag(flag_name);
      const bool takes_value = flag != nullptr && flag->type != FlagType::kBool;
      if (takes_value && i + 1 < words.size()) {
        set_flag(flag_name, words[++i], true);
      } else {
        set_flag(flag_name, "", false);
      }
    }
    // Positional words fill the declared positional flags not given by name.
    std::vector<std::string> rest;
    std::size_t next_positional = 0;
    for (const std::string& p : positional) {
      while (next_positional < spec.positional_flags.size() &&
             given.count(spec.positional_flags[next_positional]) > 0) {
        ++next_positional;
      }
      if (next_positional < spec.positional_flags.size()) {
        const std::string& flag_name = spec.positional_flags[next_positional++];
        set_flag(flag_name, p, true);
      } else {
        rest.push_back(p);
      }
    }
    positional = rest;
  } catch (const CommandError& e) {
    fail(e.what());
    return;
  }
  for (const auto& [flag, value] : given) values[flag] = value;

  // The map the command works on.
  std::string key;
  mapstore::VIMap* map = nullptr;
  mapstore::VIMap working_copy;
  if (spec.access != MapAccess::kNone) {
    key = maps_.selected();
    if (key.empty()) {
      fail("no map selected (load one first: load --map_folder DIR)");
      return;
    }
    map = maps_.Get(key).map.get();
    if (spec.access == MapAccess::kModify) {
      working_copy = map->Clone();
      map = &working_copy;
    }
  }

  if (cancel_flag_ != nullptr) cancel_flag_->store(false);
  ConsoleProgress progress(out_, options_.terminal_progress, cancel_flag_);
  CommandContext context(this, name, positional, map, key, &progress, &out_);
  try {
    spec.run(context, values);
    progress.Finish();
  } catch (const Cancelled&) {
    progress.Finish();
    result->outcome = CommandOutcome::kCancelled;
    result->message = "cancelled";
    err_ << name << ": cancelled"
         << (spec.access == MapAccess::kModify ? " (the map is unchanged)" : "") << "\n";
    return;
  } catch (const QuitRequested&) {
    result->outcome = CommandOutcome::kQuit;
    return;
  } catch (const CommandError& e) {
    progress.Finish();
    fail(e.what());
    return;
  } catch (const InputError& e) {
    progress.Finish();
    fail(e.what());
    return;
  } catch (const std::exception& e) {  // a library's invalid_argument, out_of_range, ...
    progress.Finish();
    fail(e.what());
    return;
  }
  if (spec.access == MapAccess::kModify) {
    if (options_.verify_modifications) {
      const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(working_copy);
      if (!report.ok()) {
        fail("the result is not a consistent map, so it was not applied (the map is unchanged):\n" +
             report.FullReport());
        return;
      }
    }
    maps_.Replace(key, std::move(working_copy));
  }
}

ScriptResult ConsoleSession::RunScript(const std::string& text, const std::string& source_name) {
  ScriptResult script;
  std::vector<std::pair<int, std::string>> commands;
  commands = SplitScript(text);
  for (const auto& [line, command] : commands) {
    const CommandResult result = Execute(command);
    ++script.commands_run;
    if (result.outcome == CommandOutcome::kQuit) {
      script.quit = true;
      return script;
    }
    if (!result.ok()) {
      script.ok = false;
      script.failed_command = command;
      script.source_line = source_name + ":" + std::to_string(line);
      return script;
    }
  }
  return script;
}

}  // namespace vilma::console

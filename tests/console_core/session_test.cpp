// The console core: registry, typed flags bound to options, session defaults and flag files,
// scripts, rollback of modifying commands on failure and on cancel, completion.
#include <catch2/catch.hpp>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "vilma/console/completion.h"
#include "vilma/console/session.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::console {
namespace {

struct TestOptions {
  int count = 3;
  double ratio = 0.5;
  bool verbose = false;
  std::string name = "x";
  std::string folder;
  std::string Validate() const { return count < 0 ? "count: expected >= 0" : ""; }
};

// A registry with test commands: `show` prints its options, `grow` adds a mission to the map
// and then fails / asks for cancel / succeeds as told, `corrupt` breaks the map's invariants.
CommandRegistry TestRegistry(std::atomic<bool>* cancel) {
  CommandRegistry r;
  r.Add(Command<TestOptions>("show")
            .Alias("sh")
            .Summary("print options")
            .Flag("count", &TestOptions::count, "a count", {"maplab_count"})
            .Flag("ratio", &TestOptions::ratio, "a ratio")
            .Flag("verbose", &TestOptions::verbose, "talk")
            .Flag("name", &TestOptions::name, "a name")
            .PathFlag("folder", &TestOptions::folder, "a folder")
            .Positional("name")
            .Run([](CommandContext& c, const TestOptions& o) {
              c.out() << "count=" << o.count << " ratio=" << o.ratio << " verbose=" << o.verbose
                      << " name=" << o.name << " rest=" << c.positional().size() << "\n";
            }));
  r.Add(Command<TestOptions>("grow")
            .Summary("add a mission, then fail (count=1), cancel (count=2) or succeed")
            .Access(MapAccess::kModify)
            .Flag("count", &TestOptions::count, "what to do")
            .Run([cancel](CommandContext& c, const TestOptions& o) {
              mapstore::Mission mission;
              mission.id = mapstore::IdGenerator(42 + c.map().mission_ids().size()).Next();
              c.map().AddMission(mission);
              if (o.count == 1) throw CommandError("failed on purpose");
              if (o.count == 2) {
                cancel->store(true);
                BeginProgress(c.progress(), "grow", 10);
                ReportProgress(c.progress(), 1);  // throws Cancelled
              }
            }));
  r.Add(Command<NoOptions>("corrupt")
            .Summary("leave an inconsistent map")
            .Access(MapAccess::kModify)
            .Run([](CommandContext& c, const NoOptions&) {
              // Two vertices and no IMU edge: a broken vertex chain.
              mapstore::IdGenerator ids(7);
              mapstore::Mission mission;
              mission.id = ids.Next();
              mapstore::Vertex a, b;
              a.id = mission.root_vertex_id = ids.Next();
              b.id = ids.Next();
              a.mission_id = b.mission_id = mission.id;
              b.t_ns = 1000;
              c.map().AddMission(mission);
              c.map().AddVertex(a);
              c.map().AddVertex(b);
            }));
  return r;
}

struct Fixture {
  std::ostringstream out, err;
  std::atomic<bool> cancel{false};
  ConsoleSession session{TestRegistry(&cancel), out, err, SessionOptions{}, &cancel};
};

TEST_CASE("flags: defaults, --name=value, --name value, bare bools, aliases, positionals") {
  Fixture f;
  REQUIRE(f.session.Execute("show").ok());
  CHECK(f.out.str() == "count=3 ratio=0.5 verbose=0 name=x rest=0\n");
  f.out.str("");
  REQUIRE(f.session.Execute("sh --count=7 --ratio 0.25 --verbose hello extra").ok());
  CHECK(f.out.str() == "count=7 ratio=0.25 verbose=1 name=hello rest=1\n");
  f.out.str("");
  REQUIRE(f.session.Execute("show --maplab_count=9 --verbose=false 'two words'").ok());
  CHECK(f.out.str() == "count=9 ratio=0.5 verbose=0 name=two words rest=0\n");
}

TEST_CASE("flags: wrong types, unknown flags and invalid options are errors naming the flag") {
  Fixture f;
  CommandResult r = f.session.Execute("show --count=abc");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK(r.message == "--count: expected an integer, got 'abc'");
  r = f.session.Execute("show --ratio=1e999");
  CHECK(r.message == "--ratio: expected a finite number, got '1e999'");
  r = f.session.Execute("show --cuont=1");
  CHECK_THAT(r.message, Catch::Contains("unknown flag --cuont") && Catch::Contains("--count"));
  r = f.session.Execute("show --count");
  CHECK_THAT(r.message, Catch::Contains("--count: expected a value"));
  r = f.session.Execute("show --count=-1");
  CHECK(r.message == "invalid options: count: expected >= 0");
  r = f.session.Execute("shw");
  CHECK_THAT(r.message, Catch::Contains("unknown command 'shw'") && Catch::Contains("show"));
  CHECK_THAT(f.err.str(), Catch::Contains("show: error: --count: expected an integer"));
}

TEST_CASE("set changes a default for the session, the command line still wins, flag files") {
  Fixture f;
  REQUIRE(f.session.Execute("set count 11").ok());
  REQUIRE(f.session.Execute("set --ratio=0.75").ok());
  CHECK_FALSE(f.session.Execute("set count eleven").ok());
  CHECK_FALSE(f.session.Execute("set no_such_flag 1").ok());
  f.out.str("");
  REQUIRE(f.session.Execute("show").ok());
  CHECK_THAT(f.out.str(), Catch::StartsWith("count=11 ratio=0.75"));
  f.out.str("");
  REQUIRE(f.session.Execute("show --count=2").ok());
  CHECK_THAT(f.out.str(), Catch::StartsWith("count=2 ratio=0.75"));
  REQUIRE(f.session.Execute("unset count").ok());

  const std::string path = std::filesystem::temp_directory_path() / "vilma_console_flags.txt";
  std::ofstream(path) << "# defaults\n--count=5\n\n--verbose=true\n";
  f.session.LoadFlagFile(path);
  f.out.str("");
  REQUIRE(f.session.Execute("show").ok());
  CHECK_THAT(f.out.str(), Catch::StartsWith("count=5 ratio=0.75 verbose=1"));
  // Per command.
  std::ofstream(path) << "--count=8\n";
  f.out.str("");
  REQUIRE(f.session.Execute("show --flagfile=" + path).ok());
  CHECK_THAT(f.out.str(), Catch::StartsWith("count=8"));
  std::ofstream(path) << "--count=8\nnot a flag\n";
  CHECK_THROWS_WITH(f.session.LoadFlagFile(path),
                    Catch::Contains(path + ":2: expected --name=value"));
  std::filesystem::remove(path);
}

TEST_CASE("a modifying command that fails, is cancelled or breaks the map leaves it unchanged") {
  Fixture f;
  f.session.maps().Add("m", mapstore::VIMap(), "");
  REQUIRE(f.session.Execute("grow --count=1").outcome == CommandOutcome::kFailed);
  CHECK(f.session.maps().Get("m").map->mission_ids().empty());
  REQUIRE(f.session.Execute("grow --count=2").outcome == CommandOutcome::kCancelled);
  CHECK(f.session.maps().Get("m").map->mission_ids().empty());
  CHECK_THAT(f.err.str(), Catch::Contains("grow: cancelled (the map is unchanged)"));
  const CommandResult broken = f.session.Execute("corrupt");
  CHECK(broken.outcome == CommandOutcome::kFailed);
  CHECK_THAT(broken.message, Catch::Contains("not a consistent map"));
  CHECK(f.session.maps().Get("m").map->mission_ids().empty());
  REQUIRE(f.session.Execute("grow").ok());
  CHECK(f.session.maps().Get("m").map->mission_ids().size() == 1);
  CHECK(mapstore::CheckMapConsistency(*f.session.maps().Get("m").map).ok());
}

TEST_CASE("modifying commands need a selected map") {
  Fixture f;
  const CommandResult r = f.session.Execute("grow");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("no map selected"));
}

TEST_CASE("scripts: semicolons and newlines, comments, quotes, stop at the first failure") {
  const auto commands = SplitScript("show a; show 'b;c' # comment; not run\n\n# only\nshow \"d#e\"");
  REQUIRE(commands.size() == 3);
  CHECK(commands[0] == std::make_pair(1, std::string("show a")));
  CHECK(commands[1] == std::make_pair(1, std::string("show 'b;c'")));
  CHECK(commands[2] == std::make_pair(4, std::string("show \"d#e\"")));
  CHECK(SplitWords("a 'b c' \"d\\\"e\" f\\ g") ==
        std::vector<std::string>{"a", "b c", "d\"e", "f g"});
  CHECK_THROWS_AS(SplitWords("a 'b"), CommandError);

  Fixture f;
  f.session.options().echo_commands = true;
  const ScriptResult r = f.session.RunScript("show one\nshow --count=x\nshow three", "s.txt");
  CHECK_FALSE(r.ok);
  CHECK(r.commands_run == 2);
  CHECK(r.source_line == "s.txt:2");
  CHECK(r.failed_command == "show --count=x");
  CHECK_THAT(f.out.str(), Catch::Contains("> show one") && Catch::Contains("(show: ") &&
                              !Catch::Contains("name=three"));
  CHECK(f.session.RunScript("show; quit; show --count=x", "q").quit);
}

TEST_CASE("help lists commands and describes flags with defaults and session values") {
  Fixture f;
  REQUIRE(f.session.Execute("set count 4").ok());
  f.out.str("");
  REQUIRE(f.session.Execute("help").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("show, sh") && Catch::Contains("[rolls back]"));
  f.out.str("");
  REQUIRE(f.session.Execute("help sh").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("--count, --maplab_count (int, default 3, set to 4)") &&
                              Catch::Contains("--ratio (double, default 0.5)"));
  CHECK_FALSE(f.session.Execute("help nothing").ok());
}

TEST_CASE("completion: commands, flags, map keys, paths") {
  Fixture f;
  CHECK(CompleteWord(f.session, "", "sho") == std::vector<std::string>{"show"});
  CHECK(CompleteWord(f.session, "", "sh") == std::vector<std::string>{"sh", "show"});
  CHECK(CompleteWord(f.session, "", "s") == std::vector<std::string>{"set", "sh", "show", "source"});
  CHECK(CompleteWord(f.session, "show ", "--co") == std::vector<std::string>{"--count="});
  CHECK(CompleteWord(f.session, "show ", "--verb") == std::vector<std::string>{"--verbose"});
  f.session.maps().Add("alpha", mapstore::VIMap(), "");
  f.session.maps().Add("beta", mapstore::VIMap(), "");
  const std::string dir = std::filesystem::temp_directory_path() / "vilma_completion";
  std::filesystem::create_directories(dir + "/maps_a");
  std::ofstream(dir + "/map.txt") << "x";
  CHECK(CompleteWord(f.session, "show ", "--folder=" + dir + "/ma") ==
        std::vector<std::string>{"--folder=" + dir + "/map.txt", "--folder=" + dir + "/maps_a/"});
  CHECK(CompleteWord(f.session, "show --folder ", dir + "/maps") ==
        std::vector<std::string>{dir + "/maps_a/"});
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma::console

namespace vilma::console {
namespace {

TEST_CASE("script variables: ${NAME} expands, $$ is $, undefined names are errors with the line") {
  const std::map<std::string, std::string> vars{{"map", "/maps/a"}, {"out", "/maps/a kf"}};
  CHECK(ExpandVariables("load ${map}\nsave --out='${out}' # $$5 $x", vars) ==
        "load /maps/a\nsave --out='/maps/a kf' # $5 $x");
  CHECK_THROWS_WITH(ExpandVariables("ms\nload ${mapp}", vars),
                    Catch::Contains("line 2: ${mapp} is not defined"));
  CHECK_THROWS_WITH(ExpandVariables("load ${map", vars), Catch::Contains("unterminated"));
}

}  // namespace
}  // namespace vilma::console

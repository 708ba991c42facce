#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <set>

#include "vilma/mapstore/id.h"

using vilma::mapstore::Id;
using vilma::mapstore::IdGenerator;

TEST_CASE("ids are deterministic per seed, unique and valid", "[mapstore]") {
  IdGenerator a(42), b(42), c(43);
  std::set<Id> seen;
  for (int i = 0; i < 10000; ++i) {
    const Id x = a.Next();
    REQUIRE(x.IsValid());
    REQUIRE(x == b.Next());
    REQUIRE(x != c.Next());
    REQUIRE(seen.insert(x).second);
  }
}

TEST_CASE("mission generators depend only on the mission id", "[mapstore]") {
  const Id m1 = IdGenerator(1).Next();
  const Id m2 = IdGenerator(2).Next();
  IdGenerator g1 = IdGenerator::ForMission(m1);
  IdGenerator g1b = IdGenerator::ForMission(m1);
  IdGenerator g2 = IdGenerator::ForMission(m2);
  const Id x = g1.Next();
  CHECK(x == g1b.Next());
  CHECK(x != g2.Next());
}

TEST_CASE("id hex round trip and rejects", "[mapstore]") {
  Id id;
  id.hi = 0x0123456789abcdefULL;
  id.lo = 0xfedcba9876543210ULL;
  CHECK(id.Hex() == "0123456789abcdeffedcba9876543210");
  Id back;
  REQUIRE(Id::FromHex(id.Hex(), &back));
  CHECK(back == id);
  CHECK_FALSE(Id::FromHex("0123", &back));
  CHECK_FALSE(Id::FromHex("0123456789abcdeffedcba987654321g", &back));
  CHECK_FALSE(Id().IsValid());
}

TEST_CASE("SeedFromFileContent: same content, same seed, other content, other seed") {
  const std::string dir = std::filesystem::temp_directory_path() / "vilma_seed_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/a") << "session zero IMU";
  std::ofstream(dir + "/b") << "session zero IMU";
  std::ofstream(dir + "/c") << "session one IMU!";
  const uint64_t a = vilma::mapstore::SeedFromFileContent(dir + "/a");
  CHECK(a != 0);
  CHECK(a == vilma::mapstore::SeedFromFileContent(dir + "/b"));
  CHECK(a != vilma::mapstore::SeedFromFileContent(dir + "/c"));
  CHECK_THROWS_WITH(vilma::mapstore::SeedFromFileContent(dir + "/missing"),
                    Catch::Contains(dir + "/missing"));
  std::filesystem::remove_all(dir);
}

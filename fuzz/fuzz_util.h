// Helpers shared by the libFuzzer harnesses (docs/reliability.md): a private scratch folder per
// process and the rule that bad input must be rejected by an exception, never by a crash, a
// sanitizer report or a hang.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace vilma::fuzz {

// /dev/shm (or $TMPDIR) /vilma-fuzz-<harness>-<pid>: created once, reused for every input.
inline const std::filesystem::path& ScratchDir(const char* harness) {
  static const std::filesystem::path dir = [harness] {
    const char* shm = "/dev/shm";
    const char* tmp = std::getenv("TMPDIR");
    std::filesystem::path base =
        std::filesystem::is_directory(shm) ? std::filesystem::path(shm)
                                           : std::filesystem::path(tmp ? tmp : "/tmp");
    std::filesystem::path d =
        base / ("vilma-fuzz-" + std::string(harness) + "-" + std::to_string(::getpid()));
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

inline void WriteBytes(const std::filesystem::path& path, const uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

inline std::string ReadText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Seed corpus: when $VILMA_FUZZ_WRITE_SEEDS names a folder, the harness writes its seeds there
// (seed-0, seed-1, ...; valid inputs made by the project's own writers) and the process exits
// (scripts/fuzz.sh calls each harness this way before fuzzing). Call from LLVMFuzzerInitialize.
template <typename MakeSeeds>
void WriteSeedsIfAsked(MakeSeeds make_seeds) {
  const char* dir = std::getenv("VILMA_FUZZ_WRITE_SEEDS");
  if (dir == nullptr || *dir == '\0') return;
  std::filesystem::create_directories(dir);
  const std::vector<std::string> seeds = make_seeds();
  for (std::size_t i = 0; i < seeds.size(); ++i) {
    WriteBytes(std::filesystem::path(dir) / ("seed-" + std::to_string(i)),
               reinterpret_cast<const uint8_t*>(seeds[i].data()), seeds[i].size());
  }
  std::exit(0);
}

// `prefix` byte followed by `bytes` (harnesses whose first byte picks a case).
inline std::string WithPrefix(uint8_t prefix, const std::string& bytes) {
  return std::string(1, static_cast<char>(prefix)) + bytes;
}

}  // namespace vilma::fuzz

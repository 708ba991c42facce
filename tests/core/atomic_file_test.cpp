#include "vilma/core/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "core/test_data.h"
#include "vilma/core/error.h"

namespace vilma {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::vector<std::string> Names(const std::string& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename());
  return names;
}

// Limits the size of files this process may write (RLIMIT_FSIZE) while in scope, with SIGXFSZ
// ignored so that write() fails with EFBIG instead of killing the process. Unlike a folder
// without write permission, this makes a write fail for root too (the tests run as root).
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    old_handler_ = ::signal(SIGXFSZ, SIG_IGN);
    ::getrlimit(RLIMIT_FSIZE, &old_);
    rlimit limit = old_;
    limit.rlim_cur = bytes;
    ::setrlimit(RLIMIT_FSIZE, &limit);
  }
  ~FileSizeLimit() {
    ::setrlimit(RLIMIT_FSIZE, &old_);
    ::signal(SIGXFSZ, old_handler_);
  }

 private:
  rlimit old_{};
  sighandler_t old_handler_ = SIG_DFL;
};

TEST_CASE("WriteFileAtomically writes and replaces the content and leaves no temporary file",
          "[atomic_file]") {
  testing::TempDir dir;
  const std::string path = dir.File("out.txt");
  WriteFileAtomically(path, "first");
  CHECK(ReadAll(path) == "first");
  const std::string binary("a\0b\nc", 5);
  WriteFileAtomically(path, binary);
  CHECK(ReadAll(path) == binary);
  WriteFileAtomically(path, "");
  CHECK(ReadAll(path).empty());
  CHECK(Names(dir.path()) == std::vector<std::string>{"out.txt"});
  struct stat st {};
  REQUIRE(::stat(path.c_str(), &st) == 0);
  CHECK((st.st_mode & 0777) == 0644);  // readable by others, as the data files it replaces
}

TEST_CASE("CommitFileAtomically: a file another writer made replaces the target, a missing one "
          "leaves it", "[atomic_file]") {
  testing::TempDir dir;
  const std::string path = dir.File("mesh.ply");
  const std::string partial = dir.File("mesh.ply.partial.ply");
  WriteFileAtomically(path, "old");
  std::ofstream(partial) << "new";
  CommitFileAtomically(partial, path);
  CHECK(ReadAll(path) == "new");
  CHECK(Names(dir.path()) == std::vector<std::string>{"mesh.ply"});
  // Nothing was written (the other library failed): the error names the target, which keeps
  // its content.
  CHECK_THROWS_WITH(CommitFileAtomically(partial, path),
                    Catch::StartsWith(path + ": the written temporary file ("));
  CHECK(ReadAll(path) == "new");
  // The rename fails (a folder in the way): the partial file is removed, the folder stays.
  const std::string folder = dir.File("folder");
  fs::create_directories(folder + "/inside");
  std::ofstream(partial) << "x";
  CHECK_THROWS_WITH(CommitFileAtomically(partial, folder),
                    Catch::Contains("a successful rename into place"));
  CHECK_FALSE(fs::exists(partial));
  CHECK(fs::is_directory(folder + "/inside"));
  std::ofstream(partial) << "x";
  CHECK(TryCommitFileAtomically(partial, folder) == EISDIR);
  CHECK_FALSE(fs::exists(partial));
  CHECK(TryCommitFileAtomically(partial, path) == ENOENT);
  CHECK(ReadAll(path) == "new");
}

// Everything the pipe's read end holds now (non-blocking: a writer that never came gives "").
std::string Drain(int fd) {
  std::string out;
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof(buffer));
    if (n <= 0) return out;
    out.append(buffer, static_cast<std::size_t>(n));
  }
}

TEST_CASE("WriteFileAtomically and CommitFileAtomically write through a FIFO or device, never "
          "rename over it", "[atomic_file]") {
  // `--out /dev/null` once replaced the device node /dev/null with a regular file (a rename over
  // it). A FIFO stands in for any special file here: it must stay a FIFO and carry the bytes.
  // Its read end is open (non-blocking) first, so a writer can open it and a rename over it
  // shows as nothing received, not as a hang.
  testing::TempDir dir;
  const std::string fifo = dir.File("pipe");
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  const int read_fd = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  REQUIRE(read_fd >= 0);
  WriteFileAtomically(fifo, "through the pipe");
  CHECK(Drain(read_fd) == "through the pipe");
  struct stat st {};
  REQUIRE(::stat(fifo.c_str(), &st) == 0);
  CHECK(S_ISFIFO(st.st_mode));

  const std::string partial = dir.File(".pipe.partial");
  const std::string bytes(60000, 'x');  // within the pipe's 64 KiB buffer
  std::ofstream(partial, std::ios::binary) << bytes;
  CommitFileAtomically(partial, fifo);
  CHECK(Drain(read_fd) == bytes);
  REQUIRE(::stat(fifo.c_str(), &st) == 0);
  CHECK(S_ISFIFO(st.st_mode));
  CHECK(!fs::exists(partial));
  CHECK(Names(dir.path()) == std::vector<std::string>{"pipe"});
  ::close(read_fd);
}

TEST_CASE("WriteFileAtomically: a failed write leaves the old file intact and no temporary",
          "[atomic_file]") {
  testing::TempDir dir;
  const std::string path = dir.File("map.yaml");
  WriteFileAtomically(path, "old content\n");
  const std::string big(64 * 1024, 'x');
  {
    FileSizeLimit limit(1024);  // the new content does not fit: write() fails with EFBIG
    CHECK_THROWS_WITH(WriteFileAtomically(path, big),
                      Catch::Contains("map.yaml") && Catch::Contains("room to write the file"));
    CHECK(TryWriteFileAtomically(path, big) == EFBIG);
  }
  CHECK(ReadAll(path) == "old content\n");
  CHECK(Names(dir.path()) == std::vector<std::string>{"map.yaml"});
}

TEST_CASE("WriteFileAtomically: a path that cannot be created is named in the error",
          "[atomic_file]") {
  testing::TempDir dir;
  // A parent that is a regular file fails for root as well (unlike a read-only folder).
  const std::string file = dir.File("plain_file");
  WriteFileAtomically(file, "not a folder");
  const std::string path = file + "/out.txt";
  CHECK_THROWS_AS(WriteFileAtomically(path, "x"), InputError);
  CHECK_THROWS_WITH(WriteFileAtomically(path, "x"), Catch::Contains(path));
  CHECK(TryWriteFileAtomically(path, "x") == ENOTDIR);
  CHECK(TryWriteFileAtomically(dir.File("no/such/dir/x.txt"), "x") == ENOENT);
  // A folder in the place of the file: the rename fails, the folder and its content stay.
  fs::create_directories(dir.File("taken/inner"));
  CHECK_THROWS_WITH(WriteFileAtomically(dir.File("taken"), "x"), Catch::Contains("rename"));
  CHECK(fs::is_directory(dir.File("taken/inner")));
  CHECK(ReadAll(file) == "not a folder");
  std::vector<std::string> names = Names(dir.path());
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"plain_file", "taken"});
}

TEST_CASE("WriteFileAtomically: concurrent writers of one file never leave a mixed file",
          "[atomic_file]") {
  testing::TempDir dir;
  const std::string path = dir.File("shared.txt");
  const std::string a(200000, 'a');
  const std::string b(200000, 'b');
  std::vector<std::thread> writers;
  for (int t = 0; t < 4; ++t) {
    writers.emplace_back([&, t] {
      for (int i = 0; i < 5; ++i) WriteFileAtomically(path, t % 2 == 0 ? a : b);
    });
  }
  for (std::thread& w : writers) w.join();
  const std::string content = ReadAll(path);
  CHECK((content == a || content == b));
  CHECK(Names(dir.path()) == std::vector<std::string>{"shared.txt"});
}

TEST_CASE("CreateDirectoriesDurably creates missing parents, accepts an existing folder, names "
          "a path it cannot create",
          "[atomic_file]") {
  testing::TempDir dir;
  const std::string nested = dir.File("a/b/c");
  CreateDirectoriesDurably(nested);
  CHECK(std::filesystem::is_directory(nested));
  CreateDirectoriesDurably(nested);  // already there: nothing to do, no error
  CHECK(Names(dir.path()) == std::vector<std::string>{"a"});
  // A relative path (its first parent is the working folder).
  const std::filesystem::path cwd = std::filesystem::current_path();
  std::filesystem::current_path(dir.path());
  CreateDirectoriesDurably("relative/x");
  std::filesystem::current_path(cwd);
  CHECK(std::filesystem::is_directory(dir.File("relative/x")));

  WriteFileAtomically(dir.File("file"), "x");
  for (const std::string& bad : {dir.File("file"), dir.File("file/below")}) {
    try {
      CreateDirectoriesDurably(bad);
      FAIL("no error for " << bad);
    } catch (const InputError& e) {
      CHECK_THAT(e.what(), Catch::Contains(bad) && Catch::Contains("expected a folder"));
    }
  }
  SyncDirectory(dir.File("missing"));  // best effort: a folder that is not there is no error
}

TEST_CASE("RemoveLeftoverTemporaryFiles removes only the temporary names of writes of its path",
          "[atomic_file]") {
  testing::TempDir dir;
  const std::string target = dir.File("manifest.yaml");
  WriteFileAtomically(target, "kept");
  // What a write killed before its rename leaves (".<name>." + mkstemp's 6 characters), and
  // names that only look alike.
  for (const char* name : {".manifest.yaml.a1B2c3", ".manifest.yaml.zzzzzz", ".manifest.yaml.short",
                           ".manifest.yaml.toolong7", ".other.yaml.a1B2c3", "manifest.yaml.a1B2c3"}) {
    std::ofstream(dir.File(name)) << "x";
  }
  fs::create_directories(dir.File(".manifest.yaml.folder"));  // not a regular file: kept
  CHECK(RemoveLeftoverTemporaryFiles(target) == 2);
  std::vector<std::string> names = Names(dir.path());
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{".manifest.yaml.folder", ".manifest.yaml.short",
                                          ".manifest.yaml.toolong7", ".other.yaml.a1B2c3",
                                          "manifest.yaml", "manifest.yaml.a1B2c3"});
  CHECK(ReadAll(target) == "kept");
  CHECK(RemoveLeftoverTemporaryFiles(dir.File("missing/x.yaml")) == 0);  // no folder: nothing
}

}  // namespace
}  // namespace vilma

#include "vilma/core/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "vilma/core/error.h"

namespace vilma {
namespace {

namespace fs = std::filesystem;

// The step that failed (for the error message) and its errno.
struct WriteResult {
  int error = 0;
  const char* step = "";
};

WriteResult RenameIntoPlace(const char* tmp, const std::string& path, const std::string& dir);
std::string FolderOf(const std::string& path);

// A target that exists and is not a regular file (/dev/null, /dev/stdout, a FIFO, a terminal)
// is written through, never renamed over: a rename replaced the device node /dev/null with a
// regular file when a program was given `--out /dev/null` (found on the development machine).
// stat() follows symlinks, so /dev/stdout -> /proc/self/fd/1 counts by what it points to.
bool IsSpecialFile(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
}

WriteResult WriteAll(int fd, const char* data, std::size_t size) {
  std::size_t written = 0;
  while (written < size) {
    const ssize_t n = ::write(fd, data + written, size - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      return {errno, "room to write the file"};
    }
    written += static_cast<std::size_t>(n);
  }
  return {};
}

WriteResult WriteThrough(const std::string& path, const std::string& content) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) return {errno, "a writable file"};
  const WriteResult r = WriteAll(fd, content.data(), content.size());
  ::close(fd);
  return r;
}

// The temporary name of a write of `target` is this prefix and mkstemp's 6 characters.
std::string TemporaryPrefix(const fs::path& target) {
  return "." + target.filename().string() + ".";
}

WriteResult WriteAtomically(const std::string& path, const std::string& content) {
  if (IsSpecialFile(path)) return WriteThrough(path, content);
  const fs::path target(path);
  const std::string dir = FolderOf(path);
  // mkstemp gives a name no other writer (thread or process) uses at the same time.
  std::string tmp_template = dir + "/" + TemporaryPrefix(target) + "XXXXXX";
  std::vector<char> tmp(tmp_template.begin(), tmp_template.end());
  tmp.push_back('\0');
  const int fd = ::mkostemp(tmp.data(), O_CLOEXEC);
  if (fd < 0) return {errno, "a writable folder for a temporary file"};
  auto fail = [&](const char* step) {
    const int err = errno != 0 ? errno : EIO;
    ::close(fd);
    ::unlink(tmp.data());
    return WriteResult{err, step};
  };
  // mkstemp creates 0600; data files are readable by others, as with open(..., 0644).
  if (::fchmod(fd, 0644) != 0) return fail("permission to set the file mode");
  const WriteResult written = WriteAll(fd, content.data(), content.size());
  if (written.error != 0) {
    errno = written.error;
    return fail(written.step);
  }
  if (::fsync(fd) != 0) return fail("a successful fsync");
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.data());
    return {err, "a successful close"};
  }
  return RenameIntoPlace(tmp.data(), path, dir);
}

// Shared by both writers: rename the synced temporary file over `path`, then sync the folder.
WriteResult RenameIntoPlace(const char* tmp, const std::string& path, const std::string& dir) {
  if (::rename(tmp, path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp);
    return {err, "a successful rename into place"};
  }
  // Make the rename itself durable. The file is in place now; a folder that cannot be synced
  // (some file systems refuse fsync on a directory) does not undo that.
  SyncDirectory(dir);
  return {};
}

std::string FolderOf(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

// The partial file's bytes copied into a special target (see IsSpecialFile); the partial file
// is removed afterwards by the caller's success path below.
WriteResult CopyThrough(const std::string& partial_path, const std::string& path) {
  const int in = ::open(partial_path.c_str(), O_RDONLY | O_CLOEXEC);
  if (in < 0) return {errno, "the written temporary file"};
  const int out = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (out < 0) {
    const int err = errno;
    ::close(in);
    return {err, "a writable file"};
  }
  WriteResult r;
  std::vector<char> buffer(1 << 16);
  for (;;) {
    const ssize_t n = ::read(in, buffer.data(), buffer.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      r = {errno, "the written temporary file"};
      break;
    }
    if (n == 0) break;
    r = WriteAll(out, buffer.data(), static_cast<std::size_t>(n));
    if (r.error != 0) break;
  }
  ::close(in);
  ::close(out);
  return r;
}

WriteResult CommitAtomically(const std::string& partial_path, const std::string& path) {
  if (IsSpecialFile(path)) {
    const WriteResult r = CopyThrough(partial_path, path);
    if (r.error == 0) ::unlink(partial_path.c_str());
    return r;
  }
  const int fd = ::open(partial_path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return {errno, "the written temporary file"};
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    ::unlink(partial_path.c_str());
    return {err, "a successful fsync"};
  }
  ::close(fd);
  return RenameIntoPlace(partial_path.c_str(), path, FolderOf(path));
}

}  // namespace

void SyncDirectory(const std::string& dir) {
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    ::fsync(dir_fd);
    ::close(dir_fd);
  }
}

void CreateDirectoriesDurably(const std::string& dir) {
  // The folders to create, deepest first: `dir` and its missing parents.
  std::vector<fs::path> missing;
  std::error_code ec;
  for (fs::path p = fs::path(dir).lexically_normal(); !p.empty() && !fs::exists(p, ec);
       p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw InputError(FormatInputError(
        dir, "", "expected a folder that can be created (" +
                     (ec ? ec.message() : std::string("exists and is not a folder")) + ")"));
  }
  // Parents first, so each synced entry lies in an already durable folder.
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    const fs::path parent = it->parent_path();
    SyncDirectory(parent.empty() ? "." : parent.string());
  }
}

int RemoveLeftoverTemporaryFiles(const std::string& path) {
  const std::string prefix = TemporaryPrefix(fs::path(path));
  int removed = 0;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(FolderOf(path), ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() == prefix.size() + 6 && name.compare(0, prefix.size(), prefix) == 0 &&
        entry.is_regular_file(ec) && fs::remove(entry.path(), ec)) {
      ++removed;
    }
  }
  return removed;
}

void WriteFileAtomically(const std::string& path, const std::string& content) {
  const WriteResult r = WriteAtomically(path, content);
  if (r.error != 0) {
    throw InputError(
        FormatInputError(path, "", std::string(r.step) + " (" + std::strerror(r.error) + ")"));
  }
}

int TryWriteFileAtomically(const std::string& path, const std::string& content) {
  return WriteAtomically(path, content).error;
}

int TryCommitFileAtomically(const std::string& partial_path, const std::string& path) {
  const WriteResult r = CommitAtomically(partial_path, path);
  if (r.error != 0) ::unlink(partial_path.c_str());
  return r.error;
}

void CommitFileAtomically(const std::string& partial_path, const std::string& path) {
  const WriteResult r = CommitAtomically(partial_path, path);
  if (r.error != 0) {
    ::unlink(partial_path.c_str());
    throw InputError(
        FormatInputError(path, "", std::string(r.step) + " (" + std::strerror(r.error) + ")"));
  }
}

}  // namespace vilma

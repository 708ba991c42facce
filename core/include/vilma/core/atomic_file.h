// Writing a file so that a reader (or a crash) never sees half of it: the one implementation
// for the whole project.
#pragma once

#include <string>

namespace vilma {

// Writes `content` to `path` atomically and durably: a temporary file in the same folder
// (hidden: ".<name>.XXXXXX", so folder listings never take it for data), fsync of the file,
// rename over `path`, fsync of the folder (so the rename itself survives a power loss). On
// failure the temporary file is removed and an existing `path` is left as it was.
// Throws InputError naming `path` and the step that failed. A `path` that exists and is not a
// regular file (/dev/null, /dev/stdout, a FIFO) is written through instead: a rename would
// replace the device node. The same holds for CommitFileAtomically.
void WriteFileAtomically(const std::string& path, const std::string& content);

// The same, for callers that report failures as a status instead of an exception (mapstored
// acks DISK_FULL on ENOSPC): returns 0 or the errno of the step that failed.
int TryWriteFileAtomically(const std::string& path, const std::string& content);

// The last steps of the same, for a file that another library wrote (Open3D's PLY writer,
// liblcm's log writer) under `partial_path` in the folder of `path`: fsync of the file, rename
// over `path`, fsync of the folder. On failure `partial_path` is removed and an existing `path`
// is left as it was. Throws InputError naming `path` and the step that failed.
void CommitFileAtomically(const std::string& partial_path, const std::string& path);
// The same, returning 0 or the errno of the step that failed (for callers with their own
// wording of the error).
int TryCommitFileAtomically(const std::string& partial_path, const std::string& path);

// fsync of a folder, so that the entries created, renamed or removed in it survive a power
// loss. Best effort: a folder that cannot be opened or synced (some file systems refuse fsync
// on a directory) is left as it is.
void SyncDirectory(const std::string& dir);

// Creates `dir` and its missing parents durably: after each folder is created its parent is
// synced, so that a power loss never leaves durable files in a folder that is not reachable
// (fsync of a file does not make its folder's own entry durable). Throws InputError naming the
// folder when it cannot be created or exists as something else.
void CreateDirectoriesDurably(const std::string& dir);

// Removes the temporary files that writes of `path` (WriteFileAtomically) left in its folder
// when they were killed before their rename (".<name>.XXXXXX"); returns how many. Only for a
// caller that knows no other writer of `path` is running (e.g. after its own write of `path`).
int RemoveLeftoverTemporaryFiles(const std::string& path);

}  // namespace vilma

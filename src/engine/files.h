// Small file helpers shared by the engines and the runner: atomic replacement, a cross-process
// lock, the tail of a log.
#pragma once

#include <filesystem>
#include <string>

namespace granary {

// Writes `text` to a temporary file beside `file` (named with this process' pid, so two
// processes never share it) and renames it over `file`: readers see the old or the new
// content, never a torn one. File and directory are fsynced (a shared file system may show
// the file to another node next). Throws std::runtime_error naming the file.
void WriteAtomically(const std::filesystem::path& file, const std::string& text);

// The same for a file already written at `tmp` (beside `file`): fsync, rename, fsync the
// directory.
void ReplaceAtomically(const std::filesystem::path& tmp, const std::filesystem::path& file);

// The last `lines` lines of a text file ("" if it cannot be read).
std::string TailOfFile(const std::filesystem::path& file, int lines);

// An exclusive flock on `path` (created if missing) for the lifetime of the object, so two
// processes needing the same cached bed prepare it once.
class FileLock {
 public:
  explicit FileLock(const std::filesystem::path& path);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_ = -1;
};

}  // namespace granary

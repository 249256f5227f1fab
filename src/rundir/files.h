// Small file helpers shared by the engines, the runner and the run-directory writers: atomic
// replacement, an output file that a continued run cuts back to its checkpoint, a
// cross-process lock, the tail of a log, a whole file as a string.
#pragma once

#include <cstdint>
#include <cstdio>
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

// A file written front to back with C stdio (fast formatted output), that a run continued
// from a checkpoint reopens cut back to the offset the checkpoint recorded.
class OutputFile {
 public:
  OutputFile() = default;
  // Creates (truncates) `path`.
  explicit OutputFile(const std::filesystem::path& path);
  // Reopens `path` for appending after cutting it to `offset` bytes (continuing a run); a
  // missing file is created empty.
  OutputFile(const std::filesystem::path& path, std::int64_t offset);
  ~OutputFile();
  OutputFile(OutputFile&& other) noexcept;
  OutputFile& operator=(OutputFile&& other) noexcept;
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  bool is_open() const { return file_ != nullptr; }
  std::FILE* get() const { return file_; }
  const std::filesystem::path& path() const { return path_; }
  // Bytes written so far (flushed first): what a checkpoint records. 0 when not open.
  std::int64_t Offset();
  // Flushes and closes; throws std::runtime_error naming the file if a write failed.
  void Close();

 private:
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
};

// The whole content of a file; throws std::runtime_error naming it if it cannot be read.
std::string ReadWholeFile(const std::filesystem::path& file);

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

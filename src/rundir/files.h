// Small file helpers shared by the engines, the runner and the run-directory writers: atomic
// replacement, an output file that a continued run cuts back to its checkpoint,
// cross-process locks (a cached bed's, a run directory's writer lock), the tail of a log, a
// whole file as a string, CRC-32, signal names.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace granary {

// How far an atomic write goes: kDurable fsyncs the file before the rename and the directory
// after, so that a crash of the node (or of a shared file system's server) never leaves a
// name without its whole content; kVisible only renames, for files rewritten many times a
// second that lose nothing when an old version reappears (progress.json, the stop request
// to LIGGGHTS) — an fsync on a busy disk can take longer than the work between two writes.
enum class Durability { kDurable, kVisible };

// Removes the temporary files that WriteAtomically left in `dir` when its process was killed
// between the write and the rename (`NAME.tmp.PID`): those whose PID is not a live process
// here and that are older than `min_age_s` (a writer on another node of a shared file system
// has a PID this node does not know: the age keeps its file, written a moment ago). Returns
// how many it removed; never throws.
int RemoveStaleTemporaries(const std::filesystem::path& dir, double min_age_s = 300.0);

// Writes `text` to a temporary file beside `file` (named with this process' pid, so two
// processes never share it) and renames it over `file`: readers see the old or the new
// content, never a torn one. Throws std::runtime_error naming the file.
void WriteAtomically(const std::filesystem::path& file, const std::string& text,
                     Durability durability = Durability::kDurable);

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

  bool IsOpen() const { return file_ != nullptr; }
  std::FILE* Get() const { return file_; }
  const std::filesystem::path& Path() const { return path_; }
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
  // The same; when another process holds the lock, `on_wait` is called once before waiting
  // for it (to say so).
  FileLock(const std::filesystem::path& path, const std::function<void()>& on_wait);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_ = -1;
};

// The writer lock of a run directory (docs/run-directory.md "One writer"): an exclusive flock
// on DIR/engine.lock, taken by an engine before it touches anything and held for its life.
// The descriptor is inherited by the processes the engine starts (mpirun), and helper
// processes that do not inherit it (LIGGGHTS' MPI ranks: Open MPI closes descriptors) hold a
// shared flock on DIR/engine.lock.helpers (HoldRunDirectoryAsHelper). The directory is
// free only when neither is held, so two engines never write one directory, also while the
// ranks of a killed engine are still winding down.
class RunDirectoryBusy : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class RunDirectoryLock {
 public:
  // Takes the lock or throws RunDirectoryBusy saying who holds it.
  explicit RunDirectoryLock(const std::filesystem::path& dir);
  ~RunDirectoryLock();
  RunDirectoryLock(const RunDirectoryLock&) = delete;
  RunDirectoryLock& operator=(const RunDirectoryLock&) = delete;

 private:
  int fd_ = -1;
};

// "" when no engine (and no helper of one) holds DIR's lock, else who does, e.g.
// "engine pid 4711 on node1". A runner asks before it starts an engine; only the engine's
// own lock is the guarantee.
std::string RunDirectoryHolder(const std::filesystem::path& dir);

// For a helper process about to exec: a shared lock on DIR/engine.lock.helpers on a
// descriptor that survives exec, released when the process (and what it execs) ends.
void HoldRunDirectoryAsHelper(const std::filesystem::path& dir);

// Exit status of an engine that found its run directory locked by another engine: nothing
// was touched, try again later (EX_TEMPFAIL).
inline constexpr int kExitRunDirectoryBusy = 75;

// "signal 11 (Segmentation fault)": how messages name a signal that ended a process.
std::string SignalName(int signal);

// CRC-32 (ISO-HDLC, as zlib and PNG: reflected polynomial 0xEDB88320), continued from `crc`
// (0 to start), for checksums of checkpoints and prepared beds.
std::uint32_t Crc32(std::string_view data, std::uint32_t crc = 0);

}  // namespace granary

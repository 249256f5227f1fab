// unclogs.csv: what the native engine did to break each clog of a run with
// discharge/on_clog "unclog" (docs/run-directory.md). One row per attempt: the time and step,
// the clog it broke (1-based, the block of clog_frames.dump), the method, and the bodies it
// moved or took out. One struct, one writer (streamed, cut back to a checkpoint on continue),
// one reader.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "rundir/files.h"

namespace granary::rundir {

struct UnclogEvent {
  double time = 0.0;  // since the outlets opened
  std::int64_t step = 0;
  int clog = 1;                      // which clog (1-based, as in clog_frames.dump)
  int attempt = 1;                   // 1 for the first attempt on this clog
  std::string method;                // "remove_arch" or "kick"
  std::vector<std::int64_t> bodies;  // body ids taken out (remove_arch) or kicked (kick)
};

class UnclogWriter {
 public:
  UnclogWriter() = default;
  // A new file with its header line.
  static UnclogWriter Create(const std::filesystem::path& file);
  // The file of an interrupted run cut back to `offset` bytes (what its checkpoint recorded);
  // a missing file is created with its header.
  static UnclogWriter ContinueAt(const std::filesystem::path& file, std::int64_t offset);

  void Write(const UnclogEvent& event);
  bool IsOpen() const { return file_.IsOpen(); }
  std::int64_t Offset() { return file_.Offset(); }
  void Close() { file_.Close(); }

 private:
  OutputFile file_;
};

// In file order (time order). A missing file is a run without unclogs (none). Throws ReadError
// with file:line on a malformed row.
std::vector<UnclogEvent> ReadUnclogs(const std::filesystem::path& file);

}  // namespace granary::rundir

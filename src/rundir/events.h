// events.csv: one row per body leaving the silo (docs/run-directory.md). One struct, one
// writer (streamed by the native engine, whole by the LIGGGHTS backend), one reader.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "rundir/files.h"

namespace granary::rundir {

struct ExitEvent {
  double time = 0.0;       // since the outlets opened
  std::int64_t body = -1;  // body id (0-based, stable for the run)
  std::string shape;       // species name
  double mass = 0.0;       // NaN when read from a file without a mass column
  int outlet = 0;          // base outlets first in spec order, then side outlets
};

class EventWriter {
 public:
  EventWriter() = default;
  // A new file with its header line.
  static EventWriter Create(const std::filesystem::path& file);
  // The file of an interrupted run cut back to `offset` bytes (what its checkpoint recorded).
  static EventWriter ContinueAt(const std::filesystem::path& file, std::int64_t offset);

  void Write(const ExitEvent& event);
  bool IsOpen() const { return file_.IsOpen(); }
  std::int64_t Offset() { return file_.Offset(); }
  void Close() { file_.Close(); }

 private:
  OutputFile file_;
};

// Writes a whole events.csv atomically (header and rows).
void WriteEvents(const std::filesystem::path& file, const std::vector<ExitEvent>& events);

// Sorted by time (engines write them in order; a stable sort guards against ties). Columns
// are found by name: `time` is required; `body`, `shape`, `mass`, `outlet` are optional
// (missing mass: NaN; missing outlet: 0). An empty file has no events. Throws ReadError
// with file:line.
std::vector<ExitEvent> ReadEvents(const std::filesystem::path& file);

}  // namespace granary::rundir

// clog_frames.dump and clog_contacts.dump: the clogged configurations of a run
// (docs/run-directory.md). At every clog the engine keeps every disc still in the silo and
// every contact force, one block per clog in each file, block k of one file belonging to
// block k of the other. The blocks are those of frames.dump and contacts.dump (the same
// structs, spelled by FrameWriter and ContactWriter), so OVITO opens the files as they are.
// One writer and one reader for the pair.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "rundir/contacts.h"
#include "rundir/frames.h"

namespace granary::rundir {

// One clog: the configuration and its contact forces at the step the engine judged it.
struct ClogState {
  Frame frame;
  ContactFrame contacts;
};

class ClogWriter {
 public:
  ClogWriter() = default;
  // Both files of DIR, new and empty (a run without clogs keeps two empty files).
  static ClogWriter Create(const std::filesystem::path& dir);
  // A run continued from a checkpoint taken at `timestep`: the clogs judged at or before it
  // stay, anything later (judged again by the continued run) and a block cut short by the
  // interruption is cut off. Missing files are created empty.
  static ClogWriter ContinueAfter(const std::filesystem::path& dir, std::int64_t timestep);

  // Appends one clog to both files and flushes them, so that a checkpoint taken after it
  // never counts on a clog that is not in the files.
  void Write(const ClogState& clog);
  bool IsOpen() const { return frames_.IsOpen(); }
  void Close();

 private:
  FrameWriter frames_;
  ContactWriter contacts_;
};

// The byte offset at which a dump (frames or contacts format) should be cut so that it keeps
// exactly its complete blocks with TIMESTEP <= `timestep`: the start of the first later block,
// or of the first block cut short.
std::int64_t DumpOffsetAfter(const std::filesystem::path& file, std::int64_t timestep);

// Streams the clogs of DIR in the order they happened. Throws ReadError when a file is
// malformed, or when the two files disagree (another timestep, another number of blocks).
// A run directory written before engines kept clogs has neither file: `Present()` is false
// and there are no clogs.
class ClogReader {
 public:
  explicit ClogReader(const std::filesystem::path& dir);
  bool Present() const { return present_; }
  bool Next(ClogState& clog);

 private:
  std::filesystem::path dir_;
  bool present_ = false;
  std::unique_ptr<FrameReader> frames_;
  std::unique_ptr<ContactReader> contacts_;
};

// Every clog of DIR (ClogReader).
std::vector<ClogState> ReadClogs(const std::filesystem::path& dir);

}  // namespace granary::rundir

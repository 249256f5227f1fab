// contacts.dump: contact-force frames in LAMMPS local dump format (docs/run-directory.md),
// written at the frame times when the spec asks for them. One struct, one writer, one
// streaming reader.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "rundir/files.h"
#include "rundir/gsd.h"

namespace granary::rundir {
namespace detail {
struct DumpState;
}

struct ContactRow {
  std::int64_t body_i = 0, body_j = -1;  // body_j = -1: wall or obstacle
  double xi = 0, yi = 0;                 // centre of the touching disc of body i
  double xj = 0, yj = 0;                 // centre of the touching disc of body j (a wall: the contact point)
  double cx = 0, cy = 0;                 // contact point
  double fx = 0, fy = 0;                 // force on body i
};

struct ContactFrame {
  std::int64_t timestep = 0;
  double time = 0.0;
  double box[3][2] = {{0, 0}, {0, 0}, {-0.5, 0.5}};
  std::vector<ContactRow> contacts;
};

class ContactWriter {
 public:
  ContactWriter() = default;
  // `gzip`: each frame one gzip member (contacts.dump.gz; gzip.h). A file named *.gsd is
  // written as GSD (gsd.h; `gzip` does not apply).
  static ContactWriter Create(const std::filesystem::path& file, bool gzip = false);
  // The file of an interrupted run cut back to `offset` bytes (what its checkpoint recorded).
  static ContactWriter ContinueAt(const std::filesystem::path& file, std::int64_t offset, bool gzip = false);

  // Appends one frame; NUMBER OF ENTRIES is frame.contacts.size().
  void Write(const ContactFrame& frame);
  bool IsOpen() const { return gsd_.IsOpen() || file_.IsOpen(); }
  std::int64_t Offset() { return gsd_.IsOpen() ? gsd_.Offset() : file_.Offset(); }
  void Close() {
    gsd_.Close();
    file_.Close();
  }

 private:
  gsd::GsdContactWriter gsd_;  // open for a *.gsd file
  OutputFile file_;
  std::string text_;  // rows being formatted (kept: its capacity)
  bool gzip_ = false;
};

// The bytes ContactWriter::Write adds to the file for `frame` (gzipped or not); nothing is written.
std::int64_t ContactBytes(const ContactFrame& frame, bool gzip);

// Streams a contacts.dump (or contacts.dump.gz, or contacts.gsd); columns found by name (all ten required). Malformed input throws
// ReadError with file:line; a frame cut short at the end of the file ends the stream.
class ContactReader {
 public:
  explicit ContactReader(const std::filesystem::path& file);
  ~ContactReader();
  ContactReader(ContactReader&&) noexcept;
  ContactReader& operator=(ContactReader&&) noexcept;
  bool Next(ContactFrame& frame) { return NextHeader(frame) && ReadContacts(frame); }
  // In two steps (see FrameReader): the header, then the rows read or skipped.
  bool NextHeader(ContactFrame& frame);
  bool ReadContacts(ContactFrame& frame);
  bool SkipContacts();

 private:
  std::filesystem::path file_;
  std::unique_ptr<detail::DumpState> state_;    // a text dump
  std::unique_ptr<gsd::GsdContactReader> gsd_;  // or a GSD file
};

}  // namespace granary::rundir

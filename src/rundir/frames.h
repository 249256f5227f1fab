// frames.dump: per-disc frames in LAMMPS text dump format (docs/run-directory.md). One
// struct, one writer, one streaming reader; bodies are rebuilt from their discs.
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

struct Disc {
  std::int64_t id = 0;   // disc id (1-based)
  std::int64_t mol = 0;  // body id (0-based, as in events)
  int type = 1;          // species index + 1
  double x = 0.0, y = 0.0, radius = 0.5, mass = 0.0;
  double vx = 0.0, vy = 0.0;  // velocity of the disc centre
  double omega = 0.0;         // the body's angular velocity
};

struct Frame {
  std::int64_t timestep = 0;  // steps since the outlets opened
  double time = 0.0;          // since the outlets opened
  double box[3][2] = {{0, 0}, {0, 0}, {-0.5, 0.5}};
  std::vector<Disc> discs;
};

// A rigid body reconstructed from its discs (docs/model.md "Bodies").
struct Body {
  std::int64_t id = 0;
  int type = 1;
  int n_discs = 0;
  double mass = 0.0;          // sum of disc masses
  double x = 0.0, y = 0.0;    // centre of mass
  double vx = 0.0, vy = 0.0;  // centre-of-mass velocity (mass-weighted disc velocities: exact for a rigid body)
  double omega = 0.0;
  double inertia = 0.0;  // sum m_i |r_i - R|^2 + (2/5) m_i r_i^2 (docs/model.md)
  double theta = 0.0;    // angle of the axis from the lowest-id disc to the highest-id disc, (-pi, pi]; 0 for one disc
  double area = 0.0;     // sum pi r_i^2
};

// Bodies of a frame, ordered by body id.
std::vector<Body> BodiesOf(const std::vector<Disc>& discs);

// The discs of `frame` as a LAMMPS data file (atom_style sphere: id, type, diameter, a density
// that gives each disc its mass under LAMMPS' sphere-volume convention, position), so that
// LAMMPS' `read_data` followed by `rerun` of frames.dump keeps every disc's diameter and mass
// (read_dump cannot read a radius back). docs/run-directory.md "frames.data".
std::string LammpsDataFile(const Frame& frame);

class FrameWriter {
 public:
  FrameWriter() = default;
  // `gzip`: each frame one gzip member (frames.dump.gz; gzip.h). A run's frames file
  // (frames.dump, frames.dump.gz) also gets frames.data beside it at its first frame. A file
  // named *.gsd is written as GSD (gsd.h; `gzip` does not apply).
  static FrameWriter Create(const std::filesystem::path& file, bool gzip = false);
  // The file of an interrupted run cut back to `offset` bytes (what its checkpoint recorded).
  static FrameWriter ContinueAt(const std::filesystem::path& file, std::int64_t offset, bool gzip = false);

  // Appends one frame; NUMBER OF ATOMS is frame.discs.size().
  void Write(const Frame& frame);
  bool IsOpen() const { return gsd_.IsOpen() || file_.IsOpen(); }
  std::int64_t Offset() { return gsd_.IsOpen() ? gsd_.Offset() : file_.Offset(); }
  void Close() {
    gsd_.Close();
    file_.Close();
  }

 private:
  gsd::GsdFrameWriter gsd_;  // open for a *.gsd file
  OutputFile file_;
  std::string text_;  // rows being formatted (kept: its capacity)
  bool gzip_ = false;
  std::filesystem::path data_file_;  // frames.data, written with the first frame; "" = none
};

// The bytes FrameWriter::Write adds to the file for `frame` (gzipped or not); nothing is written.
std::int64_t FrameBytes(const Frame& frame, bool gzip);

// Streams a frames.dump (or a frames.dump.gz, or a frames.gsd, told by their magic bytes). Required columns: id mol x y; optional: type radius mass vx vy
// omegaz (missing radius = 0.5, missing mass = density pi r^2, missing velocities = 0).
// Malformed input throws ReadError with file:line.
class FrameReader {
 public:
  explicit FrameReader(const std::filesystem::path& file, double density = 1.0);
  ~FrameReader();
  FrameReader(FrameReader&&) noexcept;
  FrameReader& operator=(FrameReader&&) noexcept;
  // Reads the next frame into `frame`; false at the end of the file. A frame cut short at the
  // end of the file (an engine still writing) ends the stream without an error.
  bool Next(Frame& frame) { return NextHeader(frame) && ReadDiscs(frame); }
  // The same in two steps, so that a frame nobody wants is skipped without parsing its rows:
  // NextHeader fills timestep, time and box (discs cleared); then ReadDiscs or SkipDiscs.
  bool NextHeader(Frame& frame);
  bool ReadDiscs(Frame& frame);
  bool SkipDiscs();
  const std::filesystem::path& File() const { return file_; }

 private:
  std::filesystem::path file_;
  std::unique_ptr<detail::DumpState> state_;  // a text dump
  std::unique_ptr<gsd::GsdFrameReader> gsd_;  // or a GSD file
  double density_;
};

}  // namespace granary::rundir

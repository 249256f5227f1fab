// The one reader of a run directory (docs/run-directory.md), whichever engine wrote it:
// summary.json, events.csv, frames.dump[.gz] (streamed frame by frame; per-disc rows are grouped
// into bodies with centre of mass, velocity, angular velocity, orientation, mass and moment
// of inertia) and contacts.dump[.gz]. Columns are found by name, so extra columns and keys are
// ignored; malformed input throws ReadError naming the file and the line.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace granary::analysis {

class ReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Summary {
  std::string engine;
  std::string engine_version;
  std::string granary_commit;
  std::string run_id;
  std::string end_reason;          // discharged, clogged, time_limit
  int bodies = 0;
  int exited = 0;
  int remaining = 0;
  std::vector<int> exits_per_outlet;
  double t_end = 0.0;
  nlohmann::json spec;             // the resolved run spec as the engine saw it
  nlohmann::json raw;              // everything, including keys this reader does not know
};
Summary parse_summary(const nlohmann::json& j, const std::string& where);
Summary read_summary(const std::filesystem::path& file);

struct ExitEvent {
  double time = 0.0;
  std::int64_t body = -1;
  std::string shape;
  double mass = 0.0;               // NaN when the file has no mass column
  int outlet = 0;
};
// Sorted by time (engines write them in order; a stable sort guards against ties).
std::vector<ExitEvent> read_events(const std::filesystem::path& file);

struct Disc {
  std::int64_t id = 0;
  std::int64_t mol = 0;            // body id
  int type = 1;
  double x = 0.0, y = 0.0, radius = 0.5, mass = 0.0;
  double vx = 0.0, vy = 0.0, omega = 0.0;
};

// A rigid body reconstructed from its discs (physics.md "Particles").
struct Body {
  std::int64_t id = 0;
  int type = 1;
  int n_discs = 0;
  double mass = 0.0;               // sum of disc masses
  double x = 0.0, y = 0.0;         // centre of mass
  double vx = 0.0, vy = 0.0;       // centre-of-mass velocity (mass-weighted disc velocities: exact for a rigid body)
  double omega = 0.0;
  double inertia = 0.0;            // sum m_i |r_i - R|^2 + (2/5) m_i r_i^2 (physics.md)
  double theta = 0.0;              // angle of the axis from the lowest-id disc to the highest-id disc, (-pi, pi]; 0 for one disc
  double area = 0.0;               // sum pi r_i^2
};

struct Frame {
  std::int64_t timestep = 0;
  double time = 0.0;               // since the outlets opened
  double box[3][2] = {{0, 0}, {0, 0}, {0, 0}};
  std::vector<Disc> discs;
};

// The lines of a text file, gzip-compressed (one or more members, told by the magic bytes) or
// not. Plain files go through std::ifstream: zlib's pass-through reads them 15 % slower.
class LineInput {
 public:
  explicit LineInput(const std::filesystem::path& file);
  ~LineInput();
  LineInput(const LineInput&) = delete;
  LineInput& operator=(const LineInput&) = delete;
  bool is_open() const { return gz_ != nullptr || plain_.is_open(); }
  // The next line without its '\n'; false at the end. eof() is true once a line ended at the
  // end of the file without '\n' (as std::getline sets it).
  bool getline(std::string& line);
  bool eof() const { return gz_ ? eof_ : plain_.eof(); }

 private:
  std::ifstream plain_;
  void* gz_ = nullptr;  // gzFile
  bool eof_ = false;
};

// Bodies of a frame, ordered by body id.
std::vector<Body> bodies_of(const std::vector<Disc>& discs);

// Streams frames.dump or frames.dump.gz. Required columns: id mol x y; optional: type radius mass vx vy omegaz
// (missing radius = 0.5, missing mass = density pi r^2, missing velocities = 0).
class FrameReader {
 public:
  explicit FrameReader(const std::filesystem::path& file, double density = 1.0);
  // Reads the next frame into `frame`; false at the end of the file. A frame cut short at the
  // end of the file (an engine still writing) ends the stream without an error.
  bool next(Frame& frame);
  const std::filesystem::path& file() const { return file_; }

 private:
  [[noreturn]] void fail(const std::string& what) const;
  bool next_line(std::string& line);

  std::filesystem::path file_;
  LineInput in_;
  double density_;
  std::int64_t line_no_ = 0;
};

struct ContactRow {
  std::int64_t body_i = 0, body_j = -1;  // body_j = -1: wall or obstacle
  double xi = 0, yi = 0, xj = 0, yj = 0, cx = 0, cy = 0, fx = 0, fy = 0;
};
struct ContactFrame {
  std::int64_t timestep = 0;
  double time = 0.0;
  std::vector<ContactRow> contacts;
};

class ContactReader {
 public:
  explicit ContactReader(const std::filesystem::path& file);
  bool next(ContactFrame& frame);

 private:
  [[noreturn]] void fail(const std::string& what) const;
  std::filesystem::path file_;
  LineInput in_;
  std::int64_t line_no_ = 0;
};

// What a run directory holds, read eagerly except the (large) dumps.
struct RunData {
  std::filesystem::path dir;
  bool done = false;               // DONE exists
  bool has_summary = false;
  Summary summary;
  nlohmann::json spec;             // run.json if present, else summary.spec
  std::vector<ExitEvent> events;
  bool has_frames = false;
  bool has_contacts = false;
  bool compressed = false;         // frames.dump.gz / contacts.dump.gz (output.compress)
  std::filesystem::path frames_file() const { return dir / (compressed ? "frames.dump.gz" : "frames.dump"); }
  std::filesystem::path contacts_file() const { return dir / (compressed ? "contacts.dump.gz" : "contacts.dump"); }
};
// Throws ReadError if the directory does not exist or a present file is malformed.
RunData read_run(const std::filesystem::path& dir);

}  // namespace granary::analysis

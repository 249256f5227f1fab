// Coarse-grained fields of one run directory: streams frames.dump with the contact frame of
// the same timestep from contacts.dump (when the run wrote one) through a CgAccumulator. The
// window defaults to the silo's (cg_default_window: the spec's width, the bed's height), the
// frames to a time range the caller picks (the flow analysis' steady window, say). Frames
// outside it are skipped without parsing their rows; with two threads or more the two dumps
// of a frame are parsed side by side.
#pragma once

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "analysis/cg_fields.h"
#include "rundir/contacts.h"
#include "rundir/run_directory.h"

namespace granary::analysis {

struct CgRunOptions {
  CgOptions cg;  // cg.window empty: cg_default_window of the run
  double t_start = -std::numeric_limits<double>::infinity();
  double t_end = std::numeric_limits<double>::infinity();  // frames with t_start <= t <= t_end
  int frame_stride = 1;                                    // every n-th frame of the range
  int max_frames = 0;                                      // 0: all
  bool contacts = true;                                    // read contacts.dump if the run has one
  std::vector<CgSeriesRequest> series;
  // Frames in [t_start, t_end] go to the accumulator `route(t)` returns (an index into the
  // result's `parts`, e.g. 0 flowing, 1 clogged); -1 skips the frame. Empty: one part.
  std::function<int(double)> route;
  int parts = 1;
};

struct CgRunResult {
  Rect window;
  std::vector<CgSums> parts;                   // one per route target
  std::vector<CgSeries> series;                // over the frames used (every part), in time order
  int frames_read = 0;                         // frames streamed (in and out of the range)
  bool has_contacts = false;                   // contacts.dump read
  int frames_without_contacts = 0;             // frames used whose timestep had no contact frame
  double first_time = kNaN, last_time = kNaN;  // of the frames used
};

// The contact frame of each frame's timestep, from a contacts.dump read alongside frames.dump
// (contact frames are in the same order: all or some of the frames' timesteps).
class ContactFrameMatcher {
 public:
  explicit ContactFrameMatcher(const std::filesystem::path& contacts_file) : reader_(contacts_file) {}
  // The contact frame of `timestep`, or nullptr; timesteps must not decrease between calls.
  const rundir::ContactFrame* At(std::int64_t timestep);

 private:
  rundir::ContactReader reader_;
  rundir::ContactFrame frame_;
  bool pending_ = false, done_ = false;
};

// The silo's default window: `/silo/width` of the spec and the bed's height from summary.json
// (else the top of the discs of the first frame).
Rect CgRunWindow(const rundir::RunData& data);

// Throws rundir::ReadError on a malformed dump, std::invalid_argument on bad options.
CgRunResult CgFieldsOfRun(const rundir::RunData& data, const CgRunOptions& options);

}  // namespace granary::analysis

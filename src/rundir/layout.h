// The names of the files of a run directory (docs/run-directory.md) and the error every
// reader of them throws. Nothing else in Granary spells these names.
#pragma once

#include <stdexcept>

namespace granary::rundir {

inline constexpr char kRunSpecFile[] = "run.json";                 // runner: the resolved run spec
inline constexpr char kEngineLogFile[] = "engine.log";             // runner: the engine's stdout and stderr
inline constexpr char kProgressFile[] = "progress.json";           // engine, replaced atomically
inline constexpr char kEventsFile[] = "events.csv";                // engine: one row per exit
inline constexpr char kFramesFile[] = "frames.dump";               // engine: per-disc frames
inline constexpr char kContactsFile[] = "contacts.dump";           // engine: contact-force frames
inline constexpr char kClogFramesFile[] = "clog_frames.dump";      // engine: the configuration at every clog
inline constexpr char kClogContactsFile[] = "clog_contacts.dump";  // engine: its contact forces
inline constexpr char kUnclogsFile[] = "unclogs.csv";      // native engine, on_clog "unclog": how each clog was broken
inline constexpr char kFramesGzFile[] = "frames.dump.gz";  // the same, gzip (output.compress)
inline constexpr char kFramesDataFile[] = "frames.data";   // the first frame's discs as a LAMMPS data file (rerun)
inline constexpr char kContactsGzFile[] = "contacts.dump.gz";  // the same, gzip (output.compress)
inline constexpr char kFramesGsdFile[] = "frames.gsd";         // frames as GSD (output.format "gsd")
inline constexpr char kContactsGsdFile[] = "contacts.gsd";     // contact frames as GSD (output.format "gsd")
inline constexpr char kSiloFile[] = "silo.vtk";                // engine: walls, outlets, obstacles (OVITO)
inline constexpr char kSummaryFile[] = "summary.json";         // engine: what happened
inline constexpr char kDoneFile[] = "DONE";                    // engine, last: every other file is complete
inline constexpr char kSlurmTaskFile[] = "slurm-task.json";    // Slurm batch script: its task, start, exit status

// A run-directory file that is missing, malformed or truncated where it must not be; the
// message names the file (and the line, for text files).
class ReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace granary::rundir

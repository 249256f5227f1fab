// A run directory as a whole (docs/run-directory.md): run.json, the completion marker DONE,
// and what an analysis needs to start (everything except the large dumps, which are streamed
// by FrameReader and ContactReader).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "rundir/events.h"
#include "rundir/unclogs.h"
#include "rundir/layout.h"
#include "rundir/run_spec.h"
#include "rundir/summary.h"

namespace granary::rundir {

// Writes DIR/run.json atomically (creating DIR); an identical file is left untouched, so an
// engine reading it never sees it change under it.
void WriteRunSpec(const std::filesystem::path& dir, const nlohmann::json& spec);
// DIR/run.json as JSON, not validated (analyses read specs of any age); throws ReadError.
nlohmann::json ReadRunSpecJson(const std::filesystem::path& dir);
// DIR/run.json parsed and validated: throws ReadError (missing, not JSON) or SpecError whose
// message ends with the file's name.
RunSpec ReadRunSpec(const std::filesystem::path& dir);

// The engine's last act, and the one call a backend needs to end a run: records what the run
// directory holds in DIR/manifest.json (WriteManifest, manifest.h: sizes, checksums, counts)
// and then writes DIR/DONE holding the end reason. Call it after every output is closed.
void WriteDone(const std::filesystem::path& dir, const std::string& end_reason);
bool IsDone(const std::filesystem::path& dir);

// The names of the frames and contact-frame files an engine writes for these options.
const char* FramesFileName(const Output& output);
const char* ContactsFileName(const Output& output);

// What a run directory holds, read eagerly except the dumps.
struct RunData {
  std::filesystem::path dir;
  bool done = false;  // DONE exists
  bool has_summary = false;
  Summary summary;
  nlohmann::json spec;  // run.json if present, else summary.spec
  std::vector<ExitEvent> events;
  std::vector<UnclogEvent> unclogs;  // unclogs.csv (on_clog "unclog"); none without the file
  bool has_frames = false;
  bool has_contacts = false;
  bool compressed = false;  // frames.dump.gz / contacts.dump.gz (output.compress)
  bool gsd = false;         // frames.gsd / contacts.gsd (output.format "gsd")
  // Why the frames are gone, when campaign clean --frames removed them (manifest.json
  // "dropped"): a sentence for the error of an analysis that would need them; "" otherwise.
  std::string frames_dropped;
  std::filesystem::path FramesFile() const {
    return dir / (gsd ? kFramesGsdFile : compressed ? kFramesGzFile : kFramesFile);
  }
  std::filesystem::path ContactsFile() const {
    return dir / (gsd ? kContactsGsdFile : compressed ? kContactsGzFile : kContactsFile);
  }
};
// Throws ReadError if the directory does not exist or a present file is malformed.
RunData ReadRun(const std::filesystem::path& dir);

// The frames and contact frames of the run in `dir` (any format) written as LAMMPS text dumps
// into `out` (created): frames.dump with its frames.data, and contacts.dump if the run has
// contact frames, for LAMMPS' read_dump/rerun and other tools that read no GSD. `out` must
// not be `dir` (a run directory holds one frames file). Throws ReadError if the run has no
// frames.
struct TextDumps {
  std::int64_t frames = 0, contact_frames = 0, bytes = 0;
};
TextDumps WriteTextDumps(const std::filesystem::path& dir, const std::filesystem::path& out);

}  // namespace granary::rundir

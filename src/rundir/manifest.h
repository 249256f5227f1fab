// manifest.json: what an engine wrote, recorded when it finished (docs/run-directory.md
// "manifest.json"), and the check of a run directory against it. Per file: its size, an
// XXH3-64 checksum and what it counts (frames, event rows, clogs). A run whose files differ
// from their record — cut, grown, rewritten, missing — is damaged, and every reader of the
// run (the analysis pass, the report, the export, status, show, scan --verify) says so and
// keeps it out of every number. One writer (WriteManifest, called by WriteDone), one reader
// (ReadManifest) and the check (VerifyRun).
//
// XXH3-64 (Debian's libxxhash) rather than a CRC-32: one 256 MiB buffer hashed side by side
// ran XXH3-64 at 4.8 times zlib's crc32 and 40 times the byte-wise CRC-32 of files.h
// (docs/run-directory.md has the figures), so checking a run's multi-GB frames costs about
// the time of reading them, not a computation several times longer on top.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace granary::rundir {

inline constexpr char kManifestFile[] = "manifest.json";
inline constexpr int kManifestFormat = 1;

// One file as the engine left it.
struct ManifestFile {
  std::uint64_t size = 0;
  std::string xxh3;         // 16 lower-case hex digits of XXH3-64 over the file's bytes
  std::int64_t count = -1;  // frames (dumps), rows (events.csv), clogs (clog files); -1: not counted
};

// A file removed on purpose after the run (campaign clean --frames): its record as it was,
// when and by what. Checks no longer look for it; readers say why it is gone.
struct DroppedFile {
  ManifestFile record;
  std::string at;  // UTC, ISO 8601
  std::string by;  // "campaign clean --frames"
};

struct Manifest {
  int format = kManifestFormat;
  std::map<std::string, ManifestFile> files;   // by name in the run directory (layout.h)
  std::map<std::string, DroppedFile> dropped;  // by name: files removed since the run
  // The counts of the files above, by what they count: "frames", "contact_frames", "events", "clogs".
  std::map<std::string, std::int64_t> counts;
};

// What count a file of the run directory has, and the name of that count ("" if none).
std::string CountNameOf(const std::string& file);

// The record of every output file present in DIR (run.json, summary.json, events.csv, the
// frame and contact dumps, plain or gzip, and the clog files), hashed and counted through
// their readers. Throws ReadError if a present file is malformed.
Manifest MakeManifest(const std::filesystem::path& dir);
// Writes DIR/manifest.json atomically from MakeManifest. WriteDone (run_directory.h) calls
// it before DONE, so an engine's only obligation is to call WriteDone last.
void WriteManifest(const std::filesystem::path& dir);
// DIR/manifest.json; nothing if absent (a run written before manifests). Throws ReadError if
// it is present and malformed or of a later format.
std::optional<Manifest> ReadManifest(const std::filesystem::path& dir);

// Moves the record of DIR/`name` from "files" to "dropped" (with the time and `by`) in
// DIR/manifest.json, for a file about to be removed on purpose. Throws ReadError if the run
// has no manifest or it does not record the file.
void RecordDropped(const std::filesystem::path& dir, const std::string& name, const std::string& by);

// XXH3-64 of a whole file, 16 hex digits; throws ReadError if it cannot be read.
std::string FileXxh3(const std::filesystem::path& file);

// What a check found.
enum class Integrity {
  kWhole,          // every file matches its record (as far as checked)
  kDamaged,        // a file differs from its record, or from another file (events vs summary)
  kNotVerifiable,  // no manifest.json (written before manifests): the cheap checks only
  kNotDone,        // no DONE: nothing to check yet
};
const char* IntegrityName(Integrity integrity);  // "whole", "damaged", "not verifiable", "not finished"

struct FileProblem {
  std::string file;  // as named in the run directory
  std::string what;  // "1234 bytes, the manifest records 5678"
};

struct Verification {
  Integrity integrity = Integrity::kNotDone;
  std::vector<FileProblem> problems;  // damaged: what differs (at least one)
  int files_hashed = 0;               // checksums computed by this check (the others were cached)
  // "frames.dump: 1234 bytes, the manifest records 5678; events.csv: ..." ("" when whole).
  std::string Text() const;
};

enum class VerifyLevel {
  kSizes,      // manifest present, sizes, summary.json readable: stat and one small file; and the
               //   checksum of a file found whole before whose mtime changed since (status)
  kCached,     // + events.csv rows against the manifest and summary.json; checksums and counts of
               //   the files whose size or mtime changed since they were last verified (the pass)
  kChecksums,  // + every checksum and count, whatever was verified before (scan --verify)
};

struct VerifyOptions {
  VerifyLevel level = VerifyLevel::kCached;
  // Remember what was verified in DIR/analyses/verified.json (skipped where DIR is read-only).
  bool write_cache = true;
};

// Checks DIR against its manifest (docs/run-directory.md "manifest.json"). Never throws for
// a damaged directory (that is the answer); throws only if DIR does not exist.
Verification VerifyRun(const std::filesystem::path& dir, const VerifyOptions& options = {});

}  // namespace granary::rundir

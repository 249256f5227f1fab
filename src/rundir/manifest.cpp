// See manifest.h.
#include "rundir/manifest.h"

#include <sys/stat.h>
#include <xxhash.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "rundir/analysis_cache.h"
#include "rundir/contacts.h"
#include "rundir/events.h"
#include "rundir/files.h"
#include "rundir/frames.h"
#include "rundir/layout.h"
#include "rundir/run_directory.h"
#include "rundir/summary.h"
#include "rundir/unclogs.h"

namespace granary::rundir {
namespace fs = std::filesystem;

namespace {

// The files a manifest records, in the order it lists them.
constexpr const char* kRecorded[] = {kRunSpecFile,     kSummaryFile,    kEventsFile,       kFramesFile,
                                     kFramesGzFile,    kFramesGsdFile,  kContactsFile,     kContactsGzFile,
                                     kContactsGsdFile, kClogFramesFile, kClogContactsFile, kUnclogsFile};

// DIR/analyses/verified.json: the files found equal to their record, by size and mtime, so
// that a second check hashes only what changed since (manifest.h). Kept beside the cached
// analyses: deleting the folder only costs time.
constexpr char kVerifiedFile[] = "verified.json";

struct Stat {
  bool exists = false;
  std::uint64_t size = 0;
  std::int64_t mtime_ns = 0;
};

Stat StatOf(const fs::path& file) {
  struct stat st {};
  Stat s;
  if (::stat(file.c_str(), &st) != 0) return s;
  s.exists = true;
  s.size = static_cast<std::uint64_t>(st.st_size);
  s.mtime_ns = static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
  return s;
}

std::string Hex(std::uint64_t v) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(v));
  return text;
}

// What a file of the run directory counts, through its reader; -1 if it counts nothing.
// `lenient`: a block cut mid-line ends the count (a damaged file: how much is left) instead
// of throwing.
std::int64_t CountOf(const fs::path& dir, const std::string& name, bool lenient = false) {
  const fs::path file = dir / name;
  std::int64_t n = 0;
  try {
    if (name == kEventsFile) return static_cast<std::int64_t>(ReadEvents(file).size());
    if (name == kUnclogsFile) return static_cast<std::int64_t>(ReadUnclogs(file).size());
    if (name == kFramesFile || name == kFramesGzFile || name == kFramesGsdFile || name == kClogFramesFile) {
      FrameReader reader(file);
      Frame frame;
      while (reader.NextHeader(frame) && reader.SkipDiscs()) ++n;
      return n;
    }
    if (name == kContactsFile || name == kContactsGzFile || name == kContactsGsdFile || name == kClogContactsFile) {
      ContactReader reader(file);
      ContactFrame frame;
      while (reader.NextHeader(frame) && reader.SkipContacts()) ++n;
      return n;
    }
  } catch (const ReadError&) {
    if (!lenient || name == kEventsFile || name == kUnclogsFile) throw;
    return n;
  }
  return -1;
}

std::string Plural(std::int64_t n, const std::string& what) {
  return std::to_string(n) + " " + what + (n == 1 ? "" : "s");
}

// "frames" -> "frame" etc.: how one unit of a file's count reads.
std::string UnitOf(const std::string& name) {
  const std::string count = CountNameOf(name);
  if (count == "events" || count == "unclog_attempts") return "row";
  if (count == "clogs") return "clog";
  return "frame";
}

nlohmann::json ReadVerified(const fs::path& dir) {
  std::ifstream in(dir / kAnalysesDir / kVerifiedFile);
  if (!in) return nlohmann::json::object();
  nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  return j.is_object() ? j : nlohmann::json::object();
}

}  // namespace

std::string CountNameOf(const std::string& file) {
  if (file == kEventsFile) return "events";
  if (file == kFramesFile || file == kFramesGzFile || file == kFramesGsdFile) return "frames";
  if (file == kContactsFile || file == kContactsGzFile || file == kContactsGsdFile) return "contact_frames";
  if (file == kClogFramesFile || file == kClogContactsFile) return "clogs";
  if (file == kUnclogsFile) return "unclog_attempts";
  return "";
}

std::string FileXxh3(const fs::path& file) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(file.c_str(), "rb"), &std::fclose);
  if (!f) throw ReadError(file.string() + ": cannot open: " + std::strerror(errno));
  std::unique_ptr<XXH3_state_t, XXH_errorcode (*)(XXH3_state_t*)> state(XXH3_createState(), &XXH3_freeState);
  XXH3_64bits_reset(state.get());
  std::vector<char> buffer(std::size_t{1} << 20);
  for (;;) {
    const std::size_t n = std::fread(buffer.data(), 1, buffer.size(), f.get());
    if (n > 0) XXH3_64bits_update(state.get(), buffer.data(), n);
    if (n < buffer.size()) break;
  }
  if (std::ferror(f.get())) throw ReadError(file.string() + ": read error: " + std::strerror(errno));
  return Hex(XXH3_64bits_digest(state.get()));
}

Manifest MakeManifest(const fs::path& dir) {
  Manifest m;
  for (const char* name : kRecorded) {
    const Stat st = StatOf(dir / name);
    if (!st.exists) continue;
    ManifestFile f;
    f.size = st.size;
    f.xxh3 = FileXxh3(dir / name);
    f.count = CountOf(dir, name);
    m.files[name] = f;
    const std::string count = CountNameOf(name);
    // Both clog files count the same clogs; either holds the figure.
    if (!count.empty()) m.counts[count] = f.count;
  }
  return m;
}

void WriteManifest(const fs::path& dir) {
  const Manifest m = MakeManifest(dir);
  nlohmann::ordered_json j;
  j["format"] = m.format;
  j["checksum"] = "xxh3-64";
  nlohmann::ordered_json files = nlohmann::ordered_json::object();
  for (const char* name : kRecorded) {
    const auto it = m.files.find(name);
    if (it == m.files.end()) continue;
    nlohmann::ordered_json f = {{"size", it->second.size}, {"xxh3", it->second.xxh3}};
    if (it->second.count >= 0) f[CountNameOf(name)] = it->second.count;
    files[name] = f;
  }
  j["files"] = files;
  j["counts"] = m.counts;
  WriteAtomically(dir / kManifestFile, j.dump(2) + "\n");
}

std::optional<Manifest> ReadManifest(const fs::path& dir) {
  const fs::path file = dir / kManifestFile;
  std::ifstream in(file);
  if (!in) {
    if (!fs::exists(file)) return std::nullopt;
    throw ReadError(file.string() + ": cannot open");
  }
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw ReadError(file.string() + ": not valid JSON: " + e.what());
  }
  Manifest m;
  try {
    if (!j.is_object() || !j.contains("files") || !j.at("files").is_object())
      throw ReadError(file.string() + ": not a manifest (no \"files\" object)");
    m.format = j.value("format", 0);
    if (m.format < 1 || m.format > kManifestFormat)
      throw ReadError(file.string() + ": manifest format " + std::to_string(m.format) + "; this Granary reads 1 to " +
                      std::to_string(kManifestFormat));
    for (const auto& [name, f] : j.at("files").items()) {
      ManifestFile r;
      r.size = f.at("size").get<std::uint64_t>();
      r.xxh3 = f.at("xxh3").get<std::string>();
      const std::string count = CountNameOf(name);
      if (!count.empty() && f.contains(count)) r.count = f.at(count).get<std::int64_t>();
      m.files[name] = r;
    }
    if (j.contains("counts")) m.counts = j.at("counts").get<std::map<std::string, std::int64_t>>();
    if (j.contains("dropped"))
      for (const auto& [name, f] : j.at("dropped").items()) {
        DroppedFile d;
        d.record.size = f.at("size").get<std::uint64_t>();
        d.record.xxh3 = f.at("xxh3").get<std::string>();
        d.at = f.value("at", "");
        d.by = f.value("by", "");
        m.dropped[name] = d;
      }
  } catch (const nlohmann::json::exception& e) {
    throw ReadError(file.string() + ": " + e.what());
  }
  return m;
}

void RecordDropped(const fs::path& dir, const std::string& name, const std::string& by) {
  const fs::path file = dir / kManifestFile;
  nlohmann::ordered_json j;
  try {
    j = nlohmann::ordered_json::parse(ReadWholeFile(file));
  } catch (const std::exception& e) {
    throw ReadError(file.string() + ": cannot record " + name + " as dropped: " + e.what());
  }
  if (!j.contains("files") || !j["files"].contains(name))
    throw ReadError(file.string() + ": records no " + name + " to drop");
  nlohmann::ordered_json record = j["files"][name];
  j["files"].erase(name);
  const std::time_t now = std::time(nullptr);
  char at[32];
  std::strftime(at, sizeof at, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  record["at"] = at;
  record["by"] = by;
  j["dropped"][name] = record;
  WriteAtomically(file, j.dump(2) + "\n");
}

const char* IntegrityName(Integrity integrity) {
  switch (integrity) {
    case Integrity::kWhole: return "whole";
    case Integrity::kDamaged: return "damaged";
    case Integrity::kNotVerifiable: return "not verifiable";
    case Integrity::kNotDone: return "not finished";
  }
  return "?";
}

std::string Verification::Text() const {
  std::string out;
  for (const FileProblem& p : problems) out += (out.empty() ? "" : "; ") + p.file + ": " + p.what;
  return out;
}

Verification VerifyRun(const fs::path& dir, const VerifyOptions& options) {
  if (!fs::is_directory(dir)) throw ReadError(dir.string() + ": run directory does not exist");
  Verification v;
  if (!IsDone(dir)) return v;
  auto problem = [&](const std::string& file, const std::string& what) { v.problems.push_back({file, what}); };

  std::optional<Summary> summary;
  if (fs::exists(dir / kSummaryFile)) {
    try {
      summary = ReadSummary(dir / kSummaryFile);
    } catch (const ReadError& e) {
      std::string what = e.what();
      const std::string prefix = (dir / kSummaryFile).string() + ": ";
      if (what.rfind(prefix, 0) == 0) what = what.substr(prefix.size());
      problem(kSummaryFile, what);
    }
  }
  std::optional<Manifest> manifest;
  try {
    manifest = ReadManifest(dir);
  } catch (const ReadError& e) {
    problem(kManifestFile, e.what());
  }

  // Sizes: a stat per file.
  std::map<std::string, Stat> stats;
  std::map<std::string, bool> size_ok;
  if (manifest) {
    for (const auto& [name, rec] : manifest->files) {
      const Stat st = StatOf(dir / name);
      stats[name] = st;
      size_ok[name] = st.exists && st.size == rec.size;
      if (!st.exists) {
        problem(name, "missing (the manifest records " + std::to_string(rec.size) + " bytes)");
      } else if (st.size != rec.size) {
        problem(name, std::to_string(st.size) + " bytes, the manifest records " + std::to_string(rec.size) +
                          (st.size < rec.size ? " (cut short)" : " (grown)"));
      }
    }
    if (summary && !manifest->files.count(kSummaryFile)) problem(kSummaryFile, "present, but not in the manifest");
  } else if (!v.problems.empty() || !summary) {
    // no manifest to go by: only the cross-checks below
  }

  if (options.level != VerifyLevel::kSizes) {
    // events.csv against summary.json (any run, manifest or not) and against the manifest.
    const fs::path events_file = dir / kEventsFile;
    if (fs::exists(events_file)) {
      try {
        const std::int64_t rows = static_cast<std::int64_t>(ReadEvents(events_file).size());
        if (summary && rows != summary->exited)
          problem(kEventsFile,
                  Plural(rows, "row") + ", summary.json says " + std::to_string(summary->exited) + " bodies exited");
        if (manifest) {
          const auto it = manifest->files.find(kEventsFile);
          if (it != manifest->files.end() && it->second.count >= 0 && it->second.count != rows)
            problem(kEventsFile, Plural(rows, "row") + ", the manifest records " + std::to_string(it->second.count));
        }
      } catch (const ReadError& e) {
        problem(kEventsFile, e.what());
      }
    } else if (summary && summary->exited > 0 && !(manifest && manifest->files.count(kEventsFile))) {
      problem(kEventsFile, "missing, summary.json says " + std::to_string(summary->exited) + " bodies exited");
    }
  }

  // Checksums and counts: of the files whose size or mtime changed since they were last found
  // whole (all of them for kChecksums), and of the cut ones to say how much is left. kSizes
  // hashes only a file found whole before whose mtime changed since (changed in place after a
  // report verified it); a file never verified is left to the first report.
  {
    if (manifest) {
      nlohmann::json verified = ReadVerified(dir);
      const std::string manifest_hash = FileXxh3(dir / kManifestFile);
      if (verified.value("manifest", std::string()) != manifest_hash) verified = {{"manifest", manifest_hash}};
      if (!verified.contains("files") || !verified.at("files").is_object())
        verified["files"] = nlohmann::json::object();
      bool changed = false;
      for (const auto& [name, rec] : manifest->files) {
        const Stat& st = stats[name];
        if (!st.exists) continue;
        nlohmann::json& known = verified["files"][name];
        // The last check's answer for this very file (same size and mtime): whole, or damaged
        // with what differed.
        const bool recorded = known.is_object() && known.value("size", std::uint64_t{0}) == st.size &&
                              known.value("mtime_ns", std::int64_t{0}) == st.mtime_ns;
        const bool recorded_damaged = recorded && known.contains("damaged");
        if (options.level != VerifyLevel::kChecksums && size_ok[name] && recorded) {
          if (recorded_damaged)
            for (const auto& what : known.at("damaged")) problem(name, what.get<std::string>());
          continue;
        }
        if (options.level == VerifyLevel::kSizes && (!size_ok[name] || !known.is_object())) continue;
        const std::size_t first_problem = v.problems.size();
        bool whole = size_ok[name];
        if (size_ok[name]) {
          std::string sum;
          try {
            sum = FileXxh3(dir / name);
          } catch (const ReadError& e) {
            problem(name, e.what());
            whole = false;
          }
          ++v.files_hashed;
          if (whole && sum != rec.xxh3) {
            problem(name, "checksum " + sum + ", the manifest records " + rec.xxh3 + " (changed in place)");
            whole = false;
          }
        }
        if (rec.count >= 0 && name != kEventsFile) {
          try {
            const std::int64_t n = CountOf(dir, name, !size_ok[name]);
            if (n != rec.count) {
              problem(name, Plural(n, UnitOf(name)) + " readable, the manifest records " + std::to_string(rec.count));
              whole = false;
            }
          } catch (const ReadError& e) {
            problem(name, e.what());
            whole = false;
          }
        }
        known = {{"size", st.size}, {"mtime_ns", st.mtime_ns}};
        if (!whole) {
          nlohmann::json found = nlohmann::json::array();
          for (std::size_t k = first_problem; k < v.problems.size(); ++k) found.push_back(v.problems[k].what);
          known["damaged"] = found;
        }
        changed = true;
      }
      if (changed && options.write_cache) {
        try {
          fs::create_directories(dir / kAnalysesDir);
          WriteAtomically(dir / kAnalysesDir / kVerifiedFile, verified.dump() + "\n", Durability::kVisible);
        } catch (const std::exception&) {
          // A run directory we may not write: verified again next time.
        }
      }
    }
  }
  v.integrity = !v.problems.empty() ? Integrity::kDamaged : manifest ? Integrity::kWhole : Integrity::kNotVerifiable;
  return v;
}

}  // namespace granary::rundir

// See run_directory.h.
#include "rundir/run_directory.h"

#include <fstream>

#include "rundir/contacts.h"
#include "rundir/files.h"
#include "rundir/frames.h"
#include "rundir/manifest.h"

namespace granary::rundir {
namespace fs = std::filesystem;

void WriteRunSpec(const fs::path& dir, const nlohmann::json& spec) {
  fs::create_directories(dir);
  const fs::path file = dir / kRunSpecFile;
  const std::string text = spec.dump(2) + "\n";
  if (fs::exists(file)) {
    try {
      if (ReadWholeFile(file) == text) return;
    } catch (const std::exception&) {
      // unreadable: replace it
    }
  }
  WriteAtomically(file, text);
}

nlohmann::json ReadRunSpecJson(const fs::path& dir) {
  const fs::path file = dir / kRunSpecFile;
  std::ifstream in(file);
  if (!in) throw ReadError(file.string() + ": cannot open");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw ReadError(file.string() + ": not valid JSON: " + e.what());
  }
}

RunSpec ReadRunSpec(const fs::path& dir) {
  const nlohmann::json j = ReadRunSpecJson(dir);
  try {
    return RunSpec::FromJson(j);
  } catch (const SpecError& e) {
    throw SpecError(e.Path(), e.Message() + " [" + (dir / kRunSpecFile).string() + "]");
  }
}

void WriteDone(const fs::path& dir, const std::string& end_reason) {
  WriteManifest(dir);
  WriteAtomically(dir / kDoneFile, end_reason + "\n");
}

bool IsDone(const fs::path& dir) { return fs::exists(dir / kDoneFile); }

RunData ReadRun(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw ReadError(dir.string() + ": run directory does not exist");
  RunData r;
  r.dir = dir;
  r.done = IsDone(dir);
  if (fs::exists(dir / kSummaryFile)) {
    r.summary = ReadSummary(dir / kSummaryFile);
    r.has_summary = true;
  }
  if (fs::exists(dir / kRunSpecFile)) {
    r.spec = ReadRunSpecJson(dir);
  } else if (r.has_summary) {
    r.spec = r.summary.spec;
  }
  if (fs::exists(dir / kEventsFile)) r.events = ReadEvents(dir / kEventsFile);
  r.unclogs = ReadUnclogs(dir / kUnclogsFile);
  r.compressed = !fs::exists(dir / kFramesFile) && fs::exists(dir / kFramesGzFile);
  r.gsd = !fs::exists(dir / kFramesFile) && !r.compressed &&
          (fs::exists(dir / kFramesGsdFile) || fs::exists(dir / kContactsGsdFile));
  r.has_frames = fs::exists(r.FramesFile());
  r.has_contacts = fs::exists(r.ContactsFile());
  if (!r.has_frames) {
    std::optional<Manifest> m;
    try {
      m = ReadManifest(dir);
    } catch (const ReadError&) {
      // A damaged manifest is the integrity check's to report, not this reader's.
    }
    for (const char* name : {kFramesFile, kFramesGzFile, kFramesGsdFile})
      if (m && m->dropped.count(name)) {
        const DroppedFile& d = m->dropped.at(name);
        r.frames_dropped =
            (dir / name).string() + " was removed by " + d.by + " at " + d.at +
            " (manifest.json \"dropped\"): the analyses cached before then still report, but one that "
            "must read the frames anew (new options, a new analysis or version) cannot; run the run again";
      }
  }
  return r;
}

const char* FramesFileName(const Output& output) {
  if (output.format == FrameFormat::kGsd) return kFramesGsdFile;
  return output.compress ? kFramesGzFile : kFramesFile;
}

const char* ContactsFileName(const Output& output) {
  if (output.format == FrameFormat::kGsd) return kContactsGsdFile;
  return output.compress ? kContactsGzFile : kContactsFile;
}

TextDumps WriteTextDumps(const fs::path& dir, const fs::path& out) {
  const RunData run = ReadRun(dir);
  if (!run.has_frames)
    throw ReadError(run.FramesFile().string() +
                    ": no such file (the run writes frames when its spec sets "
                    "output/frame_interval)");
  if (fs::exists(out) && fs::equivalent(out, dir))
    throw ReadError(out.string() + ": is the run directory itself; the text dumps go to another folder");
  fs::create_directories(out);
  TextDumps n;
  {
    FrameReader in(run.FramesFile());
    FrameWriter w = FrameWriter::Create(out / kFramesFile);
    for (Frame f; in.Next(f); ++n.frames) w.Write(f);
    w.Close();
  }
  n.bytes = static_cast<std::int64_t>(fs::file_size(out / kFramesFile) + fs::file_size(out / kFramesDataFile));
  if (run.has_contacts) {
    ContactReader in(run.ContactsFile());
    ContactWriter w = ContactWriter::Create(out / kContactsFile);
    for (ContactFrame c; in.Next(c); ++n.contact_frames) w.Write(c);
    w.Close();
    n.bytes += static_cast<std::int64_t>(fs::file_size(out / kContactsFile));
  }
  return n;
}

}  // namespace granary::rundir

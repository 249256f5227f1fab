// campaign dump: a run's frames (GSD or text) as LAMMPS text dumps, for LAMMPS' read_dump and
// rerun (which read no GSD) and any tool that wants text (docs/run-directory.md "Binary frames").
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "rundir/run_directory.h"
#include "runner/cli/common.h"
#include "runner/inspect.h"

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char kDumpHelp[] =
    "usage: campaign dump RUN_DIR [--out DIR] [--json]\n"
    "Write the frames of a run directory (frames.gsd, or the text dumps) as LAMMPS text dumps:\n"
    "DIR/frames.dump with DIR/frames.data (read_data, then rerun or read_dump, as\n"
    "docs/run-directory.md shows) and DIR/contacts.dump when the run has contact frames.\n"
    "  --out DIR   where (default RUN_DIR/text); never the run directory itself\n"
    "  --json      {frames, contact_frames, bytes, out}\n"
    "Exit: 0, 1 the run has no frames or a file cannot be read, 2 usage error.\n";

int Dump(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "dump");
  if (a.positional.size() != 1) throw UsageError("campaign dump: give one run directory: campaign dump RUN_DIR");
  const fs::path dir = a.positional[0];
  if (!fs::is_directory(dir)) throw UsageError("campaign dump: " + dir.string() + " is not a run directory");
  const fs::path to = a.Has("out") ? fs::path(a.Get("out", "")) : dir / "text";
  rundir::TextDumps n;
  try {
    n = rundir::WriteTextDumps(dir, to);
  } catch (const rundir::ReadError& e) {
    err << "campaign dump: " << e.what() << "\n";
    return 1;
  }
  if (a.Has("json")) {
    out << json{{"frames", n.frames}, {"contact_frames", n.contact_frames}, {"bytes", n.bytes}, {"out", to.string()}}
               .dump(2)
        << "\n";
    return 0;
  }
  out << "campaign dump: " << n.frames << " frame(s)";
  if (n.contact_frames > 0) out << " and " << n.contact_frames << " contact frame(s)";
  out << " as text, " << HumanBytes(static_cast<std::uintmax_t>(n.bytes)) << " in " << to.string() << "\n"
      << "  LAMMPS: read_data frames.data, then rerun frames.dump (the input in docs/run-directory.md, \"frames.data\")\n";
  return 0;
}

}  // namespace

Verb DumpVerb() {
  return {"dump", "a run's frames (GSD or text) as LAMMPS text dumps", kDumpHelp,
          Dump,   {{"out", true}, {"json", false}, {"help", false}},   Operand::kFile};
}

}  // namespace granary::runner::cli

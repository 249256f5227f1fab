// `campaign fields`, `snapshot` and `movie`: one run's frames as maps and pictures. Flags in docs/cli.md.

#include <unistd.h>

#include <chrono>
#include <optional>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "rundir/files.h"
#include "runner/campaign_db.h"
#include "runner/cli/common.h"
#include "runner/util.h"
#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/cg_run.h"
#include "rundir/contacts.h"
#include "rundir/frames.h"
#endif
#ifdef GRANARY_HAVE_RENDER
#include "render/run_picture.h"
#endif

namespace granary::runner::cli {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char kFieldsHelp[] =
    "usage: campaign fields RUN_DIR [--out DIR] [--fields NAMES] [--from T] [--to T] [--stride N]\n"
    "                       [--max-frames N] [--width W] [--cutoff C] [--spacing H]\n"
    "                       [--window X0,X1,Y0,Y1] [--min-phi F] [--threads N] [--json]\n"
    "       campaign fields RUN_DIR --bench [--repeat N] [--threads-list 1,2] [--max-frames N]\n"
    "Coarse-grained fields of one run directory (docs/analyses.md), time-averaged over its frames\n"
    "from T to T: one CSV per field in DIR (default RUN_DIR/fields) with columns x, y, value,\n"
    "n_frames (the frames behind the value). Stress fields need the run's contacts.dump\n"
    "(output.contact_forces).\n"
    "  --fields NAMES    comma-separated (default: all the run's data supports): phi vx vy speed\n"
    "                    omega omega_fl2 tg tg_eq46 sigma_xx sigma_xy sigma_yy pressure shear\n"
    "                    friction kinetic_pressure kinetic_shear total_pressure total_shear\n"
    "                    total_friction\n"
    "  --width W         kernel width w in d (default 1.414); --cutoff C in w (default 3)\n"
    "  --spacing H       grid spacing in d (default 1)\n"
    "  --window ...      the mapped rectangle (default: 1.5 d inside the walls, from 1.5 d above\n"
    "                    the base to min(148.5 d, the bed's height))\n"
    "  --min-phi F       velocity, Omega and T_g of a frame need phi >= F at a node (default 0.05)\n"
    "  --threads N       threads (default: all cores; any count gives the same bits)\n"
    "  --json            print the run's summary as JSON\n"
    "  --bench           frames per second over the run's frames, reading the dumps included:\n"
    "                    reading alone, then the fields at each thread count of --threads-list,\n"
    "                    in --repeat interleaved rounds (best and median); run it under\n"
    "                    `cpu bench` on a shared machine\n"
    "Exit: 0 done, 1 unreadable run directory, 2 usage error.\n";

#ifdef GRANARY_HAVE_ANALYSIS
std::vector<double> NumberList(const std::string& flag, const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      std::size_t used = 0;
      const double x = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(x)) throw std::invalid_argument(item);
      out.push_back(x);
    } catch (const std::exception&) {
      throw UsageError("--" + flag + ": \"" + item + "\" is not a number (got \"" + text + "\")");
    }
  }
  return out;
}

analysis::CgRunOptions FieldOptions(const Args& a) {
  analysis::CgRunOptions o;
  o.cg.width = a.Number("width", o.cg.width);
  o.cg.cutoff = a.Number("cutoff", o.cg.cutoff);
  o.cg.spacing = a.Number("spacing", o.cg.spacing);
  o.cg.min_phi = a.Number("min-phi", o.cg.min_phi);
  o.cg.threads = a.Integer("threads", 0, 0);
  if (a.Has("window")) {
    const auto w = NumberList("window", a.Get("window", ""));
    if (w.size() != 4 || !(w[1] > w[0]) || !(w[3] >= w[2]))
      throw UsageError("--window: needs X0,X1,Y0,Y1 with X0 < X1 and Y0 <= Y1 (got \"" + a.Get("window", "") + "\")");
    o.cg.window = {w[0], w[1], w[2], w[3]};
  }
  o.t_start = a.Number("from", o.t_start);
  o.t_end = a.Number("to", o.t_end);
  o.frame_stride = a.Integer("stride", 1, 1);
  o.max_frames = a.Integer("max-frames", 0, 0);
  return o;
}

// `campaign fields --bench`: frames per second, reading alone and the fields per thread count.
int FieldsBench(const rundir::RunData& data, const Args& a, std::ostream& out) {
  analysis::CgRunOptions o = FieldOptions(a);
  const int repeat = a.Integer("repeat", 3, 1);
  std::vector<int> threads;
  for (double t : NumberList("threads-list", a.Get("threads-list", "1,2"))) {
    if (t < 1 || t != std::floor(t)) throw UsageError("--threads-list: thread counts are integers >= 1");
    threads.push_back(static_cast<int>(t));
  }
  const int limit = o.max_frames;
  auto read_only = [&]() {
    rundir::FrameReader frames(data.FramesFile());
    std::optional<rundir::ContactReader> contacts;
    if (data.has_contacts) contacts.emplace(data.ContactsFile());
    rundir::Frame f;
    rundir::ContactFrame c;
    int n = 0;
    while ((limit == 0 || n < limit) && frames.Next(f)) {
      if (contacts) contacts->Next(c);
      ++n;
    }
    return n;
  };
  std::map<std::string, std::vector<double>> rates;
  std::vector<std::string> order = {"read"};
  for (int t : threads) order.push_back("fields, " + std::to_string(t) + (t == 1 ? " thread" : " threads"));
  int frames = 0;
  std::size_t nodes = 0, contacts_per_frame = 0, discs_per_frame = 0;
  {
    rundir::FrameReader fr(data.FramesFile());
    rundir::Frame f;
    if (fr.Next(f)) discs_per_frame = f.discs.size();
    if (data.has_contacts) {
      rundir::ContactReader cr(data.ContactsFile());
      rundir::ContactFrame c;
      if (cr.Next(c)) contacts_per_frame = c.contacts.size();
    }
  }
  for (int round = 1; round <= repeat; ++round) {
    for (const std::string& what : order) {
      const auto t0 = std::chrono::steady_clock::now();
      if (what == "read") {
        frames = read_only();
      } else {
        o.cg.threads = threads[static_cast<std::size_t>(&what - &order[1])];
        const analysis::CgRunResult r = analysis::CgFieldsOfRun(data, o);
        frames = r.parts.front().frames;
        nodes = r.parts.front().grid.size();
      }
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      rates[what].push_back(frames / s);
      out << "round " << round << "  " << std::left << std::setw(20) << what << std::right << std::fixed
          << std::setprecision(1) << std::setw(8) << frames / s << " frames/s  (" << frames << " frames in "
          << std::setprecision(2) << s << " s)\n"
          << std::defaultfloat;
    }
  }
  out << "run " << data.dir.string() << ": " << discs_per_frame << " discs and " << contacts_per_frame
      << " contacts in its first frame; grid of " << nodes << " nodes\n";
  for (const std::string& what : order) {
    std::vector<double> v = rates[what];
    std::sort(v.begin(), v.end());
    out << std::left << std::setw(20) << what << std::right << std::fixed << std::setprecision(1) << " best "
        << v.back() << "  median " << v[v.size() / 2] << " frames/s\n"
        << std::defaultfloat;
  }
  return 0;
}
#endif

int Fields(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "fields");
  if (a.positional.size() != 1)
    throw UsageError("campaign fields: needs exactly one RUN_DIR (see campaign fields --help)");
#ifdef GRANARY_HAVE_ANALYSIS
  const fs::path dir = a.positional[0];
  if (!fs::is_directory(dir)) throw UsageError("campaign fields: no run directory " + dir.string());
  const rundir::RunData data = rundir::ReadRun(dir);
  if (!data.has_frames)
    throw UsageError("campaign fields: " + dir.string() + " has no frames.dump (output.frame_interval = 0)");
  if (a.Has("bench")) return FieldsBench(data, a, out);
  const analysis::CgRunOptions o = FieldOptions(a);
  std::vector<analysis::CgField> fields;
  if (a.Has("fields")) {
    std::stringstream in(a.Get("fields", ""));
    std::string name;
    while (std::getline(in, name, ',')) {
      analysis::CgField f;
      if (!analysis::CgFieldByName(name, f)) {
        std::vector<std::string> names;
        for (const auto& info : analysis::CgFieldTable()) names.push_back(info.name);
        const std::string best = Nearest(name, names);
        throw UsageError("--fields: unknown field \"" + name + "\"" +
                         (best.empty() ? "" : "; did you mean \"" + best + "\"?"));
      }
      fields.push_back(f);
    }
  }
  analysis::CgRunResult r;
  try {
    r = analysis::CgFieldsOfRun(data, o);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("campaign fields: ") + e.what());
  }
  const analysis::CgMaps maps(r.parts.front());
  if (fields.empty())
    for (const auto& info : analysis::CgFieldTable())
      if (maps.Has(info.field)) fields.push_back(info.field);
  const fs::path out_dir = a.Has("out") ? fs::path(a.Get("out", "")) : dir / "fields";
  fs::create_directories(out_dir);
  json files = json::array();
  for (analysis::CgField f : fields) {
    const auto& info = analysis::CgFieldInfoFor(f);
    if (!maps.Has(f))
      throw UsageError(std::string("campaign fields: ") + info.name + " needs contacts.dump, which " + dir.string() +
                       " does not have (output.contact_forces)");
    const fs::path file = out_dir / (std::string(info.name) + ".csv");
    std::ofstream csv(file);
    csv << analysis::CgMapCsv(maps, f);
    if (!csv) throw std::runtime_error("cannot write " + file.string());
    files.push_back(file.string());
  }
  if (a.Has("json")) {
    out << json{{"run_dir", dir.string()},
                {"frames", maps.Frames()},
                {"contact_frames", maps.ContactFrames()},
                {"first_time", r.first_time},
                {"last_time", r.last_time},
                {"window", {r.window.x0, r.window.x1, r.window.y0, r.window.y1}},
                {"nodes", maps.Grid().size()},
                {"files", files}}
               .dump(2)
        << "\n";
  } else {
    out << "fields of " << dir.string() << ": " << maps.Frames() << " frames (t = " << r.first_time << " .. "
        << r.last_time << "), " << maps.ContactFrames() << " with contacts; window x " << r.window.x0 << " .. "
        << r.window.x1 << ", y " << r.window.y0 << " .. " << r.window.y1 << ", " << maps.Grid().nx << " x "
        << maps.Grid().ny << " nodes\n  " << files.size() << " CSV files in " << out_dir.string() << "\n";
  }
  return 0;
#else
  (void)out;
  throw UsageError("campaign fields: this build has no analysis library (granary_analysis)");
#endif
}

// ---------------------------------------------------------------- snapshot, movie
const char kSnapshotHelp[] =
    "usage: campaign snapshot RUN [--time T | --clog K | --first | --last] [--color C] [--forces]\n"
    "                         [--highlight ID,ID,...] [--width PX] --out FILE.png|FILE.svg [--db FILE]\n"
    "A picture of one frame of a run: every disc to scale, walls (grey), outlets (red), obstacles,\n"
    "optionally the contact-force network.\n"
    "  RUN          a run directory, or a run id (or the start of one) in the database\n"
    "  --time T     the frame nearest simulated time T (since the outlets opened)\n"
    "  --clog K     the K-th clog (1 = first): the middle of the clogged stretch, or the last frame\n"
    "               if the run ended in it (a clog is a gap of the run's clog_window in the exits)\n"
    "  --first      the first frame (t = 0, the bed before the outlets open)\n"
    "  --last       the last frame (default)\n"
    "  --color C    species (default), speed, rotation (angular velocity), force (summed contact\n"
    "               force on each body; needs output.contact_forces) or disc (each disc by its place\n"
    "               in the body, largest first: a snowman's head and body apart)\n"
    "  --forces     draw the contact-force network (line width ~ force; needs output.contact_forces)\n"
    "  --highlight  body ids to outline\n"
    "  --width PX   picture width in pixels (default 1000; the height follows the silo)\n"
    "  --out FILE   .png (cairo) or .svg\n"
    "  --db FILE    database to look RUN up in (default granary.db)\n"
    "Exit: 0 written, 1 the run cannot be drawn (no frames, no contact frames, no such clog),\n"
    "2 usage error.\n";

const char kMovieHelp[] =
    "usage: campaign movie RUN --out FILE.mp4 [--fps N] [--color C] [--forces] [--width PX] [--db FILE]\n"
    "Every frame of a run drawn as by campaign snapshot and encoded by ffmpeg (H.264, yuv420p),\n"
    "with a progress bar on stderr.\n"
    "  --fps N      frames per second of the movie (default 20)\n"
    "  --width PX   movie width in pixels (default 800)\n"
    "  RUN, --color, --forces, --db: as for campaign snapshot\n"
    "Exit: 0 written, 1 the run cannot be drawn or ffmpeg failed, 2 usage error.\n";

#ifdef GRANARY_HAVE_RENDER
// RUN: a run directory, or a run id (a unique prefix will do) of the database.
fs::path ResolveRun(const std::string& verb, const std::string& run, const Args& a) {
  if (fs::is_directory(run)) return run;
  const std::string db = DbPath(a);
  if (!fs::exists(db))
    throw UsageError("campaign " + verb + ": '" + run + "' is not a run directory, and there is no database " + db +
                     " to look it up in");
  const auto opened = OpenCampaignDb(db, verb);
  Store& store = *opened;
  std::vector<RunRow> found;
  for (RunRow& r : LoadRuns(store, false))
    if (r.run_id.rfind(run, 0) == 0) found.push_back(std::move(r));
  if (found.empty()) throw UsageError("campaign " + verb + ": no run directory or run id '" + run + "' in " + db);
  if (found.size() > 1)
    throw UsageError("campaign " + verb + ": '" + run + "' starts " + std::to_string(found.size()) + " run ids in " +
                     db + " (" + found[0].run_id + ", " + found[1].run_id + ", ...); give more of it");
  return found[0].run_dir;
}

render::PictureOptions PictureOptionsFrom(const std::string& verb, const Args& a) {
  render::PictureOptions o;
  int picks = 0;
  for (const char* f : {"time", "clog", "first", "last"}) picks += a.Has(f);
  if (picks > 1) throw UsageError("campaign " + verb + ": give one of --time, --clog, --first, --last");
  if (a.Has("time")) {
    o.pick.kind = render::FramePick::kTime;
    o.pick.time = a.Number("time", 0);
  } else if (a.Has("clog")) {
    o.pick.kind = render::FramePick::kClog;
    o.pick.clog = a.Integer("clog", 1, 1);
  } else if (a.Has("first")) {
    o.pick.kind = render::FramePick::kFirst;
  }
  try {
    o.colour = render::ColourFromName(a.Get("color", "species"));
  } catch (const std::invalid_argument& e) {
    throw UsageError("campaign " + verb + ": --color: " + e.what());
  }
  o.forces = a.Has("forces");
  if (a.Has("highlight")) {
    std::stringstream ids(a.Get("highlight", ""));
    for (std::string id; std::getline(ids, id, ',');) {
      std::size_t used = 0;
      long long v = -1;
      try {
        v = std::stoll(id, &used);
      } catch (const std::exception&) {
      }
      if (v < 0 || used != id.size())
        throw UsageError("campaign " + verb + ": --highlight: body ids are integers >= 0 separated by commas (got \"" +
                         id + "\")");
      o.highlight.insert(v);
    }
  }
  return o;
}
#endif

int Snapshot(const std::vector<std::string>& argv, std::ostream& out, std::ostream&) {
  const Args a = Parse(argv, "snapshot");
  if (a.positional.size() != 1)
    throw UsageError("campaign snapshot: needs exactly one RUN (see campaign snapshot --help)");
  if (!a.Has("out")) throw UsageError("campaign snapshot: --out FILE.png or FILE.svg is required");
  const fs::path file = a.Get("out", "");
  const std::string ext = file.extension().string();
  if (ext != ".png" && ext != ".svg")
    throw UsageError("campaign snapshot: --out must end in .png or .svg, not '" + ext + "'");
#ifdef GRANARY_HAVE_RENDER
  const render::PictureOptions o = PictureOptionsFrom("snapshot", a);
  const fs::path run = ResolveRun("snapshot", a.positional[0], a);
  const int width = a.Integer("width", 1000, 16);
  try {
    const render::Scene scene = render::RunScene(run, o);
    if (ext == ".svg") {
      std::ofstream f(file);
      f << render::Svg(scene, width);
      if (!f) throw std::runtime_error("cannot write " + file.string());
    } else {
      render::WritePng(scene, width, file);
    }
    out << "snapshot: " << file.string() << " (" << scene.caption << ")\n";
    return 0;
  } catch (const rundir::ReadError& e) {
    throw std::runtime_error(e.what());
  }
#else
  (void)out;
  throw UsageError("campaign snapshot: this build has no renderer (granary_render)");
#endif
}

int Movie(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args a = Parse(argv, "movie");
  if (a.positional.size() != 1) throw UsageError("campaign movie: needs exactly one RUN (see campaign movie --help)");
  if (!a.Has("out")) throw UsageError("campaign movie: --out FILE.mp4 is required");
  const fs::path file = a.Get("out", "");
  if (file.extension() != ".mp4") throw UsageError("campaign movie: --out must end in .mp4");
#ifdef GRANARY_HAVE_RENDER
  const render::PictureOptions o = PictureOptionsFrom("movie", a);
  const fs::path run = ResolveRun("movie", a.positional[0], a);
  const int width = a.Integer("width", 800, 16);
  const int fps = a.Integer("fps", 20, 1);
  const bool tty = isatty(STDERR_FILENO);
  const int frames = render::WriteMovie(run, o, file, width, fps, [&](int done, int total) {
    if (!tty && done != total) return;
    err << "\rmovie " << Bar(total > 0 ? static_cast<double>(done) / total : 1.0, 30) << " " << done << "/" << total
        << " frames" << (done == total ? "\n" : "") << std::flush;
  });
  out << "movie: " << file.string() << " (" << frames << " frames at " << fps << " fps)\n";
  return 0;
#else
  (void)out;
  (void)err;
  throw UsageError("campaign movie: this build has no renderer (granary_render)");
#endif
}

}  // namespace

Verb FieldsVerb() {
  return {"fields",
          "coarse-grained fields of one run directory as CSV maps; --bench",
          kFieldsHelp,
          Fields,
          {{"out", true},
           {"fields", true},
           {"from", true},
           {"to", true},
           {"stride", true},
           {"max-frames", true},
           {"width", true},
           {"cutoff", true},
           {"spacing", true},
           {"window", true},
           {"min-phi", true},
           {"threads", true},
           {"json", false},
           {"bench", false},
           {"repeat", true},
           {"threads-list", true},
           {"help", false}}};
}

Verb SnapshotVerb() {
  return {"snapshot",
          "a picture of one frame of a run (PNG or SVG)",
          kSnapshotHelp,
          Snapshot,
          {{"time", true},
           {"clog", true},
           {"first", false},
           {"last", false},
           {"color", true},
           {"forces", false},
           {"highlight", true},
           {"width", true},
           {"out", true},
           {"db", true},
           {"help", false}},
          Operand::kRun};
}

Verb MovieVerb() {
  return {"movie",
          "a movie of a run's frames (MP4, ffmpeg)",
          kMovieHelp,
          Movie,
          {{"out", true},
           {"fps", true},
           {"color", true},
           {"forces", false},
           {"width", true},
           {"db", true},
           {"help", false}},
          Operand::kRun};
}

}  // namespace granary::runner::cli

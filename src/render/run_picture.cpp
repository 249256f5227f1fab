#include "render/run_picture.h"

#include <boost/process.hpp>

#include <csignal>
#include <cmath>
#include <deque>
#include <limits>
#include <stdexcept>

#include "analysis/clogging.h"
#include "analysis/run_pass.h"
#include "rundir/clogs.h"

namespace granary::render {
namespace fs = std::filesystem;
namespace bp = boost::process;
using rundir::ContactFrame;
using rundir::Frame;

namespace {

double TopOf(const Frame& f) {
  double top = 0;
  for (const auto& d : f.discs) top = std::max(top, d.y + d.radius);
  return top;
}

// The time of the frame to show, or NaN for the last frame.
double PickTime(const rundir::RunData& run, const FramePick& pick) {
  switch (pick.kind) {
    case FramePick::kFirst: return -std::numeric_limits<double>::infinity();
    case FramePick::kTime: return pick.time;
    case FramePick::kLast: return std::numeric_limits<double>::quiet_NaN();
    case FramePick::kClog: break;
  }
  // The analyses' rule of a clog (clogging.h), with the run's own clog_window.
  const analysis::PassOptions pass;
  const analysis::RunView v = analysis::MakeRunView(run, pass);
  const analysis::ClogSeries series = analysis::ComputeClogSeries(run.events, -1, v.t_end, v.clog_gap,
                                                                  analysis::RunEndOf(v.end_reason), v.stop_on_clog);
  const auto& clogs = series.clogged;
  if (pick.clog < 1 || pick.clog > static_cast<int>(clogs.size()))
    throw std::runtime_error("run " + run.dir.string() + " has " + std::to_string(clogs.size()) + " clog" +
                             (clogs.size() == 1 ? "" : "s") + ", not a clog " + std::to_string(pick.clog));
  const auto& c = clogs[static_cast<std::size_t>(pick.clog - 1)];
  // In the middle of the clogged stretch: the arch stands; a clog the run ended in, at the end.
  return c.complete ? 0.5 * (c.start + c.end) : std::numeric_limits<double>::quiet_NaN();
}

std::string Caption(const Frame& f, const rundir::RunData& run) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "t = %.4g   %zu bodies", f.time, rundir::BodiesOf(f.discs).size());
  std::string s = buf;
  if (!run.summary.run_id.empty()) s += "   run " + run.summary.run_id.substr(0, 10);
  return s;
}

// The contact frame of `timestep`, or nothing.
std::optional<ContactFrame> ContactsAt(const fs::path& file, std::int64_t timestep) {
  rundir::ContactReader reader(file);
  ContactFrame c;
  while (reader.Next(c))
    if (c.timestep == timestep) return c;
  return std::nullopt;
}

SceneOptions OptionsFor(const RunSetting& setting, const PictureOptions& o) {
  SceneOptions s;
  s.window = setting.window;
  s.colour = o.colour;
  s.forces = o.forces;
  s.highlight = o.highlight;
  s.species = setting.species;
  s.marks = o.marks;
  return s;
}

bool NeedsContacts(const PictureOptions& o) { return o.forces || o.colour == Colour::kForce; }

}  // namespace

RunSetting SettingOf(const rundir::RunData& run) {
  if (!run.has_frames)
    throw std::runtime_error("run " + run.dir.string() + " has no frames (its spec's output.frame_interval is 0)");
  if (!run.spec.is_object()) throw std::runtime_error("run " + run.dir.string() + " has no run.json");
  const RunSpec spec = RunSpec::FromJson(run.spec);
  rundir::FrameReader reader(run.FramesFile(), spec.bodies.density);
  Frame first;
  if (!reader.Next(first))
    throw std::runtime_error("run " + run.dir.string() + ": " + run.FramesFile().string() + " has no frame");
  RunSetting s;
  const double top = TopOf(first);
  // Walls as high as the picture when the spec leaves their height automatic.
  const double wall_top = spec.silo.height > 0 ? spec.silo.height : top + 1;
  s.silo = silo::OutlineOf(spec.silo, wall_top);
  // Up to the bed's top; RunScene and WriteMovie raise it to the frames they draw (reinjected
  // bodies come back above the bed).
  s.window = SiloWindow(s.silo, spec.discharge.exit_distance, std::max(top, spec.silo.height));
  for (const auto& sp : spec.bodies.species) s.species.push_back(sp.name);
  s.has_contacts = run.has_contacts;
  return s;
}

Scene ClogScene(const fs::path& run_dir, int clog, const PictureOptions& o, const std::optional<Window>& window) {
  const rundir::RunData run = rundir::ReadRun(run_dir);
  if (!run.spec.is_object()) throw std::runtime_error("run " + run_dir.string() + " has no run.json");
  const std::vector<rundir::ClogState> clogs = rundir::ReadClogs(run_dir);
  if (clog < 1 || clog > static_cast<int>(clogs.size()))
    throw std::runtime_error("run " + run_dir.string() + " kept " + std::to_string(clogs.size()) + " clog" +
                             (clogs.size() == 1 ? "" : "s") + ", not a clog " + std::to_string(clog));
  const rundir::ClogState& c = clogs[static_cast<std::size_t>(clog - 1)];
  const RunSpec spec = RunSpec::FromJson(run.spec);
  const double top = TopOf(c.frame);
  RunSetting setting;
  setting.silo = silo::OutlineOf(spec.silo, spec.silo.height > 0 ? spec.silo.height : top + 1);
  setting.window = window     ? *window
                   : o.window ? *o.window
                              : SiloWindow(setting.silo, spec.discharge.exit_distance, std::max(top, spec.silo.height));
  for (const auto& sp : spec.bodies.species) setting.species.push_back(sp.name);
  SceneOptions so = OptionsFor(setting, o);
  so.contacts = &c.contacts;
  so.caption = Caption(c.frame, run) + "   clog " + std::to_string(clog);
  return MakeScene(c.frame, setting.silo, so);
}

Scene RunScene(const fs::path& run_dir, const PictureOptions& o) {
  if (o.pick.kind == FramePick::kClog && rundir::ClogReader(run_dir).Present())
    return ClogScene(run_dir, o.pick.clog, o);
  const rundir::RunData run = rundir::ReadRun(run_dir);
  const RunSetting setting = SettingOf(run);
  if (NeedsContacts(o) && !setting.has_contacts)
    throw std::runtime_error("run " + run_dir.string() +
                             " has no contact frames (its spec's output.contact_forces is false)");
  const double want = PickTime(run, o.pick);
  rundir::FrameReader reader(run.FramesFile(), run.spec.at("bodies").value("density", 1.0));
  Frame f, best;
  bool any = false;
  while (reader.Next(f)) {
    if (!any || std::isnan(want) || std::fabs(f.time - want) < std::fabs(best.time - want)) best = std::move(f);
    any = true;
    if (std::isinf(want)) break;  // the first
  }
  std::optional<ContactFrame> contacts;
  if (NeedsContacts(o)) {
    contacts = ContactsAt(run.ContactsFile(), best.timestep);
    if (!contacts)
      throw std::runtime_error("run " + run_dir.string() + " has no contact frame at step " +
                               std::to_string(best.timestep));
  }
  SceneOptions so = OptionsFor(setting, o);
  if (o.window)
    so.window = *o.window;
  else
    so.window.y_hi = std::max(so.window.y_hi, TopOf(best) + 1);
  so.contacts = contacts ? &*contacts : nullptr;
  so.caption = Caption(best, run);
  return MakeScene(best, setting.silo, so);
}

int WriteMovie(const fs::path& run_dir, const PictureOptions& o, const fs::path& out, int width_px, int fps,
               const std::function<void(int, int)>& progress) {
  const rundir::RunData run = rundir::ReadRun(run_dir);
  const RunSetting setting = SettingOf(run);
  if (NeedsContacts(o) && !setting.has_contacts)
    throw std::runtime_error("run " + run_dir.string() +
                             " has no contact frames (its spec's output.contact_forces is false)");
  const double density = run.spec.at("bodies").value("density", 1.0);
  int total = 0;
  double top = 0;  // of every frame: one window for the whole movie
  {
    rundir::FrameReader counter(run.FramesFile(), density);
    for (Frame f; counter.Next(f);) {
      ++total;
      top = std::max(top, TopOf(f));
    }
  }
  const std::string ffmpeg = bp::search_path("ffmpeg").string();
  if (ffmpeg.empty())
    throw std::runtime_error("ffmpeg not found: install Debian's package ffmpeg (scripts/setup.sh does)");
  bp::opstream frames_in;
  bp::ipstream log;
  std::optional<bp::child> ff;
  // Raw BGRA frames on stdin (cairo's ARGB32 on a little-endian machine), H.264 in yuv420p so
  // that every player and browser shows it.
  const auto StartFfmpeg = [&](PixelSize size) {
    ff.emplace(ffmpeg, "-hide_banner", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "bgra", "-s",
               std::to_string(size.width) + "x" + std::to_string(size.height), "-r", std::to_string(fps), "-i", "-",
               "-c:v", "libx264", "-pix_fmt", "yuv420p", "-movflags", "+faststart", out.string(),
               bp::std_in<frames_in, (bp::std_out & bp::std_err)> log);
  };
  // An ffmpeg that has died makes the next write fail instead of killing this process.
  const auto old_sigpipe = std::signal(SIGPIPE, SIG_IGN);
  rundir::FrameReader reader(run.FramesFile(), density);
  std::optional<rundir::ContactReader> contact_reader;
  if (NeedsContacts(o)) contact_reader.emplace(run.ContactsFile());
  SceneOptions so = OptionsFor(setting, o);
  so.window.y_hi = std::max(so.window.y_hi, top + 1);
  std::optional<PixelSize> size;  // the first frame's, for all (the legend's rows do not change)
  int done = 0;
  ContactFrame c;
  for (Frame f; reader.Next(f);) {
    std::optional<ContactFrame> contacts;
    if (contact_reader) {
      while (contact_reader->Next(c))
        if (c.timestep >= f.timestep) break;
      if (c.timestep == f.timestep) contacts = c;
    }
    so.contacts = contacts ? &*contacts : nullptr;
    if (NeedsContacts(o) && !contacts) {
      ContactFrame none;
      none.timestep = f.timestep;
      contacts = none;  // no contact frame for this frame: drawn without forces
      so.contacts = &*contacts;
    }
    so.caption = Caption(f, run);
    const Scene scene = MakeScene(f, setting.silo, so);
    if (!size) {
      size = SizeFor(scene, width_px);
      StartFfmpeg(*size);
    }
    const std::vector<unsigned char> px = Pixels(scene, *size);
    frames_in.write(reinterpret_cast<const char*>(px.data()), static_cast<std::streamsize>(px.size()));
    if (!frames_in) break;
    ++done;
    if (progress) progress(done, total);
  }
  frames_in.flush();
  frames_in.pipe().close();
  std::deque<std::string> tail;
  int code = 0;
  if (ff) {
    for (std::string line; std::getline(log, line);) {
      tail.push_back(line);
      if (tail.size() > 10) tail.pop_front();
    }
    ff->wait();
    code = ff->exit_code();
  }
  std::signal(SIGPIPE, old_sigpipe);
  if (code != 0 || done < total || done == 0) {
    std::string msg = "ffmpeg failed (exit " + std::to_string(code) + ") after " + std::to_string(done) + " of " +
                      std::to_string(total) + " frames";
    for (const auto& l : tail) msg += "\n  " + l;
    throw std::runtime_error(msg);
  }
  return done;
}

}  // namespace granary::render

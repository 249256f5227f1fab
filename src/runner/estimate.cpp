// See estimate.h.
#include "runner/estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <queue>
#include <set>

#include "rundir/contacts.h"
#include "rundir/gsd.h"
#include "rundir/frames.h"
#include "rundir/shape_table.h"

namespace granary::runner {

using nlohmann::json;

namespace {

// The largest disc of one body.
double LargestDiameter(const DiscLayout& discs) { return 2 * *std::max_element(discs.r.begin(), discs.r.end()); }

// A deterministic stream of numbers in [0, 1) for the sample frames (their digits, not their
// values, decide the bytes).
struct Lcg {
  std::uint64_t state = 0x853c49e6748fea9bULL;
  double Next() {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  }
  // Log-uniform magnitude in [lo, hi] with a random sign: velocities and forces of a silo span
  // decades, and their printed length depends on the decade.
  double SignedLog(double lo, double hi) {
    const double m = lo * std::pow(hi / lo, Next());
    return Next() < 0.5 ? -m : m;
  }
};

constexpr int kSampleRows = 2000;

// Bytes of one frame's header and of one disc row, by the frames' own writer on a sample of
// discs shaped like the run's (ids and body ids as large as the run's, its radii and masses,
// positions in its silo, velocities over the decades a flow has).
struct RowBytes {
  double header = 0.0;
  double row = 0.0;
};

// A sample of discs shaped like the run's: bodies of its species in turn (a clump's discs
// share the body id and omega, as in the engine's frames, which gzip finds), ids as large as
// the run's, positions in its silo, velocities over the decades a flow has.
std::vector<rundir::Disc> SampleDiscs(const RunSpec& spec, double discs, double bodies) {
  Lcg rng;
  const double h = std::max(10.0, discs / spec.silo.width);
  const int n = static_cast<int>(std::min<double>(kSampleRows, std::max(1.0, discs)));
  auto id = static_cast<std::int64_t>(std::max(1.0, discs - n + 1));
  auto mol = static_cast<std::int64_t>(std::max(0.0, bodies - n));
  std::vector<rundir::Disc> out;
  for (std::size_t k = 0; static_cast<int>(out.size()) < n; ++k, ++mol) {
    const Species& s = spec.bodies.species[k % spec.bodies.species.size()];
    const DiscLayout layout = DiscsOf(s);
    const int parts = static_cast<int>(layout.r.size());
    const double x = (rng.Next() - 0.5) * spec.silo.width, y = rng.Next() * h, th = rng.Next() * 6.283185307179586;
    const double vx = rng.SignedLog(1e-4, 1.0), vy = rng.SignedLog(1e-4, 1.0), w = rng.SignedLog(1e-4, 1.0);
    for (int q = 0; q < parts && static_cast<int>(out.size()) < n; ++q) {
      const double r = layout.r[static_cast<std::size_t>(q)];
      const double off = (q - 0.5 * (parts - 1)) * s.diameter;
      rundir::Disc d;
      d.id = id++;
      d.mol = mol;
      d.type = static_cast<int>(k % spec.bodies.species.size()) + 1;
      d.x = x + off * std::cos(th);
      d.y = y + off * std::sin(th);
      d.radius = r;
      d.mass = spec.bodies.density * std::numbers::pi * r * r;
      d.vx = vx - w * off * std::sin(th);
      d.vy = vy + w * off * std::cos(th);
      d.omega = w;
      out.push_back(d);
    }
  }
  return out;
}

RowBytes FrameRowBytes(const RunSpec& spec, double discs, double bodies, const Output& o) {
  const bool gzip = o.compress;
  auto bytes = [&](const rundir::Frame& f) {
    return static_cast<double>(o.format == FrameFormat::kGsd ? rundir::gsd::GsdFrameBytes(f)
                                                             : rundir::FrameBytes(f, gzip));
  };
  rundir::Frame f;
  const double h = std::max(10.0, discs / spec.silo.width);
  f.box[0][0] = -spec.silo.width / 2 - 4;
  f.box[0][1] = spec.silo.width / 2 + 4;
  f.box[1][0] = -7;
  f.box[1][1] = 1.2 * h + 4;
  const double header = bytes(f);
  f.discs = SampleDiscs(spec, discs, bodies);
  return {header, (bytes(f) - header) / static_cast<double>(f.discs.size())};
}

// Per contact row: the engine lists a disc's contacts one after another (its centre repeated
// on each row), `per_disc` of them per disc on average.
RowBytes ContactRowBytes(const RunSpec& spec, double discs, double bodies, double per_disc, const Output& out) {
  auto bytes = [&](const rundir::ContactFrame& f) {
    return static_cast<double>(out.format == FrameFormat::kGsd ? rundir::gsd::GsdContactBytes(f)
                                                               : rundir::ContactBytes(f, out.compress));
  };
  rundir::ContactFrame f;
  const double header = bytes(f);
  Lcg rng;
  const std::vector<rundir::Disc> sample = SampleDiscs(spec, discs, bodies);
  double owed = 0.0;
  for (const rundir::Disc& d : sample) {
    owed += per_disc;
    for (; owed >= 1.0; owed -= 1.0) {
      const rundir::Disc& o = sample[static_cast<std::size_t>(rng.Next() * static_cast<double>(sample.size()))];
      rundir::ContactRow c;
      c.body_i = d.mol;
      const bool wall = rng.Next() < 0.05;
      c.body_j = wall ? -1 : o.mol;
      c.xi = d.x;
      c.yi = d.y;
      c.xj = wall ? d.x - d.radius : d.x + rng.SignedLog(0.1, 1.0);
      c.yj = wall ? d.y : d.y + rng.SignedLog(0.1, 1.0);
      c.cx = 0.5 * (c.xi + c.xj);
      c.cy = 0.5 * (c.yi + c.yj);
      c.fx = rng.SignedLog(1e-3, 10.0);
      c.fy = rng.SignedLog(1e-3, 10.0);
      f.contacts.push_back(c);
    }
  }
  if (f.contacts.empty()) return {header, 0.0};
  return {header, (bytes(f) - header) / static_cast<double>(f.contacts.size())};
}

}  // namespace

double Makespan(const std::vector<double>& durations, int slots) {
  std::priority_queue<double, std::vector<double>, std::greater<>> free_at;
  for (int k = 0; k < std::max(1, slots); ++k) free_at.push(0.0);
  double end = 0.0;
  for (const double d : durations) {
    const double start = free_at.top();
    free_at.pop();
    free_at.push(start + d);
    end = std::max(end, start + d);
  }
  return end;
}

RunEstimate EstimateRun(const RunSpec& spec, const Calibration& cal, bool prepares_bed, const EstimateModel& m) {
  RunEstimate e;
  double lone_discs = 0.0, clump_discs = 0.0, area = 0.0, size = 0.0;
  for (const Species& s : spec.bodies.species) {
    const double n = spec.bodies.count * s.fraction;
    const DiscLayout discs = DiscsOf(s);
    const double count = static_cast<double>(discs.r.size());
    (count == 1 ? lone_discs : clump_discs) += n * count;
    area += n * BodyArea(s);
    size += n * LargestDiameter(discs);
  }
  e.bodies = spec.bodies.count;
  e.discs = lone_discs + clump_discs;
  const double mean_area = area / std::max(1.0, e.bodies);
  const double mean_size = size / std::max(1.0, e.bodies);
  // Seconds per disc-step: a mixture pays each kind's cost for its share of the discs.
  const double sec_per_disc_step =
      cal.Valid() && e.discs > 0 ? cal.scale * (lone_discs / cal.disc_rate + clump_discs / cal.clump_rate) / e.discs
                                 : 0.0;

  const double dt = spec.time_step;
  const Discharge& d = spec.discharge;
  // Beverloo: bodies per unit time through all outlets.
  const double density = m.packing_fraction / mean_area;
  double q = 0.0;
  auto through = [&](double w) {
    const double free = w - m.beverloo_k * mean_size;
    return free > 0 ? m.beverloo_c * density * std::sqrt(spec.gravity) * std::pow(free, 1.5) : 0.0;
  };
  for (const auto& o : spec.silo.base_outlets) q += through(o.width);
  for (const auto& o : spec.silo.side_outlets) q += through(o.width);

  // Discs present over the discharge: a run of `sim` time units; returns disc-steps and the
  // mean discs present, with bodies leaving at rate q until the silo is empty (remove mode).
  struct Span {
    double disc_steps, mean_discs;
  };
  auto span = [&](double sim, bool leaving) -> Span {
    if (!leaving || q <= 0) return {e.discs * sim / dt, e.discs};
    const double t_empty = e.bodies / q;
    const double flow = std::min(sim, t_empty);
    const double body_time = e.bodies * flow - 0.5 * q * flow * flow + (e.bodies - q * flow) * (sim - flow);
    const double per_body = e.discs / std::max(1.0, e.bodies);
    return {per_body * body_time / dt, sim > 0 ? per_body * body_time / sim : e.discs};
  };
  const bool removing = d.mode == DischargeMode::kRemove;
  Span low{}, high{};
  if (removing) {
    e.open_end = true;
    const double t_empty = q > 0 ? e.bodies / q : d.max_time;
    // Without stop_on_clog a clogged silo stays full until max_time: the upper bound.
    e.sim_high = d.StopOnClog() ? std::min(d.max_time, t_empty + d.clog_window) : d.max_time;
    high = d.StopOnClog() ? span(e.sim_high, true) : Span{e.discs * d.max_time / dt, e.discs};
    e.sim_low = d.StopOnClog() ? std::min(d.max_time, d.clog_window) : std::min(d.max_time, t_empty + d.clog_window);
    low = d.StopOnClog() ? Span{e.discs * e.sim_low / dt, e.discs} : span(e.sim_low, true);
  } else if (d.StopOnClog()) {
    e.open_end = true;
    e.sim_high = d.max_time;
    e.sim_low = std::min(d.max_time, d.clog_window);
    high = span(e.sim_high, false);
    low = span(e.sim_low, false);
  } else {
    e.sim_low = e.sim_high = d.max_time;
    high = low = span(d.max_time, false);
  }
  e.disc_steps_low = low.disc_steps;
  e.disc_steps_high = high.disc_steps;

  if (prepares_bed) {
    // Batches of batch_size fall through their insertion region (bed.cpp: area fraction
    // bed_insert_fraction of the silo's width) one after another onto the growing bed, then
    // the whole bed settles: the discs present grow linearly over the insertion.
    const double batches = std::ceil(e.bodies / std::max(1, spec.bed.batch_size));
    const double batch_height = (area / batches) / (m.bed_insert_fraction * spec.silo.width);
    const double fall = std::sqrt(2 * batch_height / spec.gravity) + 1.0;
    const double insert = batches * fall;
    const double settle = std::min(spec.bed.max_settle_time, m.bed_final_settle);
    e.bed_disc_steps = e.discs * (0.5 * insert + settle) / spec.BedTimeStep();
  }
  const double overhead = sec_per_disc_step > 0 ? m.run_overhead_s : 0.0;
  e.core_s_low = (e.bed_disc_steps + e.disc_steps_low) * sec_per_disc_step + overhead;
  e.core_s_high = (e.bed_disc_steps + e.disc_steps_high) * sec_per_disc_step + overhead;

  // Disk: frames (and contact frames), two checkpoints, events, and the small files.
  const Output& o = spec.output;
  auto frames_in = [&](double sim) {
    return o.frame_interval > 0 ? std::floor(sim / o.frame_interval + 1e-9) + 1 : 0.0;
  };
  // Formatting (and compressing) a sample frame takes milliseconds: once per kind of run.
  thread_local std::map<std::string, std::pair<RowBytes, RowBytes>> memo;
  const bool contacts = o.frame_interval > 0 && o.contact_forces;
  const double contacts_per_disc =
      e.discs > 0 ? (lone_discs * m.contacts_per_lone_disc + clump_discs * m.contacts_per_clump_disc) / e.discs : 0.0;
  const std::string memo_key = json{
      {"bodies", spec.ToJson()["bodies"]},
      {"width", spec.silo.width},
      {"gz", o.compress},
      {"format", ToString(o.format)},
      {"contacts", contacts}}.dump();
  auto found = memo.find(memo_key);
  if (found == memo.end() && o.frame_interval > 0) {
    found = memo.emplace(memo_key, std::pair{FrameRowBytes(spec, e.discs, e.bodies, o),
                                             contacts ? ContactRowBytes(spec, e.discs, e.bodies, contacts_per_disc, o)
                                                      : RowBytes{}})
                .first;
  }
  const RowBytes fr = o.frame_interval > 0 ? found->second.first : RowBytes{};
  const RowBytes cr = contacts ? found->second.second : RowBytes{};
  // A contact frame with every contact_interval-th frame: its share per frame.
  const double contact_share = 1.0 / o.contact_interval;
  auto frame_bytes = [&](double discs) {
    return fr.header + fr.row * discs +
           (contacts ? contact_share * (cr.header + cr.row * contacts_per_disc * discs) : 0.0);
  };
  e.frame_bytes = o.frame_interval > 0 ? frame_bytes(e.discs) : 0.0;
  // GSD: frame 0's per-disc constants, and each file's header, name list and outgrown index blocks.
  auto gsd_once = [&](double frames, double discs) {
    if (o.format != FrameFormat::kGsd || frames <= 0) return 0.0;
    const double contact_frames = std::floor((frames - 1) / o.contact_interval) + 1;
    return rundir::gsd::kGsdConstantBytesPerDisc * discs +
           static_cast<double>(
               rundir::gsd::GsdOverheadBytes(static_cast<std::uint64_t>(frames * rundir::gsd::kGsdFrameEntries))) +
           (contacts ? static_cast<double>(rundir::gsd::GsdOverheadBytes(
                           static_cast<std::uint64_t>(contact_frames * rundir::gsd::kGsdContactEntries)))
                     : 0.0);
  };
  // Checkpoint: per body its template, state and 11 doubles; per disc about 1.5 history
  // entries of 24 bytes; the spec; the last two are kept.
  const double checkpoint = 2.0 * (93.0 * e.bodies + 36.0 * e.discs + 4096.0);
  constexpr double kEventRow = 45.0, kSmallFiles = 16384.0;
  auto bytes_for = [&](double sim, const Span& s) {
    const double exits = removing ? std::min(e.bodies, q * sim) : q * sim;
    const double checkpoints = o.checkpoint_interval > 0 && sim >= o.checkpoint_interval ? checkpoint : 0.0;
    return frames_in(sim) * frame_bytes(s.mean_discs) + gsd_once(frames_in(sim), e.discs) + checkpoints +
           kEventRow * exits + kSmallFiles;
  };
  e.bytes_low = bytes_for(e.sim_low, low);
  e.bytes_high = bytes_for(e.sim_high, high);
  return e;
}

CampaignEstimate EstimateCampaign(const std::vector<PlannedRun>& runs, const Calibration& cal, int jobs,
                                  const std::set<std::string>& beds_ready, const EstimateModel& model) {
  CampaignEstimate c;
  c.calibration = cal;
  c.jobs = std::max(1, jobs);
  c.run_count = static_cast<int>(runs.size());
  std::set<std::string> beds;
  std::map<std::string, std::size_t> point_index;
  std::vector<double> low, high;
  for (const PlannedRun& r : runs) {
    const RunSpec spec = RunSpec::FromJson(r.Params());
    const bool first_of_bed =
        beds.insert(spec.engine + "|" + spec.bed.cache_file + "|" + spec.BedKey().dump()).second &&
        !beds_ready.count(spec.bed.cache_file);
    const RunEstimate e = EstimateRun(spec, cal, first_of_bed, model);
    c.runs[r.run_id] = e;
    const std::string key = r.point_id + "|" + r.engine;
    auto [it, fresh] = point_index.emplace(key, c.points.size());
    if (fresh) c.points.push_back({r.point_id, r.point, r.engine});
    PointEstimate& p = c.points[it->second];
    ++p.runs;
    p.open_end = p.open_end || e.open_end;
    p.core_s_low += e.core_s_low;
    p.core_s_high += e.core_s_high;
    p.bytes_low += e.bytes_low;
    p.bytes_high += e.bytes_high;
    p.run_core_s_high = std::max(p.run_core_s_high, e.core_s_high);
    c.core_s_low += e.core_s_low;
    c.core_s_high += e.core_s_high;
    c.bytes_low += e.bytes_low;
    c.bytes_high += e.bytes_high;
    c.open_end_runs += e.open_end ? 1 : 0;
    low.push_back(e.core_s_low);
    high.push_back(e.core_s_high);
  }
  c.beds = static_cast<int>(beds.size());
  c.wall_s_low = Makespan(low, c.jobs);
  c.wall_s_high = Makespan(high, c.jobs);
  std::string how = "bodies, discs and simulated time per run from the spec; ";
  if (cal.Valid()) {
    char rates[160];
    std::snprintf(rates, sizeof rates, "%.3g disc-steps/s for lone discs and %.3g for clumps, one thread per run",
                  cal.disc_rate, cal.clump_rate);
    how += std::string(rates) + " (" + cal.source + ")";
    if (cal.scaled_from_runs > 0) {
      char s[120];
      std::snprintf(s, sizeof s, ", times %.3g: what %d finished run(s) of this campaign took against their estimate",
                    cal.scale, cal.scaled_from_runs);
      how += s;
    }
  } else {
    how += "no engine speed known (" + (cal.source.empty() ? std::string("no calibration") : cal.source) +
           "): time not estimated";
  }
  how += "; a bed prepared by the first run of its seed (" + std::to_string(c.beds) + " beds); bytes per frame by the ";
  how += "run-directory writer on a frame of the run's size";
  if (c.open_end_runs > 0)
    how += "; " + std::to_string(c.open_end_runs) +
           " run(s) end at a clog or when the silo has discharged, which is not known before: from a clog as soon as "
           "one can be judged (clog_window) to flowing at Beverloo's rate until empty or max_time";
  c.method = how;
  return c;
}

void ScaleFromFinished(Calibration& cal, const std::vector<std::pair<json, json>>& finished,
                       const EstimateModel& model) {
  if (finished.empty()) return;
  if (!cal.Valid()) {
    double steps = 0.0, core = 0.0;
    for (const auto& [spec, summary] : finished) {
      const json t = summary.value("timing", json::object());
      const double wall = t.value("discharge_wall_s", 0.0), rate = t.value("disc_steps_per_s", 0.0);
      steps += rate * wall;
      core += wall * std::max(1, t.value("threads", 1));
    }
    if (steps <= 0 || core <= 0) return;
    cal.disc_rate = cal.clump_rate = steps / core;
    cal.source = "the discharge rate of " + std::to_string(finished.size()) + " finished run(s) of this campaign";
  }
  Calibration unscaled = cal;
  unscaled.scale = 1.0;
  double measured = 0.0, predicted = 0.0;
  for (const auto& [spec_json, summary] : finished) {
    const json t = summary.value("timing", json::object());
    const double wall = t.value("wall_s", 0.0);
    if (wall <= 0) continue;
    RunSpec spec = RunSpec::FromJson(spec_json);
    // What it did: its own simulated time, as a reinject run (the discs present at the end
    // averaged with those at the start in remove mode).
    const double t_end = summary.value("t_end", spec.discharge.max_time);
    spec.discharge.max_time = std::max(t_end, spec.time_step);
    spec.discharge.on_clog = OnClog::kWait;
    const DischargeMode mode = spec.discharge.mode;
    spec.discharge.mode = DischargeMode::kReinject;
    const bool bed_here = summary.value("bed", json::object()).value("prepared_here", false);
    RunEstimate e = EstimateRun(spec, unscaled, bed_here, model);
    double core_s = e.core_s_high;
    if (mode == DischargeMode::kRemove) {
      const double bodies = std::max(1.0, summary.value("bodies", e.bodies));
      const double left = summary.value("remaining", bodies) / bodies;
      const double bed_s = e.bed_disc_steps * (core_s / std::max(1.0, e.bed_disc_steps + e.disc_steps_high));
      core_s = bed_s + (core_s - bed_s) * 0.5 * (1.0 + left);
    }
    measured += wall * std::max(1, t.value("threads", 1));
    predicted += core_s;
  }
  if (predicted <= 0 || measured <= 0) return;
  cal.scale = measured / predicted;
  cal.scaled_from_runs = static_cast<int>(finished.size());
}

std::string CoreHoursText(double low_s, double high_s) {
  char buf[96];
  const double lo = low_s / 3600, hi = high_s / 3600;
  if (std::fabs(hi - lo) <= 0.05 * std::max(hi, 1e-9))
    std::snprintf(buf, sizeof buf, "%.3g core-hours", hi);
  else
    std::snprintf(buf, sizeof buf, "%.3g-%.3g core-hours", lo, hi);
  return buf;
}

std::string BytesText(double low, double high) {
  auto unit = [](double b) -> std::pair<double, const char*> {
    if (b >= 1e12) return {b / 1e12, "TB"};
    if (b >= 1e9) return {b / 1e9, "GB"};
    if (b >= 1e6) return {b / 1e6, "MB"};
    if (b >= 1e3) return {b / 1e3, "kB"};
    return {b, "B"};
  };
  char buf[96];
  const auto [hv, hu] = unit(high);
  if (std::fabs(high - low) <= 0.05 * std::max(high, 1.0)) {
    std::snprintf(buf, sizeof buf, "%.3g %s", hv, hu);
  } else {
    const auto [lv, lu] = unit(low);
    std::snprintf(buf, sizeof buf, "%.3g %s-%.3g %s", lv, lu, hv, hu);
  }
  return buf;
}

json to_json(const CampaignEstimate& e) {
  json points = json::array();
  for (const PointEstimate& p : e.points) {
    points.push_back({{"point_id", p.point_id},
                      {"point", p.point},
                      {"engine", p.engine},
                      {"runs", p.runs},
                      {"open_end", p.open_end},
                      {"core_hours", {p.core_s_low / 3600, p.core_s_high / 3600}},
                      {"bytes", {p.bytes_low, p.bytes_high}}});
  }
  const bool timed = e.calibration.Valid();
  auto range = [&](double lo, double hi) { return timed ? json{lo, hi} : json(nullptr); };
  return {{"runs", e.run_count},
          {"open_end_runs", e.open_end_runs},
          {"beds", e.beds},
          {"core_hours", range(e.core_s_low / 3600, e.core_s_high / 3600)},
          {"jobs", e.jobs},
          {"wall_s", range(e.wall_s_low, e.wall_s_high)},
          {"bytes", {e.bytes_low, e.bytes_high}},
          {"calibration",
           {{"disc_steps_per_s_disc", e.calibration.disc_rate},
            {"disc_steps_per_s_clump", e.calibration.clump_rate},
            {"scale", e.calibration.scale},
            {"scaled_from_runs", e.calibration.scaled_from_runs},
            {"source", e.calibration.source}}},
          {"method", e.method},
          {"points", points}};
}

}  // namespace granary::runner

// Implementation of run_analysis.h.
#include "analysis/run_analysis.h"

#include <cmath>
#include <limits>
#include <numbers>

namespace granary::analysis {

std::vector<OutletGeometry> outlets_of(const nlohmann::json& spec) {
  std::vector<OutletGeometry> out;
  const nlohmann::json silo = spec.is_object() ? spec.value("silo", nlohmann::json::object()) : nlohmann::json::object();
  const double half_width = 0.5 * silo.value("width", 100.0);
  if (silo.contains("base_outlets") && silo.at("base_outlets").is_array()) {
    for (const auto& o : silo.at("base_outlets")) {
      OutletGeometry g;
      g.center = o.value("center", 0.0);
      g.width = o.value("width", 10.0);
      out.push_back(g);
    }
  } else {
    out.push_back(OutletGeometry());
  }
  if (silo.contains("side_outlets") && silo.at("side_outlets").is_array()) {
    for (const auto& o : silo.at("side_outlets")) {
      OutletGeometry g;
      g.base = false;
      g.width = o.value("width", 25.0);
      g.center = o.value("bottom", 3.5) + 0.5 * g.width;
      const std::string wall = o.value("wall", std::string("right"));
      g.right_wall = wall != "left";
      g.wall_x = g.right_wall ? half_width : -half_width;
      g.label = "side " + std::to_string(out.size()) + " (" + wall + ")";
      out.push_back(g);
    }
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i].label.empty()) out[i].label = "base " + std::to_string(i);
  return out;
}

RunAnalysis analyse_events(const rundir::RunData& data, const AnalysisOptions& options) {
  RunAnalysis a;
  const nlohmann::json& spec = data.spec;
  const nlohmann::json discharge =
      spec.is_object() ? spec.value("discharge", nlohmann::json::object()) : nlohmann::json::object();
  a.run_id = data.summary.run_id.empty() && spec.is_object() ? spec.value("run_id", std::string())
                                                             : data.summary.run_id;
  a.engine = !data.summary.engine.empty() ? data.summary.engine
                                          : (spec.is_object() ? spec.value("engine", std::string("native")) : "native");
  a.end_reason = data.summary.end_reason;
  a.remove_mode = discharge.value("mode", std::string("remove")) == "remove";
  a.bodies = data.summary.bodies;
  if (a.bodies == 0 && spec.is_object() && spec.contains("bodies"))
    a.bodies = spec.at("bodies").value("count", 0);
  a.exited = data.has_summary ? data.summary.exited : static_cast<int>(data.events.size());
  a.t_end = data.summary.t_end;
  if (!data.events.empty()) a.t_end = std::max(a.t_end, data.events.back().time);
  a.clog_gap = options.clog_gap >= 0.0 ? options.clog_gap : discharge.value("clog_window", 5.0);
  a.outlets = outlets_of(spec);

  const std::size_t n_events = data.events.size();
  const std::size_t stride = std::max<std::size_t>(1, n_events / 200);
  for (std::size_t i = 0; i < n_events; i += stride) {
    a.cumulative_t.push_back(data.events[i].time);
    a.cumulative_n.push_back(static_cast<double>(i + 1));
  }
  if (n_events > 0 && (n_events - 1) % stride != 0) {
    a.cumulative_t.push_back(data.events.back().time);
    a.cumulative_n.push_back(static_cast<double>(n_events));
  }
  FlowInput in{data.events, a.remove_mode, a.bodies, a.clog_gap, -1};
  a.flow = flow_rate(in, options.window);
  const RunEnd end = run_end_of(a.end_reason);
  a.series = clog_series(data.events, -1, a.t_end, a.clog_gap, end, discharge.value("stop_on_clog", true));
  a.flow_per_outlet = flow_rate_per_outlet(in, options.window, static_cast<int>(a.outlets.size()));
  for (std::size_t o = 0; o < a.outlets.size(); ++o) {
    // A run that stopped on a clog stopped with every outlet blocked; one that discharged, with
    // every outlet open.
    a.series_per_outlet.push_back(clog_series(data.events, static_cast<int>(o), a.t_end, a.clog_gap, end));
  }
  if (data.summary.raw.is_object() && data.summary.raw.contains("clogs") && data.summary.raw.at("clogs").is_number())
    a.engine_clogs = data.summary.raw.at("clogs").get<int>();
  a.clog.clogged = end == RunEnd::kClogged;
  a.clog.bodies = a.bodies;
  a.clog.exited = a.exited;
  a.clog.undischarged = data.has_summary ? data.summary.remaining : a.bodies - a.exited;
  if (!a.flow.ok) a.notes.push_back("flow rate: " + a.flow.note);
  // The two records of the discharge must agree; a mismatch means a truncated or foreign file.
  if (data.has_summary && data.summary.exited != static_cast<int>(n_events))
    a.notes.push_back("events.csv has " + std::to_string(n_events) + " exits but summary.json says " +
                      std::to_string(data.summary.exited));
  return a;
}

void to_outlet_frame(const OutletGeometry& o, std::vector<rundir::Disc>& discs, std::vector<rundir::Body>& bodies) {
  // (x, y) -> (u, n): base: u = x - c, n = y. Right wall: u = y - c, n = X_w - x (a rotation).
  // Left wall: u = y - c, n = x - X_w (a reflection; omega changes sign, its squares do not).
  auto map = [&](double& x, double& y, double& vx, double& vy, double& omega) {
    if (o.base) {
      x -= o.center;
      return;
    }
    const double u = y - o.center, vu = vy;
    if (o.right_wall) {
      y = o.wall_x - x;
      vy = -vx;
    } else {
      y = x - o.wall_x;
      vy = vx;
      omega = -omega;
    }
    x = u;
    vx = vu;
  };
  for (rundir::Disc& d : discs) map(d.x, d.y, d.vx, d.vy, d.omega);
  for (rundir::Body& b : bodies) {
    map(b.x, b.y, b.vx, b.vy, b.omega);
    if (!o.base) b.theta = std::remainder(o.right_wall ? b.theta - 0.5 * std::numbers::pi
                                                        : 0.5 * std::numbers::pi - b.theta,
                                          2.0 * std::numbers::pi);
  }
}

void analyse_frames(const rundir::RunData& data, const AnalysisOptions& options, RunAnalysis& a) {
  if (!options.read_frames || !data.has_frames || a.outlets.empty()) return;
  double t0 = options.window.start_time;
  double t1 = std::numeric_limits<double>::infinity();
  if (a.flow.ok) {
    t0 = a.flow.t_start;
    t1 = a.flow.t_end;
  } else if (!a.series.flowing.empty() && a.series.flowing.front().complete && a.series.flowing.front().exits > 0) {
    t1 = a.series.flowing.front().end;  // no steady window: still only frames before the first clog
  }
  double density = 1.0;
  if (data.spec.is_object() && data.spec.contains("bodies")) density = data.spec.at("bodies").value("density", 1.0);
  rundir::FrameReader reader(data.frames_file(), density);
  std::vector<RegionAccumulator> regions;
  std::vector<VelocityProfileAccumulator> profiles;
  for (const OutletGeometry& o : a.outlets) {
    // In outlet coordinates every outlet is centred at 0 on the line y = 0.
    regions.emplace_back(region_above_outlet(0.0, o.width, options.region));
    profiles.emplace_back(0.0, o.width, options.profile);
  }
  rundir::Frame frame;
  int seen = 0, used = 0;
  while (reader.Next(frame)) {
    if (frame.time > t1) break;  // frames are in time order
    if (frame.time < t0) continue;
    if (seen++ % std::max(1, options.frame_stride) != 0) continue;
    const std::vector<rundir::Body> bodies = rundir::BodiesOf(frame.discs);
    for (std::size_t k = 0; k < a.outlets.size(); ++k) {
      std::vector<rundir::Disc> d = frame.discs;
      std::vector<rundir::Body> b = bodies;
      to_outlet_frame(a.outlets[k], d, b);
      regions[k].add(d, b);
      profiles[k].add(b);
    }
    ++used;
    if (options.max_frames > 0 && used >= options.max_frames) break;
  }
  if (used == 0) {
    a.notes.push_back("frames: none inside the window t = " + std::to_string(t0) + " .. " + std::to_string(t1));
    return;
  }
  for (std::size_t k = 0; k < a.outlets.size(); ++k) {
    a.region_per_outlet.push_back(regions[k].result());
    a.profile_per_outlet.push_back(profiles[k].result());
  }
  a.has_region = true;
  a.region = a.region_per_outlet.front();
  a.has_profile = true;
  a.profile = a.profile_per_outlet.front();
}

RunAnalysis analyse_run(const std::filesystem::path& dir, const AnalysisOptions& options) {
  const rundir::RunData data = rundir::ReadRun(dir);
  RunAnalysis a = analyse_events(data, options);
  analyse_frames(data, options, a);
  return a;
}

}  // namespace granary::analysis

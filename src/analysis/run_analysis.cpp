// Implementation of run_analysis.h.
#include "analysis/run_analysis.h"

#include <cmath>

namespace granary::analysis {

std::vector<OutletGeometry> outlets_of(const nlohmann::json& spec) {
  std::vector<OutletGeometry> out;
  const nlohmann::json silo = spec.is_object() ? spec.value("silo", nlohmann::json::object()) : nlohmann::json::object();
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
      g.label = "side " + std::to_string(out.size()) + " (" + o.value("wall", std::string("right")) + ")";
      out.push_back(g);
    }
  }
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i].label.empty()) out[i].label = "base " + std::to_string(i);
  return out;
}

RunAnalysis analyse_events(const RunData& data, const AnalysisOptions& options) {
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

  FlowInput in{data.events, a.remove_mode, a.bodies, a.clog_gap, -1};
  a.flow = flow_rate(in, options.window);
  const bool ended_clogged = a.end_reason == "clogged";
  a.series = clog_series(data.events, -1, a.t_end, a.clog_gap, ended_clogged);
  for (std::size_t o = 0; o < a.outlets.size(); ++o) {
    in.outlet = static_cast<int>(o);
    a.flow_per_outlet.push_back(flow_rate(in, options.window));
    // A run that stopped on a clog stopped with every outlet blocked.
    a.series_per_outlet.push_back(clog_series(data.events, static_cast<int>(o), a.t_end, a.clog_gap, ended_clogged));
  }
  a.clog.clogged = ended_clogged;
  a.clog.bodies = a.bodies;
  a.clog.exited = a.exited;
  a.clog.undischarged = data.has_summary ? data.summary.remaining : a.bodies - a.exited;
  if (!a.flow.ok) a.notes.push_back("flow rate: " + a.flow.note);
  return a;
}

void analyse_frames(const RunData& data, const AnalysisOptions& options, RunAnalysis& a) {
  if (!options.read_frames || !data.has_frames || a.outlets.empty() || !a.outlets.front().base) return;
  const OutletGeometry& outlet = a.outlets.front();
  double t0 = options.window.start_time;
  double t1 = std::numeric_limits<double>::infinity();
  if (a.flow.ok) {
    t0 = a.flow.t_start;
    t1 = a.flow.t_end;
  }
  double density = 1.0;
  if (data.spec.is_object() && data.spec.contains("bodies")) density = data.spec.at("bodies").value("density", 1.0);
  FrameReader reader(data.frames_file(), density);
  RegionAccumulator region(region_above_outlet(outlet.center, outlet.width, options.region));
  VelocityProfileAccumulator profile(outlet.center, outlet.width, options.profile);
  Frame frame;
  int seen = 0, used = 0;
  while (reader.next(frame)) {
    if (frame.time > t1) break;  // frames are in time order
    if (frame.time < t0) continue;
    if (seen++ % std::max(1, options.frame_stride) != 0) continue;
    const std::vector<Body> bodies = bodies_of(frame.discs);
    region.add(frame.discs, bodies);
    profile.add(bodies);
    ++used;
    if (options.max_frames > 0 && used >= options.max_frames) break;
  }
  if (used == 0) {
    a.notes.push_back("frames: none inside the window t = " + std::to_string(t0) + " .. " + std::to_string(t1));
    return;
  }
  a.has_region = true;
  a.region = region.result();
  a.has_profile = true;
  a.profile = profile.result();
}

RunAnalysis analyse_run(const std::filesystem::path& dir, const AnalysisOptions& options) {
  const RunData data = read_run(dir);
  RunAnalysis a = analyse_events(data, options);
  analyse_frames(data, options, a);
  return a;
}

}  // namespace granary::analysis

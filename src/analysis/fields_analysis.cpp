// See fields_analysis.h; the fields themselves are cg_fields.h, one run's window cg_run.h.
#include "analysis/fields_analysis.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "analysis/campaign_view.h"
#include "analysis/cg_run.h"
#include "analysis/options.h"
#include "analysis/region_analysis.h"

namespace granary::analysis {

std::vector<CgField> ThesisMaps() {
  return {CgField::kPhi, CgField::kSpeed,    CgField::kOmega, CgField::kOmegaFl2,
          CgField::kTg,  CgField::kPressure, CgField::kShear, CgField::kFriction};
}

FieldsOptions::FieldsOptions() : maps(ThesisMaps()) {}

bool FieldsNeedContacts(const FieldsOptions& options) {
  if (options.force_chains) return true;
  return std::any_of(options.maps.begin(), options.maps.end(),
                     [](CgField f) { return CgFieldInfoFor(f).needs_contacts; });
}

namespace {

const char* FramesName(FieldsOptions::Frames f) {
  switch (f) {
    case FieldsOptions::Frames::kSteady: return "steady";
    case FieldsOptions::Frames::kAll: return "all";
    case FieldsOptions::Frames::kSplit: return "split";
    case FieldsOptions::Frames::kRange: return "range";
  }
  return "steady";
}

// The fields every run's region means include besides the mapped ones.
constexpr CgField kRegionFields[] = {CgField::kPhi,      CgField::kSpeed, CgField::kTg,
                                     CgField::kPressure, CgField::kShear, CgField::kFriction};

std::vector<CgField> RegionFields(const FieldsOptions& o) {
  std::vector<CgField> out(std::begin(kRegionFields), std::end(kRegionFields));
  for (CgField f : o.maps)
    if (std::find(out.begin(), out.end(), f) == out.end()) out.push_back(f);
  return out;
}

}  // namespace

nlohmann::json FieldsOptions::ToJson() const {
  nlohmann::json m = nlohmann::json::array();
  for (CgField f : maps) m.push_back(CgFieldInfoFor(f).name);
  nlohmann::json j = {{"maps", m},
                      {"width", cg.width},
                      {"cutoff", cg.cutoff},
                      {"spacing", cg.spacing},
                      {"min_phi", cg.min_phi},
                      {"frames", FramesName(frames)},
                      {"series", series},
                      {"force_chains", force_chains},
                      {"region", {region.pad, region.height}}};
  // A size in d keeps the key its cached results have.
  if (region.in_d_eq) j["region_unit"] = "D_eq";
  if (cg.window.x1 > cg.window.x0) j["window"] = {cg.window.x0, cg.window.x1, cg.window.y0, cg.window.y1};
  if (frames == Frames::kRange) j["range"] = {from, to};
  return j;
}

std::optional<FieldsOptions> ReadFieldsOptions(const nlohmann::json& j, const std::string& path) {
  if (j.is_null()) return std::nullopt;
  if (j.is_boolean()) {
    if (!j.get<bool>()) return std::nullopt;
    return FieldsOptions();
  }
  OptionObject(
      j, path,
      {"maps", "width", "cutoff", "spacing", "window", "min_phi", "frames", "series", "force_chains", "region"});
  FieldsOptions o;
  constexpr double kBig = 1e300;
  for (const auto& [key, v] : j.items()) {
    const std::string p = path + "/" + key;
    if (key == "maps") {
      if (!v.is_array() || v.empty()) throw OptionError(p, v, "must be a non-empty array of field names");
      o.maps.clear();
      for (std::size_t i = 0; i < v.size(); ++i) {
        CgField f;
        if (!v[i].is_string() || !CgFieldByName(v[i].get<std::string>(), f)) {
          std::string allowed;
          for (const CgFieldInfo& info : CgFieldTable())
            allowed += (allowed.empty() ? "" : ", ") + std::string(info.name);
          throw OptionError(p + "/" + std::to_string(i), v[i], "must be a field name (" + allowed + ")");
        }
        if (std::find(o.maps.begin(), o.maps.end(), f) == o.maps.end()) o.maps.push_back(f);
      }
    } else if (key == "width") {
      o.cg.width = OptionNumber(v, p, 0.05, 100.0);
    } else if (key == "cutoff") {
      o.cg.cutoff = OptionNumber(v, p, 1.0, 10.0);
    } else if (key == "spacing") {
      o.cg.spacing = OptionNumber(v, p, 0.05, 100.0);
    } else if (key == "min_phi") {
      o.cg.min_phi = OptionNumber(v, p, 0.0, 1.0);
    } else if (key == "window") {
      bool ok = v.is_array() && v.size() == 4;
      for (std::size_t i = 0; ok && i < 4; ++i) ok = v[i].is_number() && std::isfinite(v[i].get<double>());
      if (ok) o.cg.window = {v[0].get<double>(), v[1].get<double>(), v[2].get<double>(), v[3].get<double>()};
      if (!ok || !(o.cg.window.x1 > o.cg.window.x0) || !(o.cg.window.y1 > o.cg.window.y0))
        throw OptionError(p, v, "must be [x0, x1, y0, y1] in d with x0 < x1 and y0 < y1");
    } else if (key == "frames") {
      if (v == "steady") {
        o.frames = FieldsOptions::Frames::kSteady;
      } else if (v == "all") {
        o.frames = FieldsOptions::Frames::kAll;
      } else if (v == "split") {
        o.frames = FieldsOptions::Frames::kSplit;
      } else if (v.is_object()) {
        OptionObject(v, p, {"from", "to"});
        o.frames = FieldsOptions::Frames::kRange;
        o.from = v.contains("from") ? OptionNumber(v.at("from"), p + "/from", 0.0, kBig) : 0.0;
        o.to = v.contains("to") ? OptionNumber(v.at("to"), p + "/to", 0.0, kBig) : kBig;
        if (!(o.to > o.from)) throw OptionError(p + "/to", v.value("to", nlohmann::json()), "must be > from");
      } else {
        throw OptionError(p, v, "must be \"steady\", \"all\", \"split\" or {\"from\": T, \"to\": T}");
      }
    } else if (key == "series") {
      o.series = OptionBool(v, p);
    } else if (key == "force_chains") {
      o.force_chains = OptionBool(v, p);
    } else if (key == "region") {
      o.region = ReadRegionSize(v, p);
    }
  }
  // The kernel must reach the next node: a grid coarser than the kernel's cut misses mass.
  if (o.cg.spacing > 0.5 * o.cg.cutoff * o.cg.width)
    throw OptionError(
        path + "/spacing", o.cg.spacing,
        "must be <= half the kernel's reach cutoff * width = " + FormatNumber(0.5 * o.cg.cutoff * o.cg.width));
  return o;
}

Rect OutletRegion(const OutletGeometry& o, const RegionSize& size) {
  const double half = 0.5 * (o.width + size.pad);
  if (o.base) return {o.center - half, o.center + half, 0.0, size.height};
  if (o.right_wall) return {o.wall_x - size.height, o.wall_x, o.center - half, o.center + half};
  return {o.wall_x, o.wall_x + size.height, o.center - half, o.center + half};
}

SiloDrawing MakeSiloDrawing(const nlohmann::json& spec, double top) {
  SiloDrawing d;
  const nlohmann::json silo =
      spec.is_object() ? spec.value("silo", nlohmann::json::object()) : nlohmann::json::object();
  const double half = 0.5 * silo.value("width", 100.0);
  const std::vector<OutletGeometry> outlets = OutletsOf(spec);
  // A wall from `from` to `to` along one axis with the outlets' gaps left open.
  auto wall = [&](std::vector<std::pair<double, double>> gaps, double from, double to, auto point) {
    std::sort(gaps.begin(), gaps.end());
    for (const auto& [lo, hi] : gaps) {
      if (lo > from) d.lines.push_back({point(from), point(lo)});
      from = std::max(from, hi);
    }
    if (to > from) d.lines.push_back({point(from), point(to)});
  };
  std::vector<std::pair<double, double>> base, left, right;
  for (const OutletGeometry& o : outlets)
    (o.base ? base : o.right_wall ? right : left).emplace_back(o.center - 0.5 * o.width, o.center + 0.5 * o.width);
  wall(base, -half, half, [](double x) { return std::array<double, 2>{x, 0.0}; });
  wall(left, 0.0, top, [&](double y) { return std::array<double, 2>{-half, y}; });
  wall(right, 0.0, top, [&](double y) { return std::array<double, 2>{half, y}; });
  if (silo.contains("obstacles") && silo.at("obstacles").is_array())
    for (const auto& ob : silo.at("obstacles"))
      if (ob.is_object())
        d.circles.push_back({ob.value("x", 0.0), ob.value("y", 10.0), 0.5 * ob.value("diameter", 6.0)});
  return d;
}

namespace {

// The channels of CgSums, by name (the JSON keys).
using Channel = std::vector<double> CgSums::*;
constexpr std::pair<const char*, Channel> kChannels[] = {{"phi", &CgSums::phi},
                                                         {"vx", &CgSums::vx},
                                                         {"vy", &CgSums::vy},
                                                         {"omega", &CgSums::omega},
                                                         {"omega_fl2", &CgSums::omega_fl2},
                                                         {"tg", &CgSums::tg},
                                                         {"tg_eq46", &CgSums::tg_eq46},
                                                         {"sxx", &CgSums::sxx},
                                                         {"sxy", &CgSums::sxy},
                                                         {"syx", &CgSums::syx},
                                                         {"syy", &CgSums::syy},
                                                         {"kxx", &CgSums::kxx},
                                                         {"kxy", &CgSums::kxy},
                                                         {"kyy", &CgSums::kyy}};

void KeepRows(CgSums& s, int ny) {
  if (ny >= s.grid.ny) return;
  const std::size_t n = static_cast<std::size_t>(s.grid.nx) * static_cast<std::size_t>(ny);
  for (const auto& [name, member] : kChannels) (s.*member).resize(std::min((s.*member).size(), n));
  s.n_defined.resize(std::min(s.n_defined.size(), n));
  s.grid.ny = ny;
}

}  // namespace

nlohmann::json SumsToJson(const CgSums& s) {
  nlohmann::json j = {
      {"grid",
       {{"x0", s.grid.x0}, {"y0", s.grid.y0}, {"spacing", s.grid.spacing}, {"nx", s.grid.nx}, {"ny", s.grid.ny}}},
      {"frames", s.frames},
      {"contact_frames", s.contact_frames},
      {"n_defined", s.n_defined}};
  for (const auto& [name, member] : kChannels) j[name] = JsonNumbers(s.*member);
  return j;
}

CgSums SumsFromJson(const nlohmann::json& j) {
  CgSums s;
  const nlohmann::json& g = j.at("grid");
  CgGrid grid;
  grid.x0 = g.at("x0").get<double>();
  grid.y0 = g.at("y0").get<double>();
  grid.spacing = g.at("spacing").get<double>();
  grid.nx = g.at("nx").get<int>();
  grid.ny = g.at("ny").get<int>();
  s.Resize(grid);
  s.frames = j.at("frames").get<int>();
  s.contact_frames = j.at("contact_frames").get<int>();
  const auto n_defined = j.at("n_defined").get<std::vector<std::int32_t>>();
  if (n_defined.size() == s.n_defined.size()) s.n_defined = n_defined;
  for (const auto& [name, member] : kChannels) {
    std::vector<double> v = NumbersOf(j.at(name));
    if (v.size() == (s.*member).size()) s.*member = std::move(v);
  }
  return s;
}

bool AddCommonRows(CgSums& sums, const CgSums& other) {
  if (sums.grid.nx == 0 || sums.frames == 0) {
    if (other.frames == 0 && sums.grid.nx != 0) return true;
    sums = other;
    return true;
  }
  if (other.frames == 0) return true;
  const CgGrid &a = sums.grid, &b = other.grid;
  auto same = [](double x, double y) { return std::abs(x - y) <= 1e-9 * std::max(1.0, std::abs(x)); };
  if (a.nx != b.nx || !same(a.x0, b.x0) || !same(a.y0, b.y0) || !same(a.spacing, b.spacing)) return false;
  const int ny = std::min(a.ny, b.ny);
  KeepRows(sums, ny);
  if (b.ny == ny) {
    sums.Add(other);
  } else {
    CgSums cropped = other;
    KeepRows(cropped, ny);
    sums.Add(cropped);
  }
  return true;
}

namespace {

std::string Suffix(std::size_t k) { return k == 0 ? "" : OutletSuffix(k); }

nlohmann::json RectJson(const Rect& r) { return {r.x0, r.x1, r.y0, r.y1}; }

// One frame's strong force network (|F| above the frame's mean, as Radjai splits it): segments
// between the touching discs' centres, a wall contact from the disc to its contact point.
nlohmann::json ForceChainJson(const rundir::ContactFrame& frame, const Rect& view) {
  double sum = 0.0;
  for (const rundir::ContactRow& c : frame.contacts) sum += std::hypot(c.fx, c.fy);
  const double mean = frame.contacts.empty() ? 0.0 : sum / static_cast<double>(frame.contacts.size());
  nlohmann::json segments = nlohmann::json::array();
  for (const rundir::ContactRow& c : frame.contacts) {
    const double f = std::hypot(c.fx, c.fy);
    if (!(f > mean)) continue;
    const double x2 = c.body_j >= 0 ? c.xj : c.cx, y2 = c.body_j >= 0 ? c.yj : c.cy;
    if (view.Contains(c.xi, c.yi) || view.Contains(x2, y2)) segments.push_back({c.xi, c.yi, x2, y2, f});
  }
  return {{"time", frame.time}, {"contacts", frame.contacts.size()}, {"mean_force", mean}, {"segments", segments}};
}

class FieldsRunAccumulator : public RunAccumulator {
 public:
  FieldsRunAccumulator(const RunView& run, const FieldsOptions& o)
      : run_(run), o_(o), region_(RegionForRun(o.region, run.data->spec)) {
    cg_ = o.cg;
    if (!(cg_.window.x1 > cg_.window.x0)) cg_.window = CgRunWindow(*run.data);
    const double start = run.options ? run.options->window.start_time : 0.0;
    constexpr double kInf = std::numeric_limits<double>::infinity();
    switch (o.frames) {
      case FieldsOptions::Frames::kSteady:
        windows_ = {run.steady};
        parts_ = {"steady"};
        break;
      case FieldsOptions::Frames::kAll:
        windows_ = {{start, kInf}};
        parts_ = {"all"};
        break;
      case FieldsOptions::Frames::kSplit:
        windows_ = {{start, kInf}};
        parts_ = {"flowing", "clogged"};
        break;
      case FieldsOptions::Frames::kRange:
        windows_ = {{o.from, o.to}};
        parts_ = {"range"};
        break;
    }
    std::vector<CgSeriesRequest> series;
    if (o.series)
      for (const OutletGeometry& g : run.outlets)
        series.push_back({g.label, OutletRegion(g, region_), CgField::kSpeed});
    for (std::size_t p = 0; p < parts_.size(); ++p) acc_.emplace_back(cg_, series);
    first_.assign(parts_.size(), kNaN);
    last_.assign(parts_.size(), kNaN);
    chains_.assign(parts_.size(), nullptr);
  }
  FrameRequest Frames() const override { return {windows_, FieldsNeedContacts(o_)}; }
  void AddFrame(const FrameView& f) override {
    const double t = f.frame.time;
    std::size_t part = 0;
    if (o_.frames == FieldsOptions::Frames::kSplit &&
        std::any_of(run_.clogged.begin(), run_.clogged.end(), [&](const TimeWindow& w) { return w.Contains(t); }))
      part = 1;
    acc_[part].AddFrame(t, f.frame.discs, f.contacts);
    if (std::isnan(first_[part])) first_[part] = t;
    last_[part] = t;
    if (o_.force_chains && f.contacts && chains_[part].is_null() && !f.contacts->contacts.empty())
      chains_[part] = ForceChainJson(*f.contacts, cg_.window);
  }
  nlohmann::json Finish() override {
    nlohmann::json result = {{"frames_mode", FramesName(o_.frames)},
                             {"window", RectJson(cg_.window)},
                             {"outlets", nlohmann::json::array()},
                             {"parts", nlohmann::json::array()},
                             {"notes", nlohmann::json::array()}};
    for (const OutletGeometry& g : run_.outlets) result["outlets"].push_back(g.label);
    int frames = 0;
    for (std::size_t p = 0; p < parts_.size(); ++p) {
      const CgSums& sums = acc_[p].Sums();
      frames += sums.frames;
      const CgMaps maps(sums);
      nlohmann::json part = {{"name", parts_[p]},
                             {"frames", sums.frames},
                             {"contact_frames", sums.contact_frames},
                             {"first_time", JsonNumber(first_[p])},
                             {"last_time", JsonNumber(last_[p])},
                             {"sums", SumsToJson(sums)},
                             {"regions", nlohmann::json::array()}};
      for (const OutletGeometry& g : run_.outlets) {
        const Rect r = OutletRegion(g, region_);
        nlohmann::json means = nlohmann::json::object();
        for (CgField f : RegionFields(o_))
          means[CgFieldInfoFor(f).name] =
              JsonNumber(sums.frames > 0 && maps.Has(f) ? MeanOverRegion(maps, f, r).value : kNaN);
        part["regions"].push_back({{"rect", RectJson(r)}, {"means", means}});
      }
      if (!chains_[p].is_null()) part["force_chain"] = chains_[p];
      result["parts"].push_back(part);
    }
    if (o_.series) {
      // The series of every part, merged in time order (split: flowing and clogged frames).
      nlohmann::json series = nlohmann::json::array();
      for (std::size_t k = 0; k < run_.outlets.size(); ++k) {
        std::vector<std::pair<double, double>> points;
        for (const CgAccumulator& a : acc_)
          if (k < a.Series().size())
            for (std::size_t i = 0; i < a.Series()[k].time.size(); ++i)
              points.emplace_back(a.Series()[k].time[i], a.Series()[k].value[i]);
        std::sort(points.begin(), points.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        std::vector<double> t, v;
        for (const auto& [ti, vi] : points) {
          t.push_back(ti);
          v.push_back(vi);
        }
        series.push_back({{"outlet", run_.outlets[k].label}, {"time", JsonNumbers(t)}, {"speed", JsonNumbers(v)}});
      }
      result["series"] = series;
    }
    if (frames == 0 && run_.data->has_frames) {
      std::string where;
      for (const TimeWindow& w : windows_) where += FormatNumber(w.start) + " .. " + FormatNumber(w.end);
      result["notes"].push_back("fields: no frame inside t = " + where);
    }
    if (FieldsNeedContacts(o_) && !run_.data->has_contacts && run_.data->has_frames)
      result["notes"].push_back("fields: no contacts.dump (output.contact_forces off): no stress maps or force chains");
    return result;
  }

 private:
  const RunView& run_;
  const FieldsOptions& o_;
  RegionSize region_;  // o_.region in d for this run
  CgOptions cg_;
  std::vector<TimeWindow> windows_;
  std::vector<std::string> parts_;
  std::vector<CgAccumulator> acc_;
  std::vector<double> first_, last_;
  std::vector<nlohmann::json> chains_;
};

// The per-run metrics' field names: region means above each outlet, part 0 (and "_clogged"
// for the clogged part of a split).
constexpr const char* kMetricPrefix = "cg_";

bool Diverging(CgField f) {
  return f == CgField::kVx || f == CgField::kVy || f == CgField::kOmega || f == CgField::kSigmaXX ||
         f == CgField::kSigmaXY || f == CgField::kSigmaYY;
}

std::string ValueName(CgField f) {
  const CgFieldInfo& info = CgFieldInfoFor(f);
  return std::string(info.title) + (info.unit[0] != '\0' ? std::string(" (") + info.unit + ")" : std::string());
}

class FieldsAnalysis : public Analysis {
 public:
  explicit FieldsAnalysis(FieldsOptions o) : o_(std::move(o)) {}
  std::string Key() const override { return "fields"; }
  int Version() const override { return 1; }
  nlohmann::json RunOptions() const override { return o_.ToJson(); }
  PassUse PassOptionsUsed() const override {
    return {.window = true, .clog_gap = o_.frames == FieldsOptions::Frames::kSplit, .frames = true};
  }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    return std::make_unique<FieldsRunAccumulator>(run, o_);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    std::vector<Metric> m;
    if (!result.contains("parts")) return m;
    const nlohmann::json labels = result.value("outlets", nlohmann::json::array());
    const nlohmann::json& parts = result.at("parts");
    for (std::size_t p = 0; p < parts.size() && p < 2; ++p) {
      const std::string part = p == 0 ? "" : "_" + parts[p].value("name", std::string("part"));
      const nlohmann::json& regions = parts[p].at("regions");
      for (std::size_t k = 0; k < regions.size(); ++k) {
        const std::string where = (k == 0 ? std::string(" above the outlet") : " next to " + StringAt(labels, k)) +
                                  (p == 0 ? "" : " (" + parts[p].value("name", std::string()) + ")");
        for (const auto& [name, value] : regions[k].at("means").items()) {
          CgField f;
          if (!CgFieldByName(name, f)) continue;
          m.push_back({kMetricPrefix + name + part + Suffix(k),
                       CgFieldInfoFor(f).unit[0] ? CgFieldInfoFor(f).unit : "1", NumberOf(value), kNaN,
                       std::string("coarse-grained ") + CgFieldInfoFor(f).title + where, false});
        }
      }
    }
    return m;
  }
  std::optional<Section> BuildSection(const SectionInput& in) const override;
  // Every field of the table (the sums hold them all), of the first part of the frames; with
  // frames "split" also each one of the clogged frames, "<name>_clogged".
  std::vector<FieldInfo> FieldNames() const override {
    std::vector<FieldInfo> out;
    for (const std::string part : {"", "_clogged"}) {
      if (!part.empty() && o_.frames != FieldsOptions::Frames::kSplit) break;
      for (const CgFieldInfo& info : CgFieldTable())
        out.push_back({info.name + part, std::string(info.title) + (part.empty() ? "" : " (clogged)"), info.unit,
                       Diverging(info.field)});
    }
    return out;
  }
  std::optional<FieldMap> Field(const std::string& name, const std::vector<const nlohmann::json*>& results,
                                const nlohmann::json& run_spec) const override {
    const bool clogged = name.size() > 8 && name.ends_with("_clogged");
    const std::size_t part = clogged ? 1 : 0;
    CgField f;
    if (!CgFieldByName(clogged ? name.substr(0, name.size() - 8) : name, f)) return std::nullopt;
    CgSums merged;
    int runs = 0;
    for (const nlohmann::json* r : results) {
      if (!r || !r->contains("parts") || r->at("parts").size() <= part) continue;
      const nlohmann::json& p = r->at("parts").at(part);
      if (p.value("frames", 0) == 0) continue;
      if (!AddCommonRows(merged, SumsFromJson(p.at("sums")))) return std::nullopt;
      ++runs;
    }
    if (runs == 0) return std::nullopt;
    const CgMaps maps(std::move(merged));
    if (!maps.Has(f)) return std::nullopt;
    FieldMap out;
    const CgGrid& g = maps.Grid();
    out.x0 = g.x0;
    out.y0 = g.y0;
    out.spacing = g.spacing;
    out.nx = g.nx;
    out.ny = g.ny;
    out.values = maps.Values(f);
    for (std::size_t n = 0; n < g.size(); ++n) out.n_frames.push_back(maps.NFrames(f, n));
    out.runs = runs;
    out.frames = CgFieldInfoFor(f).needs_contacts ? maps.ContactFrames() : maps.Frames();
    const SiloDrawing silo = MakeSiloDrawing(run_spec, g.Y(g.ny - 1) + 1.5);
    out.lines = silo.lines;
    out.circles = silo.circles;
    // |v| with its direction, as the section draws it: about 12 arrows across.
    if (f == CgField::kSpeed) {
      const int step = std::max(1, g.nx / 12);
      out.arrow_spacing = step * g.spacing;
      for (int j = step / 2; j < g.ny; j += step)
        for (int i = step / 2; i < g.nx; i += step) {
          const std::size_t n =
              static_cast<std::size_t>(j) * static_cast<std::size_t>(g.nx) + static_cast<std::size_t>(i);
          const double vx = maps.Value(CgField::kVx, n), vy = maps.Value(CgField::kVy, n);
          if (std::isfinite(vx) && std::isfinite(vy) && (vx != 0.0 || vy != 0.0))
            out.arrows.push_back({g.X(i), g.Y(j), vx, vy});
        }
    }
    return out;
  }

 private:
  FieldsOptions o_;
};

std::optional<Section> FieldsAnalysis::BuildSection(const SectionInput& in) const {
  const CampaignView& v = in.view;
  // Each point's sums per part, merged over its replicas.
  struct PointMaps {
    std::vector<CgMaps> parts;
    std::vector<int> runs;
    const nlohmann::json* chain_run = nullptr;
    std::size_t chain_part = 0;
    const nlohmann::json* series_run = nullptr;
  };
  std::vector<PointMaps> points(v.points.size());
  std::vector<std::string> part_names;
  std::vector<std::string> problems;
  bool any = false;
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    std::vector<CgSums> merged;
    std::vector<int> runs;
    for (const nlohmann::json* r : in.results.OfPoint(p)) {
      if (!r->contains("parts")) continue;
      const nlohmann::json& parts = r->at("parts");
      if (merged.size() < parts.size()) {
        merged.resize(parts.size());
        runs.resize(parts.size(), 0);
      }
      for (std::size_t k = 0; k < parts.size(); ++k) {
        if (part_names.size() <= k) part_names.push_back(parts[k].value("name", std::string("part")));
        if (parts[k].value("frames", 0) == 0) continue;
        if (!AddCommonRows(merged[k], SumsFromJson(parts[k].at("sums")))) {
          problems.push_back(PointName(v, v.points[p]) + ": a replica's grid differs (window or spacing); left out");
          continue;
        }
        ++runs[k];
        // Force chains: the first replica's clogged frame if it has one, else its first.
        if (parts[k].contains("force_chain") &&
            (!points[p].chain_run || (k > points[p].chain_part && points[p].chain_run == r))) {
          points[p].chain_run = r;
          points[p].chain_part = k;
        }
      }
      if (!points[p].series_run && r->contains("series") && !r->at("series").empty()) points[p].series_run = r;
    }
    for (CgSums& s : merged) {
      any = any || s.frames > 0;
      points[p].parts.emplace_back(std::move(s));
    }
    points[p].runs = runs;
  }
  if (!any) return std::nullopt;
  Section s{"fields", "Coarse-grained fields", {}};
  const char* frames_text = o_.frames == FieldsOptions::Frames::kSteady
                                ? "the frames of the steady window of the flow analysis"
                            : o_.frames == FieldsOptions::Frames::kAll ? "all frames after /report/window/start_time"
                            : o_.frames == FieldsOptions::Frames::kSplit
                                ? "all frames after /report/window/start_time, split into flowing and clogged (the "
                                  "clogged states of the exit stream)"
                                : "the frames of the time range /report/fields/frames";
  s.blocks.push_back(Text{
      "Time-averaged continuum fields (thesis eqs. 4.1-4.8): every frame's discs and contacts smeared onto a grid "
      "of spacing " +
      FormatNumber(o_.cg.spacing) + " d with the Gaussian kernel W(r) = exp(-r^2/w^2)/(pi w^2), w = " +
      FormatNumber(o_.cg.width) + " d, cut at " + FormatNumber(o_.cg.cutoff) + "w; over " + frames_text +
      ", summed over the replicas of each point (one colour scale per field across the panels). Velocity, "
      "Omega and T_g average over the frames where phi >= " +
      FormatNumber(o_.cg.min_phi) +
      " at a node. Pressure P, shear stress |tau| and mu = |tau|/P are of the **contact stress** of eq. 4.7 "
      "(each contact's force times its branch vector with the kernel integrated along the branch), as the thesis' "
      "maps; `kinetic_*` and `total_*` maps name the kinetic part and the sum. Each map's grid is a CSV (x, y, value, "
      "n_frames); docs/analyses.md \"Coarse-grained fields\" gives every definition."});
  // The view: the silo's width and from below the base to above the highest grid row.
  double half = 0.0, top = 0.0, spacing = o_.cg.spacing;
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    const nlohmann::json& spec = v.points[p].spec;
    if (spec.is_object() && spec.contains("silo")) half = std::max(half, 0.5 * spec.at("silo").value("width", 100.0));
    for (const CgMaps& m : points[p].parts)
      if (m.Frames() > 0) top = std::max(top, m.Grid().Y(m.Grid().ny - 1) + 1.5);
  }
  if (!(half > 0.0)) half = 50.0;
  auto base_figure = [&](const std::string& name, const std::string& title, const std::string& value) {
    MapFigure f;
    f.name = name;
    f.title = title;
    f.value_name = value;
    f.x_lo = -half - 1.0;
    f.x_hi = half + 1.0;
    f.y_lo = -2.0;
    f.y_hi = top + 1.0;
    return f;
  };
  auto panel_of = [&](std::size_t p, const std::string& title) {
    MapPanel panel;
    panel.title = title;
    const SiloDrawing silo = MakeSiloDrawing(v.points[p].spec, top);
    panel.lines = silo.lines;
    panel.circles = silo.circles;
    return panel;
  };
  // Panel titles: the point's sweep values (the axes' names once, in the caption).
  std::string axes_text;
  for (const std::string& axis : v.axes)
    axes_text += (axes_text.empty() ? "" : ", ") +
                 AxisText(v, axis, v.points.empty() ? nlohmann::json() : v.points.front().spec, NameForm::kLong);
  // "W = 6 d, X_db = 0.5": a value without its name and unit reads as nothing once there are two axes.
  auto values_of = [&](std::size_t p) {
    const std::string text = PointLabelWithUnits(v, v.points[p].point, v.points[p].spec);
    return text.empty() ? PointName(v, v.points[p]) : text;
  };
  const std::string panels_text = axes_text.empty() ? "" : "Panels: " + axes_text + "; ";
  const std::size_t n_parts = part_names.size();
  for (CgField field : o_.maps) {
    const CgFieldInfo& info = CgFieldInfoFor(field);
    for (std::size_t k = 0; k < n_parts; ++k) {
      const std::string part = n_parts > 1 ? " (" + part_names[k] + ")" : "";
      MapFigure f = base_figure(std::string("field_") + info.name + (n_parts > 1 ? "_" + part_names[k] : ""),
                                std::string(info.title) + part, ValueName(field));
      f.diverging = Diverging(field);
      // Velocity arrows over |v|: about 12 across, the longest 0.9 of their spacing.
      double max_speed = 0.0;
      int step = 0;
      if (field == CgField::kSpeed) {
        for (const PointMaps& pm : points)
          if (k < pm.parts.size())
            for (double x : pm.parts[k].Values(CgField::kSpeed))
              if (std::isfinite(x)) max_speed = std::max(max_speed, x);
        for (const PointMaps& pm : points)
          if (k < pm.parts.size() && pm.parts[k].Frames() > 0) step = std::max(1, pm.parts[k].Grid().nx / 12);
      }
      for (std::size_t p = 0; p < v.points.size(); ++p) {
        if (k >= points[p].parts.size() || points[p].parts[k].Frames() == 0) continue;
        const CgMaps& maps = points[p].parts[k];
        if (!maps.Has(field)) continue;
        MapPanel panel =
            panel_of(p, values_of(p) + ": " + std::to_string(points[p].runs[k]) + " runs, " +
                            std::to_string(info.needs_contacts ? maps.ContactFrames() : maps.Frames()) + " frames");
        const CgGrid& g = maps.Grid();
        panel.grid.reserve(g.size());
        for (int j = 0; j < g.ny; ++j)
          for (int i = 0; i < g.nx; ++i) {
            const std::size_t n =
                static_cast<std::size_t>(j) * static_cast<std::size_t>(g.nx) + static_cast<std::size_t>(i);
            panel.grid.push_back({g.X(i), g.Y(j), maps.Value(field, n), static_cast<double>(maps.NFrames(field, n))});
          }
        if (step > 0 && max_speed > 0.0) {
          const double scale = 0.9 * step * spacing / max_speed;
          for (int j = step / 2; j < g.ny; j += step)
            for (int i = step / 2; i < g.nx; i += step) {
              const std::size_t n =
                  static_cast<std::size_t>(j) * static_cast<std::size_t>(g.nx) + static_cast<std::size_t>(i);
              const double vx = maps.Value(CgField::kVx, n), vy = maps.Value(CgField::kVy, n);
              if (std::isfinite(vx) && std::isfinite(vy) && (vx != 0.0 || vy != 0.0))
                panel.arrows.push_back({g.X(i), g.Y(j), scale * vx, scale * vy});
            }
        }
        f.panels.push_back(std::move(panel));
      }
      if (f.panels.empty()) continue;
      f.value_key = info.name;
      f.caption = panels_text + "runs and " + (info.needs_contacts ? "contact frames" : "frames") +
                  " behind each panel in its title; walls black" +
                  (field == CgField::kSpeed
                       ? "; arrows: the velocity field, the longest " + FormatNumber(0.9 * step * spacing) + " d for " +
                             FormatNumber(max_speed) + " sqrt(g d)"
                       : std::string()) +
                  (info.needs_contacts ? "; contact stress (eq. 4.7)" : "");
      s.blocks.push_back(f);
    }
  }
  // Force chains of one frame per point.
  MapFigure chains = base_figure("force_chains", "Force chains of one frame", "|F| (rho g d^2)");
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    if (!points[p].chain_run) continue;
    const nlohmann::json& part = points[p].chain_run->at("parts").at(points[p].chain_part);
    const nlohmann::json& chain = part.at("force_chain");
    MapPanel panel = panel_of(
        p, values_of(p) + ": " + part.value("name", std::string()) + ", t = " + FormatNumber(NumberAt(chain, "time")));
    for (const auto& seg : chain.at("segments"))
      panel.segments.push_back(
          {NumberOf(seg[0]), NumberOf(seg[1]), NumberOf(seg[2]), NumberOf(seg[3]), NumberOf(seg[4])});
    chains.panels.push_back(std::move(panel));
  }
  if (!chains.panels.empty()) {
    chains.value_key = "force";
    chains.caption =
        panels_text +
        "the strong network: contacts carrying more than the frame's mean force, drawn from disc centre "
        "to disc centre (a wall contact to its contact point) with width in proportion to |F| (thesis fig. "
        "4.16); the first replica of each point, its first clogged frame if it has one, else its first "
        "frame of the fields' window";
    s.blocks.push_back(chains);
  }
  // Region means above each outlet (the point metrics: mean ± se over replicas).
  const std::size_t outlets = std::max<std::size_t>(1, v.outlets);
  Table t{"fields_region",
          "Coarse-grained fields averaged over the region next to each outlet (" + o_.region.label +
              "): mean ± se over replicas (n); mu = mean |tau| / mean P of the region",
          {"point", "outlet", "phi", "|v| (sqrt(g d))", "T_g (g d)", "P (rho g d)", "|tau| (rho g d)", "mu"},
          {},
          {"point", "outlet", "phi", "speed", "tg", "pressure", "shear", "friction"}};
  for (std::size_t p = 0; p < v.points.size(); ++p)
    for (std::size_t k = 0; k < outlets; ++k) {
      std::vector<Cell> row = {PointName(v, v.points[p]), k < v.outlet_labels.size() ? v.outlet_labels[k] : ""};
      bool has = false;
      for (const char* name : {"phi", "speed", "tg", "pressure", "shear", "friction"}) {
        const PointMetric* m = FindMetric(in.points[p], kMetricPrefix + std::string(name) + Suffix(k));
        has = has || (m && m->n > 0);
        row.push_back(m ? Cell::Estimate(m->Estimate()) : Cell());
      }
      if (has) t.rows.push_back(row);
    }
  if (!t.rows.empty()) s.blocks.push_back(t);
  // The speed above each outlet against time, first replica of each point (thesis fig. 7.2).
  Figure series{"fields_speed_series",
                "Coarse-grained speed over the region next to the outlet against time",
                "t (sqrt(d/g))",
                "|v| (sqrt(g d))",
                {},
                false,
                false,
                "The mean of the frame's |v| over the nodes inside the region; the first replica of each point"};
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    if (!points[p].series_run) continue;
    for (const auto& one : points[p].series_run->at("series")) {
      Series se;
      se.label = PointName(v, v.points[p]) + (v.outlets > 1 ? ", " + one.value("outlet", std::string()) : "");
      se.columns = {"t", "speed"};
      se.style = Series::Style::kLines;
      const std::vector<double> time = NumbersOf(one.at("time")), speed = NumbersOf(one.at("speed"));
      for (std::size_t i = 0; i < time.size() && i < speed.size(); ++i) se.rows.push_back({time[i], speed[i]});
      if (!se.rows.empty()) series.series.push_back(se);
    }
  }
  if (!series.series.empty()) s.blocks.push_back(series);
  for (const std::string& problem : problems) s.blocks.push_back(Text{"**Note:** " + problem});
  return s;
}

}  // namespace

nlohmann::json WithFieldsOutput(const nlohmann::json& campaign_spec) {
  if (!campaign_spec.is_object() || !campaign_spec.contains("report") || !campaign_spec.at("report").is_object() ||
      !campaign_spec.at("report").contains("fields"))
    return campaign_spec;
  const std::optional<FieldsOptions> o = ReadFieldsOptions(campaign_spec.at("report").at("fields"), "/report/fields");
  if (!o) return campaign_spec;
  nlohmann::json spec = campaign_spec;
  if (!spec.contains("base") || !spec.at("base").is_object()) spec["base"] = nlohmann::json::object();
  nlohmann::json& base = spec["base"];
  if (!base.contains("output") || !base.at("output").is_object()) base["output"] = nlohmann::json::object();
  nlohmann::json& output = base["output"];
  const nlohmann::json interval = output.value("frame_interval", nlohmann::json(0.0));
  if (!interval.is_number() || !(interval.get<double>() > 0.0))
    throw OptionError("/base/output/frame_interval", interval,
                      "must be > 0 when /report/fields is on: the fields are averages over frames");
  // A sweep axis that sets the output: the plan cannot know every run's frames.
  if (spec.contains("sweep") && spec.at("sweep").is_object())
    for (const auto& [kind, axes] : spec.at("sweep").items())
      if (axes.is_object())
        for (const auto& [pointer, values] : axes.items())
          if (pointer == "/output/contact_forces" || pointer == "/output/frame_interval" || pointer == "/output")
            throw OptionError("/sweep/" + kind + "/" + pointer, values,
                              "is not sweepable while /report/fields is on (set it in /base/output)");
  if (FieldsNeedContacts(*o)) {
    if (output.contains("contact_forces") && output.at("contact_forces") == false)
      throw OptionError("/base/output/contact_forces", false,
                        "must be true (or unset) when /report/fields asks for stress maps or force chains; or set "
                        "/report/fields/force_chains to false and list /report/fields/maps without stress fields");
    output["contact_forces"] = true;
  }
  return spec;
}

std::unique_ptr<Analysis> MakeFieldsAnalysis(const nlohmann::json& options, const std::string& path) {
  std::optional<FieldsOptions> o = ReadFieldsOptions(options, path);
  if (!o) return nullptr;
  return std::make_unique<FieldsAnalysis>(std::move(*o));
}

}  // namespace granary::analysis

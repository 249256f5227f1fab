// See expectations.h.
#include "analysis/expectations.h"

#include <algorithm>
#include <cmath>

#include "analysis/options.h"
#include "analysis/registry.h"

namespace granary::analysis {
namespace {

constexpr const char* kKeys[] = {"metric", "fit", "parameter", "at", "value", "tolerance", "source", "min_runs"};

std::string AtText(const Expectation& e) {
  std::string s;
  for (const auto& [name, v] : e.at)
    s += (s.empty() ? "" : ", ") + name + " = " +
         (v.is_string() ? v.get<std::string>() : FormatNumber(v.get<double>(), 6));
  return s;
}

}  // namespace

std::vector<Expectation> ReadExpectations(const nlohmann::json& spec, const std::vector<FigureSpec>& figures) {
  if (!spec.is_object() || !spec.contains("expect")) return {};
  const nlohmann::json& list = spec.at("expect");
  if (!list.is_array())
    throw OptionError("/expect", list,
                      "must be an array of {\"metric\", \"at\", \"value\", \"tolerance\", \"source\"} or {\"fit\", "
                      "\"parameter\", \"value\", ...}");
  const CampaignAxes axes = CampaignAxes::OfCampaignSpec(spec);
  std::vector<std::string> fits;
  for (const FigureSpec& f : figures)
    if (f.fit) fits.push_back(f.name);
  std::vector<Expectation> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = "/expect/" + std::to_string(i);
    const nlohmann::json& j = list[i];
    if (!j.is_object())
      throw OptionError(path, j, "must be an object {\"metric\", \"at\", \"value\", \"tolerance\", \"source\"}");
    for (const auto& [key, v] : j.items())
      if (std::none_of(std::begin(kKeys), std::end(kKeys), [&wanted = key](const char* k) { return wanted == k; }))
        throw OptionError(path + "/" + key, v,
                          "unknown key (known: metric, fit, parameter, at, value, tolerance, source, min_runs)");
    Expectation e;
    e.path = path;
    auto text = [&](const char* key) -> std::string {
      if (!j.contains(key)) return "";
      if (!j.at(key).is_string() || j.at(key).get<std::string>().empty())
        throw OptionError(path + "/" + key, j.at(key), "must be a non-empty string");
      return j.at(key).get<std::string>();
    };
    e.metric = text("metric");
    e.fit = text("fit");
    e.parameter = text("parameter");
    e.source = text("source");
    if (e.metric.empty() == e.fit.empty())
      throw OptionError(path, j,
                        "needs either \"metric\" (a metric or an expression, with \"at\") or \"fit\" (a figure of "
                        "/report/figures with a fit) and \"parameter\"");
    if (!e.metric.empty()) {
      try {
        Expression::Parse(e.metric, {});
      } catch (const ExpressionError& err) {
        throw OptionError(path + "/metric", j.at("metric"), err.what());
      }
    } else {
      if (std::find(fits.begin(), fits.end(), e.fit) == fits.end()) {
        std::string known;
        for (const auto& f : fits) known += (known.empty() ? "" : ", ") + f;
        throw OptionError(
            path + "/fit", j.at("fit"),
            "names no figure with a fit (figures with fits: " + (known.empty() ? std::string("none") : known) + ")");
      }
      if (e.parameter.empty())
        throw OptionError(path + "/parameter", nullptr, "must name a parameter of the fit's model");
      const FigureSpec& f =
          *std::find_if(figures.begin(), figures.end(), [&](const FigureSpec& s) { return s.name == e.fit; });
      const Expression model = Expression::Parse(f.fit->model, f.fit->over);
      const auto& ps = model.Parameters();
      if (std::find(ps.begin(), ps.end(), e.parameter) == ps.end()) {
        std::string known;
        for (const auto& p : ps) known += (known.empty() ? "" : ", ") + p;
        throw OptionError(path + "/parameter", j.at("parameter"),
                          "is not a parameter of " + f.fit->model + " (its parameters: " + known + ")");
      }
    }
    if (j.contains("at")) {
      const nlohmann::json& at = j.at("at");
      if (!at.is_object()) throw OptionError(path + "/at", at, "must be an object {axis: value}, e.g. {\"W\": 11}");
      for (const auto& [k, v] : at.items()) {
        const bool known = axes.FindDerived(k) || axes.PointerOf(k) || k == "L";
        if (!known) {
          std::string names;
          for (const auto& n : axes.Names()) names += (names.empty() ? "" : ", ") + n;
          throw OptionError(path + "/at/" + k, v, "names no axis (axes: " + names + ")");
        }
        if (!v.is_number() && !v.is_string()) throw OptionError(path + "/at/" + k, v, "must be a number or a string");
        const auto pointer = axes.PointerOf(k);
        e.at.emplace_back(pointer ? axes.ShortName(*pointer) : k, v);
      }
    }
    if (!j.contains("value")) throw OptionError(path + "/value", nullptr, "must be the expected number");
    e.value = OptionNumber(j.at("value"), path + "/value", -1e300, 1e300);
    if (j.contains("tolerance")) e.tolerance = OptionNumber(j.at("tolerance"), path + "/tolerance", 0.0, 1e300);
    if (j.contains("min_runs")) e.min_runs = OptionInteger(j.at("min_runs"), path + "/min_runs", 1, 1000000);
    out.push_back(std::move(e));
  }
  return out;
}

std::string ToString(Verdict v) {
  switch (v) {
    case Verdict::kAgrees: return "agrees";
    case Verdict::kDisagrees: return "disagrees";
    case Verdict::kNotComparable: return "not comparable at this size";
    case Verdict::kNotEnough: break;
  }
  return "not enough runs";
}

std::string CampaignSize(const nlohmann::json& spec) {
  if (!spec.is_object() || !spec.contains("size") || !spec.at("size").is_string()) return "";
  return spec.at("size").get<std::string>();
}

bool JudgedAtSize(const std::string& size) { return size.empty() || size == "full"; }

void CheckMetricReferences(const nlohmann::json& spec) {
  const CampaignAxes axes = CampaignAxes::OfCampaignSpec(spec);
  const AnalysisSetup setup = SetupAnalyses(spec);
  const std::vector<AnalysisEntry> rows = RegisteredAnalyses();
  std::vector<const AnalysisEntry*> on;
  for (const auto& a : setup.analyses) {
    const auto row = std::find_if(rows.begin(), rows.end(), [&](const AnalysisEntry& e) { return e.key == a->Key(); });
    // A Python analysis (its metrics are its script's) or a row without a list: not checked.
    if (row == rows.end() || row->metrics.empty()) return;
    on.push_back(&*row);
  }
  const std::vector<std::string> axis_names = axes.Names();
  auto check = [&](const std::string& text, const std::string& path, const nlohmann::json& value) {
    std::vector<std::string> names;
    try {
      names = Expression::Parse(text, {}).Parameters();  // without variables every name is a "parameter"
    } catch (const ExpressionError& err) {
      throw OptionError(path, value, err.what());
    }
    for (const std::string& name : names) {
      if (name == "L" || std::find(axis_names.begin(), axis_names.end(), name) != axis_names.end() ||
          axes.FindDerived(name))
        continue;
      if (std::any_of(on.begin(), on.end(), [&](const AnalysisEntry* e) { return OffersMetric(*e, name); })) continue;
      for (const AnalysisEntry& e : rows)
        if (OffersMetric(e, name))
          throw OptionError(path, value,
                            "\"" + name + "\" is a metric of the " + e.key +
                                " analysis, which this spec leaves off (turn it on with /report/" + e.key + ")");
      std::string offered;
      for (const AnalysisEntry* e : on)
        for (const std::string& m : e->metrics) offered += (offered.empty() ? "" : ", ") + m;
      std::string known_axes;
      for (const std::string& a : axis_names) known_axes += (known_axes.empty() ? "" : ", ") + a;
      throw OptionError(path, value,
                        "\"" + name + "\" names no metric of the analyses this spec turns on (" + offered +
                            ") and no axis (" + (known_axes.empty() ? std::string("none") : known_axes) + ")");
    }
  };
  for (const FigureSpec& f : ReadFigureSpecs(spec))
    for (std::size_t k = 0; k < f.y.size(); ++k)
      check(f.y[k], f.path + "/y" + (f.y_list ? "/" + std::to_string(k) : ""), f.y[k]);
  for (const Expectation& e : ReadExpectations(spec, ReadFigureSpecs(spec)))
    if (!e.metric.empty()) check(e.metric, e.path + "/metric", e.metric);
  if (spec.is_object() && spec.contains("replicas") && spec.at("replicas").is_object() &&
      spec.at("replicas").contains("until")) {
    const nlohmann::json& until = spec.at("replicas").at("until");
    const nlohmann::json list = until.is_array() ? until : nlohmann::json::array({until});
    for (std::size_t i = 0; i < list.size(); ++i)
      if (list[i].is_object() && list[i].contains("metric") && list[i].at("metric").is_string())
        check(list[i].at("metric").get<std::string>(),
              until.is_array() ? "/replicas/until/" + std::to_string(i) + "/metric"
                               : std::string("/replicas/until/metric"),
              list[i].at("metric"));
  }
}

std::vector<ExpectationResult> JudgeExpectations(const CampaignAnalysis& ca,
                                                 const std::vector<Expectation>& expectations,
                                                 const std::vector<FigureOutcome>& figures) {
  const CampaignView& v = ca.view;
  const std::string size = ca.view.campaign ? CampaignSize(ca.view.campaign->spec) : std::string();
  std::vector<ExpectationResult> out;
  for (const Expectation& e : expectations) {
    ExpectationResult r;
    r.expectation = &e;
    if (!e.fit.empty()) {
      r.what = e.parameter + " of the fit of figure " + e.fit;
      const FigureOutcome* f = nullptr;
      for (const FigureOutcome& o : figures)
        if (o.spec && o.spec->name == e.fit) f = &o;
      const FitParameter* p = f && f->fit ? f->fit->Parameter(e.parameter) : nullptr;
      if (f)
        for (const FigureDatum& d : f->data)
          for (std::size_t k : d.points) r.runs += static_cast<int>(v.points[k].runs.size());
      if (!p || !f->fit->Ok()) {
        r.why = f && f->fit ? "fit " + f->fit->Verdict() : "figure " + e.fit + " has no fit yet";
        out.push_back(r);
        continue;
      }
      r.measured = p->value;
      r.se = p->se;
      r.n = static_cast<int>(f->fit->y.size());
      if (f->fit->quality != FitQuality::kGood) {
        r.why = "fit " + f->fit->Verdict();
        out.push_back(r);
        continue;
      }
    } else {
      r.what = e.metric + (e.at.empty() ? "" : " at " + AtText(e));
      std::vector<std::size_t> points;
      for (std::size_t p = 0; p < v.points.size(); ++p) {
        bool keep = !v.points[p].runs.empty();
        for (const auto& [name, want] : e.at) keep = keep && AxisValueMatches(v, v.points[p], name, want);
        if (keep) points.push_back(p);
      }
      for (std::size_t p : points) r.runs += static_cast<int>(v.points[p].runs.size());
      if (points.empty()) {
        r.why = "no finished run at " + (e.at.empty() ? std::string("any point") : AtText(e));
        out.push_back(r);
        continue;
      }
      std::string problem;
      const MeanSe m = YValue(e.metric, PooledMetrics(ca, points), PointAxes(v, v.points[points.front()]), problem);
      r.measured = m.mean;
      r.se = m.se;
      r.n = m.n;
      if (!problem.empty() || !std::isfinite(m.mean)) {
        r.why = problem.empty() ? "not measured at these runs" : problem;
        out.push_back(r);
        continue;
      }
      if (r.runs < e.min_runs) {
        r.why = std::to_string(r.runs) + " finished run" + (r.runs == 1 ? "" : "s") + ", needs " +
                std::to_string(e.min_runs);
        out.push_back(r);
        continue;
      }
    }
    const double diff = std::abs(r.measured - e.value);
    const double se = std::isfinite(r.se) ? r.se : 0.0;
    const double allowed = e.tolerance + 2.0 * se;
    r.verdict = diff <= allowed ? Verdict::kAgrees : Verdict::kDisagrees;
    r.why = "|" + FormatNumber(r.measured, 4) + " - " + FormatNumber(e.value, 4) + "| = " + FormatNumber(diff, 3) +
            (r.verdict == Verdict::kAgrees ? " <= " : " > ") + "tolerance " + FormatNumber(e.tolerance, 3) +
            " + 2 se (" + FormatNumber(2.0 * se, 2) + ")" + (std::isfinite(r.se) ? "" : "; no se");
    out.push_back(r);
  }
  // Measured as at full size (the report shows the numbers), but a smaller system than the
  // thesis' is not judged against its numbers.
  if (!JudgedAtSize(size))
    for (ExpectationResult& r : out) {
      r.verdict = Verdict::kNotComparable;
      r.why =
          "a " + size + " campaign (/size): judged at full size only" + (r.why.empty() ? std::string() : "; " + r.why);
    }
  return out;
}

std::unique_ptr<Reproduction> Reproduce(const CampaignAnalysis& ca) {
  auto r = std::make_unique<Reproduction>();
  const nlohmann::json& spec = ca.view.campaign ? ca.view.campaign->spec : nlohmann::json();
  r->figure_specs = ReadFigureSpecs(spec);
  for (const FigureSpec& f : r->figure_specs) r->figures.push_back(MakeFigure(ca, f));
  r->expectations = ReadExpectations(spec, r->figure_specs);
  r->results = JudgeExpectations(ca, r->expectations, r->figures);
  return r;
}

ExpectationCounts Count(const std::vector<ExpectationResult>& results) {
  ExpectationCounts c;
  for (const auto& r : results) {
    if (r.verdict == Verdict::kAgrees)
      ++c.agree;
    else if (r.verdict == Verdict::kDisagrees)
      ++c.disagree;
    else if (r.verdict == Verdict::kNotComparable)
      ++c.not_comparable;
    else
      ++c.not_yet;
  }
  return c;
}

std::string ToString(const ExpectationCounts& c) {
  return std::to_string(c.agree) + " agree, " + std::to_string(c.disagree) +
         (c.disagree == 1 ? " disagrees, " : " disagree, ") + std::to_string(c.not_yet) + " not yet" +
         (c.not_comparable > 0 ? ", " + std::to_string(c.not_comparable) + " not comparable at this size"
                               : std::string());
}

ExportTable ExpectationsTable(const std::vector<ExpectationResult>& results) {
  ExportTable t;
  t.columns = {"quantity", "expected", "tolerance", "source", "measured", "measured_se", "n", "runs", "verdict", "why"};
  auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  for (const auto& r : results) {
    const Expectation& e = *r.expectation;
    t.rows.push_back({r.what, number(e.value), number(e.tolerance), e.source, number(r.measured), number(r.se), r.n,
                      r.runs, ToString(r.verdict), r.why});
  }
  return t;
}

std::optional<Section> KeyResultsSection(const std::vector<ExpectationResult>& results) {
  if (results.empty()) return std::nullopt;
  Section s{"key-results", "Key results", {}};
  const ExpectationCounts c = Count(results);
  s.blocks.push_back(Text{
      "What the campaign spec expects (`/expect`), each beside what the runs measured: **" + ToString(c) +
      "**. A value agrees when |measured - expected| <= tolerance + 2 se; too few "
      "finished runs (or a fit that does not determine its parameters) is \"not enough runs\"; in a quick or medium "
      "campaign (`/size`) every value is \"not comparable at this size\": measured, not judged."});
  Table t{"key_results",
          "Expected and measured (measured: mean ± se (n))",
          {"quantity", "expected", "source", "measured", "runs", "verdict", "how judged"},
          {},
          {"quantity", "expected", "source", "measured", "runs", "verdict", "why"}};
  for (const auto& r : results) {
    const Expectation& e = *r.expectation;
    t.rows.push_back(
        {r.what, FormatNumber(e.value, 4) + (e.tolerance > 0 ? " ± " + FormatNumber(e.tolerance, 3) : std::string()),
         e.source, Cell::Estimate(r.measured, r.se, r.n), Cell::Count(r.runs),
         (r.verdict == Verdict::kAgrees      ? "**agrees**"
          : r.verdict == Verdict::kDisagrees ? "**disagrees**"
                                             : ToString(r.verdict)),
         r.why});
  }
  s.blocks.push_back(t);
  return s;
}

nlohmann::json AxesJsonSchema() {
  return {{"type", "object"},
          {"description",
           "derived axes {name: expression over the sweep axes' short names and the derived axes before it}, "
           "e.g. {\"D_eq\": \"sqrt(1 + D_b^2)\", \"W_over_D_eq\": \"W / D_eq\"}"},
          {"additionalProperties", {{"type", "string"}}}};
}

nlohmann::json FiguresJsonSchema() {
  const nlohmann::json axis_or_list = {
      {"oneOf", {{{"type", "string"}}, {{"type", "array"}, {"items", {{"type", "string"}}}}}}};
  nlohmann::json fit = {
      {"type", "object"},
      {"additionalProperties", false},
      {"required", {"model"}},
      {"properties",
       {{"model", {{"type", "string"}, {"description", "an expression over axes; other names are parameters"}}},
        {"over", axis_or_list},
        {"initial", {{"type", "object"}, {"additionalProperties", {{"type", "number"}}}}},
        {"collapse", {{"type", "boolean"}, {"description", "also draw the data divided by the fitted law"}}}}}};
  nlohmann::json figure = {
      {"type", "object"},
      {"additionalProperties", false},
      {"required", {"name"}},
      {"properties",
       {{"name", {{"type", "string"}, {"pattern", "^[A-Za-z0-9._-]+$"}}},
        {"kind", {{"enum", {"points", "distribution", "curves", "maps", "profile", "pictures"}}}},
        {"picture",
         {{"enum", {"end", "bed", "clog"}},
          {"description",
           "pictures: the last frame (default), the bed at t = 0, or the kept clog of the lowest replica whose "
           "arch has the point's median N_t (its arch outlined)"}}},
        {"y",
         {{"oneOf", {{{"type", "string"}}, {{"type", "array"}, {"items", {{"type", "string"}}}, {"minItems", 1}}}},
          {"description",
           "points: a metric, or an expression over metrics and axes; a list of them draws a curve of each"}}},
        {"labels",
         {{"type", "array"},
          {"items", {{"type", "string"}}},
          {"description", "points with a list of y: the legend label of each"}}},
        {"normalize",
         {{"type", "object"},
          {"description",
           "points: {axis: value}, each curve divided by its value at that point (Q/Q_0 with {\"L\": 0})"}}},
        {"ylabel", {{"type", "string"}}},
        {"x",
         {{"type", "string"}, {"description", "a sweep axis (short name) or a derived axis; default the report's x"}}},
        {"group", axis_or_list},
        {"pool", axis_or_list},
        {"only", {{"type", "object"}, {"description", "{axis: value or [values]}"}}},
        {"fit", fit},
        {"title", {{"type", "string"}}},
        {"caption", {{"type", "string"}}},
        {"reference", {{"type", "string"}}},
        {"logx", {{"type", "boolean"}}},
        {"logy", {{"type", "boolean"}}},
        {"of",
         {{"type", "string"},
          {"description",
           "distribution: a distribution an analysis offers (vx, vy, avalanche_sizes, arch_sizes, "
           "axis_bed, axis_flow, axis_arches) or a per-run metric, pooled over the replicas of each "
           "point; curves: a curve an analysis offers (arch_pressure_theta, arch_axis_mode_theta, "
           "arch_pressure_n)"}}},
        {"bins", {{"type", "integer"}, {"minimum", 1}, {"maximum", 1000}}},
        {"range",
         {{"type", "array"},
          {"items", {{"type", "number"}}},
          {"minItems", 2},
          {"maxItems", 2},
          {"description", "distribution: [lo, hi] of the bins, the same for every curve; default the data's"}}},
        {"field",
         {{"type", "string"},
          {"description", "maps, profile: a field an analysis offers (/report/fields: phi, speed, pressure, ...)"}}},
        {"along", {{"enum", {"x", "y"}}, {"description", "profile: the direction of the line"}}},
        {"at", {{"type", "number"}, {"description", "profile: the line's other coordinate (d)"}}},
        {"width",
         {{"type", "number"},
          {"exclusiveMinimum", 0},
          {"description", "profile: the band averaged across the line (d)"}}},
        {"origin_outlet",
         {{"type", "integer"},
          {"minimum", 0},
          {"description", "profile along x: x from the centre of this base outlet of each point (thesis fig. 7.6)"}}},
        {"one_run",
         {{"type", "boolean"},
          {"description",
           "maps, profile: the lowest replica that has the field, not the runs merged (one instant: thesis fig. 3.10)"}}},
        {"annotate",
         {{"type", "array"},
          {"description",
           "pictures: marks drawn over them: {\"region\": \"region\" (the /report/region rectangle next to each "
           "outlet) or \"fields\" (the maps' window), \"outlet\", \"label\", \"shade\"}, {\"dimension\": "
           "\"outlet_width\", \"obstacle_height\", \"obstacle_offset\" or \"outlet_gap\", \"outlet\", "
           "\"obstacle\", \"label\"}, {\"dimension\": \"disc_diameters\" (each disc size of the body nearest "
           "\"at\", thesis fig. 6.1's D_s and D_b), \"at\", \"labels\"} or {\"point\": \"origin\", \"label\"}"},
          {"items",
           {{"type", "object"},
            {"additionalProperties", false},
            {"properties",
             {{"region", {{"enum", {"region", "fields"}}}},
              {"dimension",
               {{"enum", {"outlet_width", "obstacle_height", "obstacle_offset", "outlet_gap", "disc_diameters"}}}},
              {"point", {{"enum", {"origin"}}}},
              {"outlet", {{"type", "integer"}, {"minimum", 0}}},
              {"obstacle", {{"type", "integer"}, {"minimum", 0}}},
              {"label", {{"type", "string"}}},
              {"shade", {{"type", "boolean"}}},
              {"at",
               {{"type", "array"},
                {"items", {{"type", "number"}}},
                {"minItems", 2},
                {"maxItems", 2},
                {"description",
                 "disc_diameters: [x, y] in d, the body nearest it is measured (default: the zoom window's centre, "
                 "else half way up the bed on the axis)"}}},
              {"labels",
               {{"type", "array"},
                {"items", {{"type", "string"}, {"minLength", 1}}},
                {"minItems", 1},
                {"description",
                 "disc_diameters: a name per disc size, smallest first (default: D; D_s, D_b; D_1, D_2, ...)"}}}}}}}}},
        {"window",
         {{"type", "array"},
          {"items", {{"type", "number"}}},
          {"minItems", 4},
          {"maxItems", 4},
          {"description", "pictures: a zoom [x_lo, x_hi, y_lo, y_hi] in d drawn besides the whole silo"}}},
        {"colour",
         {{"enum", {"species", "disc"}},
          {"description",
           "pictures: one colour per species (default) or per disc of a body (a snowman's head and body)"}}}}}};
  return {{"type", "array"},
          {"description", "figures drawn in the report's Figures section (docs/analyses.md)"},
          {"items", figure}};
}

nlohmann::json ExpectJsonSchema() {
  nlohmann::json item = {{"type", "object"},
                         {"additionalProperties", false},
                         {"required", {"value"}},
                         {"properties",
                          {{"metric", {{"type", "string"}}},
                           {"fit", {{"type", "string"}, {"description", "the name of a figure with a fit"}}},
                           {"parameter", {{"type", "string"}}},
                           {"at", {{"type", "object"}, {"description", "{axis: value}"}}},
                           {"value", {{"type", "number"}}},
                           {"tolerance", {{"type", "number"}, {"minimum", 0}}},
                           {"source", {{"type", "string"}}},
                           {"min_runs", {{"type", "integer"}, {"minimum", 1}}}}}};
  return {{"type", "array"},
          {"description", "expected values with their source (the report's Key results)"},
          {"items", item}};
}

}  // namespace granary::analysis

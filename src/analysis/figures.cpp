// See figures.h.
#include "analysis/figures.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "analysis/cg_fields.h"
#include "analysis/fields_analysis.h"
#include "analysis/options.h"
#include "analysis/outlets.h"
#include "analysis/region_analysis.h"
#include "analysis/registry.h"
#include "analysis/system.h"

namespace granary::analysis {
namespace {

constexpr const char* kFigureKeys[] = {
    "name",  "kind",      "picture", "y",       "labels",    "ylabel",        "x",        "group",  "pool",  "only",
    "fit",   "normalize", "title",   "caption", "reference", "logx",          "logy",     "of",     "bins",  "range",
    "field", "along",     "at",      "width",   "one_run",   "origin_outlet", "annotate", "window", "colour"};
// The kinds, what each draws and the keys it takes besides name, kind, only, title, caption
// and reference.
struct KindKeys {
  const char* kind;
  const char* what;
  std::vector<std::string> keys;
};
const std::vector<KindKeys>& FigureKinds() {
  static const std::vector<KindKeys> kInds = {
      {"points",
       "points with error bars",
       {"y", "labels", "ylabel", "x", "group", "pool", "fit", "normalize", "logx", "logy"}},
      {"distribution",
       "a histogram of a per-run distribution at each chosen point",
       {"of", "bins", "range", "group", "pool", "logx", "logy"}},
      {"curves", "an analysis' curve at each chosen point", {"of", "group", "pool", "logx", "logy"}},
      {"maps", "a field's map at each chosen point", {"field", "group", "pool", "one_run"}},
      {"profile",
       "a field along a line at each chosen point",
       {"field", "along", "at", "width", "origin_outlet", "group", "pool", "one_run", "logy"}},
      {"pictures", "the silo at each chosen point", {"picture", "annotate", "window", "colour"}}};
  return kInds;
}
constexpr const char* kFitKeys[] = {"model", "over", "initial", "collapse"};

std::string Joined(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& i : items) s += (s.empty() ? "" : ", ") + i;
  return s.empty() ? "none" : s;
}

void CheckKeys(const nlohmann::json& j, const std::string& path, const char* const* begin, const char* const* end) {
  for (const auto& [key, v] : j.items())
    if (std::find_if(begin, end, [&wanted = key](const char* k) { return wanted == k; }) == end) {
      std::vector<std::string> names(begin, end);
      throw OptionError(path + "/" + key, v, "unknown key (known: " + Joined(names) + ")");
    }
}

std::string TextAt(const nlohmann::json& j, const std::string& key, const std::string& path) {
  if (!j.contains(key)) return "";
  if (!j.at(key).is_string()) throw OptionError(path + "/" + key, j.at(key), "must be a string");
  return j.at(key).get<std::string>();
}

// An axis name that the campaign has (a sweep axis by short name or pointer, a derived axis,
// or "L" where the view's x is the gap: it is checked again against the view).
std::string AxisNameAt(const nlohmann::json& v, const std::string& path, const CampaignAxes& axes) {
  const std::vector<std::string> names = axes.Names();
  if (!v.is_string()) throw OptionError(path, v, "must be an axis name (axes: " + Joined(names) + ")");
  const std::string name = v.get<std::string>();
  if (axes.FindDerived(name)) return name;
  if (const auto pointer = axes.PointerOf(name)) return axes.ShortName(*pointer);
  if (name == "L") return name;  // the gap between two outlets, when the campaign has two
  throw OptionError(path, v, "names no axis (axes: " + Joined(names) + ")");
}

std::vector<std::string> AxisListAt(const nlohmann::json& v, const std::string& path, const CampaignAxes& axes) {
  std::vector<std::string> out;
  if (v.is_string()) return {AxisNameAt(v, path, axes)};
  if (!v.is_array())
    throw OptionError(path, v, "must be an axis name or a list of them (axes: " + Joined(axes.Names()) + ")");
  for (std::size_t i = 0; i < v.size(); ++i) out.push_back(AxisNameAt(v[i], path + "/" + std::to_string(i), axes));
  return out;
}

std::vector<std::pair<std::string, std::vector<nlohmann::json>>> ReadOnly(const nlohmann::json& o,
                                                                          const std::string& path,
                                                                          const CampaignAxes& axes) {
  if (!o.is_object())
    throw OptionError(path + "/only", o, "must be an object {axis: value or [values]}, e.g. {\"W\": [15, 25]}");
  std::vector<std::pair<std::string, std::vector<nlohmann::json>>> out;
  for (const auto& [k, v] : o.items()) {
    const std::string name = AxisNameAt(nlohmann::json(k), path + "/only/" + k, axes);
    std::vector<nlohmann::json> values;
    for (const auto& one : v.is_array() ? v : nlohmann::json::array({v})) {
      if (!one.is_number() && !one.is_string())
        throw OptionError(path + "/only/" + k, v, "must be a number, a string or a list of them");
      values.push_back(one);
    }
    if (values.empty()) throw OptionError(path + "/only/" + k, v, "must list at least one value");
    out.emplace_back(name, values);
  }
  return out;
}

// What the campaign's analyses offer figures (distributions, fields), asked for only when a
// figure needs it: set up from the campaign spec.
class Offers {
 public:
  explicit Offers(const nlohmann::json& campaign_spec) : spec_(campaign_spec) {}
  const nlohmann::json& CampaignSpec() const { return spec_; }
  std::vector<DistributionInfo> Distributions() { return All(&Analysis::DistributionNames); }
  std::vector<CurveInfo> Curves() { return All(&Analysis::CurveNames); }
  std::vector<FieldInfo> Fields() { return All(&Analysis::FieldNames); }

 private:
  template <class Info>
  std::vector<Info> All(std::vector<Info> (Analysis::*offers)() const) {
    std::vector<Info> out;
    for (const Analysis* a : Setup().List())
      for (Info& i : (a->*offers)()) out.push_back(std::move(i));
    return out;
  }
  const AnalysisSetup& Setup() {
    if (!setup_) setup_ = std::make_unique<AnalysisSetup>(SetupAnalyses(spec_));
    return *setup_;
  }
  const nlohmann::json& spec_;
  std::unique_ptr<AnalysisSetup> setup_;
};

// The marks a pictures figure may ask for: what each is, the key that names it ("region",
// "dimension" or "point"), its default label, what it means.
struct MarkKind {
  const char* what;
  const char* key;
  const char* label;
  const char* meaning;
};
constexpr MarkKind kMarkKinds[] = {
    {"region", "region", "region", "the region analysis' rectangle next to an outlet, /report/region"},
    {"fields", "region", "maps", "the maps' window, /report/fields/window"},
    {"outlet_width", "dimension", "W", "the outlet's width"},
    {"obstacle_height", "dimension", "H", "the obstacle centre's height above the base"},
    {"obstacle_offset", "dimension", "L", "the obstacle centre's distance from the silo's axis"},
    {"outlet_gap", "dimension", "L", "the gap between base outlets 0 and 1, edge to edge"},
    {"disc_diameters", "dimension", "",
     "the diameter of each disc size of the body nearest \"at\", smallest first, labelled \"labels\""},
    {"origin", "point", "(0, 0)", "x = 0 on the silo's axis, y = 0 on the base, with x and y arrows"}};
constexpr const char* kMarkKeys[] = {"region", "dimension", "point"};

const MarkKind* FindMarkKind(const std::string& what) {
  for (const MarkKind& k : kMarkKinds)
    if (what == k.what) return &k;
  return nullptr;
}

std::string MarkKindNames(const std::string& key) {
  std::string s;
  for (const MarkKind& k : kMarkKinds)
    if (k.key == key) s += (s.empty() ? "" : ", ") + std::string("\"") + k.what + "\" (" + k.meaning + ")";
  return s;
}

bool FieldsOn(const nlohmann::json& campaign_spec) {
  if (!campaign_spec.is_object() || !campaign_spec.contains("report") || !campaign_spec.at("report").is_object())
    return false;
  const nlohmann::json& r = campaign_spec.at("report");
  return r.contains("fields") && !r.at("fields").is_null() && r.at("fields") != false;
}

// A pictures figure's own keys: picture, annotate, window, colour.
void ReadPictureKeys(const nlohmann::json& f, const std::string& path, const nlohmann::json& campaign_spec,
                     FigureSpec& s) {
  s.picture = f.contains("picture") ? TextAt(f, "picture", path) : "end";
  if (s.picture != "end" && s.picture != "bed" && s.picture != "clog")
    throw OptionError(path + "/picture", f.at("picture"),
                      "must be \"end\" (the last frame), \"bed\" (t = 0) or \"clog\" (a kept clog, its arch outlined)");
  if (f.contains("colour")) {
    const std::string colour = TextAt(f, "colour", path);
    if (colour != "species" && colour != "disc")
      throw OptionError(path + "/colour", f.at("colour"),
                        "must be \"species\" (one colour per species) or \"disc\" (each disc of a body by its place "
                        "in the body: a snowman's head and body apart)");
    s.colour_by_disc = colour == "disc";
  }
  if (f.contains("window")) {
    const nlohmann::json& w = f.at("window");
    if (!w.is_array() || w.size() != 4 ||
        !std::all_of(w.begin(), w.end(), [](const auto& v) { return v.is_number(); }) ||
        !(w[0].get<double>() < w[1].get<double>()) || !(w[2].get<double>() < w[3].get<double>()))
      throw OptionError(
          path + "/window", w,
          "must be [x_lo, x_hi, y_lo, y_hi] in d (x from the silo's centre, y from the base) with lo < hi");
    s.window = std::array<double, 4>{w[0].get<double>(), w[1].get<double>(), w[2].get<double>(), w[3].get<double>()};
  }
  if (!f.contains("annotate")) return;
  const nlohmann::json& list = f.at("annotate");
  if (!list.is_array())
    throw OptionError(path + "/annotate", list,
                      "must be a list of marks, e.g. [{\"region\": \"region\", \"label\": \"A\"}, {\"dimension\": "
                      "\"outlet_width\"}]");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string p = path + "/annotate/" + std::to_string(i);
    const nlohmann::json& m = list[i];
    const int keys = m.is_object() ? static_cast<int>(std::count_if(std::begin(kMarkKeys), std::end(kMarkKeys),
                                                                    [&](const char* k) { return m.contains(k); }))
                                   : 0;
    if (keys != 1) throw OptionError(p, m, "must be an object with one of \"region\", \"dimension\" or \"point\"");
    const std::string key = m.contains("region") ? "region" : m.contains("dimension") ? "dimension" : "point";
    MarkSpec mark;
    mark.what = TextAt(m, key, p);
    const MarkKind* kind = FindMarkKind(mark.what);
    if (!kind || kind->key != key) throw OptionError(p + "/" + key, m.at(key), "must be " + MarkKindNames(key));
    if (key == "region")
      OptionObject(m, p, {"region", "outlet", "label", "shade"});
    else if (mark.what == "disc_diameters")
      OptionObject(m, p, {"dimension", "at", "labels"});
    else if (key == "dimension")
      OptionObject(m, p, {"dimension", "outlet", "obstacle", "label"});
    else
      OptionObject(m, p, {"point", "label"});
    if (mark.what == "fields" && !FieldsOn(campaign_spec))
      throw OptionError(p + "/region", m.at(key), "names the maps' window, but this spec has no /report/fields");
    mark.label = m.contains("label") ? TextAt(m, "label", p) : kind->label;
    if (m.contains("shade")) mark.shade = OptionBool(m.at("shade"), p + "/shade");
    if (m.contains("outlet")) {
      if (mark.what == "fields" || mark.what == "outlet_gap" || mark.what.rfind("obstacle", 0) == 0)
        throw OptionError(p + "/outlet", m.at("outlet"), "\"" + mark.what + "\" takes no outlet");
      mark.index = OptionInteger(m.at("outlet"), p + "/outlet", 0, 1000);
    }
    if (m.contains("obstacle")) {
      if (mark.what.rfind("obstacle", 0) != 0)
        throw OptionError(p + "/obstacle", m.at("obstacle"), "\"" + mark.what + "\" takes no obstacle");
      mark.index = OptionInteger(m.at("obstacle"), p + "/obstacle", 0, 1000);
    }
    if (m.contains("at")) {
      const nlohmann::json& at = m.at("at");
      if (!at.is_array() || at.size() != 2 || !std::all_of(at.begin(), at.end(), [](const auto& v) {
            return v.is_number() && std::isfinite(v.template get<double>());
          }))
        throw OptionError(p + "/at", at,
                          "must be [x, y] in d (x from the silo's centre, y from the base): the body nearest it is "
                          "measured");
      mark.at = std::array<double, 2>{at[0].get<double>(), at[1].get<double>()};
    }
    if (m.contains("labels")) {
      const nlohmann::json& labels = m.at("labels");
      if (!labels.is_array() || labels.empty() || !std::all_of(labels.begin(), labels.end(), [](const auto& v) {
            return v.is_string() && !v.template get<std::string>().empty();
          }))
        throw OptionError(p + "/labels", labels,
                          "must be a non-empty list of names, one per disc size of the body, smallest first (a "
                          "snowman: [\"D_s\", \"D_b\"])");
      for (const auto& v : labels) mark.labels.push_back(v.get<std::string>());
    }
    if (key == "dimension" && mark.index < 0) mark.index = 0;
    s.annotate.push_back(std::move(mark));
  }
}

FigureSpec ReadOne(const nlohmann::json& f, const std::string& path, const CampaignAxes& axes,
                   const std::set<std::string>& names_before, Offers& offers) {
  if (!f.is_object())
    throw OptionError(path, f,
                      "must be an object {\"name\", \"y\", \"x\", \"group\", \"only\", \"pool\", \"fit\", ...}");
  CheckKeys(f, path, std::begin(kFigureKeys), std::end(kFigureKeys));
  FigureSpec s;
  s.path = path;
  s.name = TextAt(f, "name", path);
  if (s.name.empty())
    throw OptionError(path + "/name", f.value("name", nlohmann::json()),
                      "must be a non-empty name (the figure's file stem)");
  for (char c : s.name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.'))
      throw OptionError(path + "/name", f.at("name"), "letters, digits, '-', '_' and '.' only (it names files)");
  if (names_before.count(s.name)) throw OptionError(path + "/name", f.at("name"), "another figure has this name");
  if (f.contains("kind")) s.kind = TextAt(f, "kind", path);
  const auto kind =
      std::find_if(FigureKinds().begin(), FigureKinds().end(), [&](const KindKeys& k) { return s.kind == k.kind; });
  if (kind == FigureKinds().end()) {
    std::string allowed;
    for (const KindKeys& k : FigureKinds())
      allowed += (allowed.empty() ? "" : ", ") + std::string("\"") + k.kind + "\" (" + k.what + ")";
    throw OptionError(path + "/kind", f.at("kind"), "must be " + allowed);
  }
  for (const auto& [key, value] : f.items()) {
    static const std::set<std::string> kCommon = {"name", "kind", "only", "title", "caption", "reference"};
    if (kCommon.count(key) || std::find(kind->keys.begin(), kind->keys.end(), key) != kind->keys.end()) continue;
    std::vector<std::string> takes(kCommon.begin(), kCommon.end());
    takes.insert(takes.end(), kind->keys.begin(), kind->keys.end());
    throw OptionError(path + "/" + key, value, "a figure of kind \"" + s.kind + "\" takes " + Joined(takes));
  }
  s.title = TextAt(f, "title", path);
  s.caption = TextAt(f, "caption", path);
  s.reference = TextAt(f, "reference", path);
  if (f.contains("only")) s.only = ReadOnly(f.at("only"), path, axes);
  if (f.contains("pool")) s.pool = AxisListAt(f.at("pool"), path + "/pool", axes);
  if (f.contains("group")) {
    s.group = AxisListAt(f.at("group"), path + "/group", axes);
    s.group_given = true;
  }
  if (f.contains("logx")) s.logx = OptionBool(f.at("logx"), path + "/logx");
  if (f.contains("logy")) s.logy = OptionBool(f.at("logy"), path + "/logy");
  if (s.kind == "pictures") {
    ReadPictureKeys(f, path, offers.CampaignSpec(), s);
    return s;
  }
  if (s.kind == "distribution") {
    s.of = TextAt(f, "of", path);
    const std::vector<DistributionInfo> offered = offers.Distributions();
    std::vector<std::string> names;
    for (const auto& d : offered) names.push_back(d.name);
    if (s.of.empty() || (!IsIdentifier(s.of) && std::find(names.begin(), names.end(), s.of) == names.end()))
      throw OptionError(path + "/of", f.value("of", nlohmann::json()),
                        "must name a distribution an analysis offers (" + Joined(names) + ") or a per-run metric");
    if (f.contains("bins")) s.bins = OptionInteger(f.at("bins"), path + "/bins", 1, 1000);
    if (f.contains("range")) {
      const nlohmann::json& r = f.at("range");
      if (!r.is_array() || r.size() != 2 || !r[0].is_number() || !r[1].is_number() ||
          !(r[0].get<double>() < r[1].get<double>()))
        throw OptionError(path + "/range", r, "must be [lo, hi] with lo < hi");
      s.range_lo = r[0].get<double>();
      s.range_hi = r[1].get<double>();
      if (s.logx && !(s.range_lo > 0)) throw OptionError(path + "/range", r, "must start above 0 with logx (log bins)");
    }
    return s;
  }
  if (s.kind == "curves") {
    s.of = TextAt(f, "of", path);
    std::vector<std::string> names;
    for (const auto& c : offers.Curves()) names.push_back(c.name);
    if (std::find(names.begin(), names.end(), s.of) == names.end())
      throw OptionError(path + "/of", f.value("of", nlohmann::json()),
                        "must name a curve an analysis this spec turns on offers (" + Joined(names) + ")");
    return s;
  }
  if (s.kind == "maps" || s.kind == "profile") {
    s.field = TextAt(f, "field", path);
    const std::vector<FieldInfo> offered = offers.Fields();
    std::vector<std::string> names;
    for (const auto& d : offered) names.push_back(d.name);
    if (names.empty())
      throw OptionError(path + "/field", f.value("field", nlohmann::json()),
                        "no analysis offers fields: turn on the coarse-grained fields (/report/fields: true)");
    if (std::find(names.begin(), names.end(), s.field) == names.end())
      throw OptionError(path + "/field", f.value("field", nlohmann::json()),
                        "must name a field (fields: " + Joined(names) + ")");
    if (f.contains("one_run")) s.one_run = OptionBool(f.at("one_run"), path + "/one_run");
    if (s.kind == "maps") return s;
    s.along = TextAt(f, "along", path);
    if (s.along != "x" && s.along != "y")
      throw OptionError(path + "/along", f.value("along", nlohmann::json()),
                        "must be \"x\" (a horizontal line) or \"y\" (a vertical one)");
    if (!f.contains("at"))
      throw OptionError(path + "/at", nlohmann::json(),
                        std::string("must be the line's ") + (s.along == "x" ? "height y" : "position x") + " (d)");
    s.at = OptionNumber(f.at("at"), path + "/at", -1e9, 1e9);
    if (f.contains("width")) s.width = OptionNumber(f.at("width"), path + "/width", 1e-9, 1e9);
    if (f.contains("origin_outlet")) {
      if (s.along != "x")
        throw OptionError(path + "/origin_outlet", f.at("origin_outlet"),
                          "takes a line along x (the base outlets lie along x)");
      s.origin_outlet = OptionInteger(f.at("origin_outlet"), path + "/origin_outlet", 0, 1000);
    }
    return s;
  }
  const nlohmann::json y = f.value("y", nlohmann::json());
  constexpr const char* kWhatY = "must be a metric name or an expression over metrics and axes, or a list of them";
  s.y_list = y.is_array();
  if (y.is_string()) s.y.push_back(y.get<std::string>());
  if (s.y_list) {
    if (y.empty()) throw OptionError(path + "/y", y, kWhatY);
    for (const auto& one : y) {
      if (!one.is_string()) throw OptionError(path + "/y/" + std::to_string(s.y.size()), one, kWhatY);
      s.y.push_back(one.get<std::string>());
    }
  }
  if (s.y.empty()) throw OptionError(path + "/y", y, kWhatY);
  for (std::size_t k = 0; k < s.y.size(); ++k) {
    const std::string yp = path + "/y" + (s.y_list ? "/" + std::to_string(k) : "");
    if (s.y[k].empty()) throw OptionError(yp, s.y[k], kWhatY);
    try {
      Expression::Parse(s.y[k], {});  // the grammar; names are checked against the metrics when drawn
    } catch (const ExpressionError& e) {
      throw OptionError(yp, s.y[k], e.what());
    }
  }
  if (f.contains("labels")) {
    const nlohmann::json& l = f.at("labels");
    if (!s.y_list)
      throw OptionError(path + "/labels", l, "names the curves of a list of y; give y as a list (\"y\": [..])");
    if (!l.is_array() || l.size() != s.y.size() ||
        !std::all_of(l.begin(), l.end(), [](const nlohmann::json& one) { return one.is_string(); }))
      throw OptionError(path + "/labels", l,
                        "must be a list of " + std::to_string(s.y.size()) + " strings, one legend label per y");
    for (const auto& one : l) s.labels.push_back(one.get<std::string>());
  }
  if (f.contains("normalize")) {
    const nlohmann::json& n = f.at("normalize");
    const std::string np = path + "/normalize";
    if (!n.is_object() || n.empty())
      throw OptionError(np, n, "must be {axis: value}: each curve divided by its value there, e.g. {\"L\": 0}");
    for (const auto& [k, v] : n.items()) {
      const std::string name = AxisNameAt(nlohmann::json(k), np + "/" + k, axes);
      if (!v.is_number() && !v.is_string()) throw OptionError(np + "/" + k, v, "must be a number or a string");
      s.normalize.emplace_back(name, v);
    }
  }
  s.ylabel = TextAt(f, "ylabel", path);
  if (f.contains("x")) s.x = AxisNameAt(f.at("x"), path + "/x", axes);
  if (f.contains("fit")) {
    const nlohmann::json& fj = f.at("fit");
    const std::string fp = path + "/fit";
    if (!fj.is_object())
      throw OptionError(fp, fj,
                        "must be {\"model\": \"C * W^b\", \"over\": [axes], \"initial\": {..}, \"collapse\": bool}");
    CheckKeys(fj, fp, std::begin(kFitKeys), std::end(kFitKeys));
    FigureFitSpec fit;
    fit.model = TextAt(fj, "model", fp);
    if (fit.model.empty())
      throw OptionError(fp + "/model", fj.value("model", nlohmann::json()), "must be an expression, e.g. \"C * W^b\"");
    std::vector<std::string> usable = axes.ExpressionNames();
    if (std::find(usable.begin(), usable.end(), "L") == usable.end()) usable.push_back("L");
    if (fj.contains("over")) {
      fit.over = AxisListAt(fj.at("over"), fp + "/over", axes);
      for (const auto& v : fit.over)
        if (!IsIdentifier(v))
          throw OptionError(
              fp + "/over", fj.at("over"),
              "\"" + v +
                  "\" cannot stand in an expression; declare it under /axes with a name of letters, digits and '_'");
    }
    Expression e;
    try {
      e = Expression::Parse(fit.model, fj.contains("over") ? fit.over : usable);
    } catch (const ExpressionError& err) {
      throw OptionError(fp + "/model", fj.at("model"), err.what());
    }
    if (!fj.contains("over")) {
      // The axes the model names (without variables, every name it uses is a "parameter").
      const std::vector<std::string> named = Expression::Parse(fit.model, {}).Parameters();
      for (const auto& v : named)  // in the order the model names them
        if (std::find(usable.begin(), usable.end(), v) != usable.end()) fit.over.push_back(v);
      if (fit.over.empty())
        throw OptionError(fp + "/model", fj.at("model"),
                          "uses no axis; its variables must be axes (" + Joined(usable) + ")");
    }
    if (e.Parameters().empty()) throw OptionError(fp + "/model", fj.at("model"), "has no parameter to fit");
    if (fj.contains("initial")) {
      if (!fj.at("initial").is_object())
        throw OptionError(fp + "/initial", fj.at("initial"), "must be {parameter: value}");
      for (const auto& [k, v] : fj.at("initial").items())
        fit.initial[k] = OptionNumber(v, fp + "/initial/" + k, -1e300, 1e300);
    }
    if (fj.contains("collapse")) fit.collapse = OptionBool(fj.at("collapse"), fp + "/collapse");
    if (s.y.size() > 1) throw OptionError(fp, fj, "fits one y; this figure has " + std::to_string(s.y.size()));
    s.fit = fit;
  }
  return s;
}

}  // namespace

MeanSe YValue(const std::string& y, const std::map<std::string, MeanSe>& metrics,
              const std::map<std::string, double>& axes, std::string& problem) {
  if (const auto it = metrics.find(y); it != metrics.end()) return it->second;
  std::vector<std::string> variables;
  for (const auto& [name, e] : metrics)
    if (IsIdentifier(name)) variables.push_back(name);
  for (const auto& [name, v] : axes)
    if (IsIdentifier(name) && !metrics.count(name)) variables.push_back(name);
  Expression e;
  try {
    e = Expression::Parse(y, variables);
  } catch (const ExpressionError& err) {
    problem = err.what();
    return {};
  }
  if (!e.Parameters().empty()) {
    problem = "y \"" + y + "\" names no metric or axis: " + Joined(e.Parameters());
    return {};
  }
  std::vector<double> values;
  std::vector<double> ses;
  MeanSe out;
  out.n = -1;
  for (const auto& name : e.Variables()) {
    if (const auto it = metrics.find(name); it != metrics.end()) {
      values.push_back(it->second.mean);
      ses.push_back(it->second.se);
      if (y.find(name) != std::string::npos) out.n = out.n < 0 ? it->second.n : std::min(out.n, it->second.n);
    } else {
      values.push_back(axes.at(name));
      ses.push_back(0.0);
    }
  }
  out.mean = e.Evaluate(values, {});
  double var = 0.0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (ses[i] == 0.0) continue;
    // Only the metrics the expression reads matter; a derivative of 0 drops the rest.
    const double h = 1e-6 * std::max(1.0, std::abs(values[i]));
    std::vector<double> up = values, down = values;
    up[i] += h;
    down[i] -= h;
    const double d = (e.Evaluate(up, {}) - e.Evaluate(down, {})) / (2 * h);
    if (d == 0.0) continue;
    if (!std::isfinite(ses[i])) {
      var = kNaN;
      break;
    }
    var += d * d * ses[i] * ses[i];
  }
  out.se = std::isfinite(var) ? std::sqrt(var) : kNaN;
  if (out.n < 0) out.n = 0;
  return out;
}

MeanSe NormalisedValue(const MeanSe& y, const MeanSe& y0, bool same) {
  if (!std::isfinite(y.mean) || !std::isfinite(y0.mean) || y0.mean == 0.0) return {};
  if (same) return {1.0, 0.0, y.n};
  const double r = y.mean / y0.mean;
  const double rel = std::hypot(y.se / y.mean, y0.se / y0.mean);
  return {r, y.mean == 0.0 ? std::abs(y.se / y0.mean) : std::abs(r) * rel, std::min(y.n, y0.n)};
}

std::map<std::string, MeanSe> PooledMetrics(const CampaignAnalysis& ca, const std::vector<std::size_t>& points) {
  std::map<std::string, std::vector<PointMetric>> by_name;
  for (std::size_t p : points)
    for (const PointMetric& m : ca.AllPointMetrics(p)) by_name[m.name].push_back(m);
  std::map<std::string, MeanSe> out;
  for (const auto& [name, list] : by_name) {
    if (list.size() == 1) {
      out[name] = list.front().Estimate();
      continue;
    }
    double sum = 0, weight = 0, var = 0;
    int n = 0;
    for (const PointMetric& m : list) {
      if (!std::isfinite(m.mean) || m.n <= 0) continue;
      sum += m.n * m.mean;
      weight += m.n;
      var += std::isfinite(m.se) ? static_cast<double>(m.n) * m.n * m.se * m.se : kNaN;
      n += m.n;
    }
    out[name] = weight > 0 ? MeanSe{sum / weight, std::sqrt(var) / weight, n} : MeanSe{};
  }
  return out;
}

namespace {

std::string ValueWords(double v) { return FormatNumber(v, 6); }

}  // namespace

namespace {

// "; only W in {10, 22}; mu in {0.5}" for a caption ("" without `only`).
std::string OnlyText(const FigureSpec& spec) {
  std::string only;
  for (const auto& [name, values] : spec.only) {
    std::string vs;
    for (const auto& w : values)
      vs += (vs.empty() ? "" : ", ") + (w.is_string() ? w.get<std::string>() : ValueWords(w.get<double>()));
    only += (only.empty() ? "" : "; ") + name + " in {" + vs + "}";
  }
  return only.empty() ? "" : "; only " + only;
}

std::string WithUnit(const std::string& title, const std::string& unit) {
  return unit.empty() ? title : title + " (" + unit + ")";
}

// The per-run results of analysis `a` behind a datum: the used runs of its points.
std::vector<const nlohmann::json*> DatumResults(const CampaignAnalysis& ca, std::size_t a, const FigureDatum& d) {
  std::vector<const nlohmann::json*> out;
  for (std::size_t p : d.points)
    for (const nlohmann::json* r : ca.results[a].OfPoint(p)) out.push_back(r);
  return out;
}

// The legend or panel name of a datum: its axes, or the figure's quantity for a campaign of one point.
std::string DatumLabel(const FigureDatum& d, const std::string& otherwise) {
  return d.group.empty() ? otherwise : d.group;
}

// A histogram per datum of a distribution an analysis offers (its runs' samples pooled) or of
// a per-run metric (its runs' values), over one range and one set of bins for every curve.
void DistributionFigure(const CampaignAnalysis& ca, const FigureSpec& spec, FigureOutcome& out) {
  const CampaignView& v = ca.view;
  const std::string where = spec.path + " (\"" + spec.name + "\")";
  std::optional<std::size_t> source;
  DistributionInfo info{spec.of, spec.of, ""};
  std::vector<std::string> offered;
  for (std::size_t a = 0; ca.setup && a < ca.setup->analyses.size(); ++a)
    for (const DistributionInfo& d : ca.setup->analyses[a]->DistributionNames()) {
      offered.push_back(d.name);
      if (d.name == spec.of && !source) {
        source = a;
        info = d;
      }
    }
  std::vector<Samples> samples(out.data.size());
  bool metric_found = false;
  for (std::size_t i = 0; i < out.data.size(); ++i) {
    Samples& s = samples[i];
    auto add = [&](const Samples& one) {
      for (std::size_t k = 0; k < one.values.size(); ++k) {
        s.values.push_back(one.values[k]);
        s.weights.push_back(one.weights.empty() ? 1.0 : one.weights[k]);
      }
    };
    if (source) {
      for (const nlohmann::json* r : DatumResults(ca, *source, out.data[i]))
        add(ca.setup->analyses[*source]->Distribution(spec.of, *r));
      continue;
    }
    for (std::size_t p : out.data[i].points)
      for (std::size_t run : v.points[p].runs)
        for (std::size_t a = 0; a < ca.results.size(); ++a)
          for (const Metric& m : ca.RunMetrics(a, run)) {
            if (m.name != spec.of) continue;
            metric_found = true;
            info.title = m.title.empty() ? m.name : m.title;
            info.unit = m.unit == "1" ? "" : m.unit;
            if (std::isfinite(m.value)) add({{m.value}, {}});
          }
  }
  if (!source && !metric_found) {
    out.blocks.push_back(Text{"**Not drawn:** " + where + ": \"" + spec.of +
                              "\" is no distribution an analysis offers (" + Joined(offered) +
                              ") and no run has a metric of that name."});
    return;
  }
  // One range for every curve: the figure's, or the data's (positive values only on log bins).
  double lo = spec.range_lo, hi = spec.range_hi;
  if (!std::isfinite(lo)) {
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    for (const Samples& s : samples)
      for (std::size_t k = 0; k < s.values.size(); ++k)
        if (std::isfinite(s.values[k]) && s.weights[k] > 0 && (!spec.logx || s.values[k] > 0)) {
          lo = std::min(lo, s.values[k]);
          hi = std::max(hi, s.values[k]);
        }
    if (!std::isfinite(lo)) {
      out.blocks.push_back(
          Text{"**Not drawn:** " + where + ": no run has a value of " + spec.of + OnlyText(spec) + "."});
      return;
    }
    if (hi <= lo) {
      lo = spec.logx ? lo / 2 : lo - 0.5;
      hi = spec.logx ? hi * 2 : hi + 0.5;
    }
  }
  Figure f;
  f.name = "figure-" + spec.name;
  f.title = spec.title.empty() ? "Distribution of " + info.title : spec.title;
  f.xlabel = WithUnit(info.title, info.unit);
  f.ylabel = "probability density" + (info.unit.empty() ? std::string() : " (1/" + info.unit + ")");
  f.logx = spec.logx;
  f.logy = spec.logy;
  for (std::size_t i = 0; i < out.data.size(); ++i) {
    const Density h = DensityHistogram(samples[i], spec.bins, lo, hi, spec.logx);
    if (!(h.total > 0)) continue;
    Series se;
    const std::string label = DatumLabel(out.data[i], spec.of);
    se.label = label + " (n = " + FormatNumber(h.total, 6) + ")";
    se.file_label = label;
    se.columns = {spec.of, "density", "count"};
    se.style = Series::Style::kLinesPoints;
    se.color = static_cast<int>(i);
    for (std::size_t b = 0; b < h.center.size(); ++b)
      if (!spec.logy || h.density[b] > 0) se.rows.push_back({h.center[b], h.density[b], h.count[b]});
    out.data[i].n = static_cast<int>(std::lround(std::min(h.total, 2e9)));
    if (!se.rows.empty()) f.series.push_back(se);
  }
  f.caption = (spec.caption.empty() ? "" : spec.caption + ". ") + "Probability density: count / (n x bin width), " +
              std::to_string(spec.bins) + (spec.logx ? " logarithmic" : "") + " bins over [" + FormatNumber(lo, 4) +
              ", " + FormatNumber(hi, 4) + "] for every curve; n counts every value, those outside the range too; " +
              (source ? "pooled over the runs of each point"
                      : "one value per run (the metric " + spec.of + "), pooled over the runs of each point") +
              (spec.pool.empty() ? "" : " and over " + Joined(spec.pool)) + OnlyText(spec) +
              (spec.reference.empty() ? "" : ". Reference: " + spec.reference);
  if (f.series.empty()) {
    out.blocks.push_back(Text{"**Not drawn:** " + where + ": no run has a value of " + spec.of + OnlyText(spec) + "."});
    return;
  }
  out.blocks.push_back(f);
}

// The first of the campaign's analyses that offers `name` among its distributions, curves or
// fields (`offers`), with what it says of it.
template <class Info>
struct Offered {
  std::size_t analysis;
  Info info;
};
template <class Info>
std::optional<Offered<Info>> FindOffered(const CampaignAnalysis& ca, const std::string& name,
                                         std::vector<Info> (Analysis::*offers)() const) {
  for (std::size_t a = 0; ca.setup && a < ca.setup->analyses.size(); ++a)
    for (Info& i : ((*ca.setup->analyses[a]).*offers)())
      if (i.name == name) return Offered<Info>{a, std::move(i)};
  return std::nullopt;
}

// A curve per datum that an analysis offers (kind "curves"), each from the runs behind the
// datum merged (pooled points are one datum), with error bars where the curve has them.
void CurveFigure(const CampaignAnalysis& ca, const FigureSpec& spec, FigureOutcome& out) {
  const std::string where = spec.path + " (\"" + spec.name + "\")";
  const std::optional<Offered<CurveInfo>> found = FindOffered(ca, spec.of, &Analysis::CurveNames);
  if (!found) {
    out.blocks.push_back(Text{"**Not drawn:** " + where + ": no analysis offers the curve " + spec.of + "."});
    return;
  }
  const std::size_t source = found->analysis;
  const CurveInfo& info = found->info;
  Figure f;
  f.name = "figure-" + spec.name;
  f.title = spec.title.empty() ? info.title : spec.title;
  f.xlabel = info.xlabel;
  f.ylabel = info.ylabel;
  f.logx = spec.logx;
  f.logy = spec.logy;
  std::vector<std::string> missing;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < out.data.size(); ++i) {
    FigureDatum& d = out.data[i];
    const std::string label = DatumLabel(d, info.name);
    const std::vector<CurvePoint> points = ca.setup->analyses[source]->Curve(spec.of, DatumResults(ca, source, d));
    Series se;
    se.label = label;
    se.file_label = label;
    se.columns = {"x", "y", "y_se", "n"};
    const bool errors =
        std::any_of(points.begin(), points.end(), [](const CurvePoint& c) { return std::isfinite(c.se); });
    se.style = errors ? Series::Style::kErrorBars : Series::Style::kLinesPoints;
    if (errors) se.err = 2;
    se.color = static_cast<int>(i);
    double n = 0.0;
    for (const CurvePoint& c : points) {
      if (!std::isfinite(c.x) || !std::isfinite(c.y) || (spec.logx && !(c.x > 0)) || (spec.logy && !(c.y > 0)))
        continue;
      se.rows.push_back({c.x, c.y, std::isfinite(c.se) ? c.se : 0.0, c.n});
      n += c.n;
      lo = std::min(lo, c.x);
      hi = std::max(hi, c.x);
    }
    if (se.rows.empty()) {
      missing.push_back(label);
      continue;
    }
    d.n = static_cast<int>(std::lround(std::min(n, 2e9)));
    f.series.push_back(se);
  }
  if (info.diagonal && !f.series.empty()) {
    Series one;
    one.label = "y = x";
    one.columns = {"x", "y"};
    one.style = Series::Style::kLines;
    one.role = Series::Role::kReference;
    one.rows = {{lo, lo}, {hi, hi}};
    f.series.push_back(one);
  }
  f.caption = (spec.caption.empty() ? "" : spec.caption + ". ") + "Each curve: the runs behind it merged" +
              (spec.pool.empty() ? "" : ", pooled over " + Joined(spec.pool)) + OnlyText(spec) +
              (spec.reference.empty() ? "" : ". Reference: " + spec.reference);
  if (!f.series.empty()) out.blocks.push_back(f);
  if (!missing.empty())
    out.blocks.push_back(Text{"**" + std::string(f.series.empty() ? "Not drawn" : "Left out") + ":** " + where +
                              ": no " + spec.of + " at " + Joined(missing) + " (no run there has it)."});
}

}  // namespace

std::vector<std::vector<std::array<double, 2>>> ClipPolylines(
    const std::vector<std::vector<std::array<double, 2>>>& lines, const std::array<double, 4>& box) {
  std::vector<std::vector<std::array<double, 2>>> out;
  for (const auto& line : lines) {
    std::vector<std::array<double, 2>> run;
    auto close = [&] {
      if (run.size() > 1) out.push_back(run);
      run.clear();
    };
    for (std::size_t k = 1; k < line.size(); ++k) {
      // Liang-Barsky: the parameters t in [0, 1] of a + t (b - a) inside the box.
      const std::array<double, 2>& a = line[k - 1];
      const std::array<double, 2>& b = line[k];
      const double dx = b[0] - a[0], dy = b[1] - a[1];
      double t0 = 0.0, t1 = 1.0;
      bool inside = true;
      const double p[4] = {-dx, dx, -dy, dy}, q[4] = {a[0] - box[0], box[1] - a[0], a[1] - box[2], box[3] - a[1]};
      for (int i = 0; i < 4 && inside; ++i) {
        if (p[i] == 0.0) {
          inside = q[i] >= 0.0;
        } else {
          const double t = q[i] / p[i];
          if (p[i] < 0.0)
            t0 = std::max(t0, t);
          else
            t1 = std::min(t1, t);
          inside = t0 <= t1;
        }
      }
      if (!inside) {
        close();
        continue;
      }
      const std::array<double, 2> from = {a[0] + t0 * dx, a[1] + t0 * dy}, to = {a[0] + t1 * dx, a[1] + t1 * dy};
      if (run.empty() || run.back() != from) {
        close();
        run.push_back(from);
      }
      run.push_back(to);
      if (t1 < 1.0) close();
    }
    close();
  }
  return out;
}

namespace {

// Map panels (kind "maps") or line profiles (kind "profile") of a field an analysis offers, one
// per datum, each from the runs behind it merged.
void FieldFigure(const CampaignAnalysis& ca, const FigureSpec& spec, FigureOutcome& out) {
  const CampaignView& v = ca.view;
  const std::string where = spec.path + " (\"" + spec.name + "\")";
  const std::optional<Offered<FieldInfo>> found = FindOffered(ca, spec.field, &Analysis::FieldNames);
  if (!found) {
    out.blocks.push_back(Text{"**Not drawn:** " + where + ": no analysis offers the field " + spec.field + "."});
    return;
  }
  const std::size_t source = found->analysis;
  const FieldInfo& info = found->info;
  const Analysis& analysis = *ca.setup->analyses[source];
  std::vector<std::string> missing;
  MapFigure m;
  m.name = "figure-" + spec.name;
  m.title = spec.title.empty() ? info.title : spec.title;
  m.value_name = WithUnit(info.title, info.unit);
  m.value_key = info.name;
  m.diverging = info.diverging;
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo, y_lo = x_lo, y_hi = -x_lo;
  auto extend = [&](double x, double y) {
    x_lo = std::min(x_lo, x);
    x_hi = std::max(x_hi, x);
    y_lo = std::min(y_lo, y);
    y_hi = std::max(y_hi, y);
  };
  const char along = spec.along == "y" ? 'y' : 'x';
  const char across = along == 'x' ? 'y' : 'x';
  Figure f;
  f.name = "figure-" + spec.name;
  f.title = spec.title.empty()
                ? info.title + " along " + spec.along + " at " + across + " = " + FormatNumber(spec.at) + " d"
                : spec.title;
  f.xlabel = spec.origin_outlet >= 0 ? "x from the centre of base outlet " + std::to_string(spec.origin_outlet) + " (d)"
                                     : spec.along + " (d)";
  f.ylabel = WithUnit(info.title, info.unit);
  f.logy = spec.logy;
  std::string band;
  double arrow_spacing = 0.0;
  for (std::size_t i = 0; i < out.data.size(); ++i) {
    FigureDatum& d = out.data[i];
    const std::string label = DatumLabel(d, info.name);
    std::optional<FieldMap> map;
    std::string one;  // " (replica k)" when one run is drawn
    if (spec.one_run) {
      // The lowest replica whose run has the field (a run may end before the fields' frames).
      std::vector<std::size_t> runs;
      for (std::size_t p : d.points) runs.insert(runs.end(), v.points[p].runs.begin(), v.points[p].runs.end());
      std::stable_sort(runs.begin(), runs.end(), [&](std::size_t a, std::size_t b) {
        return v.used[a].record->replica < v.used[b].record->replica;
      });
      for (std::size_t u : runs) {
        if (u >= ca.results[source].runs.size() || ca.results[source].runs[u].is_null()) continue;
        map = analysis.Field(spec.field, {&ca.results[source].runs[u]}, v.points[d.points.front()].spec);
        if (map && map->nx > 0 && map->ny > 0) {
          one = " (replica " + std::to_string(v.used[u].record->replica) + ")";
          break;
        }
      }
    } else {
      map = analysis.Field(spec.field, DatumResults(ca, source, d), v.points[d.points.front()].spec);
    }
    if (!map || map->nx == 0 || map->ny == 0) {
      missing.push_back(label);
      continue;
    }
    d.n = map->runs;
    if (spec.kind == "maps") {
      MapPanel panel;
      panel.title = label + ": " + std::to_string(map->runs) + (map->runs == 1 ? " run" + one + ", " : " runs, ") +
                    std::to_string(map->frames) + (map->frames == 1 ? " frame" : " frames");
      for (int j = 0; j < map->ny; ++j)
        for (int k = 0; k < map->nx; ++k) {
          const std::size_t n =
              static_cast<std::size_t>(j) * static_cast<std::size_t>(map->nx) + static_cast<std::size_t>(k);
          panel.grid.push_back(
              {map->X(k), map->Y(j), map->values[n], n < map->n_frames.size() ? map->n_frames[n] : kNaN});
        }
      // The panel spans the grid and what of the silo lies within kNear of it: the walls beside
      // the default window, not those far from a zoomed one (/report/fields/window).
      constexpr double kNear = 2.0;
      const double gx0 = map->X(0) - map->spacing / 2, gx1 = map->X(map->nx - 1) + map->spacing / 2;
      const double gy0 = map->Y(0) - map->spacing / 2, gy1 = map->Y(map->ny - 1) + map->spacing / 2;
      const std::array<double, 4> box = {gx0 - kNear, gx1 + kNear, gy0 - kNear, gy1 + kNear};
      extend(gx0, gy0);
      extend(gx1, gy1);
      panel.lines = ClipPolylines(map->lines, box);
      for (const auto& line : panel.lines)
        for (const auto& pt : line) extend(pt[0], pt[1]);
      for (const auto& c : map->circles) {
        extend(std::clamp(c[0] - c[2], box[0], box[1]), std::clamp(c[1] - c[2], box[2], box[3]));
        extend(std::clamp(c[0] + c[2], box[0], box[1]), std::clamp(c[1] + c[2], box[2], box[3]));
      }
      panel.circles = map->circles;
      panel.arrows = map->arrows;  // scaled below, by one length across the panels
      if (map->arrow_spacing > 0.0)
        arrow_spacing = arrow_spacing > 0.0 ? std::min(arrow_spacing, map->arrow_spacing) : map->arrow_spacing;
      m.panels.push_back(std::move(panel));
      continue;
    }
    // x from the centre of a base outlet of the point (it may move from point to point).
    double origin = 0.0;
    if (spec.origin_outlet >= 0) {
      const nlohmann::json outlets = v.points[d.points.front()]
                                         .spec.value("silo", nlohmann::json::object())
                                         .value("base_outlets", nlohmann::json::array());
      if (!outlets.is_array() || static_cast<int>(outlets.size()) <= spec.origin_outlet ||
          !outlets[spec.origin_outlet].is_object()) {
        missing.push_back(label + " (no base outlet " + std::to_string(spec.origin_outlet) + ")");
        continue;
      }
      origin = outlets[spec.origin_outlet].value("center", 0.0);
    }
    const FieldProfile pr = ComputeFieldProfile(*map, along, spec.at, spec.width);
    if (pr.position.empty()) {
      const double lo = along == 'x' ? map->Y(0) : map->X(0),
                   hi = along == 'x' ? map->Y(map->ny - 1) : map->X(map->nx - 1);
      missing.push_back(label + " (the line " + std::string(1, across) + " = " + FormatNumber(spec.at) +
                        " d lies outside the grid, " + std::string(1, across) + " = " + FormatNumber(lo) + " .. " +
                        FormatNumber(hi) + " d)");
      continue;
    }
    if (band.empty())
      band = pr.band_lo == pr.band_hi
                 ? std::string(1, across) + " = " + FormatNumber(pr.band_lo) + " d"
                 : std::string(1, across) + " = " + FormatNumber(pr.band_lo) + " .. " + FormatNumber(pr.band_hi) + " d";
    Series se;
    se.label = label + ": " + std::to_string(map->runs) + (map->runs == 1 ? " run" + one : " runs");
    se.file_label = label;
    se.columns = {spec.along, info.name, "nodes"};
    se.style = Series::Style::kLinesPoints;
    se.color = static_cast<int>(i);
    for (std::size_t k = 0; k < pr.position.size(); ++k)
      if (std::isfinite(pr.value[k]) && (!spec.logy || pr.value[k] > 0))
        se.rows.push_back({pr.position[k] - origin, pr.value[k], static_cast<double>(pr.nodes[k])});
    if (!se.rows.empty()) f.series.push_back(se);
  }
  const std::string tail = (spec.pool.empty() ? "" : "; pooled over " + Joined(spec.pool)) + OnlyText(spec) +
                           (spec.reference.empty() ? "" : ". Reference: " + spec.reference);
  // Arrows: the longest of every panel 0.9 of their spacing.
  double longest = 0.0;
  for (const MapPanel& p : m.panels)
    for (const auto& a : p.arrows) longest = std::max(longest, std::hypot(a[2], a[3]));
  std::string arrows_text;
  if (longest > 0.0 && arrow_spacing > 0.0) {
    const double scale = 0.9 * arrow_spacing / longest;
    for (MapPanel& p : m.panels)
      for (auto& a : p.arrows) {
        a[2] *= scale;
        a[3] *= scale;
      }
    arrows_text = "; arrows: the vector field, the longest " + FormatNumber(0.9 * arrow_spacing) + " d for " +
                  FormatNumber(longest) + (info.unit.empty() ? "" : " " + info.unit);
  } else {
    for (MapPanel& p : m.panels) p.arrows.clear();
  }
  if (spec.kind == "maps" && !m.panels.empty()) {
    m.x_lo = x_lo - 1.0;
    m.x_hi = x_hi + 1.0;
    m.y_lo = y_lo - 1.0;
    m.y_hi = y_hi + 1.0;
    m.caption = (spec.caption.empty() ? "" : spec.caption + ". ") + "Each panel: " +
                (spec.one_run ? "the lowest replica that has the field" : "the runs behind it merged") +
                ", and the frames averaged; one colour scale across the panels; walls black" + arrows_text + tail;
    out.blocks.push_back(m);
  }
  if (spec.kind == "profile" && !f.series.empty()) {
    f.caption =
        (spec.caption.empty() ? "" : spec.caption + ". ") + "At each " + spec.along +
        ": the mean of the field over the grid " + (along == 'x' ? "rows " : "columns ") + band + " (within " +
        FormatNumber(spec.width / 2) + " d of " + std::string(1, across) + " = " + FormatNumber(spec.at) + " d); " +
        (spec.one_run ? "each curve the lowest replica that has the field" : "the runs behind each curve merged") +
        tail;
    out.blocks.push_back(f);
  }
  if (!missing.empty())
    out.blocks.push_back(Text{"**Not drawn:** " + where + ": no " + spec.field + " at " + [&] {
      std::string t;
      for (const auto& s : missing) t += (t.empty() ? "" : "; ") + s;
      return t;
    }() + "."});
}

}  // namespace

FieldProfile ComputeFieldProfile(const FieldMap& m, char along, double at, double width) {
  FieldProfile p;
  const bool ax = along == 'x';
  const int n_along = ax ? m.nx : m.ny, n_across = ax ? m.ny : m.nx;
  if (n_along <= 0 || n_across <= 0) return p;
  const double origin = ax ? m.y0 : m.x0;
  auto across = [&](int k) { return origin + k * m.spacing; };
  // A line outside the grid (beyond half a spacing of its outer rows) has no profile.
  if (at < across(0) - m.spacing / 2 || at > across(n_across - 1) + m.spacing / 2) return p;
  std::vector<int> band;
  for (int k = 0; k < n_across; ++k)
    if (std::abs(across(k) - at) <= width / 2 + 1e-9 * m.spacing) band.push_back(k);
  if (band.empty())
    band.push_back(std::clamp(static_cast<int>(std::lround((at - origin) / m.spacing)), 0, n_across - 1));
  p.band_lo = across(band.front());
  p.band_hi = across(band.back());
  for (int i = 0; i < n_along; ++i) {
    double sum = 0.0;
    int n = 0;
    for (int k : band) {
      const double value = ax ? m.At(i, k) : m.At(k, i);
      if (!std::isfinite(value)) continue;
      sum += value;
      ++n;
    }
    p.position.push_back(ax ? m.X(i) : m.Y(i));
    p.value.push_back(n > 0 ? sum / n : kNaN);
    p.nodes.push_back(n);
  }
  return p;
}

Density DensityHistogram(const Samples& s, int bins, double lo, double hi, bool log) {
  Density d;
  if (bins <= 0 || !(hi > lo) || (log && !(lo > 0))) return d;
  std::vector<double> edges(static_cast<std::size_t>(bins) + 1);
  for (int i = 0; i <= bins; ++i)
    edges[static_cast<std::size_t>(i)] =
        log ? lo * std::pow(hi / lo, static_cast<double>(i) / bins) : lo + (hi - lo) * i / bins;
  d.count.assign(static_cast<std::size_t>(bins), 0.0);
  for (std::size_t k = 0; k < s.values.size(); ++k) {
    const double x = s.values[k], w = s.weights.empty() ? 1.0 : s.weights[k];
    if (!std::isfinite(x) || !(w > 0)) continue;
    d.total += w;
    if (x < lo || x > hi) continue;
    const double u = log ? std::log(x / lo) * bins / std::log(hi / lo) : (x - lo) * bins / (hi - lo);
    d.count[static_cast<std::size_t>(std::clamp(static_cast<int>(std::floor(u)), 0, bins - 1))] += w;
  }
  for (int i = 0; i < bins; ++i) {
    const double a = edges[static_cast<std::size_t>(i)], b = edges[static_cast<std::size_t>(i) + 1];
    d.center.push_back(log ? std::sqrt(a * b) : 0.5 * (a + b));
    d.density.push_back(d.total > 0 ? d.count[static_cast<std::size_t>(i)] / (d.total * (b - a)) : kNaN);
  }
  return d;
}

std::vector<FigureSpec> ReadFigureSpecs(const nlohmann::json& campaign_spec) {
  if (!campaign_spec.is_object() || !campaign_spec.contains("report") || !campaign_spec.at("report").is_object() ||
      !campaign_spec.at("report").contains("figures"))
    return {};
  const nlohmann::json& list = campaign_spec.at("report").at("figures");
  if (!list.is_array())
    throw OptionError("/report/figures", list, "must be an array of figures ({\"name\", \"y\", ...})");
  const CampaignAxes axes = CampaignAxes::OfCampaignSpec(campaign_spec);
  std::vector<FigureSpec> out;
  std::set<std::string> names;
  Offers offers(campaign_spec);
  for (std::size_t i = 0; i < list.size(); ++i) {
    out.push_back(ReadOne(list[i], "/report/figures/" + std::to_string(i), axes, names, offers));
    names.insert(out.back().name);
  }
  return out;
}

std::vector<PictureMark> PictureMarksOf(const FigureSpec& figure, const nlohmann::json& campaign_spec,
                                        const nlohmann::json& run_spec, double bed_top,
                                        std::vector<std::string>& problems) {
  std::vector<PictureMark> out;
  const std::vector<OutletGeometry> outlets = OutletsOf(run_spec);
  const nlohmann::json report = campaign_spec.is_object() && campaign_spec.contains("report")
                                    ? campaign_spec.at("report")
                                    : nlohmann::json::object();
  // Dimension lines of the outlets run 1.5 d outside the silo: clear of the outlet's band.
  constexpr double kOff = 1.5;
  const auto dimension = [&](double x0, double y0, double x1, double y1, const MarkSpec& m) {
    out.push_back({PictureMark::Kind::kDimension, x0, y0, x1, y1,
                   m.label + " = " + FormatNumber(std::hypot(x1 - x0, y1 - y0), 3) + " d", false});
  };
  for (const MarkSpec& m : figure.annotate) {
    if (m.what == "region") {
      const RegionSize asked = ReadRegionSize(report.value("region", nlohmann::json()), "/report/region");
      RegionSize size;
      try {
        size = RegionForRun(asked, run_spec);
      } catch (const std::invalid_argument& e) {
        problems.push_back(m.label + ": " + e.what());
        continue;
      }
      for (std::size_t k = 0; k < outlets.size(); ++k) {
        if (m.index >= 0 && static_cast<std::size_t>(m.index) != k) continue;
        const Rect r = OutletRegion(outlets[k], size);
        out.push_back({PictureMark::Kind::kRect, r.x0, r.y0, r.x1, r.y1, m.label, m.shade});
      }
      if (m.index >= static_cast<int>(outlets.size()))
        problems.push_back(m.label + ": the run has no outlet " + std::to_string(m.index));
    } else if (m.what == "fields") {
      const std::optional<FieldsOptions> fields =
          ReadFieldsOptions(report.value("fields", nlohmann::json()), "/report/fields");
      Rect w = fields ? fields->cg.window : Rect{};
      if (!(w.x1 > w.x0)) {
        const nlohmann::json silo = run_spec.value("silo", nlohmann::json::object());
        w = CgDefaultWindow(silo.value("width", 100.0), bed_top > 0 ? bed_top : 148.5);
      }
      out.push_back({PictureMark::Kind::kRect, w.x0, w.y0, w.x1, w.y1, m.label, m.shade});
    } else if (m.what == "disc_diameters") {
      // Which body is the renderer's to find (the frame is its); the point is the spec's.
      const std::array<double, 2> at = m.at ? *m.at
                                       : figure.window
                                           ? std::array<double, 2>{0.5 * ((*figure.window)[0] + (*figure.window)[1]),
                                                                   0.5 * ((*figure.window)[2] + (*figure.window)[3])}
                                           : std::array<double, 2>{0.0, 0.5 * (bed_top > 0 ? bed_top : 10.0)};
      PictureMark discs{PictureMark::Kind::kDiscs, at[0], at[1], at[0], at[1], ""};
      discs.labels = m.labels;
      out.push_back(discs);
    } else if (m.what == "origin") {
      out.push_back({PictureMark::Kind::kOrigin, 0.0, 0.0, 0.0, 0.0, m.label});
    } else if (m.what == "outlet_width") {
      if (m.index >= static_cast<int>(outlets.size())) {
        problems.push_back(m.label + ": the run has no outlet " + std::to_string(m.index));
        continue;
      }
      const OutletGeometry& o = outlets[static_cast<std::size_t>(m.index)];
      const double lo = o.center - 0.5 * o.width, hi = o.center + 0.5 * o.width;
      if (o.base) {
        dimension(lo, -kOff, hi, -kOff, m);
      } else {
        const double x = o.wall_x + (o.right_wall ? kOff : -kOff);
        dimension(x, lo, x, hi, m);
      }
    } else if (m.what == "outlet_gap") {
      std::vector<OutletGeometry> base;
      for (const OutletGeometry& o : outlets)
        if (o.base) base.push_back(o);
      if (base.size() < 2) {
        problems.push_back(m.label + ": the run has fewer than two base outlets");
        continue;
      }
      const OutletGeometry& left = base[0].center < base[1].center ? base[0] : base[1];
      const OutletGeometry& right = base[0].center < base[1].center ? base[1] : base[0];
      dimension(left.center + 0.5 * left.width, -kOff, right.center - 0.5 * right.width, -kOff, m);
    } else {  // obstacle_height, obstacle_offset
      const std::vector<std::array<double, 3>> obstacles = MakeSiloDrawing(run_spec, 0.0).circles;
      if (m.index >= static_cast<int>(obstacles.size())) {
        problems.push_back(m.label + ": the run has no obstacle " + std::to_string(m.index));
        continue;
      }
      const double x = obstacles[static_cast<std::size_t>(m.index)][0],
                   y = obstacles[static_cast<std::size_t>(m.index)][1];
      if (m.what == "obstacle_height")
        dimension(x, 0.0, x, y, m);
      else
        dimension(0.0, y, x, y, m);
    }
  }
  return out;
}

std::map<std::string, double> PointAxes(const CampaignView& view, const Point& point) {
  std::map<std::string, double> axes = view.named.Values(point.point, point.spec);
  if (!view.x_symbol.empty() && !axes.count(view.x_symbol)) axes[view.x_symbol] = point.x;
  return axes;
}

bool AxisValueMatches(const CampaignView& view, const Point& point, const std::string& name,
                      const nlohmann::json& want) {
  if (const auto pointer = view.named.PointerOf(name)) {
    const auto v = AxisValue(*pointer, point.point, point.spec);
    if (v && v->is_string()) return want.is_string() && want.get<std::string>() == v->get<std::string>();
  }
  const std::map<std::string, double> axes = PointAxes(view, point);
  const auto it = axes.find(name);
  if (it == axes.end() || !std::isfinite(it->second) || !want.is_number()) return false;
  const double a = it->second, b = want.get<double>();
  return a == b || std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b)) || ValueWords(a) == ValueWords(b);
}

FigureOutcome MakeFigure(const CampaignAnalysis& ca, const FigureSpec& spec) {
  const CampaignView& v = ca.view;
  FigureOutcome out;
  out.spec = &spec;
  const std::string x_name = spec.x.empty() ? v.x_symbol : spec.x;
  // The group axes: as given, or every sweep axis that is not x and not pooled.
  // A figure at chosen points (distribution, maps, profile): a curve or panel per point, named
  // by every axis not pooled, or by the axes `group` names (a derived one such as L names a
  // curve as the thesis does; the points stay one curve each).
  const bool per_point =
      spec.kind == "distribution" || spec.kind == "curves" || spec.kind == "maps" || spec.kind == "profile";
  std::vector<std::string> every_axis;
  for (const auto& axis : v.axes) {
    const std::string n = v.named.ShortName(axis);
    const bool is_x = !per_point && (n == x_name || v.x_axes.count(axis));
    if (!is_x && std::find(spec.pool.begin(), spec.pool.end(), n) == spec.pool.end()) every_axis.push_back(n);
  }
  const std::vector<std::string> group = spec.group_given ? spec.group : every_axis;
  const auto group_text = [&](const std::vector<std::string>& names, const Point& point,
                              const std::map<std::string, double>& axes) {
    std::string text;
    for (const auto& g : names) {
      const auto pointer = v.named.PointerOf(g);
      const auto value = pointer ? AxisValue(*pointer, point.point, point.spec) : std::nullopt;
      const std::string shown = value ? ValueText(*value) : axes.count(g) ? ValueWords(axes.at(g)) : "?";
      const std::string unit = pointer ? AxisUnit(*pointer) : g == "L" ? "d" : "";
      text += (text.empty() ? "" : ", ") + g + " = " + shown +
              (unit.empty() || (value && value->is_string()) || (!value && !axes.count(g)) ? "" : " " + unit);
    }
    return text;
  };
  // Per datum, its name by every axis: the fallback of a per-point figure's `group`.
  const bool group_names_points = per_point && spec.group_given;
  std::vector<std::string> every_axis_text;
  std::vector<std::string> notes;
  // The points the figure shows, merged when they differ only in pooled axes.
  std::map<std::string, std::size_t> datum_of;  // key of the non-pooled axes -> index in out.data
  for (std::size_t p = 0; p < v.points.size(); ++p) {
    const Point& point = v.points[p];
    if (point.runs.empty()) continue;
    bool keep = true;
    for (const auto& [name, values] : spec.only)
      keep = keep && std::any_of(values.begin(), values.end(), [&, &axis = name](const nlohmann::json& w) {
               return AxisValueMatches(v, point, axis, w);
             });
    if (!keep) continue;
    const std::map<std::string, double> axes = PointAxes(v, point);
    std::string key;
    for (const auto& axis : v.axes) {
      const std::string n = v.named.ShortName(axis);
      if (std::find(spec.pool.begin(), spec.pool.end(), n) != spec.pool.end()) continue;
      const auto value = AxisValue(axis, point.point, point.spec);
      key += n + "=" + (value ? ValueText(*value) : "?") + ";";
    }
    if (std::find(spec.pool.begin(), spec.pool.end(), x_name) == spec.pool.end() && axes.count(x_name))
      key += "x=" + ValueWords(axes.at(x_name));
    const auto [it, added] = datum_of.emplace(key, out.data.size());
    if (added) {
      FigureDatum d;
      d.axes = axes;
      d.group = group_text(group, point, axes);
      out.data.push_back(d);
      if (group_names_points) every_axis_text.push_back(group_text(every_axis, point, axes));
    }
    out.data[it->second].points.push_back(p);
  }
  // Per point, `group` only names the curves: axes that do not tell two apart name them by
  // every axis, and the figure says so.
  std::string group_note;
  if (group_names_points) {
    std::set<std::string> seen;
    bool apart = true;
    for (const FigureDatum& d : out.data) apart = apart && seen.insert(d.group).second;
    if (!apart) {
      for (std::size_t i = 0; i < out.data.size(); ++i) out.data[i].group = every_axis_text[i];
      group_note = "**Note:** " + spec.path + " (\"" + spec.name + "\"): `group` (" + Joined(spec.group) +
                   ") does not tell its points apart: each is named by every axis.";
    }
  }
  // A curve or panel per point comes in the order of its x value, then of the other axes' values
  // in the sweep's order (X_db = 0 -> 1 as the thesis' panels a-e, W = 7 before W = 11), not in
  // the order the view keeps its points (by their group's text: "X_d = 0" first, "W = 11" before "W = 7").
  if (per_point || spec.kind == "pictures") {
    std::vector<std::string> order = {x_name};
    for (const auto& axis : v.axes) order.push_back(v.named.ShortName(axis));
    std::stable_sort(out.data.begin(), out.data.end(), [&order](const FigureDatum& a, const FigureDatum& b) {
      for (const std::string& name : order) {
        const auto ia = a.axes.find(name);
        const auto ib = b.axes.find(name);
        if (ia == a.axes.end() || ib == b.axes.end() || ia->second == ib->second) continue;
        return ia->second < ib->second;
      }
      return false;
    });
  }
  // Pictures: the chosen points are the figure; the report draws them (it has the renderer).
  if (spec.kind == "pictures") {
    if (out.data.empty())
      out.blocks.push_back(
          Text{"**Not drawn:** " + spec.path + " (\"" + spec.name + "\"): no finished run passes its `only`."});
    return out;
  }
  if (per_point) {
    for (const auto& name : spec.pool)
      for (FigureDatum& d : out.data) d.axes.erase(name);
    const std::string where = spec.path + " (\"" + spec.name + "\")";
    if (out.data.empty())
      out.blocks.push_back(Text{"**Not drawn:** " + where + ": no finished run passes its `only`."});
    else if (spec.kind == "distribution")
      DistributionFigure(ca, spec, out);
    else if (spec.kind == "curves")
      CurveFigure(ca, spec, out);
    else
      FieldFigure(ca, spec, out);
    if (!group_note.empty()) out.blocks.push_back(Text{group_note});
    return out;
  }
  // One datum per point set and y: the data of y k follow those of y k - 1.
  const std::size_t sets = out.data.size();
  for (FigureDatum& d : out.data)
    for (const auto& name : spec.pool) d.axes.erase(name);  // pooled axes vary inside a datum
  for (std::size_t k = 1; k < spec.y.size(); ++k)
    for (std::size_t i = 0; i < sets; ++i) {
      out.data.push_back(out.data[i]);
      out.data.back().series = k;
    }
  // The name of a curve: its y (when several) and its group.
  auto curve_name = [&](const FigureDatum& d) {
    if (spec.y.size() == 1) return d.group.empty() ? spec.y.front() : d.group;
    const std::string& y = spec.labels.empty() ? spec.y[d.series] : spec.labels[d.series];
    return d.group.empty() ? y : y + ", " + d.group;
  };
  std::string problem;
  std::vector<std::string> without_value;  // the data whose points have no value of their y
  std::vector<std::map<std::string, MeanSe>> metrics(sets);
  for (std::size_t i = 0; i < sets; ++i) metrics[i] = PooledMetrics(ca, out.data[i].points);
  for (std::size_t i = 0; i < out.data.size(); ++i) {
    FigureDatum& d = out.data[i];
    const auto xi = d.axes.find(x_name);
    d.x = xi == d.axes.end() ? kNaN : xi->second;
    std::string datum_problem;
    const MeanSe y = YValue(spec.y[d.series], metrics[i % sets], d.axes, datum_problem);
    if (!datum_problem.empty()) problem = datum_problem;
    if (!datum_problem.empty() || !std::isfinite(y.mean))
      without_value.push_back(curve_name(d) + ", " + x_name + " = " + FormatNumber(d.x, 6));
    d.y = y.mean;
    d.se = y.se;
    d.n = y.n;
  }
  const std::string where = spec.path + " (\"" + spec.name + "\")";
  const std::string y_text = Joined(spec.y);
  // A metric some points have and others lack (no clog at a point: no avalanche, no arch) leaves
  // those points out, saying which; only when no point has it is the figure not drawn.
  if (!problem.empty() && without_value.size() == out.data.size()) {
    notes.push_back("**Not drawn:** " + where + ": " + problem);
  } else if (!without_value.empty() && without_value.size() < out.data.size()) {
    notes.push_back("**Left out:** " + where + ": no value of " + y_text + " at " + Joined(without_value) +
                    " (no run there gave one)");
    problem.clear();
  }
  if (out.data.empty()) notes.push_back("**Not drawn:** " + where + ": no finished run passes its `only`.");

  // normalize: each datum divided by the datum of its curve at the reference values (its x and
  // group axes the same but those named).
  std::string normal_text;
  for (const auto& [name, want] : spec.normalize)
    normal_text += (normal_text.empty() ? "" : ", ") + name + " = " +
                   (want.is_string() ? want.get<std::string>() : ValueWords(want.get<double>()));
  if (!spec.normalize.empty() && problem.empty()) {
    auto text_of = [&](const FigureDatum& d, const std::string& axis) {
      if (axis == x_name) return ValueWords(d.x);
      const Point& point = v.points[d.points.front()];
      const auto pointer = v.named.PointerOf(axis);
      const auto value = pointer ? AxisValue(*pointer, point.point, point.spec) : std::nullopt;
      return value ? ValueText(*value) : d.axes.count(axis) ? ValueWords(d.axes.at(axis)) : std::string("?");
    };
    std::vector<std::string> compared = group;
    if (std::find(compared.begin(), compared.end(), x_name) == compared.end()) compared.push_back(x_name);
    std::vector<MeanSe> divided(out.data.size());
    std::vector<std::string> no_reference, ambiguous;
    for (std::size_t i = 0; i < out.data.size(); ++i) {
      const FigureDatum& d = out.data[i];
      if (!std::isfinite(d.y)) continue;
      std::vector<std::size_t> refs;
      for (std::size_t r = 0; r < out.data.size(); ++r) {
        const FigureDatum& c = out.data[r];
        if (c.series != d.series) continue;
        bool same = true;
        for (const auto& [name, want] : spec.normalize)
          same = same && AxisValueMatches(v, v.points[c.points.front()], name, want);
        for (const auto& axis : compared)
          if (std::none_of(spec.normalize.begin(), spec.normalize.end(),
                           [&axis](const auto& named) { return named.first == axis; }))
            same = same && text_of(c, axis) == text_of(d, axis);
        if (same) refs.push_back(r);
      }
      const std::string name = curve_name(d) + ", " + x_name + " = " + FormatNumber(d.x, 6);
      if (refs.empty() || !std::isfinite(out.data[refs.front()].y) || out.data[refs.front()].y == 0.0) {
        no_reference.push_back(name);
        divided[i] = MeanSe{};
      } else if (refs.size() > 1) {
        ambiguous.push_back(name);
        divided[i] = MeanSe{};
      } else {
        const FigureDatum& r = out.data[refs.front()];
        divided[i] = NormalisedValue({d.y, d.se, d.n}, {r.y, r.se, r.n}, refs.front() == i);
      }
    }
    for (std::size_t i = 0; i < out.data.size(); ++i) {
      out.data[i].y = divided[i].mean;
      out.data[i].se = divided[i].se;
    }
    if (!no_reference.empty())
      notes.push_back("**Left out:** " + where + ": no point at " + normal_text +
                      " (with a value of its y) in the curve of " + Joined(no_reference) +
                      " to divide by (`normalize`)");
    if (!ambiguous.empty())
      notes.push_back("**Left out:** " + where + ": several points at " + normal_text + " in the curve of " +
                      Joined(ambiguous) + " (`normalize` needs one; pool or choose with `only`)");
  }

  Figure f;
  f.name = "figure-" + spec.name;
  f.title = spec.title.empty() ? y_text + " against " + x_name : spec.title;
  f.xlabel = x_name;
  f.ylabel = spec.ylabel.empty() ? y_text : spec.ylabel;
  f.logx = spec.logx;
  f.logy = spec.logy;
  // The curves in order: each y, then each group.
  std::vector<std::string> groups;
  for (const FigureDatum& d : out.data)
    if (std::find(groups.begin(), groups.end(), d.group) == groups.end()) groups.push_back(d.group);
  for (std::size_t k = 0; k < spec.y.size(); ++k)
    for (std::size_t gi = 0; gi < groups.size(); ++gi) {
      Series se;
      se.columns = {x_name, "y", "y_se", "n"};
      se.style = Series::Style::kErrorBars;
      se.err = 2;
      se.color = static_cast<int>(k * groups.size() + gi);
      std::vector<const FigureDatum*> in;
      for (const FigureDatum& d : out.data)
        if (d.series == k && d.group == groups[gi] && std::isfinite(d.x) && std::isfinite(d.y)) in.push_back(&d);
      if (in.empty()) continue;
      se.label = curve_name(*in.front());
      std::sort(in.begin(), in.end(), [](const FigureDatum* a, const FigureDatum* b) { return a->x < b->x; });
      for (const FigureDatum* d : in) se.rows.push_back({d->x, d->y, d->se, static_cast<double>(d->n)});
      f.series.push_back(se);
    }
  if (problem.empty() && !out.data.empty() && f.series.empty())
    notes.push_back("**Not drawn:** " + where + ": no point has both " + x_name + " and " + y_text + ".");

  // The fit across every point of the figure.
  Table fit_table;
  Figure collapse;
  if (spec.fit && problem.empty()) {
    const FigureFitSpec& fs = *spec.fit;
    std::vector<std::vector<double>> xs;
    std::vector<double> ys, sigma;
    std::vector<const FigureDatum*> used;
    for (const FigureDatum& d : out.data) {
      if (!std::isfinite(d.y)) continue;
      std::vector<double> row;
      bool ok = true;
      for (const auto& name : fs.over) {
        const auto it = d.axes.find(name);
        ok = ok && it != d.axes.end() && std::isfinite(it->second);
        row.push_back(ok ? it->second : kNaN);
      }
      if (!ok) continue;
      xs.push_back(row);
      ys.push_back(d.y);
      sigma.push_back(d.se);
      used.push_back(&d);
    }
    FitResult r = FitModelMulti(spec.name, fs.model, fs.over, xs, ys, sigma, fs.initial);
    out.fit = r;
    fit_table = Table{"figure-" + spec.name + "-fit",
                      "Fit of " + fs.model + " over " + Joined(fs.over) + " across the figure's " +
                          std::to_string(xs.size()) + " points (95% confidence intervals, Student t; " +
                          (r.sigma.empty() ? "unweighted" : "weights 1/se^2") + "): " + r.Verdict(),
                      {"parameter", "value", "se", "95% CI low", "95% CI high", "chi2/dof", "points", "fit quality"},
                      {},
                      {"parameter", "value", "se", "ci_low", "ci_high", "chi2_per_dof", "points", "fit_quality"}};
    for (const FitParameter& par : r.parameters)
      fit_table.rows.push_back({par.name, Cell::Number(par.value, 5), Cell::Number(par.se, 2),
                                Cell::Number(par.ci_low, 5), Cell::Number(par.ci_high, 5),
                                Cell::Number(r.Ok() && r.dof > 0 ? r.chi2 / r.dof : kNaN, 3),
                                Cell::Count(static_cast<long long>(xs.size())), r.Rating()});
    if (r.quality != FitQuality::kGood) {
      notes.push_back("The fit is not drawn: " + r.Verdict() +
                      " (a curve is drawn only when every parameter is determined and no 95% interval holds 0).");
    } else {
      // One curve per group: x sampled across the figure's range, the other variables at the
      // group's values (a derived variable recomputed from the sampled sweep value).
      const auto x_pointer = v.named.PointerOf(x_name);
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const FigureDatum* d : used)
        if (std::isfinite(d->x)) {
          lo = std::min(lo, d->x);
          hi = std::max(hi, d->x);
        }
      for (std::size_t gi = 0; gi < groups.size() && std::isfinite(lo); ++gi) {
        const FigureDatum* first = nullptr;
        for (const FigureDatum* d : used)
          if (d->group == groups[gi]) first = d;
        if (!first) continue;
        Series curve;
        curve.label = "fit" + (groups[gi].empty() ? std::string() : " (" + groups[gi] + ")");
        curve.columns = {x_name, "fit"};
        curve.style = Series::Style::kLines;
        curve.role = Series::Role::kFit;
        curve.color = static_cast<int>(gi);
        constexpr int kSamples = 120;
        const Point& rep = v.points[first->points.front()];
        for (int i = 0; i <= kSamples; ++i) {
          const double xv = lo + (hi - lo) * i / kSamples;
          std::map<std::string, double> axes = first->axes;
          if (x_pointer) {
            nlohmann::json point = rep.point;
            point[*x_pointer] = xv;
            axes = PointAxes(v, Point{rep.id, point, xv, "", "", "", "", rep.spec, {}});
          } else if (std::find(fs.over.begin(), fs.over.end(), x_name) != fs.over.end()) {
            axes[x_name] = xv;
          } else {
            break;  // x is derived and not a fit variable: the curve is drawn through the points below
          }
          std::vector<double> at;
          for (const auto& name : fs.over) at.push_back(axes.count(name) ? axes.at(name) : kNaN);
          const double yv = r.EvaluateAt(at);
          if (std::isfinite(yv)) curve.rows.push_back({xv, yv});
        }
        if (curve.rows.empty())  // through the fitted values at the data points
          for (std::size_t i = 0; i < used.size(); ++i)
            if (used[i]->group == groups[gi]) curve.rows.push_back({used[i]->x, r.fitted[i]});
        std::sort(curve.rows.begin(), curve.rows.end());
        if (!curve.rows.empty()) f.series.push_back(curve);
      }
      if (fs.collapse) {
        collapse.name = "figure-" + spec.name + "-collapse";
        collapse.title = (spec.title.empty() ? y_text : spec.title) + ", divided by the fitted law";
        collapse.xlabel = x_name;
        collapse.ylabel = "(" + y_text + ") / (" + fs.model + ")";
        collapse.logx = spec.logx;
        collapse.caption =
            "The data divided by the law fitted across every point (parameters in the table): a law "
            "that holds puts every point on 1";
        for (std::size_t gi = 0; gi < groups.size(); ++gi) {
          Series se;
          se.label = groups[gi].empty() ? y_text : groups[gi];
          se.columns = {x_name, "y_over_law", "y_over_law_se"};
          se.style = Series::Style::kErrorBars;
          se.err = 2;
          se.color = static_cast<int>(gi);
          for (std::size_t i = 0; i < used.size(); ++i)
            if (used[i]->group == groups[gi] && std::isfinite(used[i]->x) && r.fitted[i] != 0.0)
              se.rows.push_back({used[i]->x, used[i]->y / r.fitted[i], used[i]->se / std::abs(r.fitted[i])});
          std::sort(se.rows.begin(), se.rows.end());
          if (!se.rows.empty()) collapse.series.push_back(se);
        }
        if (!collapse.series.empty()) {
          Series one;
          one.label = "1 (the law)";
          one.columns = {x_name, "one"};
          one.style = Series::Style::kLines;
          one.role = Series::Role::kReference;
          one.rows = {{lo, 1.0}, {hi, 1.0}};
          collapse.series.push_back(one);
        }
      }
    }
  }
  std::string caption = spec.caption;
  caption += std::string(caption.empty() ? "" : ". ") + "Error bars: standard errors" +
             (spec.pool.empty() ? "" : "; pooled over " + Joined(spec.pool) + " (means weighted by n)");
  if (!spec.normalize.empty())
    caption += "; each curve divided by its value at " + normal_text +
               " (se from both as independent; that point itself is 1 exactly)";
  caption += OnlyText(spec);
  if (spec.fit && out.fit && out.fit->quality == FitQuality::kGood)
    caption += "; dashed: " + spec.fit->model + " fitted across every point";
  if (!spec.reference.empty()) caption += ". Reference: " + spec.reference;
  f.caption = caption;
  if (!f.series.empty()) out.blocks.push_back(f);
  if (!fit_table.name.empty()) out.blocks.push_back(fit_table);
  if (!collapse.series.empty()) {
    if (!spec.reference.empty()) collapse.caption += ". Reference: " + spec.reference;
    out.blocks.push_back(collapse);
  }
  for (const auto& n : notes) out.blocks.push_back(Text{n});
  return out;
}

std::optional<Section> FiguresSection(const std::vector<FigureOutcome>& figures) {
  if (figures.empty()) return std::nullopt;
  Section s{"figures", "Figures", {}};
  s.blocks.push_back(
      Text{"The figures the campaign spec asks for (`/report/figures`); every analysis' own figures "
           "follow in its section."});
  for (const FigureOutcome& f : figures)
    for (const Block& b : f.blocks) s.blocks.push_back(b);
  return s;
}

}  // namespace granary::analysis

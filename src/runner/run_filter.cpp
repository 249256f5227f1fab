// See run_filter.h.
#include "runner/run_filter.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

#ifdef GRANARY_HAVE_ANALYSIS
#include "analysis/axes.h"
#include "analysis/report_document.h"
#endif
#include "runner/util.h"

namespace granary::runner {

using nlohmann::json;

namespace {

bool IsPointerFilter(const std::string& filter) { return filter.find('=') != std::string::npos; }

std::string List(const std::vector<std::string>& items, std::size_t max = 12) {
  std::string out;
  for (std::size_t i = 0; i < items.size() && i < max; ++i) out += (i ? ", " : "") + items[i];
  if (items.size() > max) out += ", ... (" + std::to_string(items.size()) + " in all)";
  return out;
}

// The sweep axes whose pointer ends in "/<name>" ("width", "0/width", "fraction").
std::vector<std::string> AxesEndingIn(const std::vector<std::string>& axes, const std::string& name) {
  std::vector<std::string> found;
  for (const auto& a : axes)
    if (a.size() > name.size() && a.compare(a.size() - name.size(), name.size(), name) == 0 &&
        a[a.size() - name.size() - 1] == '/')
      found.push_back(a);
  return found;
}

#ifdef GRANARY_HAVE_ANALYSIS
// The campaign's axes by name (short names, derived axes of /axes), or none if its spec has a
// derived axis that no longer parses (plan refuses such a spec; an old database may hold one).
std::optional<analysis::CampaignAxes> NamedAxes(const CampaignRow& campaign, const std::vector<const RunRow*>& live) {
  try {
    const json& spec = live.empty() ? json() : live.front()->params;
    const json& cs = campaign.spec;
    return analysis::CampaignAxes(campaign.axes, spec, cs.is_object() && cs.contains("axes") ? cs.at("axes") : json());
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// A derived axis' value equals VALUE: as numbers, or to the 6 significant digits the report prints.
bool DerivedMatches(double actual, const std::string& text) {
  const json value = json::parse(text, nullptr, false);
  if (value.is_discarded() || !value.is_number() || !std::isfinite(actual)) return false;
  const double want = value.get<double>();
  return actual == want || std::abs(actual - want) <= 1e-9 * std::max(std::abs(actual), std::abs(want)) ||
         analysis::FormatNumber(actual, 6) == analysis::FormatNumber(want, 6);
}
#endif

}  // namespace

bool ParameterMatches(const RunRow& row, const std::string& pointer, const std::string& text) {
  json::json_pointer ptr;
  try {
    ptr = json::json_pointer(pointer);
  } catch (const json::exception&) {
    return false;
  }
  if (!row.params.contains(ptr)) return false;
  const json& actual = row.params[ptr];
  const json value = json::parse(text, nullptr, false);
  if (!value.is_discarded()) {
    if (value.is_number() && actual.is_number()) return value.get<double>() == actual.get<double>();
    if (value == actual) return true;
  }
  return actual.is_string() && actual.get<std::string>() == text;
}

RunFilter::RunFilter(const std::vector<std::string>& filters) : texts_(filters) {
  for (const auto& f : filters) {
    if (f.empty()) continue;
    if (!IsPointerFilter(f)) {
      prefixes_.push_back(f);
      continue;
    }
    const auto eq = f.find('=');
    const std::string pointer = f.substr(0, eq);
    try {
      json::json_pointer p(pointer);
    } catch (const json::exception&) {
      throw FilterError("--only " + f + ": \"" + pointer + "\" is not a JSON Pointer such as /silo/width");
    }
    values_[pointer].push_back(f.substr(eq + 1));
  }
}

bool RunFilter::Matches(const RunRow& row) const {
  if (!prefixes_.empty() && std::none_of(prefixes_.begin(), prefixes_.end(),
                                         [&](const std::string& p) { return row.run_id.rfind(p, 0) == 0; }))
    return false;
  for (const auto& [key, texts] : values_) {
    const std::string& pointer = key;
    if (std::none_of(texts.begin(), texts.end(),
                     [&](const std::string& t) { return ParameterMatches(row, pointer, t); }))
      return false;
  }
  return true;
}

RunFilter ResolveFilters(const std::vector<std::string>& filters, const CampaignRow& campaign,
                         const std::vector<RunRow>& runs) {
  std::vector<const RunRow*> live;
  for (const auto& r : runs)
    if (r.state != RunState::kRetired) live.push_back(&r);
  const std::string axes = campaign.axes.empty() ? std::string("it has no sweep axes") : "axes: " + List(campaign.axes);
  std::vector<std::string> resolved;
#ifdef GRANARY_HAVE_ANALYSIS
  const std::optional<analysis::CampaignAxes> named = NamedAxes(campaign, live);
  // Derived-axis filters: axis -> the runs that pass one of its values.
  std::map<std::string, std::set<std::string>> derived;
#endif
  std::string names_text;
#ifdef GRANARY_HAVE_ANALYSIS
  if (named) {
    for (const auto& n : named->Names()) names_text += (names_text.empty() ? "" : ", ") + n;
    names_text = "; names: " + names_text;
  }
#endif
  for (const std::string& f : filters) {
    if (f.empty()) throw FilterError("--only: an empty filter (give a run-id prefix or POINTER=VALUE)");
    if (!IsPointerFilter(f)) {
      if (std::none_of(live.begin(), live.end(), [&](const RunRow* r) { return r->run_id.rfind(f, 0) == 0; }))
        throw FilterError("--only " + f + ": no run id starts with \"" + f +
                          "\" (a filter is a run-id prefix, or POINTER=VALUE on a parameter; " + axes + ")");
      resolved.push_back(f);
      continue;
    }
    const auto eq = f.find('=');
    std::string pointer = f.substr(0, eq);
    const std::string value = f.substr(eq + 1);
#ifdef GRANARY_HAVE_ANALYSIS
    if (named && !pointer.empty() && pointer[0] != '/') {
      if (const auto p = named->PointerOf(pointer)) {
        pointer = *p;  // the axis' short name, as the report and the export name it ("D_b")
      } else if (named->FindDerived(pointer)) {
        std::set<std::string>& pass = derived[pointer];
        std::vector<std::string> values;
        bool any = false;
        for (const RunRow* r : live) {
          const double actual = named->Values(r->point, r->params).at(pointer);
          const std::string text = analysis::FormatNumber(actual, 6);
          if (std::find(values.begin(), values.end(), text) == values.end()) values.push_back(text);
          if (DerivedMatches(actual, value)) {
            pass.insert(r->run_id);
            any = true;
          }
        }
        if (!any)
          throw FilterError("--only " + f + ": no run has " + pointer + " = " + value +
                            " (its values: " + List(values) + ")");
        continue;
      }
    }
#endif
    if (pointer.empty() || pointer[0] != '/') {
      // A short name: the one sweep axis that ends in it.
      const std::vector<std::string> found = AxesEndingIn(campaign.axes, pointer);
      if (found.size() != 1) {
        const std::string best = Nearest(pointer, campaign.axes);
        throw FilterError("--only " + f + ": \"" + pointer + "\" " +
                          (found.empty() ? "ends no sweep axis" : "ends several sweep axes (" + List(found) + ")") +
                          "; give the JSON Pointer" + (best.empty() ? "" : ", e.g. " + best + "=" + value) + " (" +
                          axes + names_text + ")");
      }
      pointer = found.front();
    }
    json::json_pointer ptr;
    try {
      ptr = json::json_pointer(pointer);
    } catch (const json::exception&) {
      throw FilterError("--only " + f + ": \"" + pointer + "\" is not a JSON Pointer such as /silo/width");
    }
    if (std::none_of(live.begin(), live.end(), [&](const RunRow* r) { return r->params.contains(ptr); })) {
      const std::string best = Nearest(pointer, campaign.axes);
      throw FilterError("--only " + f + ": \"" + pointer + "\" is not a parameter of the runs" +
                        (best.empty() ? "" : "; did you mean \"" + best + "\"?") + " (" + axes + ")");
    }
    if (std::none_of(live.begin(), live.end(), [&](const RunRow* r) { return ParameterMatches(*r, pointer, value); })) {
      std::vector<std::string> values;
      for (const RunRow* r : live) {
        if (!r->params.contains(ptr)) continue;
        const std::string v = r->params[ptr].dump();
        if (std::find(values.begin(), values.end(), v) == values.end()) values.push_back(v);
      }
      throw FilterError("--only " + f + ": no run has " + pointer + " = " + value + " (its values: " + List(values) +
                        ")");
    }
    resolved.push_back(pointer + "=" + value);
  }
#ifdef GRANARY_HAVE_ANALYSIS
  // Derived axes are not parameters of a run: their filters become the ids of the runs that
  // pass all of them (and any run-id prefix given), so that the filter reads the same later.
  if (!derived.empty()) {
    std::vector<std::string> prefixes, kept;
    for (const auto& r : resolved)
      if (!IsPointerFilter(r)) prefixes.push_back(r);
    for (const RunRow* r : live) {
      bool pass = prefixes.empty() || std::any_of(prefixes.begin(), prefixes.end(),
                                                  [&](const std::string& p) { return r->run_id.rfind(p, 0) == 0; });
      for (const auto& [name, ids] : derived) pass = pass && ids.count(r->run_id) > 0;
      if (pass) kept.push_back(r->run_id);
    }
    if (kept.empty())
      throw FilterError("--only " + List(filters) + ": each filter selects runs, but no run passes all of them");
    std::vector<std::string> out;
    for (const auto& r : resolved)
      if (IsPointerFilter(r)) out.push_back(r);
    out.insert(out.end(), kept.begin(), kept.end());
    resolved = out;
  }
#endif
  RunFilter filter(resolved);
  if (!filters.empty() && std::none_of(live.begin(), live.end(), [&](const RunRow* r) { return filter.Matches(*r); }))
    throw FilterError("--only " + List(filters) + ": each filter selects runs, but no run passes all of them");
  return filter;
}

}  // namespace granary::runner

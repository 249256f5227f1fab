// See contacts_analysis.h; the classification is arches.h's contact_types.
#include "analysis/contacts_analysis.h"

#include "analysis/arches.h"
#include "analysis/campaign_view.h"
#include "analysis/options.h"
#include "rundir/clogs.h"

namespace granary::analysis {
namespace {

constexpr int kKinds = 4;
constexpr const char* kNames[kKinds] = {"contact_ss", "contact_ls", "contact_ll", "contact_other"};
constexpr const char* kTitles[kKinds] = {
    "small-small contacts in the clogged system", "large-small contacts in the clogged system",
    "large-large contacts in the clogged system", "contacts of single discs or rods in the clogged system"};

// Per clog with contacts: the four fractions of all its contacts; a clog without a contact
// between two-disc bodies (only lone discs) has no size classes: NaN for those three.
void AddFractions(const nlohmann::json& result, std::vector<double> (&out)[kKinds]) {
  if (!result.is_object() || !result.contains("clogs")) return;
  for (const nlohmann::json& c : result.at("clogs")) {
    const double v[kKinds] = {c.value("small_small", 0.0), c.value("large_small", 0.0), c.value("large_large", 0.0),
                              c.value("other", 0.0)};
    const double total = v[0] + v[1] + v[2] + v[3];
    if (total <= 0) continue;
    const bool classified = v[0] + v[1] + v[2] > 0;
    for (int k = 0; k < kKinds; ++k) out[k].push_back(classified || k == 3 ? v[k] / total : kNaN);
  }
}

class ContactsAccumulator : public RunAccumulator {
 public:
  explicit ContactsAccumulator(const RunView& run) : run_(run.data) {}
  nlohmann::json Finish() override { return ContactsRunResult(*run_); }

 private:
  const rundir::RunData* run_;
};

class ContactsAnalysis : public Analysis {
 public:
  std::string Key() const override { return "contacts"; }
  int Version() const override { return 1; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    return std::make_unique<ContactsAccumulator>(run);
  }
  // Mean ± se over the run's clogs.
  std::vector<Metric> RunMetrics(const nlohmann::json& result) const override {
    std::vector<double> f[kKinds];
    AddFractions(result, f);
    if (f[0].empty()) return {};
    std::vector<Metric> m;
    for (int k = 0; k < kKinds; ++k) {
      const MeanSe x = MeanSeFinite(f[k]);
      m.push_back({kNames[k], "1", x.mean, x.se, kTitles[k], false});
    }
    return m;
  }
  // Pooled over the clogs of every replica: n = clogs.
  std::vector<PointMetric> PointMetrics(const AnalysisResults& results, std::size_t point) const override {
    std::vector<double> f[kKinds];
    for (const nlohmann::json* r : results.OfPoint(point)) AddFractions(*r, f);
    if (f[0].empty()) return {};
    std::vector<PointMetric> m;
    for (int k = 0; k < kKinds; ++k) {
      const MeanSe x = MeanSeFinite(f[k]);
      m.push_back({kNames[k], "1", x.mean, x.se, x.n, kTitles[k], false, ""});
    }
    return m;
  }

  std::optional<Section> BuildSection(const SectionInput& in) const override {
    const CampaignView& v = in.view;
    bool any = false;
    for (const auto& m : in.points) any = any || FindMetric(m, "contact_ss");
    if (!any) return std::nullopt;
    Section s{"contacts", "Contacts in the clogged system (ch. 6)", {}};
    s.blocks.push_back(Text{
        "Fig. 6.8: every contact between discs of different bodies in a clogged configuration, by the size of the two "
        "discs: in a body of two discs the smaller one is small and the larger large (two equal discs: the one with the "
        "lower id is small, the thesis' random choice made repeatable, so symmetric dumbbells give about 1/4, 1/2, "
        "1/4); a contact of a single disc or a rod's disc is `other`. Fractions of all contacts per clog, mean ± se over "
        "clogs; a system of lone discs has no size classes (blank)."});
    Table t{"contacts",
            "Contact types in the clogged systems (fractions)",
            {"point", "small-small", "large-small", "large-large", "other"},
            {},
            {"point", "contact_ss", "contact_ls", "contact_ll", "contact_other"}};
    for (std::size_t p = 0; p < v.points.size(); ++p) {
      if (!FindMetric(in.points[p], "contact_ss")) continue;
      std::vector<Cell> row = {PointName(v, v.points[p])};
      for (const char* name : kNames) row.push_back(Cell::Estimate(FindMetric(in.points[p], name)->Estimate()));
      t.rows.push_back(row);
    }
    s.blocks.push_back(t);
    if (HasX(v)) {
      Figure f{"contact_types",
               "Contact types in the clogged system against " + v.x_label,
               v.x_label,
               "fraction of contacts",
               {},
               false,
               false,
               "Error bars: standard error over clogs"};
      const std::pair<const char*, const char*> kinds[] = {
          {"contact_ss", "s-s"}, {"contact_ls", "l-s"}, {"contact_ll", "l-l"}};
      for (const auto& [name, label] : kinds)
        for (Series se : PointSeries(v, in.points, name, label)) {
          se.label = std::string(label) + (se.label == label ? "" : ", " + se.label);
          f.series.push_back(se);
        }
      if (!f.series.empty()) s.blocks.push_back(f);
    }
    return s;
  }
};

}  // namespace

nlohmann::json ContactsRunResult(const rundir::RunData& run) {
  nlohmann::json result = {{"present", false}, {"clogs", nlohmann::json::array()}, {"notes", nlohmann::json::array()}};
  try {
    rundir::ClogReader reader(run.dir);
    result["present"] = reader.Present();
    rundir::ClogState clog;
    while (reader.Next(clog)) {
      const ContactTypes t = CountContactTypes(clog.frame, clog.contacts);
      result["clogs"].push_back({{"timestep", clog.frame.timestep},
                                 {"time", clog.frame.time},
                                 {"small_small", t.small_small},
                                 {"large_small", t.large_small},
                                 {"large_large", t.large_large},
                                 {"other", t.other}});
    }
  } catch (const std::exception& e) {
    result["clogs"] = nlohmann::json::array();
    result["notes"].push_back(std::string("contacts: ") + e.what());
  }
  return result;
}

std::unique_ptr<Analysis> MakeContactsAnalysis(const nlohmann::json& options, const std::string& path) {
  if (!options.is_null()) OptionObject(options, path, {});
  return std::make_unique<ContactsAnalysis>();
}

}  // namespace granary::analysis

// The reproduction table: values a campaign spec expects (/expect), each with its source, beside
// what the campaign measured. An expectation names a metric (or an expression over metrics and
// axes, as a figure's y) at a point of the sweep, or a parameter of a figure's fit, with a value
// and a tolerance: "does it reproduce the paper?" becomes one table. Pure.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "analysis/export.h"
#include "analysis/figures.h"

namespace granary::analysis {

struct Expectation {
  std::string path;                                        // "/expect/2"
  std::string metric;                                      // a metric or expression; "" for a fitted parameter
  std::string fit, parameter;                              // a figure of /report/figures and its fit's parameter
  std::vector<std::pair<std::string, nlohmann::json>> at;  // axis -> value (all must hold)
  double value = kNaN;
  double tolerance = 0.0;  // absolute
  std::string source;      // "thesis fig. 3.3a"
  int min_runs = 2;        // fewer finished runs at the point: not enough runs
};

// Reads /expect of a campaign spec (absent: none); `figures` are its /report/figures, which a
// fitted parameter must name. Errors are OptionErrors naming the JSON path.
std::vector<Expectation> ReadExpectations(const nlohmann::json& campaign_spec, const std::vector<FigureSpec>& figures);

// kNotComparable: the campaign's /size is "quick" or "medium" (a smaller system than the
// thesis'): what it measured is shown, but not judged against the thesis' number.
enum class Verdict { kAgrees, kDisagrees, kNotEnough, kNotComparable };
// "agrees", "disagrees", "not enough runs", "not comparable at this size".
std::string ToString(Verdict verdict);

// The campaign spec's /size ("quick", "medium", "full"; "" when it does not say), and whether
// its expectations are judged at that size (full, or not said).
std::string CampaignSize(const nlohmann::json& campaign_spec);
bool JudgedAtSize(const std::string& size);

// Every name a figure's y (/report/figures/i/y), an expectation's metric (/expect/i/metric) and
// an adaptive-replica target (/replicas/until/i/metric) uses must be an axis of the spec or a
// metric of an analysis the spec turns on (registry.h, AnalysisEntry::metrics). Throws
// OptionError naming the JSON path, the name and what the spec offers; a metric of an analysis
// the spec leaves off (fields) says how to turn it on. Names are not checked when the spec has
// Python analyses (their metrics are known only when their scripts run) or an analysis whose
// registry row lists no metrics.
void CheckMetricReferences(const nlohmann::json& campaign_spec);

struct ExpectationResult {
  const Expectation* expectation = nullptr;
  std::string what;  // "psi at W = 11", "b of fig-5.2"
  double measured = kNaN, se = kNaN;
  int n = 0;     // the measurement's n (replicas, pooled items, fit points)
  int runs = 0;  // finished runs behind it
  Verdict verdict = Verdict::kNotEnough;
  std::string why;  // "|0.61 - 0.66| = 0.05 <= 0.15 + 2 se", "1 run, needs 2"
};

// Judges every expectation: agrees when |measured - value| <= tolerance + 2 se, disagrees
// otherwise; not enough runs when the point has fewer than min_runs finished runs, nothing was
// measured, or a fit is not good (fit.h). `figures` are the made figures (their fits).
std::vector<ExpectationResult> JudgeExpectations(const CampaignAnalysis& analysis,
                                                 const std::vector<Expectation>& expectations,
                                                 const std::vector<FigureOutcome>& figures);

// A campaign's figures of /report/figures and its judged /expect, made together (an
// expectation may name a figure's fit); the pointers inside point into this object.
struct Reproduction {
  std::vector<FigureSpec> figure_specs;
  std::vector<FigureOutcome> figures;
  std::vector<Expectation> expectations;
  std::vector<ExpectationResult> results;
};
// Throws OptionError for a bad /report/figures or /expect.
std::unique_ptr<Reproduction> Reproduce(const CampaignAnalysis& analysis);

struct ExpectationCounts {
  int agree = 0, disagree = 0, not_yet = 0, not_comparable = 0;
};
ExpectationCounts Count(const std::vector<ExpectationResult>& results);
// "7 agree, 1 disagrees, 3 not yet", and ", 4 not comparable at this size" when there are any.
std::string ToString(const ExpectationCounts& counts);

// The table of `campaign export --expectations` and of the report's Key results.
ExportTable ExpectationsTable(const std::vector<ExpectationResult>& results);
// JSON Schemas (draft-07) of the campaign spec's /axes, /report/figures and /expect, for
// `campaign schema`.
nlohmann::json AxesJsonSchema();
nlohmann::json FiguresJsonSchema();
nlohmann::json ExpectJsonSchema();

// "Key results": the reproduction table first in the report; nullopt without expectations.
std::optional<Section> KeyResultsSection(const std::vector<ExpectationResult>& results);

}  // namespace granary::analysis

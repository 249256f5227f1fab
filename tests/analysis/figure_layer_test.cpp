// The figure layer, derived axes and the reproduction table on a constructed campaign with two
// axes and known flow rates Q(W, mu) = a W^(b + mu/2) (point means within 1 % of it, replicas
// at -+1 % of their mean), and every
// data point of every figure the report writes inside its figure's ranges (.gp files read back).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <regex>
#include <sstream>

#include "analysis/expectations.h"
#include "analysis/export.h"
#include "analysis/figures.h"
#include "analysis/fit.h"
#include "analysis/options.h"
#include "analysis/registry.h"
#include "analysis/report.h"
#include "stored_campaign.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

namespace fs = std::filesystem;
using testing::read_file;
using testing::TempDir;
using testing::write_file;

constexpr double kA = 0.3, kB = 1.5;
double q_of(double w, double mu) { return kA * std::pow(w, kB + mu / 2); }
// Each point's mean off the law by up to 1 % (its replicas at -+1 % of that): data a fit does
// not meet exactly, so that its intervals mean something.
double off(double w, double mu) { return 1 + 0.01 * std::sin(3 * w + 7 * mu); }

nlohmann::json spec_for(double w, double mu) {
  return {{"engine", "native"},
          {"silo", {{"width", 100}, {"base_outlets", {{{"center", 0.0}, {"width", w}}}}}},
          {"bodies", {{"count", 2000}, {"density", 1.0}}},
          {"contact", {{"tangential_cap", "lammps"}, {"mu", mu}}},
          {"discharge", {{"mode", "remove"}, {"clog_window", 5.0}}}};
}

// A run of n exits at the constant rate q.
void write_run(const fs::path& dir, const nlohmann::json& spec, double q, int n, const std::string& id) {
  std::ostringstream ev;
  ev.precision(17);
  ev << "time,body,shape,mass,outlet\n";
  for (int i = 1; i <= n; ++i) ev << (i / q) << "," << i << ",disc,1.0,0\n";
  write_file(dir / "events.csv", ev.str());
  const nlohmann::json summary = {{"engine", "native"}, {"engine_version", "0.1.0"}, {"granary_commit", "abc"},
                                  {"run_id", id},       {"spec", spec},              {"end_reason", "time_limit"},
                                  {"bodies", 2000},     {"exited", n},               {"remaining", 2000 - n},
                                  {"exits_per_outlet", {n}}, {"t_end", n / q + 1.0}};
  write_file(dir / "summary.json", summary.dump());
  write_file(dir / "run.json", spec.dump());
  write_file(dir / "DONE", "");
}

struct Campaign {
  CampaignInfo info;
  std::vector<RunRecord> runs;
};

// W in {10, 14, 18, 22} x mu in {0, 0.5, 1}, two replicas each; and W = 26, mu = 0 with one.
Campaign make_campaign(const fs::path& root, const nlohmann::json& extra_spec) {
  Campaign c;
  c.info.name = "two-axes";
  c.info.axes = {"/silo/base_outlets/0/width", "/contact/mu"};
  c.info.spec = {{"name", "two-axes"},
                 {"base", spec_for(10, 0)},
                 {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {10, 14, 18, 22}}, {"/contact/mu", {0, 0.5, 1}}}}}}};
  c.info.spec.update(extra_spec);
  auto add = [&](double w, double mu, int replicas) {
    for (int rep = 0; rep < replicas; ++rep) {
      RunRecord r;
      r.point_id = "W" + format_number(w) + "mu" + format_number(mu);
      r.run_id = r.point_id + "r" + std::to_string(rep);
      r.replica = rep;
      r.engine = "native";
      r.state = "done";
      r.point = {{"/silo/base_outlets/0/width", w}, {"/contact/mu", mu}};
      r.spec = spec_for(w, mu);
      r.run_dir = root / r.run_id;
      const double q = q_of(w, mu) * off(w, mu) * (replicas == 1 ? 1.0 : rep == 0 ? 0.99 : 1.01);
      write_run(r.run_dir, r.spec, q, 400, r.run_id);
      c.runs.push_back(r);
    }
  };
  for (double w : {10.0, 14.0, 18.0, 22.0})
    for (double mu : {0.0, 0.5, 1.0}) add(w, mu, 2);
  add(26, 0, 1);
  return c;
}

std::unique_ptr<CampaignAnalysis> analyse(const Campaign& c, const AnalysisSetup& setup) {
  CampaignAnalysisOptions o;
  o.read_cache = o.write_cache = false;
  return analyse_campaign(c.info, c.runs, setup, o);
}

// Every point a .gp script draws (points, error bars) that lies outside its xrange/yrange:
// "file.gp: data/x.csv row 3: (5.75, 2) outside [5.8:10.2] x [0:3]".
std::vector<std::string> points_outside_ranges(const fs::path& report) {
  std::vector<std::string> out;
  const std::regex range(R"(set ([xy])range \[([^:\]]+):([^\]]+)\])");
  const std::regex item(R"('([^']+)' skip 1 using \(\$(\d+)([^)]*)\):\(\$(\d+)\)[^\n]*? with (\w+))");
  if (!fs::exists(report / "figures")) return out;
  for (const auto& entry : fs::directory_iterator(report / "figures")) {
    if (entry.path().extension() != ".gp") continue;
    const std::string gp = read_file(entry.path());
    if (gp.find("set logscale") != std::string::npos || gp.find("multiplot") != std::string::npos) continue;
    double lo[2] = {-INFINITY, -INFINITY}, hi[2] = {INFINITY, INFINITY};
    for (std::sregex_iterator it(gp.begin(), gp.end(), range), end; it != end; ++it) {
      const int k = (*it)[1] == "x" ? 0 : 1;
      lo[k] = std::stod((*it)[2]);
      hi[k] = std::stod((*it)[3]);
    }
    for (std::sregex_iterator it(gp.begin(), gp.end(), item), end; it != end; ++it) {
      const std::string with = (*it)[5];
      if (with == "lines" || with == "histeps" || with == "image") continue;
      const std::string file = (*it)[1];
      const int xc = std::stoi((*it)[2]), yc = std::stoi((*it)[4]);
      const std::string shift = (*it)[3];  // "+-0.25" or "*1.02" in scripts that move points
      std::istringstream csv(read_file(report / file));
      std::string line;
      std::getline(csv, line);
      for (int row = 1; std::getline(csv, line); ++row) {
        std::vector<double> cells;
        std::stringstream ls(line);
        std::string cell;
        while (std::getline(ls, cell, ',')) cells.push_back(cell == "nan" || cell.empty() ? NAN : std::stod(cell));
        if (static_cast<int>(cells.size()) < std::max(xc, yc)) continue;
        double x = cells[xc - 1];
        const double y = cells[yc - 1];
        if (!std::isfinite(x) || !std::isfinite(y)) continue;
        if (!shift.empty()) x = shift[0] == '*' ? x * std::stod(shift.substr(1)) : x + std::stod(shift.substr(1));
        if (x < lo[0] || x > hi[0] || y < lo[1] || y > hi[1])
          out.push_back(entry.path().filename().string() + ": " + file + " row " + std::to_string(row) + ": (" +
                        format_number(x) + ", " + format_number(y) + ") outside [" + format_number(lo[0]) + ":" +
                        format_number(hi[0]) + "] x [" + format_number(lo[1]) + ":" + format_number(hi[1]) + "]");
      }
    }
  }
  return out;
}

TEST(FitModelMulti, TwoVariablesRecoverKnownParametersWithinTheirIntervals) {
  // Q = a W^(b + X/2) / (1.43 + 17 X^2) (thesis ch. 5) with 2 % noise of known sigma.
  const double a = 0.9, b = 1.4;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<std::vector<double>> points;
  std::vector<double> y, sigma;
  for (double w : {8.0, 12.0, 16.0, 20.0, 24.0, 28.0})
    for (double x : {0.0, 0.25, 0.5, 0.75, 1.0}) {
      const double truth = a * std::pow(w, b + x / 2) / (1.43 + 17 * x * x);
      points.push_back({w, x});
      sigma.push_back(0.02 * truth);
      y.push_back(truth * (1 + 0.02 * noise(rng)));
    }
  const FitResult r = fit_model_multi("ch5", "a * W^(b + X/2) / (1.43 + 17 * X^2)", {"W", "X"}, points, y, sigma);
  ASSERT_EQ(r.quality, FitQuality::kGood) << r.verdict();
  const FitParameter* pa = r.parameter("a");
  const FitParameter* pb = r.parameter("b");
  ASSERT_TRUE(pa && pb);
  EXPECT_LE(pa->ci_low, a);
  EXPECT_GE(pa->ci_high, a);
  EXPECT_LE(pb->ci_low, b);
  EXPECT_GE(pb->ci_high, b);
  // The intervals are narrow enough to mean something.
  EXPECT_LT(pa->ci_high - pa->ci_low, 0.1 * a);
  EXPECT_LT(pb->ci_high - pb->ci_low, 0.05 * b);
  EXPECT_EQ(r.variables, (std::vector<std::string>{"W", "X"}));
  const double at[2] = {10.0, 0.5};
  EXPECT_NEAR(r.evaluate_at(at), pa->value * std::pow(10.0, pb->value + 0.25) / (1.43 + 17 * 0.25), 1e-12);
}

TEST(FigureLayer, FitAcrossEveryPointOfTheFigureAndCollapse) {
  TempDir dir;
  const nlohmann::json figures = {{"report",
                                   {{"figures",
                                     {{{"name", "law"},
                                       {"y", "q_count"},
                                       {"x", "W"},
                                       {"group", "mu"},
                                       {"only", {{"mu", {0, 0.5, 1}}}},
                                       {"fit", {{"model", "a * W^(b + mu/2)"}, {"initial", {{"a", 0.5}, {"b", 1}}}, {"collapse", true}}},
                                       {"reference", "thesis fig. 4.5b"}}}}}}};
  const Campaign c = make_campaign(dir.path(), figures);
  const auto a = analyse(c, setup_analyses(c.info.spec));
  const std::vector<FigureSpec> specs = read_figure_specs(c.info.spec);
  ASSERT_EQ(specs.size(), 1u);
  const FigureOutcome f = make_figure(*a, specs[0]);
  ASSERT_EQ(f.data.size(), 13u);  // 12 points, and W = 26 (one replica, no se): still a point
  ASSERT_TRUE(f.fit.has_value());
  EXPECT_EQ(f.fit->variables, (std::vector<std::string>{"W", "mu"}));
  ASSERT_EQ(f.fit->quality, FitQuality::kGood) << f.fit->verdict();
  for (const auto& [name, truth] : {std::pair{"a", kA}, std::pair{"b", kB}}) {
    const FitParameter* p = f.fit->parameter(name);
    ASSERT_TRUE(p);
    EXPECT_LE(p->ci_low, truth) << name;
    EXPECT_GE(p->ci_high, truth) << name;
    EXPECT_NEAR(p->value, truth, 0.02 * truth) << name;
    EXPECT_LT(p->ci_high - p->ci_low, 0.2 * truth) << name;  // a and b are correlated: a is the looser
  }
  // Three groups of data, one fit curve each, and the collapse on 1.
  int data = 0, curves = 0;
  const Figure* collapse = nullptr;
  for (const Block& b : f.blocks)
    if (const auto* fig = std::get_if<Figure>(&b)) {
      if (fig->name == "figure-law-collapse") collapse = fig;
      if (fig->name != "figure-law") continue;
      for (const Series& s : fig->series) (s.role == Series::Role::kFit ? curves : data) += 1;
      EXPECT_NE(fig->caption.find("thesis fig. 4.5b"), std::string::npos) << fig->caption;
    }
  EXPECT_EQ(data, 3);
  EXPECT_EQ(curves, 3);
  ASSERT_TRUE(collapse);
  for (const Series& s : collapse->series) {
    if (s.role != Series::Role::kData) continue;
    for (const auto& row : s.rows) EXPECT_NEAR(row[1], 1.0, 0.03) << s.label;
  }
}

TEST(FigureLayer, PooledFigureWeighsThePointsByTheirN) {
  TempDir dir;
  const nlohmann::json figures = {{"report", {{"figures", {{{"name", "pooled"}, {"y", "q_count"}, {"x", "W"}, {"pool", {"mu"}}}}}}}};
  const Campaign c = make_campaign(dir.path(), figures);
  const auto a = analyse(c, setup_analyses(c.info.spec));
  const FigureOutcome f = make_figure(*a, read_figure_specs(c.info.spec)[0]);
  ASSERT_EQ(f.data.size(), 5u);  // one per W: mu pooled
  for (const FigureDatum& d : f.data) {
    EXPECT_EQ(d.group, "");
    if (d.x == 26) {
      EXPECT_EQ(d.points.size(), 1u);
      continue;
    }
    ASSERT_EQ(d.points.size(), 3u);
    EXPECT_EQ(d.n, 6);
    // Two replicas at every mu: the pooled mean is the mean of the three Q.
    const double expected = (q_of(d.x, 0) * off(d.x, 0) + q_of(d.x, 0.5) * off(d.x, 0.5) + q_of(d.x, 1) * off(d.x, 1)) / 3;
    EXPECT_NEAR(d.y, expected, 1e-6 * expected) << d.x;
    EXPECT_FALSE(d.axes.count("mu"));
  }
}

TEST(FigureLayer, DerivedAxesInFiguresExportAndOnly) {
  TempDir dir;
  const nlohmann::json extra = {{"axes", {{"W2", "2 * W"}, {"Wmu", "W2 + mu"}}},
                                {"report",
                                 {{"figures",
                                   {{{"name", "derived"},
                                     {"y", "q_count / W^1.5"},
                                     {"x", "W2"},
                                     {"group", "mu"},
                                     {"only", {{"Wmu", {20, 28.5}}}}}}}}}};
  const Campaign c = make_campaign(dir.path(), extra);
  const auto a = analyse(c, setup_analyses(c.info.spec));
  const FigureOutcome f = make_figure(*a, read_figure_specs(c.info.spec)[0]);
  // Wmu = 20: W = 10, mu = 0; Wmu = 28.5: W = 14, mu = 0.5.
  ASSERT_EQ(f.data.size(), 2u);
  for (const FigureDatum& d : f.data) {
    const double w = d.x / 2, mu = d.axes.at("mu");
    EXPECT_TRUE((w == 10 && mu == 0) || (w == 14 && mu == 0.5)) << w << " " << mu;
    EXPECT_NEAR(d.y, q_of(w, mu) * off(w, mu) / std::pow(w, 1.5), 1e-6);
    EXPECT_GT(d.se, 0.0);  // propagated from q_count's se
  }
  // The export: the axes by their short names, then the derived axes.
  const ExportTable t = export_table(*a, ExportLevel::kPoint);
  ASSERT_GE(t.columns.size(), 7u);
  EXPECT_EQ(std::vector<std::string>(t.columns.begin() + 3, t.columns.begin() + 7),
            (std::vector<std::string>{"W", "mu", "W2", "Wmu"}));
  for (const auto& row : t.rows) EXPECT_DOUBLE_EQ(row[6].get<double>(), 2 * row[3].get<double>() + row[4].get<double>());
}

TEST(FigureLayer, OptionErrorsNameThePathTheValueAndWhatIsAllowed) {
  const nlohmann::json base = {{"name", "t"}, {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {4, 6}}}}}}};
  auto error_of = [&](const nlohmann::json& extra) -> std::string {
    nlohmann::json spec = base;
    spec.update(extra);
    try {
      check_report_spec(spec);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error_of({{"report", {{"figures", {{{"name", "f"}, {"y", "q_count"}, {"x", "D_b"}}}}}}})
                .find("/report/figures/0/x: names no axis (axes: W)"),
            std::string::npos);
  EXPECT_NE(error_of({{"axes", {{"D", "sqrt(W + Z)"}}}}).find("/axes/D"), std::string::npos);
  EXPECT_NE(error_of({{"axes", {{"D", "sqrt(W + Z)"}}}}).find("names no axis: Z (axes it can use: W)"), std::string::npos);
  EXPECT_NE(error_of({{"report", {{"figures", {{{"name", "f"}, {"y", "q"}, {"kind", "bars"}}}}}}})
                .find("/report/figures/0/kind"),
            std::string::npos);
  EXPECT_NE(error_of({{"expect", {{{"fit", "nope"}, {"parameter", "b"}, {"value", 1}}}}}).find("/expect/0/fit"),
            std::string::npos);
  EXPECT_NE(error_of({{"expect", {{{"metric", "psi"}, {"at", {{"H", 3}}}, {"value", 1}}}}}).find("/expect/0/at/H: names no axis"),
            std::string::npos);
  EXPECT_EQ(error_of({{"axes", {{"W2", "2 * W"}}},
                      {"report", {{"figures", {{{"name", "f"}, {"y", "q_count"}, {"x", "W2"}}}}}},
                      {"expect", {{{"metric", "q_count"}, {"at", {{"W2", 8}}}, {"value", 1}, {"source", "s"}}}}}),
            "");
}

TEST(FigureLayer, PicturesOfTheChosenPoints) {
  TempDir dir;
  const nlohmann::json extra = {
      {"report", {{"figures", {{{"name", "arches"}, {"kind", "pictures"}, {"only", {{"W", {10, 22}}, {"mu", 0.5}}},
                                {"reference", "thesis fig. 3.4"}}}}}}};
  const Campaign c = make_campaign(dir.path() / "runs", extra);
  ReportOptions o;
  o.out_dir = dir.path() / "report";
  o.figures = false;
  o.analysis.read_cache = o.analysis.write_cache = false;
  std::vector<std::string> drawn;
  o.draw_run = [&](const fs::path& run_dir, ReportOptions::Picture kind, const fs::path& png) {
    drawn.push_back(run_dir.filename().string() + (kind == ReportOptions::Picture::kBed ? ":bed" : ":end") + ":" +
                    png.filename().string());
    write_file(png, "\x89PNG fake");
    return std::string();
  };
  const ReportSummary s = write_report(c.info, c.runs, o);
  // The figure's two points (their first replica's end), then the gallery's bed and end of all 13.
  ASSERT_GE(drawn.size(), 2u);
  EXPECT_EQ(drawn[0], "W10mu0.5r0:end:figure-arches-6-end.png");
  EXPECT_EQ(drawn[1], "W22mu0.5r0:end:figure-arches-9-end.png");
  EXPECT_EQ(drawn.size(), 2u + 2 * 13);
  const std::string md = read_file(s.markdown);
  EXPECT_LT(md.find("figure-arches-6-end.png"), md.find("## Gallery"));
  EXPECT_NE(md.find("Reference: thesis fig. 3.4"), std::string::npos);
  nlohmann::json bad = c.info.spec;
  bad["report"]["figures"][0]["y"] = "q_count";
  EXPECT_THROW(read_figure_specs(bad), OptionError);
}

TEST(Expectations, AgreeDisagreeAndTooFewRuns) {
  TempDir dir;
  const double q14 = q_of(14, 0), q26 = q_of(26, 0);
  const nlohmann::json extra = {
      {"report", {{"figures", {{{"name", "law"}, {"y", "q_count"}, {"x", "W"}, {"fit", {{"model", "a * W^(b + mu/2)"}}}}}}}},
      {"expect",
       {{{"metric", "q_count"}, {"at", {{"W", 14}, {"mu", 0}}}, {"value", q14 * 1.02}, {"tolerance", 0.03 * q14}, {"source", "s1"}},
        {{"metric", "q_count"}, {"at", {{"W", 14}, {"mu", 0}}}, {"value", q14 * 1.5}, {"tolerance", 0.03 * q14}, {"source", "s2"}},
        {{"metric", "q_count"}, {"at", {{"W", 26}, {"mu", 0}}}, {"value", q26}, {"source", "s3"}},
        {{"fit", "law"}, {"parameter", "b"}, {"value", 1.5}, {"tolerance", 0.01}, {"source", "s4"}}}}};
  const Campaign c = make_campaign(dir.path(), extra);
  const auto a = analyse(c, setup_analyses(c.info.spec));
  const std::vector<FigureSpec> specs = read_figure_specs(c.info.spec);
  std::vector<FigureOutcome> figures;
  for (const auto& s : specs) figures.push_back(make_figure(*a, s));
  const std::vector<Expectation> expect = read_expectations(c.info.spec, specs);
  const std::vector<ExpectationResult> r = judge_expectations(*a, expect, figures);
  ASSERT_EQ(r.size(), 4u);
  EXPECT_EQ(r[0].verdict, Verdict::kAgrees) << r[0].why;
  EXPECT_NEAR(r[0].measured, q14 * off(14, 0), 1e-6 * q14);
  EXPECT_EQ(r[0].runs, 2);
  EXPECT_EQ(r[1].verdict, Verdict::kDisagrees) << r[1].why;
  EXPECT_EQ(r[2].verdict, Verdict::kNotEnough) << r[2].why;
  EXPECT_EQ(r[2].why, "1 finished run, needs 2");
  EXPECT_EQ(r[3].verdict, Verdict::kAgrees) << r[3].why;
  EXPECT_EQ(to_string(count(r)), "2 agree, 1 disagrees, 1 not yet");
  const ExportTable t = expectations_table(r);
  EXPECT_EQ(t.rows.size(), 4u);
  EXPECT_EQ(t.rows[1][8], "disagrees");
  EXPECT_NE(to_csv(t).find("q_count at W = 14, mu = 0"), std::string::npos) << to_csv(t);
}

TEST(Expectations, QuickAndMediumSizesAreMeasuredButNotComparable) {
  TempDir dir;
  const double q14 = q_of(14, 0);
  for (const std::string size : {"quick", "medium", "full"}) {
    const nlohmann::json extra = {
        {"size", size},
        {"expect",
         {{{"metric", "q_count"}, {"at", {{"W", 14}, {"mu", 0}}}, {"value", q14}, {"tolerance", 0.03 * q14}, {"source", "s1"}},
          {{"metric", "q_count"}, {"at", {{"W", 14}, {"mu", 0}}}, {"value", q14 * 1.5}, {"tolerance", 0.03 * q14}, {"source", "s2"}}}}};
    const Campaign c = make_campaign(dir.path() / size, extra);
    const auto a = analyse(c, setup_analyses(c.info.spec));
    const std::vector<Expectation> expect = read_expectations(c.info.spec, {});
    const std::vector<ExpectationResult> r = judge_expectations(*a, expect, {});
    ASSERT_EQ(r.size(), 2u);
    EXPECT_NEAR(r[0].measured, q14 * off(14, 0), 1e-6 * q14) << size;  // measured at every size
    if (size == "full") {
      EXPECT_EQ(r[0].verdict, Verdict::kAgrees) << r[0].why;
      EXPECT_EQ(r[1].verdict, Verdict::kDisagrees) << r[1].why;
      EXPECT_EQ(to_string(count(r)), "1 agree, 1 disagrees, 0 not yet");
      continue;
    }
    for (const ExpectationResult& x : r) {
      EXPECT_EQ(x.verdict, Verdict::kNotComparable) << size;
      EXPECT_EQ(x.why.rfind("a " + size + " campaign (/size): judged at full size only; |", 0), 0u) << x.why;
    }
    EXPECT_EQ(to_string(count(r)), "0 agree, 0 disagree, 0 not yet, 2 not comparable at this size");
    EXPECT_EQ(expectations_table(r).rows[1][8], "not comparable at this size");
    const std::optional<Section> key = key_results_section(r);
    ASSERT_TRUE(key.has_value());
    const Table& t = std::get<Table>(key->blocks[1]);
    EXPECT_EQ(t.rows[0][5].text, "not comparable at this size");
  }
}

TEST(ReportFigures, EveryDataPointLiesInsideItsFigureRanges) {
  TempDir dir;
  const nlohmann::json extra = {
      {"report", {{"figures", {{{"name", "law"}, {"y", "q_count"}, {"x", "W"}, {"fit", {{"model", "a * W^(b + mu/2)"}, {"collapse", true}}}}}}}},
      {"expect", {{{"metric", "q_count"}, {"at", {{"W", 14}, {"mu", 0}}}, {"value", q_of(14, 0)}, {"source", "s"}}}}};
  const Campaign c = make_campaign(dir.path() / "runs", extra);
  ReportOptions o;
  o.out_dir = dir.path() / "report";
  o.analysis.read_cache = o.analysis.write_cache = false;
  const ReportSummary s = write_report(c.info, c.runs, o);
  int scripts = 0;
  for (const auto& e : fs::directory_iterator(o.out_dir / "figures")) scripts += e.path().extension() == ".gp";
  EXPECT_GE(scripts, 5);
  const std::vector<std::string> outside = points_outside_ranges(o.out_dir);
  EXPECT_TRUE(outside.empty()) << outside.size() << " points outside, e.g. " << outside.front();
  // Key results first, then the figures; the system after them; the gallery last.
  const std::string md = read_file(s.markdown);
  const auto key = md.find("## Key results"), figures = md.find("## Figures"), system = md.find("## The system"),
             gallery = md.find("## Gallery");
  ASSERT_NE(key, std::string::npos);
  EXPECT_LT(key, figures);
  EXPECT_LT(figures, system);
  EXPECT_LT(system, gallery);
  EXPECT_NE(md.find("1 agree, 0 disagree, 0 not yet"), std::string::npos);
  // Data drawn at their true x: no script shifts a coordinate.
  for (const auto& e : fs::directory_iterator(o.out_dir / "figures")) {
    if (e.path().extension() != ".gp") continue;
    EXPECT_EQ(read_file(e.path()).find("using ($1+"), std::string::npos) << e.path();
  }
}

// The same on the reports of the stored native-engine campaigns (tests/data/regression:
// remove mode with clogs, two base outlets, a lateral outlet): real runs, every figure.
TEST(ReportFigures, EveryDataPointOfTheStoredEngineCampaignsLiesInsideItsRanges) {
  for (const char* name : {"remove", "two-outlets", "lateral"}) {
    const fs::path dir = fs::path(GRANARY_SOURCE_DIR) / "tests" / "data" / "regression" / name;
    const testing::StoredCampaign stored = testing::load(dir);
    TempDir out;
    ReportOptions o;
    o.out_dir = out.path();
    o.analysis.write_cache = false;  // the stored runs stay as they are
    write_report(stored.info, stored.runs, o);
    int scripts = 0;
    for (const auto& e : fs::directory_iterator(out.path() / "figures")) scripts += e.path().extension() == ".gp";
    EXPECT_GE(scripts, 3) << name;
    const std::vector<std::string> outside = points_outside_ranges(out.path());
    EXPECT_TRUE(outside.empty()) << name << ": " << outside.size() << " points outside, e.g. " << outside.front();
  }
}

}  // namespace
}  // namespace granary::analysis

// The figure layer, derived axes and the reproduction table on a constructed campaign with two
// axes and known flow rates Q(W, mu) = a W^(b + mu/2) (point means within 1 % of it, replicas
// at -+1 % of their mean); the figures at chosen points (distribution, maps, profile) of a
// distribution and a field of known values; and every data point and map node of every figure
// the report writes inside its figure's ranges (.gp files read back).
#include <gtest/gtest.h>

#include <array>
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
using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;

constexpr double kA = 0.3, kB = 1.5;
double QOf(double w, double mu) { return kA * std::pow(w, kB + mu / 2); }
// Each point's mean off the law by up to 1 % (its replicas at -+1 % of that): data a fit does
// not meet exactly, so that its intervals mean something.
double Off(double w, double mu) { return 1 + 0.01 * std::sin(3 * w + 7 * mu); }

nlohmann::json SpecFor(double w, double mu) {
  return {{"engine", "native"},
          {"silo", {{"width", 100}, {"base_outlets", {{{"center", 0.0}, {"width", w}}}}}},
          {"bodies", {{"count", 2000}, {"density", 1.0}}},
          {"contact", {{"tangential_cap", "lammps"}, {"mu", mu}}},
          {"discharge", {{"mode", "remove"}, {"clog_window", 5.0}}}};
}

// A run of n exits at the constant rate q.
void WriteRun(const fs::path& dir, const nlohmann::json& spec, double q, int n, const std::string& id) {
  std::ostringstream ev;
  ev.precision(17);
  ev << "time,body,shape,mass,outlet\n";
  for (int i = 1; i <= n; ++i) ev << (i / q) << "," << i << ",disc,1.0,0\n";
  WriteFile(dir / "events.csv", ev.str());
  const nlohmann::json summary = {
      {"engine", "native"},    {"engine_version", "0.1.0"},  {"granary_commit", "abc"}, {"run_id", id},
      {"spec", spec},          {"end_reason", "time_limit"}, {"bodies", 2000},          {"exited", n},
      {"remaining", 2000 - n}, {"exits_per_outlet", {n}},    {"t_end", n / q + 1.0}};
  WriteFile(dir / "summary.json", summary.dump());
  WriteFile(dir / "run.json", spec.dump());
  WriteFile(dir / "DONE", "");
}

struct Campaign {
  CampaignInfo info;
  std::vector<RunRecord> runs;
};

// W in {10, 14, 18, 22} x mu in {0, 0.5, 1}, two replicas each; and W = 26, mu = 0 with one.
Campaign MakeCampaign(const fs::path& root, const nlohmann::json& extra_spec) {
  Campaign c;
  c.info.name = "two-axes";
  c.info.axes = {"/silo/base_outlets/0/width", "/contact/mu"};
  c.info.spec = {
      {"name", "two-axes"},
      {"base", SpecFor(10, 0)},
      {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {10, 14, 18, 22}}, {"/contact/mu", {0, 0.5, 1}}}}}}};
  c.info.spec.update(extra_spec);
  auto add = [&](double w, double mu, int replicas) {
    for (int rep = 0; rep < replicas; ++rep) {
      RunRecord r;
      r.point_id = "W" + FormatNumber(w) + "mu" + FormatNumber(mu);
      r.run_id = r.point_id + "r" + std::to_string(rep);
      r.replica = rep;
      r.engine = "native";
      r.state = "done";
      r.point = {{"/silo/base_outlets/0/width", w}, {"/contact/mu", mu}};
      r.spec = SpecFor(w, mu);
      r.run_dir = root / r.run_id;
      const double q = QOf(w, mu) * Off(w, mu) * (replicas == 1 ? 1.0 : rep == 0 ? 0.99 : 1.01);
      WriteRun(r.run_dir, r.spec, q, 400, r.run_id);
      c.runs.push_back(r);
    }
  };
  for (double w : {10.0, 14.0, 18.0, 22.0})
    for (double mu : {0.0, 0.5, 1.0}) add(w, mu, 2);
  add(26, 0, 1);
  return c;
}

std::unique_ptr<CampaignAnalysis> Analyse(const Campaign& c, const AnalysisSetup& setup) {
  CampaignAnalysisOptions o;
  o.read_cache = o.write_cache = false;
  return AnalyseCampaign(c.info, c.runs, setup, o);
}

// The rows of a numeric CSV after its header ("nan" and empty cells NaN).
std::vector<std::vector<double>> CsvRows(const fs::path& file) {
  std::vector<std::vector<double>> rows;
  std::istringstream csv(ReadFile(file));
  std::string line;
  std::getline(csv, line);
  while (std::getline(csv, line)) {
    std::vector<double> cells;
    std::stringstream ls(line);
    std::string cell;
    while (std::getline(ls, cell, ',')) cells.push_back(cell == "nan" || cell.empty() ? NAN : std::stod(cell));
    rows.push_back(cells);
  }
  return rows;
}

// Every point a .gp script draws (points, error bars) that lies outside its xrange/yrange:
// "file.gp: data/x.csv row 3: (5.75, 2) outside [5.8:10.2] x [0:3]".
std::vector<std::string> PointsOutsideRanges(const fs::path& report) {
  std::vector<std::string> out;
  const std::regex range(R"(set ([xy])range \[([^:\]]+):([^\]]+)\])");
  const std::regex item(R"('([^']+)' skip 1 using \(\$(\d+)([^)]*)\):\(\$(\d+)\)[^\n]*? with (\w+))");
  if (!fs::exists(report / "figures")) return out;
  for (const auto& entry : fs::directory_iterator(report / "figures")) {
    if (entry.path().extension() != ".gp") continue;
    const std::string gp = ReadFile(entry.path());
    if (gp.find("set logscale") != std::string::npos) continue;
    double lo[2] = {-INFINITY, -INFINITY}, hi[2] = {INFINITY, INFINITY};
    for (std::sregex_iterator it(gp.begin(), gp.end(), range), end; it != end; ++it) {
      const int k = (*it)[1] == "x" ? 0 : 1;
      lo[k] = std::stod((*it)[2]);
      hi[k] = std::stod((*it)[3]);
    }
    auto check = [&](const std::string& file, int row, double x, double y) {
      if (x < lo[0] || x > hi[0] || y < lo[1] || y > hi[1])
        out.push_back(entry.path().filename().string() + ": " + file + " row " + std::to_string(row) + ": (" +
                      FormatNumber(x) + ", " + FormatNumber(y) + ") outside [" + FormatNumber(lo[0]) + ":" +
                      FormatNumber(hi[0]) + "] x [" + FormatNumber(lo[1]) + ":" + FormatNumber(hi[1]) + "]");
    };
    if (gp.find("multiplot") != std::string::npos) {
      // Map panels (one range for all of them): every grid node with a value, every wall point.
      const std::regex layer(R"('([^']+)' skip 1 using 1:2(:3)? with (image|lines))");
      for (std::sregex_iterator it(gp.begin(), gp.end(), layer), end; it != end; ++it) {
        const std::string file = (*it)[1];
        int row = 0;
        for (const std::vector<double>& cells : CsvRows(report / file)) {
          ++row;
          if (cells.size() < 2 || ((*it)[3] == "image" && (cells.size() < 3 || !std::isfinite(cells[2])))) continue;
          check(file, row, cells[0], cells[1]);
        }
      }
      continue;
    }
    for (std::sregex_iterator it(gp.begin(), gp.end(), item), end; it != end; ++it) {
      const std::string with = (*it)[5];
      if (with == "lines" || with == "histeps" || with == "image") continue;
      const std::string file = (*it)[1];
      const int xc = std::stoi((*it)[2]), yc = std::stoi((*it)[4]);
      const std::string shift = (*it)[3];  // "+-0.25" or "*1.02" in scripts that move points
      int row = 0;
      for (const std::vector<double>& cells : CsvRows(report / file)) {
        ++row;
        if (static_cast<int>(cells.size()) < std::max(xc, yc)) continue;
        double x = cells[xc - 1];
        const double y = cells[yc - 1];
        if (!std::isfinite(x) || !std::isfinite(y)) continue;
        if (!shift.empty()) x = shift[0] == '*' ? x * std::stod(shift.substr(1)) : x + std::stod(shift.substr(1));
        check(file, row, x, y);
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
  const FitResult r = FitModelMulti("ch5", "a * W^(b + X/2) / (1.43 + 17 * X^2)", {"W", "X"}, points, y, sigma);
  ASSERT_EQ(r.quality, FitQuality::kGood) << r.Verdict();
  const FitParameter* pa = r.Parameter("a");
  const FitParameter* pb = r.Parameter("b");
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
  EXPECT_NEAR(r.EvaluateAt(at), pa->value * std::pow(10.0, pb->value + 0.25) / (1.43 + 17 * 0.25), 1e-12);
}

TEST(FigureLayer, FitAcrossEveryPointOfTheFigureAndCollapse) {
  TempDir dir;
  const nlohmann::json figures = {
      {"report",
       {{"figures",
         {{{"name", "law"},
           {"y", "q_count"},
           {"x", "W"},
           {"group", "mu"},
           {"only", {{"mu", {0, 0.5, 1}}}},
           {"fit", {{"model", "a * W^(b + mu/2)"}, {"initial", {{"a", 0.5}, {"b", 1}}}, {"collapse", true}}},
           {"reference", "thesis fig. 4.5b"}}}}}}};
  const Campaign c = MakeCampaign(dir.Path(), figures);
  const auto a = Analyse(c, SetupAnalyses(c.info.spec));
  const std::vector<FigureSpec> specs = ReadFigureSpecs(c.info.spec);
  ASSERT_EQ(specs.size(), 1u);
  const FigureOutcome f = MakeFigure(*a, specs[0]);
  ASSERT_EQ(f.data.size(), 13u);  // 12 points, and W = 26 (one replica, no se): still a point
  ASSERT_TRUE(f.fit.has_value());
  EXPECT_EQ(f.fit->variables, (std::vector<std::string>{"W", "mu"}));
  ASSERT_EQ(f.fit->quality, FitQuality::kGood) << f.fit->Verdict();
  for (const auto& [name, truth] : {std::pair{"a", kA}, std::pair{"b", kB}}) {
    const FitParameter* p = f.fit->Parameter(name);
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

// A metric only some points have (an avalanche needs a clog: only W = 26's run stops for longer
// than the clog window) draws those points and names the points it leaves out.
TEST(FigureLayer, PointsWithoutTheMetricAreLeftOutByNameAndTheRestDrawn) {
  TempDir dir;
  const nlohmann::json figures = {{"report", {{"figures", {{{"name", "s"}, {"y", "avalanche_size"}, {"x", "W"}}}}}}};
  const Campaign c = MakeCampaign(dir.Path(), figures);
  std::ostringstream ev;
  ev << "time,body,shape,mass,outlet\n";
  for (int i = 1; i <= 60; ++i) ev << (i <= 30 ? 0.1 * i : 20.0 + 0.1 * i) << "," << i << ",disc,1.0,0\n";
  const RunRecord& w26 = c.runs.back();  // W = 26: 30 exits, 17 time units of none, 30 more
  WriteFile(w26.run_dir / "events.csv", ev.str());
  nlohmann::json summary = nlohmann::json::parse(ReadFile(w26.run_dir / "summary.json"));
  summary["exited"] = 60;
  summary["remaining"] = 1940;
  summary["exits_per_outlet"] = {60};
  summary["t_end"] = 30.0;
  WriteFile(w26.run_dir / "summary.json", summary.dump());
  const auto a = Analyse(c, SetupAnalyses(c.info.spec));
  const FigureOutcome f = MakeFigure(*a, ReadFigureSpecs(c.info.spec)[0]);
  std::string notes;
  std::vector<double> xs;
  for (const Block& b : f.blocks) {
    if (const auto* t = std::get_if<Text>(&b)) notes += t->markdown + "\n";
    if (const auto* fig = std::get_if<Figure>(&b))
      for (const Series& s : fig->series)
        for (const auto& row : s.rows) xs.push_back(row[0]);
  }
  EXPECT_EQ(xs, std::vector<double>{26}) << notes;
  EXPECT_EQ(notes.find("Not drawn"), std::string::npos) << notes;
  EXPECT_NE(notes.find("**Left out:**"), std::string::npos) << notes;
  for (const char* w : {"W = 10", "W = 14", "W = 18", "W = 22"})
    EXPECT_NE(notes.find(w), std::string::npos) << w << "\n" << notes;
}

// Several y in one figure: a curve per y and group, each with its legend label, the values
// of each y as drawn alone.
TEST(FigureLayer, SeveralMetricsAreACurveEachWithItsLabel) {
  TempDir dir;
  const nlohmann::json figures = {{"report",
                                   {{"figures",
                                     {{{"name", "both"},
                                       {"y", {"q_count", "2 * q_count"}},
                                       {"labels", {"Q", "2Q"}},
                                       {"x", "W"},
                                       {"group", "mu"},
                                       {"only", {{"mu", {0, 1}}}}}}}}}};
  const Campaign c = MakeCampaign(dir.Path(), figures);
  const auto a = Analyse(c, SetupAnalyses(c.info.spec));
  const FigureOutcome f = MakeFigure(*a, ReadFigureSpecs(c.info.spec)[0]);
  ASSERT_EQ(f.data.size(), 18u);  // (5 + 4 points) x 2 y
  const Figure* fig = nullptr;
  for (const Block& b : f.blocks)
    if (const auto* one = std::get_if<Figure>(&b)) fig = one;
  ASSERT_TRUE(fig);
  std::vector<std::string> labels;
  for (const Series& s : fig->series) labels.push_back(s.label);
  EXPECT_EQ(labels, (std::vector<std::string>{"Q, mu = 0", "Q, mu = 1", "2Q, mu = 0", "2Q, mu = 1"}));
  for (const Series& s : fig->series) {
    const double mu = s.label.find("mu = 1") != std::string::npos ? 1.0 : 0.0;
    const double factor = s.label.rfind("2Q", 0) == 0 ? 2.0 : 1.0;
    ASSERT_EQ(s.rows.size(), mu == 0 ? 5u : 4u) << s.label;
    for (const auto& row : s.rows) {
      const double expected = factor * QOf(row[0], mu) * Off(row[0], mu);
      EXPECT_NEAR(row[1], expected, 1e-6 * expected) << s.label << " W = " << row[0];
    }
  }
  EXPECT_EQ(fig->ylabel, "q_count, 2 * q_count");
}

// normalize: each curve divided by its own value at W = 10; the se from both values as
// independent (each point's replicas at -+1 %: se 1 % of its mean), the reference 1 ± 0.
TEST(FigureLayer, NormalizeDividesEachCurveByItsValueAtTheReferencePoint) {
  TempDir dir;
  const nlohmann::json figures = {
      {"report",
       {{"figures",
         {{{"name", "q-over-q0"}, {"y", "q_count"}, {"x", "W"}, {"group", "mu"}, {"normalize", {{"W", 10}}}}}}}}};
  const Campaign c = MakeCampaign(dir.Path(), figures);
  const auto a = Analyse(c, SetupAnalyses(c.info.spec));
  const FigureOutcome f = MakeFigure(*a, ReadFigureSpecs(c.info.spec)[0]);
  ASSERT_EQ(f.data.size(), 13u);
  for (const FigureDatum& d : f.data) {
    const double mu = d.axes.at("mu");
    const double ratio = QOf(d.x, mu) * Off(d.x, mu) / (QOf(10, mu) * Off(10, mu));
    EXPECT_NEAR(d.y, ratio, 1e-6 * ratio) << d.group << " W = " << d.x;
    if (d.x == 10)
      EXPECT_EQ(d.se, 0.0);
    else if (d.x == 26)
      EXPECT_TRUE(std::isnan(d.se));  // one replica: no se of its own
    else
      EXPECT_NEAR(d.se, ratio * 0.01 * std::sqrt(2.0), 1e-6 * ratio) << d.group << " W = " << d.x;
  }
  // A reference no curve but mu = 0 has: the others are left out, by name.
  TempDir dir2;
  nlohmann::json at26 = figures;
  at26["report"]["figures"][0]["normalize"] = {{"W", 26}};
  const Campaign c26 = MakeCampaign(dir2.Path(), at26);
  const auto a26 = Analyse(c26, SetupAnalyses(c26.info.spec));
  const FigureOutcome g = MakeFigure(*a26, ReadFigureSpecs(c26.info.spec)[0]);
  std::string notes;
  std::vector<std::string> drawn;
  for (const Block& b : g.blocks) {
    if (const auto* t = std::get_if<Text>(&b)) notes += t->markdown + "\n";
    if (const auto* fig = std::get_if<Figure>(&b)) {
      for (const Series& s : fig->series) drawn.push_back(s.label);
      EXPECT_NE(fig->caption.find("each curve divided by its value at W = 26"), std::string::npos) << fig->caption;
    }
  }
  EXPECT_EQ(drawn, std::vector<std::string>{"mu = 0"});
  EXPECT_NE(notes.find("**Left out:**"), std::string::npos) << notes;
  EXPECT_NE(notes.find("no point at W = 26"), std::string::npos) << notes;
  EXPECT_NE(notes.find("mu = 0.5, W = 10"), std::string::npos) << notes;
}

TEST(NormalisedValue, RatioAndIndependentErrors) {
  const MeanSe r = NormalisedValue({6.0, 0.3, 4}, {3.0, 0.4, 2}, false);
  EXPECT_DOUBLE_EQ(r.mean, 2.0);
  EXPECT_NEAR(r.se, 2.0 * std::hypot(0.3 / 6.0, 0.4 / 3.0), 1e-15);
  EXPECT_EQ(r.n, 2);
  const MeanSe one = NormalisedValue({3.0, 0.4, 2}, {3.0, 0.4, 2}, true);
  EXPECT_EQ(one.mean, 1.0);
  EXPECT_EQ(one.se, 0.0);
  EXPECT_TRUE(std::isnan(NormalisedValue({1.0, 0.1, 2}, {0.0, 0.1, 2}, false).mean));
}

TEST(FigureLayer, PooledFigureWeighsThePointsByTheirN) {
  TempDir dir;
  const nlohmann::json figures = {
      {"report", {{"figures", {{{"name", "pooled"}, {"y", "q_count"}, {"x", "W"}, {"pool", {"mu"}}}}}}}};
  const Campaign c = MakeCampaign(dir.Path(), figures);
  const auto a = Analyse(c, SetupAnalyses(c.info.spec));
  const FigureOutcome f = MakeFigure(*a, ReadFigureSpecs(c.info.spec)[0]);
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
    const double expected = (QOf(d.x, 0) * Off(d.x, 0) + QOf(d.x, 0.5) * Off(d.x, 0.5) + QOf(d.x, 1) * Off(d.x, 1)) / 3;
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
  const Campaign c = MakeCampaign(dir.Path(), extra);
  const auto a = Analyse(c, SetupAnalyses(c.info.spec));
  const FigureOutcome f = MakeFigure(*a, ReadFigureSpecs(c.info.spec)[0]);
  // Wmu = 20: W = 10, mu = 0; Wmu = 28.5: W = 14, mu = 0.5.
  ASSERT_EQ(f.data.size(), 2u);
  for (const FigureDatum& d : f.data) {
    const double w = d.x / 2, mu = d.axes.at("mu");
    EXPECT_TRUE((w == 10 && mu == 0) || (w == 14 && mu == 0.5)) << w << " " << mu;
    EXPECT_NEAR(d.y, QOf(w, mu) * Off(w, mu) / std::pow(w, 1.5), 1e-6);
    EXPECT_GT(d.se, 0.0);  // propagated from q_count's se
  }
  // The export: the axes by their short names, then the derived axes.
  const ExportTable t = MakeExportTable(*a, ExportLevel::kPoint);
  ASSERT_GE(t.columns.size(), 7u);
  EXPECT_EQ(std::vector<std::string>(t.columns.begin() + 3, t.columns.begin() + 7),
            (std::vector<std::string>{"W", "mu", "W2", "Wmu"}));
  for (const auto& row : t.rows)
    EXPECT_DOUBLE_EQ(row[6].get<double>(), 2 * row[3].get<double>() + row[4].get<double>());
}

TEST(FigureLayer, OptionErrorsNameThePathTheValueAndWhatIsAllowed) {
  const nlohmann::json base = {{"name", "t"}, {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {4, 6}}}}}}};
  auto error_of = [&](const nlohmann::json& extra) -> std::string {
    nlohmann::json spec = base;
    spec.update(extra);
    try {
      CheckReportSpec(spec);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error_of({{"report", {{"figures", {{{"name", "f"}, {"y", "q_count"}, {"x", "D_b"}}}}}}})
                .find("/report/figures/0/x: names no axis (axes: W)"),
            std::string::npos);
  EXPECT_NE(error_of({{"axes", {{"D", "sqrt(W + Z)"}}}}).find("/axes/D"), std::string::npos);
  EXPECT_NE(error_of({{"axes", {{"D", "sqrt(W + Z)"}}}}).find("names no axis: Z (axes it can use: W)"),
            std::string::npos);
  EXPECT_NE(error_of({{"report", {{"figures", {{{"name", "f"}, {"y", "q"}, {"kind", "bars"}}}}}}})
                .find("/report/figures/0/kind"),
            std::string::npos);
  EXPECT_NE(error_of({{"expect", {{{"fit", "nope"}, {"parameter", "b"}, {"value", 1}}}}}).find("/expect/0/fit"),
            std::string::npos);
  EXPECT_NE(error_of({{"expect", {{{"metric", "psi"}, {"at", {{"H", 3}}}, {"value", 1}}}}})
                .find("/expect/0/at/H: names no axis"),
            std::string::npos);
  // A list of y, its labels, normalize and a fit of several y.
  auto points = [&](const nlohmann::json& keys) {
    nlohmann::json f = {{"name", "f"}, {"x", "W"}};
    f.update(keys);
    return error_of({{"report", {{"figures", {f}}}}});
  };
  EXPECT_NE(points({{"y", {"q_count", 3}}}).find("/report/figures/0/y/1: must be a metric name"), std::string::npos);
  EXPECT_NE(points({{"y", nlohmann::json::array()}}).find("/report/figures/0/y:"), std::string::npos);
  EXPECT_NE(points({{"y", {"q_count", "psi"}}, {"labels", {"Q"}}})
                .find("/report/figures/0/labels: must be a list of 2 strings"),
            std::string::npos);
  EXPECT_NE(points({{"y", "q_count"}, {"labels", {"Q"}}}).find("/report/figures/0/labels: names the curves"),
            std::string::npos);
  EXPECT_NE(points({{"y", "q_count"}, {"normalize", {{"D", 0}}}}).find("/report/figures/0/normalize/D: names no axis"),
            std::string::npos);
  EXPECT_NE(points({{"y", "q_count"}, {"normalize", nlohmann::json::object()}}).find("/report/figures/0/normalize:"),
            std::string::npos);
  EXPECT_NE(points({{"y", {"q_count", "psi"}}, {"fit", {{"model", "a * W"}}}})
                .find("/report/figures/0/fit: fits one y; this figure has 2"),
            std::string::npos);
  EXPECT_EQ(points({{"y", {"q_count", "psi"}}, {"labels", {"Q", "Psi"}}, {"normalize", {{"W", 4}}}}), "");
  EXPECT_EQ(error_of({{"axes", {{"W2", "2 * W"}}},
                      {"report", {{"figures", {{{"name", "f"}, {"y", "q_count"}, {"x", "W2"}}}}}},
                      {"expect", {{{"metric", "q_count"}, {"at", {{"W2", 8}}}, {"value", 1}, {"source", "s"}}}}}),
            "");
}

TEST(FigureLayer, PicturesOfTheChosenPoints) {
  TempDir dir;
  const nlohmann::json extra = {{"report",
                                 {{"region", "ch3"},
                                  {"figures",
                                   {{{"name", "arches"},
                                     {"kind", "pictures"},
                                     {"only", {{"W", {10, 22}}, {"mu", 0.5}}},
                                     {"annotate",
                                      {{{"region", "region"}, {"label", "R"}, {"shade", true}},
                                       {{"dimension", "outlet_width"}},
                                       {{"dimension", "obstacle_height"}}}},
                                     {"window", {-8, 8, -3, 12}},
                                     {"reference", "thesis fig. 3.4"}}}}}}};
  const Campaign c = MakeCampaign(dir.Path() / "runs", extra);
  ReportOptions o;
  o.out_dir = dir.Path() / "report";
  o.figures = false;
  o.analysis.read_cache = o.analysis.write_cache = false;
  std::vector<std::string> drawn;
  std::vector<ReportOptions::RunPicture> pictures;
  o.draw_run = [&](const fs::path& run_dir, const ReportOptions::RunPicture& picture, const fs::path& png) {
    drawn.push_back(run_dir.filename().string() + (picture.kind == ReportOptions::Picture::kBed ? ":bed" : ":end") +
                    ":" + png.filename().string());
    pictures.push_back(picture);
    WriteFile(png, "\x89PNG fake");
    return std::string();
  };
  const ReportSummary s = WriteReport(c.info, c.runs, o);
  // The figure's two points (their first replica's end, whole and zoomed), then the gallery's
  // bed and end of all 13.
  ASSERT_GE(drawn.size(), 4u);
  EXPECT_EQ(drawn[0], "W10mu0.5r0:end:figure-arches-6-end.png");
  EXPECT_EQ(drawn[1], "W10mu0.5r0:end:figure-arches-6-end-zoom.png");
  EXPECT_EQ(drawn[2], "W22mu0.5r0:end:figure-arches-9-end.png");
  EXPECT_EQ(drawn.size(), 4u + 2 * 13);
  // W = 10: region R of ch. 3, (W + 2 d) x 10 d above the outlet, and W's dimension below the
  // base; the whole picture outlines the zoom besides; the runs have no obstacle for H.
  ASSERT_EQ(pictures[0].marks.size(), 3u);
  const PictureMark& r = pictures[0].marks[0];
  EXPECT_EQ(r.kind, PictureMark::Kind::kRect);
  EXPECT_DOUBLE_EQ(r.x0, -6);
  EXPECT_DOUBLE_EQ(r.x1, 6);
  EXPECT_DOUBLE_EQ(r.y0, 0);
  EXPECT_DOUBLE_EQ(r.y1, 10);
  EXPECT_EQ(r.label, "R");
  EXPECT_TRUE(r.shade);
  const PictureMark& w = pictures[0].marks[1];
  EXPECT_EQ(w.kind, PictureMark::Kind::kDimension);
  EXPECT_DOUBLE_EQ(w.x0, -5);
  EXPECT_DOUBLE_EQ(w.x1, 5);
  EXPECT_DOUBLE_EQ(w.y0, w.y1);
  EXPECT_LT(w.y0, 0) << "below the base";
  EXPECT_EQ(w.label, "W = 10 d");
  EXPECT_EQ(pictures[0].marks[2].label, "zoom");
  EXPECT_FALSE(pictures[0].window);
  ASSERT_TRUE(pictures[1].window);
  EXPECT_EQ(*pictures[1].window, (std::array<double, 4>{-8, 8, -3, 12}));
  EXPECT_EQ(pictures[1].marks.size(), 2u) << "the zoom without its own outline";
  EXPECT_DOUBLE_EQ(pictures[2].marks[0].x1, 12) << "W = 22: the region (22 + 2) d wide";
  EXPECT_TRUE(pictures[4].marks.empty()) << "the gallery draws no marks";
  const std::string md = ReadFile(s.markdown);
  EXPECT_LT(md.find("figure-arches-6-end.png"), md.find("## Gallery"));
  EXPECT_NE(md.find("figure-arches-6-end-zoom.png"), std::string::npos);
  EXPECT_NE(md.find("Reference: thesis fig. 3.4"), std::string::npos);
  EXPECT_NE(md.find("H: the run has no obstacle 0"), std::string::npos) << "what could not be marked is said";
  nlohmann::json bad = c.info.spec;
  bad["report"]["figures"][0]["y"] = "q_count";
  EXPECT_THROW(ReadFigureSpecs(bad), OptionError);
}

// The keys of a pictures figure: each bad value is an error naming its JSON path.
TEST(FigureLayer, PictureKeysAreChecked) {
  const auto error_of = [](const nlohmann::json& figure, const nlohmann::json& report_extra = {}) -> std::string {
    nlohmann::json spec = {{"name", "p"},
                           {"base", SpecFor(10, 0)},
                           {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {10, 14}}}}}},
                           {"report", {{"figures", {figure}}}}};
    if (report_extra.is_object()) spec["report"].update(report_extra);
    try {
      ReadFigureSpecs(spec);
      return "";
    } catch (const OptionError& e) {
      return e.Path();
    }
  };
  const nlohmann::json base = {{"name", "f"}, {"kind", "pictures"}};
  const auto with = [&](const nlohmann::json& more) {
    nlohmann::json f = base;
    f.update(more);
    return f;
  };
  EXPECT_EQ(error_of(with({{"picture", "clog"}, {"colour", "disc"}})), "");
  EXPECT_EQ(error_of(with({{"picture", "arch"}})), "/report/figures/0/picture");
  EXPECT_EQ(error_of(with({{"colour", "speed"}})), "/report/figures/0/colour");
  EXPECT_EQ(error_of(with({{"window", {1, 0, 0, 1}}})), "/report/figures/0/window");
  EXPECT_EQ(error_of(with({{"window", {0, 1, 0}}})), "/report/figures/0/window");
  EXPECT_EQ(error_of(with({{"annotate", {{{"region", "A"}}}}})), "/report/figures/0/annotate/0/region");
  EXPECT_EQ(error_of(with({{"annotate", {{{"dimension", "region"}}}}})), "/report/figures/0/annotate/0/dimension");
  EXPECT_EQ(error_of(with({{"annotate", {{{"region", "region"}, {"dimension", "outlet_width"}}}}})),
            "/report/figures/0/annotate/0");
  EXPECT_EQ(error_of(with({{"annotate", {{{"region", "region"}, {"colour", "red"}}}}})),
            "/report/figures/0/annotate/0/colour");
  EXPECT_EQ(error_of(with({{"annotate", {{{"dimension", "obstacle_height"}, {"outlet", 1}}}}})),
            "/report/figures/0/annotate/0/outlet");
  EXPECT_EQ(error_of(with({{"annotate", {{{"region", "fields"}}}}})), "/report/figures/0/annotate/0/region")
      << "the maps' window needs /report/fields";
  EXPECT_EQ(error_of(with({{"annotate", {{{"region", "fields"}, {"shade", true}}}}}), {{"fields", true}}), "");
  // A body's disc diameters: a point [x, y] and a label per disc size; the origin, a point.
  const nlohmann::json discs = {{"dimension", "disc_diameters"}, {"at", {3, 4}}, {"labels", {"D_s", "D_b"}}};
  EXPECT_EQ(error_of(with({{"annotate", {discs, {{"point", "origin"}, {"label", "O"}}}}})), "");
  EXPECT_EQ(error_of(with({{"annotate", {{{"dimension", "disc_diameters"}}}}})), "");
  const auto discs_with = [&](const char* key, const nlohmann::json& value) {
    nlohmann::json m = discs;
    m[key] = value;
    return error_of(with({{"annotate", {m}}}));
  };
  EXPECT_EQ(discs_with("at", {3}), "/report/figures/0/annotate/0/at");
  EXPECT_EQ(discs_with("at", {3, "top"}), "/report/figures/0/annotate/0/at");
  EXPECT_EQ(discs_with("labels", nlohmann::json::array()), "/report/figures/0/annotate/0/labels");
  EXPECT_EQ(discs_with("labels", {"D_s", 2}), "/report/figures/0/annotate/0/labels");
  EXPECT_EQ(discs_with("labels", "D_s"), "/report/figures/0/annotate/0/labels");
  EXPECT_EQ(discs_with("label", "D"), "/report/figures/0/annotate/0/label") << "one label per size: labels";
  EXPECT_EQ(discs_with("outlet", 0), "/report/figures/0/annotate/0/outlet");
  EXPECT_EQ(error_of(with({{"annotate", {{{"dimension", "outlet_width"}, {"at", {0, 1}}}}}})),
            "/report/figures/0/annotate/0/at");
  EXPECT_EQ(error_of(with({{"annotate", {{{"point", "centre"}}}}})), "/report/figures/0/annotate/0/point");
  EXPECT_EQ(error_of(with({{"annotate", {{{"dimension", "origin"}}}}})), "/report/figures/0/annotate/0/dimension");
  EXPECT_EQ(error_of(with({{"annotate", {{{"point", "origin"}, {"region", "region"}}}}})),
            "/report/figures/0/annotate/0");
  EXPECT_EQ(error_of(with({{"annotate", {{{"point", "origin"}, {"shade", true}}}}})),
            "/report/figures/0/annotate/0/shade");
  // Keys of other kinds, and a pictures key on another kind.
  EXPECT_EQ(error_of(with({{"y", "q_count"}})), "/report/figures/0/y");
  EXPECT_EQ(error_of({{"name", "f"}, {"y", "q_count"}, {"annotate", nlohmann::json::array()}}),
            "/report/figures/0/annotate");
}

// disc_diameters asks the renderer for the body nearest its point (as given, else the zoom
// window's centre, else half way up the bed on the axis) with its labels; origin is (0, 0).
TEST(FigureLayer, DiscDiametersAndOriginMarks) {
  const nlohmann::json spec = {{"name", "p"},
                               {"base", SpecFor(10, 0)},
                               {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {10, 14}}}}}},
                               {"report",
                                {{"figures",
                                  {{{"name", "f"},
                                    {"kind", "pictures"},
                                    {"annotate",
                                     {{{"dimension", "disc_diameters"}, {"at", {3, 4}}, {"labels", {"D_s", "D_b"}}},
                                      {{"dimension", "disc_diameters"}},
                                      {{"point", "origin"}}}}}}}}}};
  std::vector<FigureSpec> figures = ReadFigureSpecs(spec);
  ASSERT_EQ(figures.size(), 1u);
  std::vector<std::string> problems;
  std::vector<PictureMark> marks = PictureMarksOf(figures[0], spec, spec.at("base"), 30.0, problems);
  EXPECT_TRUE(problems.empty());
  ASSERT_EQ(marks.size(), 3u);
  EXPECT_EQ(marks[0].kind, PictureMark::Kind::kDiscs);
  EXPECT_DOUBLE_EQ(marks[0].x0, 3);
  EXPECT_DOUBLE_EQ(marks[0].y0, 4);
  EXPECT_EQ(marks[0].labels, (std::vector<std::string>{"D_s", "D_b"}));
  EXPECT_DOUBLE_EQ(marks[1].x0, 0) << "no point, no zoom: on the axis";
  EXPECT_DOUBLE_EQ(marks[1].y0, 15) << "half way up a bed 30 d high";
  EXPECT_TRUE(marks[1].labels.empty()) << "the renderer names the sizes";
  EXPECT_EQ(marks[2].kind, PictureMark::Kind::kOrigin);
  EXPECT_DOUBLE_EQ(marks[2].x0, 0);
  EXPECT_DOUBLE_EQ(marks[2].y0, 0);
  EXPECT_EQ(marks[2].label, "(0, 0)");
  figures[0].window = std::array<double, 4>{-4, 8, 0, 10};
  marks = PictureMarksOf(figures[0], spec, spec.at("base"), 30.0, problems);
  EXPECT_DOUBLE_EQ(marks[1].x0, 2) << "the zoom window's centre";
  EXPECT_DOUBLE_EQ(marks[1].y0, 5);
  EXPECT_DOUBLE_EQ(marks[0].x0, 3) << "a point given stays";
}

TEST(Expectations, AgreeDisagreeAndTooFewRuns) {
  TempDir dir;
  const double q14 = QOf(14, 0), q26 = QOf(26, 0);
  const nlohmann::json extra = {
      {"report",
       {{"figures", {{{"name", "law"}, {"y", "q_count"}, {"x", "W"}, {"fit", {{"model", "a * W^(b + mu/2)"}}}}}}}},
      {"expect",
       {{{"metric", "q_count"},
         {"at", {{"W", 14}, {"mu", 0}}},
         {"value", q14 * 1.02},
         {"tolerance", 0.03 * q14},
         {"source", "s1"}},
        {{"metric", "q_count"},
         {"at", {{"W", 14}, {"mu", 0}}},
         {"value", q14 * 1.5},
         {"tolerance", 0.03 * q14},
         {"source", "s2"}},
        {{"metric", "q_count"}, {"at", {{"W", 26}, {"mu", 0}}}, {"value", q26}, {"source", "s3"}},
        {{"fit", "law"}, {"parameter", "b"}, {"value", 1.5}, {"tolerance", 0.01}, {"source", "s4"}}}}};
  const Campaign c = MakeCampaign(dir.Path(), extra);
  const auto a = Analyse(c, SetupAnalyses(c.info.spec));
  const std::vector<FigureSpec> specs = ReadFigureSpecs(c.info.spec);
  std::vector<FigureOutcome> figures;
  for (const auto& s : specs) figures.push_back(MakeFigure(*a, s));
  const std::vector<Expectation> expect = ReadExpectations(c.info.spec, specs);
  const std::vector<ExpectationResult> r = JudgeExpectations(*a, expect, figures);
  ASSERT_EQ(r.size(), 4u);
  EXPECT_EQ(r[0].verdict, Verdict::kAgrees) << r[0].why;
  EXPECT_NEAR(r[0].measured, q14 * Off(14, 0), 1e-6 * q14);
  EXPECT_EQ(r[0].runs, 2);
  EXPECT_EQ(r[1].verdict, Verdict::kDisagrees) << r[1].why;
  EXPECT_EQ(r[2].verdict, Verdict::kNotEnough) << r[2].why;
  EXPECT_EQ(r[2].why, "1 finished run, needs 2");
  EXPECT_EQ(r[3].verdict, Verdict::kAgrees) << r[3].why;
  EXPECT_EQ(ToString(Count(r)), "2 agree, 1 disagrees, 1 not yet");
  const ExportTable t = ExpectationsTable(r);
  EXPECT_EQ(t.rows.size(), 4u);
  EXPECT_EQ(t.rows[1][8], "disagrees");
  EXPECT_NE(ToCsv(t).find("q_count at W = 14, mu = 0"), std::string::npos) << ToCsv(t);
}

TEST(Expectations, QuickAndMediumSizesAreMeasuredButNotComparable) {
  TempDir dir;
  const double q14 = QOf(14, 0);
  for (const std::string size : {"quick", "medium", "full"}) {
    const nlohmann::json extra = {{"size", size},
                                  {"expect",
                                   {{{"metric", "q_count"},
                                     {"at", {{"W", 14}, {"mu", 0}}},
                                     {"value", q14},
                                     {"tolerance", 0.03 * q14},
                                     {"source", "s1"}},
                                    {{"metric", "q_count"},
                                     {"at", {{"W", 14}, {"mu", 0}}},
                                     {"value", q14 * 1.5},
                                     {"tolerance", 0.03 * q14},
                                     {"source", "s2"}}}}};
    const Campaign c = MakeCampaign(dir.Path() / size, extra);
    const auto a = Analyse(c, SetupAnalyses(c.info.spec));
    const std::vector<Expectation> expect = ReadExpectations(c.info.spec, {});
    const std::vector<ExpectationResult> r = JudgeExpectations(*a, expect, {});
    ASSERT_EQ(r.size(), 2u);
    EXPECT_NEAR(r[0].measured, q14 * Off(14, 0), 1e-6 * q14) << size;  // measured at every size
    if (size == "full") {
      EXPECT_EQ(r[0].verdict, Verdict::kAgrees) << r[0].why;
      EXPECT_EQ(r[1].verdict, Verdict::kDisagrees) << r[1].why;
      EXPECT_EQ(ToString(Count(r)), "1 agree, 1 disagrees, 0 not yet");
      continue;
    }
    for (const ExpectationResult& x : r) {
      EXPECT_EQ(x.verdict, Verdict::kNotComparable) << size;
      EXPECT_EQ(x.why.rfind("a " + size + " campaign (/size): judged at full size only; |", 0), 0u) << x.why;
    }
    EXPECT_EQ(ToString(Count(r)), "0 agree, 0 disagree, 0 not yet, 2 not comparable at this size");
    EXPECT_EQ(ExpectationsTable(r).rows[1][8], "not comparable at this size");
    const std::optional<Section> key = KeyResultsSection(r);
    ASSERT_TRUE(key.has_value());
    const Table& t = std::get<Table>(key->blocks[1]);
    EXPECT_EQ(t.rows[0][5].text, "not comparable at this size");
  }
}

TEST(ReportFigures, EveryDataPointLiesInsideItsFigureRanges) {
  TempDir dir;
  const nlohmann::json extra = {
      {"report",
       {{"figures",
         {{{"name", "law"},
           {"y", "q_count"},
           {"x", "W"},
           {"fit", {{"model", "a * W^(b + mu/2)"}, {"collapse", true}}}}}}}},
      {"expect", {{{"metric", "q_count"}, {"at", {{"W", 14}, {"mu", 0}}}, {"value", QOf(14, 0)}, {"source", "s"}}}}};
  const Campaign c = MakeCampaign(dir.Path() / "runs", extra);
  ReportOptions o;
  o.out_dir = dir.Path() / "report";
  o.analysis.read_cache = o.analysis.write_cache = false;
  const ReportSummary s = WriteReport(c.info, c.runs, o);
  int scripts = 0;
  for (const auto& e : fs::directory_iterator(o.out_dir / "figures")) scripts += e.path().extension() == ".gp";
  EXPECT_GE(scripts, 5);
  const std::vector<std::string> outside = PointsOutsideRanges(o.out_dir);
  EXPECT_TRUE(outside.empty()) << outside.size() << " points outside, e.g. " << outside.front();
  // Key results first, then the figures; the system after them; the gallery last.
  const std::string md = ReadFile(s.markdown);
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
    EXPECT_EQ(ReadFile(e.path()).find("using ($1+"), std::string::npos) << e.path();
  }
}

// The same on the reports of the stored native-engine campaigns (tests/data/regression:
// remove mode with clogs, two base outlets, a lateral outlet): real runs, every figure.
TEST(ReportFigures, EveryDataPointOfTheStoredEngineCampaignsLiesInsideItsRanges) {
  for (const char* name : {"remove", "two-outlets", "lateral"}) {
    const fs::path dir = fs::path(GRANARY_SOURCE_DIR) / "tests" / "data" / "regression" / name;
    const testing::StoredCampaign stored = testing::Load(dir);
    TempDir out;
    ReportOptions o;
    o.out_dir = out.Path();
    o.analysis.write_cache = false;  // the stored runs stay as they are
    WriteReport(stored.info, stored.runs, o);
    int scripts = 0;
    for (const auto& e : fs::directory_iterator(out.Path() / "figures")) scripts += e.path().extension() == ".gp";
    EXPECT_GE(scripts, 3) << name;
    const std::vector<std::string> outside = PointsOutsideRanges(out.Path());
    EXPECT_TRUE(outside.empty()) << name << ": " << outside.size() << " points outside, e.g. " << outside.front();
  }
}

// An analysis registered by these tests alone, offering a distribution and a field of known
// values: per run at outlet width W, the values {0.5, 1.5, 2.5} + (W - 10)/4 with weights
// {1, 2, 3} (replica 0) or {3, 2, 1} (replica 1), so that a point's replicas pool to 4 each;
// the field 2x + 3y + W on the nodes x = -5..5, y = 0..10 (spacing 1), undefined at
// (5, 5), 7 frames per run; and the curve y = k <W> at x = k = 1, 2, 3 with se 0.1 k and n the
// runs merged (<W> their mean outlet width), with the line y = x.
class KnownFigures : public Analysis {
 public:
  std::string Key() const override { return "known_figures"; }
  int Version() const override { return 1; }
  std::unique_ptr<RunAccumulator> Start(const RunView& run) const override {
    class Acc : public RunAccumulator {
     public:
      Acc(double w, std::string id) : w_(w), id_(std::move(id)) {}
      nlohmann::json Finish() override { return {{"w", w_}, {"replica", id_.back() == '0' ? 0 : 1}}; }

     private:
      double w_;
      std::string id_;
    };
    return std::make_unique<Acc>(run.outlets.at(0).width, run.run_id);
  }
  std::vector<Metric> RunMetrics(const nlohmann::json&) const override { return {}; }
  std::vector<DistributionInfo> DistributionNames() const override { return {{"known", "known quantity s", "bodies"}}; }
  Samples Distribution(const std::string& name, const nlohmann::json& r) const override {
    EXPECT_EQ(name, "known");
    const double shift = (r.at("w").get<double>() - 10) / 4;
    Samples s{{0.5 + shift, 1.5 + shift, 2.5 + shift}, {1, 2, 3}};
    if (r.at("replica") == 1) s.weights = {3, 2, 1};
    return s;
  }
  std::vector<CurveInfo> CurveNames() const override { return {{"known_curve", "known curve", "k", "y (d)", true}}; }
  std::vector<CurvePoint> Curve(const std::string& name,
                                const std::vector<const nlohmann::json*>& results) const override {
    EXPECT_EQ(name, "known_curve");
    if (results.empty()) return {};
    double w = 0;
    for (const nlohmann::json* r : results) w += r->at("w").get<double>();
    w /= static_cast<double>(results.size());
    std::vector<CurvePoint> out;
    for (int k = 1; k <= 3; ++k)
      out.push_back({static_cast<double>(k), k * w, 0.1 * k, static_cast<double>(results.size())});
    return out;
  }
  std::vector<FieldInfo> FieldNames() const override { return {{"ramp", "ramp field", "rho g d", false}}; }
  std::optional<FieldMap> Field(const std::string& name, const std::vector<const nlohmann::json*>& results,
                                const nlohmann::json&) const override {
    EXPECT_EQ(name, "ramp");
    if (results.empty()) return std::nullopt;
    FieldMap m;
    m.x0 = -5;
    m.y0 = 0;
    m.nx = m.ny = 11;
    const double w = results.front()->at("w").get<double>();
    for (int j = 0; j < m.ny; ++j)
      for (int i = 0; i < m.nx; ++i) {
        m.values.push_back(i == 10 && j == 5 ? kNaN : 2 * m.X(i) + 3 * m.Y(j) + w);
        m.n_frames.push_back(7.0 * static_cast<double>(results.size()));
      }
    m.runs = static_cast<int>(results.size());
    m.frames = 7 * m.runs;
    m.lines = {{{-6, 12}, {-6, -1}, {-1, -1}}, {{1, -1}, {6, -1}, {6, 12}}};
    return m;
  }
};

AnalysisEntry KnownFiguresEntry() {
  return {"known_figures", [](const nlohmann::json&, const std::string&) { return std::make_unique<KnownFigures>(); }};
}

// A constructed campaign with one figure, analysed (kept together: the view points into the
// campaign, the outcome into the specs).
struct Analysed {
  Campaign c;
  AnalysisSetup setup;
  std::unique_ptr<CampaignAnalysis> a;
  std::vector<FigureSpec> specs;
  FigureOutcome f;
};
std::unique_ptr<Analysed> FigureOf(const fs::path& root, const nlohmann::json& figure) {
  auto r = std::make_unique<Analysed>();
  r->c = MakeCampaign(root, {{"report", {{"figures", {figure}}}}});
  r->setup = SetupAnalyses(r->c.info.spec);
  r->a = Analyse(r->c, r->setup);
  r->specs = ReadFigureSpecs(r->c.info.spec);
  r->f = MakeFigure(*r->a, r->specs.at(0));
  return r;
}

const Figure* FigureIn(const FigureOutcome& f) {
  for (const Block& b : f.blocks)
    if (const auto* fig = std::get_if<Figure>(&b)) return fig;
  return nullptr;
}

TEST(DensityHistogram, KnownCountsDensitiesAndValuesOutsideTheRange) {
  const Density d = DensityHistogram(Samples{{0.5, 1.0, 1.5, 2.5, 2.5, 3.0, 7.0}, {}}, 3, 0, 3, false);
  ASSERT_EQ(d.center.size(), 3u);
  EXPECT_EQ(d.total, 7.0);  // 7.0 lies outside but counts in n
  EXPECT_EQ(d.count, (std::vector<double>{1, 2, 3})) << "bins [0, 1), [1, 2), [2, 3]";
  EXPECT_EQ(d.center, (std::vector<double>{0.5, 1.5, 2.5}));
  for (int i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(d.density[i], (i + 1) / 7.0);
  // Log bins: [1, 10), [10, 100), weights as counts; density over each bin's own width.
  const Density l = DensityHistogram(Samples{{2, 20, 30, -1}, {1, 2, 1, 5}}, 2, 1, 100, true);
  EXPECT_EQ(l.count, (std::vector<double>{1, 3}));
  EXPECT_DOUBLE_EQ(l.total, 9.0);
  EXPECT_DOUBLE_EQ(l.density[1], 3.0 / (9.0 * 90.0));
  EXPECT_DOUBLE_EQ(l.center[0], std::sqrt(10.0));
}

TEST(FigureKinds, DistributionPoolsReplicasOverOneRangeForEveryCurve) {
  ScopedAnalysis known(KnownFiguresEntry());
  TempDir dir;
  const auto r = FigureOf(dir.Path(), {{"name", "dist"},
                                       {"kind", "distribution"},
                                       {"of", "known"},
                                       {"bins", 3},
                                       {"only", {{"W", {10, 14}}, {"mu", 0}}},
                                       {"reference", "thesis fig. 4.6"}});
  const FigureOutcome& f = r->f;
  const Figure* fig = FigureIn(f);
  ASSERT_TRUE(fig);
  ASSERT_EQ(fig->series.size(), 2u);
  // Range: the data's, 0.5 .. 3.5, three bins of width 1 for both curves.
  const Series& w10 = fig->series[0];
  const Series& w14 = fig->series[1];
  EXPECT_EQ(w10.label, "W = 10 d, mu = 0 (n = 12)");
  EXPECT_EQ(w14.label, "W = 14 d, mu = 0 (n = 12)");
  ASSERT_EQ(w10.rows.size(), 3u);
  ASSERT_EQ(w14.rows.size(), 3u);
  // W = 14: 1.5, 2.5 and 3.5 (the top of the range: in the last bin, which is closed).
  const double density10[3] = {1.0 / 3, 1.0 / 3, 1.0 / 3}, density14[3] = {0, 1.0 / 3, 2.0 / 3};
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(w10.rows[i][0], 1.0 + i, 1e-6);
    EXPECT_NEAR(w14.rows[i][0], w10.rows[i][0], 1e-12) << "one set of bins for every curve";
    EXPECT_NEAR(w10.rows[i][1], density10[i], 1e-6) << i;
    EXPECT_NEAR(w14.rows[i][1], density14[i], 1e-6) << i;
  }
  EXPECT_EQ(fig->xlabel, "known quantity s (bodies)");
  EXPECT_NE(fig->caption.find("Reference: thesis fig. 4.6"), std::string::npos);
  // A given range: [0, 4), four bins; W = 14 pooled (4, 4, 4) in the upper three.
  nlohmann::json spec = r->c.info.spec;
  spec["report"]["figures"][0]["range"] = {0, 4};
  spec["report"]["figures"][0]["bins"] = 4;
  spec["report"]["figures"][0]["pool"] = "mu";
  spec["report"]["figures"][0]["only"] = {{"W", 14}};
  const FigureSpec ranged = ReadFigureSpecs(spec).at(0);
  const FigureOutcome g = MakeFigure(*r->a, ranged);
  const Figure* gf = FigureIn(g);
  ASSERT_TRUE(gf);
  ASSERT_EQ(gf->series.size(), 1u);  // mu pooled: one curve of 2 points x 2 replicas
  EXPECT_EQ(gf->series[0].label, "W = 14 d (n = 36)");
  const double pooled[4] = {0, 1.0 / 3, 1.0 / 3, 1.0 / 3};
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(gf->series[0].rows[i][1], pooled[i], 1e-9) << i;
}

// The built-in offers: the region's velocity histograms as their bins' centres with counts, the
// avalanches' sizes as samples.
TEST(FigureKinds, TheAnalysesOfferTheirDistributionsByName) {
  const AnalysisSetup setup = SetupAnalyses(nlohmann::json::object());
  const Analysis* region = nullptr;
  const Analysis* avalanches = nullptr;
  for (const Analysis* a : setup.List()) {
    if (a->Key() == "region") region = a;
    if (a->Key() == "avalanches") avalanches = a;
  }
  ASSERT_TRUE(region && avalanches);
  ASSERT_EQ(region->DistributionNames().size(), 2u);
  EXPECT_EQ(region->DistributionNames()[0].unit, "sqrt(g d)");
  // Grid bin k holds [(k - 1/2) w, (k + 1/2) w): centre k w.
  const nlohmann::json result = {
      {"regions", {{{"velocity", {{"vx", {{"width", 0.05}, {"first", -2}, {"counts", {1, 0, 3}}}}}}}}}};
  const Samples vx = region->Distribution("vx", result);
  ASSERT_EQ(vx.values.size(), 2u);  // the empty bin is no sample
  EXPECT_DOUBLE_EQ(vx.values[0], -0.1);
  EXPECT_DOUBLE_EQ(vx.values[1], 0.0);
  EXPECT_EQ(vx.weights, (std::vector<double>{1, 3}));
  EXPECT_TRUE(region->Distribution("vy", result).values.empty());
  EXPECT_TRUE(region->Distribution("vx", nlohmann::json::object()).values.empty()) << "a run without frames";
  const Samples sizes = avalanches->Distribution("avalanche_sizes", {{"sizes", {3, 5, 5}}});
  EXPECT_EQ(sizes.values, (std::vector<double>{3, 5, 5}));
  EXPECT_TRUE(sizes.weights.empty());
}

TEST(FigureKinds, DistributionOfAPerRunMetricPoolsItsReplicas) {
  TempDir dir;
  const auto r = FigureOf(
      dir.Path(), {{"name", "q"}, {"kind", "distribution"}, {"of", "q_count"}, {"bins", 2}, {"only", {{"mu", 0}}}});
  const FigureOutcome& f = r->f;
  const Figure* fig = FigureIn(f);
  ASSERT_TRUE(fig);
  ASSERT_EQ(fig->series.size(), 5u);  // W = 10, 14, 18, 22, 26 at mu = 0
  double total = 0;
  for (const Series& se : fig->series) {
    double n = 0;
    for (const auto& row : se.rows) n += row[2];
    EXPECT_EQ(n, se.label.find("W = 26") == 0 ? 1 : 2) << se.label;  // one value per run
    total += n;
  }
  EXPECT_EQ(total, 9);
  // Two bins over [Q(10), Q(26)]: every W < 19.3 in the first.
  const double mid = 0.5 * (fig->series.front().rows[0][0] + fig->series.front().rows[1][0]);
  EXPECT_GT(mid, QOf(14, 0) * 1.02);
  EXPECT_LT(mid, QOf(22, 0) * 0.98);
  // An unknown name is said, not drawn.
  nlohmann::json spec = r->c.info.spec;
  spec["report"]["figures"][0]["of"] = "no_such_metric";
  const FigureOutcome none = MakeFigure(*r->a, ReadFigureSpecs(spec).at(0));
  ASSERT_EQ(none.blocks.size(), 1u);
  EXPECT_NE(std::get<Text>(none.blocks[0]).markdown.find("no run has a metric of that name"), std::string::npos);
}

TEST(FigureKinds, CurvesOfTheChosenPointsMergeTheirRunsAndDrawTheirLine) {
  ScopedAnalysis known(KnownFiguresEntry());
  TempDir dir;
  const auto r = FigureOf(dir.Path(), {{"name", "curves"},
                                       {"kind", "curves"},
                                       {"of", "known_curve"},
                                       {"pool", "mu"},
                                       {"only", {{"W", {10, 26}}}},
                                       {"reference", "thesis fig. 6.7"}});
  const Figure* fig = FigureIn(r->f);
  ASSERT_TRUE(fig);
  ASSERT_EQ(fig->series.size(), 3u);  // W = 10 (mu pooled: 3 points x 2 replicas), W = 26 (one run), y = x
  EXPECT_EQ(fig->series[0].label, "W = 10 d");
  EXPECT_EQ(fig->series[1].label, "W = 26 d");
  EXPECT_EQ(fig->xlabel, "k");
  EXPECT_EQ(fig->ylabel, "y (d)");
  for (std::size_t c = 0; c < 2; ++c) {
    const double w = c == 0 ? 10 : 26, runs = c == 0 ? 6 : 1;
    const Series& se = fig->series[c];
    EXPECT_EQ(se.style, Series::Style::kErrorBars);
    ASSERT_EQ(se.rows.size(), 3u);
    for (int k = 1; k <= 3; ++k) {
      EXPECT_DOUBLE_EQ(se.rows[k - 1][0], k);
      EXPECT_DOUBLE_EQ(se.rows[k - 1][1], k * w);
      EXPECT_DOUBLE_EQ(se.rows[k - 1][2], 0.1 * k);
      EXPECT_DOUBLE_EQ(se.rows[k - 1][3], runs);
    }
    EXPECT_EQ(r->f.data[c].n, 3 * runs);
  }
  EXPECT_EQ(fig->series[2].role, Series::Role::kReference);
  EXPECT_EQ(fig->series[2].rows, (std::vector<std::vector<double>>{{1, 1}, {3, 3}}));
  EXPECT_NE(fig->caption.find("pooled over mu; only W in {10, 26}. Reference: thesis fig. 6.7"), std::string::npos)
      << fig->caption;
}

// The arches' curves and arch sizes from constructed clogs, the orientation window's axis
// angles from constructed sums: known bins, means and counts.
TEST(FigureKinds, TheArchesAndTheOrientationOfferTheirCurvesAndDistributions) {
  const AnalysisSetup setup = SetupAnalyses(nlohmann::json::object());
  const Analysis* arches = nullptr;
  const Analysis* orientation = nullptr;
  for (const Analysis* a : setup.List()) {
    if (a->Key() == "arches") arches = a;
    if (a->Key() == "orientation") orientation = a;
  }
  ASSERT_TRUE(arches && orientation);
  const double pi = std::acos(-1.0);
  auto body = [](double theta, double axis, double pressure) {
    return nlohmann::json{{"discs", 2}, {"theta", theta}, {"axis", axis}, {"pressure", pressure}};
  };
  auto run = [](int n, double mean_pressure, const nlohmann::json& bodies) {
    nlohmann::json arch = {{"outlet", 0}, {"n", n}, {"mean_pressure", mean_pressure}};
    arch["bodies"] = bodies;
    nlohmann::json clog = {{"sealed_outlets", nlohmann::json::array({0})}};
    clog["arches"] = nlohmann::json::array({arch});
    return nlohmann::json{{"present", true}, {"clogs", nlohmann::json::array({clog})}};
  };
  // Default bins: 9 of theta over [0, pi] (20 degrees), 12 of the axis over [0, pi) (15 degrees).
  const nlohmann::json a = run(3, 2.0, nlohmann::json::array({body(0.1, 0.1, 1.0), body(pi / 2, pi / 2, 3.0)}));
  const nlohmann::json b = run(3, 4.0, nlohmann::json::array({body(pi / 2, pi / 2, 5.0)}));
  const std::vector<CurvePoint> p = arches->Curve("arch_pressure_theta", {&a, &b});
  ASSERT_EQ(p.size(), 2u);
  EXPECT_NEAR(p[0].x, 10, 1e-9);
  EXPECT_DOUBLE_EQ(p[0].y, 1.0);
  EXPECT_EQ(p[0].n, 1);
  EXPECT_NEAR(p[1].x, 90, 1e-9);
  EXPECT_DOUBLE_EQ(p[1].y, 4.0);  // 3 and 5
  EXPECT_DOUBLE_EQ(p[1].se, 1.0);
  EXPECT_EQ(p[1].n, 2);
  const std::vector<CurvePoint> m = arches->Curve("arch_axis_mode_theta", {&a, &b});
  ASSERT_EQ(m.size(), 2u);
  EXPECT_NEAR(m[0].y, 7.5, 1e-9);
  EXPECT_NEAR(m[1].y, 97.5, 1e-9);  // pi/2 falls in the axis bin [90, 105)
  EXPECT_TRUE(std::isnan(m[1].se));
  const std::vector<CurvePoint> byn = arches->Curve("arch_pressure_n", {&a, &b});
  ASSERT_EQ(byn.size(), 1u);
  EXPECT_DOUBLE_EQ(byn[0].x, 3);
  EXPECT_DOUBLE_EQ(byn[0].y, 3.0);
  EXPECT_EQ(byn[0].n, 2);
  EXPECT_TRUE(arches->Curve("arch_pressure_theta", {}).empty());
  EXPECT_EQ(arches->Distribution("arch_sizes", a).values, (std::vector<double>{3}));
  // The window's axis angles: 4 bins of 45 degrees as the runs keep them.
  const nlohmann::json o = {{"elongated", true},
                            {"bed", {{"window_axes", {5, 0, 0, 1}}}},
                            {"flow", {{"window_axes", {0, 2, 0, 0}}}},
                            {"arch_window", {0, 0, 3, 0}}};
  const Samples bed = orientation->Distribution("axis_bed", o);
  EXPECT_EQ(bed.values, (std::vector<double>{22.5, 157.5}));
  EXPECT_EQ(bed.weights, (std::vector<double>{5, 1}));
  EXPECT_EQ(orientation->Distribution("axis_flow", o).values, (std::vector<double>{67.5}));
  EXPECT_EQ(orientation->Distribution("axis_arches", o).weights, (std::vector<double>{3}));
  EXPECT_TRUE(orientation->Distribution("axis_flow", {{"elongated", false}}).values.empty()) << "discs have no axis";
}

TEST(FigureKinds, MapPanelsAtTheChosenPointsWithAxesAndUnitsInTheirTitles) {
  ScopedAnalysis known(KnownFiguresEntry());
  TempDir dir;
  const auto r = FigureOf(
      dir.Path(), {{"name", "maps"}, {"kind", "maps"}, {"field", "ramp"}, {"only", {{"W", {10, 22}}, {"mu", 0.5}}}});
  const FigureOutcome& f = r->f;
  const MapFigure* m = nullptr;
  for (const Block& b : f.blocks)
    if (const auto* x = std::get_if<MapFigure>(&b)) m = x;
  ASSERT_TRUE(m);
  ASSERT_EQ(m->panels.size(), 2u);
  EXPECT_EQ(m->panels[0].title, "W = 10 d, mu = 0.5: 2 runs, 14 frames");
  EXPECT_EQ(m->panels[1].title, "W = 22 d, mu = 0.5: 2 runs, 14 frames");
  EXPECT_EQ(m->value_name, "ramp field (rho g d)");
  for (std::size_t k = 0; k < 2; ++k) {
    const double w = k == 0 ? 10 : 22;
    ASSERT_EQ(m->panels[k].grid.size(), 121u);
    for (const auto& node : m->panels[k].grid) {
      EXPECT_GE(node[0], m->x_lo);
      EXPECT_LE(node[0], m->x_hi);
      EXPECT_GE(node[1], m->y_lo);
      EXPECT_LE(node[1], m->y_hi);
      if (node[0] == 5 && node[1] == 5)
        EXPECT_TRUE(std::isnan(node[2]));
      else
        EXPECT_DOUBLE_EQ(node[2], 2 * node[0] + 3 * node[1] + w);
    }
    EXPECT_EQ(m->panels[k].lines.size(), 2u);
  }
  // One run (an instant, fig. 3.10): the lowest replica's, said in the panel's title.
  nlohmann::json spec = r->c.info.spec;
  spec["report"]["figures"][0]["one_run"] = true;
  const FigureOutcome one = MakeFigure(*r->a, ReadFigureSpecs(spec).at(0));
  const MapFigure* m1 = nullptr;
  for (const Block& b : one.blocks)
    if (const auto* x = std::get_if<MapFigure>(&b)) m1 = x;
  ASSERT_TRUE(m1);
  ASSERT_EQ(m1->panels.size(), 2u);
  EXPECT_EQ(m1->panels[0].title, "W = 10 d, mu = 0.5: 1 run (replica 0), 7 frames");
  EXPECT_EQ(m1->panels[1].title, "W = 22 d, mu = 0.5: 1 run (replica 0), 7 frames");
  EXPECT_NE(m1->caption.find("Each panel: the lowest replica that has the field"), std::string::npos) << m1->caption;
}

// `group` names the panels (or curves) of a figure at chosen points by the axes it lists, a
// derived one too (fig. 7.6: L rather than the outlets' centres); axes that do not tell the
// points apart name them by every axis, and the figure says so.
TEST(FigureKinds, GroupNamesThePanelsOfAFigureAtChosenPoints) {
  ScopedAnalysis known(KnownFiguresEntry());
  TempDir dir;
  const nlohmann::json maps = {
      {"name", "maps"}, {"kind", "maps"}, {"field", "ramp"}, {"only", {{"W", {10, 22}}, {"mu", 0.5}}}};
  auto panels_of = [&](const nlohmann::json& group, std::string* note) {
    nlohmann::json figure = maps;
    figure["group"] = group;
    const Campaign c = MakeCampaign(dir.Path(), {{"axes", {{"W2", "2 * W"}}}, {"report", {{"figures", {figure}}}}});
    const AnalysisSetup setup = SetupAnalyses(c.info.spec);
    const auto a = Analyse(c, setup);
    const FigureOutcome f = MakeFigure(*a, ReadFigureSpecs(c.info.spec).at(0));
    std::vector<std::string> titles;
    for (const Block& b : f.blocks) {
      if (const auto* m = std::get_if<MapFigure>(&b))
        for (const auto& panel : m->panels) titles.push_back(panel.title);
      if (const auto* t = std::get_if<Text>(&b)) *note += t->markdown;
    }
    return titles;
  };
  std::string note;
  EXPECT_EQ(panels_of("W2", &note),
            (std::vector<std::string>{"W2 = 20: 2 runs, 14 frames", "W2 = 44: 2 runs, 14 frames"}));
  EXPECT_EQ(note, "");
  EXPECT_EQ(panels_of("mu", &note), (std::vector<std::string>{"W = 10 d, mu = 0.5: 2 runs, 14 frames",
                                                              "W = 22 d, mu = 0.5: 2 runs, 14 frames"}));
  EXPECT_NE(note.find("`group` (mu) does not tell its points apart: each is named by every axis"), std::string::npos)
      << note;
}

// Panels come in the order of x, then the other axes, by value: not in the view's order of its
// points, which sorts them by their group's text (mu = 0 before mu = 1, whatever their W).
TEST(FigureKinds, PanelsComeInTheOrderOfXThenTheOtherAxes) {
  ScopedAnalysis known(KnownFiguresEntry());
  TempDir dir;
  const auto r = FigureOf(
      dir.Path(), {{"name", "maps"}, {"kind", "maps"}, {"field", "ramp"}, {"only", {{"W", {10, 22}}, {"mu", {0, 1}}}}});
  const MapFigure* m = nullptr;
  for (const Block& b : r->f.blocks)
    if (const auto* x = std::get_if<MapFigure>(&b)) m = x;
  ASSERT_TRUE(m);
  ASSERT_EQ(m->panels.size(), 4u);
  EXPECT_EQ(m->panels[0].title.substr(0, 16), "W = 10 d, mu = 0");
  EXPECT_EQ(m->panels[1].title.substr(0, 16), "W = 10 d, mu = 1");
  EXPECT_EQ(m->panels[2].title.substr(0, 16), "W = 22 d, mu = 0");
  EXPECT_EQ(m->panels[3].title.substr(0, 16), "W = 22 d, mu = 1");
}

// The walls over a zoomed map: only their parts inside the panel's box.
TEST(FigureKinds, WallsClippedToTheMapsBox) {
  using Polyline = std::vector<std::array<double, 2>>;
  const std::array<double, 4> box = {0, 10, 0, 10};
  const auto clipped = ClipPolylines({{{-5, 5}, {5, 5}, {5, 15}},          // enters, turns, leaves
                                      {{2, 2}, {20, 2}, {20, 8}, {2, 8}},  // leaves and comes back: two lines
                                      {{-5, -5}, {-5, 20}},                // never inside
                                      {{1, 1}, {9, 9}}},                   // inside
                                     box);
  ASSERT_EQ(clipped.size(), 4u);
  EXPECT_EQ(clipped[0], (Polyline{{0, 5}, {5, 5}, {5, 10}}));
  EXPECT_EQ(clipped[1], (Polyline{{2, 2}, {10, 2}}));
  EXPECT_EQ(clipped[2], (Polyline{{10, 8}, {2, 8}}));
  EXPECT_EQ(clipped[3], (Polyline{{1, 1}, {9, 9}}));
}

TEST(FigureKinds, ProfileAlongXAndYOfAConstructedField) {
  FieldMap m;
  m.x0 = -5;
  m.y0 = 0;
  m.nx = m.ny = 11;
  for (int j = 0; j < m.ny; ++j)
    for (int i = 0; i < m.nx; ++i) m.values.push_back(i == 10 && j == 5 ? kNaN : 2 * m.X(i) + 3 * m.Y(j));
  const FieldProfile px = ComputeFieldProfile(m, 'x', 5, 2);  // rows y = 4, 5, 6
  ASSERT_EQ(px.position.size(), 11u);
  EXPECT_EQ(px.band_lo, 4);
  EXPECT_EQ(px.band_hi, 6);
  for (std::size_t i = 0; i < 11; ++i) {
    EXPECT_DOUBLE_EQ(px.position[i], -5.0 + static_cast<double>(i));
    EXPECT_DOUBLE_EQ(px.value[i], 2 * px.position[i] + 15) << i;  // at x = 5 rows 4 and 6 alone: still 25
    EXPECT_EQ(px.nodes[i], i == 10 ? 2 : 3);
  }
  const FieldProfile py = ComputeFieldProfile(m, 'y', 0.2, 0.5);  // no column within 0.25 of 0.2: the nearest, x = 0
  ASSERT_EQ(py.position.size(), 11u);
  EXPECT_EQ(py.band_lo, 0);
  for (std::size_t j = 0; j < 11; ++j) EXPECT_DOUBLE_EQ(py.value[j], 3 * py.position[j]);
  EXPECT_TRUE(ComputeFieldProfile(m, 'x', 11, 1).position.empty()) << "a line above the grid";
}

TEST(FigureKinds, ProfileFigureOfTheChosenPoints) {
  ScopedAnalysis known(KnownFiguresEntry());
  TempDir dir;
  const auto r = FigureOf(dir.Path(), {{"name", "prof"},
                                       {"kind", "profile"},
                                       {"field", "ramp"},
                                       {"along", "x"},
                                       {"at", 3},
                                       {"width", 2.5},
                                       {"pool", "mu"},
                                       {"only", {{"W", {14, 18}}}},
                                       {"reference", "thesis fig. 5.15"}});
  const FigureOutcome& f = r->f;
  const Figure* fig = FigureIn(f);
  ASSERT_TRUE(fig);
  ASSERT_EQ(fig->series.size(), 2u);
  EXPECT_EQ(fig->series[0].label, "W = 14 d: 6 runs");  // mu pooled: 3 points x 2 replicas
  EXPECT_EQ(fig->xlabel, "x (d)");
  EXPECT_EQ(fig->ylabel, "ramp field (rho g d)");
  for (const Series& se : fig->series) {
    const double w = se.label.find("W = 14") == 0 ? 14 : 18;
    ASSERT_EQ(se.rows.size(), 11u);
    for (const auto& row : se.rows) EXPECT_DOUBLE_EQ(row[1], 2 * row[0] + 9 + w);  // rows y = 2, 3, 4
  }
  EXPECT_NE(fig->caption.find("rows y = 2 .. 4 d"), std::string::npos) << fig->caption;
  // x from a base outlet's centre: each point's own (here moved to x = W / 2).
  for (Point& p : r->a->view.points) p.spec["silo"]["base_outlets"][0]["center"] = p.x / 2;
  nlohmann::json shifted = r->c.info.spec;
  shifted["report"]["figures"][0]["origin_outlet"] = 0;
  const FigureOutcome from = MakeFigure(*r->a, ReadFigureSpecs(shifted).at(0));
  const Figure* ff = FigureIn(from);
  ASSERT_TRUE(ff);
  ASSERT_EQ(ff->series.size(), 2u);
  EXPECT_EQ(ff->xlabel, "x from the centre of base outlet 0 (d)");
  for (const Series& se : ff->series) {
    const double w = se.label.find("W = 14") == 0 ? 14 : 18;
    ASSERT_EQ(se.rows.size(), 11u);
    EXPECT_DOUBLE_EQ(se.rows.front()[0], -5 - w / 2);
    for (const auto& row : se.rows) EXPECT_DOUBLE_EQ(row[1], 2 * (row[0] + w / 2) + 9 + w);
  }
  shifted["report"]["figures"][0]["origin_outlet"] = 1;
  const FigureOutcome none = MakeFigure(*r->a, ReadFigureSpecs(shifted).at(0));
  ASSERT_FALSE(none.blocks.empty());
  EXPECT_NE(std::get<Text>(none.blocks.back()).markdown.find("W = 14 d (no base outlet 1)"), std::string::npos);
  // A line outside the grid is said.
  nlohmann::json spec = r->c.info.spec;
  spec["report"]["figures"][0]["at"] = 40;
  const FigureOutcome out = MakeFigure(*r->a, ReadFigureSpecs(spec).at(0));
  ASSERT_FALSE(out.blocks.empty());
  EXPECT_NE(std::get<Text>(out.blocks.back()).markdown.find("the line y = 40 d lies outside the grid, y = 0 .. 10 d"),
            std::string::npos);
}

TEST(FigureKinds, OptionErrorsNameThePathTheValueAndWhatIsAllowed) {
  const nlohmann::json base = {{"name", "t"}, {"sweep", {{"grid", {{"/silo/base_outlets/0/width", {4, 6}}}}}}};
  nlohmann::json fields = base;
  fields["report"]["fields"] = true;
  // The spec's check with one figure, on `base` or with the fields on.
  auto error_with = [&](const nlohmann::json& on, const nlohmann::json& figure) -> std::string {
    nlohmann::json spec = on;
    spec["report"]["figures"] = {figure};
    try {
      CheckReportSpec(spec);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  };
  auto error_of = [&](const nlohmann::json& figure) { return error_with(base, figure); };
  auto field_error = [&](const nlohmann::json& figure) { return error_with(fields, figure); };
  auto has = [](const std::string& error, const std::string& part) {
    return error.find(part) != std::string::npos
               ? ::testing::AssertionSuccess()
               : ::testing::AssertionFailure() << "\"" << part << "\" not in: " << error;
  };
  EXPECT_TRUE(has(error_of({{"name", "f"}, {"kind", "bars"}}), "/report/figures/0/kind: must be \"points\""));
  EXPECT_TRUE(
      has(error_of({{"name", "f"}, {"kind", "bars"}}), "\"profile\" (a field along a line at each chosen point)"));
  EXPECT_TRUE(has(
      error_of({{"name", "f"}, {"kind", "maps"}, {"field", "phi"}}),
      "/report/figures/0/field: no analysis offers fields: turn on the coarse-grained fields (/report/fields: true)"));
  EXPECT_TRUE(has(error_of({{"name", "f"}, {"kind", "distribution"}, {"of", "vx"}, {"y", "q_count"}}),
                  "/report/figures/0/y: a figure of kind \"distribution\" takes"));
  EXPECT_TRUE(
      has(error_of({{"name", "f"}, {"kind", "distribution"}, {"of", "vx"}, {"bins", 0}}), "/report/figures/0/bins"));
  EXPECT_TRUE(has(error_of({{"name", "f"}, {"kind", "distribution"}, {"of", "vx"}, {"range", {2, 1}}}),
                  "/report/figures/0/range: must be [lo, hi] with lo < hi"));
  EXPECT_TRUE(
      has(error_of({{"name", "f"}, {"kind", "distribution"}, {"of", "v x"}}),
          "/report/figures/0/of: must name a distribution an analysis offers (vx, vy, avalanche_sizes, arch_sizes, "
          "axis_bed, axis_flow, axis_arches) or a per-run metric"));
  EXPECT_TRUE(has(error_of({{"name", "f"}, {"kind", "curves"}, {"of", "arch_presure_theta"}}),
                  "/report/figures/0/of: must name a curve an analysis this spec turns on offers (arch_pressure_theta, "
                  "arch_axis_mode_theta, arch_pressure_n) (got \"arch_presure_theta\")"));
  EXPECT_TRUE(has(error_of({{"name", "f"}, {"kind", "curves"}, {"of", "arch_pressure_n"}, {"bins", 3}}),
                  "/report/figures/0/bins: a figure of kind \"curves\" takes"));
  EXPECT_EQ(error_of({{"name", "f"}, {"kind", "curves"}, {"of", "arch_pressure_n"}, {"pool", "W"}}), "");
  EXPECT_EQ(error_of({{"name", "f"}, {"kind", "distribution"}, {"of", "vy"}, {"logy", true}}), "");
  EXPECT_EQ(field_error({{"name", "f"}, {"kind", "maps"}, {"field", "pressure"}, {"only", {{"W", 4}}}}), "");
  EXPECT_TRUE(has(field_error({{"name", "f"}, {"kind", "maps"}, {"field", "presure"}}),
                  "/report/figures/0/field: must name a field (fields: phi,"));
  EXPECT_TRUE(has(field_error({{"name", "f"}, {"kind", "profile"}, {"field", "speed"}, {"along", "z"}, {"at", 3}}),
                  "/report/figures/0/along: must be \"x\""));
  EXPECT_TRUE(has(field_error({{"name", "f"}, {"kind", "profile"}, {"field", "speed"}, {"along", "y"}}),
                  "/report/figures/0/at: must be the line's position x (d)"));
  EXPECT_TRUE(has(
      field_error({{"name", "f"}, {"kind", "profile"}, {"field", "speed"}, {"along", "y"}, {"at", 0}, {"width", -1}}),
      "/report/figures/0/width"));
  EXPECT_TRUE(has(field_error({{"name", "f"}, {"kind", "maps"}, {"field", "speed"}, {"one_run", 1}}),
                  "/report/figures/0/one_run"));
  EXPECT_TRUE(has(
      field_error(
          {{"name", "f"}, {"kind", "profile"}, {"field", "speed"}, {"along", "y"}, {"at", 0}, {"origin_outlet", 0}}),
      "/report/figures/0/origin_outlet: takes a line along x"));
  EXPECT_TRUE(has(error_of({{"name", "f"}, {"kind", "distribution"}, {"of", "vx"}, {"one_run", true}}),
                  "/report/figures/0/one_run: a figure of kind \"distribution\" takes"));
  EXPECT_TRUE(has(field_error({{"name", "f"}, {"kind", "maps"}, {"field", "speed"}, {"at", 0}}),
                  "/report/figures/0/at: a figure of kind \"maps\" takes"));
}

// Every new kind in a written report: the .gp scripts hold every point and every map node
// inside their ranges, the maps and the profile are in the report.
TEST(ReportFigures, EveryPointOfTheNewKindsLiesInsideItsRanges) {
  ScopedAnalysis known(KnownFiguresEntry());
  TempDir dir;
  const nlohmann::json extra = {
      {"report",
       {{"figures",
         {{{"name", "dist"}, {"kind", "distribution"}, {"of", "known"}, {"bins", 5}},
          {{"name", "dist-range"}, {"kind", "distribution"}, {"of", "known"}, {"range", {1, 2}}, {"bins", 4}},
          {{"name", "q-dist"}, {"kind", "distribution"}, {"of", "q_count"}, {"pool", "mu"}},
          {{"name", "maps"}, {"kind", "maps"}, {"field", "ramp"}, {"only", {{"W", {10, 26}}, {"mu", 0}}}},
          {{"name", "curves"}, {"kind", "curves"}, {"of", "known_curve"}, {"only", {{"mu", 0.5}}}},
          {{"name", "prof"},
           {"kind", "profile"},
           {"field", "ramp"},
           {"along", "y"},
           {"at", 0},
           {"only", {{"mu", 1}}}}}}}}};
  const Campaign c = MakeCampaign(dir.Path() / "runs", extra);
  ReportOptions o;
  o.out_dir = dir.Path() / "report";
  o.analysis.read_cache = o.analysis.write_cache = false;
  const ReportSummary s = WriteReport(c.info, c.runs, o);
  for (const char* name :
       {"figure-dist", "figure-dist-range", "figure-q-dist", "figure-maps", "figure-prof", "figure-curves"})
    EXPECT_TRUE(fs::exists(o.out_dir / "figures" / (std::string(name) + ".gp"))) << name;
  const std::vector<std::string> outside = PointsOutsideRanges(o.out_dir);
  EXPECT_TRUE(outside.empty()) << outside.size() << " points outside, e.g. " << outside.front();
  EXPECT_NE(ReadFile(o.out_dir / "figures" / "figure-maps.gp").find("W = 26 d, mu = 0: 1 run, 7 frames"),
            std::string::npos);
  EXPECT_NE(ReadFile(s.markdown).find("figure-prof.svg"), std::string::npos);
}

}  // namespace
}  // namespace granary::analysis

// write_report on campaigns whose runs have several outlets (thesis ch. 5 and 7) and on
// sweeps with zipped group axes (ch. 4): hand-written exit streams with known rates per
// outlet, so the per-outlet numbers, the x axis (outlet width or the gap L between two base
// outlets) and the fits have known answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

#include "analysis/report.h"
#include "analysis/report_document.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::CsvCell;
using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;

constexpr double kC = 0.8, kK = 1.5;
double Beverloo(double w) { return kC * std::pow(w - kK, 1.5); }

// Exit times of a steady stream at rate q in [t0, t1).
std::vector<double> Stream(double q, double t0, double t1) {
  std::vector<double> t;
  for (int i = 0; t0 + i / q < t1; ++i) t.push_back(t0 + i / q);
  return t;
}

nlohmann::json SiloSpec(const nlohmann::json& base_outlets,
                        const nlohmann::json& side_outlets = nlohmann::json::array()) {
  return {{"engine", "native"},
          {"silo", {{"width", 100}, {"base_outlets", base_outlets}, {"side_outlets", side_outlets}}},
          {"bodies", {{"count", 2000}}},
          {"discharge", {{"mode", "reinject"}, {"clog_window", 5.0}}}};
}

struct Campaign {
  CampaignInfo info;
  std::vector<RunRecord> runs;
  std::filesystem::path root;

  // A finished run whose outlet k has the exit times streams[k].
  void Add(const std::string& point_id, const nlohmann::json& point, const nlohmann::json& spec,
           const std::vector<std::vector<double>>& streams, double t_end) {
    std::vector<std::pair<double, int>> events;
    for (std::size_t k = 0; k < streams.size(); ++k)
      for (double t : streams[k]) events.emplace_back(t, static_cast<int>(k));
    std::sort(events.begin(), events.end());
    RunRecord r;
    r.point_id = point_id;
    r.replica = static_cast<int>(
        std::count_if(runs.begin(), runs.end(), [&](const RunRecord& x) { return x.point_id == point_id; }));
    r.run_id = point_id + "r" + std::to_string(r.replica);
    r.state = "done";
    r.engine = "native";
    r.point = point;
    r.spec = spec;
    r.run_dir = root / r.run_id;
    std::ostringstream ev;
    ev.precision(17);
    ev << "time,body,shape,mass,outlet\n";
    for (std::size_t i = 0; i < events.size(); ++i)
      ev << events[i].first << "," << i << ",dumbbell,2.0," << events[i].second << "\n";
    WriteFile(r.run_dir / "events.csv", ev.str());
    const int n = static_cast<int>(events.size());
    const nlohmann::json summary = {{"engine", "native"}, {"engine_version", "0.1.0"},  {"run_id", r.run_id},
                                    {"spec", spec},       {"end_reason", "time_limit"}, {"bodies", 2000},
                                    {"exited", n},        {"remaining", 2000},          {"t_end", t_end}};
    WriteFile(r.run_dir / "summary.json", summary.dump());
    WriteFile(r.run_dir / "run.json", spec.dump());
    runs.push_back(r);
  }

  std::filesystem::path Report(const std::filesystem::path& out, bool figures = false) const {
    ReportOptions opt;
    opt.out_dir = out;
    opt.figures = figures;
    WriteReport(info, runs, opt);
    return out;
  }
};

// The value of `column` in the CSV row whose first cell is `first`.
std::string CellOfRow(const std::string& csv, const std::string& first, int column) {
  std::istringstream in(csv);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(first + ",", 0) == 0) return CsvCell(line, {}, column);
  return "";
}

TEST(ReportOutlets, TwoBaseOutletsAgainstTheGapWithFlowPerOutlet) {
  // Ch. 5b: two outlets of width 8 whose centres are zipped to gaps L = 0, 4, 8; outlet 0
  // flows at 5 - L/4, outlet 1 at 3 (replicas at -+1%).
  TempDir dir;
  Campaign c;
  c.root = dir.Path() / "runs";
  c.info.name = "two-outlets";
  c.info.axes = {"/silo/base_outlets/0/center", "/silo/base_outlets/1/center"};
  for (double l : {0.0, 4.0, 8.0}) {
    const double centre = 4.0 + l / 2.0;
    const nlohmann::json point = {{"/silo/base_outlets/0/center", -centre}, {"/silo/base_outlets/1/center", centre}};
    const nlohmann::json spec = SiloSpec({{{"center", -centre}, {"width", 8}}, {{"center", centre}, {"width", 8}}});
    for (double f : {0.99, 1.01})
      c.Add("L" + FormatNumber(l), point, spec, {Stream(f * (5.0 - l / 4.0), 0.5, 60.0), Stream(f * 3.0, 0.7, 60.0)},
            60.0);
  }
  const auto out = c.Report(dir.Path() / "report");
  const std::string flow = ReadFile(out / "data" / "flow_rate.csv");
  EXPECT_EQ(flow.substr(0, flow.find('\n')),
            "point,q_count,q_count_se,q_count_n,q_mass,q_mass_se,q_mass_n,q_count_outlet0,q_count_outlet0_se,"
            "q_count_outlet0_n,q_count_outlet1,q_count_outlet1_se,q_count_outlet1_n");
  EXPECT_NEAR(std::stod(CsvCell(flow, {"L = 4,"}, 7)), 4.0, 1e-3);  // staircase sampled at all exits
  EXPECT_NEAR(std::stod(CsvCell(flow, {"L = 8,"}, 7)), 3.0, 1e-3);
  EXPECT_NEAR(std::stod(CsvCell(flow, {"L = 8,"}, 10)), 3.0, 1e-3);
  EXPECT_NEAR(std::stod(CsvCell(flow, {"L = 0,"}, 1)), 8.0, 0.1);  // merged streams: nearly q0 + q1
  // The figure of each outlet against L (edge-to-edge gap computed from the centres).
  const std::string outlet0 = ReadFile(out / "data" / "flow_rate_per_outlet--base_0.csv");
  EXPECT_EQ(outlet0.substr(0, outlet0.find('\n')), "L,Q,Q_se,n");
  EXPECT_NEAR(std::stod(CellOfRow(outlet0, "4", 1)), 4.0, 1e-3);
  EXPECT_NEAR(std::stod(CellOfRow(outlet0, "4", 2)), 0.04, 1e-3);  // se of the -+1% replicas
  EXPECT_EQ(std::count(outlet0.begin(), outlet0.end(), '\n'), 4);
  EXPECT_NEAR(std::stod(CellOfRow(ReadFile(out / "data" / "flow_rate_per_outlet--base_1.csv"), "8", 1)), 3.0, 1e-3);
  const std::string md = ReadFile(out / "report.md");
  EXPECT_NE(md.find("against L/d (gap between base outlets 0 and 1, edge to edge)"), std::string::npos);
  EXPECT_EQ(md.find("Fits of Q(W/d)"), std::string::npos);  // x is not a width: no Beverloo fits
}

TEST(ReportOutlets, FitsAndHeadlineUseTheSweptOutlet) {
  // Ch. 7: a small outlet of swept width W1 beside a large one that flows at 10 whatever W1;
  // Q through the small outlet follows Beverloo, the total does not.
  TempDir dir;
  Campaign c;
  c.root = dir.Path() / "runs";
  c.info.name = "small-beside-large";
  c.info.axes = {"/silo/base_outlets/0/width"};
  for (double w : {4.0, 6.0, 8.0, 10.0}) {
    const nlohmann::json spec = SiloSpec({{{"center", -20}, {"width", w}}, {{"center", 20}, {"width", 12}}});
    for (double f : {0.99, 1.01})
      c.Add("W" + FormatNumber(w), {{"/silo/base_outlets/0/width", w}}, spec,
            {Stream(f * Beverloo(w), 0.5, 60.0), Stream(10.0, 0.6, 60.0)}, 60.0);
  }
  const auto out = c.Report(dir.Path() / "report");
  const std::string fits = ReadFile(out / "data" / "flow_rate_fits.csv");
  EXPECT_NEAR(std::stod(CsvCell(fits, {"beverloo_2d", ",C,"}, 3)), kC, 1e-3);
  EXPECT_NEAR(std::stod(CsvCell(fits, {"beverloo_2d", ",k,"}, 3)), kK, 1e-3);
  const std::string headline = ReadFile(out / "data" / "flow_rate--Q.csv");
  EXPECT_NEAR(std::stod(CellOfRow(headline, "6", 1)), Beverloo(6.0), 1e-3);
  EXPECT_NE(ReadFile(out / "report.md").find("Flow rate Q through base 0 against W/d"), std::string::npos);
}

TEST(ReportOutlets, SideOutletWidthCountsAfterTheBaseOutlets) {
  // A base outlet (steady 5) and a lateral outlet of swept width: outlets are numbered base
  // first, so /silo/side_outlets/0/width is outlet 1, and the fit sees its Q.
  TempDir dir;
  Campaign c;
  c.root = dir.Path() / "runs";
  c.info.name = "side";
  c.info.axes = {"/silo/side_outlets/0/width"};
  for (double w : {5.0, 7.0, 9.0, 11.0}) {
    const nlohmann::json spec =
        SiloSpec({{{"center", 0}, {"width", 10}}}, {{{"wall", "right"}, {"bottom", 3.5}, {"width", w}}});
    for (double f : {0.99, 1.01})
      c.Add("W" + FormatNumber(w), {{"/silo/side_outlets/0/width", w}}, spec,
            {Stream(5.0, 0.5, 60.0), Stream(f * Beverloo(w), 0.6, 60.0)}, 60.0);
  }
  const auto out = c.Report(dir.Path() / "report");
  EXPECT_NEAR(std::stod(CsvCell(ReadFile(out / "data" / "flow_rate_fits.csv"), {"beverloo_2d", ",k,"}, 3)), kK, 1e-3);
  EXPECT_NE(ReadFile(out / "report.md").find("Q side 1 (right)"), std::string::npos);
}

TEST(ReportOutlets, AvalanchesAndIntermittencyOfOneOutletWhileTheOtherFlows) {
  // Outlet 0 flows at 2 from 0.5 to 10 (20 exits), is clogged 10 -> 20, flows 20..28; outlet
  // 1 never stops, so the merged stream has no avalanche but outlet 0 has one of 20 bodies.
  TempDir dir;
  Campaign c;
  c.root = dir.Path() / "runs";
  c.info.name = "intermittent";
  c.info.axes = {"/silo/base_outlets/0/width"};
  const nlohmann::json spec = SiloSpec({{{"center", -20}, {"width", 4}}, {{"center", 20}, {"width", 12}}});
  std::vector<double> small = Stream(2.0, 0.5, 10.01), late = Stream(2.0, 20.0, 28.01);
  small.insert(small.end(), late.begin(), late.end());
  c.Add("W4", {{"/silo/base_outlets/0/width", 4}}, spec, {small, Stream(4.0, 0.25, 30.0)}, 30.0);
  const auto out = c.Report(dir.Path() / "report");
  const std::string av = ReadFile(out / "data" / "avalanches_per_outlet.csv");
  EXPECT_EQ(CsvCell(av, {"W_1 = 4", "base 0"}, 2), "20");
  EXPECT_EQ(CsvCell(av, {"W_1 = 4", "base 0"}, 4), "1");  // n
  EXPECT_EQ(CsvCell(av, {"W_1 = 4", "base 1"}, 2), "no avalanche");
  EXPECT_FALSE(std::filesystem::exists(out / "data" / "avalanches.csv"));  // the merged stream never stopped
  const std::string inter = ReadFile(out / "data" / "intermittency.csv");
  EXPECT_EQ(CsvCell(inter, {"W_1 = 4", "base 0"}, 5), "10");  // t_c: 10 -> 20
  EXPECT_EQ(CsvCell(inter, {"W_1 = 4", "base 0"}, 7), "1");
  EXPECT_DOUBLE_EQ(std::stod(CsvCell(inter, {"W_1 = 4", "base 0"}, 8)), 1.0 / 30.0);
  EXPECT_EQ(CsvCell(inter, {"W_1 = 4", "base 1"}, 9), "0");  // unclogs
}

TEST(ReportOutlets, FitsPerGroupOfZippedAxesAndSmoothCurves) {
  // Ch. 4: the two species fractions are zipped (X and 1 - X); Q = C(X) (W - 1.5)^1.5 with
  // C(X) = 0.8 / (1 + X/2). The parameter trend is drawn against the first zipped axis, and
  // each fitted curve is the function sampled over the whole plotted range of W.
  TempDir dir;
  Campaign c;
  c.root = dir.Path() / "runs";
  c.info.name = "zipped";
  c.info.axes = {"/silo/base_outlets/0/width", "/bodies/species/0/fraction", "/bodies/species/1/fraction"};
  for (double x : {0.0, 0.5, 1.0}) {
    for (double w : {8.0, 12.0, 16.0, 20.0}) {
      const double lo_w = x == 1.0 ? w + 4.0 : w;  // the X = 1 group is measured at 12..24
      nlohmann::json spec = SiloSpec({{{"center", 0}, {"width", lo_w}}});
      spec["bodies"]["species"] = {{{"name", "dumbbell"}, {"shape", "dumbbell"}, {"fraction", x}},
                                   {{"name", "disc"}, {"shape", "disc"}, {"fraction", 1 - x}}};
      c.Add("W" + FormatNumber(lo_w) + "X" + FormatNumber(x),
            {{"/silo/base_outlets/0/width", lo_w},
             {"/bodies/species/0/fraction", x},
             {"/bodies/species/1/fraction", 1 - x}},
            spec, {Stream(kC / (1.0 + x / 2.0) * std::pow(lo_w - kK, 1.5), 0.5, 40.0)}, 40.0);
    }
  }
  const auto out = c.Report(dir.Path() / "report", true);
  const std::string trend = ReadFile(out / "data" / "fit_parameters_beverloo_2d--C.csv");
  EXPECT_EQ(trend.substr(0, trend.find('\n')), "species.0.fraction,C,C_se,ci_low,ci_high");
  EXPECT_NEAR(std::stod(CellOfRow(trend, "0.5", 1)), 0.64, 1e-3);
  EXPECT_EQ(std::count(trend.begin(), trend.end(), '\n'), 4);
  // The parameters are drawn against the group axis by its name, not its JSON path.
  const std::string trend_gp = ReadFile(out / "figures" / "fit_parameters_beverloo_2d.gp");
  EXPECT_NE(trend_gp.find("set xlabel 'dumbbell fraction X_db'"), std::string::npos) << trend_gp;
  // Tables and keys name the points by the thesis' symbols, the W axis in words; the curves'
  // files are named after their keys, short ASCII.
  EXPECT_NE(CsvCell(ReadFile(out / "data" / "flow_rate.csv"), {"W = 8, X_db = 0.5, X_d = 0.5"}, 1), "");
  const std::string flow_gp = ReadFile(out / "figures" / "flow_rate.gp");
  EXPECT_NE(flow_gp.find("set xlabel 'W/d (outlet width W)'"), std::string::npos) << flow_gp;
  EXPECT_NE(flow_gp.find("title 'X_db = 0.5, X_d = 0.5'"), std::string::npos) << flow_gp;
  EXPECT_EQ(flow_gp.find("species.0"), std::string::npos) << flow_gp;
  // The data of the three groups, then the Beverloo curve of each.
  const std::string curve = ReadFile(out / "data" / "flow_rate--beverloo_2d_X_db_0_X_d_1.csv");
  ASSERT_EQ(curve.substr(0, curve.find('\n')), "W,Q_fit");
  EXPECT_EQ(std::count(curve.begin(), curve.end(), '\n'), 202);  // header + 201 samples
  EXPECT_EQ(CellOfRow(curve, "8", 0), "8");
  EXPECT_NEAR(std::stod(CellOfRow(curve, "24", 1)), Beverloo(24.0), 1e-3);  // beyond its own widths
  EXPECT_NEAR(std::stod(CellOfRow(curve, "14", 1)), Beverloo(14.0), 1e-3);  // between measured widths
}

}  // namespace
}  // namespace granary::analysis

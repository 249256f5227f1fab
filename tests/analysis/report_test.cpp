// write_report and the campaign analysis on a synthetic campaign: hand-written run
// directories whose exit streams have known flow rates Q(W) = 0.8 (W - 1.5)^(3/2), one
// frame file with a known packing fraction and temperature, a failed and a planned run.
#include "analysis/report.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <sstream>

#include "analysis/options.h"
#include "analysis/registry.h"
#include "analysis/report_document.h"
#include "test_util.h"

namespace granary::analysis {
namespace {

using testing::CsvCell;
using testing::ReadFile;
using testing::TempDir;
using testing::WriteFile;

constexpr double kC = 0.8, kK = 1.5;
double QOf(double w) { return kC * std::pow(w - kK, 1.5); }

nlohmann::json SpecFor(double w) {
  return {{"engine", "native"},
          {"silo", {{"width", 100}, {"base_outlets", {{{"center", 0.0}, {"width", w}}}}}},
          {"bodies", {{"count", 2000}, {"density", 1.0}}},
          {"contact", {{"tangential_cap", "lammps"}}},
          {"discharge", {{"mode", "remove"}, {"clog_window", 5.0}}}};
}

// A run with n exits at a constant rate q (exact slope), mass 2 each.
void WriteRun(const std::filesystem::path& dir, double w, double q, int n, const std::string& id) {
  std::ostringstream ev;
  ev.precision(17);
  ev << "time,body,shape,mass,outlet\n";
  for (int i = 1; i <= n; ++i) ev << (i / q) << "," << i << ",dumbbell,2.0,0\n";
  WriteFile(dir / "events.csv", ev.str());
  nlohmann::json summary = {{"engine", "native"},
                            {"engine_version", "0.1.0"},
                            {"granary_commit", "abc123"},
                            {"run_id", id},
                            {"spec", SpecFor(w)},
                            {"end_reason", "time_limit"},
                            {"bodies", 2000},
                            {"exited", n},
                            {"remaining", 2000 - n},
                            {"exits_per_outlet", {n}},
                            {"t_end", n / q + 1.0}};
  WriteFile(dir / "summary.json", summary.dump());
  WriteFile(dir / "run.json", SpecFor(w).dump());
  WriteFile(dir / "DONE", "");
}

// Two frames: a dumbbell (discs at (0,1), (2,1), v = (0,-1)) and a disc at (-3,1), v = (0,-3),
// all radius 0.5, inside the ch. 4 region of W = 10 (|x| < 6.41, y < 7.07).
void WriteFrames(const std::filesystem::path& dir) {
  std::string f;
  for (int k = 0; k < 2; ++k) {
    f += "ITEM: TIMESTEP\n" + std::to_string(100000 * (k + 1)) + "\nITEM: TIME\n" + std::to_string(10.0 * (k + 1)) +
         "\nITEM: NUMBER OF ATOMS\n3\nITEM: BOX BOUNDS ff ff pp\n-50 50\n-5 160\n-0.5 0.5\n"
         "ITEM: ATOMS id mol type x y z radius mass vx vy vz omegaz\n"
         "1 0 1 0 1 0 0.5 0.7853981633974483 0 -1 0 0\n"
         "2 0 1 2 1 0 0.5 0.7853981633974483 0 -1 0 0\n"
         "3 1 2 -3 1 0 0.5 0.7853981633974483 0 -3 0 0\n";
  }
  WriteFile(dir / "frames.dump", f);
}

struct Campaign {
  CampaignInfo info;
  std::vector<RunRecord> runs;
};

Campaign MakeCampaign(const std::filesystem::path& root) {
  Campaign c;
  c.info.name = "synthetic";
  c.info.spec_hash = "hash42";
  c.info.axes = {"/silo/base_outlets/0/width"};
  c.info.granary_version = "0.1.0";
  c.info.git_commit = "abc123";
  const double widths[] = {10, 14, 18, 22};
  for (double w : widths) {
    for (int rep = 0; rep < 2; ++rep) {
      RunRecord r;
      r.point_id = "W" + std::to_string(static_cast<int>(w));
      r.run_id = r.point_id + "r" + std::to_string(rep);
      r.replica = rep;
      r.engine = "native";
      r.state = "done";
      r.point = {{"/silo/base_outlets/0/width", w}};
      r.spec = SpecFor(w);
      r.run_dir = root / r.run_id;
      // Replicas at (1 -+ 1%) of Q(W): mean Q(W), se 1% of Q.
      WriteRun(r.run_dir, w, QOf(w) * (rep == 0 ? 0.99 : 1.01), 1000, r.run_id);
      if (w == 10 && rep == 0) WriteFrames(r.run_dir);
      c.runs.push_back(r);
    }
  }
  RunRecord failed = c.runs.front();
  failed.run_id = "W10r2";
  failed.replica = 2;
  failed.state = "failed";
  failed.failure = "engine exited with status 3: overlap too large";
  failed.run_dir = root / "W10r2";
  c.runs.push_back(failed);
  RunRecord planned = c.runs.front();
  planned.run_id = "W10r3";
  planned.replica = 3;
  planned.state = "planned";
  planned.run_dir = root / "W10r3";
  c.runs.push_back(planned);
  return c;
}

TEST(CampaignAnalysis, FlowRateAndRegionFromRunDirectories) {
  TempDir dir;
  const Campaign c = MakeCampaign(dir.Path());
  const AnalysisSetup setup = SetupAnalyses(c.info.spec);
  const auto a = AnalyseCampaign(c.info, c.runs, setup);
  ASSERT_EQ(a->view.points.size(), 4u);
  EXPECT_EQ(a->view.points[0].id, "W10");
  EXPECT_EQ(a->view.points[0].runs.size(), 2u);  // the failed and planned runs are not analysed
  auto m = [&](std::size_t p, const std::string& name) {
    const std::vector<PointMetric> all = a->AllPointMetrics(p);
    const PointMetric* x = FindMetric(all, name);
    return x ? *x : PointMetric{};
  };
  EXPECT_EQ(m(0, "q_count").n, 2);
  EXPECT_NEAR(m(0, "q_count").mean, QOf(10), 1e-9 * QOf(10));
  EXPECT_NEAR(m(0, "q_count").se, 0.01 * QOf(10), 1e-9 * QOf(10));
  EXPECT_NEAR(m(3, "q_mass").mean, 2.0 * QOf(22), 1e-9 * QOf(22));
  // Region: three discs of radius 0.5 inside (W + 2 sqrt2) x 5 sqrt2.
  const double area = (10.0 + 2.0 * std::numbers::sqrt2) * 5.0 * std::numbers::sqrt2;
  EXPECT_EQ(m(0, "phi").n, 1);
  EXPECT_NEAR(m(0, "phi").mean, 3.0 * std::numbers::pi * 0.25 / area, 1e-12);
  EXPECT_NEAR(m(0, "tg_translational").mean, 0.5, 1e-12);  // v_y = -1, -3 about -2
  EXPECT_EQ(m(1, "phi").n, 0);
  EXPECT_NEAR(m(0, "v_max").mean, 3.0, 1e-12);  // both bodies within 2 d of the base
  // The runs reached their time limit flowing: neither clogged nor discharged, so no Psi
  // (the remaining 1000 are not a stagnant count), and the note says why.
  EXPECT_EQ(m(0, "clogged_runs").mean, 0.0);
  EXPECT_EQ(m(0, "unfinished_runs").mean, 2.0);
  EXPECT_EQ(m(0, "psi").n, 0);
  EXPECT_TRUE(std::isnan(m(0, "psi").mean));
  EXPECT_NE(m(0, "psi").note.find("left out replicas 0, 1: neither clogged nor discharged"), std::string::npos);
  EXPECT_EQ(m(0, "avalanche_size").n, 0);
  // The per-run metrics of a run.
  const std::vector<Metric> run0 = a->RunMetrics(0, a->view.points[0].runs[0]);
  ASSERT_NE(FindMetric(run0, "q_count"), nullptr);
  EXPECT_EQ(FindMetric(run0, "q_count")->unit, "bodies/sqrt(d/g)");
}

TEST(WriteReport, SyntheticCampaign) {
  TempDir dir;
  const Campaign c = MakeCampaign(dir.Path() / "runs");
  ReportOptions opt;
  opt.out_dir = dir.Path() / "report";
  opt.figures = std::system("command -v gnuplot > /dev/null 2>&1") == 0;
  Campaign with_model = c;
  with_model.info.spec = {{"report",
                           {{"flow",
                             {{"models",
                               {{{"name", "power_law"},
                                 {"expression", "a * x^b"},
                                 {"variable", "x"},
                                 {"initial", {{"a", 1.0}, {"b", 1.5}}}},
                                // 4 widths for 4 parameters: not fitted
                                {{"name", "four"},
                                 {"expression", "a * x^b + c + e * x"},
                                 {"variable", "x"},
                                 {"initial", {{"a", 1.0}, {"b", 1.5}}}}}}}}}}};
  const ReportSummary s = WriteReport(with_model.info, c.runs, opt);
  EXPECT_EQ(s.runs_used, 8);
  EXPECT_EQ(s.runs_missing, 1);
  EXPECT_EQ(s.runs_failed, 1);
  ASSERT_TRUE(std::filesystem::exists(s.markdown));
  ASSERT_TRUE(std::filesystem::exists(s.html));

  const std::string md = ReadFile(s.markdown);
  EXPECT_NE(md.find("8 used"), std::string::npos);
  EXPECT_NE(md.find("overlap too large"), std::string::npos);  // failure reason
  EXPECT_NE(md.find("Flow rate"), std::string::npos);
  EXPECT_EQ(md.find("Clogging index"), std::string::npos);  // no clogs: no section
  EXPECT_EQ(md.find("Avalanche"), std::string::npos);

  // Flow-rate table: mean, se and n in columns of their own, to full precision.
  const std::string flow = ReadFile(opt.out_dir / "data" / "flow_rate.csv");
  EXPECT_EQ(flow.substr(0, flow.find('\n')), "point,q_count,q_count_se,q_count_n,q_mass,q_mass_se,q_mass_n");
  EXPECT_NEAR(std::stod(CsvCell(flow, {"W = 14"}, 1)), QOf(14), 1e-12 * QOf(14));
  EXPECT_NEAR(std::stod(CsvCell(flow, {"W = 14"}, 2)), 0.01 * QOf(14), 1e-9 * QOf(14));
  EXPECT_EQ(CsvCell(flow, {"W = 14"}, 3), "2");
  EXPECT_NE(md.find(FormatMeanSe(QOf(14), 0.01 * QOf(14), 2)), std::string::npos);

  // Beverloo 2-D recovers the generating C and k (the replica means lie on the curve).
  const std::string fits = ReadFile(opt.out_dir / "data" / "flow_rate_fits.csv");
  EXPECT_NEAR(std::stod(CsvCell(fits, {"beverloo_2d", ",C,"}, 3)), kC, 1e-3);
  EXPECT_NEAR(std::stod(CsvCell(fits, {"beverloo_2d", ",k,"}, 3)), kK, 1e-3);
  EXPECT_NE(CsvCell(fits, {"power_law", ",b,"}, 3), "");
  EXPECT_EQ(CsvCell(fits, {"beverloo_2d", ",C,"}, 10), "good");
  // A model with as many parameters as points: not fitted, and its start values (b = 1.5) are
  // not shown as results.
  EXPECT_EQ(CsvCell(fits, {"four", ",b,"}, 3), "nan");  // numeric CSV: missing is nan
  EXPECT_EQ(CsvCell(fits, {"four", ",b,"}, 10), "not fitted: 4 points for 4 parameters (needs at least 5)");

  // Provenance: engine version, commit and tangential cap.
  const std::string prov = ReadFile(opt.out_dir / "data" / "provenance.csv");
  EXPECT_NE(prov.find("native,0.1.0,abc123,lammps,8"), std::string::npos) << prov;

  // Region statistics of the run with frames; velocity profile section exists.
  EXPECT_TRUE(std::filesystem::exists(opt.out_dir / "data" / "region.csv"));
  EXPECT_NE(md.find("Velocity profiles"), std::string::npos);
  // The figure data is there even without gnuplot.
  const std::string series = ReadFile(opt.out_dir / "data" / "flow_rate--Q.csv");
  EXPECT_EQ(series.substr(0, series.find('\n')), "W,Q,Q_se,n");

  const std::string html = ReadFile(s.html);
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  if (opt.figures) {
    EXPECT_TRUE(std::filesystem::exists(opt.out_dir / "figures" / "flow_rate.svg"));
    // Velocity profiles carry their replica standard errors as error bars.
    EXPECT_NE(ReadFile(opt.out_dir / "figures" / "velocity_profile_vy.gp").find("yerrorlines"), std::string::npos);
    EXPECT_NE(html.find("<svg"), std::string::npos);
  }
  if (const char* keep = std::getenv("GRANARY_REPORT_DEMO_DIR")) {
    opt.out_dir = keep;
    WriteReport(c.info, c.runs, opt);
  }
}

// A run with the given exit times, mode and end.
void WriteRunTimes(const std::filesystem::path& dir, const std::vector<double>& times, const std::string& mode,
                   const std::string& end, int bodies, double t_end, double w) {
  std::ostringstream ev;
  ev.precision(17);
  ev << "time,body,shape,mass,outlet\n";
  for (std::size_t i = 0; i < times.size(); ++i) ev << times[i] << "," << i << ",dumbbell,1.5707963267948966,0\n";
  WriteFile(dir / "events.csv", ev.str());
  nlohmann::json spec = SpecFor(w);
  spec["discharge"]["mode"] = mode;
  spec["contact"]["tangential_cap"] = "liggghts";
  const int exited = static_cast<int>(times.size());
  const nlohmann::json summary = {
      {"engine", "liggghts"}, {"engine_version", "3.8.0"}, {"granary_commit", "def456"}, {"spec", spec},
      {"end_reason", end},    {"bodies", bodies},          {"exited", exited},           {"remaining", bodies - exited},
      {"t_end", t_end}};
  WriteFile(dir / "summary.json", summary.dump());
  WriteFile(dir / "run.json", spec.dump());
  WriteFile(dir / "DONE", "");
}

std::vector<double> Steady(double t0, double dt, int n) {
  std::vector<double> t;
  for (int i = 0; i < n; ++i) t.push_back(t0 + dt * i);
  return t;
}

TEST(WriteReport, ClogSectionsWithKnownNumbers) {
  TempDir dir;
  CampaignInfo info;
  info.name = "clogs";
  info.axes = {"/silo/base_outlets/0/width"};
  std::vector<RunRecord> runs;
  auto add = [&](const std::string& id, double w, int replica) -> const std::filesystem::path& {
    RunRecord r;
    r.run_id = id;
    r.point_id = "W" + FormatNumber(w);
    r.replica = replica;
    r.state = "done";
    r.engine = "liggghts";
    r.point = {{"/silo/base_outlets/0/width", w}};
    r.spec = SpecFor(w);
    r.run_dir = dir.Path() / "runs" / id;
    runs.push_back(r);
    return runs.back().run_dir;
  };
  // W = 6, remove mode: clogs after 300 exits; clogs after 50 (discarded for Psi); discharges
  // leaving 40 in the stagnant zones. Psi = ((700 - 40)/960 + 0)/2; avalanches 300 and 50.
  WriteRunTimes(add("a", 6, 0), Steady(0.1, 0.1, 300), "remove", "clogged", 1000, 35.0, 6);
  WriteRunTimes(add("b", 6, 1), Steady(0.1, 0.1, 50), "remove", "clogged", 1000, 10.0, 6);
  WriteRunTimes(add("c", 6, 2), Steady(0.1, 0.1, 960), "remove", "discharged", 1000, 96.5, 6);
  // W = 8, reinject: flow 0.5..10, clogged 10 -> 20, flow 20..25, end at 26 while flowing.
  std::vector<double> t = Steady(0.5, 0.5, 20);
  for (double x : Steady(20.0, 0.5, 11)) t.push_back(x);
  WriteRunTimes(add("d", 8, 0), t, "reinject", "time_limit", 1000, 26.0, 8);

  ReportOptions opt;
  opt.out_dir = dir.Path() / "report";
  opt.figures = false;
  WriteReport(info, runs, opt);
  const std::string md = ReadFile(opt.out_dir / "report.md");
  EXPECT_NE(md.find("Clogging index"), std::string::npos);
  EXPECT_NE(md.find("Avalanche sizes"), std::string::npos);
  EXPECT_NE(md.find("Flowing and clogged times"), std::string::npos);

  const std::string psi = ReadFile(opt.out_dir / "data" / "clogging_index.csv");
  EXPECT_EQ(
      psi.substr(0, psi.find('\n')),
      "point,psi,psi_se,psi_n,clogged_runs,discharged_runs,discarded_runs,unfinished_runs,n_stagnant,psi_range,note");
  EXPECT_NEAR(std::stod(CsvCell(psi, {"W = 6"}, 1)), 660.0 / 960.0 / 2.0, 1e-15);
  EXPECT_NEAR(std::stod(CsvCell(psi, {"W = 6"}, 2)), 660.0 / 960.0 / 2.0, 1e-15);
  EXPECT_EQ(CsvCell(psi, {"W = 6"}, 3), "2");
  EXPECT_EQ(CsvCell(psi, {"W = 6"}, 4), "1");   // clogged
  EXPECT_EQ(CsvCell(psi, {"W = 6"}, 5), "1");   // discharged
  EXPECT_EQ(CsvCell(psi, {"W = 6"}, 6), "1");   // discarded
  EXPECT_EQ(CsvCell(psi, {"W = 6"}, 8), "40");  // N_u

  const std::string av = ReadFile(opt.out_dir / "data" / "avalanches.csv");
  EXPECT_EQ(CsvCell(av, {"W = 6"}, 1), "175");
  EXPECT_EQ(CsvCell(av, {"W = 6"}, 2), "125");
  EXPECT_EQ(CsvCell(av, {"W = 8"}, 1), "20");
  EXPECT_EQ(CsvCell(av, {"W = 8"}, 2), "nan");  // one avalanche: no se
  EXPECT_EQ(CsvCell(av, {"W = 8"}, 3), "1");

  const std::string inter = ReadFile(opt.out_dir / "data" / "intermittency.csv");
  EXPECT_EQ(CsvCell(inter, {"W = 8", "base 0"}, 2), "10");  // t_f: 0 -> 10
  EXPECT_EQ(CsvCell(inter, {"W = 8", "base 0"}, 5), "10");  // t_c: 10 -> 20
  EXPECT_DOUBLE_EQ(std::stod(CsvCell(inter, {"W = 8", "base 0"}, 8)), 1.0 / 26.0);
  // The figure data: t_f of outlet 0 at W = 8 (W = 6 runs stopped on clogs: no complete t_c).
  const std::string tf = ReadFile(opt.out_dir / "data" / "intermittency_times--t_f_base_0.csv");
  EXPECT_EQ(tf.substr(0, tf.find('\n')), "W,t_f,t_f_se,n");
  EXPECT_NE(tf.find("\n8,10,nan,1\n"), std::string::npos) << tf;

  const std::string prov = ReadFile(opt.out_dir / "data" / "provenance.csv");
  EXPECT_NE(prov.find("liggghts,3.8.0,def456,liggghts,4"), std::string::npos) << prov;
}

TEST(WriteReport, FitsPerGroupOfAnotherAxis) {
  // Q = C(X) (W - 1.5)^1.5 with C(X) = 0.8 / (1 + X/2) (the ch. 4 collapse): one fit per X.
  TempDir dir;
  CampaignInfo info;
  info.name = "groups";
  info.axes = {"/silo/base_outlets/0/width", "/bodies/species/0/fraction"};
  std::vector<RunRecord> runs;
  for (double x : {0.0, 0.5, 1.0}) {
    for (double w : {8.0, 12.0, 16.0, 20.0}) {
      RunRecord r;
      r.point_id = "W" + FormatNumber(w) + "X" + FormatNumber(x);
      r.run_id = r.point_id;
      r.state = "done";
      r.point = {{"/silo/base_outlets/0/width", w}, {"/bodies/species/0/fraction", x}};
      r.spec = SpecFor(w);
      r.run_dir = dir.Path() / r.run_id;
      WriteRun(r.run_dir, w, kC / (1.0 + x / 2.0) * std::pow(w - kK, 1.5), 600, r.run_id);
      runs.push_back(r);
    }
  }
  ReportOptions opt;
  opt.out_dir = dir.Path() / "report";
  opt.figures = false;
  WriteReport(info, runs, opt);
  const std::string fits = ReadFile(opt.out_dir / "data" / "flow_rate_fits.csv");
  EXPECT_NEAR(std::stod(CsvCell(fits, {"X_0 = 0.5", "beverloo_2d", ",C,"}, 3)), 0.64, 1e-3);
  EXPECT_NEAR(std::stod(CsvCell(fits, {"X_0 = 1", "beverloo_2d", ",k,"}, 3)), kK, 1e-3);
  // The parameter trend against the other axis: C(X) for X = 0, 0.5, 1.
  const std::string trend = ReadFile(opt.out_dir / "data" / "fit_parameters_beverloo_2d--C.csv");
  EXPECT_EQ(trend.substr(0, trend.find('\n')), "species.0.fraction,C,C_se,ci_low,ci_high");
  EXPECT_NEAR(std::stod(CsvCell(trend, {"0.5,"}, 1)), 0.64, 1e-3);
  EXPECT_EQ(std::count(trend.begin(), trend.end(), '\n'), 4);
  if (const char* keep = std::getenv("GRANARY_REPORT_DEMO_DIR2")) {
    opt.out_dir = keep;
    opt.figures = true;
    WriteReport(info, runs, opt);
  }
}

// The message of the OptionError that reading `report` throws, or "".
std::string ErrorOf(const nlohmann::json& report) {
  try {
    SetupAnalyses({{"report", report}});
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ReportSpec, OptionsFromCampaignSpec) {
  const AnalysisSetup setup = SetupAnalyses({{"report",
                                              {{"region", "ch3"},
                                               {"clog_gap", 2.5},
                                               {"window", {{"start_time", 4}}},
                                               {"profile", {{"bins", 8}}},
                                               {"frame_stride", 2}}}});
  EXPECT_DOUBLE_EQ(setup.pass.clog_gap, 2.5);
  EXPECT_DOUBLE_EQ(setup.pass.window.start_time, 4.0);
  EXPECT_EQ(setup.pass.frame_stride, 2);
  for (const auto& a : setup.analyses) {
    if (a->Key() == "region") {
      EXPECT_EQ(a->RunOptions(), (nlohmann::json{{"pad", 2.0}, {"height", 10.0}}));
    }
    if (a->Key() == "profile") {
      EXPECT_EQ(a->RunOptions()["bins"], 8);
    }
  }
  EXPECT_EQ(ErrorOf({{"window", {{"start_fraction", 1.5}}}}),
            "/report/window/start_fraction: must be in [0, 1] (got 1.5)");
  EXPECT_EQ(ErrorOf({{"flow", {{"models", {{{"expression", "a * (W"}, {"variable", "W"}}}}}}}),
            "/report/flow/models/0/expression: model 'a * (W': position 7: expected ')'");
  EXPECT_EQ(ErrorOf({{"flow", {{"model", 1}}}}), "/report/flow/model: unknown key (known: models) (got 1)");
  EXPECT_EQ(ErrorOf({{"profile", {{"bins", 0}}}}), "/report/profile/bins: must be in [1, 1e+06] (got 0)");
  EXPECT_EQ(ErrorOf({{"window", {{"min_exits_before_clog", 2.5}}}}),
            "/report/window/min_exits_before_clog: must be an integer (got 2.5)");
  EXPECT_EQ(ErrorOf({{"region", "ch5"}}),
            "/report/region: must be \"ch3\", \"ch4\", \"ch6\" or {\"pad\": .., \"height\": .., \"unit\": \"d\" or "
            "\"D_eq\"} (got \"ch5\")");
  // Keys that moved to their analysis say where to.
  EXPECT_EQ(ErrorOf({{"models", nlohmann::json::array()}}),
            "/report/models: fit models are options of the flow analysis now: /report/flow/models (got [])");
  EXPECT_EQ(ErrorOf({{"min_exits_before_clog", 5}}),
            "/report/min_exits_before_clog: moved to /report/window/min_exits_before_clog (got 5)");
  // The clogging index discards by the flow window's start-up clog rule: one threshold.
  EXPECT_EQ(ErrorOf({{"clogging_index", {{"min_exits_before_clog", 5}}}}),
            "/report/clogging_index/min_exits_before_clog: moved to /report/window/min_exits_before_clog (got 5)");
  // An unknown key lists the known ones: the pass' and every registered analysis', in the
  // registry's order.
  const std::string unknown = ErrorOf({{"regoin", "ch3"}});
  EXPECT_NE(unknown.find("/report/regoin: unknown key (known: window, clog_gap, frame_stride, max_frames, figures, "),
            std::string::npos)
      << unknown;
  std::size_t at = 0;
  const std::vector<AnalysisEntry> rows = RegisteredAnalyses();
  for (const AnalysisEntry& e : rows) {
    const std::size_t found = unknown.find(" " + e.key + (&e == &rows.back() ? ")" : ","), at);
    EXPECT_NE(found, std::string::npos) << e.key << " in " << unknown;
    if (found != std::string::npos) at = found;
  }
}

TEST(WriteReport, EmptyCampaignStillWritesReport) {
  TempDir dir;
  CampaignInfo info;
  info.name = "empty";
  ReportOptions opt;
  opt.out_dir = dir.Path() / "r";
  opt.figures = false;
  const ReportSummary s = WriteReport(info, {}, opt);
  EXPECT_EQ(s.runs_used, 0);
  const std::string md = ReadFile(s.markdown);
  EXPECT_NE(md.find("0 runs in the campaign"), std::string::npos);
  EXPECT_NE(md.find("figures were switched off"), std::string::npos);
  opt.out_dir.clear();
  EXPECT_THROW(WriteReport(info, {}, opt), std::invalid_argument);
}

}  // namespace
}  // namespace granary::analysis

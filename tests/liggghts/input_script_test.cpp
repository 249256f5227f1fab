// LIGGGHTS input generation: geometry, the contact-law mapping, body templates against the
// native engine's masses and inertias, and that no spec string reaches the scripts.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "silo/shapes.h"
#include "liggghts/input_script.h"

namespace granary::liggghts {
namespace {

using nlohmann::json;

RunSpec Spec(const json& overrides) {
  json j = {{"run_id", "t"}, {"seed", 11}, {"engine", "liggghts"}};
  j.merge_patch(overrides);
  return RunSpec::FromJson(j);
}

std::vector<double> NumbersAfter(const std::string& line, const std::string& keyword, int n) {
  std::istringstream in(line.substr(line.find(keyword) + keyword.size()));
  std::vector<double> v(static_cast<std::size_t>(n));
  for (double& x : v) in >> x;
  return v;
}

TEST(InputScript, BaseMeshesLeaveAGapAtEachOutletAndCountersStayBelowTheirOwnOutlet) {
  const RunSpec spec = Spec(
      {{"silo", {{"width", 60}, {"base_outlets", {{{"center", -10}, {"width", 6}}, {{"center", 8}, {"width", 4}}}}}}});
  const SiloSetup s = MakeSetup(spec);
  ASSERT_EQ(s.discharge_meshes.size(), 3u);
  EXPECT_DOUBLE_EQ(s.discharge_meshes[0].x0, -30);
  EXPECT_DOUBLE_EQ(s.discharge_meshes[0].x1, -13);
  EXPECT_DOUBLE_EQ(s.discharge_meshes[1].x0, -7);
  EXPECT_DOUBLE_EQ(s.discharge_meshes[1].x1, 6);
  EXPECT_DOUBLE_EQ(s.discharge_meshes[2].x0, 10);
  EXPECT_DOUBLE_EQ(s.discharge_meshes[2].x1, 30);
  ASSERT_EQ(s.counters.size(), 2u);
  EXPECT_EQ(s.outlets, 2);
  for (const Counter& c : s.counters) EXPECT_DOUBLE_EQ(c.mesh.y0, -spec.discharge.exit_distance);
  EXPECT_LE(s.counters[0].mesh.x1, s.counters[1].mesh.x0);  // never overlapping
  EXPECT_LT(s.counters[0].mesh.x0, -13);
  EXPECT_GT(s.counters[1].mesh.x1, 10);
  // The bed settles on a closed base.
  ASSERT_EQ(s.fill_meshes.size(), 1u);
  EXPECT_DOUBLE_EQ(s.fill_meshes[0].x0, -30);
  EXPECT_DOUBLE_EQ(s.fill_meshes[0].x1, 30);
}

TEST(InputScript, ASideOutletTurnsItsWallIntoMeshPiecesAroundTheHole) {
  const RunSpec spec = Spec({{"silo",
                              {{"width", 40},
                               {"base_outlets", json::array()},
                               {"side_outlets", {{{"wall", "right"}, {"bottom", 3}, {"width", 8}}}}}},
                             {"discharge", {{"mode", "remove"}}}});
  const SiloSetup s = MakeSetup(spec, 50.0);
  EXPECT_TRUE(s.wall_lo_primitive);
  EXPECT_FALSE(s.wall_hi_primitive);
  std::vector<MeshFile> right;
  for (const MeshFile& m : s.discharge_meshes)
    if (m.x0 == 20 && m.x1 == 20) right.push_back(m);
  ASSERT_EQ(right.size(), 2u);
  EXPECT_DOUBLE_EQ(right[0].y0, 0);
  EXPECT_DOUBLE_EQ(right[0].y1, 3);
  EXPECT_DOUBLE_EQ(right[1].y0, 11);
  EXPECT_LT(right[1].y1, 50.0);      // inside the bed's box
  ASSERT_EQ(s.counters.size(), 2u);  // outside the wall and below the base level
  for (const Counter& c : s.counters) EXPECT_EQ(c.outlet, 0);
  const std::string discharge = DischargeScript(spec, s, {});
  EXPECT_EQ(discharge.find("fix wall_hi"), std::string::npos);
  EXPECT_NE(discharge.find("fix wall_lo"), std::string::npos);
  // While the bed settles the silo is closed: both walls.
  const std::string bed = BedScript(spec, s);
  EXPECT_NE(bed.find("fix wall_hi"), std::string::npos);
}

TEST(InputScript, ReinjectWithASideOutletIsASpecErrorNamingTheMode) {
  const json side = {{"silo", {{"width", 40}, {"side_outlets", {{{"wall", "left"}, {"bottom", 3}, {"width", 8}}}}}},
                     {"discharge", {{"mode", "reinject"}}}};
  // Refused when a LIGGGHTS run is planned (the run spec's validation) ...
  try {
    Spec(side);
    FAIL() << "expected a SpecError";
  } catch (const SpecError& e) {
    EXPECT_EQ(e.Path(), "/discharge/mode");
    EXPECT_NE(e.Message().find("remove"), std::string::npos);
  }
  // ... and by the input generator, whatever engine the spec names.
  json native = side;
  native["engine"] = "native";
  try {
    MakeSetup(Spec(native));
    FAIL() << "expected a SpecError";
  } catch (const SpecError& e) {
    EXPECT_EQ(e.Path(), "/discharge/mode");
  }
}

TEST(InputScript, ContactLawMapsOntoHertzStiffnessWithWallFriction) {
  const RunSpec spec =
      Spec({{"contact",
             {{"kn", 3e6},
              {"kt", 1e6},
              {"gamma_n", 500},
              {"gamma_t", 200},
              {"mu", 0.3},
              {"mu_wall", 0.7},
              {"clip_normal", true}}},
            {"bodies",
             {{"species", {{{"shape", "disc"}, {"fraction", 0.5}}, {{"shape", "dumbbell"}, {"fraction", 0.5}}}}}}});
  const SiloSetup s = MakeSetup(spec);
  EXPECT_EQ(s.wall_type, 3);
  const std::string bed = BedScript(spec, s);
  EXPECT_NE(bed.find("kn peratomtypepair 3 3000000 3000000 3000000 3000000 3000000 3000000 3000000 3000000 3000000"),
            std::string::npos);
  EXPECT_NE(bed.find("gammat peratomtypepair 3 200 200 200"), std::string::npos);
  // Body-body pairs mu, any pair with the wall type mu_wall.
  EXPECT_NE(
      bed.find("coefficientFriction peratomtypepair 3 0.29999999999999999 0.29999999999999999 0.69999999999999996 "
               "0.29999999999999999 0.29999999999999999 0.69999999999999996 0.69999999999999996 "
               "0.69999999999999996 0.69999999999999996"),
      std::string::npos);
  EXPECT_NE(bed.find("pair_style gran model hertz/stiffness tangential history tangential_damping on limitForce on"),
            std::string::npos);
  EXPECT_NE(bed.find("timestep 0.0001"), std::string::npos);
}

TEST(InputScript, ClumpTemplatesCarryTheNativeMassAndInertiaInEveryOrientation) {
  const RunSpec spec = Spec({{"bodies",
                              {{"count", 100},
                               {"species",
                                {{{"shape", "snowman"}, {"big_diameter", 1.6}, {"fraction", 0.5}},
                                 {{"shape", "rod"}, {"n", 4}, {"diameter", 0.707}, {"fraction", 0.5}}}}}}});
  const SiloSetup s = MakeSetup(spec);
  ASSERT_EQ(s.template_count, 12 + 6);  // snowmen over 360 degrees, rods over 180
  for (std::size_t k = 0; k < 2; ++k) {
    const silo::ShapeTemplate tp = silo::MakeTemplate(spec.bodies.species[k], 1.0, static_cast<int>(k));
    double own = 0;  // the spheres' own moments, sum 0.4 m r^2
    for (std::size_t i = 0; i < tp.r.size(); ++i) own += 0.4 * tp.disc_mass[i] * tp.r[i] * tp.r[i];
    int seen = 0;
    for (const std::string& line : s.template_lines) {
      if (line.find("atom_type " + std::to_string(k + 1) + " ") == std::string::npos) continue;
      ++seen;
      EXPECT_NEAR(NumbersAfter(line, " mass ", 1)[0], tp.mass, 1e-12);
      const std::vector<double> I = NumbersAfter(line, "inertia_tensor", 6);  // xx xy xz yy yz zz
      EXPECT_NEAR(I[5], tp.inertia, 1e-12);
      EXPECT_NEAR(I[0] + I[3], tp.inertia + own, 1e-9);  // perpendicular-axis theorem, any rotation
      EXPECT_GT(I[0] * I[3] - I[1] * I[1], 0);           // positive definite
      EXPECT_NE(line.find("fflag on on off tflag off off on"), std::string::npos);
    }
    EXPECT_EQ(seen, k == 0 ? 12 : 6);
  }
}

TEST(InputScript, DistributionWeightsAreMassBasedSoNumberFractionsComeOut) {
  const RunSpec spec =
      Spec({{"bodies",
             {{"species", {{{"shape", "disc"}, {"fraction", 0.25}}, {{"shape", "dumbbell"}, {"fraction", 0.75}}}}}}});
  const SiloSetup s = MakeSetup(spec);
  const std::string dist = s.template_lines.back();
  // 1 disc template (mass pi/4, weight 0.25 pi/4) and 6 dumbbell templates (mass pi/2, 0.75/6 each).
  std::smatch m;
  ASSERT_TRUE(std::regex_search(dist, m, std::regex(R"(tmpl_0 ([0-9.e-]+) tmpl_1 ([0-9.e-]+))")));
  const double disc = std::stod(m[1]), dumbbell = std::stod(m[2]);
  const double n_disc = disc / (std::numbers::pi / 4), n_dumbbell = 6 * dumbbell / (std::numbers::pi / 2);
  EXPECT_NEAR(n_disc / (n_disc + n_dumbbell), 0.25, 1e-12);
}

TEST(InputScript, NoStringFromTheSpecReachesTheScripts) {
  // Line breaks are a spec error in names; substitutions and commands are not.
  const std::string hostile = "x; shell touch /tmp/granary-pwned ${HOME} v_x $(id)";
  const RunSpec spec = Spec({{"run_id", "r$(touch /tmp/granary-pwned)"},
                             {"bodies", {{"species", {{{"shape", "dumbbell"}, {"name", hostile}}}}}}});
  const SiloSetup s = MakeSetup(spec);
  for (const std::string& script : {BedScript(spec, s), DischargeScript(spec, s, {})}) {
    EXPECT_EQ(script.find("pwned"), std::string::npos);
    EXPECT_EQ(script.find("shell"), std::string::npos);
    EXPECT_EQ(script.find("$("), std::string::npos);
    EXPECT_EQ(script.find("HOME"), std::string::npos);
  }
}

TEST(InputScript, SeedsArePrimesAboveTenThousandAndReproducible) {
  for (int salt = 0; salt < 20; ++salt) {
    const long long p = PrimeSeed(42, salt);
    EXPECT_GT(p, 10000);
    for (long long d = 2; d * d <= p; ++d) ASSERT_NE(p % d, 0) << p;
    EXPECT_EQ(p, PrimeSeed(42, salt));
  }
  EXPECT_NE(PrimeSeed(42, 0), PrimeSeed(42, 1));
  EXPECT_NE(PrimeSeed(42, 0), PrimeSeed(43, 0));
}

}  // namespace
}  // namespace granary::liggghts

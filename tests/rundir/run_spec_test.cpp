// Tests of the run spec parser (src/rundir/run_spec.cpp): defaults, canonical JSON and one
// test per class of error, each asserting the exact message.
#include "rundir/run_spec.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <regex>

namespace granary {
namespace {

using nlohmann::json;

std::string ErrorOf(const json& j) {
  try {
    RunSpec::FromJson(j);
  } catch (const SpecError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(RunSpecTest, EmptyObjectTakesDefaults) {
  const RunSpec s = RunSpec::FromJson(json::object());
  EXPECT_EQ(s.bodies.count, 1000);
  ASSERT_EQ(s.bodies.species.size(), 1u);
  EXPECT_EQ(s.bodies.species[0].shape, Shape::kDumbbell);
  EXPECT_EQ(s.bodies.species[0].name, "dumbbell");
  ASSERT_EQ(s.silo.base_outlets.size(), 1u);
  EXPECT_EQ(s.silo.base_outlets[0].width, 10.0);
  EXPECT_EQ(s.contact.kn, 2.0e6);
  EXPECT_EQ(s.discharge.mode, DischargeMode::kRemove);
}

TEST(RunSpecTest, MuWallDefaultsToMu) {
  const RunSpec s = RunSpec::FromJson(json::parse(R"({"contact": {"mu": 0.3}})"));
  EXPECT_EQ(s.contact.mu_wall, 0.3);
  const RunSpec t = RunSpec::FromJson(json::parse(R"({"contact": {"mu": 0.3, "mu_wall": 0.7}})"));
  EXPECT_EQ(t.contact.mu_wall, 0.7);
}

TEST(RunSpecTest, RodDefaultNameCarriesN) {
  const RunSpec s = RunSpec::FromJson(json::parse(R"({"bodies": {"species": [{"shape": "rod", "n": 4}]}})"));
  EXPECT_EQ(s.bodies.species[0].name, "rod4");
}

TEST(RunSpecTest, ToJsonRoundTripsAndFillsDefaults) {
  const json in = json::parse(R"({"seed": 7, "silo": {"width": 40, "base_outlets": [{"center": -5, "width": 6}]},
    "discharge": {"mode": "reinject"}, "bodies": {"count": 300}})");
  const RunSpec s = RunSpec::FromJson(in);
  const json out = s.ToJson();
  EXPECT_EQ(out["discharge"]["mode"], "reinject");
  EXPECT_EQ(out["silo"]["base_outlets"][0]["center"], -5.0);
  EXPECT_EQ(out["contact"]["tangential_cap"], "lammps");
  EXPECT_EQ(out["output"]["checkpoint_interval"], 10.0);
  EXPECT_EQ(RunSpec::FromJson(out).ToJson(), out);
}

TEST(RunSpecTest, BedKeyIgnoresOutletsAndObstacles) {
  const RunSpec a = RunSpec::FromJson(json::parse(R"({"silo": {"base_outlets": [{"width": 6}]}})"));
  const RunSpec b = RunSpec::FromJson(
      json::parse(R"({"silo": {"base_outlets": [{"width": 12}], "obstacles": [{"x": 0, "y": 20, "diameter": 5}]}})"));
  EXPECT_EQ(a.BedKey(), b.BedKey());
  const RunSpec c = RunSpec::FromJson(json::parse(R"({"seed": 2})"));
  EXPECT_NE(a.BedKey(), c.BedKey());
  // The native bed procedure is in the key: a bed poured with the fixed wait (or at another
  // step) is not taken for one poured on landing at the default step.
  const RunSpec fixed = RunSpec::FromJson(json::parse(R"({"bed": {"next_batch": "fixed"}})"));
  EXPECT_NE(a.BedKey(), fixed.BedKey());
  EXPECT_EQ(a.BedKey()["bed"]["next_batch"], "landed");
  EXPECT_EQ(a.BedKey()["bed"]["landed_ke_per_body"], kBedLandedKePerBody);
  EXPECT_EQ(a.BedKey()["bed"]["resolved_time_step"], kBedTimeStepFactor * a.time_step);
  EXPECT_FALSE(fixed.BedKey()["bed"].contains("landed_ke_per_body"));
  const RunSpec step = RunSpec::FromJson(json::parse(R"({"bed": {"time_step": 1e-4}})"));
  EXPECT_NE(a.BedKey(), step.BedKey());
}

TEST(RunSpecErrorTest, UnknownKeySuggestsNearest) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"widht": 10}})")), "/silo/widht: unknown key; did you mean \"width\"?");
  EXPECT_EQ(ErrorOf(json::parse(R"({"zzzzzzzzzzzzzzzz": 1, "seed": 1})")).substr(0, 40),
            "/zzzzzzzzzzzzzzzz: unknown key; allowed:");
}

TEST(RunSpecErrorTest, WrongType) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"width": "wide"}})")), "/silo/width: must be a number (got \"wide\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"bodies": {"count": 2.5}})")), "/bodies/count: must be an integer (got 2.5)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": []})")), "/silo: must be an object (got array)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"seed": -1})")), "/seed: must be a non-negative integer (got -1)");
}

TEST(RunSpecErrorTest, BadEnum) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"bodies": {"species": [{"shape": "cube"}]}})")),
            "/bodies/species/0/shape: must be one of \"disc\", \"dumbbell\", \"snowman\", \"rod\" (got \"cube\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"mode": "drain"}})")),
            "/discharge/mode: must be one of \"remove\", \"reinject\" (got \"drain\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"engine": "gromacs"})")),
            "/engine: must be one of \"native\", \"liggghts\", \"lammps\" (got \"gromacs\")");
}

TEST(RunSpecTest, ReinjectPositionIsInTheResolvedSpecOnlyWhenNotTheDefault) {
  // Run ids planned before the option existed stay the same.
  EXPECT_FALSE(RunSpec::FromJson(json::object()).ToJson()["discharge"].contains("reinject_position"));
  const RunSpec p =
      RunSpec::FromJson(json::parse(R"({"discharge": {"mode": "reinject", "reinject_position": "periodic"}})"));
  EXPECT_EQ(p.discharge.reinject_position, ReinjectPosition::kPeriodic);
  EXPECT_EQ(p.ToJson()["discharge"]["reinject_position"], "periodic");
  EXPECT_EQ(RunSpec::FromJson(p.ToJson()).ToJson(), p.ToJson());
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"reinject_position": "top"}})")),
            "/discharge/reinject_position: must be one of \"random\", \"periodic\" (got \"top\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"mode": "reinject", "reinject_position": "periodic"},
    "silo": {"side_outlets": [{"wall": "right", "bottom": 3, "width": 5}]}})")),
            "/discharge/reinject_position: \"periodic\" returns bodies through the bottom of the box, which a body "
            "leaving through a side outlet never reaches; use \"random\" with side outlets (got \"periodic\")");
}

// on_clog: "stop" and "wait" are the older stop_on_clog true and false (same resolved spec,
// same run ids); "unclog" with its protocol is written only when chosen.
TEST(RunSpecTest, OnClogAndTheUnclogProtocol) {
  const json stop = RunSpec::FromJson(json::object()).ToJson();
  EXPECT_EQ(RunSpec::FromJson(json::parse(R"({"discharge": {"on_clog": "stop"}})")).ToJson(), stop);
  EXPECT_FALSE(stop["discharge"].contains("on_clog"));
  const json wait = RunSpec::FromJson(json::parse(R"({"discharge": {"on_clog": "wait"}})")).ToJson();
  EXPECT_EQ(wait, RunSpec::FromJson(json::parse(R"({"discharge": {"stop_on_clog": false}})")).ToJson());
  EXPECT_EQ(wait["discharge"]["stop_on_clog"], false);
  const RunSpec u = RunSpec::FromJson(json::parse(
      R"({"discharge": {"on_clog": "unclog", "unclog": {"method": "kick", "max_clogs": 200, "kick_speed": 2}}})"));
  EXPECT_EQ(u.discharge.on_clog, OnClog::kUnclog);
  EXPECT_FALSE(u.discharge.StopOnClog());
  EXPECT_EQ(u.discharge.unclog.method, UnclogMethod::kKick);
  EXPECT_EQ(u.discharge.unclog.max_clogs, 200);
  EXPECT_EQ(u.discharge.unclog.max_attempts, 10);
  EXPECT_EQ(u.ToJson()["discharge"]["on_clog"], "unclog");
  EXPECT_EQ(u.ToJson()["discharge"]["unclog"]["kick_speed"], 2.0);
  EXPECT_EQ(RunSpec::FromJson(u.ToJson()).ToJson(), u.ToJson());
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"on_clog": "blow"}})")),
            "/discharge/on_clog: must be one of \"stop\", \"wait\", \"unclog\" (got \"blow\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"on_clog": "unclog", "stop_on_clog": true}})")),
            "/discharge/stop_on_clog: contradicts /discharge/on_clog \"unclog\"; give only on_clog (got true)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"unclog": {"method": "kick"}}})")),
            "/discharge/unclog: applies only with /discharge/on_clog \"unclog\" (on_clog is \"stop\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"on_clog": "unclog", "unclog": {"max_clogs": 0}}})")),
            "/discharge/unclog/max_clogs: must be an integer >= 1 (got 0)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"on_clog": "unclog", "unclog": {"mehtod": "kick"}}})")),
            "/discharge/unclog/mehtod: unknown key; did you mean \"method\"?");
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"mode": "reinject", "reinject_position": "periodic",
                                                  "on_clog": "unclog"}})")),
            "/discharge/unclog/method: remove_arch returns the arch's bodies on top of the bed, which the periodic box "
            "has no place for; use reinject_position \"random\" or the method \"kick\" (got \"remove_arch\")");
  // remove_arch's fallback: "none" (the default) is left out of the resolved spec, so runs planned
  // before it existed keep their ids and a run.json without it says what they did; "kick" is
  // written. It belongs to remove_arch only.
  const RunSpec plain = RunSpec::FromJson(json::parse(R"({"discharge": {"on_clog": "unclog"}})"));
  EXPECT_EQ(plain.discharge.unclog.fallback, UnclogFallback::kNone);
  EXPECT_FALSE(plain.ToJson()["discharge"]["unclog"].contains("fallback"));
  EXPECT_EQ(RunSpec::FromJson(json::parse(R"({"discharge": {"on_clog": "unclog", "unclog": {"fallback": "none"}}})"))
                .ToJson(),
            plain.ToJson());
  const RunSpec kicking =
      RunSpec::FromJson(json::parse(R"({"discharge": {"on_clog": "unclog", "unclog": {"fallback": "kick"}}})"));
  EXPECT_EQ(kicking.discharge.unclog.fallback, UnclogFallback::kKick);
  EXPECT_EQ(kicking.ToJson()["discharge"]["unclog"]["fallback"], "kick");
  EXPECT_EQ(RunSpec::FromJson(kicking.ToJson()).ToJson(), kicking.ToJson());
  EXPECT_NE(kicking.ToJson(), plain.ToJson());
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"on_clog": "unclog", "unclog": {"fallback": "blow"}}})")),
            "/discharge/unclog/fallback: must be one of \"none\", \"kick\" (got \"blow\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"on_clog": "unclog", "unclog": {"fallback": true}}})")),
            "/discharge/unclog/fallback: must be one of \"none\", \"kick\" (got true)");
  EXPECT_EQ(
      ErrorOf(json::parse(R"({"discharge": {"on_clog": "unclog", "unclog": {"method": "kick", "fallback": "kick"}}})")),
      "/discharge/unclog/fallback: applies only to the method \"remove_arch\" (the method is \"kick\"); leave it out "
      "or give \"none\" (got \"kick\")");
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"unclog": {"fallback": "kick"}}})")),
            "/discharge/unclog: applies only with /discharge/on_clog \"unclog\" (on_clog is \"stop\")");
  // The LIGGGHTS backend refuses it when the run is planned.
  EXPECT_EQ(ErrorOf(json::parse(R"({"engine": "liggghts", "discharge": {"on_clog": "unclog"}})")),
            "/discharge/on_clog: the LIGGGHTS backend cannot break a clog: it runs LIGGGHTS' input script to the end, "
            "with no step at which to take out an arch or kick the bodies over the outlet; use the native engine, or "
            "\"stop\" or \"wait\" (got \"unclog\")");
  // So does the LAMMPS backend.
  EXPECT_EQ(ErrorOf(json::parse(R"({"engine": "lammps", "discharge": {"on_clog": "unclog"}})")),
            "/discharge/on_clog: the LAMMPS backend cannot break a clog yet: it runs one LAMMPS input to the end, "
            "with no step at which to take out an arch or kick the bodies over the outlet; use the native engine, or "
            "\"stop\" or \"wait\" (got \"unclog\")");
}

TEST(RunSpecTest, PeriodicHeadroomIsInTheResolvedSpecOnlyWhenNotTheDefault) {
  EXPECT_FALSE(RunSpec::FromJson(json::object()).ToJson()["discharge"].contains("periodic_headroom"));
  const RunSpec p = RunSpec::FromJson(json::parse(R"({"discharge": {"periodic_headroom": 30}})"));
  EXPECT_EQ(p.discharge.periodic_headroom, 30.0);
  EXPECT_EQ(p.ToJson()["discharge"]["periodic_headroom"], 30.0);
  EXPECT_EQ(RunSpec::FromJson(p.ToJson()).ToJson(), p.ToJson());
  EXPECT_EQ(ErrorOf(json::parse(R"({"discharge": {"periodic_headroom": -1}})")).substr(0, 31),
            "/discharge/periodic_headroom: m");
}

TEST(RunSpecErrorTest, WhatTheLiggghtsBackendCannotDoIsRefusedAtPlanning) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"engine": "liggghts", "discharge": {"mode": "reinject"},
    "silo": {"side_outlets": [{"wall": "right", "bottom": 3, "width": 5}]}})"))
                .substr(0, 40),
            "/discharge/mode: the LIGGGHTS backend re");
  // The same specs are fine on the native engine.
  EXPECT_NO_THROW(RunSpec::FromJson(json::parse(R"({"discharge": {"mode": "reinject"},
    "silo": {"side_outlets": [{"wall": "right", "bottom": 3, "width": 5}]}})")));
}

TEST(RunSpecTest, NormalModelIsHertzByDefaultAndHookeOnTheNativeEngineAndLammps) {
  EXPECT_EQ(RunSpec::FromJson(json::object()).contact.normal_model, NormalModel::kHertz);
  EXPECT_FALSE(RunSpec::FromJson(json::object()).ToJson()["contact"].contains("normal_model"));
  const RunSpec hooke = RunSpec::FromJson(json::parse(R"({"contact": {"normal_model": "hooke"}})"));
  EXPECT_EQ(hooke.contact.normal_model, NormalModel::kHooke);
  EXPECT_EQ(hooke.ToJson()["contact"]["normal_model"], "hooke");
  EXPECT_EQ(RunSpec::FromJson(hooke.ToJson()).ToJson(), hooke.ToJson());
  EXPECT_NE(hooke.BedKey(), RunSpec::FromJson(json::object()).BedKey()) << "a Hooke bed is not a Hertz bed";
  EXPECT_EQ(ErrorOf(json::parse(R"({"contact": {"normal_model": "hook"}})")).substr(0, 45),
            "/contact/normal_model: must be one of \"hertz\"");
  // LAMMPS has the law as pair gran/hooke/history (tests/lammps/backend_test.cpp runs it).
  EXPECT_EQ(RunSpec::FromJson(json::parse(R"({"engine": "lammps", "contact": {"normal_model": "hooke"}})"))
                .contact.normal_model,
            NormalModel::kHooke);
  EXPECT_EQ(ErrorOf(json::parse(R"({"engine": "liggghts", "contact": {"normal_model": "hooke"}})")),
            "/contact/normal_model: the LIGGGHTS backend writes model hertz/stiffness only; hooke is the native "
            "engine's (got \"hooke\", allowed: \"hertz\")");
}

TEST(RunSpecErrorTest, SpeciesNameThatWouldBreakEventsCsv) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"bodies": {"species": [{"name": "a,b"}]}})")),
            "/bodies/species/0/name: must be a non-empty name without commas, control characters or line breaks (it is "
            "a column of events.csv) (got \"a,b\", which holds ',')");
  EXPECT_EQ(ErrorOf(json::parse(R"({"bodies": {"species": [{"name": "a\u0000b"}]}})")),
            "/bodies/species/0/name: must be a non-empty name without commas, control characters or line breaks (it is "
            "a column of events.csv) (got \"a\\u0000b\", which holds U+0000 (NUL))");
  EXPECT_EQ(ErrorOf(json::parse(R"({"bodies": {"species": [{"name": ""}]}})")).substr(0, 24),
            "/bodies/species/0/name: ");
  EXPECT_NO_THROW(RunSpec::FromJson(json::parse(R"({"bodies": {"species": [{"name": "big disc D=1.4"}]}})")));
}

TEST(RunSpecErrorTest, NonPositiveParameter) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"base_outlets": [{"width": -3}]}})")),
            "/silo/base_outlets/0/width: must be > 0 (got -3.0)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"contact": {"kn": 0}})")), "/contact/kn: must be > 0 (got 0.0)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"time_step": -1e-4})")), "/time_step: must be > 0 (got -0.0001)");
}

TEST(RunSpecErrorTest, OutletWiderThanBase) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"width": 40, "base_outlets": [{"width": 50}]}})")),
            "/silo/base_outlets/0/width: must be < the silo width 40.0 (got 50.0)");
}

TEST(RunSpecErrorTest, OutletOutsideBase) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"width": 40, "base_outlets": [{"center": 18, "width": 6}]}})")),
            "/silo/base_outlets/0: outlet [15.0, 21.0] lies outside the base [-20.0, 20.0]");
}

TEST(RunSpecErrorTest, OverlappingOutlets) {
  EXPECT_EQ(
      ErrorOf(json::parse(R"({"silo": {"base_outlets": [{"center": 0, "width": 10}, {"center": 8, "width": 10}]}})")),
      "/silo/base_outlets/1: overlaps base outlet 0 ([3.0, 13.0] and [-5.0, 5.0])");
}

TEST(RunSpecErrorTest, SideOutletAboveWall) {
  EXPECT_EQ(ErrorOf(json::parse(
                R"({"bodies": {"count": 10}, "silo": {"height": 20, "side_outlets": [{"bottom": 10, "width": 15}]}})")),
            "/silo/side_outlets/0: top 25.0 is above the wall height 20.0");
}

TEST(RunSpecErrorTest, ObstacleThroughWallOrBase) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"obstacles": [{"x": 48, "y": 20, "diameter": 6}]}})")),
            "/silo/obstacles/0: obstacle at x = 48.0 of diameter 6.0 crosses a side wall at x = +-50.0");
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"obstacles": [{"x": 0, "y": 2, "diameter": 6}]}})")),
            "/silo/obstacles/0: obstacle at y = 2.0 of diameter 6.0 crosses the base at y = 0");
}

TEST(RunSpecErrorTest, BodiesDoNotFit) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"width": 1.5, "base_outlets": [{"width": 1}]}})")),
            "/silo/width: bodies of length 2.0 cannot fit in a silo of width 1.5");
  EXPECT_EQ(ErrorOf(json::parse(
                R"({"bodies": {"count": 1000}, "silo": {"width": 10, "height": 10, "base_outlets": [{"width": 2}]}})")),
            "/silo/height: the bed of 1000 bodies needs a height of about 197.0 (got 10.0)");
}

TEST(RunSpecErrorTest, FractionsMustSumToOne) {
  EXPECT_EQ(
      ErrorOf(json::parse(
          R"({"bodies": {"species": [{"shape": "disc", "fraction": 0.5}, {"shape": "dumbbell", "fraction": 0.4}]}})")),
      "/bodies/species: fractions must sum to 1 (got 0.9)");
}

TEST(RunSpecErrorTest, SnowmanRatio) {
  EXPECT_EQ(
      ErrorOf(json::parse(R"({"bodies": {"species": [{"shape": "snowman", "diameter": 1, "big_diameter": 2.5}]}})")),
      "/bodies/species/0/big_diameter: D_b/D_s must be in [1, 2] (got 2.5/1.0 = 2.5)");
}

TEST(RunSpecErrorTest, RodNeedsTwoDiscs) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"bodies": {"species": [{"shape": "rod", "n": 1}]}})")),
            "/bodies/species/0/n: must be an integer >= 2 (got 1)");
}

TEST(RunSpecErrorTest, NoOutlet) {
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"base_outlets": []}})")),
            "/silo/base_outlets: the silo needs at least one outlet (got none)");
}

// The table is what the validator knows: every key it writes has a row, every default in the
// table is the parser's default, and every row's type and range is enforced (a value just
// outside the range, or of another type, at that place is refused naming the place).
std::string Concrete(const std::string& pattern) { return std::regex_replace(pattern, std::regex("\\*"), "0"); }

TEST(RunSpecTable, CoversTheCanonicalSpecAndItsDefaults) {
  const json canonical = RunSpec::FromJson(json::object()).ToJson();
  std::vector<std::pair<std::string, const json*>> stack = {{"", &canonical}};
  int checked = 0, left_out = 0;
  while (!stack.empty()) {
    const auto [at, v] = stack.back();
    stack.pop_back();
    if (!at.empty()) {
      EXPECT_NE(RunSpecTable().Find(SpecPattern(at)), nullptr) << at << " has no row";
    }
    if (v->is_object())
      for (const auto& [k, child] : v->items()) stack.emplace_back(at + "/" + k, &child);
    if (v->is_array())
      for (std::size_t i = 0; i < v->size(); ++i) stack.emplace_back(at + "/" + std::to_string(i), &(*v)[i]);
  }
  for (const SpecField& f : RunSpecTable().Fields()) {
    if (f.default_value.is_null() || f.pattern.find('*') != std::string::npos) continue;
    const json::json_pointer p(f.pattern);
    if (!canonical.contains(p)) {
      // Written only when not the default, so that older run ids stay valid.
      ++left_out;
      continue;
    }
    if (f.default_value.is_number()) {
      EXPECT_EQ(canonical[p].get<double>(), f.default_value.get<double>()) << f.pattern;
    } else {
      EXPECT_EQ(canonical[p], f.default_value) << f.pattern;
    }
    ++checked;
  }
  // Rows inside arrays: the defaults of an element the spec gives empty.
  const json element = RunSpec::FromJson(json::parse(R"({"silo": {"side_outlets": [{}], "obstacles": [{}],
      "base_outlets": [{}]}, "bodies": {"species": [{}]}})"))
                           .ToJson();
  for (const SpecField& f : RunSpecTable().Fields()) {
    if (f.default_value.is_null() || f.pattern.find('*') == std::string::npos || f.type == SpecType::kObject) continue;
    const json::json_pointer p(Concrete(f.pattern));
    ASSERT_TRUE(element.contains(p)) << f.pattern;
    EXPECT_EQ(element[p], f.default_value) << f.pattern;
    ++checked;
  }
  EXPECT_GT(checked, 40);
  // reinject_position, periodic_headroom, compress, output/format, output/contact_interval,
  // bed/time_step, bed/next_batch, bed/settled_by, on_clog and the six keys of discharge/unclog
  EXPECT_EQ(left_out, 16);
}

TEST(RunSpecTable, EveryRowsTypeAndRangeIsEnforced) {
  int checked = 0;
  for (const SpecField& f : RunSpecTable().Fields()) {
    if (f.pattern == "/engine") continue;  // the engine has its own message (below)
    const std::string place = Concrete(f.pattern);
    const json::json_pointer p(place);
    auto refused = [&](const json& value, const std::string& what) {
      json spec = json::object();
      spec[p] = value;
      const std::string e = ErrorOf(spec);
      EXPECT_EQ(e.rfind(place + ": " + what, 0), 0u) << f.pattern << " = " << value.dump() << ": " << e;
      ++checked;
    };
    switch (f.type) {
      case SpecType::kNumber: refused("x", "must be a number"); break;
      case SpecType::kInteger: refused(2.5, "must be an integer"); break;
      case SpecType::kUnsigned: refused(-1, "must be a non-negative integer"); break;
      case SpecType::kBoolean: refused(1, "must be true or false"); break;
      case SpecType::kString: refused(7, "must be a string"); break;
      case SpecType::kEnum: refused("nonsense", "must be one of"); break;
      case SpecType::kObject: refused(json::array(), "must be an object"); break;
      case SpecType::kArray: refused(json::object(), "must be an array"); break;
      default: break;
    }
    if (f.minimum) refused(f.minimum->exclusive ? f.minimum->value : f.minimum->value - 1, "must be");
    if (f.maximum) refused(f.maximum->exclusive ? f.maximum->value : f.maximum->value + 1, "must be");
  }
  EXPECT_GT(checked, 80);
  EXPECT_EQ(ErrorOf(json::parse(R"({"silo": {"base_outlets": [{"width": 0}]}})")),
            "/silo/base_outlets/0/width: must be > 0 (got 0.0)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"bodies": {"species": [{"fraction": 1.5}]}})")),
            "/bodies/species/0/fraction: must be in [0, 1] (got 1.5)");
  EXPECT_EQ(ErrorOf(json::parse(R"({"bodies": {"count": 0}})")), "/bodies/count: must be an integer >= 1 (got 0)");
}

TEST(RunSpecTable, UnknownKeysAreTheTablesComplement) {
  for (const SpecField& f : RunSpecTable().Fields()) {
    if (f.type != SpecType::kObject) continue;
    json spec = json::object();
    const std::string place = Concrete(f.pattern);
    spec[json::json_pointer(place + "/no_such_key")] = 1;
    EXPECT_EQ(ErrorOf(spec).rfind(place + "/no_such_key: unknown key", 0), 0u) << ErrorOf(spec);
  }
}

}  // namespace
}  // namespace granary

namespace granary {
namespace {

// Extends(): a larger max_time or max_clogs continues a run; anything else, or a smaller
// limit, is another run; a spec without the unclog protocol has no max_clogs to compare.
TEST(RunSpecTest, ExtendsByALargerTimeOrClogLimitOnly) {
  const auto resolved = [](double max_time, int max_clogs, double mu = 0.5) {
    json j = {{"run_id", "x"},
              {"discharge",
               {{"max_time", max_time},
                {"on_clog", "unclog"},
                {"unclog", {{"method", "remove_arch"}, {"max_clogs", max_clogs}}}}},
              {"contact", {{"mu", mu}}}};
    return RunSpec::FromJson(j).ToJson();
  };
  EXPECT_TRUE(Extends(resolved(10, 5), resolved(10, 8)));
  EXPECT_TRUE(Extends(resolved(10, 5), resolved(20, 8)));
  EXPECT_TRUE(Extends(resolved(10, 5), resolved(20, 5)));
  EXPECT_FALSE(Extends(resolved(10, 5), resolved(10, 5)));
  EXPECT_FALSE(Extends(resolved(10, 8), resolved(20, 5)));
  EXPECT_FALSE(Extends(resolved(10, 5), resolved(10, 8, 0.4)));
  const json plain_a = RunSpec::FromJson(json{{"discharge", {{"max_time", 10}}}}).ToJson();
  const json plain_b = RunSpec::FromJson(json{{"discharge", {{"max_time", 12}}}}).ToJson();
  EXPECT_TRUE(Extends(plain_a, plain_b));
}

}  // namespace
}  // namespace granary

// The settings table (src/io/case_settings.hpp): every row reads, writes and checks its own key,
// and what `cdshear settings` prints reads back as the same case.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <utility>

#include "case_file.hpp"
#include "case_settings.hpp"
#include "config_error.hpp"
#include "shear_case.hpp"
#include "test_support.hpp"
#include "toml_text.hpp"

namespace cdshear {
namespace {

/// The resolved case as case.toml holds it.
std::string resolved_text(const ShearCase& c) {
  return toml_document_text(case_to_toml(c));
}

ShearCase with(const std::vector<std::string>& overrides) {
  CaseSource source;
  source.overrides = overrides;
  return load_case(source);
}

/// A value of `s` other than `now` and inside its range (and its constraints, for the defaults).
SettingValue other_value(const CaseSetting& s, const SettingValue& now) {
  switch (s.type) {
    case SettingType::kNumber: {
      const double v = std::get<double>(now);
      if (v != 0.0) return 0.9 * v;
      const bool one_allowed = s.hi > 1.0 || (s.hi == 1.0 && !s.hi_open);
      return one_allowed ? 1.0 : 0.5 * s.hi;  // a range that ends at or below 1
    }
    case SettingType::kInteger: {
      const std::int64_t v = std::get<std::int64_t>(now);
      return v + 1 <= s.hi ? v + 1 : v - 1;
    }
    case SettingType::kBoolean:
      return !std::get<bool>(now);
    case SettingType::kString:
      return std::get<std::string>(now) + "other.json";
    case SettingType::kChoice:
      for (const std::string& c : s.choices)
        if (c != std::get<std::string>(now)) return c;
      break;
    case SettingType::kNumberList:
      return std::vector<double>{0.5 * std::get<std::vector<double>>(now).at(0)};
    case SettingType::kNumberOrAuto:
      return 1e-3;
  }
  ADD_FAILURE() << s.dotted() << ": no other value";
  return now;
}

std::string dotted_key_of(const std::string& line) {
  return line.substr(0, line.find(" = "));
}

TEST(CaseSettings, EveryKeyIsReadIntoItsOwnFieldAndWrittenBack) {
  // For every row: --set it to another value; the resolved case must show that value under that
  // key and nothing else changed (two rows bound to one field, or a row whose reader and writer
  // disagree, fail here).
  const ShearCase defaults = with({});
  const toml::table base = case_to_toml(defaults);
  std::set<std::string> keys;
  for (const CaseSetting& s : case_settings()) {
    EXPECT_TRUE(keys.insert(s.dotted()).second) << s.dotted() << " listed twice";
    const SettingValue value = other_value(s, s.get(defaults));
    const ShearCase changed = with({s.dotted() + "=" + toml_text(value)});
    EXPECT_EQ(toml_text(s.get(changed)), toml_text(value)) << s.dotted();
    const toml::table resolved = case_to_toml(changed);
    for (const CaseSetting& other : case_settings()) {
      if (&other == &s) continue;
      // L_y sets the default boundary thickness (L_y / 4 below 40).
      if (s.dotted() == "system.height" && other.dotted() == "measure.boundary_thickness") continue;
      EXPECT_EQ(toml_text(other.get(changed)), toml_text(other.get(defaults)))
          << "--set " << s.dotted() << " changed " << other.dotted();
    }
    EXPECT_NE(resolved_text(changed), resolved_text(defaults)) << s.dotted();
  }
  // Every key the writer writes is a row (the resolved case holds nothing else).
  std::size_t written = 0;
  for (const auto& [table, values] : base) written += values.as_table()->size();
  EXPECT_EQ(written, case_settings().size());
}

TEST(CaseSettings, ValuesOutsideTheRangeAreRefusedNamingTheKey) {
  for (const CaseSetting& s : case_settings()) {
    std::vector<std::string> bad;
    if (s.type == SettingType::kNumber || s.type == SettingType::kInteger ||
        s.type == SettingType::kNumberOrAuto || s.type == SettingType::kNumberList) {
      const bool integer = s.type == SettingType::kInteger;
      const auto text = [&](double v) {
        const std::string one =
            integer ? std::to_string(static_cast<std::int64_t>(v)) : toml_text(SettingValue(v));
        return s.type == SettingType::kNumberList ? "[" + one + "]" : one;
      };
      if (std::isfinite(s.lo)) bad.push_back(text(s.lo_open ? s.lo : s.lo - 1.0));
      if (std::isfinite(s.hi) && s.hi < 1e18) bad.push_back(text(s.hi_open ? s.hi : s.hi + 1.0));
      if (!integer) bad.push_back(s.type == SettingType::kNumberList ? "[nan]" : "nan");
    }
    if (s.type == SettingType::kChoice) bad.push_back("\"none-of-these\"");
    if (s.type != SettingType::kString && s.type != SettingType::kChoice) bad.push_back("[[1]]");
    for (const std::string& value : bad) {
      try {
        with({s.dotted() + "=" + value});
        ADD_FAILURE() << s.dotted() << " = " << value << " accepted";
      } catch (const ConfigError& e) {
        EXPECT_EQ(e.key(), s.dotted()) << e.what();
      }
    }
  }
}

TEST(CaseSettings, PrintedSettingsReadBackAsTheSameCase) {
  // `cdshear settings --system 5 -V 0.1` is a case file: reading it gives the case it describes,
  // every number exact (0.1 is not 0.10000000000000001 rounded to 6 digits).
  CaseSource source;
  source.system = 5;
  source.velocity = 0.1;
  source.overrides = {"measure.boundary_thickness=[3, 5, 7, 10]", "step.dt=3e-4",
                      // quotes, and control characters the printed file escapes
                      "preparation.packing=\"a \\\"quoted\\\"\\n path\\t.json\""};
  const ShearCase c = load_case(source);
  ASSERT_EQ(c.packing_file, "a \"quoted\"\n path\t.json");
  const std::string text = settings_as_toml(c,
                                            "a header that is long enough to be wrapped over "
                                            "more than one line of comments in the file");
  const toml::table read = toml::parse(text);
  const ShearCase back = case_from_toml(read, "printed settings", ShearCase{});
  EXPECT_EQ(resolved_text(back), resolved_text(c));
  // Each key is printed once, under its own table.
  std::istringstream lines(text);
  std::string line, table;
  std::set<std::string> seen;
  while (std::getline(lines, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (line[0] == '[') {
      table = line.substr(1, line.find(']') - 1);
      continue;
    }
    EXPECT_TRUE(seen.insert(table + "." + dotted_key_of(line)).second) << line;
  }
  EXPECT_EQ(seen.size(), case_settings().size());
}

TEST(CaseSettings, ACaseFileThatGivesTheSystemsOwnNumbersRefusesAnotherPreset) {
  // The file comes after --system: a file printed for system 1 with --system 3 would run system
  // 1, unseen. Refused naming the key; the same preset, or the key given by --set, passes.
  testing::TempDir dir("system_preset");
  CaseSource system1;
  system1.system = 1;
  const std::string file =
      dir.write("system1.toml", settings_as_toml(load_case(system1), "system 1's case"));
  CaseSource other;
  other.file = file;
  other.system = 3;
  try {
    load_case(other);
    ADD_FAILURE() << "--system 3 over a file of system 1 accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), file);
    EXPECT_EQ(e.key(), "system.n");
    EXPECT_NE(std::string(e.what()).find("--system 3 gives 1023"), std::string::npos) << e.what();
  }
  other.system = 1;
  EXPECT_EQ(load_case(other).n, 511u);
  other.system = 3;
  other.overrides = {"system.n=1023", "system.height=40", "shear.normal_stress=0.0625"};
  const ShearCase three = load_case(other);
  EXPECT_EQ(three.n, 1023u);
  EXPECT_EQ(three.normal_stress, 0.0625);
  EXPECT_EQ(three.duration, 20000.0);  // the file's, which comes after the preset's 10000
}

TEST(CaseSettings, SceneSolverRowsAreTheCaseSolverRows) {
  // Scene files and case files read [solver] through the same rows: the same keys and ranges,
  // except that a case's alpha and residual_tolerance may also be "auto" (the rules of the wall
  // speed, default_alpha and default_residual_tolerance).
  std::set<std::string> scene, cases;
  for (const auto& row : solver_settings()) scene.insert(row.key + " " + range_text(row));
  for (const CaseSetting& s : case_settings()) {
    if (s.table != "solver") continue;
    std::string range = range_text(s);
    if (s.key == "alpha" || s.key == "residual_tolerance") {
      EXPECT_EQ(s.type, SettingType::kNumberOrAuto);
      const std::string or_auto = ", or \"auto\"";
      ASSERT_NE(range.find(or_auto), std::string::npos) << range;
      range.erase(range.find(or_auto), or_auto.size());
    }
    cases.insert(s.key + " " + range);
  }
  EXPECT_EQ(scene, cases);
}

TEST(CaseSettings, AlphaFollowsTheWallSpeedUnlessTheCaseGivesIt) {
  // "auto" (the default): the shear phase's alpha from V' = V within [0.05, 0.5], as
  // alpha_fast (V' / 0.5)^2, alpha_fast being shear_step_defaults()' alpha.
  const double fast = shear_step_defaults().solver.alpha;
  const auto resolved_alpha = [](const std::vector<std::string>& overrides) {
    ShearCase c = with(overrides);
    resolve_step_rules(c);
    return c.step.solver.alpha;
  };
  EXPECT_EQ(resolved_alpha({}), fast);  // the built-in case runs at V = 0.5
  EXPECT_EQ(resolved_alpha({"shear.velocity=2"}), fast);
  EXPECT_DOUBLE_EQ(resolved_alpha({"shear.velocity=0.25"}), fast / 4);
  EXPECT_DOUBLE_EQ(resolved_alpha({"shear.velocity=0.05"}), fast / 100);
  EXPECT_DOUBLE_EQ(resolved_alpha({"shear.velocity=0.01"}), fast / 100);
  EXPECT_EQ(resolved_alpha({"shear.velocity=0.05", "solver.alpha=3e-6"}), 3e-6);
  EXPECT_DOUBLE_EQ(resolved_alpha({"shear.velocity=0.05", "solver.alpha=\"auto\""}), fast / 100);
  // Slower walls, tighter tolerance: never looser as V falls.
  double previous = 1.0;
  for (const double v : {8.0, 0.5, 0.4, 0.2, 0.1, 0.07, 0.05, 0.02}) {
    const double a = default_alpha(v);
    EXPECT_LE(a, previous) << "V = " << v;
    previous = a;
  }
  // A case file keeps the word, so that a resumed or rerun case follows its own V.
  EXPECT_NE(resolved_text(with({"shear.velocity=0.05"})).find("alpha = \"auto\""),
            std::string::npos);
}

TEST(CaseSettings, ResidualToleranceFollowsTheWallSpeedAndTimeStepUnlessTheCaseGivesIt) {
  // "auto" (the default): e dt at most kResidualPerSpeed V' dt, V' = max(V, 0.05), with the
  // step's own dt (the default rule's or the case's).
  const auto resolved = [](const std::vector<std::string>& overrides) {
    ShearCase c = with(overrides);
    resolve_step_rules(c);
    return std::pair{c.step.solver.residual_tolerance, c.step.dt};
  };
  for (const double v : {0.01, 0.05, 0.1, 0.5, 2.0}) {
    const auto [tolerance, dt] = resolved({"shear.velocity=" + std::to_string(v)});
    EXPECT_DOUBLE_EQ(tolerance, kResidualPerSpeed * std::max(v, 0.05) * dt) << "V = " << v;
  }
  // From V = 0.4 up the default dt moves the walls 0.002 d per step: the same bound on e dt.
  EXPECT_DOUBLE_EQ(resolved({"shear.velocity=0.5"}).first, resolved({"shear.velocity=2"}).first);
  const auto [own_dt, dt] = resolved({"shear.velocity=0.5", "step.dt=0.001"});
  EXPECT_DOUBLE_EQ(dt, 0.001);
  EXPECT_DOUBLE_EQ(own_dt, kResidualPerSpeed * 0.5 * 0.001);
  EXPECT_EQ(resolved({"solver.residual_tolerance=0"}).first, 0.0);  // off
  EXPECT_EQ(resolved({"solver.residual_tolerance=2e-7"}).first, 2e-7);
  EXPECT_NE(resolved_text(with({})).find("residual_tolerance = \"auto\""), std::string::npos);
  EXPECT_NE(resolved_text(with({"solver.residual_tolerance=0"})).find("residual_tolerance = 0.0"),
            std::string::npos);
}

TEST(CaseSettings, KeysNoLongerReadAreAcceptedAtTheValueNowUsedOnly) {
  // A case.toml written while these were keys holds them at their defaults of then: it reads as
  // today's defaults, so the run resumes.
  const std::vector<std::string> written_then = {"solver.criterion=\"change\"",
                                                 "solver.slab_correction_min_bands=20",
                                                 "solver.anderson_period_with_slab_correction=8",
                                                 "preparation.relaxation=1.0",
                                                 "preparation.skip_dormant=false",
                                                 "preparation.slab_correction_period=0"};
  EXPECT_EQ(resolved_text(with(written_then)), resolved_text(with({})));
  // Any other value would ask for a solve cdshear no longer does: refused, naming the key.
  for (const std::string item :
       {"solver.criterion=\"error\"", "solver.slab_correction_min_bands=2",
        "solver.anderson_period_with_slab_correction=4", "preparation.relaxation=1.6",
        "preparation.skip_dormant=true", "preparation.slab_correction_period=8"}) {
    const std::string key = item.substr(0, item.find('='));
    try {
      with({item});
      ADD_FAILURE() << item << " was accepted";
    } catch (const ConfigError& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(key), std::string::npos) << message;
      EXPECT_NE(message.find("no longer a setting"), std::string::npos) << message;
    }
  }
  // Where the key has no effect (no slab correction), any value.
  EXPECT_NO_THROW(with({"solver.slab_correction_period=0", "solver.slab_correction_min_bands=2",
                        "solver.anderson_period_with_slab_correction=4"}));
  EXPECT_NO_THROW(with({"solver.normal_compliance=0.01", "solver.slab_correction_min_bands=2",
                        "solver.anderson_period_with_slab_correction=4"}));
  // The mix period follows anderson_period.
  EXPECT_NO_THROW(
      with({"solver.anderson_period=3", "solver.anderson_period_with_slab_correction=6"}));
  // The sequential order and under-relaxation are not offered.
  EXPECT_THROW(with({"solver.order=\"sequential\""}), ConfigError);
  EXPECT_THROW(with({"solver.relaxation=0.9"}), ConfigError);
}

TEST(CaseSettings, SettingsNamedWithoutEffectChangeNoRunAndEffectiveOnesAreNotNamed) {
  // The slab correction needs 20 bands of 4 largest diameters: the tall box (600 disks, 5 wide,
  // about 95 high) has about 24, the short one (300 disks, 12 wide, about 20 high) about 5.
  const testing::ShearedBox tall = testing::sheared_dense_box(600, 5.0, 0.5);
  const testing::ShearedBox short_box = testing::sheared_dense_box(300, 12.0, 0.5);
  ASSERT_TRUE(tall.dense && short_box.dense);
  const auto hash = [](const testing::ShearedBox& box, const SolverOptions& solver) {
    World world = box.world;
    ContactDynamics dynamics = box.dynamics;
    StepOptions o = shear_step_defaults();
    o.dt = 2e-3;
    o.solver = solver;
    for (int k = 0; k < 40; ++k) EXPECT_FALSE(dynamics.step(world, o).blown_up);
    return state_hash(world);
  };
  const SolverOptions shear = shear_step_defaults().solver;
  const auto named = [&](const SolverOptions& o, const std::string& key) {
    const std::vector<std::string> notes = solver_settings_without_effect(o, shear, "solver");
    return notes.size() == 1 && notes[0].starts_with("solver." + key + " = ");
  };
  struct Pair {
    const char* key;
    SolverOptions given, without;  // the key given, and at its value that turns it off
    bool named;                    // whether the given value is named as without effect
  };
  const auto period = [&](ContactOrder order, double kappa, int slab_period) {
    SolverOptions o = shear;
    o.order = order;
    o.normal_compliance = kappa;
    o.slab_correction_period = slab_period;
    return o;
  };
  const auto mix = [&](int depth, int mix_period) {
    SolverOptions o = shear;
    o.anderson_depth = depth;
    o.anderson_period = mix_period;
    return o;
  };
  const ContactOrder kRandom = ContactOrder::kRandom, kColoured = ContactOrder::kColoured;
  for (const Pair& p :
       {Pair{"slab_correction_period", period(kRandom, 0.0, 4), period(kRandom, 0.0, 0), true},
        Pair{"slab_correction_period", period(kColoured, 0.01, 4), period(kColoured, 0.01, 0),
             true},
        Pair{"anderson_period", mix(0, 3), mix(0, 1), true},
        Pair{"slab_correction_period", period(kColoured, 0.0, 4), period(kColoured, 0.0, 0), false},
        Pair{"anderson_period", mix(5, 3), mix(5, 1), false}}) {
    EXPECT_EQ(named(p.given, p.key), p.named) << p.key;
    const bool same = hash(tall, p.given) == hash(tall, p.without);
    EXPECT_EQ(same, p.named) << p.key
                             << ": a named setting changes nothing, the others change "
                                "the run";
  }
  // The band rule, on the case: named in system 1's cell (L_y 20), not in system 5's (L_y 80);
  // the correction indeed changes nothing in a cell of that height.
  const auto case_notes = [](std::optional<int> system, const std::vector<std::string>& sets) {
    CaseSource source;
    source.system = system;
    source.overrides = sets;
    return case_settings_without_effect(load_case(source));
  };
  const std::vector<std::string> short_notes = case_notes(1, {"solver.slab_correction_period=4"});
  ASSERT_EQ(short_notes.size(), 1u);
  EXPECT_NE(short_notes[0].find("in this cell"), std::string::npos) << short_notes[0];
  EXPECT_EQ(hash(short_box, period(kColoured, 0.0, 4)), hash(short_box, period(kColoured, 0.0, 0)));
  EXPECT_TRUE(case_notes(5, {"solver.slab_correction_period=4"}).empty());
  // A default is never named: a case that only changes the order stays quiet.
  EXPECT_TRUE(case_notes(1, {"solver.order=\"random\""}).empty());
}

}  // namespace
}  // namespace cdshear

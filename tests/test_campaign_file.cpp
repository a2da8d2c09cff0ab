// Campaign files (`cdshear sweep`): a good file is resolved into the right runs (names, V,
// durations from strain, time steps), velocity ranges are spaced as asked, the resolved campaign
// reads back to itself, and every bad file is refused naming the file and the key.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

#include "campaign_file.hpp"
#include "config_error.hpp"
#include "packing_file.hpp"
#include "shear_case.hpp"
#include "test_support.hpp"

namespace cdshear {
namespace {

using testing::TempDir;

Campaign parse(const std::string& text) {
  return campaign_from_toml(toml::parse(text), "test.toml", "/tmp");
}

/// A packing file that system `system`'s runs accept (its n, L_y and diameters; disks on a grid,
/// for the campaign reader, which never builds the cell), written to `dir`/`name`.
std::string write_packing_of_system(const TempDir& dir, const std::string& name, int system) {
  ShearCase c;
  apply_system_preset(c, system);
  Packing p;
  p.height = c.height;
  p.diameter_min = c.diameter_min;
  p.diameter_max = c.diameter_max;
  const auto columns = static_cast<std::size_t>(std::ceil(std::sqrt(static_cast<double>(c.n))));
  const double spacing = (c.height - 1.0) / static_cast<double>(columns);
  p.length_x = spacing * static_cast<double>(columns);
  for (std::size_t i = 0; i < c.n; ++i)
    p.disks.push_back({{(static_cast<double>(i % columns) + 0.5) * spacing,
                        0.5 + (static_cast<double>(i / columns) + 0.5) * spacing},
                       0.45});
  const std::filesystem::path path = dir.path() / name;
  write_packing(path, p);
  return path.string();
}

/// `back` (a campaign read back from its resolved form) has the same runs as `c`: names,
/// durations and time steps, in order.
void expect_same_runs(const Campaign& back, const Campaign& c) {
  ASSERT_EQ(back.runs.size(), c.runs.size());
  for (std::size_t k = 0; k < c.runs.size(); ++k) {
    EXPECT_EQ(back.runs[k].name, c.runs[k].name);
    EXPECT_EQ(back.runs[k].duration, c.runs[k].duration);
    EXPECT_EQ(back.runs[k].dt, c.runs[k].dt);
  }
}

TEST(CampaignFile, GoodFileIsResolvedIntoEveryRun) {
  const Campaign c = parse(
      "[campaign]\nname = \"study\"\nsystems = [1, 2]\nvelocities = [0.05, 0.5]\n"
      "seeds = [3]\nduration = 100\nboundary_thickness = [5.0, 10.0]\nanalyze = false\n"
      "[set]\nmeasure.enabled = false\nsolver.order = \"random\"\n");
  EXPECT_EQ(c.name, "study");
  ASSERT_EQ(c.runs.size(), 4u);
  // systems x seeds x velocities
  EXPECT_EQ(c.runs[0].name, "s1_seed3_V0.05");
  EXPECT_EQ(c.runs[1].name, "s1_seed3_V0.5");
  EXPECT_EQ(c.runs[2].name, "s2_seed3_V0.05");
  EXPECT_EQ(c.runs[3].name, "s2_seed3_V0.5");
  EXPECT_EQ(c.runs[2].n, 1023u);
  EXPECT_DOUBLE_EQ(c.runs[2].height, 40.0);
  EXPECT_EQ(c.runs[3].seed, 3u);
  for (const CampaignRun& r : c.runs) EXPECT_DOUBLE_EQ(r.duration, 100.0);
  // dt = min(0.005, 0.002 / V)
  EXPECT_DOUBLE_EQ(c.runs[0].dt, 0.005);
  EXPECT_DOUBLE_EQ(c.runs[1].dt, 0.004);
  EXPECT_DOUBLE_EQ(c.runs[3].cost(), 1023 * 100 / 0.004);
  ASSERT_EQ(c.overrides.size(), 2u);
  EXPECT_EQ(c.overrides[0], "measure.enabled=false");
  EXPECT_EQ(c.overrides[1].rfind("solver.order=", 0), 0u);
  EXPECT_EQ(c.groups.at(0).seeds, std::vector<std::uint64_t>{3});
  EXPECT_FALSE(c.analyze);
  // analyze defaults to true
  EXPECT_TRUE(
      parse("[campaign]\nname = \"a\"\nsystems = [1]\nvelocities = [0.5]\nduration = 1\n").analyze);
}

TEST(CampaignFile, LogRangeIsGeometric) {
  const Campaign c = parse(
      "[campaign]\nname = \"r\"\nsystems = [1]\nduration = 10\n"
      "[campaign.velocity_range]\nfrom = 0.01\nto = 1\ncount = 5\nspacing = \"log\"\n");
  const std::vector<double> want = {0.01, 0.0316228, 0.1, 0.316228, 1.0};
  ASSERT_EQ(c.groups.at(0).velocities.size(), want.size());
  for (std::size_t k = 0; k < want.size(); ++k)
    EXPECT_DOUBLE_EQ(c.groups[0].velocities[k], want[k]) << k;
  EXPECT_EQ(c.runs[1].name, "s1_seed1_V0.0316228");
  // log is the default spacing; linear is evenly spaced
  const Campaign lin = parse(
      "[campaign]\nname = \"r\"\nsystems = [1]\nduration = 10\n"
      "[campaign.velocity_range]\nfrom = 0.5\nto = 2\ncount = 4\nspacing = \"linear\"\n");
  EXPECT_EQ(lin.groups.at(0).velocities, (std::vector<double>{0.5, 1.0, 1.5, 2.0}));
  const Campaign dflt = parse(
      "[campaign]\nname = \"r\"\nsystems = [1]\nduration = 10\n"
      "[campaign.velocity_range]\nfrom = 0.1\nto = 10\ncount = 3\n");
  EXPECT_EQ(dflt.groups.at(0).velocities, (std::vector<double>{0.1, 1.0, 10.0}));
}

TEST(CampaignFile, StrainBecomesADurationPerRun) {
  // t = strain L_y / (2 V): system 1 (L_y 20) and 2 (L_y 40)
  const Campaign c =
      parse("[campaign]\nname = \"s\"\nsystems = [1, 2]\nvelocities = [0.5, 2]\nstrain = 10\n");
  ASSERT_EQ(c.runs.size(), 4u);
  EXPECT_DOUBLE_EQ(c.runs[0].duration, 200.0);
  EXPECT_DOUBLE_EQ(c.runs[1].duration, 50.0);
  EXPECT_DOUBLE_EQ(c.runs[2].duration, 400.0);
  EXPECT_DOUBLE_EQ(c.runs[3].duration, 100.0);
  // the height a [set] gives counts
  const Campaign h = parse(
      "[campaign]\nname = \"s\"\nsystems = [1]\nvelocities = [1]\nstrain = 4\n"
      "[set]\nsystem.height = 30\n");
  EXPECT_DOUBLE_EQ(h.runs[0].duration, 60.0);
}

TEST(CampaignFile, DurationsPerSystem) {
  // model.md section 6 gives each system its own simulated time; the resolved form keeps the table.
  const Campaign c = parse(
      "[campaign]\nname = \"p\"\nsystems = [1, 2]\nvelocities = [0.5]\n"
      "duration = { 1 = 20000, 2 = 10000 }\n");
  ASSERT_EQ(c.runs.size(), 2u);
  EXPECT_DOUBLE_EQ(c.runs[0].duration, 20000.0);
  EXPECT_DOUBLE_EQ(c.runs[1].duration, 10000.0);
  const Campaign back =
      campaign_from_toml(campaign_to_toml(c), "p.toml", std::filesystem::current_path().string());
  EXPECT_EQ(back.groups.at(0).duration_of_system, c.groups.at(0).duration_of_system);
}

TEST(CampaignFile, ResolvedCampaignReadsBackToItself) {
  TempDir dir("campaign");
  const std::string packing = write_packing_of_system(dir, "p.json", 1);
  const Campaign c = campaign_from_toml(
      toml::parse("[campaign]\nname = \"x\"\nsystems = [1]\nstrain = 3\nanalyze = false\n"
                  "packing = { 1 = \"p.json\" }\n"
                  "[campaign.velocity_range]\nfrom = 0.02\nto = 2\ncount = 4\n"
                  "[set]\nstep.dt_max = 0.004\n"),
      "x.toml", dir.path().string());
  EXPECT_EQ(c.packings.at(1), packing);  // relative to the campaign file's folder
  const toml::table resolved = campaign_to_toml(c);
  const Campaign back = campaign_from_toml(resolved, "back.toml", "/");
  expect_same_runs(back, c);
  EXPECT_EQ(campaign_fingerprint(campaign_to_toml(back)), campaign_fingerprint(resolved));
  EXPECT_TRUE(campaign_differences(resolved, campaign_to_toml(back)).empty());
  // a change is named
  Campaign changed = c;
  changed.groups.at(0).velocities.back() = 3.0;
  const auto diff = campaign_differences(resolved, campaign_to_toml(changed));
  ASSERT_EQ(diff.size(), 1u);
  EXPECT_EQ(diff[0].rfind("campaign.velocities: ", 0), 0u) << diff[0];
  EXPECT_NE(campaign_fingerprint(campaign_to_toml(changed)), campaign_fingerprint(resolved));
  // the file's header holds the fingerprint of the campaign below it; a user's file holds none
  const std::string written = campaign_file_text(c);
  ASSERT_TRUE(written.starts_with(kResolvedCampaignHeader));
  EXPECT_EQ(recorded_fingerprint(written), campaign_fingerprint(resolved));
  EXPECT_EQ(recorded_fingerprint(campaign_file_text(changed)),
            campaign_fingerprint(campaign_to_toml(changed)));
  EXPECT_EQ(recorded_fingerprint("[campaign]\nname = \"x\"\n# ; fingerprint 0123.\n"), "");
}

TEST(CampaignFile, AFolderWrittenWithOtherNumberTextKeepsItsFingerprint) {
  // Numbers are written in their shortest form, and the fingerprint is of that text.
  const Campaign c =
      parse("[campaign]\nname = \"b\"\nsystems = [1]\nvelocities = [0.05, 0.3]\nduration = 4\n");
  const std::string written = campaign_file_text(c);
  EXPECT_NE(written.find("\nvelocities = [0.05, 0.3]\n"), std::string::npos) << written;
  EXPECT_EQ(campaign_fingerprint(campaign_to_toml(c)), recorded_fingerprint(written));
  // A file of a build that printed 17 digits (tests/data/README.md): its campaign has another
  // fingerprint now, and the one it was written with is the recorded one; an edit of its values,
  // or a table added after its run list, matches neither.
  const std::string file =
      std::string(CDSHEAR_SOURCE_DIR) + "/tests/data/campaign_printed_with_17_digits.toml";
  std::ifstream in(file, std::ios::binary);
  const std::string old((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_NE(old.find("0.050000000000000003"), std::string::npos) << file;
  const std::string recorded = recorded_fingerprint(old);
  ASSERT_FALSE(recorded.empty());
  const toml::table as_written = campaign_to_toml(read_campaign(file));
  EXPECT_NE(campaign_fingerprint(as_written), recorded);
  EXPECT_EQ(printed_fingerprint(as_written), recorded);
  std::string edited = old;
  edited.replace(edited.find("duration = 4.0"), 14, "duration = 5.0");
  const toml::table edited_campaign = campaign_to_toml(parse(edited));
  EXPECT_NE(printed_fingerprint(edited_campaign), recorded);
  EXPECT_NE(campaign_fingerprint(edited_campaign), recorded);
  const toml::table appended = campaign_to_toml(parse(old + "[set.solver]\nalpha = 1e-6\n"));
  EXPECT_NE(printed_fingerprint(appended), recorded);
  EXPECT_NE(campaign_fingerprint(appended), recorded);
}

TEST(CampaignFile, GroupsGiveEachPurposeItsOwnRuns) {
  // Velocities around a transition with two seeds, and another system with its own range and
  // duration: the runs of each group, in group order, and the resolved form keeps the groups.
  const Campaign c = parse(
      "[campaign]\nname = \"g\"\nboundary_thickness = [10.0]\n"
      "[[campaign.group]]\npurpose = \"regimes of system 1\"\nsystems = [1]\n"
      "velocities = [0.1, 0.2]\nseeds = [1, 2]\nduration = 50\n"
      "[[campaign.group]]\nsystems = [2]\nstrain = 4\n"
      "[campaign.group.velocity_range]\nfrom = 1\nto = 4\ncount = 3\n");
  ASSERT_TRUE(c.grouped);
  ASSERT_EQ(c.groups.size(), 2u);
  EXPECT_EQ(c.groups[0].purpose, "regimes of system 1");
  ASSERT_EQ(c.runs.size(), 7u);
  EXPECT_EQ(c.runs[0].name, "s1_seed1_V0.1");
  EXPECT_EQ(c.runs[3].name, "s1_seed2_V0.2");
  EXPECT_DOUBLE_EQ(c.runs[3].duration, 50.0);
  EXPECT_EQ(c.runs[4].name, "s2_seed1_V1");
  EXPECT_EQ(c.runs[6].name, "s2_seed1_V4");
  EXPECT_DOUBLE_EQ(c.runs[6].duration, 4.0 * 40.0 / (2.0 * 4.0));  // t = strain L_y / 2V
  const toml::table resolved = campaign_to_toml(c);
  const Campaign back = campaign_from_toml(resolved, "back.toml", "/");
  expect_same_runs(back, c);
  EXPECT_EQ(back.groups[0].purpose, c.groups[0].purpose);
  EXPECT_TRUE(campaign_differences(resolved, campaign_to_toml(back)).empty());
  // adding a group is a change that names the group
  Campaign more = c;
  more.groups.push_back(c.groups[1]);
  more.groups.back().systems = {3};
  const auto diff = campaign_differences(resolved, campaign_to_toml(more));
  ASSERT_EQ(diff.size(), 1u);
  EXPECT_EQ(diff[0], "campaign.group[2]: added");
}

TEST(CampaignFile, DifferencesPairGroupsByContentNotByPlace) {
  // A group inserted first renumbers the others: only it is named. A group whose velocities
  // changed is paired with its old self by its purpose and named by the key that changed; a group
  // gone is named by its place in the folder's campaign.
  const Campaign c = parse(
      "[campaign]\nname = \"g\"\n"
      "[[campaign.group]]\npurpose = \"transition\"\nsystems = [1]\n"
      "velocities = [0.1, 0.2]\nduration = 50\n"
      "[[campaign.group]]\nsystems = [2]\nvelocities = [1]\nduration = 20\n"
      "[[campaign.group]]\npurpose = \"fast\"\nsystems = [3]\nvelocities = [2]\nduration = 9\n");
  const toml::table resolved = campaign_to_toml(c);
  Campaign changed = c;
  CampaignGroup extended = c.groups[0];
  extended.purpose = "transition, extended";
  extended.velocities = {0.2};
  extended.duration = 80.0;
  changed.groups[0].velocities = {0.1};                     // same purpose: paired
  changed.groups.insert(changed.groups.begin(), extended);  // new purpose: added
  changed.groups.pop_back();                                // "fast" removed
  const auto diff = campaign_differences(resolved, campaign_to_toml(changed));
  ASSERT_EQ(diff.size(), 3u) << fmt::format("{}", fmt::join(diff, "\n"));
  EXPECT_EQ(diff[0], "campaign.group[0]: added (purpose \"transition, extended\")");
  EXPECT_EQ(diff[1], "campaign.group[1].velocities: [0.1, 0.2] -> [0.1]");
  EXPECT_EQ(diff[2], "campaign.group[2] of the folder's campaign: removed (purpose \"fast\")");
  // a group without a purpose changed in place is named by its keys; floats stay floats
  Campaign longer = c;
  longer.groups[1].duration = 30.0;
  const auto in_place = campaign_differences(resolved, campaign_to_toml(longer));
  ASSERT_EQ(in_place.size(), 1u) << fmt::format("{}", fmt::join(in_place, "\n"));
  EXPECT_EQ(in_place[0], "campaign.group[1].duration: 20.0 -> 30.0");
}

TEST(CampaignFile, SetValuesKeepTheirTypeWhenPassedToTheRuns) {
  // [set] values reach each run as --set KEY=VALUE text: a whole-number float stays a float, so
  // an integer key given one is refused as on the command line.
  EXPECT_THROW(parse("[campaign]\nname = \"s\"\nsystems = [1]\nvelocities = [0.5]\n"
                     "duration = 10\n[set]\nsolver.max_sweeps = 300.0\n"),
               ConfigError);
  const Campaign c = parse(
      "[campaign]\nname = \"s\"\nsystems = [1]\nvelocities = [0.5]\nduration = 10\n"
      "[set]\nstep.dt_max = 1.0\nsolver.alpha = 1e-07\n");
  const std::vector<std::string> set = run_case_overrides(c, c.runs.at(0));
  EXPECT_NE(std::find(set.begin(), set.end(), "step.dt_max=1.0"), set.end())
      << fmt::format("{}", fmt::join(set, " "));
  EXPECT_NE(std::find(set.begin(), set.end(), "solver.alpha=1e-7"), set.end())
      << fmt::format("{}", fmt::join(set, " "));
}

TEST(CampaignFile, GivenPackingServesOneSeedOverAllGroups) {
  TempDir dir("campaign_packing");
  const std::string packing = write_packing_of_system(dir, "p.json", 1);
  const std::string head = "[campaign]\nname = \"p\"\npacking = { 1 = \"" + packing + "\" }\n";
  const std::string group =
      "[[campaign.group]]\nsystems = [1]\nvelocities = [0.5]\nduration = 10\n";
  EXPECT_EQ(campaign_from_toml(toml::parse(head + group), "p.toml", "/").packings.at(1), packing);
  try {
    campaign_from_toml(toml::parse(head + group +
                                   "[[campaign.group]]\nsystems = [1]\nvelocities = [0.7]\n"
                                   "seeds = [2]\nduration = 10\n"),
                       "p.toml", "/");
    FAIL() << "two seeds of system 1 shared one given packing";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "campaign.packing.1");
    EXPECT_NE(std::string(e.what()).find("serves one seed"), std::string::npos) << e.what();
  }
}

TEST(CampaignFile, GivenPackingPlacedWithAnotherSeedIsRefused) {
  // The run's folder and summary would name seed 2 for a placement of seed 1.
  TempDir dir("campaign_packing_seed");
  const std::string packing = write_packing_of_system(dir, "p.json", 1);
  const std::string text =
      "[campaign]\nname = \"p\"\nsystems = [1]\nvelocities = [0.5]\n"
      "duration = 10\npacking = { 1 = \"p.json\" }\nseeds = [";
  EXPECT_EQ(read_packing(packing, 0.0).seed, 1U);
  EXPECT_EQ(
      campaign_from_toml(toml::parse(text + "1]\n"), "p.toml", dir.path().string()).runs.at(0).name,
      "s1_seed1_V0.5");
  try {
    campaign_from_toml(toml::parse(text + "2]\n"), "p.toml", dir.path().string());
    FAIL() << "a packing placed with seed 1 was run as seed 2";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "campaign.packing.1");
    EXPECT_NE(std::string(e.what()).find("placed with seed 1, the campaign would run it as seed 2"),
              std::string::npos)
        << e.what();
  }
}

TEST(CampaignFile, GivenPackingOfAnotherSystemIsRefusedBeforeAnyRun) {
  TempDir dir("campaign_foreign_packing");
  const std::string packing = write_packing_of_system(dir, "p.json", 2);
  try {
    campaign_from_toml(toml::parse("[campaign]\nname = \"p\"\nsystems = [1]\nvelocities = "
                                   "[0.5]\nduration = 10\npacking = { 1 = \"p.json\" }\n"),
                       "p.toml", dir.path().string());
    FAIL() << "a packing of system 2 was taken for system 1";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), "p.toml");
    EXPECT_EQ(e.key(), "campaign.packing.1");
    EXPECT_NE(std::string(e.what()).find(packing + ": key 'n': packing has"), std::string::npos)
        << e.what();
  }
}

/// The file is refused with a ConfigError naming the file and `key`.
void expect_refused(const std::string& text, const std::string& key, const std::string& says) {
  TempDir dir("campaign_bad");
  const std::string path = dir.write("bad.toml", text);
  try {
    read_campaign(path);
    ADD_FAILURE() << "accepted; expected a refusal naming " << key << "\n" << text;
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), path) << e.what();
    EXPECT_EQ(e.key(), key) << e.what();
    EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
  }
}

const std::string kHead = "[campaign]\nname = \"b\"\n";

TEST(CampaignFile, StepLimitIsTheRunsNotThePresets) {
  // 1 t in steps of 1e-9 is 1e9 steps, within the limit of 2e9 that the preset's 20000 t exceed.
  TempDir dir("campaign_dt");
  const Campaign c = read_campaign(dir.write(
      "c.toml",
      kHead + "systems = [1]\nvelocities = [0.5]\nduration = 1\n[set]\nstep.dt = 1e-9\n"));
  ASSERT_EQ(c.runs.size(), 1u);
  EXPECT_EQ(c.runs[0].duration, 1.0);
  EXPECT_EQ(c.runs[0].dt, 1e-9);
}

TEST(CampaignFile, SystemsThatSetMakesOneCaseAreRefused) {
  // Systems 2 and 3 differ only in their normal stress: a [set] of it makes them one case, run
  // twice under two names.
  const std::string two_systems = kHead + "systems = [2, 3]\nvelocities = [0.5]\n";
  EXPECT_EQ(parse(two_systems + "duration = 10\n").runs.size(), 2u);
  expect_refused(two_systems + "duration = 10\n[set]\nshear.normal_stress = 1.0\n", "set",
                 "makes runs s2_seed1_V0.5 and s3_seed1_V0.5 one case");
  // Their durations differing does not make them two cases.
  expect_refused(two_systems + "duration = {2 = 10, 3 = 20}\n[set]\nshear.normal_stress = 1.0\n",
                 "set", "differ in nothing but the duration");
  // One value where they already agree keeps them two.
  EXPECT_EQ(parse(two_systems + "duration = 10\n[set]\nshear.friction_grain = 0.3\n").runs.size(),
            2u);
}

TEST(CampaignFile, BadFilesAreRefusedNamingTheKey) {
  const std::string ok_rest = "systems = [1]\nvelocities = [0.5]\nduration = 10\n";
  expect_refused(kHead + ok_rest + "velocitys = [1]\n", "campaign.velocitys", "unknown key");
  expect_refused(kHead + ok_rest + "[extra]\na = 1\n", "extra", "unknown key");
  expect_refused("[campaign]\n" + ok_rest, "campaign.name", "required");
  expect_refused("[campaign]\nname = \"a/b\"\n" + ok_rest, "campaign.name", "a folder name");
  expect_refused("[campaign]\nname = \"" + std::string(256, 'a') + "\"\n" + ok_rest,
                 "campaign.name", "at most 255 characters, got 256");
  expect_refused(kHead + "systems = [8]\nvelocities = [0.5]\nduration = 10\n", "campaign.systems",
                 "unknown");
  expect_refused(kHead + "systems = [0]\nvelocities = [0.5]\nduration = 10\n", "campaign.systems",
                 "unknown");
  expect_refused(kHead + "systems = []\nvelocities = [0.5]\nduration = 10\n", "campaign.systems",
                 "empty");
  expect_refused(kHead + "systems = [1]\nvelocities = []\nduration = 10\n", "campaign.velocities",
                 "empty");
  expect_refused(kHead + "systems = [1]\nduration = 10\n", "campaign.velocities", "required");
  expect_refused(kHead + "systems = [1]\nvelocities = [0.5, -1]\nduration = 10\n",
                 "campaign.velocities", "> 0");
  expect_refused(kHead + "systems = [1]\nvelocities = [0]\nduration = 10\n", "campaign.velocities",
                 "> 0");
  expect_refused(kHead + "systems = [1]\nvelocities = [nan]\nduration = 10\n",
                 "campaign.velocities", "finite");
  expect_refused(kHead + "systems = [1]\nvelocities = [inf]\nduration = 10\n",
                 "campaign.velocities", "finite");
  expect_refused(kHead + "systems = [1]\nvelocities = [\"fast\"]\nduration = 10\n",
                 "campaign.velocities", "numbers");
  expect_refused(kHead +
                     "systems = [1]\nduration = 10\n[campaign.velocity_range]\nfrom = 0\nto = 1\n"
                     "count = 3\n",
                 "campaign.velocity_range.from", "> 0");
  expect_refused(kHead +
                     "systems = [1]\nduration = 10\n[campaign.velocity_range]\nfrom = 0.1\nto = 1\n"
                     "count = 3\nspacing = \"cubic\"\n",
                 "campaign.velocity_range.spacing", "one of");
  // duplicate runs: the same system, V and seed twice
  expect_refused(kHead + "systems = [1]\nvelocities = [0.5, 0.50]\nduration = 10\n",
                 "campaign.velocities", "twice");
  // distinct numbers that name the same run folder (6 significant digits)
  expect_refused(kHead + "systems = [1]\nvelocities = [0.1, 0.10000001]\nduration = 10\n",
                 "campaign.velocities", "twice");
  // checked as the runs will get it: the case refuses an h listed twice
  expect_refused(kHead + ok_rest + "boundary_thickness = [5.0, 5.0]\n",
                 "campaign.boundary_thickness", "twice");
  expect_refused(kHead + "systems = [1]\nvelocities = [0.5]\nseeds = [2, 2]\nduration = 10\n",
                 "campaign.seeds", "twice");
  expect_refused(kHead + "systems = [1, 1]\nvelocities = [0.5]\nduration = 10\n",
                 "campaign.systems", "twice");
  // too many runs: 2 seeds x 10000 velocities
  expect_refused(kHead +
                     "systems = [1]\nseeds = [1, 2]\nduration = 10\n[campaign.velocity_range]\n"
                     "from = 0.01\nto = 1\ncount = 10000\n",
                 "campaign", "more than the limit");
  // per-system durations: every system, and only those
  expect_refused(kHead + "systems = [1, 2]\nvelocities = [0.5]\nduration = { 1 = 100 }\n",
                 "campaign.duration.2", "missing");
  expect_refused(kHead + "systems = [1]\nvelocities = [0.5]\nduration = { 1 = 100, 3 = 5 }\n",
                 "campaign.duration.3",
                 "unknown key: the table gives a duration to each of the "
                 "systems = [1]");
  expect_refused(kHead + "systems = [1]\nvelocities = [0.5]\nduration = { 1 = -1 }\n",
                 "campaign.duration.1", "> 0");
  // duration or strain: one of them
  expect_refused(kHead + "systems = [1]\nvelocities = [0.5]\nduration = 10\nstrain = 2\n",
                 "campaign.strain", "not both");
  expect_refused(kHead + "systems = [1]\nvelocities = [0.5]\n", "campaign.duration", "required");
  expect_refused(kHead + "systems = [1]\nvelocities = [0.5]\nduration = -1\n", "campaign.duration",
                 "> 0");
  // [set]: keys the campaign owns, and what the case refuses
  expect_refused(kHead + ok_rest + "[set]\nshear.velocity = 2\n", "set.shear.velocity",
                 "set by the campaign");
  expect_refused(kHead + ok_rest + "[set]\nshear.duration = 2\n", "set.shear.duration",
                 "set by the campaign");
  for (const std::string key : {"packing", "shear.packing"})  // `run --packing` is no case key
    expect_refused(kHead + ok_rest + "[set]\n" + key + " = \"p.json\"\n", "set." + key,
                   "a campaign's packing files are given per system in [campaign]");
  expect_refused(kHead + ok_rest + "[set]\nmeasure.enabled = 3\n", "set.measure.enabled",
                 "true or false");
  expect_refused(kHead + ok_rest + "[set]\nshear.frobnicate = 3\n", "set.shear.frobnicate",
                 "unknown key");
  // A quoted key that would smuggle a value past the checks when passed on as key=value text:
  // every run at V = 5 under names that say 0.5, or a duration past the step limit.
  expect_refused(kHead + ok_rest + "[set]\n\"shear.velocity=5 #\" = 0\n", "set", "not a case key");
  expect_refused(kHead + ok_rest + "[set]\nshear.\"duration=1e9 #\" = 0\n", "set",
                 "not a case key");
  expect_refused(kHead + ok_rest + "[set]\n\"shear velocity\" = 1\n", "set", "not a case key");
  expect_refused(kHead + ok_rest + "[set]\n\"\" = 1\n", "set", "empty");
  // One key written twice, dotted and quoted (the later would win unseen).
  expect_refused(
      kHead + ok_rest + "[set]\nshear.friction_grain = 0.4\n\"shear.friction_grain\" = 0.3\n",
      "set.shear.friction_grain", "given twice");
  // Speeds of a range that underflow to subnormals, or whose ratio overflows: refused by the
  // case's own checks, under the range's key.
  expect_refused(kHead +
                     "systems = [1]\nduration = 10\n[campaign.velocity_range]\nfrom = 1e-320\n"
                     "to = 1\ncount = 3\n",
                 "campaign.velocity_range", "less than one grain");
  expect_refused(kHead +
                     "systems = [1]\nduration = 10\n[campaign.velocity_range]\nfrom = 0.1\n"
                     "to = 1e308\ncount = 3\n",
                 "campaign.velocity_range", "sets the time step to");
  // A run too big for its run.h5, refused as `cdshear run` would refuse it, with the campaign's
  // duration: 1e8 samples in 1 t; 2e8 stripes in a 10-tall cell.
  expect_refused(kHead +
                     "systems = [1]\nvelocities = [0.5]\nduration = 1\n[set]\n"
                     "measure.window = 0.5\nmeasure.sample_interval = 1e-8\n",
                 "set.measure.sample_interval", "1e+08 samples over the duration 1");
  expect_refused(kHead +
                     "systems = [1]\nvelocities = [0.5]\nstrain = 0.1\n[set]\n"
                     "system.height = 10.0\nmeasure.stripe_thickness = 1e-7\n",
                 "set.measure.stripe_thickness", "profile points");
  expect_refused(kHead + "systems = [1]\nvelocities = [0.5]\nduration = 1e9\n", "campaign.duration",
                 "more than the limit");
  // A tiny step limit is blamed on itself, not on the campaign's speeds.
  expect_refused(kHead + ok_rest + "[set]\nstep.dt_max = 1e-20\n", "set.step.dt_max",
                 "the longest run the step limit allows");
  // A condition between two keys, one of them the campaign's: its key named, the other beside
  // the problem (the built-in measure.contact_gap against a margin of the campaign's).
  expect_refused(kHead + ok_rest + "[set]\nstep.contact_margin = 1e-4\n", "set.step.contact_margin",
                 "measure.contact_gap: must be at most half of step.contact_margin");
  // An analysis of runs that measure nothing (it exited 0 with no analysis); the message says
  // whether the file gave `analyze` or left it to its default.
  expect_refused(kHead + ok_rest + "[set]\nmeasure.enabled = false\n", "campaign.analyze",
                 "is true by default (not given), but the runs measure nothing");
  expect_refused(kHead + ok_rest + "analyze = true\n[set]\nmeasure.enabled = false\n",
                 "campaign.analyze", "is true, but the runs measure nothing");
  // a packing for a system the campaign does not run, and a missing packing file
  expect_refused(kHead + ok_rest + "packing = { 2 = \"p.json\" }\n", "campaign.packing.2",
                 "unknown key");
  expect_refused(kHead + ok_rest + "packing = { 1 = \"missing.json\" }\n", "campaign.packing.1",
                 "no packing file");
  // groups: the runs are listed in [campaign] or in groups, each run in one group
  const std::string group = "[[campaign.group]]\n" + ok_rest;
  expect_refused(kHead + "systems = [1]\n" + group, "campaign.systems", "each [[campaign.group]]");
  expect_refused(kHead + "group = []\n", "campaign.group", "empty");
  expect_refused(kHead + group + group, "campaign.group[1]", "campaign.group[0] already");
  // a purpose names its group when a changed campaign is compared: one per group
  const std::string slow =
      "[[campaign.group]]\nsystems = [2]\nvelocities = [0.05]\nduration = 10\n";
  expect_refused(kHead + group + "purpose = \"slow\"\n" + slow + "purpose = \"slow\"\n",
                 "campaign.group[1].purpose", "the purpose of campaign.group[0] already");
  EXPECT_EQ(
      parse(kHead + group + "purpose = \"fast\"\n" + slow + "purpose = \"slow\"\n").runs.size(),
      2u);
  EXPECT_EQ(parse(kHead + group + slow).runs.size(), 2u);  // two without one
  expect_refused(kHead + group + "frobnicate = 1\n", "campaign.group[0].frobnicate", "unknown key");
  expect_refused(kHead + "[[campaign.group]]\nsystems = [1]\nvelocities = [-1]\nduration = 1\n",
                 "campaign.group[0].velocities", "> 0");
  expect_refused(kHead + group + "[[campaign.group]]\nsystems = [1]\nvelocities = [0.7]\n",
                 "campaign.group[1].duration", "required");
}

}  // namespace
}  // namespace cdshear

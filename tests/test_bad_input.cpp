// Bad input is refused with a message that names the file and the key; a step that blows up says
// so; the executable turns both into a non-zero exit status and a message on stderr.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <functional>

#include <sys/stat.h>
#include <sys/wait.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "case_file.hpp"
#include "cdshear_git.hpp"
#include "checkpoint.hpp"
#include "config_error.hpp"
#include "packing_file.hpp"
#include "scene_file.hpp"
#include "test_support.hpp"

namespace cdshear {
namespace {

using testing::disk;
using testing::TempDir;

/// A valid scene: two disks on a floor. Each test breaks one thing.
std::string scene_text(const std::string& step_table = "dt = 1e-3\n",
                       const std::string& disks =
                           "[[disks]]\nposition = [1.0, 0.5]\nradius = 0.5\n"
                           "[[disks]]\nposition = [2.5, 0.5]\n"
                           "radius = 0.5\n",
                       const std::string& extra = "") {
  return "gravity = [0.0, -1.0]\n" + extra +
         "[material]\nfriction_disk_disk = 0.5\n"
         "[step]\n" +
         step_table +
         "[solver]\nseed = 3\n"
         "[run]\nduration = 0.01\nsample_every = 5\n"
         "[[walls]]\nname = \"floor\"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]\n" +
         disks;
}

/// Loads `text` from a temporary file and returns the ConfigError it must raise.
ConfigError load_error(const std::string& text) {
  TempDir dir("bad_input");
  const std::string path = dir.write("scene.toml", text);
  try {
    load_scene_file(path, {});
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    return e;
  }
  ADD_FAILURE() << "no ConfigError for:\n" << text;
  return ConfigError("", "", "");
}

/// Builds `scene` and returns the SceneError the builder must raise.
SceneError build_error(const SceneDefinition& scene) {
  try {
    build_world(scene);
  } catch (const SceneError& e) {
    return e;
  }
  ADD_FAILURE() << "no SceneError";
  return SceneError("", "");
}

void expect_names(const ConfigError& e, const std::string& key, const std::string& problem) {
  EXPECT_EQ(e.key(), key) << e.what();
  const std::string what = e.what();
  EXPECT_NE(what.find("'" + key + "'"), std::string::npos) << what;
  EXPECT_NE(what.find(problem), std::string::npos) << what;
}

TEST(BadInput, ValidSceneLoads) {
  // The base scene is valid, so every failure below comes from the one thing each test breaks.
  TempDir dir("good_input");
  const SceneFile sf = load_scene_file(dir.write("scene.toml", scene_text()), {});
  EXPECT_EQ(sf.scene.disks.size(), 2u);
  EXPECT_EQ(sf.step.dt, 1e-3);
  EXPECT_EQ(sf.step.solver.seed, 3u);
  EXPECT_NO_THROW(build_world(sf.scene));
}

TEST(BadInput, TheResolvedSceneHoldsEveryValueInUseAndReadsBackAsTheSameScene) {
  // The file leaves out most keys; the resolved table written beside the results (scene.toml)
  // holds each with the value the run used, a --set's included.
  TempDir dir("resolved_scene");
  const std::string disks =
      "[[disks]]\nposition = [1.0, 0.5]\nradius = 0.5\n"
      "[[random_disks]]\ncount = 20\nregion_min = [0.0, 2.0]\nregion_max = [6.0, 8.0]\n";
  const SceneFile first = load_scene_file(dir.write("scene.toml", scene_text("dt = 1e-3\n", disks)),
                                          {"solver.relaxation=1.3"});
  for (const char* key :
       {"solver.relaxation", "solver.anderson_depth", "solver.order", "step.contact_margin",
        "material.density", "walls[0].friction", "walls[0].mode_x", "walls[0].velocity",
        "disks[0].omega", "random_disks[0].seed", "random_disks[0].diameter_min",
        "domain.periodic_x", "run.status_every", "overlap_tolerance"})
    EXPECT_TRUE(first.resolved.at_path(key)) << key << " is not in the resolved scene";
  EXPECT_EQ(first.resolved.at_path("solver.relaxation").value<double>(), 1.3);
  EXPECT_EQ(first.resolved.at_path("random_disks[0].diameter_min").value<double>(), 0.8);
  std::ostringstream written;
  written << first.resolved;
  const SceneFile again = load_scene_file(dir.write("again.toml", written.str()), {});
  std::ostringstream rewritten;
  rewritten << again.resolved;
  EXPECT_EQ(rewritten.str(), written.str()) << "the resolved scene left a value out";
  EXPECT_EQ(again.step.solver.relaxation, 1.3);
  EXPECT_EQ(state_hash(build_world(again.scene)), state_hash(build_world(first.scene)));
}

TEST(BadInput, UnknownKey) {
  expect_names(load_error(scene_text("dt = 1e-3\ndtt = 2e-3\n")), "step.dtt", "unknown key");
  expect_names(load_error(scene_text("dt = 1e-3\n", "", "gravty = [0.0, 1.0]\n")), "gravty",
               "unknown key");
  expect_names(load_error(scene_text("dt = 1e-3\n",
                                     "[[disks]]\nposition = [1.0, 0.5]\n"
                                     "radius = 0.5\nmass = 2.0\n")),
               "disks[0].mass", "unknown key");
  // A key that exists, given without the one that gives it a meaning, says which that is.
  expect_names(load_error(scene_text("dt = 1e-3\n", "", "[domain]\nlength_x = 10.0\n")),
               "domain.length_x", "give domain.periodic_x = true with it");
}

TEST(BadInput, AMissingRequiredKeyNamesTheMisspellingTheFileGives) {
  std::string misspelt = scene_text();
  misspelt.replace(misspelt.find("duration ="), 8, "duraton");
  const ConfigError e = load_error(misspelt);
  expect_names(e, "run.duration", "is required");
  EXPECT_NE(std::string(e.what()).find("'run.duraton': misspelt?"), std::string::npos) << e.what();

  // A key far from the missing one is not offered: it is reported as unknown once read.
  std::string far = scene_text();
  far.replace(far.find("duration ="), 8, "length");
  const ConfigError f = load_error(far);
  expect_names(f, "run.duration", "is required");
  EXPECT_EQ(std::string(f.what()).find("misspelt"), std::string::npos) << f.what();

  // A sibling key read after the missing one (region_max after region_min) is not a misspelling.
  const std::string random_disks = "[[random_disks]]\ncount = 1\nregion_max = [4.0, 4.0]\n";
  const ConfigError g = load_error(scene_text("dt = 1e-3\n", "", random_disks));
  expect_names(g, "random_disks[0].region_min", "is required");
  EXPECT_EQ(std::string(g.what()).find("misspelt"), std::string::npos) << g.what();
  const ConfigError h = load_error(
      scene_text("dt = 1e-3\n", "", "[[random_disks]]\ncount = 1\nregion_mn = [0.0, 0.0]\n"));
  EXPECT_NE(std::string(h.what()).find("'random_disks[0].region_mn': misspelt?"), std::string::npos)
      << h.what();

  // A misspelling given by --set is named as such, and the error blames that --set.
  TempDir dir("misspelt_set");
  std::string without = scene_text();
  without.erase(without.find("duration = 0.01\n"), 16);
  const std::string path = dir.write("scene.toml", without);
  try {
    load_scene_file(path, {"run.duraton=0.01"});
    ADD_FAILURE() << "a scene without run.duration loaded";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), "--set run.duraton=0.01") << e.what();
    EXPECT_NE(std::string(e.what()).find("(--set gives 'run.duraton': misspelt?)"),
              std::string::npos)
        << e.what();
  }
}

TEST(BadInput, WallNamesAreWordsThatCanHeadACsvColumn) {
  auto named = [](const std::string& name) {
    std::string text = scene_text();
    return text.replace(text.find("\"floor\""), 7, "\"" + name + "\"");
  };
  // ASCII separators and controls; a C1 control, Unicode spaces (no-break, em, ideographic) and
  // invisible characters (zero-width space, byte-order mark), as TOML escapes.
  for (const std::string bad :
       {"a b", "a,b", "a'b", "a\\u001bb", "a\\tb", "", "a\\u0085b", "a\\u00a0b", "a\\u2003b",
        "a\\u3000b", "a\\u200bb", "a\\ufeffb", "\\u00ad"})
    expect_names(load_error(named(bad)), "walls[0].name", "printable characters");
  // A NUL ends a C string (a path would open a shorter name): no string setting takes one.
  expect_names(load_error(named("a\\u0000b")), "walls[0].name", "holds a NUL character");
  TempDir dir("wall_names");
  EXPECT_EQ(load_scene_file(dir.write("scene.toml", named("sol_\u00e9")), {}).scene.walls[0].name,
            "sol_\xc3\xa9");  // UTF-8 letters are printable
  EXPECT_EQ(
      load_scene_file(dir.write("scene2.toml", named("\u03c3_\u58c1")), {}).scene.walls[0].name,
      "\xcf\x83_\xe5\xa3\x81");  // so are Greek and CJK ones
}

TEST(BadInput, WrongType) {
  expect_names(load_error(scene_text("dt = \"fast\"\n")), "step.dt", "must be a number");
  expect_names(load_error(scene_text("dt = 1e-3\n", "",
                                     "[domain]\n"
                                     "periodic_x = \"yes\"\n")),
               "domain.periodic_x", "must be true or false");
  expect_names(load_error(scene_text("dt = 1e-3\n", "[[disks]]\nposition = 1.0\nradius = 0.5\n")),
               "disks[0].position", "array of two numbers");
}

TEST(BadInput, SolverKeyNoLongerReadOnlyAtTheValueNowUsed) {
  // A scene's [solver] reads the keys retired from the solver as a case file does
  // (read_retired_solver_keys): at the value now used, and no other.
  TempDir dir("retired_key");
  const std::string path = dir.write("scene.toml", scene_text());
  EXPECT_NO_THROW(load_scene_file(path, {"solver.criterion=\"change\""}));
  try {
    load_scene_file(path, {"solver.criterion=\"error\""});
    ADD_FAILURE() << "solver.criterion = \"error\" was accepted";
  } catch (const ConfigError& e) {
    expect_names(e, "solver.criterion", "no longer a setting");
  }
}

TEST(BadInput, NegativeRadius) {
  expect_names(
      load_error(scene_text("dt = 1e-3\n", "[[disks]]\nposition = [1.0, 0.5]\nradius = -0.5\n")),
      "disks[0].radius", "must be > 0");
}

TEST(BadInput, NegativeTimeStep) {
  expect_names(load_error(scene_text("dt = -1e-3\n")), "step.dt", "must be > 0");
  expect_names(load_error(scene_text("dt = 0.0\n")), "step.dt", "must be > 0");
}

TEST(BadInput, MissingFile) {
  const std::string path = "/nonexistent/cdshear/no_such_scene.toml";
  try {
    load_scene_file(path, {});
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos);
  }
}

TEST(BadInput, SyntaxErrorNamesTheLine) {
  const ConfigError e = load_error(scene_text() + "[run\n");
  EXPECT_NE(std::string(e.what()).find("line"), std::string::npos) << e.what();
}

TEST(BadInput, OverlappingDisksAreRefusedByTheSceneBuilder) {
  // The file is well formed; the scene builder refuses it, naming the entry and both disks.
  TempDir dir("overlap");
  const std::string path =
      dir.write("scene.toml", scene_text("dt = 1e-3\n",
                                         "[[disks]]\nposition = [1.0, 0.5]\nradius = 0.5\n"
                                         "[[disks]]\nposition = [1.9, 0.5]\nradius = 0.5\n"));
  const SceneError e = build_error(load_scene_file(path, {}).scene);
  EXPECT_EQ(e.key(), "disks");
  const std::string what = e.what();
  EXPECT_NE(what.find("disk 0 and disk 1 overlap by 0.1"), std::string::npos) << what;
}

TEST(BadInput, DisksPiledOnOnePointAreRefusedWithoutListingEveryPair) {
  // 2000 disks at one point (a packing written with every position the same): every pair is
  // within reach, 2 million of them. The builder refuses the pile from the first disks of the
  // crowded cell (overlap 1 between two of radius 0.5), not from the largest overlap over every
  // pair, which is the last two disks' 1.2.
  SceneDefinition s;
  for (int i = 0; i < 1998; ++i) s.disks.push_back(disk({5.0, 5.0}, 0.5));
  s.disks.push_back(disk({5.0, 5.0}, 0.6));
  s.disks.push_back(disk({5.0, 5.0}, 0.6));
  const SceneError e = build_error(s);
  EXPECT_EQ(e.key(), "disks");
  const std::string what = e.what();
  EXPECT_NE(what.find("disk 0 and disk 1 overlap by 1 "), std::string::npos) << what;
}

TEST(BadInput, InvalidSceneDefinitionsNameTheKey) {
  // The same checks apply to scenes built in code (tests, benchmarks, shear preparation).
  auto key_of = [](const SceneDefinition& s) -> std::string {
    try {
      build_world(s);
    } catch (const SceneError& e) {
      return e.key();
    }
    return "(no error)";
  };
  SceneDefinition s;
  s.disks = {disk({0.0, 0.0}, -0.5)};
  EXPECT_EQ(key_of(s), "disks[0].radius");
  s = {};
  s.walls = {testing::free_y_wall("top", {0.0, 5.0}, {0.0, -1.0}, 0.0, {0.0, -1.0})};
  EXPECT_EQ(key_of(s), "walls[0].mass");
  s.walls = {testing::free_y_wall("top", {0.0, 5.0}, {0.0, -1.0}, 1e-320, {0.0, -1.0})};
  EXPECT_EQ(key_of(s), "walls[0].mass");  // subnormal: its inverse is infinite
  s.walls = {testing::free_y_wall("top", {0.0, 5.0}, {0.0, -1.0}, 1e308, {0.0, -1.0})};
  EXPECT_EQ(key_of(s), "walls[0].mass");  // its inverse is subnormal
  s.walls = {testing::free_y_wall("top", {0.0, 5.0}, {0.0, -1.0}, 1e300, {0.0, -1.0})};
  EXPECT_EQ(key_of(s), "(no error)");
  s = {};
  s.domain = {true, 2.0};  // shorter than 3 diameters
  s.disks = {disk({0.5, 0.5}, 0.5)};
  EXPECT_EQ(key_of(s), "domain.length_x");
  s = {};
  s.walls = {testing::fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0})};
  s.disks = {disk({0.0, 0.3}, 0.5)};  // crosses the floor
  EXPECT_EQ(key_of(s), "disks");
  s = {};
  RandomDisksSpec r;
  r.count = 100;
  r.region_max = {3.0, 3.0};  // cannot hold 100 disks
  s.random_disks = {r};
  EXPECT_EQ(key_of(s), "random_disks[0].count");
  s = {};
  r = {};
  r.count = 3;
  r.region_min = {0.0, -1e308};
  r.region_max = {10.0, 1e308};  // each finite, the height not
  s.random_disks = {r};
  EXPECT_EQ(key_of(s), "random_disks[0].region_max");
  s = {};
  r = {};
  r.count = 3;
  r.region_max = {10.0, 10.0};
  r.diameter_min = 1e-100;  // a moment of inertia of about 1e-400: zero
  s.random_disks = {r};
  EXPECT_EQ(key_of(s), "random_disks[0].diameter_min");
  s = {};
  s.domain = {true, 10.0};
  s.walls = {testing::fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0}),
             testing::fixed_wall("side", {1.0, 0.0}, {1.0, 0.0})};  // across the period
  s.disks = {disk({3.0, 0.5}, 0.5)};
  EXPECT_EQ(key_of(s), "walls[1].normal");
  s.domain = {};  // without a period the same wall is a side wall
  EXPECT_EQ(key_of(s), "(no error)");
}

TEST(BadInput, APlacementThatAWallPreventsNamesTheWall) {
  // A box [0, 10] x [0, 10] whose right wall's normal points out of the box: no disk fits, and
  // the message names that wall, not the region's size.
  SceneDefinition s;
  s.walls = {testing::fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0}),
             testing::fixed_wall("right", {10.0, 0.0}, {1.0, 0.0})};
  RandomDisksSpec r;
  r.count = 10;
  r.region_max = {10.0, 10.0};
  s.random_disks = {r};
  const SceneError behind = build_error(s);
  EXPECT_EQ(behind.key(), "random_disks[0].count");
  const std::string what = behind.what();
  EXPECT_NE(what.find("could place only 0 of 10"), std::string::npos) << what;
  EXPECT_NE(what.find("wholly behind wall 'right' (normal (1, 0))"), std::string::npos) << what;
  EXPECT_EQ(what.find("floor"), std::string::npos) << what;
  s.walls[1].normal = {-1.0, 0.0};  // pointing into the box: the ten disks fit
  EXPECT_EQ(build_world(s).disks.size(), 10u);
  s.random_disks[0].count = 1000;  // too many: the usual advice, no wall named
  const std::string crowded = build_error(s).what();
  EXPECT_NE(crowded.find("enlarge the region or lower the count"), std::string::npos) << crowded;
}

TEST(BadInput, APeriodTooShortGivesTheLargestDiameter) {
  SceneDefinition s;
  s.domain = {true, 2.5};
  s.disks = {disk({0.5, 0.5}, 0.5)};
  const std::string what = build_error(s).what();
  EXPECT_NE(what.find("period 2.5 is shorter than 3 largest diameters (3 x 1)"), std::string::npos)
      << what;
}

TEST(BadInput, RandomDiskKeysNameTheirDefaultsAndTheirPeriod) {
  const std::string group = "[[random_disks]]\ncount = 3\nregion_min = [0.0, 1.0]\n";
  // diameter_max alone under diameter_min's default: the message says where 0.8 comes from
  expect_names(load_error(scene_text("dt = 1e-3\n", group + "region_max = [10.0, 5.0]\n"
                                                            "diameter_max = 0.5\n")),
               "random_disks[0].diameter_max", "which is 0.8 when not given");
  // a region a billion periods from the origin, as an explicit disk there is refused
  const std::string periodic = "[domain]\nperiodic_x = true\nlength_x = 10.0\n";
  expect_names(
      load_error(scene_text("dt = 1e-3\n", group + "region_max = [1e15, 5.0]\n", periodic)),
      "random_disks[0].region_max", "more than a million periods");
}

TEST(BadInput, ATomlKeyOfManyPartsIsRefusedBeforeTheLibraryRecursesOverIt) {
  // A key of 40 000 parts overflowed the stack inside the TOML library (exit 139).
  std::string deep = "a";
  for (int i = 0; i < 40000; ++i) deep += ".a";
  const ConfigError e = load_error(scene_text() + deep + " = 1\n");
  EXPECT_NE(std::string(e.what()).find("holds a dotted key of more than 16 parts"),
            std::string::npos)
      << e.what();
  const std::string line = "line " + std::to_string(std::ranges::count(scene_text(), '\n') + 1);
  EXPECT_NE(std::string(e.what()).find(line), std::string::npos) << e.what();
  // 16 parts pass (and are read as usual); so do paths, numbers and arrays of them.
  std::string sixteen = "a";
  for (int i = 1; i < 16; ++i) sixteen += ".a";
  EXPECT_EQ(too_deep_toml_key(sixteen + " = 1\n"), "");
  EXPECT_NE(too_deep_toml_key(sixteen + ".a = 1\n"), "");
  EXPECT_NE(too_deep_toml_key("[" + sixteen + ".a]\n"), "");
  EXPECT_NE(too_deep_toml_key("x = {" + sixteen + ".a = 1}\n"), "");
  EXPECT_EQ(
      too_deep_toml_key("p = \"" + std::string(20, '.') + "/../../../../../../../../../.x\"\n"),
      "");
  std::string numbers = "v = [";
  for (int i = 0; i < 100; ++i) numbers += "0.5, ";
  EXPECT_EQ(too_deep_toml_key(numbers + "1.5]\n"), "");
}

TEST(BadInput, SceneWallNamesCannotRepeatAFixedColumnOfTheSeries) {
  // A wall named "momentum" heads momentum_x and momentum_y, which the series already has.
  std::string text = scene_text();
  text.replace(text.find("\"floor\""), 7, "\"momentum\"");
  expect_names(load_error(text), "walls[0].name", "would head the column momentum_x");
}

TEST(BadInput, SceneOverlapToleranceMustBeBelowTheAbortBound) {
  // Two coincident disks with overlap_tolerance = 2 ran to the end, one thrown at 1000 d/t.
  const ConfigError e =
      load_error(scene_text("dt = 1e-3\nabort_overlap = 0.1\n", "", "overlap_tolerance = 2.0\n"));
  expect_names(e, "overlap_tolerance", "must be less than step.abort_overlap (0.1)");
}

TEST(BadInput, SceneWallValuesItsModesWouldIgnoreAreRefused) {
  // The floor is fixed on both axes unless a test says otherwise. Each value below used to be
  // read and then ignored by the wall's modes, so the scene ran as if it were not there.
  const auto floor_with = [](const std::string& keys) {
    std::string text = scene_text();
    text.replace(text.find("normal = [0.0, 1.0]\n"), 20, "normal = [0.0, 1.0]\n" + keys);
    return text;
  };
  expect_names(load_error(floor_with("velocity = [0.5, 0.0]\n")), "walls[0].velocity",
               "x = 0.5 on a fixed axis (mode_x = \"fixed\")");
  expect_names(load_error(floor_with("mode_x = \"imposed\"\nvelocity = [0.5, -1.0]\n")),
               "walls[0].velocity", "y = -1 on a fixed axis (mode_y = \"fixed\")");
  expect_names(load_error(floor_with("mode_x = \"imposed\"\nmass = 3.0\n")), "walls[0].mass",
               "is used on free axes only");
  expect_names(load_error(floor_with("mode_y = \"free\"\nmass = 3.0\nforce = [1.0, -2.0]\n")),
               "walls[0].force", "x = 1 on an axis that is not free (mode_x)");
  // What each mode uses is accepted: an imposed x velocity, a free y axis with its mass, force
  // and starting velocity.
  TempDir dir("wall_modes");
  const SceneFile sf = load_scene_file(
      dir.write("scene.toml",
                floor_with("mode_x = \"imposed\"\nmode_y = \"free\"\nvelocity = [0.5, -1.0]\n"
                           "mass = 3.0\nforce = [0.0, -2.0]\n")),
      {});
  ASSERT_EQ(sf.scene.walls.size(), 1u);
  EXPECT_EQ(sf.scene.walls[0].velocity.x, 0.5);
  EXPECT_EQ(sf.scene.walls[0].mass, 3.0);
  EXPECT_EQ(sf.scene.walls[0].applied_force.y, -2.0);
}

TEST(BadInput, NumbersTooSmallToInvertAreRefusedNotTurnedIntoNaN) {
  // A wall normal is divided by its length, a disk's mass and inertia are inverted: a length
  // of 1e-320 has an infinite inverse, a radius of 1e-160 a zero moment of inertia. The files
  // are well formed; the scene builder refuses them, naming the entry.
  const std::string floor = "normal = [0.0, 1.0]\n";
  auto with_normal = [&](std::string text, const std::string& normal) {
    return text.replace(text.find(floor), floor.size(), "normal = " + normal + "\n");
  };
  auto scene_error = [](const std::string& text) -> std::pair<std::string, std::string> {
    TempDir dir("tiny_numbers");
    const SceneFile sf = load_scene_file(dir.write("scene.toml", text), {});
    try {
      const World w = build_world(sf.scene);
      for (std::size_t i = 0; i < w.disks.size(); ++i)
        EXPECT_TRUE(std::isfinite(1.0 / w.disks.inertia[i]) &&
                    std::isfinite(1.0 / w.disks.mass[i]));
      for (const Wall& wall : w.walls) EXPECT_NEAR(length(wall.normal), 1.0, 1e-15);
    } catch (const SceneError& e) {
      return {e.key(), e.what()};
    }
    return {"(no error)", ""};
  };
  auto [key, what] = scene_error(with_normal(scene_text(), "[0.0, 1e-320]"));
  EXPECT_EQ(key, "walls[0].normal");
  EXPECT_NE(what.find("inverse is finite"), std::string::npos) << what;
  std::tie(key, what) =
      scene_error(scene_text("dt = 1e-3\n", "[[disks]]\nposition = [1.0, 0.5]\nradius = 1e-160\n"));
  EXPECT_EQ(key, "disks[0].radius");
  EXPECT_NE(what.find("normal floating-point numbers"), std::string::npos) << what;
  // Small but ordinary numbers stay accepted, and the world built from them is finite.
  std::tie(key, what) = scene_error(
      with_normal(scene_text("dt = 1e-3\n", "[[disks]]\nposition = [1.0, 0.5]\nradius = 1e-60\n"),
                  "[0.0, 1e-300]"));
  EXPECT_EQ(key, "(no error)") << what;
}

TEST(BadInput, OverrideWithUnknownKeyIsRefused) {
  TempDir dir("override");
  const std::string path = dir.write("scene.toml", scene_text());
  try {
    load_scene_file(path, {"solver.sede=4"});
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "solver.sede");
  }
  // A valid override is applied.
  EXPECT_EQ(load_scene_file(path, {"solver.seed=4"}).step.solver.seed, 4u);
}

TEST(BadInput, OverrideWithATableValueIsRefusedNotAppliedAsAWholeTable) {
  // `--set solver={seed=4}` would replace the whole [solver] table, the file's keys included.
  TempDir dir("override_table");
  std::string text = scene_text();
  const std::string solver = "[solver]\nseed = 3\n";
  text.replace(text.find(solver), solver.size(), solver + "relaxation = 1.5\n");
  const std::string path = dir.write("scene.toml", text);
  try {
    load_scene_file(path, {"solver={seed=4}"});
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "solver");
    EXPECT_NE(e.problem().find("one key per --set"), std::string::npos) << e.what();
  }
  const SolverOptions s = load_scene_file(path, {"solver.seed=4"}).step.solver;
  EXPECT_EQ(s.seed, 4u);
  EXPECT_EQ(s.relaxation, 1.5);  // the file's key kept beside the override
}

TEST(BadInput, ASceneContactMarginWiderThanTheDisksIsRefused) {
  // scene_text's disks have radius 0.5: a margin of one diameter is taken, a wider one is not.
  TempDir dir("scene_margin");
  const std::string path = dir.write("scene.toml", scene_text());
  EXPECT_EQ(load_scene_file(path, {"step.contact_margin=1.0"}).step.contact_margin, 1.0);
  try {
    load_scene_file(path, {"step.contact_margin=1.5"});
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "step.contact_margin");
    EXPECT_NE(std::string(e.what()).find("--set step.contact_margin=1.5"), std::string::npos)
        << e.what();
    EXPECT_NE(e.problem().find("more than the disks' mean diameter (1)"), std::string::npos)
        << e.what();
  }
  // One large disk far off, or a group of no disks with large ones, does not lift the bound:
  // the mean of 1, 1 and 100 is 34, of 1, 1 and nothing 1.
  const std::string large = "[[disks]]\nposition = [1000.0, 0.5]\nradius = 50.0\n";
  const std::string none =
      "[[random_disks]]\ncount = 0\nregion_min = [0.0, 0.0]\n"
      "region_max = [1.0, 1.0]\ndiameter_min = 100.0\ndiameter_max = 100.0\n";
  for (const std::string& extra : {large, none}) {
    const std::string text = scene_text() + extra;
    const std::string bound = extra == large ? "(34)" : "(1)";
    const double wide = extra == large ? 40.0 : 1.5;
    const std::string file = dir.write("extra.toml", text);
    EXPECT_EQ(load_scene_file(file, {"step.contact_margin=1.0"}).step.contact_margin, 1.0);
    try {
      load_scene_file(file, {"step.contact_margin=" + std::to_string(wide)});
      ADD_FAILURE() << "no ConfigError for " << extra;
    } catch (const ConfigError& e) {
      EXPECT_NE(e.problem().find("mean diameter " + bound), std::string::npos) << e.what();
    }
  }
}

TEST(BadInput, AnOverrideInsideAValueBlamesTheOverrideThatGaveTheValue) {
  // `--set solver=1 --set solver.seed=4`: the first --set is the mistake, not the second.
  TempDir dir("override_inside_value");
  const std::string path = dir.write("scene.toml", scene_text());
  try {
    load_scene_file(path, {"solver=1", "solver.seed=4"});
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "solver");
    EXPECT_EQ(e.given_key(), "solver");
    EXPECT_NE(std::string(e.what()).find("--set solver=1"), std::string::npos) << e.what();
    EXPECT_NE(e.problem().find("--set solver.seed=4 cannot set a key inside it"), std::string::npos)
        << e.what();
  }
  // A value the file gives (run.duration) is named, with the file, on the --set that reaches
  // inside it.
  try {
    load_scene_file(path, {"run.duration.x=4"});
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "run.duration.x");
    EXPECT_NE(e.problem().find("'run.duration' is not a table: " + path + " gives it a value"),
              std::string::npos)
        << e.what();
  }
  // The same in a case file.
  CaseSource source;
  source.file = dir.write("case.toml", "shear = 1\n");
  source.overrides = {"shear.velocity=0.3"};
  try {
    load_case(source);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "shear.velocity");
    EXPECT_NE(std::string(e.what()).find("--set shear.velocity=0.3"), std::string::npos)
        << e.what();
    EXPECT_NE(e.problem().find("'shear' is not a table: " + source.file + " gives it a value"),
              std::string::npos)
        << e.what();
  }
}

TEST(BadInput, APackingDestinationIsCheckedBeforeAnythingIsPrepared) {
  const TempDir dir("packing_destination");
  const auto expect_refused = [](const std::filesystem::path& path, const std::string& words) {
    try {
      check_packing_destination(path);
      ADD_FAILURE() << path << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  const auto fifo = dir.path() / "fifo.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expect_refused(fifo, "not a regular file");
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));                      // left as it was
  expect_refused(dir.path(), "not a regular file");                 // a folder
  expect_refused(dir.path().string() + "/new/", "names a folder");  // a trailing slash
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "new"));
  const std::string plain = dir.write("plain.txt", "text");
  expect_refused(std::filesystem::path(plain) / "p.json", "cannot make the packing's folder");
  // Only a packing is replaced: not a case file, a run's run.h5 or a JSON file of another kind.
  expect_refused(plain, "not a cdshear packing");
  expect_refused(dir.write("other.json", R"({"format": "cdshear-progress"})"),
                 "not a cdshear packing");
  EXPECT_EQ(testing::read_text(plain), "text");
  // A new folder is made, a packing may be replaced, and no probe is left behind.
  check_packing_destination(dir.path() / "sub" / "p.json");
  EXPECT_TRUE(std::filesystem::is_directory(dir.path() / "sub"));
  EXPECT_TRUE(std::filesystem::is_empty(dir.path() / "sub"));
  check_packing_destination(dir.write("old.json", R"( {"format": "cdshear-packing", "n": 1})"));
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()),
                          std::filesystem::directory_iterator()),
            5);  // fifo.json, plain.txt, other.json, old.json, sub
}

TEST(BadInput, RelaxationOutsideZeroToTwoIsRefused) {
  TempDir dir("relaxation");
  const std::string path = dir.write("scene.toml", scene_text());
  for (const char* bad :
       {"solver.relaxation=2.0", "solver.relaxation=0.0", "solver.relaxation=-1.0"}) {
    try {
      load_scene_file(path, {bad});
      ADD_FAILURE() << "no ConfigError for " << bad;
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), "solver.relaxation") << bad;
    }
  }
  EXPECT_EQ(load_scene_file(path, {"solver.relaxation=1.5"}).step.solver.relaxation, 1.5);
}

TEST(BadInput, AndersonKeysOutOfRangeAreRefused) {
  TempDir dir("anderson");
  const std::string path = dir.write("scene.toml", scene_text());
  for (const auto& [bad, key] : {std::pair{"solver.anderson_depth=-1", "solver.anderson_depth"},
                                 std::pair{"solver.anderson_depth=17", "solver.anderson_depth"},
                                 std::pair{"solver.anderson_period=0", "solver.anderson_period"}}) {
    try {
      load_scene_file(path, {bad});
      ADD_FAILURE() << "no ConfigError for " << bad;
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), key) << bad;
    }
  }
  const SolverOptions s =
      load_scene_file(path, {"solver.anderson_depth=5", "solver.anderson_period=2"}).step.solver;
  EXPECT_EQ(s.anderson_depth, 5);
  EXPECT_EQ(s.anderson_period, 2);
}

TEST(BlowUp, TooFastApproachWithZeroMarginIsReported) {
  // Two disks 0.001 apart closing at 800 per time unit with contact_margin 0: they are no
  // candidate contact at the start of the step, and after it they overlap by 0.799. The step
  // must report it (not silently push them apart at the next step).
  SceneDefinition s;
  s.disks = {disk({0.0, 0.0}, 0.5, {400.0, 0.0}), disk({1.001, 0.0}, 0.5, {-400.0, 0.0})};
  StepOptions o;
  o.contact_margin = 0.0;
  testing::Simulation sim(s, o);
  sim.run(1);
  const StepReport& r = sim.last();
  EXPECT_EQ(r.contacts, 0u);
  EXPECT_TRUE(r.displacement_exceeded);
  EXPECT_NEAR(r.max_overlap, 1.0 - (1.001 - 0.8), 1e-12);
  ASSERT_TRUE(r.blown_up);
  EXPECT_NE(r.problem.find("overlap 0.799"), std::string::npos) << r.problem;
  EXPECT_NE(r.problem.find("abort_overlap"), std::string::npos) << r.problem;
  // A tiny bound is printed as given, not as 0.000000.
  o.abort_overlap = 1e-9;
  testing::Simulation tiny(s, o);
  tiny.run(1);
  EXPECT_NE(tiny.last().problem.find("exceeds abort_overlap 1e-09"), std::string::npos)
      << tiny.last().problem;
}

TEST(BlowUp, SameApproachWithinTheMarginIsHandled) {
  // Control: with a margin covering the approach the contact is a candidate, the solver stops
  // the disks (perfectly inelastic) and nothing blows up.
  SceneDefinition s;
  s.disks = {disk({0.0, 0.0}, 0.5, {400.0, 0.0}), disk({1.001, 0.0}, 0.5, {-400.0, 0.0})};
  StepOptions o;
  o.contact_margin = 1.0;
  o.displacement_bound = 1.0;
  testing::Simulation sim(s, o);
  sim.run(3);
  EXPECT_FALSE(sim.last().blown_up) << sim.last().problem;
  EXPECT_LT(sim.largest_overlap(), 1e-12);
  EXPECT_NEAR(sim.world.disks.velocity[0].x, 0.0, 1e-9);
}

TEST(BlowUp, NonFiniteVelocityIsReported) {
  SceneDefinition s;
  s.gravity = {std::numeric_limits<double>::quiet_NaN(), -1.0};
  s.disks = {disk({0.0, 0.0}, 0.5)};
  testing::Simulation sim(s, StepOptions{});
  sim.run(1);
  ASSERT_TRUE(sim.last().blown_up);
  EXPECT_NE(sim.last().problem.find("NaN"), std::string::npos) << sim.last().problem;
}

TEST(BlowUp, VelocityTooLargeToSquareIsReported) {
  // Finite velocities and positions whose squares overflow: the kinetic energy would be
  // infinite, so the step is a blow-up, not a finished step. A control at 1e100 passes.
  for (const double speed : {1e155, 1e100}) {
    SceneDefinition s;
    s.disks = {disk({0.0, 0.0}, 0.5, {speed, 0.0})};
    StepOptions o;
    o.displacement_bound = 1e300;
    testing::Simulation sim(s, o);
    sim.run(1);
    EXPECT_EQ(sim.last().blown_up, speed > 1e154) << speed << ": " << sim.last().problem;
  }
  SceneDefinition far;
  far.disks = {disk({1.7e308, 0.0}, 0.5, {1e306, 0.0})};  // x + v dt overflows
  StepOptions o;
  o.dt = 10.0;
  testing::Simulation sim(far, o);
  sim.run(1);
  ASSERT_TRUE(sim.last().blown_up);
  EXPECT_NE(sim.last().problem.find("position or velocity"), std::string::npos)
      << sim.last().problem;
}

TEST(BlowUp, NonFiniteWallIsReportedWithItsName) {
  // A wall free in y with an infinite applied force: its velocity becomes infinite in the first
  // step, with no disk touching it. That is a blow-up, named after the wall.
  SceneDefinition s;
  s.walls = {testing::free_y_wall("lid", {0.0, 5.0}, {0.0, -1.0}, 1.0,
                                  {0.0, -std::numeric_limits<double>::infinity()})};
  s.disks = {disk({0.0, 1.0}, 0.5)};
  testing::Simulation sim(s, StepOptions{});
  sim.run(1);
  ASSERT_TRUE(sim.last().blown_up);
  EXPECT_NE(sim.last().problem.find("wall 'lid'"), std::string::npos) << sim.last().problem;
}

TEST(BadInput, RandomPlacementStopsWhenCancelled) {
  // The flag a signal handler sets: random placement checks it between disks.
  SceneDefinition s;
  RandomDisksSpec r;
  r.count = 1000;
  r.region_min = {0.0, 0.0};
  r.region_max = {100.0, 100.0};
  s.random_disks.push_back(r);
  std::atomic<bool> cancel{true};
  EXPECT_THROW(build_world(s, &cancel), PlacementCancelled);
  cancel = false;
  EXPECT_EQ(build_world(s, &cancel).disks.size(), 1000u);
}

// ---- Checkpoints are validated like input files ------------------------------------------------

/// A small valid world and contact list to damage.
Checkpoint sample_checkpoint() {
  SceneDefinition s;
  s.domain = {true, 10.0};
  s.walls = {testing::fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0})};
  // x = 1.1: not a float32, so CBOR stores it as 8 bytes (the checksum test flips one of them).
  s.disks = {disk({1.1, 0.5}, 0.5), disk({2.3, 0.5}, 0.5)};
  Checkpoint cp;
  cp.world = build_world(s);
  Contact c;
  c.key = {0, 2, 0};
  c.impulse_n = 0.1;
  cp.contacts = {c};
  return cp;
}

/// Writes `cp` as a checkpoint, reads it back and returns the error's text ("" if none).
std::string checkpoint_error(const Checkpoint& cp) {
  const TempDir dir("checkpoint");
  const auto path = dir.path() / "checkpoint.cbor";
  write_checkpoint(path, cp.world, cp.contacts);
  try {
    read_checkpoint(path);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(CheckpointValidation, AValidCheckpointReadsBackAndEveryBadFieldIsNamed) {
  EXPECT_EQ(checkpoint_error(sample_checkpoint()), "");
  const auto expect = [](const std::function<void(Checkpoint&)>& damage, const std::string& words) {
    Checkpoint cp = sample_checkpoint();
    damage(cp);
    const std::string error = checkpoint_error(cp);
    EXPECT_NE(error.find(words), std::string::npos) << "'" << words << "' not in: " << error;
  };
  expect([](Checkpoint& c) { c.world.disks.position[1].x = std::nan(""); }, "disks[1]");
  expect([](Checkpoint& c) { c.world.disks.radius[0] = -0.5; }, "disks[0]");
  expect([](Checkpoint& c) { c.world.domain.length_x = 0.0; }, "length_x");
  expect([](Checkpoint& c) { c.world.walls[0].mode_y = static_cast<AxisMode>(7); },
         "key 'walls[0].mode_y': must be a whole number from 0 to 2, not 7");
  expect([](Checkpoint& c) { c.contacts[0].key.body_b = 3; }, "contacts.b[0]");
  expect([](Checkpoint& c) { c.contacts[0].key.body_a = 2; }, "contacts.a[0]");
  expect([](Checkpoint& c) { c.contacts[0].key.body_a = 0, c.contacts[0].key.body_b = 0; },
         "contacts.b[0]': joins bodies 0 and 0");
  // Each contact once, in key order (the order the warm start merges them in).
  expect([](Checkpoint& c) { c.contacts.push_back(c.contacts[0]); },
         "key 'contacts[1]': the contact of bodies 0 and 2 (image 0) comes again or out of order");
  expect(
      [](Checkpoint& c) {
        Contact first = c.contacts[0];
        first.key = {0, 1, 0};
        c.contacts.push_back(first);
      },
      "key 'contacts[1]': the contact of bodies 0 and 1 (image 0) comes again or out of order");
}

TEST(CheckpointValidation, APipeIsRefusedWithoutBlocking) {
  // Opening a FIFO for reading blocks until a writer comes: the reader must refuse it first.
  const TempDir dir("checkpoint_fifo");
  const auto path = dir.path() / "checkpoint.cbor";
  ASSERT_EQ(::mkfifo(path.c_str(), 0600), 0);
  try {
    read_checkpoint(path);
    ADD_FAILURE() << "a FIFO was read";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
  }
}

TEST(CheckpointValidation, ACraftedDeepNestingBehindACorrectSealIsRefused) {
  // 200000 nested CBOR arrays (0x81: an array of one element) around a null, sealed with its
  // correct checksum: the seal stops accidents, the reader's depth bound stops crafted files
  // (nlohmann's CBOR reader recurses once per level: this crashed on the stack before).
  std::vector<std::uint8_t> body(200000, 0x81);
  body.push_back(0xf6);
  const uLong crc = crc32(crc32(0L, Z_NULL, 0), body.data(), static_cast<uInt>(body.size()));
  char seal[96];
  std::snprintf(seal, sizeof seal, "cdshear-checkpoint crc32=%08lx size=%zu\n", crc, body.size());
  const TempDir dir("checkpoint_deep");
  const std::string text = std::string(seal) + std::string(body.begin(), body.end());
  const std::string path = dir.write("deep.cbor", text);
  try {
    read_checkpoint(path);
    ADD_FAILURE() << "a 200000-deep checkpoint was read";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find("nests deeper than 64 levels"), std::string::npos)
        << e.what();
  }
}

// A checkpoint's fields edited behind a correct seal (a crafted file: the seal stops accidents)
// are named by their path and the type they must have, not by the JSON library's words.
TEST(CheckpointValidation, CraftedFieldsAreNamedByTheirPath) {
  const TempDir dir("checkpoint_fields");
  const Checkpoint cp = sample_checkpoint();
  const auto path = dir.path() / "c.cbor";
  write_checkpoint(path, cp.world, cp.contacts);
  const std::string text = testing::read_text(path);
  const std::size_t newline = text.find('\n');
  const nlohmann::json original = nlohmann::json::from_cbor(text.substr(newline + 1));
  const auto read_edited = [&](const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json j = original;
    edit(j);
    const std::vector<std::uint8_t> body = nlohmann::json::to_cbor(j);
    const uLong crc = crc32(crc32(0L, Z_NULL, 0), body.data(), static_cast<uInt>(body.size()));
    char seal[96];
    std::snprintf(seal, sizeof seal, "cdshear-checkpoint crc32=%08lx size=%zu\n", crc, body.size());
    std::ofstream(path, std::ios::binary) << seal << std::string(body.begin(), body.end());
    return read_checkpoint(path);
  };
  EXPECT_EQ(state_hash(read_edited([](nlohmann::json&) {}).world), state_hash(cp.world));
  const std::pair<std::function<void(nlohmann::json&)>, std::string> cases[] = {
      {[](nlohmann::json& j) { j.erase("time"); }, "time"},
      {[](nlohmann::json& j) { j["step"] = -4; }, "step"},
      {[](nlohmann::json& j) { j["periodic_x"] = 1; }, "periodic_x"},
      {[](nlohmann::json& j) { j["body_force"] = {0.0}; }, "body_force"},
      {[](nlohmann::json& j) { j["disks"]["vy"].erase(0); }, "disks.vy"},
      {[](nlohmann::json& j) { j["disks"]["x"].push_back(1.0); }, "disks.y"},
      {[](nlohmann::json& j) { j["disks"]["omega"][1] = "spin"; }, "disks.omega[1]"},
      {[](nlohmann::json& j) { j["disks"]["image"][0] = 0.5; }, "disks.image[0]"},
      {[](nlohmann::json& j) { j["disks"] = 3; }, "disks"},
      {[](nlohmann::json& j) { j["walls"][0].erase("mass"); }, "walls[0].mass"},
      {[](nlohmann::json& j) { j["walls"][0]["mode_x"] = 9; }, "walls[0].mode_x"},
      {[](nlohmann::json& j) { j["walls"][0]["name"] = 5; }, "walls[0].name"},
      {[](nlohmann::json& j) {
         j["walls"] = {{"a", 1}};
       },
       "walls"},
      {[](nlohmann::json& j) { j["contacts"]["rt"] = nlohmann::json::array(); }, "contacts.rt"},
      // A wall list cut short is named through the wall contact's index with the counts.
      {[](nlohmann::json& j) { j["walls"] = nlohmann::json::array(); }, "contacts.b[0]"},
      {[](nlohmann::json& j) { j["contacts"]["b"][0] = 5000000000LL; }, "contacts.b[0]"},
  };
  for (const auto& [edit, key] : cases) {
    try {
      read_edited(edit);
      ADD_FAILURE() << key << ": accepted";
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), key) << e.what();
      EXPECT_EQ(std::string(e.what()).find("json.exception"), std::string::npos) << e.what();
    }
  }
}

TEST(CheckpointValidation, EveryFieldComesBackExactly) {
  Checkpoint cp = sample_checkpoint();
  cp.world.time = 1.0 / 3.0;
  cp.world.step = 12345;
  cp.world.disks.velocity[0] = {0.1, -1.0 / 7.0};
  cp.world.disks.omega[1] = 2.0 / 3.0;
  cp.world.disks.image[1] = -3;
  cp.world.walls[0].contact_impulse = {1.0 / 9.0, -5.5};
  cp.contacts[0].impulse_t = -0.0125;
  const TempDir dir("checkpoint_round_trip");
  write_checkpoint(dir.path() / "c.cbor", cp.world, cp.contacts, {{"x", 1}}, {{"n", 2}});
  const Checkpoint back = read_checkpoint(dir.path() / "c.cbor");
  EXPECT_EQ(state_hash(back.world), state_hash(cp.world));
  EXPECT_EQ(back.world.time, cp.world.time);
  EXPECT_EQ(back.world.domain.length_x, cp.world.domain.length_x);
  EXPECT_EQ(back.world.disks.radius, cp.world.disks.radius);
  EXPECT_EQ(back.world.disks.mass, cp.world.disks.mass);
  EXPECT_EQ(back.world.walls[0].contact_impulse, cp.world.walls[0].contact_impulse);
  EXPECT_EQ(back.world.walls[0].name, "floor");
  ASSERT_EQ(back.contacts.size(), 1u);
  EXPECT_EQ(back.contacts[0].key, cp.contacts[0].key);
  EXPECT_EQ(back.contacts[0].impulse_n, cp.contacts[0].impulse_n);
  EXPECT_EQ(back.contacts[0].impulse_t, cp.contacts[0].impulse_t);
  EXPECT_EQ(back.observers, nlohmann::json({{"x", 1}}));
  EXPECT_EQ(back.case_identity, nlohmann::json({{"n", 2}}));
  EXPECT_EQ(back.instruction_set, CDSHEAR_INSTRUCTION_SET);
}

// A resume by a build for another instruction set rounds differently from there on: it is
// warned of, naming the file and both sets; a resume by the same build, by a build that rounds
// alike (both without fused multiply-adds), or of a checkpoint written before checkpoints named
// their build, is not.
TEST(CheckpointValidation, AResumeByABuildForAnotherInstructionSetIsWarnedOf) {
  const TempDir dir("checkpoint_instruction_set");
  const Checkpoint cp = sample_checkpoint();
  const auto same = dir.path() / "same.cbor", other = dir.path() / "other.cbor";
  write_checkpoint(same, cp.world, cp.contacts);
  write_checkpoint(other, cp.world, cp.contacts, nullptr, nullptr, "another-set");
  EXPECT_EQ(instruction_set_warning(read_checkpoint(same), same.string()), "");
  const Checkpoint back = read_checkpoint(other);
  EXPECT_EQ(back.instruction_set, "another-set");
  const std::string warning = instruction_set_warning(back, other.string(), "this-build's-set");
  EXPECT_NE(warning.find(other.string()), std::string::npos) << warning;
  EXPECT_NE(warning.find("another-set"), std::string::npos) << warning;
  EXPECT_NE(warning.find("this-build's-set"), std::string::npos) << warning;
  Checkpoint unnamed = back;
  unnamed.instruction_set.clear();
  EXPECT_EQ(instruction_set_warning(unnamed, other.string(), "this-build's-set"), "");
  // The builds without fused multiply-adds round alike: no warning between them, either way;
  // a build with them is warned of against both.
  Checkpoint baseline = back, nofma = back;
  baseline.instruction_set = "default";
  nofma.instruction_set = "x86-64-v3-solver-nofma";
  EXPECT_EQ(instruction_set_warning(baseline, other.string(), "x86-64-v3-solver-nofma"), "");
  EXPECT_EQ(instruction_set_warning(nofma, other.string(), "default"), "");
  EXPECT_NE(instruction_set_warning(nofma, other.string(), "x86-64-v3-solver"), "");
  EXPECT_NE(instruction_set_warning(baseline, other.string(), "x86-64-v3"), "");
  EXPECT_FALSE(same_rounding("x86-64-v3-solver", "x86-64-v3-solver-nofma"));
}

TEST(CheckpointValidation, AChangedByteFailsTheChecksum) {
  const TempDir dir("checkpoint_flip");
  const auto path = dir.path() / "checkpoint.cbor";
  const Checkpoint cp = sample_checkpoint();
  write_checkpoint(path, cp.world, cp.contacts);
  std::string bytes = testing::read_text(path);
  // Flip one bit of the first disk's x (a double, stored as 8 bytes after its CBOR tag): the
  // file still parses, with another number.
  const double x = cp.world.disks.position[0].x;
  std::string pattern(8, '\0');
  for (int k = 0; k < 8; ++k)
    pattern[static_cast<std::size_t>(k)] =
        static_cast<char>((std::bit_cast<std::uint64_t>(x) >> (8 * (7 - k))) & 0xff);
  const auto at = bytes.find(pattern);
  ASSERT_NE(at, std::string::npos);
  bytes[at + 7] = static_cast<char>(bytes[at + 7] ^ 1);
  std::ofstream(path, std::ios::binary) << bytes;
  try {
    read_checkpoint(path);
    ADD_FAILURE() << "a changed checkpoint was read";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos) << e.what();
  }
}

// ---- The executable -------------------------------------------------------------------------

struct ProcessResult {
  int status = -1;
  std::string out, err;
};

/// Runs the cdshear executable with `args` (shell-quoted by the caller), capturing its output.
ProcessResult run_cdshear(const TempDir& dir, const std::string& args) {
  const auto out = dir.path() / "stdout.txt", err = dir.path() / "stderr.txt";
  const std::string cmd = std::string("'") + CDSHEAR_EXECUTABLE + "' " + args + " > '" +
                          out.string() + "' 2> '" + err.string() + "'";
  const int raw = std::system(cmd.c_str());
  ProcessResult r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  r.out = testing::read_text(out);
  r.err = testing::read_text(err);
  return r;
}

TEST(Executable, VersionNamesTheCommitOfItsSourceTree) {
  TempDir dir("exe_version");
  const ProcessResult r = run_cdshear(dir, "--version");
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.out.rfind("cdshear " CDSHEAR_VERSION " (commit ", 0), 0u) << r.out;
  EXPECT_NE(r.out.find(" build, instruction set "), std::string::npos) << r.out;
  // The commit the build read (cmake/build_info.cmake): 12 hex digits in a git tree.
  EXPECT_NE(r.out.find("commit " CDSHEAR_GIT_COMMIT), std::string::npos) << r.out;
  const std::string commit = CDSHEAR_GIT_COMMIT;
  if (commit != "unknown") {
    EXPECT_EQ(commit.size(), 12u);
    EXPECT_EQ(commit.find_first_not_of("0123456789abcdef"), std::string::npos) << commit;
  }
}

TEST(Executable, UnknownKeyGivesNonZeroExitAndMessage) {
  TempDir dir("exe_unknown");
  const std::string path = dir.write("bad.toml", scene_text("dt = 1e-3\ndtt = 2e-3\n"));
  const ProcessResult r =
      run_cdshear(dir, "scene -q '" + path + "' -o '" + (dir.path() / "out").string() + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find("error"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("step.dtt"), std::string::npos) << r.err;
}

TEST(Executable, OverlappingDisksGiveNonZeroExitNamingFileAndKey) {
  TempDir dir("exe_overlap");
  const std::string path =
      dir.write("overlap.toml", scene_text("dt = 1e-3\n",
                                           "[[disks]]\nposition = [1.0, 0.5]\nradius = 0.5\n"
                                           "[[disks]]\nposition = [1.9, 0.5]\nradius = 0.5\n"));
  const ProcessResult r =
      run_cdshear(dir, "scene -q '" + path + "' -o '" + (dir.path() / "out").string() + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("'disks'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("overlap"), std::string::npos) << r.err;
}

TEST(Executable, BlownUpRunGivesNonZeroExit) {
  TempDir dir("exe_blowup");
  const std::string path =
      dir.write("fast.toml", scene_text("dt = 1e-3\ncontact_margin = 0.0\n",
                                        "[[disks]]\nposition = [1.0, 2.0]\nradius = 0.5\n"
                                        "velocity = [400.0, 0.0]\n"
                                        "[[disks]]\nposition = [2.001, 2.0]\nradius = 0.5\n"
                                        "velocity = [-400.0, 0.0]\n"));
  const ProcessResult r =
      run_cdshear(dir, "scene -q '" + path + "' -o '" + (dir.path() / "out").string() + "'");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find("abort_overlap"), std::string::npos) << r.err;
}

TEST(Executable, ValidSceneRuns) {
  // Control for the tests above: the same base scene runs to the end with status 0.
  TempDir dir("exe_good");
  const std::string path = dir.write("good.toml", scene_text());
  const ProcessResult r =
      run_cdshear(dir, "scene -q '" + path + "' -o '" + (dir.path() / "out").string() + "'");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "out" / "timeseries.csv"));
}

}  // namespace
}  // namespace cdshear

#include "scene_file.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "case_settings.hpp"
#include "outputs.hpp"

namespace cdshear {

namespace {

/// True for a non-empty UTF-8 word (toml++ has checked the encoding) whose every character is
/// seen: no ASCII or C1 control, no space of any width (U+00A0, U+1680, U+2000 to U+200A,
/// U+202F, U+205F, U+3000), no line or paragraph separator, and no invisible format character
/// (U+00AD, U+200B to U+200F, U+202A to U+202E, U+2060 to U+206F, U+FEFF).
bool is_visible_word(const std::string& text) {
  if (text.empty()) return false;
  for (std::size_t i = 0; i < text.size();) {
    const auto byte = static_cast<unsigned char>(text[i]);
    const int length = byte < 0x80 ? 1 : byte < 0xe0 ? 2 : byte < 0xf0 ? 3 : 4;
    char32_t code = length == 1 ? byte : byte & (0x7f >> length);
    for (int k = 1; k < length && i + k < text.size(); ++k)
      code = (code << 6) | (static_cast<unsigned char>(text[i + k]) & 0x3f);
    i += static_cast<std::size_t>(length);
    const bool unseen = code <= 0x20 || (code >= 0x7f && code <= 0xa0) || code == 0xad ||
                        code == 0x1680 || (code >= 0x2000 && code <= 0x200f) ||
                        (code >= 0x2028 && code <= 0x202f) || code == 0x205f ||
                        (code >= 0x2060 && code <= 0x206f) || code == 0x3000 || code == 0xfeff;
    if (unseen) return false;
  }
  return true;
}

}  // namespace

AxisMode parse_axis_mode(TomlReader& t, const std::string& key) {
  const std::string m = t.choice(key, {"fixed", "imposed", "free"}, "fixed");
  return m == "free" ? AxisMode::kFree : m == "imposed" ? AxisMode::kImposed : AxisMode::kFixed;
}

SolverOptions read_solver_options(TomlReader& solver, SolverOptions s) {
  for (const Setting<SolverOptions>& row : solver_settings()) read_setting(row, solver, s);
  read_retired_solver_keys(solver, "solver", s);
  solver.finish();
  return s;
}

StepOptions read_step_options(TomlReader& step, TomlReader& solver) {
  StepOptions o;
  o.dt = step.positive("dt", o.dt);
  if (o.dt < kMinTimeStep)
    step.fail("dt", "must be at least " + format_number(kMinTimeStep) + ", got " +
                        format_number(o.dt) + " (" + std::string(kMinTimeStepReason) + ")");
  o.contact_margin = step.non_negative("contact_margin", o.contact_margin);
  o.displacement_bound = step.positive("displacement_bound", o.displacement_bound);
  o.abort_overlap = step.positive("abort_overlap", o.abort_overlap);
  step.finish();

  o.solver = read_solver_options(solver, o.solver);
  return o;
}

SceneFile load_scene_file(const std::string& path, const std::vector<std::string>& overrides) {
  SceneFile out;
  out.resolved = parse_toml_file(path);
  auto sources = std::make_shared<OverrideSources>();
  apply_overrides(out.resolved, overrides, sources.get(), path);
  out.file = path;
  out.sources = sources;
  TomlReader root = TomlReader::filling(out.resolved, path, sources);
  SceneDefinition& s = out.scene;

  TomlReader domain = root.table("domain");
  s.domain.periodic_x = domain.boolean("periodic_x", false);
  // A period asked for on the command line of a file that gives none is the --set's to answer.
  if (s.domain.periodic_x && !domain.has("length_x") && domain.overridden("domain.periodic_x"))
    domain.fail_between("length_x", {"domain.periodic_x"},
                        "is required with domain.periodic_x = true: give the period too (--set "
                        "domain.length_x=...)");
  if (s.domain.periodic_x)
    s.domain.length_x = domain.positive("length_x");
  else if (domain.has("length_x"))
    domain.fail("length_x", "is the period of a periodic x: give domain.periodic_x = true with it");
  domain.finish();

  TomlReader material = root.table("material");
  s.density = material.positive("density", 1.0);
  s.friction_disk_disk = material.non_negative("friction_disk_disk", 0.5);
  material.finish();

  s.gravity = root.vec2("gravity", Vec2{});

  TomlReader step = root.table("step");
  TomlReader solver = root.table("solver");
  out.step = read_step_options(step, solver);

  TomlReader run = root.table("run");
  out.run.duration = run.positive("duration");
  out.run.status_every =
      static_cast<std::uint64_t>(run.integer_in("status_every", 0, kMaxStepInterval, 0));
  out.run.sample_every =
      static_cast<std::uint64_t>(run.integer_in("sample_every", 1, kMaxStepInterval, 1));
  run.finish();

  for (TomlReader& w : root.tables("walls")) {
    Wall wall;
    wall.name = w.string("name", "wall" + std::to_string(s.walls.size()));
    // Names head CSV columns: printable, without separators, quotes or spaces, no two alike.
    if (!is_visible_word(wall.name) || wall.name.find_first_of(",\"'") != std::string::npos)
      w.fail("name",
             "must be a non-empty word of printable characters without commas, quotes or "
             "spaces (Unicode spaces, controls and invisible characters included)");
    for (const Wall& other : s.walls)
      if (other.name == wall.name) w.fail("name", "'" + wall.name + "' names two walls");
    for (const std::string_view suffix : TimeSeriesWriter::kWallColumnSuffixes)
      for (const std::string_view column : TimeSeriesWriter::kColumns)
        if (wall.name + std::string(suffix) == column)
          w.fail("name", "'" + wall.name + "' would head the column " + std::string(column) +
                             " of timeseries.csv twice");
    wall.point = w.vec2("point");
    wall.normal = w.vec2("normal");
    if (!(length(wall.normal) > 0.0)) w.fail("normal", "must not be zero");
    wall.friction = w.non_negative("friction", 0.5);
    wall.mode_x = parse_axis_mode(w, "mode_x");
    wall.mode_y = parse_axis_mode(w, "mode_y");
    wall.velocity = w.vec2("velocity", Vec2{});
    const bool free = wall.mode_x == AxisMode::kFree || wall.mode_y == AxisMode::kFree;
    if (!free && w.has("mass"))
      w.fail_between("mass", {w.full_key("mode_x"), w.full_key("mode_y")},
                     "is used on free axes only, and neither mode_x nor mode_y is \"free\"");
    wall.mass = free ? w.positive("mass") : 0.0;
    wall.applied_force = w.vec2("force", Vec2{});
    // A value the wall's modes would ignore is a mistake in the file: refuse it, naming the mode.
    const auto check_axis = [&](const char* axis, AxisMode mode, double velocity, double force) {
      const std::string mode_key = std::string("mode_") + axis;
      if (mode == AxisMode::kFixed && velocity != 0.0)
        w.fail_between("velocity", {w.full_key(mode_key)},
                       std::string(axis) + " = " + format_number(velocity) + " on a fixed axis (" +
                           mode_key + " = \"fixed\"), which does not move: give " + mode_key +
                           " = \"imposed\" to drive the wall at it, \"free\" to start it with it");
      if (mode != AxisMode::kFree && force != 0.0)
        w.fail_between("force", {w.full_key(mode_key)},
                       std::string(axis) + " = " + format_number(force) +
                           " on an axis that is not free (" + mode_key +
                           "): an applied force acts on free axes only");
    };
    check_axis("x", wall.mode_x, wall.velocity.x, wall.applied_force.x);
    check_axis("y", wall.mode_y, wall.velocity.y, wall.applied_force.y);
    w.finish();
    s.walls.push_back(wall);
  }
  for (TomlReader& d : root.tables("disks")) {
    DiskSpec disk;
    disk.position = d.vec2("position");
    if (s.domain.periodic_x &&
        !(std::abs(disk.position.x) <= kMaxPeriodsFromOrigin * s.domain.length_x))
      d.fail_between("position", {"domain.length_x"},
                     "x = " + format_number(disk.position.x) +
                         " is more than a million periods (domain.length_x = " +
                         format_number(s.domain.length_x) +
                         ") from 0: give the disk's place within the period");
    disk.radius = d.positive("radius");
    disk.velocity = d.vec2("velocity", Vec2{});
    disk.omega = d.number("omega", 0.0);
    d.finish();
    s.disks.push_back(disk);
  }
  for (TomlReader& r : root.tables("random_disks")) {
    RandomDisksSpec spec;
    spec.count = static_cast<std::size_t>(r.integer_in("count", 0, kMaxDisks));
    spec.region_min = r.vec2("region_min");
    spec.region_max = r.vec2("region_max");
    const bool min_given = r.has("diameter_min");  // before the default is filled in
    spec.diameter_min = r.positive("diameter_min", 0.8);
    spec.diameter_max = r.positive("diameter_max", 1.0);
    // The scene builder checks the order; here the file is known, and with it which bound the
    // file left at its default.
    if (spec.diameter_max < spec.diameter_min && !min_given)
      r.fail("diameter_max",
             "is " + format_number(spec.diameter_max) + ", below diameter_min, which is " +
                 format_number(spec.diameter_min) + " when not given: give diameter_min as well");
    if (s.domain.periodic_x)
      for (const auto& [key, corner] :
           {std::pair{"region_min", spec.region_min}, std::pair{"region_max", spec.region_max}})
        if (!(std::abs(corner.x) <= kMaxPeriodsFromOrigin * s.domain.length_x))
          r.fail_between(key, {"domain.length_x"},
                         "x = " + format_number(corner.x) +
                             " is more than a million periods (domain.length_x = " +
                             format_number(s.domain.length_x) +
                             ") from 0, where doubles no longer resolve a disk's place: give "
                             "the region within the period");
    spec.seed = static_cast<std::uint64_t>(
        r.integer_in("seed", 0, std::numeric_limits<std::int64_t>::max(), 1));
    r.finish();
    s.random_disks.push_back(spec);
  }
  s.overlap_tolerance = root.non_negative("overlap_tolerance", 1e-9);
  if (!(s.overlap_tolerance < out.step.abort_overlap))
    root.fail_between("overlap_tolerance", {"step.abort_overlap"},
                      "must be less than step.abort_overlap (" +
                          format_number(out.step.abort_overlap) +
                          "): a scene cannot start from an overlap its run would stop at");
  // As a case's step.contact_margin is at most 1 d: a margin wider than the disks makes nearly
  // every pair a candidate contact (1e300 listed all of them, gigabytes for a few thousand
  // disks). The bound is the disks' mean diameter, each disk counted once (a random group at the
  // middle of its range, a group of none not at all), so that one large disk among many small
  // ones does not lift it. The default margin stays allowed whatever the disks' size (a scene's
  // units are its own).
  double diameters = 0.0, disk_count = 0.0;
  for (const DiskSpec& d : s.disks) diameters += 2.0 * d.radius, disk_count += 1.0;
  for (const RandomDisksSpec& r : s.random_disks) {
    const auto count = static_cast<double>(r.count);
    diameters += count * (0.5 * r.diameter_min + 0.5 * r.diameter_max), disk_count += count;
  }
  const double mean_diameter = disk_count > 0.0 ? diameters / disk_count : 0.0;
  const double default_margin = StepOptions{}.contact_margin;
  if (out.step.contact_margin > std::max(mean_diameter, default_margin))
    root.fail_between("step.contact_margin", {"disks", "random_disks"},
                      "is " + format_number(out.step.contact_margin) +
                          ", more than the disks' mean diameter (" + format_number(mean_diameter) +
                          ") and the default " + format_number(default_margin) +
                          ": nearly every pair would be a candidate contact");
  root.finish();
  return out;
}

}  // namespace cdshear

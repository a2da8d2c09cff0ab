#include "case_file.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <sstream>

#include <fmt/format.h>

#include "case_settings.hpp"
#include "config_error.hpp"
#include "scene_file.hpp"
#include "toml_reader.hpp"

namespace cdshear {
namespace {

/// The most samples of the series a measured run may ask for (docs/reliability.md).
constexpr double kMaxSamples = 1e7;
/// ParaView snapshots of one run: each is two files (disks and contacts) of together some 300
/// bytes per disk, 1e5 of system 1 about 15 GB; an interval of 1e-300 (a typo) writes one a step.
constexpr double kMaxSnapshots = 1e5;
/// The most profile points (stripes times windows) a measured run may ask for.
constexpr double kMaxProfilePoints = 1e7;

/// The readers of a case file's tables, each created when first asked for, so that every table
/// is checked for unknown keys (finish) once all its settings are read.
class TableReaders {
 public:
  explicit TableReaders(TomlReader& root) : root_(root) {}
  TomlReader& operator[](const std::string& table) {
    for (auto& [name, reader] : readers_)
      if (name == table) return reader;
    return readers_.emplace_back(table, root_.table(table)).second;
  }
  void finish() {
    for (auto& [name, reader] : readers_) reader.finish();
    root_.finish();
  }

 private:
  TomlReader& root_;
  std::deque<std::pair<std::string, TomlReader>> readers_;  // references stay valid
};

/// The conditions between keys (each setting's own range is checked as it is read): the
/// `constraint` of the rows of case_settings(), which the docs print.
void check_constraints(const ShearCase& c, TableReaders& t) {
  if (c.diameter_max < c.diameter_min)
    t["system"].fail_between("diameter_max", {"system.diameter_min"}, "must be >= diameter_min");
  // Numbers the engine inverts (docs/reliability.md): the smallest disk's mass and moment of
  // inertia, the walls' and the piston's masses.
  if (const std::string why = disk_mass_problem(SceneDefinition{}.density, 0.5 * c.diameter_min);
      !why.empty())
    t["system"].fail("diameter_min", "a disk of this diameter cannot move: " + why);
  if (const std::string why = body_mass_problem(c.wall_mass); !why.empty())
    t["shear"].fail("wall_mass", why);
  if (const std::string why = body_mass_problem(c.preparation.piston_mass); !why.empty())
    t["preparation"].fail("piston_mass", why);
  if (c.height <= c.diameter_max)
    t["system"].fail_between("height", {"system.diameter_max"},
                             "L_y = " + format_number(c.height) +
                                 " must exceed the largest grain diameter " +
                                 format_number(c.diameter_max));
  // A wall speed at which no run the step limit allows moves the walls by one grain: a typo or
  // an underflow (1e-320), not a flow (the slowest of model.md section 6 is 0.005).
  // (The longer of dt_max and a given dt: a tiny given dt is the step limit's to refuse.)
  // Blamed on the time step when it came from the command line (a tiny dt_max) and the speed did
  // not, or would pass with the built-in dt_max (a campaign gives every run's speed), else on the
  // speed.
  if (const double longest = std::max(c.dt.value_or(c.dt_max), c.dt_max) * kMaxRunSteps;
      c.velocity * longest < c.diameter_max) {
    TomlReader& shear = t["shear"];
    const char* step_key = c.dt && *c.dt > c.dt_max ? "dt" : "dt_max";
    const bool speed_passes_alone =
        c.velocity * ShearCase{}.dt_max * kMaxRunSteps >= c.diameter_max;
    if ((!shear.overridden("shear.velocity") || speed_passes_alone) &&
        t["step"].overridden(std::string("step.") + step_key))
      t["step"].fail_between(step_key, {"shear.velocity", "system.diameter_max"},
                             "the longest run the step limit allows in steps of " +
                                 format_number(longest / kMaxRunSteps) + " (" +
                                 format_number(longest) +
                                 " time units) would move the walls at "
                                 "V = " +
                                 format_number(c.velocity) + " by less than one grain (" +
                                 format_number(c.diameter_max) + "); give at least " +
                                 format_number(c.diameter_max / (c.velocity * kMaxRunSteps)));
    shear.fail_between(
        "velocity", {"step.dt", "step.dt_max", "system.diameter_max"},
        "V = " + format_number(c.velocity) + " would move the walls by less than one grain (" +
            format_number(c.diameter_max) + ") in the longest run the step limit allows (" +
            format_number(longest) + " time units); give at least " +
            format_number(c.diameter_max / longest));
  }
  // The shear phase's steps, as a run counts them (checked_end_step): a case no run could take
  // is refused where it is read, by `settings` and `sweep` too. Blame the time step when given,
  // the wall speed when the step it sets (step.displacement_per_step / V, below step.dt_max) is
  // what makes the run too long.
  if (const double dt = c.dt ? *c.dt : default_time_step(c); !(c.duration / dt <= kMaxRunSteps)) {
    // The speed is blamed when the step it sets makes the run too long, unless the duration came
    // from the command line and nothing that sets the step did.
    const bool speed_set_it =
        !c.dt && dt < c.dt_max && c.duration / c.dt_max <= kMaxRunSteps &&
        !(t["shear"].overridden("shear.duration") && !t["shear"].overridden("shear.velocity") &&
          !t["step"].overridden("step.displacement_per_step"));
    t[c.dt ? "step" : "shear"].fail_between(
        c.dt ? "dt" : (speed_set_it ? "velocity" : "duration"),
        {"shear.duration", "step.dt", "shear.velocity", "step.displacement_per_step",
         "step.dt_max"},
        (speed_set_it ? "V = " + format_number(c.velocity) + " sets the time step to " +
                            format_number(dt) + " (step.displacement_per_step / V): "
                      : std::string()) +
            "shear.duration = " + format_number(c.duration) + " in steps of " + format_number(dt) +
            " is more than the limit of " + format_number(kMaxRunSteps) +
            " steps (docs/reliability.md)");
  }
  // The preparation counts its phases and windows in steps of its own time steps: a limit that
  // asks for more steps than a run may take is a typo, and a window longer than the limit could
  // never end a phase.
  const PreparationOptions& po = c.preparation;
  if (const double shortest = std::min(po.step.dt, po.compression_dt);
      !(po.max_time_per_phase / shortest <= kMaxRunSteps)) {
    // Blame the time step when it was given (the limit's default is no typo).
    const std::string dt_key = po.step.dt <= po.compression_dt ? "dt" : "compression_dt";
    TomlReader& p = t["preparation"];
    const bool dt_given = p.has(dt_key);
    p.fail_between(
        dt_given ? dt_key : "max_time_per_phase",
        {"preparation.max_time_per_phase", "preparation.dt", "preparation.compression_dt"},
        "preparation.max_time_per_phase = " + format_number(po.max_time_per_phase) +
            " time units in steps of " + format_number(shortest) + " is more than the limit of " +
            format_number(kMaxRunSteps) + " steps (docs/reliability.md)");
  }
  if (po.window_time > po.max_time_per_phase)
    t["preparation"].fail_between("window_time", {"preparation.max_time_per_phase"},
                                  "must be at most preparation.max_time_per_phase (" +
                                      format_number(po.max_time_per_phase) + "), got " +
                                      format_number(po.window_time));
  // An interval longer than the run is allowed: a run extended by --resume reaches it.
  if (c.snapshot_interval > 0 && !(c.duration / c.snapshot_interval <= kMaxSnapshots))
    t["output"].fail_between(
        "snapshot_interval", {"shear.duration"},
        fmt::format("{:.3g} snapshots over the duration {} exceed the limit of {:.0e} (two files "
                    "each): take them less often",
                    c.duration / c.snapshot_interval, c.duration, kMaxSnapshots));
  const MeasureOptions& mo = c.measure;
  TomlReader& m = t["measure"];
  // A closed contact must be a candidate of the sample's step: its gap at the start of the step
  // was below the margin, and a step moves a pair by far less than half of it.
  if (mo.enabled && mo.contact_gap > 0.5 * c.step.contact_margin)
    m.fail_between("contact_gap", {"step.contact_margin", "measure.enabled"},
                   "must be at most half of step.contact_margin (" +
                       format_number(0.5 * c.step.contact_margin) + "), got " +
                       format_number(mo.contact_gap));
  for (std::size_t k = 0; k < mo.boundary_thickness.size(); ++k) {
    const double h = mo.boundary_thickness[k];
    if (!(h <= 0.5 * c.height))  // the two layers would overlap
      m.fail_between("boundary_thickness", {"system.height"},
                     "every h must be at most half of L_y (" + format_number(0.5 * c.height) +
                         "), got " + format_number(h));
    for (std::size_t j = 0; j < k; ++j)
      if (std::abs(mo.boundary_thickness[j] - h) < 1e-9)
        m.fail("boundary_thickness", "lists h = " + format_number(h) + " twice");
  }
  if (mo.window < mo.sample_interval)
    m.fail_between(
        "window", {"measure.sample_interval"},
        "must be at least measure.sample_interval (" + format_number(mo.sample_interval) + ")");
  // run.h5 holds about 150 bytes per sample and per profile point (a stripe in a window), kept
  // in memory and rewritten at every checkpoint: a run that would grow it beyond 1.5 GB is a
  // typo, refused where the case is read (by `run`, `settings` and `sweep` alike).
  if (mo.enabled) {
    if (mo.sample_interval > c.duration)  // the run would end before its first sample
      m.fail_between("sample_interval", {"shear.duration", "measure.enabled"},
                     "is longer than shear.duration (" + format_number(c.duration) +
                         "): the run would take no sample; sample more often or shear longer");
    if (!(c.duration / mo.sample_interval <= kMaxSamples))
      m.fail_between("sample_interval", {"shear.duration", "measure.enabled"},
                     fmt::format("{:.3g} samples over the duration {} exceed the limit of {:.0e} "
                                 "(run.h5 would grow beyond 1.5 GB): sample less often",
                                 c.duration / mo.sample_interval, c.duration, kMaxSamples));
    const double stripes = stripe_count(mo, c.height);
    const double windows = std::max(1.0, std::ceil(c.duration / mo.window));
    if (!(stripes * windows <= kMaxProfilePoints))
      m.fail_between(
          "stripe_thickness",
          {"shear.duration", "measure.window", "measure.stripe_span", "system.height",
           "measure.enabled"},
          fmt::format("{:.3g} stripes (stripe_span x L_y / stripe_thickness) over {:.3g} "
                      "windows exceed the limit of {:.0e} profile points (run.h5 would grow "
                      "beyond 1.5 GB): thicker stripes or longer windows",
                      stripes, windows, kMaxProfilePoints));
  }
  // A given step is bounded by its range; the auto rule's, from V, here (after the run's size:
  // a V so large also asks for too many steps).
  if (!c.dt)
    if (const double dt = default_time_step(c); !(dt >= kMinTimeStep))
      t["step"].fail_between(
          "dt", {"shear.velocity", "step.displacement_per_step", "step.dt_max"},
          fmt::format("\"auto\" gives min(dt_max, displacement_per_step / V) = {:.3g}, below "
                      "{:.0e} ({}): give a longer step.displacement_per_step or a smaller V",
                      dt, kMinTimeStep, kMinTimeStepReason));
}

}  // namespace

ShearCase case_from_toml(const toml::table& table, const std::string& file, ShearCase c,
                         std::shared_ptr<const OverrideSources> sources) {
  TomlReader root(table, file, "", std::move(sources));
  TableReaders tables(root);
  if (tables["output"].has("sample_interval"))
    tables["output"].fail("sample_interval",
                          "moved to measure.sample_interval (the series of a shear run are in "
                          "run.h5)");
  for (const CaseSetting& s : case_settings()) read_setting(s, tables[s.table], c);
  read_retired_solver_keys(tables["solver"], "solver", c.step.solver);
  read_retired_solver_keys(tables["preparation"], "preparation", c.preparation.step.solver);
  check_constraints(c, tables);
  tables.finish();
  if (c.measure.boundary_thickness.empty())
    c.measure.boundary_thickness = default_boundary_thickness(c.height);
  sync_preparation(c);
  return c;
}

namespace {

/// A case file comes after the `--system` preset: where it gives the system's own numbers (its
/// grains, height or normal stress) other values than the preset's, `--system` would change
/// nothing there, unseen (a file written by `cdshear settings` gives them all). Refused, naming
/// the key; a --set of the key is meant and passes.
void check_file_keeps_system(const toml::table& table, const std::string& file, int system,
                             const ShearCase& preset, const OverrideSources& given_on_line) {
  const struct {
    const char* key;
    double value;
  } identity[] = {{"system.n", static_cast<double>(preset.n)},
                  {"system.height", preset.height},
                  {"shear.normal_stress", preset.normal_stress}};
  for (const auto& [key, value] : identity) {
    if (given_on_line.contains(key)) continue;
    const std::optional<double> given = table.at_path(key).value<double>();
    if (!given || *given == value) continue;
    throw ConfigError(file, key,
                      "is " + format_number(*given) + " where --system " + std::to_string(system) +
                          " gives " + format_number(value) +
                          ": the case file comes after the preset, so --system would change "
                          "nothing here; give the key with --set, remove it from the file (whose "
                          "shear.duration and measure.window, if given, also win over the "
                          "preset's), or leave out --system (docs/case-files.md, precedence)");
  }
}

}  // namespace

ShearCase load_case(const CaseSource& src) {
  ShearCase c;
  sync_preparation(c);
  if (src.system) {
    try {
      apply_system_preset(c, *src.system);
    } catch (const std::invalid_argument& e) {
      throw ConfigError("--system", "", e.what());
    }
  }
  toml::table table;
  std::string name = "built-in default case";
  if (!src.file.empty()) {
    table = parse_toml_file(src.file);
    name = src.file;
  }
  auto sources = std::make_shared<OverrideSources>();
  if (src.velocity) {
    if (!table.contains("shear")) table.insert("shear", toml::table{});
    table["shear"].as_table()->insert_or_assign("velocity", *src.velocity);
    (*sources)["shear.velocity"] = "--velocity";
  }
  apply_overrides(table, src.overrides, sources.get(), src.file);
  if (src.system && !src.file.empty())
    check_file_keeps_system(table, src.file, *src.system, c, *sources);
  if (src.velocity && *src.velocity <= 0.0)
    throw ConfigError("--velocity", "shear.velocity",
                      "must be > 0, got " + format_number(*src.velocity), "shear.velocity");
  ShearCase resolved = case_from_toml(table, name, c, sources);
  resolved.step.solver.threads = src.threads;
  resolved.preparation.step.solver.threads = src.threads;
  return resolved;
}

std::vector<std::string> case_settings_without_effect(const ShearCase& c) {
  const SolverOptions& o = c.step.solver;
  const SolverOptions defaults = ShearCase{}.step.solver;
  std::vector<std::string> notes = solver_settings_without_effect(o, defaults, "solver");
  // The coloured order's bands are 4 largest diameters tall (contact_dynamics.cpp), and the
  // correction needs kSlabCorrectionMinBands of them: disk centres spread over (20 - 1) x 4
  // d_max = 76 d_max. Named only well below that (0.9 of it), where no dilation of the cell
  // under the walls' pressure reaches it.
  const double needed_span =
      (static_cast<double>(kSlabCorrectionMinBands) - 1.0) * 4.0 * c.diameter_max;
  if (o.slab_correction_period != defaults.slab_correction_period && asks_for_slab_correction(o) &&
      c.height < 0.9 * needed_span)
    notes.push_back(fmt::format(
        "solver.slab_correction_period = {} has no effect in this cell: the slab correction "
        "runs in packings of {} bands of 4 largest diameters or more (L_y of about {} d_max = "
        "{}), system.height is {}",
        o.slab_correction_period, kSlabCorrectionMinBands, 4 * kSlabCorrectionMinBands,
        format_number(4.0 * kSlabCorrectionMinBands * c.diameter_max), format_number(c.height)));
  return notes;
}

nlohmann::json case_identity(const ShearCase& c) {
  return {{"n", c.n},
          {"height", c.height},
          {"diameter_min", c.diameter_min},
          {"diameter_max", c.diameter_max},
          {"seed", c.seed},
          {"velocity", c.velocity},
          {"normal_stress", c.normal_stress},
          {"friction_grain", c.friction_grain},
          {"friction_wall", c.friction_wall},
          {"wall_mass", c.wall_mass},
          {"initial_velocity", c.initial_velocity}};
}

std::string differing_identity_key(const nlohmann::json& stored, const nlohmann::json& wanted) {
  for (const auto& [key, value] : wanted.items())
    if (stored.contains(key) && stored.at(key) != value) return key;
  return "";
}

toml::table case_to_toml(const ShearCase& c) {
  toml::table out;
  for (const CaseSetting& s : case_settings()) {
    if (!out.contains(s.table)) out.insert(s.table, toml::table{});
    insert_setting(*out[s.table].as_table(), s.key, s.get(c));
  }
  return out;
}

std::vector<std::string> keys_missing_from(const toml::table& table, const toml::table& resolved) {
  std::vector<std::string> missing;
  for (const auto& [section, values] : resolved) {
    const toml::table* given = table[section].as_table();
    const toml::table* wanted = values.as_table();
    if (wanted == nullptr) continue;
    for (const auto& [key, value] : *wanted)
      if (given == nullptr || !given->contains(key))
        missing.push_back(std::string(section.str()) + "." + std::string(key.str()));
  }
  return missing;
}

}  // namespace cdshear

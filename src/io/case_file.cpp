#include "case_file.hpp"

#include <cmath>
#include <limits>
#include <sstream>

#include "config_error.hpp"
#include "scene_file.hpp"
#include "toml_reader.hpp"

namespace cdshear {
namespace {

std::uint64_t read_seed(TomlReader& t, const std::string& key, std::uint64_t fallback) {
  return static_cast<std::uint64_t>(t.integer_in(key, 0, std::numeric_limits<std::int64_t>::max(),
                                                 static_cast<std::int64_t>(fallback)));
}

}  // namespace

ShearCase case_from_toml(const toml::table& table, const std::string& file, ShearCase c,
                         std::shared_ptr<const OverrideSources> sources) {
  TomlReader root(table, file, "", std::move(sources));

  TomlReader sys = root.table("system");
  c.n = static_cast<std::size_t>(sys.integer_in("n", 1, kMaxDisks, static_cast<std::int64_t>(c.n)));
  c.height = sys.positive("height", c.height);
  c.diameter_min = sys.positive("diameter_min", c.diameter_min);
  c.diameter_max = sys.positive("diameter_max", c.diameter_max);
  if (c.diameter_max < c.diameter_min) sys.fail("diameter_max", "must be >= diameter_min");
  if (c.height <= c.diameter_max)
    sys.fail("height", "L_y = " + format_number(c.height) +
                           " must exceed the largest grain diameter " +
                           format_number(c.diameter_max));
  c.seed = read_seed(sys, "seed", c.seed);
  sys.finish();

  TomlReader sh = root.table("shear");
  c.velocity = sh.positive("velocity", c.velocity);
  c.normal_stress = sh.positive("normal_stress", c.normal_stress);
  c.friction_grain = sh.non_negative("friction_grain", c.friction_grain);
  c.friction_wall = sh.non_negative("friction_wall", c.friction_wall);
  c.wall_mass = sh.positive("wall_mass", c.wall_mass);
  c.duration = sh.positive("duration", c.duration);
  sh.finish();

  TomlReader step = root.table("step");
  if (step.has("dt")) {
    const toml::node* dt = table.at_path("step.dt").node();
    if (dt->is_string()) {
      if (step.string("dt") != "auto") step.fail("dt", "must be a number or \"auto\"");
      c.dt.reset();
    } else {
      c.dt = step.positive("dt");
    }
  }
  c.dt_max = step.positive("dt_max", c.dt_max);
  // A wall speed at which no run the step limit allows moves the walls by one grain: a typo or
  // an underflow (1e-320), not a flow (the slowest of model.md section 6 is 0.005).
  // (The longer of dt_max and a given dt: a tiny given dt is the step limit's to refuse.)
  if (const double longest = std::max(c.dt.value_or(c.dt_max), c.dt_max) * kMaxRunSteps;
      c.velocity * longest < c.diameter_max)
    sh.fail("velocity",
            "V = " + format_number(c.velocity) + " would move the walls by less than one grain (" +
                format_number(c.diameter_max) + ") in the longest run the step limit allows (" +
                format_number(longest) + " time units); give at least " +
                format_number(c.diameter_max / longest));
  c.displacement_per_step = step.positive("displacement_per_step", c.displacement_per_step);
  c.step.contact_margin = step.non_negative("contact_margin", c.step.contact_margin);
  c.step.displacement_bound = step.positive("displacement_bound", c.step.displacement_bound);
  c.step.abort_overlap = step.positive("abort_overlap", c.step.abort_overlap);
  step.finish();

  TomlReader solver = root.table("solver");
  c.step.solver = read_solver_options(solver, c.step.solver);

  TomlReader prep = root.table("preparation");
  PreparationOptions& p = c.preparation;
  p.initial_solid_fraction = prep.positive("initial_solid_fraction", p.initial_solid_fraction);
  if (p.initial_solid_fraction >= 0.55)
    prep.fail("initial_solid_fraction", "random placement cannot exceed about 0.55");
  p.gravity = prep.positive("gravity", p.gravity);
  p.piston_stress = prep.positive("piston_stress", p.piston_stress);
  p.piston_mass = prep.positive("piston_mass", p.piston_mass);
  p.settle_kinetic_energy_per_disk =
      prep.positive("settle_kinetic_energy_per_disk", p.settle_kinetic_energy_per_disk);
  p.kinetic_energy_per_disk = prep.positive("kinetic_energy_per_disk", p.kinetic_energy_per_disk);
  p.piston_speed = prep.positive("piston_speed", p.piston_speed);
  p.force_balance = prep.positive("force_balance", p.force_balance);
  p.window_time = prep.positive("window_time", p.window_time);
  p.max_time_per_phase = prep.positive("max_time_per_phase", p.max_time_per_phase);
  p.step.dt = prep.positive("dt", p.step.dt);
  p.compression_dt = prep.positive("compression_dt", p.compression_dt);
  p.step.solver.alpha = prep.positive("alpha", p.step.solver.alpha);
  p.step.solver.max_sweeps =
      static_cast<int>(prep.integer_in("max_sweeps", 1, kMaxSweeps, p.step.solver.max_sweeps));
  p.step.solver.relaxation = prep.positive("relaxation", p.step.solver.relaxation);
  if (!(p.step.solver.relaxation < 2.0))
    prep.fail("relaxation", "must be < 2 (projected SOR diverges)");
  p.step.solver.order = read_contact_order(prep, p.step.solver.order);
  p.step.solver.skip_dormant = prep.boolean("skip_dormant", p.step.solver.skip_dormant);
  p.step.solver.slab_correction_period = static_cast<int>(
      prep.integer_in("slab_correction_period", 0, 1000, p.step.solver.slab_correction_period));
  c.packing_file = prep.string("packing", c.packing_file);
  prep.finish();

  TomlReader out = root.table("output");
  if (out.has("sample_interval"))
    out.fail("sample_interval",
             "moved to measure.sample_interval (the series of a shear run are in run.h5)");
  c.status_interval = out.non_negative("status_interval", c.status_interval);
  c.checkpoint_interval = out.non_negative("checkpoint_interval", c.checkpoint_interval);
  c.snapshot_interval = out.non_negative("snapshot_interval", c.snapshot_interval);
  out.finish();

  TomlReader m = root.table("measure");
  MeasureOptions& mo = c.measure;
  mo.enabled = m.boolean("enabled", mo.enabled);
  mo.sample_interval = m.positive("sample_interval", mo.sample_interval);
  mo.window = m.positive("window", mo.window);
  mo.stripe_thickness = m.positive("stripe_thickness", mo.stripe_thickness);
  mo.stripe_span = m.positive("stripe_span", mo.stripe_span);
  if (mo.stripe_span < 1.0 || mo.stripe_span > 10.0)
    m.fail("stripe_span", "must be between 1 and 10 (times the nominal L_y), got " +
                              format_number(mo.stripe_span));
  mo.force_threshold = m.non_negative("force_threshold", mo.force_threshold);
  mo.contact_gap = m.positive("contact_gap", mo.contact_gap);
  // A closed contact must be a candidate of the sample's step: its gap at the start of the step
  // was below the margin, and a step moves a pair by far less than half of it.
  if (mo.enabled && mo.contact_gap > 0.5 * c.step.contact_margin)
    m.fail("contact_gap", "must be at most half of step.contact_margin (" +
                              format_number(0.5 * c.step.contact_margin) + "), got " +
                              format_number(mo.contact_gap));
  if (m.has("boundary_thickness")) {
    mo.boundary_thickness = m.number_array("boundary_thickness");
    if (mo.boundary_thickness.empty()) m.fail("boundary_thickness", "must list at least one h");
    for (std::size_t k = 0; k < mo.boundary_thickness.size(); ++k) {
      const double h = mo.boundary_thickness[k];
      if (!(h > 0.0) || !std::isfinite(h))
        m.fail("boundary_thickness", "every h must be a positive number, got " + format_number(h));
      if (!(h <= 0.5 * c.height))  // the two layers would overlap
        m.fail("boundary_thickness", "every h must be at most half of L_y (" +
                                         format_number(0.5 * c.height) + "), got " +
                                         format_number(h));
      for (std::size_t j = 0; j < k; ++j)
        if (std::abs(mo.boundary_thickness[j] - h) < 1e-9)
          m.fail("boundary_thickness", "lists h = " + format_number(h) + " twice");
    }
  }
  if (mo.window < mo.sample_interval)
    m.fail("window",
           "must be at least measure.sample_interval (" + format_number(mo.sample_interval) + ")");
  m.finish();

  root.finish();
  if (c.measure.boundary_thickness.empty())
    c.measure.boundary_thickness = default_boundary_thickness(c.height);
  sync_preparation(c);
  return c;
}

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
  apply_overrides(table, src.overrides, sources.get());
  if (src.velocity && *src.velocity <= 0.0)
    throw ConfigError("--velocity", "shear.velocity", "must be > 0");
  ShearCase resolved = case_from_toml(table, name, c, sources);
  resolved.step.solver.threads = src.threads;
  resolved.preparation.step.solver.threads = src.threads;
  return resolved;
}

toml::table case_to_toml(const ShearCase& c) {
  const PreparationOptions& p = c.preparation;
  const SolverOptions& s = c.step.solver;
  toml::table step{{"dt_max", c.dt_max},
                   {"displacement_per_step", c.displacement_per_step},
                   {"contact_margin", c.step.contact_margin},
                   {"displacement_bound", c.step.displacement_bound},
                   {"abort_overlap", c.step.abort_overlap}};
  toml::array boundary;
  for (const double h : c.measure.boundary_thickness) boundary.push_back(h);
  if (c.dt)
    step.insert("dt", *c.dt);
  else
    step.insert("dt", "auto");
  toml::table solver{
      {"alpha", s.alpha},
      {"converged_fraction", s.converged_fraction},
      {"max_sweeps", s.max_sweeps},
      {"order", contact_order_name(s.order)},
      {"skip_dormant", s.skip_dormant},
      {"relaxation", s.relaxation},
      {"criterion", s.criterion == ConvergenceCriterion::kError ? "error" : "change"},
      {"seed", static_cast<std::int64_t>(s.seed)},
      // Always written: an absent key reads back as the shear default, not as off.
      {"anderson_depth", s.anderson_depth},
      {"anderson_period", s.anderson_period},
      {"slab_correction_period", s.slab_correction_period},
      {"slab_correction_min_bands", s.slab_correction_min_bands},
      {"anderson_period_with_slab_correction", s.anderson_period_with_slab_correction},
      {"newton_iterations", s.newton_iterations}};
  return toml::table{
      {"system", toml::table{{"n", static_cast<std::int64_t>(c.n)},
                             {"height", c.height},
                             {"diameter_min", c.diameter_min},
                             {"diameter_max", c.diameter_max},
                             {"seed", static_cast<std::int64_t>(c.seed)}}},
      {"shear", toml::table{{"velocity", c.velocity},
                            {"normal_stress", c.normal_stress},
                            {"friction_grain", c.friction_grain},
                            {"friction_wall", c.friction_wall},
                            {"wall_mass", c.wall_mass},
                            {"duration", c.duration}}},
      {"step", step},
      {"solver", solver},
      {"preparation",
       toml::table{{"initial_solid_fraction", p.initial_solid_fraction},
                   {"gravity", p.gravity},
                   {"piston_stress", p.piston_stress},
                   {"piston_mass", p.piston_mass},
                   {"settle_kinetic_energy_per_disk", p.settle_kinetic_energy_per_disk},
                   {"kinetic_energy_per_disk", p.kinetic_energy_per_disk},
                   {"piston_speed", p.piston_speed},
                   {"force_balance", p.force_balance},
                   {"window_time", p.window_time},
                   {"max_time_per_phase", p.max_time_per_phase},
                   {"dt", p.step.dt},
                   {"compression_dt", p.compression_dt},
                   {"alpha", p.step.solver.alpha},
                   {"max_sweeps", p.step.solver.max_sweeps},
                   {"relaxation", p.step.solver.relaxation},
                   {"order", contact_order_name(p.step.solver.order)},
                   {"skip_dormant", p.step.solver.skip_dormant},
                   {"slab_correction_period", p.step.solver.slab_correction_period},
                   {"packing", c.packing_file}}},
      {"output", toml::table{{"status_interval", c.status_interval},
                             {"checkpoint_interval", c.checkpoint_interval},
                             {"snapshot_interval", c.snapshot_interval}}},
      {"measure", toml::table{{"enabled", c.measure.enabled},
                              {"sample_interval", c.measure.sample_interval},
                              {"window", c.measure.window},
                              {"stripe_thickness", c.measure.stripe_thickness},
                              {"stripe_span", c.measure.stripe_span},
                              {"boundary_thickness", boundary},
                              {"force_threshold", c.measure.force_threshold},
                              {"contact_gap", c.measure.contact_gap}}}};
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

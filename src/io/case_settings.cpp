#include "case_settings.hpp"

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <type_traits>

#include "toml_text.hpp"

// The rows below name only the fields that differ from Setting's defaults (designated
// initializers); the others keep their defaults, which is what this warning is about.
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"

namespace cdshear {
namespace {

using enum SettingType;
using enum SettingPhase;

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Binds a setting to a field of T, given as a lambda `[](auto& t) -> auto& { return t.x; }`:
/// get and set follow from the field's C++ type.
template <class T, class Field>
Setting<T> bind(Setting<T> s, Field field) {
  using V = std::remove_cvref_t<decltype(field(std::declval<T&>()))>;
  s.get = [field](const T& t) -> SettingValue {
    const V& v = field(t);
    if constexpr (std::is_same_v<V, bool> || std::is_same_v<V, double> ||
                  std::is_same_v<V, std::string> || std::is_same_v<V, std::vector<double>>)
      return v;
    else if constexpr (std::is_integral_v<V>)
      return static_cast<std::int64_t>(v);
    else if constexpr (std::is_same_v<V, ContactOrder>)
      return std::string(contact_order_name(v));
    else if constexpr (std::is_same_v<V, std::optional<double>>)
      return v ? SettingValue(*v) : SettingValue(std::string("auto"));
    else
      static_assert(sizeof(V) == 0, "no setting type for this field");
  };
  s.set = [field](T& t, const SettingValue& value) {
    V& v = field(t);
    if constexpr (std::is_same_v<V, bool> || std::is_same_v<V, double> ||
                  std::is_same_v<V, std::string> || std::is_same_v<V, std::vector<double>>)
      v = std::get<V>(value);
    else if constexpr (std::is_integral_v<V>)
      v = static_cast<V>(std::get<std::int64_t>(value));  // within the range read_setting checked
    else if constexpr (std::is_same_v<V, ContactOrder>)
      contact_order_from_name(std::get<std::string>(value), v);
    else if constexpr (std::is_same_v<V, std::optional<double>>)
      v = std::holds_alternative<double>(value) ? std::optional<double>(std::get<double>(value))
                                                : std::nullopt;
  };
  return s;
}

/// A [solver] row placed in a case table, on the SolverOptions that `options` selects.
template <class Options>
CaseSetting lift(const Setting<SolverOptions>& row, std::string table, SettingPhase phase,
                 Options options, std::string meaning) {
  CaseSetting s;
  s.table = std::move(table);
  s.key = row.key;
  s.type = row.type;
  s.unit = row.unit;
  s.meaning = meaning.empty() ? row.meaning : std::move(meaning);
  s.phase = phase;
  s.lo = row.lo;
  s.hi = row.hi;
  s.lo_open = row.lo_open;
  s.hi_open = row.hi_open;
  s.range_reason = row.range_reason;
  s.choices = row.choices;
  s.constraint = row.constraint;
  s.get = [get = row.get, options](const ShearCase& c) { return get(options(c)); };
  s.set = [set = row.set, options](ShearCase& c, const SettingValue& v) { set(options(c), v); };
  return s;
}

const Setting<SolverOptions>& solver_row(const std::string& key) {
  for (const auto& row : solver_settings())
    if (row.key == key) return row;
  throw std::logic_error("no solver setting " + key);
}

/// A key of read_retired_solver_keys: its table, what the solver now does in its place, and
/// whether the file's value (read with the key's type) gives that.
struct RetiredSolverKey {
  const char* table;
  const char* key;
  const char* now;
  bool (*accepts)(TomlReader& reader, const std::string& key, const SolverOptions& options);
};

// The texts below name these values.
static_assert(kSlabCorrectionMinBands == 20 && kMixPeriodFactorWithSlabCorrection == 2);

const RetiredSolverKey kRetiredSolverKeys[] = {
    {"solver", "criterion", "alpha bounds the last sweep's change (\"change\")",
     [](TomlReader& r, const std::string& k, const SolverOptions&) {
       return r.string(k) == "change";
     }},
    {"solver", "slab_correction_min_bands",
     "the slab correction runs in packings of 20 bands or more",
     [](TomlReader& r, const std::string& k, const SolverOptions& o) {
       const std::int64_t v = r.integer(k);
       return !asks_for_slab_correction(o) ||
              v == static_cast<std::int64_t>(kSlabCorrectionMinBands);
     }},
    {"solver", "anderson_period_with_slab_correction",
     "where the slab correction runs, the mix runs every 2 anderson_period sweeps",
     [](TomlReader& r, const std::string& k, const SolverOptions& o) {
       const std::int64_t v = r.integer(k);
       return !asks_for_slab_correction(o) || o.anderson_depth == 0 ||
              v ==
                  static_cast<std::int64_t>(kMixPeriodFactorWithSlabCorrection) * o.anderson_period;
     }},
    {"preparation", "relaxation", "the preparation's sweeps are plain Gauss-Seidel (1)",
     [](TomlReader& r, const std::string& k, const SolverOptions&) { return r.number(k) == 1.0; }},
    {"preparation", "skip_dormant", "the preparation sweeps every contact (false)",
     [](TomlReader& r, const std::string& k, const SolverOptions&) { return !r.boolean(k); }},
    {"preparation", "slab_correction_period", "the preparation runs no slab correction (0)",
     [](TomlReader& r, const std::string& k, const SolverOptions&) { return r.integer(k) == 0; }},
};

std::int64_t integer_bound(double v) {
  if (v >= 9.2e18) return std::numeric_limits<std::int64_t>::max();
  if (v <= -9.2e18) return std::numeric_limits<std::int64_t>::min();
  return static_cast<std::int64_t>(v);
}

std::string bound_text(double v, bool integer) {
  return integer ? std::to_string(integer_bound(v)) : format_number(v);
}

/// "> 0", ">= 0 and < 2", "between 1 and 10": what a value must be, for errors.
template <class T>
std::string bounds_problem(const Setting<T>& s) {
  const bool integer = s.type == kInteger;
  const bool has_lo = std::isfinite(s.lo),
             has_hi = std::isfinite(s.hi) && (!integer || s.hi < 9.2e18);
  if (has_lo && has_hi && !s.lo_open && !s.hi_open)
    return "between " + bound_text(s.lo, integer) + " and " + bound_text(s.hi, integer);
  std::string text;
  if (has_lo) text = (s.lo_open ? "> " : ">= ") + bound_text(s.lo, integer);
  if (has_hi)
    text += (text.empty() ? "" : " and ") + std::string(s.hi_open ? "< " : "<= ") +
            bound_text(s.hi, integer);
  return text;
}

template <class T>
bool in_range(const Setting<T>& s, double v) {
  return (s.lo_open ? v > s.lo : v >= s.lo) && (s.hi_open ? v < s.hi : v <= s.hi);
}

template <class T>
void check_range(const Setting<T>& s, TomlReader& r, double v, const std::string& what) {
  if (in_range(s, v)) return;
  r.fail(s.key, what + "must be " + bounds_problem(s) + ", got " + format_number(v) +
                    (s.range_reason.empty() ? "" : " (" + s.range_reason + ")"));
}

std::string escape_markdown(std::string s) {
  for (std::size_t i = 0; (i = s.find('|', i)) != std::string::npos; i += 2) s.insert(i, "\\");
  return s;
}

/// Splits `text` into lines of at most `width` characters at spaces.
std::vector<std::string> wrap(const std::string& text, std::size_t width) {
  std::vector<std::string> lines;
  std::string line;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find(' ', start);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(start, end - start);
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      lines.push_back(line);
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
    start = end + 1;
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

// A table, one row per key, in the order of the docs: longer than a function should be, because
// splitting it would scatter the keys of one file table over several places.
std::vector<Setting<SolverOptions>> make_solver_settings() {
  using S = Setting<SolverOptions>;
  const std::vector<std::string> orders(std::begin(kContactOrderNames),
                                        std::end(kContactOrderNames));
  return {
      bind(
          S{.key = "alpha",
            .meaning = "convergence tolerance: a contact is converged when the squared relative "
                       "change of its impulse over a sweep is below alpha (model.md section 3, "
                       "item 5, uses 1e-6)",
            .lo = 0.0,
            .lo_open = true},
          [](auto& o) -> auto& { return o.alpha; }),
      bind(
          S{.key = "converged_fraction",
            .meaning = "share of the contacts that must meet alpha, with the mean impulse, for "
                       "the step to stop sweeping",
            .lo = 0.0,
            .hi = 1.0,
            .lo_open = true},
          [](auto& o) -> auto& { return o.converged_fraction; }),
      bind(
          S{.key = "max_sweeps",
            .type = kInteger,
            .meaning =
                "most sweeps per step (the cap); with relaxation > 1, up to as many more with "
                "relaxation 1 (the plain finish)",
            .lo = 1,
            .hi = static_cast<double>(kMaxSweeps)},
          [](auto& o) -> auto& { return o.max_sweeps; }),
      bind(
          S{.key = "order",
            .type = kChoice,
            .meaning = "order of the contacts in a sweep: coloured (the order `--threads` share) "
                       "or random (shuffled each step; docs/performance.md)",
            .choices = orders},
          [](auto& o) -> auto& { return o.order; }),
      bind(
          S{.key = "skip_dormant",
            .type = kBoolean,
            .meaning = "leave open, separating contacts out of the sweeps, looking at them every "
                       "8 sweeps"},
          [](auto& o) -> auto& { return o.skip_dormant; }),
      bind(
          S{.key = "relaxation",
            .meaning = "projected over-relaxation of each update (1: plain Gauss-Seidel)",
            .lo = 1.0,
            .hi = 2.0,
            .hi_open = true,
            .range_reason = "projected SOR diverges at 2 and above; under-relaxation never paid "
                            "(docs/performance.md)"},
          [](auto& o) -> auto& { return o.relaxation; }),
      bind(
          S{.key = "anderson_depth",
            .type = kInteger,
            .meaning = "Anderson mixing of the last this many sweeps' results, projected on the "
                       "Signorini-Coulomb set (0: off; docs/performance.md)",
            .lo = 0,
            .hi = kMaxAndersonDepth},
          [](auto& o) -> auto& { return o.anderson_depth; }),
      bind(
          S{.key = "anderson_period",
            .type = kInteger,
            .meaning = "sweeps between two Anderson mixes",
            .lo = 1,
            .hi = 1000},
          [](auto& o) -> auto& { return o.anderson_period; }),
      bind(
          S{.key = "slab_correction_period",
            .type = kInteger,
            .meaning =
                "the slab correction every this many sweeps (0: off; coloured order, rigid "
                "contacts, packings of 20 bands of 4 largest diameters or more, L_y >= 80 d): "
                "the force-carrying contacts of each band of height rescaled so that every band's "
                "mean normal-velocity error vanishes; the mix then runs every 2 anderson_period "
                "sweeps (docs/performance.md)",
            .lo = 0,
            .hi = 1000},
          [](auto& o) -> auto& { return o.slab_correction_period; }),
      bind(
          S{.key = "residual_tolerance",
            .meaning = "largest root mean square contact-law violation over a step, e dt "
                       "[d], of the force-carrying contacts at which the sweeps may stop, "
                       "once alpha's test holds (0: no such test; docs/step-error.md, \"Per-step "
                       "check\")",
            .lo = 0.0},
          [](auto& o) -> auto& { return o.residual_tolerance; }),
      bind(
          S{.key = "normal_compliance",
            .meaning = "normal compliance kappa, a fraction of each contact's w_nn: a contact "
                       "carrying R_n ends a step overlapping by kappa w_nn R_n dt (0: rigid; "
                       "no slab correction with it; docs/performance.md, \"Normal "
                       "compliance\")",
            .lo = 0.0,
            .hi = kNormalComplianceBound,
            .hi_open = true,
            .range_reason = "at 1 a contact is as compliant as its two bodies are mobile"},
          [](auto& o) -> auto& { return o.normal_compliance; }),
      bind(
          S{.key = "newton_iterations",
            .type = kInteger,
            .meaning = "active-set Newton iterations after the sweeps (0: off; "
                       "src/core/active_set_solve.hpp, docs/performance.md)",
            .lo = 0,
            .hi = kMaxNewtonIterations},
          [](auto& o) -> auto& { return o.newton_iterations; }),
      bind(
          S{.key = "seed",
            .type = kInteger,
            .meaning = "seed of the contact order's shuffles",
            .lo = 0,
            .hi = kInf},
          [](auto& o) -> auto& { return o.seed; }),
  };
}

// A table, one row per key, in the order of the docs (see make_solver_settings).
std::vector<CaseSetting> make_case_settings() {
  using S = CaseSetting;
  std::vector<CaseSetting> rows = {
      // [system]: what the packing is made of.
      bind(
          S{.table = "system",
            .key = "n",
            .type = kInteger,
            .meaning = "number of disks",
            .phase = kBoth,
            .lo = 1,
            .hi = static_cast<double>(kMaxDisks)},
          [](auto& c) -> auto& { return c.n; }),
      bind(
          S{.table = "system",
            .key = "height",
            .unit = "d",
            .meaning = "L_y between the walls at preparation",
            .phase = kBoth,
            .lo = 0.0,
            .lo_open = true,
            .constraint = "> diameter_max"},
          [](auto& c) -> auto& { return c.height; }),
      bind(
          S{.table = "system",
            .key = "diameter_min",
            .unit = "d",
            .meaning = "smallest diameter: diameters are uniform in [diameter_min, diameter_max]",
            .phase = kBoth,
            .lo = 0.0,
            .lo_open = true,
            .constraint = "the disk's mass and moment of inertia normal numbers"},
          [](auto& c) -> auto& { return c.diameter_min; }),
      bind(
          S{.table = "system",
            .key = "diameter_max",
            .unit = "d",
            .meaning = "largest diameter (the unit of length d is the largest diameter of the "
                       "study)",
            .phase = kBoth,
            .lo = 0.0,
            .lo_open = true,
            .constraint = ">= diameter_min"},
          [](auto& c) -> auto& { return c.diameter_max; }),
      bind(
          S{.table = "system",
            .key = "seed",
            .type = kInteger,
            .meaning = "placement seed of the packing",
            .phase = kBoth,
            .lo = 0,
            .hi = kInf},
          [](auto& c) -> auto& { return c.seed; }),
      // [shear]
      bind(
          S{.table = "shear",
            .key = "velocity",
            .unit = "d/t",
            .meaning = "V: the bottom wall moves at -V, the top wall at +V along x",
            .lo = 0.0,
            .lo_open = true,
            .constraint = "V dt_max x 2e9 steps (the step limit) >= diameter_max"},
          [](auto& c) -> auto& { return c.velocity; }),
      bind(
          S{.table = "shear",
            .key = "normal_stress",
            .unit = "force/length",
            .meaning = "sigma_yy: each wall is pushed inwards by sigma_yy L_x",
            .lo = 0.0,
            .hi = 1e100,
            .lo_open = true,
            .range_reason = "beyond it the squares of the impulses would overflow"},
          [](auto& c) -> auto& { return c.normal_stress; }),
      bind(
          S{.table = "shear",
            .key = "friction_grain",
            .meaning = "mu_p, the friction coefficient between grains",
            .lo = 0.0},
          [](auto& c) -> auto& { return c.friction_grain; }),
      bind(
          S{.table = "shear",
            .key = "friction_wall",
            .meaning = "mu_w, the friction coefficient between grains and walls",
            .lo = 0.0},
          [](auto& c) -> auto& { return c.friction_wall; }),
      bind(
          S{.table = "shear",
            .key = "wall_mass",
            .unit = "mass",
            .meaning = "M_w, the mass of each wall along y",
            .lo = 1e-100,
            .range_reason = "below it the wall's inverse mass would overflow the solver's sums",
            .constraint = "1 / wall_mass a normal number"},
          [](auto& c) -> auto& { return c.wall_mass; }),
      bind(
          S{.table = "shear",
            .key = "duration",
            .unit = "t",
            .meaning = "simulated shear time (`--system K` presets: the study's, model.md "
                       "section 6)",
            .lo = 0.0,
            .lo_open = true,
            .constraint = "duration / step.dt <= 2e9 steps (the step limit)"},
          [](auto& c) -> auto& { return c.duration; }),
      bind(
          S{.table = "shear",
            .key = "initial_velocity",
            .type = kChoice,
            .meaning = "the disks' velocity at the start: linear (from -V at the bottom wall to "
                       "+V at the top, close to regime A's steady profile) or rest (the time to "
                       "steady state of model.md section 8 as a diffusion across the height)",
            .choices = {kInitialLinear, kInitialRest}},
          [](auto& c) -> auto& { return c.initial_velocity; }),
      // [step]
      bind(
          S{.table = "step",
            .key = "dt",
            .type = kNumberOrAuto,
            .unit = "t",
            .meaning = "time step; \"auto\": min(dt_max, displacement_per_step / V)",
            .lo = kMinTimeStep,
            .range_reason = std::string(kMinTimeStepReason)},
          [](auto& c) -> auto& { return c.dt; }),
      bind(
          S{.table = "step",
            .key = "dt_max",
            .unit = "t",
            .meaning = "longest time step of the auto rule",
            .lo = kMinTimeStep,
            .range_reason = std::string(kMinTimeStepReason)},
          [](auto& c) -> auto& { return c.dt_max; }),
      bind(
          S{.table = "step",
            .key = "displacement_per_step",
            .unit = "d",
            .meaning = "wall displacement per step the auto rule aims at",
            .lo = 0.0,
            .lo_open = true},
          [](auto& c) -> auto& { return c.displacement_per_step; }),
      bind(
          S{.table = "step",
            .key = "contact_margin",
            .unit = "d",
            .meaning = "candidate contacts: pairs whose gap is below this",
            .lo = 0.0,
            .hi = 1.0},
          [](auto& c) -> auto& { return c.step.contact_margin; }),
      bind(
          S{.table = "step",
            .key = "displacement_bound",
            .unit = "d",
            .meaning = "warn when V dt, or a disk's displacement in a step, exceeds this",
            .lo = 0.0,
            .lo_open = true},
          [](auto& c) -> auto& { return c.step.displacement_bound; }),
      bind(
          S{.table = "step",
            .key = "abort_overlap",
            .unit = "d",
            .meaning = "an overlap above this stops the run as blown up (exit 3)",
            .lo = 0.0,
            .lo_open = true},
          [](auto& c) -> auto& { return c.step.abort_overlap; }),
  };
  // [solver]: the shear phase's solver.
  const auto shear_solver = [](auto& c) -> auto& {
    return c.step.solver;
  };
  // alpha and residual_tolerance: a number, or "auto" for the rule of the wall speed
  // (shear_case.hpp, default_alpha and default_residual_tolerance), which resolve_step_rules
  // applies; `bound` reads and writes the case's own optional field.
  const auto number_or_auto = [&](const Setting<SolverOptions>& row, const std::string& rule,
                                  const CaseSetting& bound) {
    CaseSetting a = lift(row, "solver", kShear, shear_solver,
                         fmt::format("{}; \"auto\": {} (docs/accuracy.md)", row.meaning, rule));
    a.type = kNumberOrAuto;
    a.get = bound.get;
    a.set = bound.set;
    return a;
  };
  for (const auto& row : solver_settings()) {
    if (row.key == "alpha")
      rows.push_back(number_or_auto(row,
                                    fmt::format("{:g} (V' / {:g})^2, V' = V within [{:g}, {:g}]",
                                                shear_step_defaults().solver.alpha, kAlphaFullSpeed,
                                                kAlphaSlowSpeed, kAlphaFullSpeed),
                                    bind(
                                        CaseSetting{}, [](auto& c) -> auto& { return c.alpha; })));
    else if (row.key == "residual_tolerance")
      rows.push_back(number_or_auto(
          row,
          fmt::format("{:g} V' dt, V' = max(V, {:g}): a root mean square violation of at most "
                      "{:g} V'",
                      kResidualPerSpeed, kAlphaSlowSpeed, kResidualPerSpeed),
          bind(
              CaseSetting{}, [](auto& c) -> auto& { return c.residual_tolerance; })));
    else
      rows.push_back(lift(row, "solver", kShear, shear_solver, ""));
  }
  // [preparation]: the protocol of model.md section 5 and its solver.
  const auto more = std::vector<CaseSetting>{
      bind(
          S{.table = "preparation",
            .key = "packing",
            .type = kString,
            .meaning = "packing file to shear, and the one `cdshear prepare` writes; \"\": "
                       "packings/<parameters>.json, prepared if absent",
            .phase = kPreparation},
          [](auto& c) -> auto& { return c.packing_file; }),
      bind(
          S{.table = "preparation",
            .key = "initial_solid_fraction",
            .meaning = "solid fraction of the loose random placement",
            .phase = kPreparation,
            .lo = 0.0,
            .hi = 0.55,
            .lo_open = true,
            .hi_open = true,
            .range_reason = "random placement cannot reach about 0.55"},
          [](auto& c) -> auto& { return c.preparation.initial_solid_fraction; }),
      bind(
          S{.table = "preparation",
            .key = "gravity",
            .unit = "d/t^2",
            .meaning = "body force per unit mass along -x while the grains settle",
            .phase = kPreparation,
            .lo = 0.0,
            .lo_open = true},
          [](auto& c) -> auto& { return c.preparation.gravity; }),
      bind(
          S{.table = "preparation",
            .key = "piston_stress",
            .unit = "force/length",
            .meaning = "sigma_xx of the piston that compresses the packing",
            .phase = kPreparation,
            .lo = 0.0,
            .lo_open = true},
          [](auto& c) -> auto& { return c.preparation.piston_stress; }),
      bind(
          S{.table = "preparation",
            .key = "piston_mass",
            .unit = "mass",
            .meaning = "mass of the piston",
            .phase = kPreparation,
            .lo = 0.0,
            .lo_open = true,
            .constraint = "1 / piston_mass a normal number"},
          [](auto& c) -> auto& { return c.preparation.piston_mass; }),
      bind(
          S{.table = "preparation",
            .key = "settle_kinetic_energy_per_disk",
            .unit = "mass d^2/t^2",
            .meaning = "settling ends when a window's mean kinetic energy per disk is below this",
            .phase = kPreparation,
            .lo = 0.0,
            .lo_open = true},
          [](auto& c) -> auto& { return c.preparation.settle_kinetic_energy_per_disk; }),
      bind(
          S{.table = "preparation",
            .key = "kinetic_energy_per_disk",
            .unit = "mass d^2/t^2",
            .meaning = "compression ends when a window's mean kinetic energy per disk is below "
                       "this (with the two criteria below)",
            .phase = kPreparation,
            .lo = 0.0,
            .lo_open = true},
          [](auto& c) -> auto& { return c.preparation.kinetic_energy_per_disk; }),
      bind(
          S{.table = "preparation",
            .key = "piston_speed",
            .unit = "d/t",
            .meaning = "... and the piston's net drift over a window is below this",
            .phase = kPreparation,
            .lo = 0.0,
            .lo_open = true},
          [](auto& c) -> auto& { return c.preparation.piston_speed; }),
      bind(
          S{.table = "preparation",
            .key = "force_balance",
            .meaning = "... and the grains' mean force on the piston matches the applied force "
                       "within this (relative)",
            .phase = kPreparation,
            .lo = 0.0,
            .lo_open = true},
          [](auto& c) -> auto& { return c.preparation.force_balance; }),
      bind(
          S{.table = "preparation",
            .key = "window_time",
            .unit = "t",
            .meaning = "the windows over which the equilibrium criteria are averaged",
            .phase = kPreparation,
            .lo = 0.0,
            .lo_open = true,
            .constraint = "<= max_time_per_phase"},
          [](auto& c) -> auto& { return c.preparation.window_time; }),
      bind(
          S{.table = "preparation",
            .key = "max_time_per_phase",
            .unit = "t",
            .meaning = "a phase that has not reached equilibrium after this long fails (exit 1)",
            .phase = kPreparation,
            .lo = 0.0,
            .lo_open = true,
            .constraint = "at most 2e9 steps of min(dt, compression_dt)"},
          [](auto& c) -> auto& { return c.preparation.max_time_per_phase; }),
      bind(
          S{.table = "preparation",
            .key = "dt",
            .unit = "t",
            .meaning = "time step of the settling phase",
            .phase = kPreparation,
            .lo = kMinTimeStep,
            .range_reason = std::string(kMinTimeStepReason)},
          [](auto& c) -> auto& { return c.preparation.step.dt; }),
      bind(
          S{.table = "preparation",
            .key = "compression_dt",
            .unit = "t",
            .meaning = "time step of the compression phase",
            .phase = kPreparation,
            .lo = kMinTimeStep,
            .range_reason = std::string(kMinTimeStepReason)},
          [](auto& c) -> auto& { return c.preparation.compression_dt; }),
  };
  rows.insert(rows.end(), more.begin(), more.end());
  const auto preparation_solver = [](auto& c) -> auto& {
    return c.preparation.step.solver;
  };
  for (const char* key : {"alpha", "max_sweeps", "order"})
    rows.push_back(lift(solver_row(key), "preparation", kPreparation, preparation_solver,
                        "as solver." + std::string(key) + ", for the preparation's solver"));
  // [output]: intervals of simulated time, converted to whole steps.
  const auto outputs = std::vector<CaseSetting>{
      bind(
          S{.table = "output",
            .key = "status_interval",
            .unit = "t",
            .meaning = "time between status lines (0: about 20 per run)",
            .lo = 0.0},
          [](auto& c) -> auto& { return c.status_interval; }),
      bind(
          S{.table = "output",
            .key = "checkpoint_interval",
            .unit = "t",
            .meaning = "time between checkpoints (0: only at the end or on a signal)",
            .lo = 0.0},
          [](auto& c) -> auto& { return c.checkpoint_interval; }),
      bind(
          S{.table = "output",
            .key = "snapshot_interval",
            .unit = "t",
            .meaning = "time between ParaView snapshots, snapshots/*.pvd (0: none)",
            .lo = 0.0,
            .constraint = "if > 0: at most 1e5 snapshots over shear.duration"},
          [](auto& c) -> auto& { return c.snapshot_interval; }),
      // [measure]: model.md section 7, into run.h5.
      bind(
          S{.table = "measure",
            .key = "enabled",
            .type = kBoolean,
            .meaning = "the measurements of model.md section 7 into run.h5 (docs/measurements.md)"},
          [](auto& c) -> auto& { return c.measure.enabled; }),
      bind(
          S{.table = "measure",
            .key = "sample_interval",
            .unit = "t",
            .meaning = "time between samples of the series and the profiles",
            .lo = 0.0,
            .lo_open = true,
            .constraint = "with measure.enabled: shear.duration / sample_interval from 1 to 1e7 "
                          "samples"},
          [](auto& c) -> auto& { return c.measure.sample_interval; }),
      bind(
          S{.table = "measure",
            .key = "window",
            .unit = "t",
            .meaning = "profiles are averaged over consecutive windows of this length (the "
                       "`--system K` presets: the 80 of model.md section 7; the built-in case: "
                       "40, so that its 240 time units hold six windows)",
            .lo = 0.0,
            .lo_open = true,
            .constraint = ">= sample_interval"},
          [](auto& c) -> auto& { return c.measure.window; }),
      bind(
          S{.table = "measure",
            .key = "stripe_thickness",
            .unit = "d",
            .meaning = "dy of the stripe profiles",
            .lo = 0.0,
            .lo_open = true,
            .constraint = "with measure.enabled: stripes x windows <= 1e7 profile points"},
          [](auto& c) -> auto& { return c.measure.stripe_thickness; }),
      bind(
          S{.table = "measure",
            .key = "stripe_span",
            .meaning = "the stripes cover this times the nominal L_y: a fast flow dilates the "
                       "cell, and a profile must reach the top wall",
            .lo = 1.0,
            .hi = 10.0},
          [](auto& c) -> auto& { return c.measure.stripe_span; }),
      bind(
          S{.table = "measure",
            .key = "boundary_thickness",
            .type = kNumberList,
            .unit = "d",
            .meaning = "the thicknesses h of the boundary layers; if not given, [10], or "
                       "[L_y / 4] when L_y < 40",
            .lo = 0.0,
            .lo_open = true,
            .constraint = "each at most L_y / 2, no two alike"},
          [](auto& c) -> auto& { return c.measure.boundary_thickness; }),
      bind(
          S{.table = "measure",
            .key = "force_threshold",
            .meaning = "force-carrying contact: R_n above this times the mean R_n",
            .lo = 0.0},
          [](auto& c) -> auto& { return c.measure.force_threshold; }),
      bind(
          S{.table = "measure",
            .key = "contact_gap",
            .unit = "d",
            .meaning = "closed contact (Z, the grains of the slip velocity): gap at most this at "
                       "the sample (docs/measurements.md, \"Coordination number\")",
            .lo = 0.0,
            .lo_open = true,
            .constraint = "with measure.enabled: <= step.contact_margin / 2"},
          [](auto& c) -> auto& { return c.measure.contact_gap; }),
  };
  rows.insert(rows.end(), outputs.begin(), outputs.end());
  return rows;
}

}  // namespace

const std::vector<Setting<SolverOptions>>& solver_settings() {
  static const std::vector<Setting<SolverOptions>> rows = make_solver_settings();
  return rows;
}

const std::vector<CaseSetting>& case_settings() {
  static const std::vector<CaseSetting> rows = make_case_settings();
  return rows;
}

template <class T>
void read_setting(const Setting<T>& s, TomlReader& r, T& target) {
  if (!r.has(s.key)) {  // a filling reader records the value in use
    if (toml::table* table = r.fill_target(s.key)) insert_setting(*table, s.key, s.get(target));
    return;
  }
  SettingValue value;
  switch (s.type) {
    case kNumber: {
      const double v = r.number(s.key);
      check_range(s, r, v, "");
      value = v;
      break;
    }
    case kInteger:
      value = r.integer_in(s.key, integer_bound(s.lo), integer_bound(s.hi));
      break;
    case kBoolean:
      value = r.boolean(s.key);
      break;
    case kString:
      value = r.string(s.key);
      break;
    case kChoice:
      value = r.choice(s.key, s.choices);
      break;
    case kNumberList: {
      std::vector<double> list = r.number_array(s.key);
      if (list.empty()) r.fail(s.key, "must list at least one value");
      for (const double v : list) check_range(s, r, v, "every entry ");
      value = std::move(list);
      break;
    }
    case kNumberOrAuto:
      if (r.holds_string(s.key)) {
        if (r.string(s.key) != "auto") r.fail(s.key, "must be a number or \"auto\"");
        value = std::string("auto");
      } else {
        const double v = r.number(s.key);
        check_range(s, r, v, "");
        value = v;
      }
      break;
  }
  s.set(target, value);
}

void read_retired_solver_keys(TomlReader& reader, const std::string& table,
                              const SolverOptions& options) {
  for (const RetiredSolverKey& k : kRetiredSolverKeys)
    if (table == k.table && reader.has(k.key) && !k.accepts(reader, k.key, options))
      reader.fail(k.key, std::string("is no longer a setting: ") + k.now +
                             "; remove the key (docs/case-files.md, \"Keys no longer read\")");
}

std::vector<std::string> solver_settings_without_effect(const SolverOptions& o,
                                                        const SolverOptions& defaults,
                                                        const std::string& table) {
  std::vector<std::string> notes;
  const std::string prefix = table.empty() ? "" : table + ".";
  if (o.slab_correction_period != defaults.slab_correction_period && o.slab_correction_period > 0) {
    const std::string key =
        fmt::format("{}slab_correction_period = {}", prefix, o.slab_correction_period);
    if (o.order != ContactOrder::kColoured)
      notes.push_back(key +
                      " has no effect: the slab correction runs in the coloured order only (" +
                      prefix + "order = \"" + contact_order_name(o.order) + "\")");
    else if (o.normal_compliance > 0.0)
      notes.push_back(key + " has no effect: the slab correction runs with rigid contacts only (" +
                      prefix + "normal_compliance = " + format_number(o.normal_compliance) + ")");
  }
  if (o.anderson_period != defaults.anderson_period && o.anderson_depth == 0)
    notes.push_back(
        fmt::format("{}anderson_period = {} has no effect: {}anderson_depth = 0 (no mix)", prefix,
                    o.anderson_period, prefix));
  return notes;
}

template <class T>
std::string range_text(const Setting<T>& s) {
  std::string text;
  switch (s.type) {
    case kBoolean:
      break;
    case kChoice:
      for (const std::string& c : s.choices) text += (text.empty() ? "" : ", ") + c;
      break;
    case kString:
      break;
    case kNumberList:
      text = "each " + bounds_problem(s);
      break;
    case kNumberOrAuto:
      text = bounds_problem(s) + ", or \"auto\"";
      break;
    default: {
      const bool integer = s.type == kInteger;
      const bool has_lo = std::isfinite(s.lo),
                 has_hi = std::isfinite(s.hi) && (!integer || s.hi < 9.2e18);
      text = has_lo && has_hi && !s.lo_open && !s.hi_open
                 ? bound_text(s.lo, integer) + " to " + bound_text(s.hi, integer)
                 : bounds_problem(s);
      if (has_lo && has_hi && (s.lo_open || s.hi_open)) {
        // "> 0 and < 2" reads as "(0, 2)" in a table.
        text = std::string(s.lo_open ? "(" : "[") + bound_text(s.lo, integer) + ", " +
               bound_text(s.hi, integer) + (s.hi_open ? ")" : "]");
      }
    }
  }
  if (!s.constraint.empty()) text += (text.empty() ? "" : "; ") + s.constraint;
  return text;
}

template void read_setting(const Setting<ShearCase>&, TomlReader&, ShearCase&);
template void read_setting(const Setting<SolverOptions>&, TomlReader&, SolverOptions&);
template std::string range_text(const Setting<ShearCase>&);
template std::string range_text(const Setting<SolverOptions>&);

void insert_setting(toml::table& table, const std::string& key, const SettingValue& v) {
  std::visit(
      [&](const auto& x) {
        using V = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<V, std::vector<double>>) {
          toml::array list;
          for (const double h : x) list.push_back(h);
          table.insert_or_assign(key, std::move(list));
        } else {
          table.insert_or_assign(key, x);
        }
      },
      v);
}

std::string toml_text(const SettingValue& v) {
  toml::table one;
  insert_setting(one, "v", v);
  return toml_value_text(*one.get("v"));
}

const char* phase_name(SettingPhase phase) {
  switch (phase) {
    case kBoth:
      return "both";
    case kPreparation:
      return "preparation";
    case kShear:
      return "shear";
  }
  return "";
}

std::string settings_as_toml(const ShearCase& c, const std::string& header) {
  std::string out;
  for (const std::string& line : wrap(header, 98)) out += "# " + line + "\n";
  std::string table;
  for (const CaseSetting& s : case_settings()) {
    if (s.table != table) {
      table = s.table;
      out += "\n[" + table + "]\n";
    }
    for (const std::string& line : wrap(s.meaning, 98)) out += "# " + line + "\n";
    std::string note = s.unit.empty() ? "" : "[" + s.unit + "]";
    if (const std::string range = range_text(s); !range.empty())
      note += (note.empty() ? "" : " ") + range;
    std::string line = s.key + " = " + toml_text(s.get(c));
    if (!note.empty())
      line += std::string(line.size() < 40 ? 40 - line.size() : 1, ' ') + "# " + note;
    out += line + "\n";
  }
  return out;
}

namespace {
template <class T>
std::string markdown_table(const std::vector<Setting<T>>& rows, const T& defaults,
                           bool with_phase) {
  std::string out = with_phase
                        ? "| key | default | unit | range | phase | meaning |\n"
                          "|---|---|---|---|---|---|\n"
                        : "| key | default | unit | range | meaning |\n|---|---|---|---|---|\n";
  for (const Setting<T>& s : rows)
    out += "| `" + s.dotted() + "` | `" + escape_markdown(toml_text(s.get(defaults))) + "` | " +
           s.unit + " | " + escape_markdown(range_text(s)) + " | " +
           (with_phase ? std::string(phase_name(s.phase)) + " | " : std::string()) +
           escape_markdown(s.meaning) + " |\n";
  return out;
}
}  // namespace

std::string settings_as_markdown(const ShearCase& c) {
  return markdown_table(case_settings(), c, true);
}

std::string scene_solver_settings_as_markdown() {
  return markdown_table(solver_settings(), SolverOptions{}, false);
}

}  // namespace cdshear

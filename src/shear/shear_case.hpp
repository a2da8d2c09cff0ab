// The plane shear cell of docs/model.md sections 4 and 6: every parameter of one shear run, the
// seven systems of the reference study as presets, the default time-step and tolerance rules, and
// the world built from a prepared packing (model.md section 5, step 3).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "contact_dynamics.hpp"
#include "packing.hpp"
#include "preparation.hpp"
#include "shear_measurement.hpp"
#include "world.hpp"

namespace cdshear {

/// The shear phase's step options when the case sets none. Each default and its measured reason
/// (docs/accuracy.md, "Defaults and what they guarantee"):
/// - the coloured contact order, so that `--threads` share the sweeps of large systems (two
///   threads step system 7 1.8 to 1.9 times as fast as one); the same averages as the random order;
/// - alpha = 1e-5 (the reference value of model.md section 3, item 5, is 1e-6) at V >= 0.5, the
///   ceiling of the shear case's rule default_alpha: with the mix, the averages of 1e-6 at V = 0.5
///   and on system 7, within 1.4 combined errors, for 15 to 28% fewer sweeps;
/// - skip_dormant on: the same averages as sweeping every contact at 0.74 times the cost;
/// - relaxation = 1.6 (projected over-relaxation): 0.58 times Gauss-Seidel's cost, and Z within
///   the error of the converged reference where Gauss-Seidel at the sweep cap is 3.4 errors low;
/// - Anderson mixing of the sweeps (depth 5, every 4 sweeps): the same cost at V = 0.5 and 4% less
///   at V = 0.05, per-step errors 2 to 5 times smaller, and at V = 0.05 the solid fraction and Z
///   of the converged reference where over-relaxation alone was 3 to 14 combined errors off;
/// - the slab correction every 8 sweeps, which the solver runs in packings of 20 bands or more
///   only (L_y >= 80 d: systems 5 to 7; slab_correction.hpp): in system 7's slow phase the
///   force-carrying contacts within 0.3 to 1.1% of a solve run to convergence, where without it
///   they are 2.6 to 7% too few, for a quarter fewer sweeps. Where it runs, the mix runs every 8
///   sweeps instead of 4 (kMixPeriodFactorWithSlabCorrection): 6 to 10% fewer sweeps and half
///   the mixes, the same averages over five seeds of system 5.
/// Scene files keep the engine's plain defaults; the preparation has its own (preparation.hpp).
inline StepOptions shear_step_defaults() {
  StepOptions o;
  o.solver.order = ContactOrder::kColoured;
  o.solver.alpha = 1e-5;
  o.solver.skip_dormant = true;
  o.solver.relaxation = 1.6;
  o.solver.anderson_depth = 5;
  o.solver.anderson_period = 4;
  o.solver.slab_correction_period = 8;
  return o;
}

/// The values of ShearCase::initial_velocity.
inline constexpr const char* kInitialLinear = "linear";
inline constexpr const char* kInitialRest = "rest";

struct ShearCase {
  // System (what the packing is made of).
  std::size_t n = 511;
  double height = 20.0;  ///< nominal L_y [d]
  double diameter_min = 0.8, diameter_max = 1.0;
  std::uint64_t seed = 1;  ///< placement seed of the packing (the contact order has its own)

  // Shear.
  double velocity = 0.5;        ///< V: bottom wall at -V, top wall at +V along x [d/t]
  double normal_stress = 0.25;  ///< sigma_yy: walls pushed inwards by F_y = sigma_yy L_x
  double friction_grain = 0.5;  ///< mu_p
  double friction_wall = 0.5;   ///< mu_w
  double wall_mass = 50.0;      ///< M_w of each wall along y
  double duration = 240.0;      ///< simulated shear time [t] (the default job: 6 windows of 40)
  /// The disks' velocity at the shear's start: kInitialLinear ("linear"), the profile from -V at
  /// the bottom wall to +V at the top, close to regime A's steady one; kInitialRest ("rest"), every
  /// disk at rest, the walls already at +-V (the start from which the time to steady state of
  /// model.md section 8 is a diffusion of momentum across the whole height).
  std::string initial_velocity = kInitialLinear;

  // Time step: dt = min(dt_max, displacement_per_step / V) unless dt is given (default rule).
  std::optional<double> dt;             ///< explicit dt [t]
  double dt_max = 5e-3;                 ///< [t]
  double displacement_per_step = 2e-3;  ///< target wall displacement per step [d]
  // Solver tolerance: step.solver.alpha = alpha unless empty, then default_alpha(velocity).
  std::optional<double> alpha;
  // Contact-law bound: step.solver.residual_tolerance = residual_tolerance unless empty, then
  // default_residual_tolerance(velocity, step.dt) [d].
  std::optional<double> residual_tolerance;
  /// Margin, bounds, solver; step.dt and step.solver.alpha set by resolve_step_rules. The shear
  /// phase leaves dormant contacts out of the sweeps: docs/accuracy.md measured the same steady
  /// averages as sweeping every contact at 0.74 times the cost. The preparation (static packings,
  /// not measured) does not.
  StepOptions step = shear_step_defaults();

  PreparationOptions preparation;  ///< n, height, diameters, seed copied from above
  std::string packing_file;        ///< packing to reuse; empty: cached by parameters

  // Outputs, as intervals of simulated time (converted to whole steps) [t]; 0 disables.
  double status_interval = 0.0;  ///< status line; 0: about 20 per run
  double checkpoint_interval = 50.0;
  double snapshot_interval = 0.0;  ///< VTK snapshots

  /// The measurements of model.md section 7 ([measure]); boundary_thickness empty:
  /// default_boundary_thickness(). The built-in case (the default job) averages over windows of 40
  /// so that its 240 time units hold enough windows for error bars; the --system presets use the 80
  /// of model.md section 7.
  MeasureOptions measure{.window = 40.0, .boundary_thickness = {}};
};

/// The boundary thicknesses h measured when the case names none: [10] (model.md section 7), or
/// [L_y / 4] for cells thinner than 40 d so that a bulk remains (system 1: h = 5).
std::vector<double> default_boundary_thickness(double height);

/// The default time-step rule: dt = min(dt_max, displacement_per_step / V), so that the walls
/// (and the fastest grains, which move at about V) move at most displacement_per_step per step.
double default_time_step(const ShearCase& c);

/// The shear phase's convergence tolerance at wall speed V when the case gives none:
/// alpha = alpha_fast (V' / 0.5)^2, V' = V within [0.05, 0.5], alpha_fast =
/// shear_step_defaults().solver.alpha (1e-5): 1e-5 from V = 0.5 up, 1.6e-6 at 0.2, 4e-7 at 0.1,
/// 1e-7 at 0.05 and below (the slowest measured). Measured: at one alpha the per-step error
/// grows as V falls (system 1 at 1e-5: median 0.11% at V = 0.5, 1.3% at 0.2, 2.2% at 0.1, 3.2% at
/// 0.05); with the rule it stays below 1% (0.11, 0.58, 0.56, 0.35%), for 1.2, 1.4 and 1.6 times
/// the sweeps at 0.2, 0.1 and 0.05 (docs/step-error.md). A likely reason: below
/// V = 0.4 a step moves the walls 0.005 V (dt_max), so the impulses change less per step as V
/// falls, while the relative change per sweep that alpha bounds does not scale with it.
double default_alpha(double velocity);
/// default_alpha's speeds [d/t]: alpha_fast from kAlphaFullSpeed up, its value at kAlphaSlowSpeed
/// below that one (the slowest measured).
inline constexpr double kAlphaFullSpeed = 0.5, kAlphaSlowSpeed = 0.05;

/// The shear phase's bound on each step's contact-law violation when the case gives none
/// (SolverOptions::residual_tolerance, on e dt [d]): e, the root mean square over the
/// force-carrying contacts of the velocity residual (velocity_residual.hpp), at most
/// kResidualPerSpeed V' with V' = max(V, kAlphaSlowSpeed), i.e. kResidualPerSpeed V' dt.
/// Every step that ends off the cap meets it (a refined step that would not keeps the sweeps'
/// result: ContactDynamics::step). The defaults' steps leave a median e of about 1e-5 V and up
/// to 1.4e-4 to 5.5e-4 V without it, so it holds back the worst 0.2 to 1.5% of the steps, which
/// take 0.00 to 0.18% of the sweeps after it (docs/step-error.md, "Per-step check").
double default_residual_tolerance(double velocity, double dt);
/// default_residual_tolerance's bound on e, per unit of wall speed.
inline constexpr double kResidualPerSpeed = 1e-4;

/// The case's "auto" settings made numbers: c.step.dt from c.dt or the default rule,
/// c.step.solver.alpha from c.alpha or default_alpha, and c.step.solver.residual_tolerance from
/// c.residual_tolerance or default_residual_tolerance; returns a warning (empty if none) when
/// the resulting wall displacement per step V dt exceeds c.step.displacement_bound.
std::string resolve_step_rules(ShearCase& c);

/// Applies the row of model.md section 6 for system 1..7 (n, L_y, sigma_yy, duration); V is left as
/// is. Throws std::invalid_argument for another number.
void apply_system_preset(ShearCase& c, int system);

/// Copies the system parameters into c.preparation (n, height, diameters, seed).
void sync_preparation(ShearCase& c);

/// The shear world of model.md section 4 from a packing: x periodic with period L_x, walls at y = 0
/// and y = L_y moving at -V and +V along x and free along y (mass M_w, force F_y inwards), friction
/// mu_p and mu_w, disks given the linear velocity profile from -V (bottom) to +V (top), or at rest
/// (c.initial_velocity). Throws std::invalid_argument for another initial_velocity.
World build_shear_world(const ShearCase& c, const Packing& packing);

/// The first field of a world that is not as build_shear_world made it for `c` and a run keeps it,
/// as a key of a checkpoint (`walls[1].mass`) and what is wrong; an empty key when none.
struct ShearWorldProblem {
  std::string key, problem;
};
/// Checks what a run never changes: x periodic, no body force, the grain friction, two walls
/// (bottom, top) with their normals, modes, mass, friction, velocity along x and load sigma_yy L_x,
/// each disk's mass and inertia those of its radius at unit density, and the time within half a
/// step of step x dt (`c`'s time step resolved: resolve_step_rules).
ShearWorldProblem shear_world_problem(const World& w, const ShearCase& c);

/// The heights L_y / nominal L_y a shear run may reach; beyond them the walls flew apart or went
/// through each other (a blow-up). Wide, because a fast start from the linear profile is a
/// violent dilation: the first collisions launch the walls (mass 50), and only their load
/// sigma_yy L_x brings them back, at a deceleration of sigma_yy L_x / 50 (0.098 d/t^2 for
/// sigma_yy = 0.25 and L_x = 19.6). System 1 at V = 5 reaches L_y = 61 (3.05 times) at t = 30
/// and settles about 28 to 34 by t = 80. From the validation campaign's packings, one run each:
/// system 2 at V = 12.2 reaches 283 (7.1 times) at t = 60, still rising, and at V = 30
/// 815 (20 times) at t = 60, rising at 11 d/t; system 3 (sigma_yy = 0.0625) at V = 30 reaches
/// 1496 (37 times) at t = 100, rising at 13 d/t against 0.028 d/t^2: about 4600 (115 times) at
/// its highest, some 500 t in, and back in about as long again. The study's velocities (up to 30
/// for systems 2 to 7) need the upper bound well above that. What it bounds: the grains follow
/// the walls, and contact detection's cell list spans the grains (nominal L_x x 1000 nominal L_y
/// in cells of about a diameter: 4 million cells at most for system 7).
inline constexpr double kHeightRange[2] = {0.5, 1000.0};

/// Why a shear run's wall gap `height` (L_y) is a blow-up for its nominal height: outside
/// kHeightRange times it, or not a number; empty when it is neither.
std::string wall_gap_problem(double height, double nominal_height);

/// Indices of the bottom and top walls in the shear world.
inline constexpr std::size_t kBottomWall = 0, kTopWall = 1;

}  // namespace cdshear

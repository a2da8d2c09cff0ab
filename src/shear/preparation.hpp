// The preparation protocol of docs/model.md section 5 (steps 1 and 2):
//   1. settling: horizontal walls fixed at y = 0 and y = L_y, a vertical wall at x = 0, every
//      contact frictionless; n disks placed at random without overlap in a loose box to the right
//      of the wall, settling against it under a body force g along -x;
//   2. compression: body force off; a piston (vertical wall, normal -x) placed on the free surface,
//      free in x with mass M_p under the force sigma_xx L_y, pushes until equilibrium.
// Equilibrium is judged on consecutive blocks of `window_time`: a phase ends at the end of the
// first block whose mean kinetic energy per disk is below `settle_kinetic_energy_per_disk`
// (phase 1: the pile has settled; phase 2 finishes the job) or `kinetic_energy_per_disk`
// (phase 2), whose net piston drift |x_end - x_start| / window_time is below `piston_speed`, and
// whose mean force of the disks on the piston matches the applied force within `force_balance`
// (relative). Block means, not every step, because a rigid packing has isolated spikes that
// would reset a step-by-step test for a long time. L_x is then the distance from the vertical
// wall to the piston. The floor of the kinetic energy is set by the solver tolerance: an
// unconverged step leaves overlaps of order 1e-6 d which the next step removes at speed overlap /
// dt.
#pragma once

#include <atomic>
#include <functional>
#include <stdexcept>
#include <string>

#include "contact_dynamics.hpp"
#include "packing.hpp"

namespace cdshear {

/// Thrown when the cancel flag (SIGINT, SIGTERM, SIGHUP) stops a preparation: nothing is written.
struct PreparationInterrupted : std::runtime_error {
  explicit PreparationInterrupted(int phase)
      : std::runtime_error("preparation interrupted in phase " + std::to_string(phase) +
                           "; nothing was written") {}
};

/// Thrown when a preparation phase blows up or does not reach equilibrium within
/// max_time_per_phase: not the input's fault as such (exit 1), nothing is written.
struct PreparationFailed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct PreparationOptions {
  std::size_t n = 511;
  double height = 20.0;  ///< L_y [d]
  double diameter_min = 0.8, diameter_max = 1.0;
  std::uint64_t seed = 1;                ///< placement seed
  double initial_solid_fraction = 0.35;  ///< of the loose random placement
  double gravity = 1.0;                  ///< settling body force per unit mass along -x [d/t^2]
  double piston_stress = 0.25;           ///< sigma_xx [force/length]
  double piston_mass = 50.0;             ///< [mass]
  double settle_kinetic_energy_per_disk = 1e-4;  ///< phase 1 threshold [mass d^2/t^2]
  double kinetic_energy_per_disk = 1e-6;         ///< phase 2 threshold [mass d^2/t^2]
  double piston_speed = 1e-4;                    ///< phase 2 threshold [d/t]
  double force_balance = 0.01;       ///< |<F_contact> - F_applied| / F_applied at equilibrium
  double window_time = 5.0;          ///< the criteria must hold over this long [t]
  double max_time_per_phase = 2000;  ///< give up (error) after this long [t]
  /// dt (phase 1), margin, solver options of the protocol. The solver tolerance is alpha = 1e-4
  /// here, not the 1e-5 of shear runs: preparation needs an equilibrium packing, not accurate
  /// force histories, and is then about 3 times faster (measured: 91 s against more than 4 min for
  /// system 1; L_x 19.56 against 19.67, solid fraction 0.829 against 0.824).
  /// The coloured contact order, so that `--threads` share the sweeps: system 7 in 10 min on two
  /// threads against 19 min in the random order on one, and no shift of the prepared solid
  /// fraction over five seeds of system 1 (+0.0008 +- 0.0016, docs/benchmarks.md, "Performance
  /// targets"). The result does not depend on the number of threads.
  StepOptions step = [] {
    StepOptions s;
    s.solver.alpha = 1e-4;
    s.solver.order = ContactOrder::kColoured;
    return s;
  }();
  double compression_dt = 1e-3;  ///< phase 2 time step [t]
};

struct PreparationProgress {
  int phase = 1;  ///< 1 settling, 2 compression
  double time = 0.0;
  double kinetic_energy_per_disk = 0.0;
  double piston_x = 0.0, piston_speed = 0.0;
  StepReport report;
};

/// Runs the protocol; `progress` (optional) is called every `progress_interval` of simulated
/// time. Throws std::runtime_error if a phase does not reach equilibrium within
/// max_time_per_phase, or when `cancel` (optional) becomes true.
Packing prepare_packing(const PreparationOptions& options,
                        const std::function<void(const PreparationProgress&)>& progress = {},
                        double progress_interval = 5.0, const std::atomic<bool>* cancel = nullptr);

}  // namespace cdshear

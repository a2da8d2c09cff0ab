// One Contact Dynamics time step, as a named sequence of stages (docs/model.md section 3):
//   1. detect   candidate contacts (cell list, gap < margin), warm-started from the last step;
//   2. prepare  free velocities: v + dt * (external force / mass) for disks and free wall axes,
//               imposed values on driven axes, 0 on fixed ones;
//   3. solve    the contact impulses by nonlinear Gauss-Seidel (nlgs_solver.hpp);
//   4. check    the solved step's velocity residual against the contact laws
//               (velocity_residual.hpp); it changes nothing, except that a refined step
//               (newton_iterations > 0) that breaks the bound the sweeps' result met keeps
//               the sweeps' result;
//   5. integrate positions with the new velocities (semi-implicit Euler), wrap x;
//   6. measure  wall forces, largest overlap (over every pair when bodies moved more than the
//               contact margin allows for), largest displacement; check for blow-up.
// Each stage is timed into the report. The step never does I/O.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "active_set_solve.hpp"
#include "contact.hpp"
#include "contact_detection.hpp"
#include "nlgs_solver.hpp"
#include "velocity_residual.hpp"
#include "world.hpp"

namespace cdshear {

struct StepOptions {
  double dt = 1e-3;                  ///< time step [time]
  double contact_margin = 0.05;      ///< candidate contacts: gap below this [length]
  double displacement_bound = 0.01;  ///< warn when a disk moves more than this in a step [length]
  double abort_overlap = 0.1;        ///< an overlap above this is a blow-up [length]
  SolverOptions solver;
};

struct StageSeconds {
  /// check: the velocity residual of the solved step (velocity_residual.hpp).
  double detect = 0.0, prepare = 0.0, solve = 0.0, check = 0.0, integrate = 0.0, measure = 0.0;
  double total() const { return detect + prepare + solve + check + integrate + measure; }
};

struct StepReport {
  std::uint64_t step = 0;    ///< index of the step just done (world.step after it)
  double time = 0.0;         ///< simulated time after the step
  std::size_t contacts = 0;  ///< candidate contacts
  SolverReport solver;
  ActiveSetReport active_set;
  VelocityResidual velocity_residual;  ///< the solved step against the contact laws
  double max_overlap = 0.0;            ///< largest overlap after the step (>= 0) [length]
  double max_displacement = 0.0;       ///< largest disk displacement during the step [length]
  bool displacement_exceeded = false;
  bool blown_up = false;  ///< NaN or overlap above abort_overlap: stop the run
  std::string problem;    ///< what blew up, when blown_up
  StageSeconds seconds;
};

/// Holds what persists between steps (contacts for warm starts, scratch memory).
class ContactDynamics {
 public:
  StepReport step(World& world, const StepOptions& options);

  const std::vector<Contact>& contacts() const { return contacts_; }
  /// The solver's bodies of the last step (disks, then walls): end-of-step velocities, inverse
  /// masses.
  const std::vector<SolverBody>& bodies() const { return bodies_; }
  /// Replaces the contact memory (used when resuming from a checkpoint).
  void set_contacts(std::vector<Contact> contacts) { contacts_ = std::move(contacts); }

 private:
  std::vector<Contact> contacts_;
  std::vector<SolverBody> bodies_;
  ContactDetector detector_;
  SolverWorkspace workspace_;
  ActiveSetSolver active_set_;
  /// The sweeps' result while the refinement runs: kept where the refined step breaks the
  /// contact-law bound that the sweeps' result met (step(), "3. solve").
  std::vector<Contact> swept_contacts_;
  std::vector<SolverBody> swept_bodies_;
  std::vector<Contact> overlap_scratch_;  ///< every touching pair, when candidates may miss some
  std::vector<std::int64_t> image_before_wrap_;
  std::vector<Contact> renamed_;
  /// Per thread of the step's passes over the disks: a lowest and a highest value, and a flag.
  std::vector<double> thread_low_, thread_high_;
  std::vector<std::uint8_t> thread_finite_;

  /// What the integration found, for the measurement stage.
  struct Integrated {
    double max_disp2 = 0.0;             ///< largest squared disk displacement [length^2]
    double max_wall_disp = 0.0;         ///< largest wall displacement [length]
    bool finite = true;                 ///< every disk and wall position and velocity finite
    const Wall* broken_wall = nullptr;  ///< the first wall that is not
  };

  /// The stages of step() after detection, in order (each its own pass, shared by `team`
  /// threads).
  void prepare_bodies(const World& world, const StepOptions& options, int team);
  Integrated integrate(World& world, double dt, int team);
  void measure(World& world, const StepOptions& options, int team, const Integrated& integrated,
               StepReport& report);

  /// Renames the contacts of disks that were just wrapped across x = 0 (see the .cpp).
  void follow_wrapped_disks(const World& world);
};

/// Overlap (positive) of contact c in the current positions of `world`; <= 0 when apart.
double current_overlap(const World& world, const Contact& c);

/// The largest of `largest` and current_overlap(world, c) over `contacts`, with a square root only
/// for the pairs that may exceed the running maximum (bit for bit the same maximum).
double largest_overlap(const World& world, std::span<const Contact> contacts, double largest);

}  // namespace cdshear

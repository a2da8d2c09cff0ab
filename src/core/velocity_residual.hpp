// How far a solved step is from the contact laws, in velocities: the per-step check of the
// solver's accuracy (docs/step-error.md, "Per-step check"). The sweeps stop on the last sweep's
// change, which underestimates the error left 30 to 300 times; this residual is read from the
// step's result itself.
//
// For each candidate contact, with u_n the end-of-step normal velocity plus gap/dt (the
// Signorini condition of the step: u_n >= 0, R_n >= 0, u_n R_n = 0) and u_t the sliding
// velocity (Coulomb: |R_t| <= mu R_n, u_t = 0 where |R_t| < mu R_n, u_t against R_t where
// |R_t| = mu R_n):
//   e_n = |u_n| where R_n > 0 (a closed contact that still opens or interpenetrates),
//         max(0, -u_n) where R_n = 0 (an open contact closing faster than its gap allows);
//   e_t = |u_t| where R_n > 0 and |R_t| < mu R_n (a sticking contact that slides),
//         max(0, u_t sign(R_t)) where |R_t| = mu R_n (sliding with the friction force),
//         0 where mu = 0;
//   e = sqrt(e_n^2 + e_t^2)  [length/time].
// With a normal compliance (SolverOptions::normal_compliance, kappa) u_n also holds kappa w_nn R_n:
// the residual is that of the law the step solves.
// Zero at a solution of the step. It measures what the motion feels: in a hyperstatic packing
// the impulses of a step are not unique and the sweeps relax their self-stress part slowest, but
// a residual velocity moves grains. One pass over the contacts, about a sweep's cost.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "contact.hpp"
#include "solver_rows.hpp"

namespace cdshear {

/// A contact's end-of-step relative velocity [length/time]: n = u_n + gap/dt (the Signorini
/// condition's velocity), t = u_t (the sliding velocity), from the bodies' velocities (walls
/// included, body_b >= the disks' count).
struct ContactVelocity {
  double n = 0.0, t = 0.0;
};

inline ContactVelocity contact_velocity(const Contact& c, const std::vector<SolverBody>& bodies,
                                        double inv_dt) {
  const SolverBody& a = bodies[static_cast<std::size_t>(c.key.body_a)];
  const SolverBody& b = bodies[static_cast<std::size_t>(c.key.body_b)];
  const double dvx = a.velocity.x - b.velocity.x, dvy = a.velocity.y - b.velocity.y;
  return {dvx * c.normal.x + dvy * c.normal.y + c.gap * inv_dt,
          dvy * c.normal.x - dvx * c.normal.y + c.lever_a * a.omega + c.lever_b * b.omega};
}

/// A solved contact's state by its impulses: open (no normal impulse), sticking (inside the
/// Coulomb cone) or sliding (on its boundary, where the solver's projection puts it exactly).
enum class ImpulseStatus { kOpen, kSticking, kSliding };

inline ImpulseStatus impulse_status(const Contact& c) {
  if (!(c.impulse_n > 0.0)) return ImpulseStatus::kOpen;
  return std::abs(c.impulse_t) < c.friction * c.impulse_n ? ImpulseStatus::kSticking
                                                          : ImpulseStatus::kSliding;
}

/// e^2 of one contact (the definitions above) from its Signorini velocity u_n (+ gap/dt), its
/// sliding velocity u_t and its impulses: shared by the step's check and the solver's stop test
/// (SolverOptions::residual_tolerance), which reads it from its rows.
inline double contact_law_violation2(double u_n, double u_t, double r_n, double r_t,
                                     double friction) {
  if (!(r_n > 0.0)) {
    const double e_n = std::max(0.0, -u_n);
    return e_n * e_n;
  }
  double e_t = 0.0;  // frictionless: free to slide either way
  if (friction != 0.0)
    e_t = std::abs(r_t) < friction * r_n ? std::abs(u_t) : std::max(0.0, r_t > 0.0 ? u_t : -u_t);
  return u_n * u_n + e_t * e_t;
}

struct VelocityResidual {
  double largest = 0.0;       ///< largest e over the candidates [length/time]
  double rms_carrying = 0.0;  ///< root mean square of e over the force-carrying ones (R_n > 0)
  std::size_t carrying = 0;   ///< force-carrying contacts
};

/// The residual of a solved step: `bodies` hold the end-of-step velocities of the solver (walls
/// included), `contacts` the step's impulses and start-of-step gaps. Shared among `threads`
/// threads (a team of its own), the same figures on any number. `normal_compliance`: the
/// step's kappa (0: the rigid laws).
VelocityResidual velocity_residual(const std::vector<Contact>& contacts,
                                   const std::vector<SolverBody>& bodies, double dt,
                                   int threads = 1, double normal_compliance = 0.0);

}  // namespace cdshear

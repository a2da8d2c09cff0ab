// A candidate contact between a disk and another body (disk or wall), as the solver sees it.
//
// Conventions (derivation in docs/physics.md):
//   - body_a is always a disk; body_b is a disk or a wall (solver body index, walls after disks).
//   - normal n points from b to a; tangent t = n rotated by +90 degrees.
//   - impulse R = R_n n + R_t t acts on a, -R on b, over the whole step [force x time].
//   - relative velocity at the contact point: u = v_a(c) - v_b(c), with
//       u_n = (v_a - v_b).n,
//       u_t = (v_a - v_b).t + lever_a w_a + lever_b w_b,
//     because the contact point sits at -|lever_a| n from a's centre and +|lever_b| n from b's,
//     and in 2D w x (-r n) = -r w t, w x (r n) = r w t. The torque of R on either disk is
//     lever * R_t. Between two disks the contact point is the middle of the gap g (or overlap),
//     common to both so that angular momentum is conserved: lever = -(radius + g/2). Against a
//     wall, lever_a = -r_a and lever_b = 0 (walls do not rotate).
#pragma once

#include <cstdint>
#include <vector>

#include "vec2.hpp"

namespace cdshear {

/// Identifies a contact across steps (for warm starts): the ordered pair and the periodic image
/// of b (b's centre is shifted by image * L_x along x).
struct ContactKey {
  std::int32_t body_a = 0;
  std::int32_t body_b = 0;
  std::int32_t image_b = 0;
  friend auto operator<=>(const ContactKey&, const ContactKey&) = default;
};

struct Contact {
  ContactKey key;
  Vec2 normal;             ///< unit, from b to a
  double lever_a = 0.0;    ///< -(r_a + gap/2) against a disk, -r_a against a wall
  double lever_b = 0.0;    ///< -(r_b + gap/2) for a disk, 0 for a wall
  double gap = 0.0;        ///< signed distance at the start of the step (< 0: overlap) [length]
  double friction = 0.0;   ///< Coulomb coefficient of this pair
  double impulse_n = 0.0;  ///< R_n over the step [force time]
  double impulse_t = 0.0;  ///< R_t over the step [force time]

  /// The tangent t = perp(normal). Computed, not stored (nor is the arm): detection writes,
  /// the warm start reads and the solver's set-up reads every contact of every step, and 80
  /// bytes per contact instead of 112 are that much less memory to move.
  Vec2 tangent() const { return perp(normal); }
  /// Contact point minus centre of a [length]: lever_a n (the point lies |lever_a| from a's
  /// centre against n).
  Vec2 arm_a() const { return lever_a * normal; }
  /// The impulse on a, R = R_n n + R_t t (-R on b) [force time].
  Vec2 impulse() const { return impulse_n * normal + impulse_t * tangent(); }
};

}  // namespace cdshear

// The simulation state as plain data: disks, walls, the periodic domain, the body force.
// Units are those of docs/model.md section 1 (length: largest grain diameter; mass: 2D density 1).
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "vec2.hpp"

namespace cdshear {

/// Disks stored as parallel arrays (structure of arrays): the solver touches only velocities
/// and inverse masses every sweep, positions once per step.
struct Disks {
  std::vector<Vec2> position;       ///< centre [length]; x wrapped into [0, L_x) if periodic
  std::vector<std::int64_t> image;  ///< periodic image counter: unwrapped x = x + image * L_x
  std::vector<double> angle;        ///< rotation, counter-clockwise [rad]
  std::vector<Vec2> velocity;       ///< centre velocity [length/time]
  std::vector<double> omega;        ///< angular velocity, counter-clockwise [rad/time]
  std::vector<double> radius;       ///< [length]
  std::vector<double> mass;         ///< [mass]
  std::vector<double> inertia;      ///< moment of inertia about the centre [mass length^2]

  std::size_t size() const { return position.size(); }
  /// Adds a uniform disk of 2D density `density`: m = density pi r^2, J = m r^2 / 2.
  std::size_t add(Vec2 centre, double radius_value, double density = 1.0);
  void clear();
};

/// How one wall moves along one world axis (x or y).
enum class AxisMode {
  kFixed,    ///< velocity 0 along this axis
  kImposed,  ///< velocity imposed (`Wall::velocity`), whatever the contact forces
  kFree,     ///< Newton's law with `Wall::mass` and `Wall::applied_force` plus contact forces
};

/// An infinite straight wall: the line through `point` with unit `normal` pointing into the
/// domain (towards the disks it touches). Walls translate but never rotate.
struct Wall {
  std::string name;
  Vec2 point;             ///< a point of the line [length]
  Vec2 normal{0.0, 1.0};  ///< unit normal, into the domain
  AxisMode mode_x = AxisMode::kFixed;
  AxisMode mode_y = AxisMode::kFixed;
  Vec2 velocity;          ///< current velocity; the imposed value on kImposed axes
  double mass = 0.0;      ///< used on kFree axes [mass]
  Vec2 applied_force;     ///< external force on kFree axes [force]
  double friction = 0.5;  ///< Coulomb coefficient against disks
  Vec2 contact_force;     ///< output: mean force the disks exerted on it last step
  /// Output: integral of contact_force over time since the start of the run [force time]. Exact
  /// time averages between any two samples: (J(t2) - J(t1)) / (t2 - t1), whereas rigid contact
  /// forces sampled at single steps are spiky.
  Vec2 contact_impulse;
};

/// The periodic boundary along x (y is never periodic).
struct Domain {
  bool periodic_x = false;
  double length_x = 0.0;  ///< period L_x [length], used when periodic_x

  /// Number of periods to subtract from a separation dx to get its nearest image (0 if not
  /// periodic): nearbyint(dx / L_x). Most separations asked for (neighbours) are under half a
  /// period, where that is a zero with dx's sign (dx / L_x rounds to at most 0.5 in magnitude,
  /// and a tie rounds to the even 0): given without the division and the library call, the
  /// same value bit for bit.
  double periods_in(double dx) const {
    if (!periodic_x) return 0.0;
    if (std::abs(dx) < 0.5 * length_x) return std::copysign(0.0, dx);
    return std::nearbyint(dx / length_x);
  }
  /// The nearest periodic image of a separation vector.
  Vec2 minimum_image(Vec2 delta) const {
    delta.x -= length_x * periods_in(delta.x);
    return delta;
  }
};

struct World {
  Domain domain;
  Disks disks;
  std::vector<Wall> walls;
  Vec2 body_force;  ///< acceleration applied to every disk (gravity) [length/time^2]
  double friction_disk_disk = 0.5;  ///< Coulomb coefficient between disks
  double time = 0.0;                ///< simulated time
  std::uint64_t step = 0;           ///< steps done

  /// Unwrapped centre of disk i (periodic image added back).
  Vec2 unwrapped_position(std::size_t i) const {
    return {disks.position[i].x + static_cast<double>(disks.image[i]) * domain.length_x,
            disks.position[i].y};
  }
};

/// Kinetic energy of the disks (translation + rotation).
double kinetic_energy(const World& world);
/// Total linear momentum of the disks.
Vec2 linear_momentum(const World& world);
/// Total angular momentum of the disks about the origin, from unwrapped positions.
double angular_momentum(const World& world);
/// Largest disk radius (0 when there are no disks).
double max_radius(const World& world);
/// Wraps disk positions into [0, L_x) and updates the image counters (no-op if not periodic).
void wrap_positions(World& world);
/// How far from 0, in periods L_x, a disk may start (scene files, packings): beyond it the
/// wrapped place within the period loses its digits (x - floor(x / L_x) L_x at x = 1e20, L_x = 20
/// gives -16384, outside the cell) and the period count its range.
inline constexpr double kMaxPeriodsFromOrigin = 1e6;
/// FNV-1a hash of every position, velocity, angle, image counter and wall state: equal worlds
/// hash equal; used by determinism and resume tests.
std::uint64_t state_hash(const World& world);

}  // namespace cdshear

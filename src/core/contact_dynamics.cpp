#include "contact_dynamics.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "threads.hpp"

namespace cdshear {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point& t0) {
  const auto t1 = Clock::now();
  const double s = std::chrono::duration<double>(t1 - t0).count();
  t0 = t1;
  return s;
}

double axis_free_velocity(AxisMode mode, double v, double force, double mass, double dt) {
  switch (mode) {
    case AxisMode::kFixed:
      return 0.0;
    case AxisMode::kImposed:
      return v;
    case AxisMode::kFree:
      return v + dt * force / mass;
  }
  return 0.0;
}

double axis_inv_mass(AxisMode mode, double mass) {
  return mode == AxisMode::kFree ? 1.0 / mass : 0.0;
}

}  // namespace

double current_overlap(const World& world, const Contact& c) {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  const std::size_t a = static_cast<std::size_t>(c.key.body_a);
  const std::size_t b = static_cast<std::size_t>(c.key.body_b);
  if (b >= n) return -wall_gap(world, a, world.walls[b - n]);
  // Minimum image: the periodic image of b may have changed when either disk was wrapped.
  const Vec2 delta = world.domain.minimum_image(d.position[b] - d.position[a]);
  return d.radius[a] + d.radius[b] - centre_distance(length_squared(delta));
}

double largest_overlap(const World& world, std::span<const Contact> contacts, double largest) {
  // current_overlap takes a square root per disk pair, a few per cent of a step on
  // one thread for thousands of contacts. A pair overlaps by more than `largest` only if its
  // distance is below reach = r_a + r_b - largest, which the square of the distance tells without
  // a root: pairs at least (1 + 1e-9) reach^2 away (a margin far above the rounding of either
  // side) cannot raise the maximum and are passed over. The others are measured as
  // current_overlap measures them, so the maximum is bit for bit the one over every contact.
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  for (const Contact& c : contacts) {
    const auto a = static_cast<std::size_t>(c.key.body_a);
    const auto b = static_cast<std::size_t>(c.key.body_b);
    if (b < n) {
      const double reach = d.radius[a] + d.radius[b] - largest;
      const Vec2 a_to_b = world.domain.minimum_image(d.position[b] - d.position[a]);
      if (reach > 0.0 && length_squared(a_to_b) >= (1.0 + 1e-9) * reach * reach) continue;
    }
    largest = std::max(largest, current_overlap(world, c));
  }
  return largest;
}

void ContactDynamics::follow_wrapped_disks(const World& world) {
  // A contact's key holds the periodic image of b relative to a: b's centre + image_b L_x - a's
  // centre is the separation. When a moves by s_a periods and b by s_b (their image counters),
  // the same pair is image_b + s_b - s_a. Renaming the key keeps the contact's impulse for the
  // next step's warm start, which would otherwise restart from zero for every contact of a disk
  // that crossed x = 0. The renamed contacts are taken out, sorted and merged back: the list
  // stays sorted by key in O(contacts).
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  bool any = false;
  for (std::size_t i = 0; i < n && !any; ++i) any = d.image[i] != image_before_wrap_[i];
  if (!any) return;
  renamed_.clear();
  std::erase_if(contacts_, [&](Contact& c) {
    const auto a = static_cast<std::size_t>(c.key.body_a);
    const auto b = static_cast<std::size_t>(c.key.body_b);
    if (b >= n) return false;  // walls have no image
    const std::int64_t shift =
        (d.image[b] - image_before_wrap_[b]) - (d.image[a] - image_before_wrap_[a]);
    if (shift == 0) return false;
    c.key.image_b += static_cast<std::int32_t>(shift);
    renamed_.push_back(c);
    return true;
  });
  const auto by_key = [](const Contact& x, const Contact& y) { return x.key < y.key; };
  std::sort(renamed_.begin(), renamed_.end(), by_key);
  const auto middle = static_cast<std::ptrdiff_t>(contacts_.size());
  contacts_.insert(contacts_.end(), renamed_.begin(), renamed_.end());
  std::inplace_merge(contacts_.begin(), contacts_.begin() + middle, contacts_.end(), by_key);
}

namespace {
/// x with 6 significant digits (std::to_string's 6 decimals print 1e-9 as 0.000000).
std::string significant(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", x);
  return text;
}
}  // namespace

StepReport ContactDynamics::step(World& world, const StepOptions& options) {
  StepReport report;
  auto t0 = Clock::now();
  const std::size_t n = world.disks.size();

  // 1. detect (on the solver's threads: the list is the same on any number)
  detector_.detect(world, options.contact_margin, contacts_, options.solver.threads);
  report.contacts = contacts_.size();
  report.seconds.detect = seconds_since(t0);

  // 2. prepare free velocities (per disk: shared by the threads, each its share of the disks)
  const int team = threads_for(n, ContactDetector::kMinDisksPerThread, options.solver.threads);
  prepare_bodies(world, options, team);
  report.seconds.prepare = seconds_since(t0);

  // 3. solve; then refine. The refinement keeps its best iterate by its own merit (the natural
  // map), which can leave a larger root mean square contact-law violation than the sweeps' result
  // had: where the sweeps' result met the bound (SolverOptions::residual_tolerance, off the cap)
  // and the refined one does not, the step keeps the sweeps' result, so that the bound holds
  // for every step that ends off the cap.
  report.solver =
      solve_contacts(contacts_, bodies_, n, options.dt, options.solver, world.step, workspace_);
  const bool refine = options.solver.newton_iterations > 0;
  const bool swept_meets_bound = options.solver.residual_tolerance > 0.0 && !report.solver.hit_cap;
  if (refine) {
    if (swept_meets_bound) {
      swept_contacts_ = contacts_;
      swept_bodies_ = bodies_;
    }
    ActiveSetOptions o;
    o.max_iterations = options.solver.newton_iterations;
    o.normal_compliance = options.solver.normal_compliance;
    o.record_history = options.solver.newton_history;
    report.active_set = active_set_.refine(contacts_, bodies_, options.dt, o);
  }
  report.seconds.solve = seconds_since(t0);

  // 4. check: the solved step against the contact laws (on the solver's threads where it has
  // rows enough to share)
  const int check_team =
      threads_for(contacts_.size(), options.solver.min_rows_per_thread, options.solver.threads);
  report.velocity_residual = velocity_residual(contacts_, bodies_, options.dt, check_team,
                                               options.solver.normal_compliance);
  if (refine && swept_meets_bound &&
      !(report.velocity_residual.rms_carrying * options.dt <= options.solver.residual_tolerance)) {
    contacts_.swap(swept_contacts_);
    bodies_.swap(swept_bodies_);
    report.active_set.undone = true;
    report.velocity_residual = velocity_residual(contacts_, bodies_, options.dt, check_team,
                                                 options.solver.normal_compliance);
  }
  report.seconds.check = seconds_since(t0);

  // 5. integrate
  const Integrated integrated = integrate(world, options.dt, team);
  report.seconds.integrate = seconds_since(t0);

  // 6. measure
  measure(world, options, team, integrated, report);
  report.seconds.measure = seconds_since(t0);
  return report;
}

void ContactDynamics::prepare_bodies(const World& world, const StepOptions& options, int team) {
  const double dt = options.dt;
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  const auto team_size = static_cast<std::size_t>(team);
  bodies_.resize(n + world.walls.size());
  // Bands of height for the coloured order (nlgs_solver.hpp): four of the largest diameters, so
  // that a contact spans at most two bands. A property of the packing, not of the thread count
  // (a minimum and a maximum are exact in any order). The other orders do not read them.
  const bool bands = options.solver.order == ContactOrder::kColoured;
  double y_min = std::numeric_limits<double>::infinity(), r_max = 0.0;
  if (bands) {
    thread_low_.assign(team_size, y_min);
    thread_high_.assign(team_size, 0.0);
    for_shares(team, n, [&](std::size_t first, std::size_t last, std::size_t t) {
      double low = thread_low_[t], high = thread_high_[t];
      for (std::size_t i = first; i < last; ++i) {
        low = std::min(low, d.position[i].y);
        high = std::max(high, d.radius[i]);
      }
      thread_low_[t] = low;
      thread_high_[t] = high;
    });
    for (std::size_t t = 0; t < team_size; ++t) {
      y_min = std::min(y_min, thread_low_[t]);
      r_max = std::max(r_max, thread_high_[t]);
    }
  }
  const double band_height = 8.0 * r_max;
  for_shares(team, n, [&](std::size_t first, std::size_t last, std::size_t) {
    constexpr double kMaxBand = 4095.0;
    for (std::size_t i = first; i < last; ++i) {
      SolverBody& b = bodies_[i];
      if (bands) {
        const double band = (d.position[i].y - y_min) / band_height;
        b.band = band >= 0.0 ? static_cast<std::uint32_t>(std::min(band, kMaxBand)) : 0;
      }
      b.velocity = d.velocity[i] + dt * world.body_force;
      b.omega = d.omega[i];
      const double im = 1.0 / d.mass[i];
      b.inv_mass = {im, im};
      b.inv_inertia = 1.0 / d.inertia[i];
    }
  });
  for (std::size_t w = 0; w < world.walls.size(); ++w) {
    const Wall& wall = world.walls[w];
    SolverBody& b = bodies_[n + w];
    b.velocity = {
        axis_free_velocity(wall.mode_x, wall.velocity.x, wall.applied_force.x, wall.mass, dt),
        axis_free_velocity(wall.mode_y, wall.velocity.y, wall.applied_force.y, wall.mass, dt)};
    b.omega = 0.0;
    b.inv_mass = {axis_inv_mass(wall.mode_x, wall.mass), axis_inv_mass(wall.mode_y, wall.mass)};
    b.inv_inertia = 0.0;
  }
}

ContactDynamics::Integrated ContactDynamics::integrate(World& world, double dt, int team) {
  // Semi-implicit Euler: positions move with the end-of-step velocities, each thread its share
  // of the disks; the largest displacement and the finiteness merged after (a maximum and a
  // logical and: the same in any order).
  Disks& d = world.disks;
  const std::size_t n = d.size();
  const auto team_size = static_cast<std::size_t>(team);
  thread_high_.assign(team_size, 0.0);
  thread_finite_.assign(team_size, 1);
  for_shares(team, n, [&](std::size_t first, std::size_t last, std::size_t t) {
    double max_disp2 = 0.0;
    bool finite = true;
    for (std::size_t i = first; i < last; ++i) {
      const SolverBody& b = bodies_[i];
      d.velocity[i] = b.velocity;
      d.omega[i] = b.omega;
      const Vec2 step = dt * b.velocity;
      d.position[i] += step;
      d.angle[i] += dt * b.omega;
      const double step2 = length_squared(step);
      max_disp2 = std::max(max_disp2, step2);
      // A velocity whose square overflows is as broken as a NaN: the kinetic energy, the
      // displacement bound and the contact search all square it.
      finite = finite && std::isfinite(step2) && std::isfinite(length_squared(b.velocity)) &&
               std::isfinite(b.omega * b.omega) && std::isfinite(d.position[i].x) &&
               std::isfinite(d.position[i].y);
    }
    thread_high_[t] = max_disp2;
    thread_finite_[t] = finite ? 1 : 0;
  });
  Integrated out;
  for (std::size_t t = 0; t < team_size; ++t) {
    out.max_disp2 = std::max(out.max_disp2, thread_high_[t]);
    out.finite = out.finite && thread_finite_[t] != 0;
  }
  for (std::size_t w = 0; w < world.walls.size(); ++w) {
    Wall& wall = world.walls[w];
    wall.velocity = bodies_[n + w].velocity;
    wall.point += dt * wall.velocity;
    wall.contact_force = {};
    out.max_wall_disp = std::max(out.max_wall_disp, dt * length(wall.velocity));
    if (!std::isfinite(wall.point.x) || !std::isfinite(wall.point.y) ||
        !std::isfinite(wall.velocity.x) || !std::isfinite(wall.velocity.y))
      out.broken_wall = out.broken_wall != nullptr ? out.broken_wall : &wall;
  }
  out.finite = out.finite && out.broken_wall == nullptr;
  if (out.finite && world.domain.periodic_x) {
    image_before_wrap_ = d.image;
    wrap_positions(world);
    follow_wrapped_disks(world);
  }
  world.time += dt;
  ++world.step;
  return out;
}

void ContactDynamics::measure(World& world, const StepOptions& options, int team,
                              const Integrated& integrated, StepReport& report) {
  const double dt = options.dt;
  const std::size_t n = world.disks.size();
  for (const Contact& c : contacts_) {
    const std::size_t b = static_cast<std::size_t>(c.key.body_b);
    if (b >= n) {  // force on the wall is minus the impulse on the disk, per unit time
      world.walls[b - n].contact_force -= (1.0 / dt) * c.impulse();
    }
  }
  if (integrated.finite) {  // each thread the largest of its share, then the largest of those
    thread_high_.assign(static_cast<std::size_t>(team), report.max_overlap);
    for_shares(team, contacts_.size(), [&](std::size_t first, std::size_t last, std::size_t t) {
      thread_high_[t] = largest_overlap(
          world, std::span<const Contact>(contacts_).subspan(first, last - first), thread_high_[t]);
    });
    for (const double largest : thread_high_)
      report.max_overlap = std::max(report.max_overlap, largest);
  }
  for (Wall& wall : world.walls) wall.contact_impulse += dt * wall.contact_force;
  report.max_displacement = std::sqrt(integrated.max_disp2);
  // The candidates had gap < margin at the start of the step. Another pair can overlap now only
  // if its two bodies closed in by more than the margin during the step: then look at every pair
  // again (cell list, margin 0), or an overlap from a too-fast approach would go unreported.
  const double closing =
      std::max(2.0 * report.max_displacement, report.max_displacement + integrated.max_wall_disp);
  if (integrated.finite && closing > options.contact_margin) {
    detector_.detect(world, 0.0, overlap_scratch_);
    report.max_overlap = largest_overlap(world, overlap_scratch_, report.max_overlap);
  }
  report.displacement_exceeded = report.max_displacement > options.displacement_bound;
  report.step = world.step;
  report.time = world.time;
  if (integrated.broken_wall != nullptr) {
    report.blown_up = true;
    report.problem = "the position or velocity of wall '" + integrated.broken_wall->name +
                     "' became NaN or infinite";
  } else if (!integrated.finite) {
    report.blown_up = true;
    report.problem =
        "a disk's position or velocity became NaN or infinite (or too large to square)";
  } else if (!std::isfinite(report.solver.residual)) {
    report.blown_up = true;
    report.problem = "the solver residual is " + significant(report.solver.residual) + " after " +
                     std::to_string(report.solver.sweeps) + " sweeps" +
                     (report.solver.hit_cap ? " (at the cap)" : "");
  } else if (report.max_overlap > options.abort_overlap) {
    report.blown_up = true;
    report.problem = "overlap " + significant(report.max_overlap) + " exceeds abort_overlap " +
                     significant(options.abort_overlap);
  }
}

}  // namespace cdshear

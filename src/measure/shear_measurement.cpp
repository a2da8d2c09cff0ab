#include "shear_measurement.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include "stripe_geometry.hpp"

namespace cdshear {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t kBottom = 0, kTop = 1;

std::uint64_t steps_in(double interval, double dt) {
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(interval / dt)));
}

double friction_ratio(Vec2 f) {
  return f.y != 0.0 ? std::abs(f.x) / std::abs(f.y) : kNaN;
}

Vec2 mean_force(Vec2 impulse_end, Vec2 impulse_start, double seconds) {
  return seconds > 0 ? (1.0 / seconds) * (impulse_end - impulse_start) : Vec2{};
}

/// Linear interpolation of a profile at height y (NaN outside or on empty stripes).
double interpolate(const std::vector<double>& centres, const std::vector<double>& v, double y) {
  for (std::size_t k = 0; k + 1 < centres.size(); ++k)
    if (y >= centres[k] && y <= centres[k + 1]) {
      const double s = (y - centres[k]) / (centres[k + 1] - centres[k]);
      return (1.0 - s) * v[k] + s * v[k + 1];
    }
  return kNaN;
}

/// What a sample adds of one grain to the stripes it crosses.
struct GrainShare {
  double radius = 0.0, density = 0.0;  ///< [d], [mass / length^2]
  Vec2 velocity;                       ///< of the centre [d/t]
  double omega = 0.0;                  ///< counter-clockwise [1/t]
  Tensor2 moment;                      ///< contact moment M_i since the last sample
  int closed = 0, carrying = 0;        ///< closed and force-carrying contacts
};

/// Adds a grain's parts to the stripes of `w`, stripe k between k dy and (k + 1) dy of a
/// coordinate in which the grain's centre is at `centre`; `up` is +1 when that coordinate is the
/// height above the bottom wall and -1 when it is the depth below the top wall (the part's first
/// moment in y is `up` times its moment in the coordinate; its area and second moments are the
/// same in both).
void add_grain_parts(StripeSums& w, double dy, double centre, double up, const GrainShare& g) {
  const auto stripes = static_cast<std::ptrdiff_t>(w.area.size());
  const double r = g.radius, grain_area = std::numbers::pi * r * r, density = g.density;
  const Vec2 v = g.velocity;
  const double w_i = g.omega;
  const Tensor2& m = g.moment;
  const auto k0 =
      std::max<std::ptrdiff_t>(0, static_cast<std::ptrdiff_t>(std::floor((centre - r) / dy)));
  const auto k1 = std::min<std::ptrdiff_t>(
      stripes - 1, static_cast<std::ptrdiff_t>(std::floor((centre + r) / dy)));
  for (std::ptrdiff_t k = k0; k <= k1; ++k) {
    const auto s = static_cast<std::size_t>(k);
    const StripePart part =
        disk_in_stripe(centre, r, static_cast<double>(k) * dy, static_cast<double>(k + 1) * dy);
    if (part.area <= 0.0) continue;
    const double first_moment_y = up * part.first_moment;
    const double ms = density * part.area, share = part.area / grain_area;
    const double rm1 = density * first_moment_y;
    w.area[s] += part.area;
    w.velocity_area[s] += v.x * part.area - w_i * first_moment_y;
    w.mass[s] += ms;
    w.mass_vx[s] += ms * v.x;
    w.mass_vy[s] += ms * v.y;
    w.mass_vxx[s] += ms * v.x * v.x;
    w.mass_vxy[s] += ms * v.x * v.y;
    w.mass_vyy[s] += ms * v.y * v.y;
    w.material_vx[s] += ms * v.x - w_i * rm1;
    w.material_vxx[s] +=
        ms * v.x * v.x - 2.0 * v.x * w_i * rm1 + density * w_i * w_i * part.second_moment_y;
    w.material_vxy[s] += ms * v.x * v.y - v.y * w_i * rm1;
    w.material_vyy[s] += ms * v.y * v.y + density * w_i * w_i * part.second_moment_x;
    w.coordination_area[s] += part.area * g.closed;
    w.carrying_area[s] += part.area * g.carrying;
    w.stress_xx[s] -= share * m.xx;
    w.stress_xy[s] -= share * m.xy;
    w.stress_yx[s] -= share * m.yx;
    w.stress_yy[s] -= share * m.yy;
  }
}

}  // namespace

double current_gap(const World& world, const Contact& contact) {
  const Disks& d = world.disks;
  const auto a = static_cast<std::size_t>(contact.key.body_a);
  const auto b = static_cast<std::size_t>(contact.key.body_b);
  if (b < d.size())
    return length(world.domain.minimum_image(d.position[a] - d.position[b])) - d.radius[a] -
           d.radius[b];
  const Wall& wall = world.walls[b - d.size()];
  return dot(d.position[a] - wall.point, wall.normal) - d.radius[a];
}

double force_carrying_threshold(const std::vector<Contact>& contacts, double relative) {
  double sum = 0.0;
  std::size_t count = 0;
  for (const Contact& c : contacts)
    if (c.impulse_n > 0.0) {
      sum += c.impulse_n;
      ++count;
    }
  // With no force at all nothing carries: the threshold is then +inf.
  return count > 0 ? relative * sum / static_cast<double>(count)
                   : std::numeric_limits<double>::infinity();
}

ShearMeasurement::ShearMeasurement(MeasureOptions options, MeasureContext context,
                                   const World& world)
    : options_(std::move(options)), context_(context), length_x_(world.domain.length_x) {
  sample_every_ = steps_in(options_.sample_interval, context_.dt);
  samples_per_window_ = std::max<std::uint64_t>(
      1, static_cast<std::uint64_t>(
             std::llround(options_.window / (static_cast<double>(sample_every_) * context_.dt))));
  const double dy = options_.stripe_thickness;
  const auto stripes = static_cast<std::size_t>(stripe_count(options_, context_.nominal_height));
  for (std::size_t k = 0; k < stripes; ++k)
    stripe_centres_.push_back((static_cast<double>(k) + 0.5) * dy);
  for (std::size_t k = 0; k < top_stripe_count(options_); ++k)
    top_stripe_depths_.push_back((static_cast<double>(k) + 0.5) * dy);
  state_.grain_moment.assign(world.disks.size(), Tensor2{});
  state_.last_sample_step = world.step;
  state_.last_sample_time = world.time;
  state_.bottom_impulse_last = world.walls[kBottom].contact_impulse;
  state_.top_impulse_last = world.walls[kTop].contact_impulse;
  reset_window(world);
}

void ShearMeasurement::restore(MeasurementState state, std::vector<SeriesRow> series,
                               std::vector<WindowProfile> windows) {
  state_ = std::move(state);
  series_ = std::move(series);
  windows_ = std::move(windows);
}

namespace {

/// Every sum of a stripe set (pointers to const for a const set).
template <class Sums>
auto every_sum(Sums& s) {
  return std::array{&s.area,
                    &s.velocity_area,
                    &s.mass,
                    &s.mass_vx,
                    &s.mass_vy,
                    &s.mass_vxx,
                    &s.mass_vxy,
                    &s.mass_vyy,
                    &s.material_vx,
                    &s.material_vxx,
                    &s.material_vxy,
                    &s.material_vyy,
                    &s.coordination_area,
                    &s.carrying_area,
                    &s.stress_xx,
                    &s.stress_xy,
                    &s.stress_yx,
                    &s.stress_yy};
}

}  // namespace

void StripeSums::assign(std::size_t stripes) {
  for (std::vector<double>* v : every_sum(*this)) v->assign(stripes, 0.0);
}

bool StripeSums::same_size() const {
  for (const std::vector<double>* v : every_sum(*this))
    if (v->size() != area.size()) return false;
  return true;
}

std::size_t top_stripe_count(const MeasureOptions& o) {
  double h_max = 0.0;
  for (const double h : o.boundary_thickness) h_max = std::max(h_max, h);
  return static_cast<std::size_t>(std::ceil(h_max / o.stripe_thickness)) + 1;
}

void ShearMeasurement::reset_window(const World& world) {
  WindowSums& w = state_.window;
  w = WindowSums{};
  w.step_start = world.step;
  w.bottom_impulse_start = world.walls[kBottom].contact_impulse;
  w.top_impulse_start = world.walls[kTop].contact_impulse;
  w.stripes.assign(stripe_centres_.size());
  w.top_stripes.assign(top_stripe_depths_.size());
}

void ShearMeasurement::after_step(const World& world, const std::vector<Contact>& contacts,
                                  const StepReport& report) {
  state_.interval.add(report);
  add_contact_moments(world.disks.size(), contacts);
  if (world.step % sample_every_ == 0) sample(world, contacts);
}

void ShearMeasurement::add_contact_moments(std::size_t n, const std::vector<Contact>& contacts) {
  // First the contacts that carry an impulse, listed without a branch (each index written at the
  // list's end, which moves on only for a loaded contact): about half of the candidates carry
  // none, in no order a branch predictor can learn, and testing them in the loop below cost
  // about 1% of a system-1 step. Then their moments, in contact order as before.
  loaded_.resize(contacts.size());
  std::size_t count = 0;
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    loaded_[count] = static_cast<std::uint32_t>(k);
    count += static_cast<std::size_t>(contacts[k].impulse_n != 0.0) |
             static_cast<std::size_t>(contacts[k].impulse_t != 0.0);
  }
  for (std::size_t k = 0; k < count; ++k) {
    const Contact& c = contacts[loaded_[k]];
    // Impulse R on a, -R on b; a's arm is lever_a n, b's is -lever_b n (contact.hpp), so both
    // moments are R (x) (lever n).
    const Vec2 r = c.impulse();
    const auto add = [&r, &c](Tensor2& m, double lever) {
      const Vec2 arm = lever * c.normal;
      m.xx += r.x * arm.x;
      m.xy += r.x * arm.y;
      m.yx += r.y * arm.x;
      m.yy += r.y * arm.y;
    };
    add(state_.grain_moment[static_cast<std::size_t>(c.key.body_a)], c.lever_a);
    if (static_cast<std::size_t>(c.key.body_b) < n)
      add(state_.grain_moment[static_cast<std::size_t>(c.key.body_b)], c.lever_b);
  }
}

ShearMeasurement::ContactCounts ShearMeasurement::count_contacts(
    const World& world, const std::vector<Contact>& contacts) {
  const std::size_t n = world.disks.size();
  const double threshold = force_carrying_threshold(contacts, options_.force_threshold);
  carrying_count_.assign(n, 0);
  closed_count_.assign(n, 0);
  touches_.assign(n, 0);
  ContactCounts counts;
  for (const Contact& c : contacts) {
    const auto a = static_cast<std::size_t>(c.key.body_a);
    const auto b = static_cast<std::size_t>(c.key.body_b);
    if (c.impulse_n > threshold) {
      ++counts.carrying;
      ++carrying_count_[a];
      if (b < n) ++carrying_count_[b];
    }
    if (current_gap(world, c) <= options_.contact_gap) {
      ++counts.closed;
      ++closed_count_[a];
      if (b < n)
        ++closed_count_[b];
      else
        touches_[a] |= static_cast<signed char>(b - n == kBottom ? 1 : 2);
    }
  }
  return counts;
}

double ShearMeasurement::add_series_row(const World& world, const std::vector<Contact>& contacts,
                                        const ContactCounts& counts) {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  const double bottom_y = world.walls[kBottom].point.y;
  const double height = world.walls[kTop].point.y - bottom_y;
  SeriesRow row;
  row.step = world.step;
  // step x dt, as the windows' t_start and t_end: world.time adds dt at every step and drifts
  // from it by about 1e-11, enough to put a sample on a window's edge into the wrong window.
  row.time = static_cast<double>(world.step) * context_.dt;
  double mass = 0.0, momentum_x = 0.0, area = 0.0, block_mass = 0.0, block_momentum_x = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    mass += d.mass[i];
    momentum_x += d.mass[i] * d.velocity[i].x;
    area += std::numbers::pi * d.radius[i] * d.radius[i];
    const double y = d.position[i].y - bottom_y;
    if (y > 0.25 * height && y < 0.75 * height) {
      block_mass += d.mass[i];
      block_momentum_x += d.mass[i] * d.velocity[i].x;
    }
  }
  row.com_vx = mass > 0 ? momentum_x / mass : 0.0;
  row.block_vx = block_mass > 0 ? block_momentum_x / block_mass : 0.0;
  row.height = height;
  row.solid_fraction = area / (length_x_ * height);
  row.kinetic_energy = kinetic_energy(world);
  row.contacts = contacts.size();
  row.force_carrying = counts.carrying;
  row.closed = counts.closed;
  const double interval_time = world.time - state_.last_sample_time;
  row.bottom_force =
      mean_force(world.walls[kBottom].contact_impulse, state_.bottom_impulse_last, interval_time);
  row.top_force =
      mean_force(world.walls[kTop].contact_impulse, state_.top_impulse_last, interval_time);
  row.bottom_mu = friction_ratio(row.bottom_force);
  row.top_mu = friction_ratio(row.top_force);
  row.solver = state_.interval;
  series_.push_back(row);
  state_.interval = IntervalStats{};
  state_.last_sample_step = world.step;
  state_.last_sample_time = world.time;
  state_.bottom_impulse_last = world.walls[kBottom].contact_impulse;
  state_.top_impulse_last = world.walls[kTop].contact_impulse;
  return row.com_vx;
}

void ShearMeasurement::add_stripe_shares(const World& world) {
  const Disks& d = world.disks;
  const std::size_t n = d.size();
  const double bottom_y = world.walls[kBottom].point.y, top_y = world.walls[kTop].point.y;
  WindowSums& w = state_.window;
  const double dy = options_.stripe_thickness;
  for (std::size_t i = 0; i < n; ++i) {
    const double y = d.position[i].y, r = d.radius[i];
    if (!std::isfinite(y)) continue;  // never reached in a run: blown-up steps are not fed
    const GrainShare g{.radius = r,
                       .density = d.mass[i] / (std::numbers::pi * r * r),
                       .velocity = d.velocity[i],
                       .omega = d.omega[i],
                       .moment = state_.grain_moment[i],
                       .closed = closed_count_[i],
                       .carrying = carrying_count_[i]};
    add_grain_parts(w.stripes, dy, y - bottom_y, 1.0, g);
    add_grain_parts(w.top_stripes, dy, top_y - y, -1.0, g);
    state_.grain_moment[i] = Tensor2{};
    // Slip (docs/model.md section 7): grain surface velocity at the contact point minus the wall's
    // velocity.
    const Vec2 v = g.velocity;
    if (touches_[i] & 1) {
      w.slip_bottom_sum += v.x + g.omega * r - world.walls[kBottom].velocity.x;
      ++w.slip_bottom_count;
    }
    if (touches_[i] & 2) {
      w.slip_top_sum += world.walls[kTop].velocity.x - (v.x - g.omega * r);
      ++w.slip_top_count;
    }
  }
}

void ShearMeasurement::sample(const World& world, const std::vector<Contact>& contacts) {
  const double height = world.walls[kTop].point.y - world.walls[kBottom].point.y;
  const ContactCounts counts = count_contacts(world, contacts);
  const double com_vx = add_series_row(world, contacts, counts);
  add_stripe_shares(world);
  WindowSums& w = state_.window;
  w.height_sum += height;
  w.com_vx_sum += com_vx;
  ++w.samples;
  if (w.samples == samples_per_window_) {
    close_window(world);
    reset_window(world);
  }
}

namespace {

/// One stripe's values over a window, from its sums (NaN but the solid fraction where the stripe
/// held no grain); `cell` the stripe's area, `samples` N, `seconds` T (header).
struct StripeValues {
  double solid_fraction = 0.0, vx = kNaN, coordination = kNaN, carrying = kNaN;
  Tensor2 contact{kNaN, kNaN, kNaN, kNaN}, kinetic = contact, rotational = contact,
                                           stress = contact;
};

StripeValues stripe_values(const StripeSums& w, std::size_t k, double cell, double samples,
                           double seconds) {
  StripeValues out;
  out.solid_fraction = w.area[k] / (cell * samples);
  if (w.area[k] <= 0.0) return out;
  out.vx = w.velocity_area[k] / w.area[k];
  out.coordination = w.coordination_area[k] / w.area[k];
  out.carrying = w.carrying_area[k] / w.area[k];
  const Tensor2 c{w.stress_xx[k] / (cell * seconds), w.stress_xy[k] / (cell * seconds),
                  w.stress_yx[k] / (cell * seconds), w.stress_yy[k] / (cell * seconds)};
  const double mx = w.mass_vx[k], my = w.mass_vy[k], m = w.mass[k];
  const double kxy = (w.mass_vxy[k] - mx * my / m) / (cell * samples);
  const Tensor2 kin{(w.mass_vxx[k] - mx * mx / m) / (cell * samples), kxy, kxy,
                    (w.mass_vyy[k] - my * my / m) / (cell * samples)};
  // The material velocity's moments about its own stripe mean, minus the centre velocity's.
  const double ux = w.material_vx[k];
  const double mxy = (w.material_vxy[k] - ux * my / m) / (cell * samples);
  const Tensor2 rot{(w.material_vxx[k] - ux * ux / m) / (cell * samples) - kin.xx, mxy - kxy,
                    mxy - kxy, (w.material_vyy[k] - my * my / m) / (cell * samples) - kin.yy};
  out.contact = c;
  out.kinetic = kin;
  out.rotational = rot;
  // The rotational flux is not added: a spinning grain's centripetal internal stress cancels
  // it (header), and the contact stress is spread over each grain's area as a whole.
  out.stress = {c.xx + kin.xx, c.xy + kin.xy, c.yx + kin.yx, c.yy + kin.yy};
  return out;
}

}  // namespace

void ShearMeasurement::close_window(const World& world) {
  const WindowSums& w = state_.window;
  const std::size_t s_count = stripe_centres_.size();
  const double dy = options_.stripe_thickness, dt = context_.dt;
  const double samples = static_cast<double>(w.samples);
  const double seconds = static_cast<double>(world.step - w.step_start) * dt;
  const double cell = length_x_ * dy;  // stripe area [length^2]
  WindowProfile p;
  p.t_start = static_cast<double>(w.step_start) * dt;
  p.t_end = static_cast<double>(world.step) * dt;
  p.samples = w.samples;
  p.height = w.height_sum / samples;
  p.com_vx = w.com_vx_sum / samples;
  p.mu_eff.assign(s_count, kNaN);
  p.shear_rate.assign(s_count, kNaN);
  p.inertial_number.assign(s_count, kNaN);
  for (std::size_t k = 0; k < s_count; ++k) {
    const StripeValues v = stripe_values(w.stripes, k, cell, samples, seconds);
    p.solid_fraction.push_back(v.solid_fraction);
    p.vx.push_back(v.vx);
    p.coordination.push_back(v.coordination);
    p.force_carrying_coordination.push_back(v.carrying);
    p.contact_stress.push_back(v.contact);
    p.kinetic_stress.push_back(v.kinetic);
    p.rotational_stress.push_back(v.rotational);
    p.stress.push_back(v.stress);
    if (v.stress.yy > 0) p.mu_eff[k] = std::abs(v.stress.xy) / v.stress.yy;
  }
  for (std::size_t k = 0; k < top_stripe_depths_.size(); ++k) {
    const StripeValues v = stripe_values(w.top_stripes, k, cell, samples, seconds);
    TopStripes& t = p.top_stripes;
    t.solid_fraction.push_back(v.solid_fraction);
    t.vx.push_back(v.vx);
    t.coordination.push_back(v.coordination);
    t.force_carrying_coordination.push_back(v.carrying);
    t.stress.push_back(v.stress);
  }
  const double inertial_scale = std::sqrt(kInertialMass / context_.normal_stress);
  for (std::size_t k = 0; k < s_count; ++k) {
    const std::size_t lo = k > 0 && !std::isnan(p.vx[k - 1]) ? k - 1 : k;
    const std::size_t hi = k + 1 < s_count && !std::isnan(p.vx[k + 1]) ? k + 1 : k;
    if (hi == lo || std::isnan(p.vx[k])) continue;
    p.shear_rate[k] = (p.vx[hi] - p.vx[lo]) / (stripe_centres_[hi] - stripe_centres_[lo]);
    p.inertial_number[k] = std::abs(p.shear_rate[k]) * inertial_scale;
  }
  p.bottom_force =
      mean_force(world.walls[kBottom].contact_impulse, w.bottom_impulse_start, seconds);
  p.top_force = mean_force(world.walls[kTop].contact_impulse, w.top_impulse_start, seconds);
  p.wall_mu = 0.5 * (friction_ratio(p.bottom_force) + friction_ratio(p.top_force));
  p.slip_bottom_count = w.slip_bottom_count;
  p.slip_top_count = w.slip_top_count;
  p.slip_bottom = w.slip_bottom_count > 0 ? w.slip_bottom_sum / w.slip_bottom_count : kNaN;
  p.slip_top = w.slip_top_count > 0 ? w.slip_top_sum / w.slip_top_count : kNaN;
  for (double h : options_.boundary_thickness)
    p.regions.push_back(region_values(p, stripe_centres_, top_stripe_depths_, h, context_.velocity,
                                      context_.normal_stress));
  windows_.push_back(std::move(p));
}

RegionValues region_values(const WindowProfile& w, const std::vector<double>& centres,
                           const std::vector<double>& top_depths, double h, double velocity,
                           double normal_stress) {
  RegionValues out{};
  out.h = h;
  const double H = w.height;
  const double scale = std::sqrt(kInertialMass / normal_stress);
  // Sums over the stripes of one region, each stripe assigned by its centre. The bottom layer:
  // the stripes counted up from the bottom wall with centre y < h; the top layer: those counted
  // down from the top wall with centre depth < h (both h rounded to whole stripes the same way,
  // each exact at every sample); the bulk: the stripes counted up from the bottom wall between
  // h and H - h (H the window's mean height) that lie wholly below H.
  const double dy = centres.size() > 1 ? centres[1] - centres[0] : 2.0 * centres[0];
  struct Sums {
    double sxy = 0, syy = 0, nu = 0, nu_z = 0, nu_zc = 0, count = 0;
    double sy = 0, sv = 0, syy2 = 0, syv = 0;  // least squares of vx against y
    void add(double y, double vx, const Tensor2& stress, double solid_fraction, double coordination,
             double carrying) {
      sxy += stress.xy;
      syy += stress.yy;
      nu += solid_fraction;
      nu_z += solid_fraction * coordination;
      nu_zc += solid_fraction * carrying;
      count += 1;
      sy += y;
      sv += vx;
      syy2 += y * y;
      syv += y * vx;
    }
  } bulk, bottom, top;
  for (std::size_t k = 0; k < centres.size(); ++k) {
    const double y = centres[k];
    if (std::isnan(w.vx[k])) continue;
    const bool inside = y + 0.5 * dy <= H;
    if (y >= h && (y > H - h || !inside)) continue;
    const double carrying =
        k < w.force_carrying_coordination.size() ? w.force_carrying_coordination[k] : kNaN;
    (y < h ? bottom : bulk)
        .add(y, w.vx[k], w.stress[k], w.solid_fraction[k], w.coordination[k], carrying);
  }
  const TopStripes& t = w.top_stripes;
  for (std::size_t k = 0; k < top_depths.size() && k < t.vx.size(); ++k)
    if (top_depths[k] < h && !std::isnan(t.vx[k]))
      top.add(top_depths[k], t.vx[k], t.stress[k], t.solid_fraction[k], t.coordination[k],
              t.force_carrying_coordination[k]);
  const auto mu = [](const Sums& s) {
    return s.count > 0 && s.syy > 0 ? std::abs(s.sxy) / s.syy : kNaN;
  };
  const auto nu = [](const Sums& s) { return s.count > 0 ? s.nu / s.count : kNaN; };
  const auto z = [](const Sums& s) { return s.nu > 0 ? s.nu_z / s.nu : kNaN; };
  const auto zc = [](const Sums& s) { return s.nu > 0 ? s.nu_zc / s.nu : kNaN; };
  out.bulk_mu_eff = mu(bulk);
  out.bulk_solid_fraction = nu(bulk);
  out.bulk_coordination = z(bulk);
  out.bulk_force_carrying_coordination = zc(bulk);
  const double det = bulk.count * bulk.syy2 - bulk.sy * bulk.sy;
  out.bulk_shear_rate =
      bulk.count >= 2 && det > 0 ? (bulk.count * bulk.syv - bulk.sy * bulk.sv) / det : kNaN;
  out.bulk_inertial_number = std::abs(out.bulk_shear_rate) * scale;
  out.bottom_mu_eff = mu(bottom);
  out.bottom_solid_fraction = nu(bottom);
  out.bottom_coordination = z(bottom);
  out.bottom_force_carrying_coordination = zc(bottom);
  out.bottom_velocity_jump = interpolate(centres, w.vx, h) + velocity;
  out.bottom_inertial_number = scale * out.bottom_velocity_jump / h;
  out.top_mu_eff = mu(top);
  out.top_solid_fraction = nu(top);
  out.top_coordination = z(top);
  out.top_force_carrying_coordination = zc(top);
  out.top_velocity_jump = velocity - interpolate(top_depths, t.vx, h);
  out.top_inertial_number = scale * out.top_velocity_jump / h;
  return out;
}

}  // namespace cdshear

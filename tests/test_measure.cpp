// The measurement layer (src/measure) against exact answers: circular-segment geometry against
// numerical integration; velocity profiles of rigid motions; stresses of a single loaded grain;
// the bulk and boundary reduction on a profile built by hand; run.h5 written and read back.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>

#include <nlohmann/json.hpp>

#include "config_error.hpp"
#include "run_data_file.hpp"
#include "shear_measurement.hpp"
#include "stripe_geometry.hpp"
#include "test_support.hpp"

namespace cdshear {
namespace {

constexpr double kPi = std::numbers::pi;

/// Area, first and second moments of the disk between y0 and y1 by the midpoint rule on `slices`
/// slices (a slice of chord c at height dy holds int x^2 dx = c^3 / 12).
StripePart integrate_numerically(double yc, double r, double y0, double y1, int slices) {
  StripePart p;
  const double lo = std::max(y0, yc - r), hi = std::min(y1, yc + r);
  if (hi <= lo) return p;
  const double h = (hi - lo) / slices;
  for (int k = 0; k < slices; ++k) {
    const double y = lo + (k + 0.5) * h, dy = y - yc;
    const double chord = 2.0 * std::sqrt(std::max(0.0, r * r - dy * dy));
    p.area += chord * h;
    p.first_moment += dy * chord * h;
    p.second_moment_y += dy * dy * chord * h;
    p.second_moment_x += chord * chord * chord / 12.0 * h;
  }
  return p;
}

TEST(StripeGeometry, AreasSumToTheDiskAndMomentsMatchIntegration) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> height(0.0, 10.0), radius(0.05, 3.0);
  for (const double dy : {0.3, 1.0, 2.5})
    for (int trial = 0; trial < 200; ++trial) {
      const double r = radius(rng);
      // Every fourth disk touches a stripe edge exactly (bottom or top).
      double yc = height(rng);
      if (trial % 4 == 1) yc = std::floor(yc / dy) * dy + r;
      if (trial % 4 == 2) yc = std::ceil(yc / dy) * dy - r;
      double total_area = 0.0, total_moment = 0.0, total_second_y = 0.0, total_second_x = 0.0;
      for (int k = static_cast<int>(std::floor((yc - r) / dy)) - 1;
           k <= static_cast<int>(std::floor((yc + r) / dy)) + 1; ++k) {
        const StripePart exact = disk_in_stripe(yc, r, k * dy, (k + 1) * dy);
        const StripePart numeric = integrate_numerically(yc, r, k * dy, (k + 1) * dy, 20000);
        EXPECT_NEAR(exact.area, numeric.area, 1e-5 * r * r) << "r " << r << " k " << k;
        EXPECT_NEAR(exact.first_moment, numeric.first_moment, 1e-5 * r * r * r);
        EXPECT_NEAR(exact.second_moment_y, numeric.second_moment_y, 1e-5 * r * r * r * r);
        EXPECT_NEAR(exact.second_moment_x, numeric.second_moment_x, 1e-5 * r * r * r * r);
        EXPECT_GE(exact.area, 0.0);
        total_area += exact.area;
        total_moment += exact.first_moment;
        total_second_y += exact.second_moment_y;
        total_second_x += exact.second_moment_x;
      }
      EXPECT_NEAR(total_area, kPi * r * r, 1e-12 * r * r);
      EXPECT_NEAR(total_moment, 0.0, 1e-12 * r * r * r);  // about the centre
      // The whole disk's second moment about a diameter: pi r^4 / 4, for either axis.
      EXPECT_NEAR(total_second_y, 0.25 * kPi * r * r * r * r, 1e-12 * r * r * r * r);
      EXPECT_NEAR(total_second_x, 0.25 * kPi * r * r * r * r, 1e-12 * r * r * r * r);
    }
}

TEST(StripeGeometry, DiskInsideOneStripeIsWholeAndOutsideIsEmpty) {
  const StripePart inside = disk_in_stripe(1.5, 0.3, 1.0, 2.0);
  EXPECT_DOUBLE_EQ(inside.area, kPi * 0.09);
  EXPECT_NEAR(inside.first_moment, 0.0, 1e-15);
  const StripePart outside = disk_in_stripe(5.0, 0.3, 1.0, 2.0);
  EXPECT_EQ(outside.area, 0.0);
  // Upper half: area pi r^2 / 2, moment (2/3) r^3.
  const StripePart half = disk_in_stripe(1.0, 0.5, 1.0, 3.0);
  EXPECT_NEAR(half.area, kPi * 0.125, 1e-15);
  EXPECT_NEAR(half.first_moment, 2.0 / 3.0 * 0.125, 1e-15);
}

/// A shear-cell-like world without dynamics: walls at y = 0 and y = height, disks on a
/// triangular lattice; the measurement layer only reads it.
World lattice_world(double length_x, double height, double radius) {
  World w;
  w.domain.periodic_x = true;
  w.domain.length_x = length_x;
  for (int k = 0; k < 2; ++k) {
    Wall wall;
    wall.point = {0.0, k == 0 ? 0.0 : height};
    wall.normal = {0.0, k == 0 ? 1.0 : -1.0};
    w.walls.push_back(wall);
  }
  const double spacing = 2.0 * radius, row = spacing * std::sqrt(3.0) / 2.0;
  for (int j = 0; radius + j * row < height - radius; ++j)
    for (double x = (j % 2) * radius; x < length_x - 1e-9; x += spacing)
      w.disks.add({x, radius + j * row}, radius);
  return w;
}

/// Feeds `samples` samples of a frozen world (no contacts) into a measurement.
void feed(ShearMeasurement& m, World& w, std::uint64_t steps) {
  const std::vector<Contact> none;
  for (std::uint64_t s = 0; s < steps; ++s) {
    ++w.step;
    w.time = static_cast<double>(w.step) * m.context().dt;
    m.after_step(w, none, StepReport{});
  }
}

MeasureOptions quick_options() {
  MeasureOptions o;
  o.sample_interval = 0.1;
  o.window = 1.0;
  o.boundary_thickness = {2.0, 3.0};
  return o;
}

TEST(Profiles, RigidTranslationGivesExactlyItsVelocityAndTheLatticeSolidFraction) {
  World w = lattice_world(10.0, 8.0, 0.5);
  for (std::size_t i = 0; i < w.disks.size(); ++i) w.disks.velocity[i] = {0.37, -0.1};
  ShearMeasurement m(quick_options(), {0.01, 0.5, 0.25, 8.0}, w);
  feed(m, w, 100);
  ASSERT_EQ(m.windows().size(), 1u);
  const WindowProfile& p = m.windows()[0];
  double area = 0.0;
  for (std::size_t k = 0; k < m.stripes(); ++k) {
    area += p.solid_fraction[k] * 10.0 * 1.0;
    if (p.solid_fraction[k] == 0.0) continue;
    EXPECT_NEAR(p.vx[k], 0.37, 1e-14);
    EXPECT_NEAR(p.shear_rate[k], 0.0, 1e-12);
    // No fluctuations about the mean: no kinetic stress; no contacts: no contact stress.
    EXPECT_NEAR(p.kinetic_stress[k].xx, 0.0, 1e-14);
    EXPECT_NEAR(p.kinetic_stress[k].yy, 0.0, 1e-14);
    EXPECT_EQ(p.contact_stress[k].yy, 0.0);
  }
  EXPECT_NEAR(area, static_cast<double>(w.disks.size()) * kPi * 0.25, 1e-9);
}

TEST(Profiles, RigidRotationGivesTheExactAreaWeightedVelocity) {
  // Rotation at rate Omega about (xc, yc): v_i = Omega x (r_i - c), w_i = Omega, so every
  // material point moves along x at -Omega (y - yc); a stripe's velocity is -Omega (ybar - yc),
  // ybar the centroid height of the material in it, computed here by brute-force integration.
  World w = lattice_world(12.0, 9.0, 0.45);
  const double omega = 0.3, xc = 6.0, yc = 4.0;
  for (std::size_t i = 0; i < w.disks.size(); ++i) {
    const Vec2 p = w.disks.position[i];
    w.disks.velocity[i] = {-omega * (p.y - yc), omega * (p.x - xc)};
    w.disks.omega[i] = omega;
  }
  ShearMeasurement m(quick_options(), {0.01, 0.5, 0.25, 9.0}, w);
  feed(m, w, 100);
  const WindowProfile& p = m.windows().at(0);
  for (std::size_t k = 0; k < m.stripes(); ++k) {
    double area = 0.0, moment = 0.0;
    for (std::size_t i = 0; i < w.disks.size(); ++i) {
      const StripePart part = integrate_numerically(w.disks.position[i].y, w.disks.radius[i],
                                                    double(k), double(k + 1), 4000);
      area += part.area;
      moment += part.area * w.disks.position[i].y + part.first_moment;
    }
    if (area == 0.0) continue;
    EXPECT_NEAR(p.vx[k], -omega * (moment / area - yc), 1e-6) << "stripe " << k;
  }
}

TEST(Profiles, ImposedLinearFieldGivesBackShearRateAndInertialNumber) {
  // v_x = gamma (y - H/2) at every material point: centre velocity gamma (y_i - H/2) and
  // counter-clockwise rotation -gamma (the point at y moves at v_ix - w (y - y_i)). The disks
  // (free to overlap: the measurement does not care) are spread uniformly so that the material
  // of each stripe is centred on it, unlike a lattice's layers.
  World w = lattice_world(12.0, 10.0, 0.5);
  w.disks.clear();
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> ux(0.0, 12.0), uy(0.3, 9.7);
  for (int i = 0; i < 20000; ++i) w.disks.add({ux(rng), uy(rng)}, 0.3);
  const double gamma = 0.08, sigma = 0.25;
  for (std::size_t i = 0; i < w.disks.size(); ++i) {
    w.disks.velocity[i] = {gamma * (w.disks.position[i].y - 5.0), 0.0};
    w.disks.omega[i] = -gamma;
  }
  ShearMeasurement m(quick_options(), {0.01, 0.4, sigma, 10.0}, w);
  feed(m, w, 100);
  const WindowProfile& p = m.windows().at(0);
  // Interior stripes: next to the walls the material of a stripe is not centred on it (as with
  // wall layering in a real packing) and the finite difference is biased.
  for (std::size_t k = 2; k <= 7; ++k) {
    EXPECT_NEAR(p.shear_rate[k], gamma, 0.02 * gamma) << "stripe " << k;
    EXPECT_NEAR(p.inertial_number[k], gamma * std::sqrt(kInertialMass / sigma), 0.02 * gamma);
  }
  const RegionValues& r = p.regions.at(0);  // h = 2
  EXPECT_NEAR(r.bulk_shear_rate, gamma, 0.01 * gamma);
  EXPECT_NEAR(r.bulk_inertial_number, gamma * std::sqrt(kInertialMass / sigma), 0.01 * gamma);
}

TEST(Stress, OneGrainSqueezedBetweenTheWallsCarriesThePressure) {
  // One disk of radius 0.5 at y = 0.5 between two walls 1 apart, pushed by R_n on each side:
  // sigma_yy = R_n r * 2 / (A dt) spread over its area; the stripe [0,1) holds it all, so the
  // stripe stress is 2 R_n r / (dt L_x dy) and sigma_xx = 0.
  World w;
  w.domain = {true, 4.0};
  for (int k = 0; k < 2; ++k) {
    Wall wall;
    wall.point = {0.0, double(k)};
    wall.normal = {0.0, k == 0 ? 1.0 : -1.0};
    w.walls.push_back(wall);
  }
  w.disks.add({1.0, 0.5}, 0.5);
  const double dt = 0.01, rn = 0.003, rt = 0.001;
  std::vector<Contact> contacts(2);
  for (int k = 0; k < 2; ++k) {
    Contact& c = contacts[static_cast<std::size_t>(k)];
    c.key = {0, 1 + k, 0};
    c.normal = w.walls[static_cast<std::size_t>(k)].normal;
    c.lever_a = -0.5;
    c.impulse_n = rn;
    c.impulse_t = rt;  // opposite tangential forces from the two walls (tangents opposite)
  }
  MeasureOptions o = quick_options();
  o.boundary_thickness = {0.25};
  ShearMeasurement m(o, {dt, 0.5, 0.25, 1.0}, w);
  for (int s = 0; s < 100; ++s) {
    ++w.step;
    m.after_step(w, contacts, StepReport{});
  }
  const Tensor2 st = m.windows().at(0).contact_stress.at(0);
  const double scale = 1.0 / (dt * 4.0 * 1.0);  // per time, per stripe area
  EXPECT_NEAR(st.yy, 2.0 * rn * 0.5 * scale, 1e-12);
  EXPECT_NEAR(st.xx, 0.0, 1e-15);
  // Tangential impulse rt along t = perp(n): on the bottom t = (-1, 0) at arm (0, -r), on the
  // top t = (1, 0) at arm (0, r): sigma_xy = -(1/A) sum F_x r_y = -2 rt r ... / (dt L_x dy).
  EXPECT_NEAR(st.xy, -2.0 * rt * 0.5 * scale, 1e-12);
  EXPECT_NEAR(m.windows()[0].mu_eff[0], rt / rn, 1e-12);
  // Both contacts are closed and carry force: Z = 2 for the only grain, by either count.
  EXPECT_DOUBLE_EQ(m.windows()[0].coordination[0], 2.0);
  EXPECT_DOUBLE_EQ(m.windows()[0].force_carrying_coordination[0], 2.0);
}

/// Every disk pair and disk-wall pair of `w` with a gap below `margin`, as detection gives them
/// (walls after the disks), with no impulse.
std::vector<Contact> candidates_by_brute_force(const World& w, double margin) {
  std::vector<Contact> out;
  const std::size_t n = w.disks.size();
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) {
      Vec2 delta = w.disks.position[a] - w.disks.position[b];
      const double images = std::nearbyint(delta.x / w.domain.length_x);
      delta.x -= images * w.domain.length_x;
      const double gap =
          std::sqrt(delta.x * delta.x + delta.y * delta.y) - w.disks.radius[a] - w.disks.radius[b];
      if (gap >= margin) continue;
      Contact c;
      c.key = {static_cast<std::int32_t>(a), static_cast<std::int32_t>(b),
               static_cast<std::int32_t>(-images)};
      c.gap = gap;
      out.push_back(c);
    }
    for (std::size_t k = 0; k < w.walls.size(); ++k) {
      const double gap =
          (w.disks.position[a].y - w.walls[k].point.y) * w.walls[k].normal.y - w.disks.radius[a];
      if (gap >= margin) continue;
      Contact c;
      c.key = {static_cast<std::int32_t>(a), static_cast<std::int32_t>(n + k), 0};
      c.gap = gap;
      out.push_back(c);
    }
  }
  return out;
}

TEST(Coordination, ClosedContactsOfALatticeGiveItsZExactly) {
  // A triangular lattice of touching disks (spacing = diameter = 1), ten to a row in a period of
  // 10, the bottom row on the bottom wall, the top wall 0.07 above the top row: an interior disk
  // has 6 closed contacts, a bottom-row disk 2 + 2 + the wall = 5, a top-row disk 4. Candidates
  // within 0.05 also include nothing else; a second lattice row pushed up by 0.02 opens its
  // contacts with the row below (gap 0.02 > contact_gap) but leaves them candidates. Force is
  // carried by the contacts of even-numbered disks only, so the per-step count differs.
  World w = lattice_world(10.0, 8.0, 0.5);
  const std::size_t n = w.disks.size();
  ASSERT_EQ(n, 90u);  // 9 rows of 10
  std::vector<int> row(n);
  for (std::size_t i = 0; i < n; ++i)
    row[i] = static_cast<int>(std::lround((w.disks.position[i].y - 0.5) / (std::sqrt(3.0) / 2)));
  for (std::size_t i = 0; i < n; ++i)
    if (row[i] >= 4) w.disks.position[i].y += 0.02;  // rows 4.. lifted: rows 3-4 open
  std::vector<Contact> contacts = candidates_by_brute_force(w, 0.05);
  // Expected closed and force-carrying contacts per disk, from the lattice's structure.
  std::vector<int> closed(n), carrying(n);
  for (Contact& c : contacts) {
    const auto a = static_cast<std::size_t>(c.key.body_a);
    const auto b = static_cast<std::size_t>(c.key.body_b);
    c.impulse_n = a % 2 == 0 ? 1e-3 : 0.0;
    const bool open = b < n && row[a] != row[b] && std::min(row[a], row[b]) == 3;
    for (const std::size_t body : {a, b}) {
      if (body >= n) continue;
      closed[body] += open ? 0 : 1;
      carrying[body] += a % 2 == 0 ? 1 : 0;
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const int expected = row[i] == 0 ? 5 : row[i] == 8 ? 4 : row[i] == 3 || row[i] == 4 ? 4 : 6;
    ASSERT_EQ(closed[i], expected) << "disk " << i << " row " << row[i];
  }
  ShearMeasurement m(quick_options(), {0.01, 0.5, 0.25, 8.0}, w);
  for (int s = 0; s < 100; ++s) {
    ++w.step;
    m.after_step(w, contacts, StepReport{});
  }
  const WindowProfile& p = m.windows().at(0);
  for (std::size_t k = 0; k < m.stripes(); ++k) {
    double area = 0.0, closed_area = 0.0, carrying_area = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double s = disk_in_stripe(w.disks.position[i].y, 0.5, double(k), double(k + 1)).area;
      area += s;
      closed_area += s * closed[i];
      carrying_area += s * carrying[i];
    }
    if (area == 0.0) continue;
    EXPECT_NEAR(p.coordination[k], closed_area / area, 1e-12) << "stripe " << k;
    EXPECT_NEAR(p.force_carrying_coordination[k], carrying_area / area, 1e-12) << "stripe " << k;
  }
  // The series: every closed contact once (wall contacts included).
  int closed_sum = 0;
  for (const int z : closed) closed_sum += z;
  EXPECT_EQ(m.series().back().closed, static_cast<std::uint64_t>(closed_sum + 10) / 2);
}

TEST(Stress, RotationOfTheGrainsGivesTheExactMaterialMomentumFlux) {
  // One disk spinning at w with its centre moving at v, alone in the cell: the centre velocity
  // has no fluctuation about the stripe mean, so the whole kinetic stress is the rotational part,
  // rho (int u (x) u dS - int u dS (x) int u dS / S) / (L_x dy) over the disk's part in each
  // stripe, u = v + w x (p - c). Here by brute force on a grid. A whole disk gives J w^2 / 2 on
  // both normal components.
  World w;
  w.domain = {true, 4.0};
  for (int k = 0; k < 2; ++k) {
    Wall wall;
    wall.point = {0.0, 3.0 * k};
    wall.normal = {0.0, k == 0 ? 1.0 : -1.0};
    w.walls.push_back(wall);
  }
  const double r = 0.45, spin = 1.7, yc = 1.3;
  w.disks.add({2.0, yc}, r);
  w.disks.velocity[0] = {0.3, -0.2};
  w.disks.omega[0] = spin;
  const double rho = w.disks.mass[0] / (kPi * r * r);
  MeasureOptions o = quick_options();
  o.boundary_thickness = {1.0};
  ShearMeasurement m(o, {0.01, 0.5, 0.25, 3.0}, w);
  feed(m, w, 100);
  const WindowProfile& p = m.windows().at(0);
  const int grid = 2000;
  for (std::size_t k = 0; k < 2; ++k) {  // the disk spans stripes [0,1) and [1,2)
    double s = 0, ux = 0, uy = 0, uxx = 0, uxy = 0, uyy = 0;
    const double step = 2.0 * r / grid;
    for (int i = 0; i < grid; ++i)
      for (int j = 0; j < grid; ++j) {
        const double dx = -r + (i + 0.5) * step, dy = -r + (j + 0.5) * step;
        const double y = yc + dy;
        if (dx * dx + dy * dy > r * r || y < double(k) || y >= double(k + 1)) continue;
        const double vx = 0.3 - spin * dy, vy = -0.2 + spin * dx, da = step * step;
        s += da;
        ux += vx * da;
        uy += vy * da;
        uxx += vx * vx * da;
        uxy += vx * vy * da;
        uyy += vy * vy * da;
      }
    const double cell = 4.0 * 1.0;
    const Tensor2& rot = p.rotational_stress.at(k);
    const double scale = rho / cell, tolerance = 2e-3 * rho * spin * spin * r * r * s / cell;
    EXPECT_NEAR(rot.xx, scale * (uxx - ux * ux / s), tolerance) << "stripe " << k;
    EXPECT_NEAR(rot.xy, scale * (uxy - ux * uy / s), tolerance) << "stripe " << k;
    EXPECT_NEAR(rot.yx, rot.xy, 1e-15);
    EXPECT_NEAR(rot.yy, scale * (uyy - uy * uy / s), tolerance) << "stripe " << k;
    EXPECT_NEAR(p.kinetic_stress.at(k).xx, 0.0, 1e-14);
    // The flux is cancelled by the spinning grain's centripetal internal stress: not in the
    // stress, which is the contact and (centre-velocity) kinetic parts.
    EXPECT_EQ(p.stress.at(k).yy, p.contact_stress.at(k).yy + p.kinetic_stress.at(k).yy);
  }
  // The disk whole inside one stripe: J w^2 / 2 on both normal components, no shear part.
  World whole = w;
  whole.disks.position[0].y = 2.5;
  ShearMeasurement m2(o, {0.01, 0.5, 0.25, 3.0}, whole);
  feed(m2, whole, 100);
  const Tensor2& rot = m2.windows().at(0).rotational_stress.at(2);
  const double j_w2 = 0.5 * w.disks.mass[0] * r * r * spin * spin;
  EXPECT_NEAR(rot.xx, 0.5 * j_w2 / 4.0, 1e-12);
  EXPECT_NEAR(rot.yy, 0.5 * j_w2 / 4.0, 1e-12);
  EXPECT_NEAR(rot.xy, 0.0, 1e-14);
}

TEST(Regions, BulkAndBoundaryFromAProfileBuiltByHand) {
  // A profile with still bulk and two sheared layers of h = 3 in a cell 12 high: regime B. The
  // top layer's stripes are counted down from the top wall (depth = 12 - y).
  WindowProfile w;
  w.height = 12.0;
  std::vector<double> centres, depths;
  const double V = 1.0;
  const auto vx_at = [V](double y) {
    return y < 3 ? -V + (V - 0.1) * y / 3 : y > 9 ? 0.1 + (V - 0.1) * (y - 9) / 3 : 0.1;
  };
  for (int k = 0; k < 15; ++k) {
    const double y = k + 0.5;
    centres.push_back(y);
    w.vx.push_back(y < 12 ? vx_at(y) : NAN);
    w.solid_fraction.push_back(y < 12 ? 0.8 : 0.0);
    w.coordination.push_back(y < 3 ? 3.0 : 4.0);
    w.stress.push_back({0.0, -0.05, -0.05, 0.25});
  }
  for (int k = 0; k < 4; ++k) {
    const double depth = k + 0.5;
    depths.push_back(depth);
    w.top_stripes.vx.push_back(vx_at(12.0 - depth));
    w.top_stripes.solid_fraction.push_back(0.7);
    w.top_stripes.coordination.push_back(depth < 3 ? 2.5 : 4.0);
    w.top_stripes.force_carrying_coordination.push_back(1.0);
    w.top_stripes.stress.push_back({0.0, -0.06, -0.06, 0.25});
  }
  const RegionValues r = region_values(w, centres, depths, 3.0, V, 0.25);
  EXPECT_NEAR(r.bulk_shear_rate, 0.0, 1e-12);
  EXPECT_NEAR(r.bulk_mu_eff, 0.2, 1e-12);
  EXPECT_NEAR(r.bulk_solid_fraction, 0.8, 1e-12);
  EXPECT_NEAR(r.bottom_coordination, 3.0, 1e-12);
  EXPECT_NEAR(r.bulk_coordination, 4.0, 1e-12);
  EXPECT_NEAR(r.top_coordination, 2.5, 1e-12);
  EXPECT_NEAR(r.top_solid_fraction, 0.7, 1e-12);
  EXPECT_NEAR(r.top_mu_eff, 0.24, 1e-12);
  EXPECT_NEAR(r.top_force_carrying_coordination, 1.0, 1e-12);
  // vx(3) interpolated between 2.5 and 3.5: the bottom jump is V + 0.1 ... by the profile.
  EXPECT_NEAR(r.bottom_velocity_jump, 0.5 * ((-V + 0.9 * 2.5 / 3) + 0.1) + V, 1e-12);
  EXPECT_NEAR(r.top_velocity_jump, V - 0.5 * (0.1 + (0.1 + 0.9 * 0.5 / 3)), 1e-12);
  EXPECT_NEAR(r.bottom_inertial_number,
              r.bottom_velocity_jump / 3.0 * std::sqrt(kInertialMass / 0.25), 1e-12);
}

TEST(Regions, TheBulkTakesOnlyStripesWhollyBelowTheMeanHeight) {
  // Mean height 6.4 and h = 0.25: the stripe [6, 7) lies above H - h but is 40% inside the cell;
  // a uniform packing of solid fraction 0.8 measures 0.32 there, which the bulk must not take.
  WindowProfile w;
  w.height = 6.4;
  std::vector<double> centres;
  for (int k = 0; k < 10; ++k) {
    const double y = k + 0.5;
    centres.push_back(y);
    w.vx.push_back(y < 7 ? 0.0 : NAN);
    w.solid_fraction.push_back(y < 6 ? 0.8 : y < 7 ? 0.32 : 0.0);
    w.coordination.push_back(3.0);
    w.stress.push_back({0.0, -0.05, -0.05, 0.25});
  }
  const RegionValues r = region_values(w, centres, {0.5, 1.5}, 0.25, 1.0, 0.25);
  EXPECT_NEAR(r.bulk_solid_fraction, 0.8, 1e-12);
  EXPECT_TRUE(std::isnan(r.top_solid_fraction));  // no top stripes given
}

TEST(Regions, TheTopLayerMovesWithTheTopWallAndMirrorsTheBottomOne) {
  // A lattice whose upper half rides on the top wall, which rises and falls by up to 0.45 d from
  // sample to sample (the walls' spacing that a window averages over). The point reflection of
  // the cell about its moving top wall (x -> L_x - x, y -> y_top - y, v -> -v) puts that layer at
  // a bottom wall that does not move, at every sample: its bottom layer, exact by construction,
  // must be the top layer measured in the moving cell, to rounding.
  const double length_x = 10.0, height = 8.0, V = 0.5;
  World w = lattice_world(length_x, height, 0.5);
  for (std::size_t i = 0; i < w.disks.size(); ++i) {
    const Vec2 p = w.disks.position[i];
    const bool rides = p.y > 4.0;
    w.disks.velocity[i] = {rides ? V : -V + 0.1 * p.y, 0.01 * p.x};
    w.disks.omega[i] = rides ? 0.0 : 0.05 * (p.y - 4.0);
  }
  World mirror = w;
  const auto reflect = [&] {
    const double top = w.walls[1].point.y;
    mirror.walls[1].point.y = top;
    for (std::size_t i = 0; i < w.disks.size(); ++i) {
      mirror.disks.position[i] = {length_x - w.disks.position[i].x, top - w.disks.position[i].y};
      mirror.disks.velocity[i] = -1.0 * w.disks.velocity[i];
    }
  };
  reflect();
  ShearMeasurement moving(quick_options(), {0.01, V, 0.25, height}, w);
  ShearMeasurement still(quick_options(), {0.01, V, 0.25, height}, mirror);
  const std::vector<Contact> none;
  double lift = 0.0;
  for (int s = 0; s < 100; ++s) {
    const double next = 0.225 * (1.0 + std::sin(0.7 * s));  // 0 to 0.45: no overlaps
    w.walls[1].point.y += next - lift;
    for (std::size_t i = 0; i < w.disks.size(); ++i)
      if (w.disks.position[i].y > 4.0) w.disks.position[i].y += next - lift;
    lift = next;
    reflect();
    for (World* x : {&w, &mirror}) {
      ++x->step;
      x->time = static_cast<double>(x->step) * 0.01;
    }
    moving.after_step(w, none, StepReport{});
    still.after_step(mirror, none, StepReport{});
  }
  ASSERT_EQ(moving.windows().size(), 1u);
  ASSERT_EQ(still.windows().size(), 1u);
  const WindowProfile &a = moving.windows()[0], &b = still.windows()[0];
  ASSERT_GT(std::abs(a.height - height - 0.225), 0.0);  // the mean height is no sample's
  for (std::size_t k = 0; k < quick_options().boundary_thickness.size(); ++k) {
    const RegionValues &top = a.regions[k], &bottom = b.regions[k];
    SCOPED_TRACE(top.h);
    EXPECT_NEAR(top.top_solid_fraction, bottom.bottom_solid_fraction, 1e-12);
    EXPECT_GT(top.top_solid_fraction, 0.5);
    EXPECT_NEAR(top.top_velocity_jump, bottom.bottom_velocity_jump, 1e-12);
    EXPECT_NEAR(top.top_mu_eff, bottom.bottom_mu_eff, 1e-12);  // kinetic stress alone
    EXPECT_NEAR(top.top_coordination, bottom.bottom_coordination, 1e-12);
  }
  // h = 2: the grains within 2.5 d of the top wall all ride on it at V.
  EXPECT_NEAR(a.regions[0].top_velocity_jump, 0.0, 1e-12);
  // Stripe by stripe, the same profile in depth as the reflection's from its bottom wall.
  for (std::size_t k = 0; k < moving.top_stripe_depths().size(); ++k) {
    EXPECT_NEAR(a.top_stripes.solid_fraction[k], b.solid_fraction[k], 1e-12);
    EXPECT_NEAR(a.top_stripes.vx[k], -b.vx[k], 1e-12);
  }
}

/// A lattice whose grains get random velocities at every step, measured for `steps` steps.
struct NoisyRun {
  World world;
  ShearMeasurement measurement;
};
NoisyRun noisy_run(std::uint64_t seed, int steps) {
  NoisyRun r{
      lattice_world(10.0, 8.0, 0.5),
      ShearMeasurement(quick_options(), {0.01, 0.5, 0.25, 8.0}, lattice_world(10.0, 8.0, 0.5))};
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int s = 0; s < steps; ++s) {
    for (std::size_t i = 0; i < r.world.disks.size(); ++i) {
      r.world.disks.velocity[i] = {noise(rng), noise(rng)};
      r.world.disks.omega[i] = noise(rng);
    }
    feed(r.measurement, r.world, 1);
  }
  return r;
}

/// The metadata of the noisy run's cell (dt 0.01, V 0.5, sigma_yy 0.25, 10 x 8): the readers
/// refuse sizes, speeds and durations that are not finite and > 0.
RunMetadata physical_metadata(const World& w) {
  RunMetadata meta;
  meta.n = w.disks.size();
  meta.length_x = 10.0;
  meta.height = 8.0;
  meta.velocity = 0.5;
  meta.normal_stress = 0.25;
  meta.dt = 0.01;
  meta.duration = 2.5;
  meta.time = w.time;
  return meta;
}

TEST(RunDataFile, DataThatAreNotARunAreRefusedNamingTheKey) {
  // As the analysis's reader does (python/tests/test_rundata_physics.py): what `cdshear run`
  // cannot write.
  NoisyRun run = noisy_run(3, 50);
  const testing::TempDir tmp("run_data_not_physics");
  const auto refused = [&](RunMetadata meta, const std::string& key) {
    write_run_data(tmp.path() / "run.h5", meta, run.measurement, run.world, {});
    try {
      read_run_data(tmp.path() / "run.h5");
      ADD_FAILURE() << "accepted a run.h5 with a bad " << key;
    } catch (const ConfigError& e) {
      EXPECT_EQ(e.key(), key) << e.what();
    }
  };
  RunMetadata meta = physical_metadata(run.world);
  meta.velocity = 0.0;
  refused(meta, "velocity");
  meta = physical_metadata(run.world);
  meta.height = -8.0;
  refused(meta, "height");
  meta = physical_metadata(run.world);
  meta.duration = std::numeric_limits<double>::quiet_NaN();
  refused(meta, "duration");
  meta = physical_metadata(run.world);
  meta.time = -1.0;
  refused(meta, "time");
}

TEST(RunDataFile, WrittenAndReadBackGivesTheSameNumbers) {
  NoisyRun run = noisy_run(3, 250);
  const World& w = run.world;
  const ShearMeasurement& m = run.measurement;
  ASSERT_EQ(m.windows().size(), 2u);
  const testing::TempDir tmp("run_data_roundtrip");
  const auto path = tmp.path() / "run.h5";
  RunMetadata meta = physical_metadata(w);
  meta.case_toml = "[shear]\nvelocity = 0.5\n";
  meta.step = w.step;
  write_run_data(path, meta, m, w, {});
  const RunData back = read_run_data(path);
  EXPECT_EQ(back.meta.case_toml, meta.case_toml);
  EXPECT_EQ(back.meta.step, w.step);
  ASSERT_EQ(back.series.size(), m.series().size());
  for (std::size_t r = 0; r < back.series.size(); ++r) {
    EXPECT_EQ(back.series[r].step, m.series()[r].step);
    EXPECT_EQ(back.series[r].com_vx, m.series()[r].com_vx);
    EXPECT_EQ(back.series[r].kinetic_energy, m.series()[r].kinetic_energy);
  }
  ASSERT_EQ(back.windows.size(), 2u);
  for (std::size_t k = 0; k < m.stripes(); ++k) {
    const WindowProfile &a = m.windows()[1], &b = back.windows[1];
    EXPECT_TRUE(a.vx[k] == b.vx[k] || (std::isnan(a.vx[k]) && std::isnan(b.vx[k])));
    EXPECT_EQ(a.solid_fraction[k], b.solid_fraction[k]);
    EXPECT_TRUE(a.kinetic_stress[k].xy == b.kinetic_stress[k].xy ||
                (std::isnan(a.kinetic_stress[k].xy) && std::isnan(b.kinetic_stress[k].xy)));
  }
  EXPECT_EQ(back.windows[1].regions.at(1).h, 3.0);
  EXPECT_EQ(back.windows[0].regions.at(0).bulk_solid_fraction,
            m.windows()[0].regions.at(0).bulk_solid_fraction);
}

TEST(RunDataFile, PythonLoadRunReadsTheSameNumbers) {
  // The same numbers as JSON (shortest round-trip decimal, NaN as null) and as run.h5; the
  // project's Python package loads run.h5 and must find them bit for bit.
  NoisyRun run = noisy_run(9, 200);
  const World& w = run.world;
  const ShearMeasurement& m = run.measurement;
  const testing::TempDir tmp("python_reads");
  const RunMetadata meta = physical_metadata(w);
  write_run_data(tmp.path() / "run.h5", meta, m, w, {});
  nlohmann::json expected;
  for (const SeriesRow& r : m.series()) {
    expected["series"]["com_vx"].push_back(r.com_vx);
    expected["series"]["kinetic_energy"].push_back(r.kinetic_energy);
  }
  for (const WindowProfile& p : m.windows()) {
    expected["windows"]["vx"].push_back(p.vx);
    expected["windows"]["solid_fraction"].push_back(p.solid_fraction);
    expected["top_stripes"]["vx"].push_back(p.top_stripes.vx);
    expected["top_stripes"]["solid_fraction"].push_back(p.top_stripes.solid_fraction);
  }
  expected["top_stripes"]["depth"] = m.top_stripe_depths();
  std::ofstream(tmp.path() / "expected.json") << expected.dump();
  const std::string script =
      "import json, sys, numpy as np\n"
      "from cdshear_analysis import load_run\n"
      "run = load_run(sys.argv[1]); e = json.load(open(sys.argv[1] + '/expected.json'))\n"
      "ok = True\n"
      "for group in e:\n"
      "  for name, values in e[group].items():\n"
      "    want = np.array(values, dtype=float)\n"
      "    ok = ok and np.array_equal(run[group][name], want, equal_nan=True)\n"
      "sys.exit(0 if ok else 1)\n";
  std::ofstream(tmp.path() / "check.py") << script;
  const std::string command = "PYTHONPATH='" CDSHEAR_SOURCE_DIR "/python' /usr/bin/python3 '" +
                              (tmp.path() / "check.py").string() + "' '" + tmp.path().string() +
                              "'";
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
}

TEST(RunDataFile, MissingEmptyAndTruncatedFilesAreClearErrors) {
  const testing::TempDir tmp("run_data_bad");
  const auto& dir = tmp.path();
  const auto expect_error = [](const std::filesystem::path& p, const std::string& words) {
    try {
      read_run_data(p);
      ADD_FAILURE() << "no error for " << p;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  expect_error(dir / "absent.h5", "no such file");
  { std::ofstream(dir / "empty.h5"); }
  expect_error(dir / "empty.h5", "has no cdshear seal");
  // A real file cut in half.
  World w = lattice_world(10.0, 8.0, 0.5);
  ShearMeasurement m(quick_options(), {0.01, 0.5, 0.25, 8.0}, w);
  feed(m, w, 200);
  write_run_data(dir / "whole.h5", RunMetadata{}, m, w, {});
  const std::string bytes = testing::read_text(dir / "whole.h5");
  { std::ofstream(dir / "cut.h5", std::ios::binary) << bytes.substr(0, bytes.size() / 2); }
  expect_error(dir / "cut.h5", "damaged");
  // One byte changed in the middle: HDF5 might read it, or crash on it; the seal refuses it.
  std::string flipped = bytes;
  flipped[flipped.size() / 2] = static_cast<char>(flipped[flipped.size() / 2] ^ 0x10);
  { std::ofstream(dir / "flipped.h5", std::ios::binary) << flipped; }
  expect_error(dir / "flipped.h5", "does not match the checksum");
  // A seal whose size is negative (not read as 2^64 - 5) is no seal.
  std::string negative = bytes;
  const std::size_t size_at = negative.find(" size=") + 6;
  ASSERT_LT(size_at, negative.find('\n'));
  negative.replace(size_at, 0, "-");
  { std::ofstream(dir / "negative.h5", std::ios::binary) << negative; }
  expect_error(dir / "negative.h5", "has no cdshear seal");
}

}  // namespace
}  // namespace cdshear

// The measurements of docs/model.md section 7 on the shear cell, as one observer-side object that
// reads the state after every step and never changes it (no I/O here; src/io/run_data_file writes
// what it holds).
//
// Every step: the solver statistics of the sampling interval, and each grain's contact moment
//   M_i = sum over its contacts j of R_ij (x) r_ij   [force time length]
// (R_ij the impulse of the step on i, r_ij from i's centre to the contact point), from the stored
// contact geometry of the step (normal, levers: start of step), so that the contact stress is
// a time average over every step, not a sample of single spiky steps.
// Every `sample_every` steps (a sample): one row of the global series, and each grain's share of
// every stripe (exact circular-segment area S_ik, first moment M1_ik and second moments X2_ik,
// Y2_ik about the centre, stripe_geometry.hpp) added to the running window: area, velocity
// including rotation, mass-weighted moments of the centre velocity and of the material velocity
// (for the kinetic stress), coordination, and the grain's contact moment accumulated since the
// previous sample, spread with weights S_ik / A_i. Stripes start at the bottom wall's current
// height; a second, short set starts at the top wall's current height and counts down (the top
// boundary layer's, so that it is as exact at every sample as the bottom one), with the same
// definitions in the depth below the wall (a part's first moment in y is minus its moment in
// depth). Every `samples_per_window` samples the window closes into a WindowProfile (every window
// kept):
//   solid fraction   nu_k = sum S_ik / (L_x dy N)                           (N samples)
//   velocity         v_k  = sum (v_ix S_ik - w_i M1_ik) / sum S_ik
//   contact stress   s_k  = sum_i (S_ik / A_i) (-M_i) / (L_x dy T)          (T window time)
//   kinetic stress   k_k  = (sum m_ik v v - (sum m_ik v)(sum m_ik v) / sum m_ik) / (L_x dy N),
//                    m_ik = rho_i S_ik, v the centre velocity: rho nu <dv (x) dv> about the
//                    window's stripe mean
//   rotational flux  r_k  = the same moments of the material velocity u = v + w x (p - c)
//                    integrated exactly over each part, minus k_k: with u_x = v_x - w y',
//                    u_y = v_y + w x', rho int u_x u_x = m v_x v_x - 2 rho v_x w M1 + rho w^2 Y2,
//                    rho int u_x u_y = m v_x v_y - rho v_y w M1, rho int u_y u_y = m v_y v_y +
//                    rho w^2 X2 (the odd moments in x' vanish); J w^2 / 2 on both normal
//                    components for a whole disk. Kept as a diagnostic, not added to the
//                    stress: a grain's mean internal stress is (1/A)(sum F (x) r - int rho a (x)
//                    x' dS), and the centripetal acceleration a = -w^2 x' of a spinning rigid
//                    disk gives + rho w^2 int x' (x) x' = (pi r^4 / 4) rho w^2 I, which cancels
//                    the rotational flux rho w^2 int (z x x') (x) (z x x') of the whole disk
//                    exactly; with each grain's stress spread over its area as a whole
//                    (model.md section 7), neither term enters
//   stress           s_k + k_k;  mu_eff = |stress_xy| / stress_yy
//   Z_k = sum S_ik z_i / sum S_ik, z_i the grain's closed contacts (below);
//   shear rate by central differences; I = |gamma_dot| sqrt(m / sigma_yy), m = pi/4.
// Compression is positive: -M_i is positive in compression.
//
// Coordination. A contact is closed at a sample when its gap, from the positions at the end of the
// sample's step, is at most `contact_gap` (overlaps included); the coordination number Z counts
// closed contacts, grain-grain and grain-wall, and the grains counted in the slip velocity are
// those with a closed contact with the wall. This is a property of the configuration: it
// converges as dt -> 0, whereas the contacts that carry an impulse at one sampled step grow with
// dt (a rigid contact may carry an impulse in one step and none in the next). That per-step count
// is kept, honestly named, as the force-carrying coordination: R_n > force_threshold times the
// mean R_n of the contacts with R_n > 0 at the sample step.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "contact.hpp"
#include "contact_dynamics.hpp"
#include "interval_stats.hpp"
#include "world.hpp"

namespace cdshear {

struct MeasureOptions {
  bool enabled = true;
  double sample_interval = 0.1;   ///< time between samples (series and profiles) [t]
  double window = 80.0;           ///< averaging window [t]
  double stripe_thickness = 1.0;  ///< dy [d]
  /// Stripes cover this times the nominal L_y: a fast flow dilates (system 1 at V = 5: L_y about
  /// 28 to 34 after a transient up to 61), and a profile must reach the top wall.
  double stripe_span = 2.0;
  std::vector<double> boundary_thickness{10.0};  ///< the h of the boundary layers [d]
  double force_threshold = 0.01;  ///< force-carrying: R_n > this * mean R_n (of R_n > 0)
  double contact_gap = 1e-4;      ///< closed contact (Z, slip): gap <= this at the sample [d]
};

/// The stripes of the profiles: stripe_span x nominal L_y / stripe_thickness, rounded up (a
/// double: a run that would ask for more than a size can hold is refused with this figure).
inline double stripe_count(const MeasureOptions& o, double nominal_height) {
  return std::ceil(o.stripe_span * nominal_height / o.stripe_thickness);
}

/// The stripes counted down from the top wall: down to one stripe below the largest h, so that
/// the velocity at depth h lies between two stripe centres.
std::size_t top_stripe_count(const MeasureOptions& o);

/// What the measurement needs to know beyond the state.
struct MeasureContext {
  double dt = 0.0;               ///< time step [t]
  double velocity = 0.0;         ///< V of the walls [d/t]
  double normal_stress = 0.25;   ///< imposed sigma_yy [force/length]
  double nominal_height = 20.0;  ///< nominal L_y, sets the number of stripes [d]
};

/// m = pi/4: the mass of a disk of diameter 1 in I = gamma_dot sqrt(m / sigma_yy) (model.md
/// section 7).
inline constexpr double kInertialMass = 0.78539816339744830962;

struct Tensor2 {
  double xx = 0.0, xy = 0.0, yx = 0.0, yy = 0.0;  ///< [a][b]: xy is row x, column y
};

/// One row of the global time series; "interval" fields cover the steps since the previous row.
struct SeriesRow {
  std::uint64_t step = 0;
  double time = 0.0;
  double com_vx = 0.0;          ///< centre-of-mass x-velocity of the grains
  double block_vx = 0.0;        ///< mass-weighted x-velocity of the grains of the central half,
                                ///< H/4 < y - y_bottom < 3H/4 (the block, without the bands)
  double height = 0.0;          ///< L_y = y_top - y_bottom
  double solid_fraction = 0.0;  ///< disk area / (L_x L_y)
  double kinetic_energy = 0.0;
  std::uint64_t contacts = 0, force_carrying = 0, closed = 0;  ///< candidates, carrying, closed
  Vec2 bottom_force, top_force;  ///< interval mean force of the grains on each wall (impulses)
  double bottom_mu = 0.0, top_mu = 0.0;  ///< interval |f_x| / |f_y|
  IntervalStats solver;
};

/// Bulk and boundary-layer quantities of one window for one boundary thickness h (NaN: empty).
struct RegionValues {
  double h = 0.0;
  double bulk_mu_eff, bulk_solid_fraction, bulk_coordination, bulk_force_carrying_coordination,
      bulk_shear_rate, bulk_inertial_number;
  double bottom_mu_eff, bottom_solid_fraction, bottom_coordination,
      bottom_force_carrying_coordination, bottom_velocity_jump, bottom_inertial_number;
  double top_mu_eff, top_solid_fraction, top_coordination, top_force_carrying_coordination,
      top_velocity_jump, top_inertial_number;
};

/// The stripes counted down from the top wall at each sample (stripe k between depths k dy and
/// (k + 1) dy below the wall): the top boundary layer's profile, exact at every sample as the
/// bottom layer's stripes are (docs/measurements.md, "Bulk and boundary layers").
struct TopStripes {
  std::vector<double> solid_fraction, vx, coordination, force_carrying_coordination;
  std::vector<Tensor2> stress;  ///< contact + kinetic, as WindowProfile::stress
};

/// One completed averaging window. Profiles have one entry per stripe (NaN where empty).
struct WindowProfile {
  double t_start = 0.0, t_end = 0.0;
  std::uint64_t samples = 0;
  double height = 0.0, com_vx = 0.0;  ///< window means
  std::vector<double> solid_fraction, vx, mu_eff, coordination, force_carrying_coordination,
      shear_rate, inertial_number;
  /// stress = contact_stress + kinetic_stress (centre velocities); rotational_stress is the
  /// rotation's momentum flux, a diagnostic (cancelled by the spinning grains' internal stress)
  std::vector<Tensor2> contact_stress, kinetic_stress, rotational_stress, stress;
  Vec2 bottom_force, top_force;  ///< exact window means from the walls' impulses
  double wall_mu = 0.0;          ///< mean of |f_x| / |f_y| of the two walls
  double slip_bottom = 0.0, slip_top = 0.0;
  std::uint64_t slip_bottom_count = 0, slip_top_count = 0;
  TopStripes top_stripes;             ///< depths: ShearMeasurement::top_stripe_depths()
  std::vector<RegionValues> regions;  ///< one per boundary thickness
};

/// Per-stripe sums of one set of stripes over the open window (each vector one entry per
/// stripe).
struct StripeSums {
  std::vector<double> area;           ///< sum S_ik
  std::vector<double> velocity_area;  ///< sum (v_ix S_ik - w_i M1_ik)
  std::vector<double> mass, mass_vx, mass_vy, mass_vxx, mass_vxy, mass_vyy;  ///< rho S, rho S v..
  /// rho int u dS and rho int u u dS of the material velocity u (u_y's integral is mass_vy's)
  std::vector<double> material_vx, material_vxx, material_vxy, material_vyy;
  std::vector<double> coordination_area;  ///< sum S_ik z_i, closed contacts
  std::vector<double> carrying_area;      ///< sum S_ik z_i, force-carrying contacts
  std::vector<double> stress_xx, stress_xy, stress_yx, stress_yy;  ///< sum S_ik (-M_i) / A_i

  void assign(std::size_t stripes);  ///< that many stripes, all sums zero
  bool same_size() const;            ///< every sum has area's length
};

/// Running sums of the open window: with the per-grain moments and the interval statistics, all
/// that a checkpoint must carry for a resumed run to measure bit-identically.
struct WindowSums {
  std::uint64_t samples = 0;
  std::uint64_t step_start = 0;
  Vec2 bottom_impulse_start, top_impulse_start;  ///< walls' contact impulses at the start
  double height_sum = 0.0, com_vx_sum = 0.0;
  double slip_bottom_sum = 0.0, slip_top_sum = 0.0;
  std::uint64_t slip_bottom_count = 0, slip_top_count = 0;
  StripeSums stripes;      ///< the profile's stripes, counted up from the bottom wall
  StripeSums top_stripes;  ///< the top layer's stripes, counted down from the top wall
};

struct MeasurementState {
  WindowSums window;
  std::vector<Tensor2> grain_moment;  ///< M_i since the last sample [force time length]
  IntervalStats interval;
  std::uint64_t last_sample_step = 0;
  double last_sample_time = 0.0;
  Vec2 bottom_impulse_last, top_impulse_last;  ///< walls' contact impulses at the last sample
};

/// The measurements of one shear run. Walls: bottom index 0, top index 1 (shear_case.hpp).
class ShearMeasurement {
 public:
  ShearMeasurement(MeasureOptions options, MeasureContext context, const World& world);

  /// Call after every step with the contacts of that step.
  void after_step(const World& world, const std::vector<Contact>& contacts,
                  const StepReport& report);

  const MeasureOptions& options() const { return options_; }
  const MeasureContext& context() const { return context_; }
  std::uint64_t sample_every() const { return sample_every_; }
  std::uint64_t samples_per_window() const { return samples_per_window_; }
  std::size_t stripes() const { return stripe_centres_.size(); }
  const std::vector<double>& stripe_centres() const { return stripe_centres_; }
  /// Centres of the top stripes, as depths below the top wall [d].
  const std::vector<double>& top_stripe_depths() const { return top_stripe_depths_; }
  const std::vector<SeriesRow>& series() const { return series_; }
  const std::vector<WindowProfile>& windows() const { return windows_; }
  const MeasurementState& state() const { return state_; }

  /// Resume: the open window and moments from a checkpoint, completed rows and windows from the
  /// run's data file (cut at the checkpoint's step).
  void restore(MeasurementState state, std::vector<SeriesRow> series,
               std::vector<WindowProfile> windows);

 private:
  /// Contacts of a sample, over the whole packing.
  struct ContactCounts {
    std::uint64_t carrying = 0, closed = 0;
  };

  void add_contact_moments(std::size_t n, const std::vector<Contact>& contacts);
  /// One sample: the series row, each grain's share of the stripes, and the window closed when
  /// it is full.
  void sample(const World& world, const std::vector<Contact>& contacts);
  /// Closed and force-carrying contacts per grain (carrying_count_, closed_count_) and which
  /// grains touch a wall with a closed contact (touches_).
  ContactCounts count_contacts(const World& world, const std::vector<Contact>& contacts);
  /// The series row of this sample (the wall forces averaged since the last one); returns its
  /// centre-of-mass velocity.
  double add_series_row(const World& world, const std::vector<Contact>& contacts,
                        const ContactCounts& counts);
  /// Each grain's share of each stripe, and the wall slip, into the window's sums.
  void add_stripe_shares(const World& world);
  void close_window(const World& world);
  void reset_window(const World& world);

  MeasureOptions options_;
  MeasureContext context_;
  double length_x_ = 0.0;
  std::uint64_t sample_every_ = 1, samples_per_window_ = 1;
  std::vector<double> stripe_centres_;
  std::vector<double> top_stripe_depths_;
  MeasurementState state_;
  std::vector<SeriesRow> series_;
  std::vector<WindowProfile> windows_;
  std::vector<int> carrying_count_;    ///< scratch: force-carrying contacts per grain
  std::vector<int> closed_count_;      ///< scratch: closed contacts per grain
  std::vector<signed char> touches_;   ///< scratch: bit 1 bottom wall, bit 2 top wall
  std::vector<std::uint32_t> loaded_;  ///< scratch: contacts carrying an impulse, this step
};

/// Gap of a candidate contact from the world's current positions (< 0: overlap) [length]: the
/// nearest periodic image between two disks, the distance to the wall's line minus the radius.
double current_gap(const World& world, const Contact& contact);

/// Force threshold of a contact list: force_threshold times the mean R_n of contacts with R_n > 0.
double force_carrying_threshold(const std::vector<Contact>& contacts, double relative);

/// Bulk and boundary quantities of a window for one h (exposed for tests): the bulk and the
/// bottom layer from the stripes counted up from the bottom wall (`stripe_centres`), the top
/// layer from w.top_stripes (`top_depths`, below the top wall).
RegionValues region_values(const WindowProfile& w, const std::vector<double>& stripe_centres,
                           const std::vector<double>& top_depths, double h, double velocity,
                           double normal_stress);

}  // namespace cdshear

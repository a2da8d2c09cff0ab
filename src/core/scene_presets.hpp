// Ready-made scenes shared by the benchmarks and the tests: a dense packing of disks compressed
// by a pressure-controlled top wall. They are built through the project's one scene builder
// (SceneDefinition + build_world) and stepped with the ordinary ContactDynamics step.
//
// Units are those of docs/model.md section 1: length = largest grain diameter (the default
// diameters are in [0.8, 1.0]), mass from the 2D density 1, and the time unit set by the pressure
// (stress sigma_yy = force / length = 0.25 by default).
#pragma once

#include <cstdint>

#include "contact_dynamics.hpp"
#include "scene.hpp"
#include "world.hpp"

namespace cdshear {

/// A box of width `width` with a fixed bottom wall at y = 0, fixed side walls at x = 0 and
/// x = width (or a periodic x boundary of period `width`), and a top wall that is free in y
/// (fixed in x), pushed down by force pressure * width. The disks are placed at random, without
/// overlap, in the whole box below the top wall; the box height is chosen so that the disks
/// cover `initial_solid_fraction` of it (random sequential addition cannot go much above 0.5).
/// No gravity. `compaction_speed` is used by make_dense_box (start_compaction), not by the scene.
struct CompressedBoxParams {
  std::size_t count = 500;               ///< number of disks
  double width = 20.0;                   ///< box width, or x period when periodic_x [length]
  bool periodic_x = false;               ///< periodic in x instead of side walls
  double diameter_min = 0.8;             ///< smallest disk diameter [length]
  double diameter_max = 1.0;             ///< largest disk diameter [length]
  double initial_solid_fraction = 0.45;  ///< expected disk area / box area at placement [-]
  double pressure = 0.25;                ///< sigma_yy: top-wall force per unit width [force/length]
  double top_wall_mass = 50.0;           ///< mass of the top wall (free in y) [mass]
  double friction_disk_disk = 0.5;       ///< Coulomb coefficient between disks [-]
  double friction_wall = 0.5;            ///< Coulomb coefficient between disks and walls [-]
  double density = 1.0;                  ///< 2D mass density of the disks [mass/length^2]
  std::uint64_t seed = 1;                ///< seeds diameters and placement
  double compaction_speed = 2.0;  ///< initial top-wall speed, see start_compaction [length/time]
};

/// Wall indices of the compressed box in World::walls (named "bottom", "top", "left", "right";
/// the side walls exist only when the box is not periodic).
inline constexpr std::size_t kBoxBottomWall = 0;
inline constexpr std::size_t kBoxTopWall = 1;

/// Expected disk area of `count` disks with diameters uniform in [dmin, dmax]:
/// count * pi/4 * E[d^2], E[d^2] = (dmax^3 - dmin^3) / (3 (dmax - dmin)) (dmin^2 if equal).
double expected_disk_area(std::size_t count, double diameter_min, double diameter_max);

/// The scene described above (not yet dense: the disks are loose, at rest).
SceneDefinition compressed_box_scene(const CompressedBoxParams& p);

/// Sets the initial velocities of a compaction: the top wall moves down at `speed` and every disk
/// at the affine profile v_y = -speed * y / h (h: height of the top wall above the bottom wall,
/// y measured from the bottom wall), so that the whole box closes at once, in about
/// h (1 - initial fraction / final fraction) / speed, instead of a slow snowplow from the top
/// under the pressure alone (whose velocity scale is sqrt(pressure / density) = 0.5). speed = 0
/// leaves everything at rest.
void start_compaction(World& world, double speed);

/// Step settings of the compaction: coarser than the StepOptions defaults, because the
/// preparation only has to end dense and at rest, not follow an accurate trajectory: dt = 4e-3,
/// displacement_bound = 0.02, solver alpha = 1e-4 and max_sweeps = 20 (the reference values of
/// model.md section 3, item 5: 1e-6 and 200; 20 sweeps halve the preparation time of 5000 disks
/// against 50, 10 let the packing creep). With compaction_speed 2 a disk moves at most about 0.01
/// per step.
StepOptions densify_step_options();

/// When a compressed packing counts as dense, checked every `check_every` steps: kinetic energy
/// per disk and top-wall speed below their thresholds, and the top wall resting on the disks
/// (the force they exert on it at least `min_top_wall_support` times the applied force). The
/// velocity scale of the problem is sqrt(pressure / density) = 0.5 by default and its energy
/// scale per disk pressure * d^2 = 0.25: the default thresholds are a velocity of about 2% of the
/// scale, a coarse criterion meant for benchmarks and test fixtures. NLGS at a finite tolerance
/// leaves a small creep in a static frictional packing, so much lower thresholds may never be
/// met.
struct DensifyOptions {
  StepOptions step = densify_step_options();  ///< time step and solver settings of the stepping
  double max_kinetic_energy_per_disk = 1e-4;  ///< [mass length^2/time^2]
  double max_top_wall_speed = 1e-2;           ///< |v_y| of the top wall [length/time]
  double min_top_wall_support = 0.5;          ///< contact force / applied force on the top wall [-]
  std::uint64_t min_steps = 100;              ///< never stop before this many steps
  std::uint64_t max_steps = 100000;           ///< give up (dense = false) after this many steps
  std::uint64_t check_every = 50;             ///< test the criterion every this many steps
};

struct DensifyReport {
  bool dense = false;                    ///< criterion met before max_steps
  std::uint64_t steps = 0;               ///< steps done
  double kinetic_energy_per_disk = 0.0;  ///< at the end [mass length^2/time^2]
  double top_wall_speed = 0.0;           ///< |v_y| of the top wall at the end [length/time]
  double top_wall_support = 0.0;         ///< contact force / applied force, top wall, last step [-]
  double height = 0.0;                   ///< top-wall y minus bottom-wall y at the end [length]
  double solid_fraction = 0.0;           ///< disk area / (width * height) at the end [-]
  std::size_t contacts = 0;              ///< candidate contacts of the last step
  std::uint64_t capped_steps = 0;        ///< steps whose solver hit the sweep cap
};

/// Steps `world` (a compressed box: wall kBoxTopWall is the top wall) with `dynamics` until the
/// criterion of `options` holds or max_steps is reached. Throws std::runtime_error if a step
/// blows up.
DensifyReport densify(World& world, ContactDynamics& dynamics, const DensifyOptions& options);

/// A dense compressed box: the world, the contact memory of its last step (for warm starts) and
/// how the compaction went.
struct DenseBox {
  World world;
  ContactDynamics dynamics;
  DensifyReport report;
};

/// build_world(compressed_box_scene(p)), start_compaction(p.compaction_speed), then densify;
/// the world's time and step counter are reset to 0 afterwards (the contact memory is kept).
DenseBox make_dense_box(const CompressedBoxParams& p, const DensifyOptions& options = {});

}  // namespace cdshear

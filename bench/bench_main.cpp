// cdshear_bench: the cost of the Contact Dynamics step on dense packings (docs/benchmarks.md).
//
// For each size (about 500 and 5000 disks, periodic in x) a dense packing is prepared with the
// compressed-box preset (untimed), then stepped
//   - "static": at rest under the top-wall pressure, StepOptions defaults (dt = 1e-3);
//   - "shear":  bottom and top walls driven at -V and +V along x, both free in y under the
//               pressure (docs/model.md section 4), dt from the shear default rule
//               min(5e-3, 2e-3 / V);
// and the figures below are written as one CSV line per case to stdout:
//   ns_per_update   solve seconds / sum over steps of (sweeps x contacts): one contact solved once
//                   in one sweep (the solve stage includes the Delassus fill, the warm start and
//                   the shuffle of the contact order, spread over the updates);
//   steps_per_s     steps / wall-clock seconds of the measured loop;
//   share_*         share of the summed stage timings (StepReport::seconds) per stage;
//   mean_sweeps, mean_contacts, capped_share (steps that hit the sweep cap) and more.
// Progress goes to stderr. --save appends the lines to bench/results/<hostname>.csv.
#include <lapacke.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "checkpoint.hpp"
#include "config_error.hpp"
#include "contact_dynamics.hpp"
#include "packing_file.hpp"
#include "scene_presets.hpp"
#include "shear_case.hpp"
#include "shear_measurement.hpp"
#include "toml_reader.hpp"
#include "world.hpp"

#ifndef CDSHEAR_SOURCE_DIR
#define CDSHEAR_SOURCE_DIR "."
#endif
#ifndef CDSHEAR_BUILD_TYPE
#define CDSHEAR_BUILD_TYPE "unknown"
#endif

namespace {

using cdshear::AxisMode;
using cdshear::ContactDynamics;
using cdshear::StepOptions;
using cdshear::StepReport;
using cdshear::World;
using Clock = std::chrono::steady_clock;

cdshear::SolverOptions one_thread(cdshear::SolverOptions s) {
  s.threads = 1;
  return s;
}

/// The step options of a shear case at wall speed V as `cdshear run` resolves them
/// (resolve_step_rules, shear_case.hpp): the time step, alpha and the contact-law bound from
/// their rules unless given.
cdshear::StepOptions shear_step_rules(double velocity, std::optional<double> alpha,
                                      std::optional<double> residual_tolerance,
                                      std::optional<double> dt) {
  cdshear::ShearCase c;
  c.velocity = velocity;
  c.alpha = alpha;
  c.residual_tolerance = residual_tolerance;
  c.dt = dt;
  cdshear::resolve_step_rules(c);
  return c.step;
}

struct Settings {
  bool core_round_trip = false;  // --core-round-trip: measure it and stop
  std::vector<std::size_t> sizes{500, 5000};
  bool run_static = true;
  bool run_shear = true;
  double seconds = 12.0;         // measured wall time per case (at least)
  std::uint64_t min_steps = 20;  // measured steps per case (at least)
  std::uint64_t warmup_steps = 100;
  double velocity = 0.5;  // shear wall speed V
  double width = 0.0;     // cell width; 0: 20 below 2000 disks, 50 above
  // The shear phase's solver settings (shear_step_defaults), one thread: what `cdshear run`
  // steps a shear case with, per core. Each option below overrides one of them.
  cdshear::SolverOptions solver = one_thread(cdshear::shear_step_defaults().solver);
  // Neither --alpha nor --plain: the shear case takes the shear phase's rule, alpha =
  // default_alpha(V) (shear_case.hpp), the static case shear_step_defaults()' alpha.
  bool alpha_given = false;
  // Neither --residual-tolerance nor --plain: the shear case takes the shear phase's rule,
  // default_residual_tolerance(V, dt), the static case none.
  bool residual_given = false;
  std::optional<double> dt;  // --dt: the shear time step [t]; none: the rule (step.dt "auto")
  double reference_relaxation = 1.0;  // relaxation of --step-error's reference solve
  int reference_anderson = 0;         // Anderson depth of that reference solve (0: off)
  int reference_newton = 0;           // active-set iterations ending it (and --polish's)
  int step_error_samples = 0;
  int step_error_spacing = 20;  // ordinary steps before each sample
  bool from_reference = false;  // after each sample, go on from the reference's step
  // The ordinary steps (warm-up, measured, between samples) with the shear defaults, only the
  // samples' tested solves with `solver`: runs that differ in `solver` sample the same states.
  bool paired = false;
  bool polish = false;          // a third solve: the reference's settings from the tested end
  double state_jitter = 0.0;    // one more: the reference from disks moved by up to this [d]
  bool error_spectrum = false;  // split each sample's error over the modes of M^-1/2 H^T
  bool error_locality = false;  // where in the packing each sample's error lies
  std::string dump_samples;     // folder: each sample's contacts, bodies and both solves
  bool stress_error = false;    // what each sample's error does to the contact stress
  int stress_window = 1;        // steps --stress-error sums, along both solves' own paths
  bool save = false;
  std::string save_path;  // empty: bench/results/<hostname>.csv in the source tree
  std::string packing;    // a prepared packing (cdshear prepare -o FILE) instead of the sizes
  std::string state;      // a run's checkpoint (checkpoint.cbor) instead of the sizes
};

struct System {
  std::size_t disks;
  double width;
};

System system_for(std::size_t disks, double width) {
  // Widths of the reference study's cells: 20 for the small ones, 50 for system 4.
  if (width > 0.0) return {disks, width};
  return {disks, disks >= 2000 ? 50.0 : 20.0};
}

void usage() {
  std::cerr <<
      R"(usage: cdshear_bench [options]
  --quick             shorter run: 4 s per case, 30 warm-up steps (about 1 minute in all)
  --sizes N[,N...]    disk counts (default 500,5000); width 20 below 2000 disks, 50 above
  --width W           cell width for every size (system 7's shape: --sizes 5119 --width 20)
  --seconds S         measured wall time per case, at least (default 12)
  --steps N           measure exactly N steps per case instead (no time limit): with the
                      same settings, the same states whatever the machine's speed
  --warmup N          untimed steps before each measurement (default 100)
  --velocity V        shear wall speed (default 0.5)
  --dt DT             shear time step [t] (default: the rule of `cdshear run`, step.dt
                      "auto": min(0.005, 0.002 / V)); the contact-law bound follows it
Solver settings: the shear phase's defaults (shear_case.hpp, docs/case-files.md) on one thread;
each option overrides one of them.
  --plain             start from the engine's plain defaults instead (random order, no
                      acceleration, alpha 1e-6: scene files' defaults); later options apply on top
  --order O           NLGS contact order: random or coloured (default)
  --threads N         solver threads (default 1; used by the coloured order only)
  --skip-dormant, --no-skip-dormant
                      leave dormant contacts out of the sweeps, or not (solver.skip_dormant; on)
  --anderson M        Anderson mixing of the last M sweeps' images (solver.anderson_depth, 5)
  --anderson-period P mix every P sweeps (solver.anderson_period, 4)
  --slab-correction P the slab correction every P sweeps in packings of 20 bands or more,
                      coloured order only (solver.slab_correction_period, 8; 0: off); where
                      it runs, the mix runs every 2 anderson-period sweeps
  --max-sweeps N      sweep cap (solver.max_sweeps, 200)
  --no-plain-finish   stop an over-relaxed step at the cap instead of going on with
                      relaxation 1 for up to max-sweeps more (SolverOptions::plain_finish)
  --relaxation W      over-relaxation of each update, 1 <= W < 2 (solver.relaxation, 1.6)
  --normal-compliance K  normal compliance, 0 <= K < 1, a fraction of each contact's w_nn
                      (solver.normal_compliance, 0: rigid); --step-error's reference solves
                      the same compliant step
  --alpha A           convergence tolerance (solver.alpha; default: the shear phase's rule,
                      1e-5 (V' / 0.5)^2 with V' = V within [0.05, 0.5], 1e-5 in the static
                      case; 0: every step sweeps max-sweeps times, to compare settings at
                      equal sweeps)
  --converged-fraction F  share of the force-carrying contacts that must meet alpha
                      (solver.converged_fraction, 0.9, as in docs/model.md section 3)
  --newton N          active-set Newton iterations after the sweeps (solver.newton_iterations,
                      0: off; active_set_solve.hpp)
  --newton-history    with --step-error, print each tested solve's refinement iterations:
                      statuses changed, unknowns, contacts open / sticking / sliding,
                      |dR| / |R| of the linear solve, the ratio test's step and the contacts
                      blocking it, the line search's fraction, the regularisations raised,
                      GMRES or factorised, the residual after it
  --residual-tolerance L  stop only once the force-carrying contacts' root mean square
                      contact-law violation over the step, e dt, is at most L [d]
                      (solver.residual_tolerance; default: the shear phase's rule,
                      1e-4 max(V, 0.05) dt, none in the static case; 0: off)
  --profile           time the solver's stages on its first thread (set-up, sweeps, waits at
                      the phases' barriers, convergence test, slab correction, mix,
                      write-back) and print their shares of the solve
Reference solve of --step-error:
  --reference-anderson M  its Anderson depth (default 0: plain)
  --reference-relaxation W
                      its relaxation (default 1: Gauss-Seidel; every relaxation has the same
                      fixed point)
  --reference-newton N
                      N active-set Newton iterations after its sweeps (default 0), which end it
                      at round-off where the sweeps stop at their cap; with --polish, that solve
                      is 1 sweep and the N iterations from the tested impulses, ending on a
                      solution near the tested solve: its distance measures the tested solve's
                      error where the step has several solutions
  --step-error-spacing S  ordinary steps between two samples of --step-error (default 20)
  --from-reference    after each sample of --step-error, go on from the reference's step
                      instead of the tested one: how fast exact steps lose their accuracy
  --paired            every ordinary step (warm-up, measured, between samples) with the shear
                      defaults, only --step-error's tested solves with the settings given:
                      with --steps, runs that differ in their solver settings test the same
                      states, sample by sample (the case's line then describes the defaults)
  --polish            a third solve of each sample: the reference's settings, warm-started
                      from the tested solve's impulses; prints the tested solve's distance
                      to that exact solution (an upper bound on its distance to the step's
                      solution set) and that solution's distance to the reference (another
                      exact solution of the step where it is not small)
  --state-jitter EPS  one more solve of each --step-error sample: the reference's settings
                      from the same state with every disk moved by a fixed pseudo-random
                      displacement of up to EPS [d] (below 1e-4) along each axis; prints
                      how far that moves the step's solution (impulses matched by contact,
                      top wall force, velocities): how well the state defines the step's
                      solution
  --error-locality    where each sample's impulse error lies: its shares on the contacts whose
                      status differs from the reference's and on the 1% of contacts most
                      off, and the run of three bands of 4 d (by height) holding most of it,
                      with the relative error there
  --stress-error      what each sample's impulse error does to the contact stress (the sum
                      of R (x) branch vector): relative errors of sigma_yy and of
                      sigma_xy / sigma_yy over the bulk (beyond 10 d from both walls; the
                      middle half of a cell under 40 d), and the largest over bands of 4 d
                      and of 1 d (by the contact point's height)
  --stress-window K   with --stress-error, also the errors of the sums over K steps, each
                      solve going on along its own path from the sample (default 1: none);
                      the paths' own divergence included
  --error-spectrum    split each sample's impulse error over the singular vectors of
                      M^-1/2 H^T on the reference's force-carrying contacts (a dense SVD:
                      up to a few thousand contacts)
  --dump-samples DIR  write each --step-error sample as text to DIR/<case>_n<disks>/ (emptied
                      first): its contacts with the tested and reference impulses, its bodies
                      (bench/coarse_space.py)
  --step-error N      after each case, N times: solve one step with the case's settings and
                      again to round-off from the same state; print the impulse, wall-force
                      and velocity errors (stderr)
  --packing FILE      shear a prepared packing (`cdshear prepare --system K -o FILE`: the
                      study's cells, e.g. system 7) instead of compressed boxes of --sizes;
                      the shear case only, walls as `cdshear run` builds them
  --state FILE        go on from a shear run's checkpoint (its checkpoint.cbor: world, walls
                      and contact memory) instead of compressed boxes of --sizes; the shear
                      case only, at the state's own wall speed (--velocity is ignored); to
                      test the solver on an old, dense flow rather than a fresh packing
  --no-static         skip the static cases
  --no-shear          skip the shear cases
  --core-round-trip   only measure how long a cache line takes to go from one core to another
                      and back (two threads handing a counter to each other; median of 5
                      times 100000 hand-overs, in ns) and stop: on a virtual machine it
                      changes with where the host places the two processors, and the
                      solver's two-thread speed with it (docs/benchmarks.md, "Threads")
  --save[=PATH]       append the CSV lines to PATH (default bench/results/<hostname>.csv);
                      PATH's folder must exist
  --help              this text
CSV lines go to stdout, progress to stderr. See docs/benchmarks.md.
)";
}

/// Bad command-line input: exit status 2, as for `cdshear`.
struct UsageError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

/// The value of `option` as a whole number that T holds (no sign for an unsigned T, nothing after
/// the digits).
template <class T>
T whole(const std::string& option, const std::string& text) {
  T v{};
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, v);
  if (text.empty() || error != std::errc() || stop != end)
    throw UsageError(option + ": '" + text + "' is not a whole number" +
                     (std::is_unsigned_v<T> ? " >= 0" : "") +
                     (error == std::errc::result_out_of_range ? " this program can hold" : ""));
  return v;
}

/// The value of `option` as a finite number (nothing after it).
double number(const std::string& option, const std::string& text) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || !std::isfinite(v))
    throw UsageError(option + ": '" + text + "' is not a finite number");
  return v;
}

Settings parse(int argc, char** argv) {
  Settings s;
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    auto value = [&]() -> std::string {
      if (k + 1 >= argc) throw UsageError(a + " needs a value");
      return argv[++k];
    };
    if (a == "--quick") {
      s.seconds = 4.0;
      s.warmup_steps = 30;
      s.min_steps = 10;
    } else if (a == "--sizes") {
      s.sizes.clear();
      std::stringstream list(value());
      for (std::string item; std::getline(list, item, ',');) {
        s.sizes.push_back(whole<std::size_t>(a, item));
        // As many disks as `cdshear` takes (system.n).
        if (s.sizes.back() < 1 || s.sizes.back() > static_cast<std::size_t>(cdshear::kMaxDisks))
          throw UsageError("--sizes: each disk count must be in 1.." +
                           std::to_string(cdshear::kMaxDisks) + ", got " + item);
      }
    } else if (a == "--width") {
      s.width = number(a, value());
      if (!(s.width > 0.0)) throw UsageError("--width must be > 0");
    } else if (a == "--seconds") {
      s.seconds = number(a, value());
      if (!(s.seconds >= 0.0)) throw UsageError("--seconds must be >= 0");
    } else if (a == "--warmup") {
      s.warmup_steps = whole<std::uint64_t>(a, value());
    } else if (a == "--velocity") {
      s.velocity = number(a, value());
    } else if (a == "--dt") {
      s.dt = number(a, value());
      if (!(*s.dt > 0.0)) throw UsageError("--dt must be > 0");
    } else if (a == "--order") {
      if (!cdshear::contact_order_from_name(value(), s.solver.order))
        throw UsageError("--order must be random or coloured");
    } else if (a == "--packing") {
      s.packing = value();
    } else if (a == "--state") {
      s.state = value();
    } else if (a == "--plain") {
      s.solver = one_thread(cdshear::SolverOptions{});
      s.alpha_given = true;
      s.residual_given = true;
    } else if (a == "--no-plain-finish") {
      s.solver.plain_finish = false;
    } else if (a == "--newton-history") {
      s.solver.newton_history = true;
    } else if (a == "--newton") {
      s.solver.newton_iterations = whole<int>(a, value());
      if (s.solver.newton_iterations < 0 ||
          s.solver.newton_iterations > cdshear::kMaxNewtonIterations)
        throw UsageError("--newton must be in 0.." + std::to_string(cdshear::kMaxNewtonIterations));
    } else if (a == "--step-error") {
      s.step_error_samples = whole<int>(a, value());
      if (s.step_error_samples < 0) throw UsageError("--step-error must be >= 0");
    } else if (a == "--step-error-spacing") {
      s.step_error_spacing = whole<int>(a, value());
      if (s.step_error_spacing < 0) throw UsageError("--step-error-spacing must be at least 0");
    } else if (a == "--from-reference") {
      s.from_reference = true;
    } else if (a == "--paired") {
      s.paired = true;
    } else if (a == "--polish") {
      s.polish = true;
    } else if (a == "--state-jitter") {
      s.state_jitter = number(a, value());
      // Small enough that no disk crosses x = 0 in one of the two solves only (its contacts'
      // keys would then differ between them): the chance is about N EPS / L_x per sample.
      if (!(s.state_jitter >= 0.0 && s.state_jitter < 1e-4))
        throw UsageError("--state-jitter must be in [0, 1e-4)");
    } else if (a == "--steps") {
      s.min_steps = whole<std::uint64_t>(a, value());
      s.seconds = 0.0;
      if (s.min_steps == 0) throw UsageError("--steps must be >= 1");
    } else if (a == "--error-spectrum") {
      s.error_spectrum = true;
    } else if (a == "--error-locality") {
      s.error_locality = true;
    } else if (a == "--dump-samples") {
      s.dump_samples = value();
    } else if (a == "--stress-error") {
      s.stress_error = true;
    } else if (a == "--stress-window") {
      s.stress_window = whole<int>(a, value());
      if (s.stress_window < 1) throw UsageError("--stress-window must be at least 1");
    } else if (a == "--max-sweeps") {
      s.solver.max_sweeps = whole<int>(a, value());
      if (s.solver.max_sweeps < 1) throw UsageError("--max-sweeps must be at least 1");
    } else if (a == "--converged-fraction") {
      s.solver.converged_fraction = number(a, value());
      if (!(s.solver.converged_fraction >= 0.0 && s.solver.converged_fraction <= 1.0))
        throw UsageError("--converged-fraction must be in [0, 1]");
    } else if (a == "--residual-tolerance") {
      s.solver.residual_tolerance = number(a, value());
      if (!(s.solver.residual_tolerance >= 0.0))
        throw UsageError("--residual-tolerance must be >= 0");
      s.residual_given = true;
    } else if (a == "--profile") {
      s.solver.profile = true;
    } else if (a == "--core-round-trip") {
      s.core_round_trip = true;
    } else if (a == "--alpha") {
      s.solver.alpha = number(a, value());
      s.alpha_given = true;
      if (!(s.solver.alpha >= 0.0)) throw UsageError("--alpha must be >= 0");
    } else if (a == "--reference-relaxation") {
      s.reference_relaxation = number(a, value());
      if (!(s.reference_relaxation >= 1.0 && s.reference_relaxation < 2.0))
        throw UsageError("--reference-relaxation must be in [1, 2)");
    } else if (a == "--relaxation") {
      s.solver.relaxation = number(a, value());
      if (!(s.solver.relaxation >= 1.0 && s.solver.relaxation < 2.0))
        throw UsageError("--relaxation must be in [1, 2)");
    } else if (a == "--normal-compliance") {
      s.solver.normal_compliance = number(a, value());
      if (!(s.solver.normal_compliance >= 0.0 &&
            s.solver.normal_compliance < cdshear::kNormalComplianceBound))
        throw UsageError("--normal-compliance must be in [0, 1)");
    } else if (a == "--skip-dormant") {
      s.solver.skip_dormant = true;
    } else if (a == "--no-skip-dormant") {
      s.solver.skip_dormant = false;
    } else if (a == "--reference-newton") {
      s.reference_newton = whole<int>(a, value());
      if (s.reference_newton < 0 || s.reference_newton > cdshear::kMaxNewtonIterations)
        throw UsageError("--reference-newton must be in 0.." +
                         std::to_string(cdshear::kMaxNewtonIterations));
    } else if (a == "--reference-anderson") {
      s.reference_anderson = whole<int>(a, value());
      if (s.reference_anderson < 0 || s.reference_anderson > cdshear::kMaxAndersonDepth)
        throw UsageError("--reference-anderson must be in 0..16");
    } else if (a == "--anderson") {
      s.solver.anderson_depth = whole<int>(a, value());
      if (s.solver.anderson_depth < 0 || s.solver.anderson_depth > cdshear::kMaxAndersonDepth)
        throw UsageError("--anderson must be in 0..16");
    } else if (a == "--slab-correction") {
      s.solver.slab_correction_period = whole<int>(a, value());
      if (s.solver.slab_correction_period < 0) throw UsageError("--slab-correction must be >= 0");
    } else if (a == "--anderson-period") {
      s.solver.anderson_period = whole<int>(a, value());
      if (s.solver.anderson_period < 1) throw UsageError("--anderson-period must be >= 1");
    } else if (a == "--threads") {
      s.solver.threads = whole<int>(a, value());
      if (s.solver.threads < 1) throw UsageError("--threads must be at least 1");
    } else if (a == "--no-static") {
      s.run_static = false;
    } else if (a == "--no-shear") {
      s.run_shear = false;
    } else if (a == "--save") {
      s.save = true;
    } else if (a.rfind("--save=", 0) == 0) {
      s.save = true;
      s.save_path = a.substr(7);
    } else if (a == "--help" || a == "-h") {
      usage();
      std::exit(0);
    } else {
      throw UsageError("unknown option " + a);
    }
  }
  if (!(s.velocity > 0.0)) throw UsageError("--velocity must be > 0");
  if (s.state_jitter > 0.0 && s.step_error_samples == 0)
    throw UsageError("--state-jitter needs --step-error");
  if (!s.dump_samples.empty() && s.step_error_samples == 0)
    throw UsageError("--dump-samples needs --step-error");
  if (!s.state.empty() && !s.packing.empty())
    throw UsageError("--state and --packing exclude each other");
  if (!s.save_path.empty()) {  // checked before the bench runs, so that no figure is lost to it
    const std::filesystem::path path(s.save_path);
    const std::filesystem::path folder = path.parent_path();
    if (std::filesystem::is_directory(path))
      throw UsageError("--save=" + s.save_path + ": is a folder; --save takes a CSV file's path");
    if (!folder.empty() && !std::filesystem::is_directory(folder))
      throw UsageError("--save=" + s.save_path + ": the folder " + folder.string() +
                       " does not exist (only the default bench/results/ is created)");
  }
  return s;
}

std::string hostname() {
  char buf[256] = {};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

double load_average() {
  double load[1] = {0.0};
  return getloadavg(load, 1) == 1 ? load[0] : -1.0;
}

std::string compiler() {
#if defined(__clang__)
  return std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
  return std::string("g++ ") + __VERSION__;
#else
  return "unknown";
#endif
}

double seconds_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

/// Turns the dense box into the shear cell of model.md section 4: walls at -V and +V along x, both
/// free in y (mass of the top wall, force pressure * width inwards), disks given the linear
/// profile.
void start_shear(World& world, double v) {
  cdshear::Wall& bottom = world.walls[cdshear::kBoxBottomWall];
  cdshear::Wall& top = world.walls[cdshear::kBoxTopWall];
  bottom.mode_x = AxisMode::kImposed;
  bottom.velocity.x = -v;
  top.mode_x = AxisMode::kImposed;
  top.velocity.x = v;
  bottom.mode_y = AxisMode::kFree;
  bottom.mass = top.mass;
  bottom.applied_force = {0.0, -top.applied_force.y};
  const double y0 = bottom.point.y, h = top.point.y - bottom.point.y;
  for (std::size_t i = 0; i < world.disks.size(); ++i)
    world.disks.velocity[i].x = -v + 2.0 * v * (world.disks.position[i].y - y0) / h;
}

struct Measurement {
  std::uint64_t steps = 0;
  double wall_s = 0.0, cpu_s = 0.0;
  cdshear::StageSeconds stages;
  double updates = 0.0;  // sum of sweeps x contacts
  double sum_sweeps = 0.0, sum_contacts = 0.0, sum_active = 0.0;
  double sum_dormant = 0.0, sum_woken = 0.0;
  std::uint64_t capped = 0, displacement_warnings = 0;
  std::uint64_t finished_plain = 0;  // went on with relaxation 1 (the cap or the residual test)
  double best_block_ns = 0.0;        // lowest ns per update over blocks of about 1/6 of the run
  double largest_overlap = 0.0;
  double observer_s = 0.0;              // time in the measurement layer (shear cases)
  std::vector<int> sweeps;              // of every measured step
  cdshear::SolverProfile profile;       // --profile: the solver's first thread, summed over steps
  std::uint64_t held_back = 0;          // steps whose residual test refused a stop at least once
  double sweeps_held_back = 0.0;        // their sweeps after the first refusal
  std::vector<double> residual_rms;     // the check's rms_carrying of every step not at the cap
  double residual_rms_capped = 0.0;     // its largest over the steps at the cap
  cdshear::RefinementTally refinement;  // the active-set refinement (--newton)
};

/// "p10 a, p50 b, p90 c, p99 d, max e" of the sweeps per step.
std::string sweep_distribution(std::vector<int> sweeps) {
  if (sweeps.empty()) return "no steps";
  std::sort(sweeps.begin(), sweeps.end());
  const auto at = [&](double q) {
    return sweeps[static_cast<std::size_t>(q * static_cast<double>(sweeps.size() - 1))];
  };
  char buf[160];
  std::snprintf(buf, sizeof buf, "p10 %d, p50 %d, p90 %d, p99 %d, max %d", at(0.1), at(0.5),
                at(0.9), at(0.99), sweeps.back());
  return buf;
}

/// The steps' velocity residual (the check; docs/step-error.md, "Per-step check") as the
/// contact-law violation over a step, e dt [d]: median and largest over the steps not at the cap,
/// largest over those at it; and the steps that the residual test held back.
void print_residual(const Measurement& m, double dt, double velocity) {
  std::vector<double> rms = m.residual_rms;
  if (rms.empty()) return;
  std::sort(rms.begin(), rms.end());
  const double median = rms[rms.size() / 2], largest = rms.back();
  char per_v[96] = "";
  if (velocity > 0.0)
    std::snprintf(per_v, sizeof per_v, " (e / V: %.2e, %.2e, %.2e)", median / velocity,
                  largest / velocity, m.residual_rms_capped / velocity);
  std::fprintf(stderr,
               "  velocity residual, e dt [d]: median %.2e, largest %.2e off the cap, largest "
               "%.2e at it%s; held back by the residual test: %.2f%% of the steps, %.2f%% of "
               "the sweeps\n",
               median * dt, largest * dt, m.residual_rms_capped * dt, per_v,
               100.0 * static_cast<double>(m.held_back) / static_cast<double>(m.steps),
               100.0 * m.sweeps_held_back / m.sum_sweeps);
}

/// --profile: the shares of the solver's stages on its first thread, and the part of the solve
/// stage they cover (the rest: the set-up before the team starts, the refinement).
void print_profile(const cdshear::SolverProfile& p, double solve_seconds) {
  const double total = p.total();
  if (!(total > 0.0)) return;
  const auto pc = [&](double x) { return 100.0 * x / total; };
  std::fprintf(stderr,
               "  solver stages, first thread: set-up %.1f%%, sweeps %.1f%%, waits at phase "
               "ends %.1f%%, convergence test %.1f%%, slab correction %.1f%%, mix %.1f%%, "
               "write-back %.1f%% (%.3f s, %.1f%% of the solve stage)\n",
               pc(p.set_up), pc(p.sweeps), pc(p.phase_waits), pc(p.convergence), pc(p.correction),
               pc(p.mix), pc(p.write_back), total,
               solve_seconds > 0.0 ? 100.0 * total / solve_seconds : 0.0);
}

/// Steps `world` untimed for `warmup` steps, then timed until both `seconds` and `min_steps`
/// are reached.
Measurement measure(World& world, ContactDynamics& dynamics, const StepOptions& options,
                    const Settings& s, cdshear::ShearMeasurement* observer = nullptr) {
  for (std::uint64_t k = 0; k < s.warmup_steps; ++k) {
    const StepReport r = dynamics.step(world, options);
    if (r.blown_up) throw std::runtime_error("warm-up blew up: " + r.problem);
  }
  Measurement m;
  const double block_seconds = s.seconds / 6.0;
  double block_solve = 0.0, block_updates = 0.0;
  auto block_start = Clock::now();
  m.best_block_ns = INFINITY;
  const std::clock_t cpu0 = std::clock();
  const auto t0 = Clock::now();
  while (true) {
    const StepReport r = dynamics.step(world, options);
    if (r.blown_up) throw std::runtime_error("step blew up: " + r.problem);
    ++m.steps;
    const double updates = static_cast<double>(r.solver.sweeps) * static_cast<double>(r.contacts);
    m.updates += updates;
    m.stages.detect += r.seconds.detect;
    m.stages.prepare += r.seconds.prepare;
    m.stages.solve += r.seconds.solve;
    m.stages.check += r.seconds.check;
    m.stages.integrate += r.seconds.integrate;
    m.stages.measure += r.seconds.measure;
    m.sum_sweeps += r.solver.sweeps;
    m.sweeps.push_back(r.solver.sweeps);
    m.sum_contacts += static_cast<double>(r.contacts);
    m.sum_active += r.solver.active_contacts;
    m.sum_dormant += static_cast<double>(r.solver.dormant_contacts);
    m.sum_woken += static_cast<double>(r.solver.woken_contacts);
    m.profile += r.solver.profile;
    m.held_back += r.solver.residual_refusals > 0;
    if (r.solver.first_refusal_sweep > 0)
      m.sweeps_held_back += r.solver.sweeps - r.solver.first_refusal_sweep;
    if (r.solver.hit_cap)
      m.residual_rms_capped = std::max(m.residual_rms_capped, r.velocity_residual.rms_carrying);
    else
      m.residual_rms.push_back(r.velocity_residual.rms_carrying);
    m.capped += r.solver.hit_cap;
    m.refinement.add(r.active_set);
    m.finished_plain += r.solver.finished_plain;
    m.displacement_warnings += r.displacement_exceeded;
    m.largest_overlap = std::max(m.largest_overlap, r.max_overlap);
    // What `cdshear run` adds to every step: the observers of model.md section 7.
    if (observer != nullptr) {
      const auto o0 = Clock::now();
      observer->after_step(world, dynamics.contacts(), r);
      m.observer_s += seconds_between(o0, Clock::now());
    }
    block_solve += r.seconds.solve;
    block_updates += updates;
    const auto now = Clock::now();
    if (seconds_between(block_start, now) >= block_seconds && block_updates > 0.0) {
      m.best_block_ns = std::min(m.best_block_ns, 1e9 * block_solve / block_updates);
      block_solve = block_updates = 0.0;
      block_start = now;
    }
    if (m.steps >= s.min_steps && seconds_between(t0, now) >= s.seconds) break;
  }
  m.wall_s = seconds_between(t0, Clock::now());
  m.cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  if (block_updates > 0.0 && !std::isfinite(m.best_block_ns))
    m.best_block_ns = 1e9 * block_solve / block_updates;
  return m;
}

const char* kHeader =
    "date,host,case,disks,width,periodic,velocity,dt,order,steps,wall_s,steps_per_s,"
    "steps_per_cpu_s,ns_per_update,ns_per_update_best,ns_per_update_cpu,mean_sweeps,"
    "mean_contacts,mean_active,capped_share,share_detect,share_prepare,share_solve,"
    "share_integrate,share_measure,detect_ns_per_disk,solid_fraction,cpu_share,load_avg,compiler,"
    "build,threads,dormant_share,woken_per_step";

/// A number with `decimals` digits after the point.
std::string num(double x, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, x);
  return buf;
}

std::string csv_line(const std::string& date, const std::string& host, const std::string& name,
                     const System& sys, double velocity, const StepOptions& options,
                     const Measurement& m, double solid_fraction, double load) {
  const double steps = static_cast<double>(m.steps);
  const double total = m.stages.total();
  auto share = [&](double x) { return num(total > 0.0 ? x / total : 0.0, 4); };
  const double ns_per_update = m.updates > 0.0 ? 1e9 * m.stages.solve / m.updates : 0.0;
  const double cpu_share = m.cpu_s / m.wall_s;
  const std::vector<std::string> fields = {
      date,
      host,
      name,
      std::to_string(sys.disks),
      num(sys.width, 1),
      "1",
      num(velocity, 3),
      num(options.dt, 4),
      cdshear::contact_order_name(options.solver.order),
      std::to_string(m.steps),
      num(m.wall_s, 3),
      num(steps / m.wall_s, 2),
      num(steps / m.cpu_s, 2),
      num(ns_per_update, 2),
      num(m.best_block_ns, 2),
      num(ns_per_update * cpu_share, 2),
      num(m.sum_sweeps / steps, 2),
      num(m.sum_contacts / steps, 1),
      num(m.sum_active / steps, 1),
      num(static_cast<double>(m.capped) / steps, 3),
      share(m.stages.detect),
      share(m.stages.prepare),
      share(m.stages.solve),
      share(m.stages.integrate),
      share(m.stages.measure),
      num(1e9 * m.stages.detect / (steps * static_cast<double>(sys.disks)), 1),
      num(solid_fraction, 4),
      num(cpu_share, 3),
      num(load, 2),
      "\"" + compiler() + "\"",
      CDSHEAR_BUILD_TYPE,
      std::to_string(options.solver.threads),
      num(m.sum_contacts > 0.0 ? m.sum_dormant / m.sum_contacts : 0.0, 3),
      num(m.sum_woken / steps, 2),
  };
  std::string line;
  for (const std::string& f : fields) line += (line.empty() ? "" : ",") + f;
  return line;
}

/// How far a step solved with `options` is from the same step solved to round-off (alpha 1e-20
/// on every force-carrying contact, no practical cap), from the same state and warm start:
/// `samples` times, `spacing` ordinary steps apart. Printed to stderr: the relative L2 error of
/// all impulses, the largest error of one contact relative to the mean impulse, the relative
/// error of the top wall's force, the disks' end-of-step velocity error (root mean square of
/// |v - v_ref| over the disks, in units of the top wall's speed V), the last sweep's relative
/// change (sqrt of the residual), the sweeps of both solves and the contacts whose status (open,
/// sticking, sliding) differs between the two solves. In a hyperstatic packing the
/// impulses of a step need not be unique while the velocities are: the velocity error is what
/// the motion feels, and `polish` (the reference's solve from the tested impulses) tells an error
/// from another solution. The reference relaxes its updates by `reference_relaxation`
/// and mixes them with Anderson depth `reference_anderson` (every 2 sweeps; 0: off) whatever
/// `options` does, without the slab correction (every relaxation, mix and correction has
/// Gauss-Seidel's fixed points, so a converged reference is the same solution where the solution
/// is unique; where it is not, a corrected solve may end on another one). A reference that stops
/// at its cap is flagged: in the 200 d tall cell most do, whatever the relaxation. Both:
/// docs/step-error.md, "Tall cells". The world goes on with `options`, or, `from_reference`, from
/// the reference's step (its positions, velocities and impulses as the next warm start): the
/// samples then measure how fast a step solved to round-off loses that accuracy, `spacing`
/// ordinary steps later. --paired: the ordinary steps use `trajectory` (the shear defaults) and
/// go on from the state before each sample, the reference is formed from `trajectory`, and only
/// the tested solve uses `options`: runs that differ in `options` test the same states.
/// --error-spectrum: where a sample's impulse error e = R - R_ref lies. A = M^-1/2 H^T maps the
/// impulses (normal and tangential) of the reference's force-carrying contacts to the bodies'
/// velocity changes, scaled so that |A R|^2 is twice the kinetic energy R gives; its singular
/// values sigma_j are the square roots of the eigenvalues of the Delassus operator W = A^T A on
/// those contacts, its null space their self-stresses (impulses that move no body). e's
/// components along the right singular vectors: the shares of |e|^2 in the null space and at
/// sigma / sigma_max in [0, 0.01), [0.01, 0.03), [0.03, 0.1), [0.1, 0.3), [0.3, 1], on the
/// contacts open in the reference; and how many of the lowest modes hold 90% of it. A
/// Gauss-Seidel sweep damps a mode the less the smaller its sigma.
void error_spectrum(const std::vector<cdshear::Contact>& a, const std::vector<cdshear::Contact>& b,
                    const std::vector<cdshear::SolverBody>& bodies) {
  std::vector<std::size_t> carrying;
  double total2 = 0.0, open2 = 0.0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    const double dn = a[i].impulse_n - b[i].impulse_n, dt = a[i].impulse_t - b[i].impulse_t;
    total2 += dn * dn + dt * dt;
    if (b[i].impulse_n > 0.0)
      carrying.push_back(i);
    else
      open2 += dn * dn + dt * dt;
  }
  if (carrying.empty() || !(total2 > 0.0)) return;
  const int m = static_cast<int>(3 * bodies.size()), n = static_cast<int>(2 * carrying.size());
  std::vector<double> A(static_cast<std::size_t>(m) * n, 0.0), e(n);  // A column-major
  const auto add = [&](std::size_t body, int col, cdshear::Vec2 force, double torque) {
    const cdshear::SolverBody& q = bodies[body];
    double* column = A.data() + static_cast<std::size_t>(col) * m + 3 * body;
    column[0] += force.x * std::sqrt(q.inv_mass.x);
    column[1] += force.y * std::sqrt(q.inv_mass.y);
    column[2] += torque * std::sqrt(q.inv_inertia);
  };
  for (std::size_t k = 0; k < carrying.size(); ++k) {
    const cdshear::Contact& c = b[carrying[k]];
    const auto ia = static_cast<std::size_t>(c.key.body_a),
               ib = static_cast<std::size_t>(c.key.body_b);
    const int col = static_cast<int>(2 * k);
    // The impulse R_n n + R_t t on body a, its opposite on b; R_t turns each by its lever
    // (u_t = t . (v_a - v_b) + lever_a omega_a + lever_b omega_b, H's rows).
    add(ia, col, c.normal, 0.0);
    add(ib, col, -c.normal, 0.0);
    add(ia, col + 1, c.tangent(), c.lever_a);
    add(ib, col + 1, -c.tangent(), c.lever_b);
    e[2 * k] = a[carrying[k]].impulse_n - c.impulse_n;
    e[2 * k + 1] = a[carrying[k]].impulse_t - c.impulse_t;
  }
  const int rank_bound = std::min(m, n);
  std::vector<double> sigma(rank_bound), vt(static_cast<std::size_t>(n) * n), superb(rank_bound);
  double unused_u = 0.0;
  if (LAPACKE_dgesvd(LAPACK_COL_MAJOR, 'N', 'A', m, n, A.data(), m, sigma.data(), &unused_u, 1,
                     vt.data(), n, superb.data()) != 0) {
    std::fprintf(stderr, "    error spectrum: the SVD did not converge\n");
    return;
  }
  const double kLimits[] = {0.01, 0.03, 0.1, 0.3};
  double share[6] = {};          // null space, then the bands of sigma / sigma_max
  std::vector<double> along(n);  // |e . v_j|^2, j by decreasing sigma
  int null_dimension = 0;
  for (int j = 0; j < n; ++j) {
    double c = 0.0;
    for (int k = 0; k < n; ++k) c += vt[static_cast<std::size_t>(k) * n + j] * e[k];
    along[j] = c * c;
    const double rel = j < rank_bound ? sigma[j] / sigma[0] : 0.0;
    int band = 0;
    if (rel >= 1e-10)
      band = 1 + static_cast<int>(std::upper_bound(std::begin(kLimits), std::end(kLimits), rel) -
                                  std::begin(kLimits));
    null_dimension += band == 0;
    share[band] += along[j];
  }
  double held = 0.0;
  int lowest = 0;
  double carrying2 = total2 - open2;
  for (int j = n - 1; j >= 0 && held < 0.9 * carrying2; --j, ++lowest) held += along[j];
  std::fprintf(stderr,
               "    error spectrum: %zu contacts, null space %d, sigma_min / sigma_max %.1e; "
               "|e|^2 shares: null %.3f, <0.01 %.3f, <0.03 %.3f, <0.1 %.3f, <0.3 %.3f, rest "
               "%.3f, open in the reference %.3f; 90%% of it in the lowest %d of %d modes\n",
               carrying.size(), null_dimension,
               rank_bound > 0 ? sigma[rank_bound - 1] / sigma[0] : 0.0, share[0] / total2,
               share[1] / total2, share[2] / total2, share[3] / total2, share[4] / total2,
               share[5] / total2, open2 / total2, lowest, n);
}

/// --dump-samples: each sample as text for offline study, FOLDER/sample_K_contacts.txt (one line
/// per contact: bodies, normal, levers, arm, gap, friction, tested and reference impulses) and
/// FOLDER/sample_K_bodies.txt (position, inverse masses and inertia, and the velocities after the
/// reference solve: v_x, v_y, omega; walls after the disks, at their points), with the periodic
/// length, the walls' heights and the time step on each file's first line.
void dump_sample(const std::string& folder, int k, const std::vector<cdshear::Contact>& a,
                 const std::vector<cdshear::Contact>& b,
                 const std::vector<cdshear::SolverBody>& bodies, const World& world, double dt) {
  std::filesystem::create_directories(folder);
  const std::string stem = folder + "/sample_" + std::to_string(k);
  const auto open = [](const std::string& path) {
    std::FILE* file = std::fopen(path.c_str(), "w");
    if (file == nullptr) throw std::runtime_error("--dump-samples: cannot write " + path);
    return file;
  };
  const auto close = [](std::FILE* file, const std::string& path) {
    const bool failed = std::ferror(file) != 0;
    if (std::fclose(file) != 0 || failed)
      throw std::runtime_error("--dump-samples: could not write all of " + path);
  };
  const double lx = world.domain.length_x;
  const double y0 = world.walls[cdshear::kBoxBottomWall].point.y;
  const double y1 = world.walls[cdshear::kBoxTopWall].point.y;
  std::FILE* f = open(stem + "_contacts.txt");
  std::fprintf(f, "# %.17g %.17g %.17g %.17g\n", lx, y0, y1, dt);
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    const cdshear::Contact& c = b[i];
    std::fprintf(
        f, "%d %d %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n",
        c.key.body_a, c.key.body_b, c.normal.x, c.normal.y, c.lever_a, c.lever_b, c.arm_a().x,
        c.arm_a().y, c.gap, c.friction, a[i].impulse_n, a[i].impulse_t, c.impulse_n, c.impulse_t);
  }
  close(f, stem + "_contacts.txt");
  f = open(stem + "_bodies.txt");
  std::fprintf(f, "# %.17g %.17g %.17g %.17g\n", lx, y0, y1, dt);
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    cdshear::Vec2 p{0.0, 0.0};
    if (i < world.disks.size())
      p = world.disks.position[i];
    else if (i - world.disks.size() < world.walls.size())
      p = world.walls[i - world.disks.size()].point;
    std::fprintf(f, "%.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", p.x, p.y,
                 bodies[i].inv_mass.x, bodies[i].inv_mass.y, bodies[i].inv_inertia,
                 bodies[i].velocity.x, bodies[i].velocity.y, bodies[i].omega);
  }
  close(f, stem + "_bodies.txt");
}

/// --error-locality: where a sample's impulse error e = R - R_ref lies. Its shares of |e|^2 on the
/// contacts open, sticking or sliding unlike the reference, and on the 1% of contacts with the
/// largest |e|; the three consecutive bands of kLocalityBand (by the height of the contact's first
/// disk) holding the largest share, and |e| / |R_ref| over those bands' contacts.
void error_locality(const std::vector<cdshear::Contact>& a, const std::vector<cdshear::Contact>& b,
                    const World& world) {
  constexpr double kLocalityBand = 4.0;  // [d], the coloured order's band height
  std::vector<double> e2, band_e2, band_r2;
  double total2 = 0.0, mismatch2 = 0.0;
  const double y0 = world.walls[cdshear::kBoxBottomWall].point.y;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    const double dn = a[i].impulse_n - b[i].impulse_n, dt = a[i].impulse_t - b[i].impulse_t;
    const double here = dn * dn + dt * dt;
    e2.push_back(here);
    total2 += here;
    if (cdshear::impulse_status(a[i]) != cdshear::impulse_status(b[i])) mismatch2 += here;
    const double y = world.disks.position[static_cast<std::size_t>(b[i].key.body_a)].y - y0;
    const auto band = static_cast<std::size_t>(std::max(0.0, y / kLocalityBand));
    if (band >= band_e2.size()) {
      band_e2.resize(band + 1, 0.0);
      band_r2.resize(band + 1, 0.0);
    }
    band_e2[band] += here;
    band_r2[band] += b[i].impulse_n * b[i].impulse_n + b[i].impulse_t * b[i].impulse_t;
  }
  if (!(total2 > 0.0)) return;
  std::sort(e2.begin(), e2.end(), std::greater<>());
  double top2 = 0.0;
  for (std::size_t i = 0; i < std::max<std::size_t>(e2.size() / 100, 1); ++i) top2 += e2[i];
  std::size_t first = 0;
  double best = -1.0;
  for (std::size_t k = 0; k < band_e2.size(); ++k) {
    double sum = 0.0;
    for (std::size_t j = k; j < std::min(k + 3, band_e2.size()); ++j) sum += band_e2[j];
    if (sum > best) {
      best = sum;
      first = k;
    }
  }
  double run_r2 = 0.0;
  const std::size_t last = std::min(first + 3, band_e2.size());
  for (std::size_t j = first; j < last; ++j) run_r2 += band_r2[j];
  std::fprintf(stderr,
               "    error locality: status differences %.3f of |e|^2, the 1%% of contacts most off "
               "%.3f; heights %.0f to %.0f d (of %.0f) %.3f, off by %.1e there\n",
               mismatch2 / total2, top2 / total2, kLocalityBand * first, kLocalityBand * last,
               kLocalityBand * band_e2.size(), best / total2,
               run_r2 > 0.0 ? std::sqrt(best / run_r2) : 0.0);
}

/// --stress-error: what a sample's impulse error does to the contact stress, the Love sum
/// S = sum over contacts of R (x) l (R = R_n n + R_t t the impulse on the first disk, l = -(lever_a
/// + lever_b) n its branch vector: centre to centre for two disks, contact point to centre against
/// a wall), which the stripe profiles spread over the grains (src/measure/shear_measurement.hpp).
/// Tallied over regions by the contact point's height above the bottom wall: the bulk (farther
/// than kBulkMargin from both walls, or than a quarter of the height in a cell under 4
/// kBulkMargin tall, such as system 1's) and bands of 4 d and of 1 d (a profile's stripe);
/// summed over the steps of a window, a time average's. A self-stress error (forces balanced on
/// every grain, none on the walls) sums to zero over any region it lies in: the soft modes'
/// impulse error reaches a region's stress only through the forces across its boundary, that is
/// through the momentum the grains beyond it gain, which later steps give back.
class StressTally {
 public:
  static constexpr double kBulkMargin = 10.0;  // [d], the boundary layers' h

  /// Adds one step: its contacts (geometry of the step's start) and the world before the step.
  void add(const std::vector<cdshear::Contact>& contacts, const World& world) {
    const double y0 = world.walls[cdshear::kBoxBottomWall].point.y;
    const double y1 = world.walls[cdshear::kBoxTopWall].point.y;
    const double margin = std::min(kBulkMargin, (y1 - y0) / 4.0);
    for (const cdshear::Contact& c : contacts) {
      const auto ia = static_cast<std::size_t>(c.key.body_a);
      const double y = world.disks.position[ia].y + c.arm_a().y - y0;
      const double length = -(c.lever_a + c.lever_b);
      const cdshear::Vec2 r = c.impulse();
      const Sums here{r.y * length * c.normal.y, r.x * length * c.normal.y};
      if (y >= margin && y1 - y0 - y >= margin) bulk_ += here;
      add_to(band4_, y / 4.0, here);
      add_to(band1_, y, here);
    }
  }

  /// Relative errors of this tally against the reference's: S_yy's, and mu = S_xy / S_yy's to
  /// first order, |dS_xy - mu_ref dS_yy| / S_yy,ref; over the bulk, and the largest over the
  /// bands of 4 d and of 1 d holding at least a tenth of the mean band's S_yy.
  void print_against(const StressTally& reference, int steps) const {
    double b4_yy = 0.0, b4_mu = 0.0, b1_yy = 0.0, b1_mu = 0.0;
    worst(band4_, reference.band4_, b4_yy, b4_mu);
    worst(band1_, reference.band1_, b1_yy, b1_mu);
    const Sums& r = reference.bulk_;
    const double d_yy = bulk_.yy - r.yy, d_xy = bulk_.xy - r.xy;
    const double mu = r.yy != 0.0 ? r.xy / r.yy : 0.0;
    std::fprintf(stderr,
                 "    stress error%s: bulk sigma_yy %+.1e, mu %+.1e (mu %.3f); largest of bands of "
                 "4 d %.1e, %.1e; of 1 d %.1e, %.1e\n",
                 steps > 1 ? (" over " + std::to_string(steps) + " steps").c_str() : "",
                 r.yy != 0.0 ? d_yy / r.yy : 0.0, r.yy != 0.0 ? (d_xy - mu * d_yy) / r.yy : 0.0,
                 std::abs(mu), b4_yy, b4_mu, b1_yy, b1_mu);
  }

 private:
  struct Sums {
    double yy = 0.0, xy = 0.0;
    Sums& operator+=(const Sums& o) {
      yy += o.yy;
      xy += o.xy;
      return *this;
    }
  };

  static void add_to(std::vector<Sums>& bands, double position, const Sums& here) {
    const auto k = static_cast<std::size_t>(std::max(0.0, position));
    if (k >= bands.size()) bands.resize(k + 1);
    bands[k] += here;
  }

  static void worst(const std::vector<Sums>& tested, const std::vector<Sums>& reference,
                    double& worst_yy, double& worst_mu) {
    double mean_yy = 0.0;
    for (const Sums& r : reference) mean_yy += std::abs(r.yy);
    mean_yy /= static_cast<double>(std::max<std::size_t>(reference.size(), 1));
    worst_yy = worst_mu = 0.0;
    for (std::size_t k = 0; k < reference.size(); ++k) {
      const Sums& r = reference[k];
      if (!(std::abs(r.yy) > 0.1 * mean_yy)) continue;
      const Sums t = k < tested.size() ? tested[k] : Sums{};
      const double d_yy = t.yy - r.yy, d_xy = t.xy - r.xy;
      worst_yy = std::max(worst_yy, std::abs(d_yy / r.yy));
      worst_mu = std::max(worst_mu, std::abs((d_xy - r.xy / r.yy * d_yy) / r.yy));
    }
  }

  Sums bulk_;
  std::vector<Sums> band4_, band1_;
};

/// |R_a - R_b| / |R_b| over both impulse components of contacts listed alike (one step's
/// candidates from one state); not a number where every impulse of b vanishes.
double relative_impulse_distance(const std::vector<cdshear::Contact>& a,
                                 const std::vector<cdshear::Contact>& b) {
  double diff2 = 0.0, ref2 = 0.0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    const double dn = a[i].impulse_n - b[i].impulse_n, dt = a[i].impulse_t - b[i].impulse_t;
    diff2 += dn * dn + dt * dt;
    ref2 += b[i].impulse_n * b[i].impulse_n + b[i].impulse_t * b[i].impulse_t;
  }
  return std::sqrt(diff2 / ref2);
}

/// |a - b| / |b| over the impulses of two contact lists sorted by key (ContactDynamics keeps
/// them so), matched by key: a contact in one list only counts with a zero impulse in the other.
/// Two solves from slightly different states may have different candidates.
double keyed_impulse_distance(const std::vector<cdshear::Contact>& a,
                              const std::vector<cdshear::Contact>& b) {
  double diff2 = 0.0, ref2 = 0.0;
  std::size_t i = 0, j = 0;
  while (i < a.size() || j < b.size()) {
    double an = 0.0, at = 0.0, bn = 0.0, bt = 0.0;
    if (j == b.size() || (i < a.size() && a[i].key < b[j].key)) {
      an = a[i].impulse_n, at = a[i].impulse_t;
      ++i;
    } else if (i == a.size() || b[j].key < a[i].key) {
      bn = b[j].impulse_n, bt = b[j].impulse_t;
      ++j;
    } else {
      an = a[i].impulse_n, at = a[i].impulse_t, bn = b[j].impulse_n, bt = b[j].impulse_t;
      ++i, ++j;
    }
    diff2 += (an - bn) * (an - bn) + (at - bt) * (at - bt);
    ref2 += bn * bn + bt * bt;
  }
  return std::sqrt(diff2 / ref2);
}

/// Every disk of `world` moved by a fixed pseudo-random displacement in [-eps, eps] along each
/// axis (splitmix64 of the disk's index and axis: the same on every machine); a periodic x
/// that would leave [0, L_x) is not moved.
void jitter_disks(World& world, double eps) {
  auto uniform = [](std::uint64_t z) {
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-53 * 2.0 - 1.0;  // [-1, 1)
  };
  for (std::size_t i = 0; i < world.disks.size(); ++i) {
    cdshear::Vec2& x = world.disks.position[i];
    const double dx = eps * uniform(2 * i), dy = eps * uniform(2 * i + 1);
    if (!world.domain.periodic_x || (x.x + dx >= 0.0 && x.x + dx < world.domain.length_x))
      x.x += dx;
    x.y += dy;
  }
}

/// A reference solve that stopped at its sweep cap and, with --reference-newton, was not brought
/// to round-off by the iterations either.
bool reference_not_converged(const StepReport& r, const StepOptions& reference) {
  return r.solver.sweeps >= reference.solver.max_sweeps && !r.active_set.converged;
}

/// |F_a - F_b| / |F_b| of the top wall's contact force after two solves of the same step.
double top_wall_distance(const World& a, const World& b) {
  const auto top = cdshear::kBoxTopWall;
  return cdshear::length(a.walls[top].contact_force - b.walls[top].contact_force) /
         cdshear::length(b.walls[top].contact_force);
}

/// RMS over the disks of |v_a - v_b| after two solves of the same step, in units of b's top wall
/// speed (absolute, length / time, in the static case, where V = 0).
double velocity_distance(const World& a, const World& b) {
  double dv2 = 0.0;
  const std::size_t n = b.disks.size();
  for (std::size_t i = 0; i < n; ++i)
    dv2 += cdshear::length_squared(a.disks.velocity[i] - b.disks.velocity[i]);
  const double wall_speed = std::abs(b.walls[cdshear::kBoxTopWall].velocity.x);
  return std::sqrt(dv2 / static_cast<double>(std::max<std::size_t>(n, 1))) /
         (wall_speed > 0.0 ? wall_speed : 1.0);
}

/// The contacts open, sticking or sliding in one list only.
std::size_t status_differences(const std::vector<cdshear::Contact>& a,
                               const std::vector<cdshear::Contact>& b) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i)
    count += cdshear::impulse_status(a[i]) != cdshear::impulse_status(b[i]) ? 1 : 0;
  return count;
}

void step_error(World& world, ContactDynamics& dynamics, const StepOptions& options,
                const StepOptions& trajectory, const Settings& s, const std::string& dump_folder) {
  const int samples = s.step_error_samples, spacing = s.step_error_spacing;
  const bool from_reference = s.from_reference;
  // --paired: the reference from the trajectory's settings too, so that it is the same solve
  // in runs that differ in `options` only.
  StepOptions tight = s.paired ? trajectory : options;
  tight.solver.alpha = 1e-20;
  tight.solver.converged_fraction = 1.0;
  tight.solver.max_sweeps = 200000;
  tight.solver.skip_dormant = false;
  tight.solver.relaxation = s.reference_relaxation;
  tight.solver.anderson_depth = s.reference_anderson;  // not the tested settings' own
  tight.solver.anderson_period = 2;
  tight.solver.slab_correction_period = 0;  // plain Gauss-Seidel's own solution
  tight.solver.newton_iterations = s.reference_newton;
  tight.solver.plain_finish = false;  // a reference at its cap is flagged as such
  // --polish with --reference-newton: the active-set iterations from the tested impulses after
  // one sweep, so that the solution it ends on is one near the tested solve.
  StepOptions polish = tight;
  if (s.reference_newton > 0) polish.solver.max_sweeps = 1;
  std::vector<double> l2, wall, velocity;
  std::vector<double> polished, between;  // --polish: tested to polished, polished to reference
  std::vector<double> jittered, jittered_wall, jittered_velocity;  // --state-jitter
  const bool sheared = world.walls[cdshear::kBoxTopWall].velocity.x != 0.0;
  std::fprintf(stderr,
               "  step error (this step's settings against a solve to round-off):\n"
               "    sweeps  ref_sweeps  last_change  impulse_l2  worst_contact/mean  top_wall"
               "  %s  status_changes  largest_e_dt  ref_largest_e_dt\n",
               sheared ? "velocity_rms/V" : "velocity_rms");
  std::vector<int> sweeps;
  for (int k = 0; k < samples; ++k) {
    for (int j = 0; j < spacing; ++j) dynamics.step(world, trajectory);
    World w_ref = world;
    ContactDynamics d_ref = dynamics;
    World w_opt = world;
    ContactDynamics d_opt = dynamics;
    const StepReport r_opt = d_opt.step(w_opt, options);
    const StepReport r_ref = d_ref.step(w_ref, tight);
    const auto& a = d_opt.contacts();
    const auto& b = d_ref.contacts();
    double ref_sum = 0.0, worst = 0.0;
    const std::size_t status_changes = status_differences(a, b);
    for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
      const double dn = a[i].impulse_n - b[i].impulse_n, dt = a[i].impulse_t - b[i].impulse_t;
      ref_sum += std::hypot(b[i].impulse_n, b[i].impulse_t);
      worst = std::max(worst, std::hypot(dn, dt));
    }
    const double mean = ref_sum / static_cast<double>(std::max<std::size_t>(b.size(), 1));
    const double wall_error = top_wall_distance(w_opt, w_ref);
    l2.push_back(relative_impulse_distance(a, b));
    wall.push_back(wall_error);
    velocity.push_back(velocity_distance(w_opt, w_ref));
    const bool ref_capped = reference_not_converged(r_ref, tight);
    if (s.error_spectrum) error_spectrum(a, b, d_ref.bodies());
    if (options.solver.newton_iterations > 0)
      std::fprintf(
          stderr,
          "    newton %d it (%d factorised, %d by GMRES), %zu unknowns, %zu changed, last %.2e, "
          "residual %.2e -> %.2e\n",
          r_opt.active_set.iterations, r_opt.active_set.factorisations,
          r_opt.active_set.krylov_solves, r_opt.active_set.unknowns, r_opt.active_set.changed,
          r_opt.active_set.correction, r_opt.active_set.initial_residual,
          r_opt.active_set.residual);
    for (std::size_t i = 0; i < r_opt.active_set.history.size(); ++i) {
      const cdshear::ActiveSetIteration& h = r_opt.active_set.history[i];
      std::fprintf(stderr,
                   "      it %2zu: changed %5zu, unknowns %6zu (open %zu, stick %zu, slide %zu), "
                   "|dR|/|R| %.1e, ratio %.2e (%zu blocking), line %.4f, regularised %d, "
                   "%s, residual %.2e\n",
                   i + 1, h.changed, h.unknowns, h.open, h.stick, h.slide, h.newton_norm,
                   h.ratio_step, h.blocking, h.line_step, h.attempt, h.by_krylov ? "GMRES" : "LU",
                   h.residual);
    }
    // The largest contact-law violation over the step, e dt [length], of each solve
    // (velocity_residual.hpp): a tested step can meet the contact law closely while its
    // impulses are far from the reference's (the error in the soft modes).
    std::fprintf(
        stderr, "    %6d  %10d  %11.2e  %10.2e  %18.2e  %8.2e  %14.2e  %14zu  %12.2e  %16.2e%s\n",
        r_opt.solver.sweeps, r_ref.solver.sweeps, std::sqrt(r_opt.solver.residual), l2.back(),
        worst / mean, wall_error, velocity.back(), status_changes,
        r_opt.velocity_residual.largest * options.dt, r_ref.velocity_residual.largest * options.dt,
        ref_capped ? "  (reference not converged: at its cap)" : "");
    sweeps.push_back(r_opt.solver.sweeps);
    if (s.error_locality) error_locality(a, b, world);
    if (!dump_folder.empty()) dump_sample(dump_folder, k, a, b, d_ref.bodies(), world, options.dt);
    if (s.stress_error) {
      StressTally tested, reference;
      tested.add(a, world);
      reference.add(b, world);
      tested.print_against(reference, 1);
      if (s.stress_window > 1) {
        // Both solves go on along their own paths for the rest of the window: a tested step's
        // error in the grains' momentum is given back in the steps after it.
        World w_t = w_opt, w_r = w_ref;
        ContactDynamics d_t = d_opt, d_r = d_ref;
        for (int j = 1; j < s.stress_window; ++j) {
          const World before_t = w_t, before_r = w_r;
          d_t.step(w_t, options);
          d_r.step(w_r, tight);
          tested.add(d_t.contacts(), before_t);
          reference.add(d_r.contacts(), before_r);
        }
        tested.print_against(reference, s.stress_window);
      }
    }
    if (s.polish) {
      // The tested solve's impulses as the warm start of a solve to round-off from the state
      // before the step. Keys renamed for disks that crossed x = 0 in the tested step
      // (follow_wrapped_disks) get their image back, so that every contact finds its impulse.
      std::vector<cdshear::Contact> start = a;
      const std::size_t n_disks = world.disks.size();
      for (cdshear::Contact& c : start) {
        const auto ia = static_cast<std::size_t>(c.key.body_a),
                   ib = static_cast<std::size_t>(c.key.body_b);
        if (ib >= n_disks) continue;
        const std::int64_t shift = (w_opt.disks.image[ib] - world.disks.image[ib]) -
                                   (w_opt.disks.image[ia] - world.disks.image[ia]);
        c.key.image_b -= static_cast<std::int32_t>(shift);
      }
      std::sort(start.begin(), start.end(),
                [](const cdshear::Contact& x, const cdshear::Contact& y) { return x.key < y.key; });
      World w_pol = world;
      ContactDynamics d_pol = dynamics;
      d_pol.set_contacts(std::move(start));
      const StepReport r_pol = d_pol.step(w_pol, polish);
      const auto& p = d_pol.contacts();
      const double to_polished = relative_impulse_distance(a, p),
                   polished_to_reference = relative_impulse_distance(p, b);
      polished.push_back(to_polished);
      between.push_back(polished_to_reference);
      char newton_residual[64] = "";
      if (s.reference_newton > 0)
        std::snprintf(newton_residual, sizeof newton_residual, ", natural-map residual %.2e",
                      r_pol.active_set.residual);
      std::fprintf(stderr,
                   "      polish: %d sweeps%s, tested to polished %.2e, polished to reference "
                   "%.2e, status changes %zu and %zu, largest e dt %.2e%s\n",
                   r_pol.solver.sweeps,
                   r_pol.solver.sweeps >= polish.solver.max_sweeps && s.reference_newton == 0
                       ? " (at its cap)"
                       : "",
                   to_polished, polished_to_reference, status_differences(a, p),
                   status_differences(p, b), r_pol.velocity_residual.largest * options.dt,
                   newton_residual);
    }
    if (s.state_jitter > 0.0) {
      // The reference's solve from the state moved by up to state_jitter: how far the step's
      // exact solution moves when the state does (its conditioning), to set beside the tested
      // solve's distance to the reference.
      World w_jit = world;
      jitter_disks(w_jit, s.state_jitter);
      ContactDynamics d_jit = dynamics;
      const StepReport r_jit = d_jit.step(w_jit, tight);
      jittered.push_back(keyed_impulse_distance(d_jit.contacts(), b));
      jittered_wall.push_back(top_wall_distance(w_jit, w_ref));
      jittered_velocity.push_back(velocity_distance(w_jit, w_ref));
      std::fprintf(stderr,
                   "      state moved by up to %.1e: reference moved by %.2e (impulses), %.2e "
                   "(top wall), %.2e (velocities%s), %d sweeps%s\n",
                   s.state_jitter, jittered.back(), jittered_wall.back(), jittered_velocity.back(),
                   sheared ? " / V" : "", r_jit.solver.sweeps,
                   reference_not_converged(r_jit, tight) ? " (at its cap)" : "");
    }
    // The step, not solved again; --paired without --from-reference: the trajectory's own
    // steps go on from the state before the sample.
    if (from_reference) {
      world = std::move(w_ref);
      dynamics = std::move(d_ref);
    } else if (!s.paired) {
      world = std::move(w_opt);
      dynamics = std::move(d_opt);
    }
  }
  std::sort(sweeps.begin(), sweeps.end());
  std::sort(polished.begin(), polished.end());
  if (!jittered.empty()) {
    std::sort(jittered.begin(), jittered.end());
    std::sort(jittered_wall.begin(), jittered_wall.end());
    std::sort(jittered_velocity.begin(), jittered_velocity.end());
    std::fprintf(stderr,
                 "    state moved by up to %.1e: the reference moved by median %.2e (largest "
                 "%.2e) in its impulses, %.2e (%.2e) in the top wall force, %.2e (%.2e) in "
                 "velocities\n",
                 s.state_jitter, jittered[jittered.size() / 2], jittered.back(),
                 jittered_wall[jittered_wall.size() / 2], jittered_wall.back(),
                 jittered_velocity[jittered_velocity.size() / 2], jittered_velocity.back());
  }
  std::sort(between.begin(), between.end());
  if (!polished.empty())
    std::fprintf(stderr,
                 "    polish: median distance to the polished solution %.2e (largest %.2e), "
                 "polished to reference %.2e (largest %.2e)\n",
                 polished[polished.size() / 2], polished.back(), between[between.size() / 2],
                 between.back());
  std::sort(l2.begin(), l2.end());
  std::sort(wall.begin(), wall.end());
  std::sort(velocity.begin(), velocity.end());
  if (!l2.empty())
    std::fprintf(stderr,
                 "    median impulse error %.2e (largest %.2e), median top-wall error "
                 "%.2e (largest %.2e), median velocity error %.2e V (largest %.2e V), "
                 "median sweeps %d\n",
                 l2[l2.size() / 2], l2.back(), wall[wall.size() / 2], wall.back(),
                 velocity[velocity.size() / 2], velocity.back(), sweeps[sweeps.size() / 2]);
}

double solid_fraction(const World& world) {
  double area = 0.0;
  for (const double r : world.disks.radius) area += std::numbers::pi * r * r;
  const double h =
      world.walls[cdshear::kBoxTopWall].point.y - world.walls[cdshear::kBoxBottomWall].point.y;
  return area / (world.domain.length_x * h);
}

/// Nanoseconds for one round trip of a cache line between two threads: each waits for the
/// counter to reach its turn and moves it on. The median of 5 runs of `hand_overs` round trips.
double core_round_trip_ns(int hand_overs) {
  std::vector<double> runs;
  for (int run = 0; run < 5; ++run) {
    alignas(64) std::atomic<int> counter{0};
    std::thread partner([&] {
      for (int i = 0; i < hand_overs; ++i) {
        while (counter.load(std::memory_order_acquire) != 2 * i + 1) {
        }
        counter.store(2 * i + 2, std::memory_order_release);
      }
    });
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < hand_overs; ++i) {
      counter.store(2 * i + 1, std::memory_order_release);
      while (counter.load(std::memory_order_acquire) != 2 * i + 2) {
      }
    }
    const auto end = std::chrono::steady_clock::now();
    partner.join();
    runs.push_back(std::chrono::duration<double, std::nano>(end - start).count() / hand_overs);
  }
  std::sort(runs.begin(), runs.end());
  return runs[runs.size() / 2];
}

int run(const Settings& s) {
  if (s.core_round_trip) {
    std::cout << "core round trip: " << std::lround(core_round_trip_ns(100000)) << " ns\n";
    return 0;
  }
  const std::string host = hostname(), date = utc_now();
  std::vector<std::string> lines;
  std::cout << kHeader << '\n' << std::flush;
#ifndef NDEBUG
  std::cerr << "warning: assertions are on (not a Release build); figures are not representative\n";
#endif
  // One pass per size, or one for the prepared packing.
  const bool prepared = !s.packing.empty() || !s.state.empty();
  const std::vector<std::size_t> sizes = prepared ? std::vector<std::size_t>{0} : s.sizes;
  for (const std::size_t size : sizes) {
    cdshear::DenseBox box;
    System sys{size, 0.0};
    double velocity = s.velocity;  // the state's own with --state
    const auto t0 = Clock::now();
    if (!s.state.empty()) {
      cdshear::Checkpoint cp = cdshear::read_checkpoint(s.state);
      box.world = std::move(cp.world);
      const auto& walls = box.world.walls;
      if (walls.size() <= cdshear::kBoxTopWall || walls[cdshear::kBoxTopWall].velocity.x == 0.0)
        throw std::invalid_argument(s.state + ": not a shear run's state (top wall at rest)");
      velocity = walls[cdshear::kBoxTopWall].velocity.x;
      box.dynamics.set_contacts(std::move(cp.contacts));
      sys = {box.world.disks.size(), box.world.domain.length_x};
      std::fprintf(stderr, "%s: %zu disks, L_x %.2f, L_y %.2f, t = %g, sheared at V = %g\n",
                   s.state.c_str(), sys.disks, sys.width,
                   walls[cdshear::kBoxTopWall].point.y - walls[cdshear::kBoxBottomWall].point.y,
                   box.world.time, velocity);
    } else if (!s.packing.empty()) {
      const cdshear::Packing packing = cdshear::read_packing(s.packing);
      cdshear::ShearCase c;
      c.velocity = s.velocity;
      box.world = cdshear::build_shear_world(c, packing);
      sys = {packing.n(), packing.length_x};
      std::fprintf(stderr, "%s: %zu disks, L_x %.2f, L_y %.2f, sheared at V = %g\n",
                   s.packing.c_str(), packing.n(), packing.length_x, packing.height, s.velocity);
    } else {
      sys = system_for(size, s.width);
      cdshear::CompressedBoxParams p;
      p.count = size;
      p.width = sys.width;
      p.periodic_x = true;
      p.initial_solid_fraction = 0.47;
      std::cerr << "preparing " << size << " disks, width " << sys.width << ", periodic x ... "
                << std::flush;
      try {
        box = cdshear::make_dense_box(p);
      } catch (const std::runtime_error& e) {
        // The quick preparation (densify_step_options: 20 sweeps a step) does not hold every
        // column (8000 disks 20 wide blew up); the study's tall cells come from `cdshear
        // prepare` (settle, then a piston), whose packings the bench reads.
        throw std::runtime_error(
            std::string(e.what()) + "\n  the bench's quick preparation of " + std::to_string(size) +
            " disks, width " + num(sys.width, 1) +
            " failed; prepare the packing with `cdshear prepare --set system.n=N --set "
            "system.height=H` (its piston then sets the width, about 0.78 N / H) and pass it "
            "with --packing");
      }
      const cdshear::DensifyReport& d = box.report;
      std::fprintf(stderr,
                   "%.1f s: %s after %llu steps, solid fraction %.3f, height %.2f, %zu contacts, "
                   "KE/disk %.2g, top wall |v_y| %.2g\n",
                   seconds_between(t0, Clock::now()), d.dense ? "dense" : "NOT dense (max_steps)",
                   static_cast<unsigned long long>(d.steps), d.solid_fraction, d.height, d.contacts,
                   d.kinetic_energy_per_disk, d.top_wall_speed);
    }

    auto report = [&](const std::string& name, double velocity, const StepOptions& options,
                      cdshear::ShearMeasurement* observer = nullptr) {
      // --paired: the ordinary steps with the shear defaults (one thread), the line theirs.
      StepOptions trajectory = options;
      if (s.paired) {
        trajectory.solver =
            one_thread(velocity > 0.0 ? shear_step_rules(velocity, {}, {}, s.dt).solver
                                      : cdshear::shear_step_defaults().solver);
        trajectory.solver.profile = options.solver.profile;
      }
      std::fprintf(stderr, "  %s%s: %llu warm-up steps, then ", name.c_str(),
                   s.paired ? " (--paired: the shear defaults' steps)" : "",
                   static_cast<unsigned long long>(s.warmup_steps));
      if (s.seconds > 0.0)
        std::fprintf(stderr, ">= %.0f s ... ", s.seconds);
      else
        std::fprintf(stderr, "%llu steps ... ", static_cast<unsigned long long>(s.min_steps));
      std::fflush(stderr);
      const double load = load_average();
      const Measurement m = measure(box.world, box.dynamics, trajectory, s, observer);
      const std::string line =
          csv_line(date, host, name, sys, velocity, trajectory, m, solid_fraction(box.world), load);
      std::fprintf(
          stderr, "%llu steps, %.1f steps/s, %.2f ns/update, %.1f sweeps, %.0f contacts%s\n",
          static_cast<unsigned long long>(m.steps), m.steps / m.wall_s,
          1e9 * m.stages.solve / m.updates, m.sum_sweeps / m.steps, m.sum_contacts / m.steps,
          m.displacement_warnings ? " (displacement bound exceeded)" : "");
      std::fprintf(stderr, "  sweeps per step: %s; capped %.1f%% (finished plain %.1f%%)\n",
                   sweep_distribution(m.sweeps).c_str(),
                   100.0 * static_cast<double>(m.capped) / static_cast<double>(m.steps),
                   100.0 * static_cast<double>(m.finished_plain) / static_cast<double>(m.steps));
      if (m.cpu_s < 0.9 * m.wall_s)
        std::fprintf(stderr,
                     "  warning: the process ran only %.0f%% of the wall time (load average "
                     "%.1f): wall-clock figures are inflated, see the *_cpu columns\n",
                     100.0 * m.cpu_s / m.wall_s, load);
      if (observer != nullptr)
        std::fprintf(
            stderr, "  measurement observers: %.2f%% of the step time (%.1f us per step)\n",
            100.0 * m.observer_s / (m.wall_s - m.observer_s), 1e6 * m.observer_s / m.steps);
      print_residual(m, options.dt, velocity);
      if (m.refinement.steps > 0)
        std::fprintf(stderr,
                     "  refinement: %llu of %llu steps to its tolerance, %.2f iterations per "
                     "step, largest residual %.2e, %llu undone (the contact-law bound)\n",
                     static_cast<unsigned long long>(m.refinement.steps_to_tolerance),
                     static_cast<unsigned long long>(m.refinement.steps),
                     m.refinement.mean_iterations(), m.refinement.largest_residual,
                     static_cast<unsigned long long>(m.refinement.steps_undone));
      if (trajectory.solver.profile) print_profile(m.profile, m.stages.solve);
      std::cout << line << '\n' << std::flush;
      lines.push_back(line);
      // --dump-samples: a folder per case, emptied first, so that no sample of another case or
      // of an earlier run is read with this one's.
      std::string dump_folder;
      if (!s.dump_samples.empty()) {
        dump_folder = s.dump_samples + "/" + name + "_n" + std::to_string(box.world.disks.size());
        std::filesystem::remove_all(dump_folder);
      }
      if (s.step_error_samples > 0)
        step_error(box.world, box.dynamics, options, trajectory, s, dump_folder);
    };

    StepOptions options;  // the defaults of a run (model.md section 3, item 5), dt = 1e-3
    options.solver = s.solver;
    if (s.run_static && !prepared) report("static", 0.0, options);
    if (s.run_shear) {
      if (!prepared) start_shear(box.world, velocity);
      const StepOptions rules = shear_step_rules(
          velocity, s.alpha_given ? std::optional(s.solver.alpha) : std::nullopt,
          s.residual_given ? std::optional(s.solver.residual_tolerance) : std::nullopt, s.dt);
      options.dt = rules.dt;
      options.solver.alpha = rules.solver.alpha;
      options.solver.residual_tolerance = rules.solver.residual_tolerance;
      const double height = box.world.walls[cdshear::kBoxTopWall].point.y -
                            box.world.walls[cdshear::kBoxBottomWall].point.y;
      cdshear::ShearMeasurement observer(cdshear::MeasureOptions{},
                                         {options.dt, velocity, 0.25, height}, box.world);
      report("shear", velocity, options, &observer);
    }
  }

  if (s.save) {
    namespace fs = std::filesystem;
    const fs::path path = s.save_path.empty()
                              ? fs::path(CDSHEAR_SOURCE_DIR) / "bench" / "results" / (host + ".csv")
                              : fs::path(s.save_path);
    if (s.save_path.empty()) fs::create_directories(path.parent_path());
    const bool fresh = !fs::exists(path) || fs::file_size(path) == 0;
    std::ofstream out(path, std::ios::app);
    if (!out) throw std::runtime_error("cannot append to " + path.string());
    if (fresh) out << kHeader << '\n';
    for (const std::string& l : lines) out << l << '\n';
    std::cerr << "appended " << lines.size() << " lines to " << path.string() << '\n';
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const UsageError& e) {
    std::cerr << "cdshear_bench: " << e.what() << " (--help lists the options)\n";
    return 2;
  } catch (const cdshear::ConfigError& e) {  // a packing or state file that cannot be used
    std::cerr << "cdshear_bench: error: " << e.what() << '\n';
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "cdshear_bench: " << e.what() << '\n';
    return 1;
  }
}

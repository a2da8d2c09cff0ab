// The run loop: steps the world until a target step, calling observers on their schedules
// ("every N steps", counted from step 0 so that a resumed run samples at the same steps), and
// printing a status line and a progress bar. Stops early, cleanly, on SIGINT/SIGTERM or on a
// blown-up step; the caller decides what to write then.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "contact_dynamics.hpp"
#include "world.hpp"

namespace cdshear {

/// A measurement or writer called after a step; it reads the state and never changes it.
class Observer {
 public:
  virtual ~Observer() = default;
  virtual void observe(const World& world, const ContactDynamics& dynamics,
                       const StepReport& report) = 0;
};

struct ScheduledObserver {
  std::uint64_t every = 1;  ///< called when world.step % every == 0
  Observer* observer = nullptr;
};

/// Where a run stands in this sitting (this call of run_until), for a progress file.
struct RunProgress {
  std::uint64_t step = 0;             ///< the step reached
  double time = 0.0;                  ///< [t] the simulated time reached
  std::uint64_t sitting_step = 0;     ///< the step this sitting started from
  double sitting_time = 0.0;          ///< [t] the time this sitting started from
  double sitting_wall_seconds = 0.0;  ///< [s] wall time of this sitting so far
  bool last = false;                  ///< the loop is returning
};

struct RunLoopSettings {
  std::uint64_t end_step = 0;      ///< run until world.step reaches this
  std::uint64_t status_every = 0;  ///< steps between status lines; 0: none
  bool progress_bar = false;       ///< redraw a bar with time left on stderr
  /// With options.solver.threads > 1: run each step on one thread or on all of them, whichever
  /// the run measures faster (thread_chooser.hpp); a line on stdout says each choice. Off: every
  /// step on options.solver.threads. The results are the same either way.
  bool choose_threads = false;
  /// Optional check of the state after every step: a non-empty answer names a problem and stops
  /// the run as blown up (for example the shear cell's walls flying apart).
  std::function<std::string(const World&)> check_state;
  /// Called with where the run stands before the first step, every `progress_seconds` of wall
  /// time, and as the loop returns; empty: never. It must not change the state.
  std::function<void(const RunProgress&)> on_progress;
  double progress_seconds = 2.0;  ///< [s] between calls of on_progress
};

enum class RunOutcome { kFinished, kInterrupted, kBlownUp };

/// What the loop saw, for the run summary.
struct RunSummary {
  RunOutcome outcome = RunOutcome::kFinished;
  StepReport last;
  std::uint64_t steps = 0;  ///< steps done by this call
  double wall_seconds = 0.0;
  std::uint64_t capped_steps = 0;  ///< steps whose solver hit the sweep cap (per interval: the
                                   ///< time series and the status lines)
  std::uint64_t plain_finish_steps = 0;     ///< steps that went on with relaxation 1 after the
                                            ///< cap or the residual test
                                            ///< (SolverReport::finished_plain)
  std::uint64_t held_back_steps = 0;        ///< steps the residual test held back at least once
                                            ///< (SolverOptions::residual_tolerance)
  std::uint64_t displacement_warnings = 0;  ///< steps above displacement_bound
  double largest_overlap = 0.0;
  double mean_sweeps = 0.0;
  int largest_sweeps = 0;
  double mean_contacts = 0.0;
  /// The steps' velocity residuals (velocity_residual.hpp) [length/time]: the mean and the
  /// largest of each step's root mean square over its force-carrying contacts, that largest over
  /// the steps that ended off the cap (at most residual_tolerance / dt), and the largest of one
  /// contact.
  double velocity_residual_rms_mean = 0.0;
  double velocity_residual_rms_largest = 0.0;
  double velocity_residual_rms_largest_off_cap = 0.0;
  double velocity_residual_largest = 0.0;
  /// The active-set refinement (SolverOptions::newton_iterations > 0; active_set_solve.hpp).
  RefinementTally refinement;
  StageSeconds seconds;  ///< summed over the steps
  /// Threads chosen by speed (thread_chooser.hpp): its trials (none when the run uses one
  /// thread or a fixed count), those of them its watch started, and the steps on all threads.
  int thread_trials = 0, thread_watch_trials = 0;
  std::uint64_t steps_on_all_threads = 0;
};

RunSummary run_until(World& world, ContactDynamics& dynamics, const StepOptions& options,
                     const RunLoopSettings& settings, std::span<const ScheduledObserver> observers);

/// The summary as JSON (for run_info.json).
nlohmann::json summary_to_json(const RunSummary& s);

/// Name of the state file a run leaves: blowup_state.json after a blow-up, final_state.json when
/// it reached its end, interrupted_state.json otherwise (signal, --stop-at).
const char* state_file_name(RunOutcome outcome, bool reached_end);

}  // namespace cdshear

#include "run_loop.hpp"

#include "thread_chooser.hpp"

#include "interval_stats.hpp"
#include "stop_signals.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>

namespace cdshear {

namespace {
std::string format_duration(double s) {
  if (s < 60) return fmt::format("{:.0f}s", s);
  if (s < 3600) return fmt::format("{:.0f}m{:02.0f}s", std::floor(s / 60), std::fmod(s, 60));
  return fmt::format("{:.0f}h{:02.0f}m", std::floor(s / 3600), std::fmod(s / 60, 60));
}

/// One line per interval: the interval's solver figures, capped steps summed (no warning per step:
/// a default run can cap thousands of steps).
void print_status_line(const World& world, const StepReport& r, const IntervalStats& interval,
                       double steps_per_second) {
  std::printf(
      "step %10llu  t %10.4f  contacts %6zu  sweeps mean %6.1f max %4d  capped %6llu/%llu  "
      "residual max %9.3g  overlap max %9.3g  Ek %11.5g  %8.1f steps/s\n",
      static_cast<unsigned long long>(world.step), world.time, r.contacts, interval.sweeps_mean(),
      interval.sweeps_max, static_cast<unsigned long long>(interval.capped_steps),
      static_cast<unsigned long long>(interval.steps), interval.residual_max, interval.overlap_max,
      kinetic_energy(world), steps_per_second);
}

/// One step's report into the run's totals (the last report, counts, largest values, seconds).
void add_step(RunSummary& summary, const StepReport& r) {
  summary.last = r;
  ++summary.steps;
  summary.largest_sweeps = std::max(summary.largest_sweeps, r.solver.sweeps);
  summary.largest_overlap = std::max(summary.largest_overlap, r.max_overlap);
  summary.velocity_residual_rms_largest =
      std::max(summary.velocity_residual_rms_largest, r.velocity_residual.rms_carrying);
  summary.velocity_residual_largest =
      std::max(summary.velocity_residual_largest, r.velocity_residual.largest);
  if (!r.solver.hit_cap)
    summary.velocity_residual_rms_largest_off_cap =
        std::max(summary.velocity_residual_rms_largest_off_cap, r.velocity_residual.rms_carrying);
  summary.seconds.detect += r.seconds.detect;
  summary.seconds.prepare += r.seconds.prepare;
  summary.seconds.solve += r.seconds.solve;
  summary.seconds.check += r.seconds.check;
  summary.seconds.integrate += r.seconds.integrate;
  summary.seconds.measure += r.seconds.measure;
  summary.capped_steps += r.solver.hit_cap ? 1 : 0;
  summary.plain_finish_steps += r.solver.finished_plain ? 1 : 0;
  summary.held_back_steps += r.solver.residual_refusals > 0 ? 1 : 0;
  summary.refinement.add(r.active_set);
}

/// The progress bar on stderr: the share `done` of the run, the time reached, and the wall time
/// left at the pace so far (`elapsed` seconds for `done`).
void print_progress_bar(double done, double time, double elapsed) {
  const int width = 30, filled = static_cast<int>(done * width);
  std::fprintf(stderr, "\r[%s%s] %5.1f%%  t %.2f  left %s ", std::string(filled, '#').c_str(),
               std::string(width - filled, '.').c_str(), 100.0 * done, time,
               format_duration(done > 0 ? elapsed * (1 - done) / done : 0.0).c_str());
  std::fflush(stderr);
}

}  // namespace

RunSummary run_until(World& world, ContactDynamics& dynamics, const StepOptions& options,
                     const RunLoopSettings& settings,
                     std::span<const ScheduledObserver> observers) {
  using Clock = std::chrono::steady_clock;
  RunSummary summary;
  const auto start = Clock::now();
  auto interval_start = start, last_bar = start;
  std::uint64_t interval_steps = 0;
  const std::uint64_t first_step = world.step;
  const std::uint64_t total = settings.end_step > first_step ? settings.end_step - first_step : 0;
  double sum_sweeps = 0.0, sum_contacts = 0.0, sum_residual_rms = 0.0;
  IntervalStats interval;  // since the last status line
  StepOptions step_options = options;
  const bool choosing = settings.choose_threads && options.solver.threads > 1;
  ThreadChooser chooser(choosing ? options.solver.threads : 1);
  auto last_progress = start;
  const double first_time = world.time;
  const auto report_progress = [&](Clock::time_point now, bool last) {
    if (!settings.on_progress) return;
    last_progress = now;
    settings.on_progress({world.step, world.time, first_step, first_time,
                          std::chrono::duration<double>(now - start).count(), last});
  };
  report_progress(start, false);

  while (world.step < settings.end_step) {
    if (g_stop_requested.load()) {
      summary.outcome = RunOutcome::kInterrupted;
      break;
    }
    if (choosing) step_options.solver.threads = chooser.threads();
    if (choosing && chooser.threads() == chooser.most()) ++summary.steps_on_all_threads;
    const auto step_start = Clock::now();
    StepReport r = dynamics.step(world, step_options);
    if (chooser.after_step(std::chrono::duration<double>(Clock::now() - step_start).count()) &&
        settings.status_every > 0) {  // quiet runs say it in run_info.json only
      const int most = chooser.most();
      if (settings.progress_bar) std::fputs("\r\033[K", stderr);
      std::printf(
          "threads: %d of %d from step %llu (measured %.3g ms per step on 1, %.3g ms on %d)\n",
          chooser.threads(), most, static_cast<unsigned long long>(world.step),
          1e3 * chooser.seconds_per_step(1), 1e3 * chooser.seconds_per_step(most), most);
      std::fflush(stdout);
    }
    if (!r.blown_up && settings.check_state)
      if (std::string problem = settings.check_state(world); !problem.empty()) {
        r.blown_up = true;
        r.problem = std::move(problem);
      }
    add_step(summary, r);
    ++interval_steps;
    sum_sweeps += r.solver.sweeps;
    sum_contacts += static_cast<double>(r.contacts);
    sum_residual_rms += r.velocity_residual.rms_carrying;
    interval.add(r);
    if (r.displacement_exceeded) {
      if (summary.displacement_warnings == 0)
        std::fprintf(stderr,
                     "warning: step %llu moved a disk by %.3g > displacement_bound %.3g; "
                     "reduce step.dt\n",
                     static_cast<unsigned long long>(r.step), r.max_displacement,
                     options.displacement_bound);
      ++summary.displacement_warnings;
    }
    for (const ScheduledObserver& o : observers)
      if (world.step % o.every == 0) o.observer->observe(world, dynamics, r);
    if (r.blown_up) {
      summary.outcome = RunOutcome::kBlownUp;
      break;
    }

    const auto now = Clock::now();
    if (settings.status_every > 0 && world.step % settings.status_every == 0) {
      const double secs = std::chrono::duration<double>(now - interval_start).count();
      if (settings.progress_bar) std::fputs("\r\033[K", stderr);
      print_status_line(world, r, interval,
                        secs > 0 ? static_cast<double>(interval_steps) / secs : 0.0);
      std::fflush(stdout);
      interval_start = now;
      interval_steps = 0;
      interval = IntervalStats{};
    }
    if (std::chrono::duration<double>(now - last_progress).count() >= settings.progress_seconds)
      report_progress(now, false);
    if (settings.progress_bar && total > 0 &&
        std::chrono::duration<double>(now - last_bar).count() > 0.25) {
      last_bar = now;
      print_progress_bar(static_cast<double>(world.step - first_step) / static_cast<double>(total),
                         world.time, std::chrono::duration<double>(now - start).count());
    }
  }
  if (settings.progress_bar) std::fputs("\r\033[K", stderr);
  const auto end = Clock::now();
  summary.wall_seconds = std::chrono::duration<double>(end - start).count();
  summary.thread_trials = chooser.trials();
  summary.thread_watch_trials = chooser.watch_trials();
  report_progress(end, true);
  if (summary.steps > 0) {
    summary.mean_sweeps = sum_sweeps / static_cast<double>(summary.steps);
    summary.mean_contacts = sum_contacts / static_cast<double>(summary.steps);
    summary.velocity_residual_rms_mean = sum_residual_rms / static_cast<double>(summary.steps);
  }
  return summary;
}

const char* state_file_name(RunOutcome outcome, bool reached_end) {
  if (outcome == RunOutcome::kBlownUp) return "blowup_state.json";
  return reached_end && outcome == RunOutcome::kFinished ? "final_state.json"
                                                         : "interrupted_state.json";
}

nlohmann::json summary_to_json(const RunSummary& s) {
  const char* outcome = s.outcome == RunOutcome::kFinished      ? "finished"
                        : s.outcome == RunOutcome::kInterrupted ? "interrupted"
                                                                : "blown_up";
  nlohmann::json j = {{"outcome", outcome},
                      {"steps", s.steps},
                      {"wall_seconds", s.wall_seconds},
                      {"steps_per_second",
                       s.wall_seconds > 0 ? static_cast<double>(s.steps) / s.wall_seconds : 0.0},
                      {"mean_sweeps", s.mean_sweeps},
                      {"largest_sweeps", s.largest_sweeps},
                      {"mean_contacts", s.mean_contacts},
                      {"capped_steps", s.capped_steps},
                      {"plain_finish_steps", s.plain_finish_steps},
                      {"held_back_steps", s.held_back_steps},
                      {"displacement_warnings", s.displacement_warnings},
                      {"largest_overlap", s.largest_overlap},
                      {"velocity_residual",
                       {{"rms_mean", s.velocity_residual_rms_mean},
                        {"rms_largest", s.velocity_residual_rms_largest},
                        {"rms_largest_off_cap", s.velocity_residual_rms_largest_off_cap},
                        {"largest", s.velocity_residual_largest}}},
                      {"stage_seconds",
                       {{"detect", s.seconds.detect},
                        {"prepare", s.seconds.prepare},
                        {"solve", s.seconds.solve},
                        {"check", s.seconds.check},
                        {"integrate", s.seconds.integrate},
                        {"measure", s.seconds.measure}}},
                      {"problem", s.last.problem}};
  if (s.thread_trials > 0)
    j["threads_chosen_by_speed"] = {{"trials", s.thread_trials},
                                    {"watch_trials", s.thread_watch_trials},
                                    {"steps_on_all_threads", s.steps_on_all_threads}};
  if (s.refinement.steps > 0)
    j["refinement"] = {{"steps", s.refinement.steps},
                       {"steps_to_tolerance", s.refinement.steps_to_tolerance},
                       {"steps_undone", s.refinement.steps_undone},
                       {"mean_iterations", s.refinement.mean_iterations()},
                       {"largest_residual", s.refinement.largest_residual}};
  return j;
}
}  // namespace cdshear

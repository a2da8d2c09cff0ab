// Child processes run at most N at once, costliest first, each with its output in a log file;
// a stop request (SIGINT/SIGTERM to this process) is forwarded to the children as SIGTERM.
// Used by `cdshear sweep`; knows nothing about runs.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace cdshear {

struct Job {
  std::string name;
  std::vector<std::string> argv;  ///< argv[0] is the program (a path: not looked up in PATH)
  std::filesystem::path log;      ///< stdout and stderr, appended
  double cost = 0.0;              ///< estimated cost, any unit: the costliest start first
};

struct JobEnd {
  std::size_t job = 0;   ///< index into the jobs given
  int exit_code = 0;     ///< the child's exit status, or 128 + signal if a signal ended it
  double seconds = 0.0;  ///< wall-clock time it ran [s]
};

struct JobProgress {
  std::size_t done = 0, running = 0, waiting = 0;
  std::vector<std::pair<std::size_t, double>> running_jobs;  ///< (job, seconds running so far)
  std::vector<std::size_t> waiting_jobs;                     ///< not started yet
};

struct ScheduleResult {
  bool interrupted = false;        ///< a stop was requested: no more jobs were started
  std::vector<JobEnd> ends;        ///< in the order they ended
  std::vector<std::size_t> never;  ///< jobs never started (after a stop)
};

/// Runs the jobs, at most `max_parallel` at once, starting the costliest first. After each job
/// ends, `on_end` is called (from this thread). Polls g_stop_requested: once it is set, no job is
/// started, SIGTERM is sent to every running child, and the call returns when they have exited.
/// `also_stop`, if given, is polled the same way: a true answer is a stop request like
/// g_stop_requested (the MPI worker passes "rank 0 asked to stop").
/// The jobs' indices, costliest first (ties in list order): the order both schedulers start them.
std::vector<std::size_t> costliest_first(const std::vector<Job>& jobs);

ScheduleResult run_jobs(const std::vector<Job>& jobs, int max_parallel,
                        const std::function<void(const JobEnd&, const JobProgress&)>& on_end,
                        const std::function<bool()>& also_stop = {});

}  // namespace cdshear

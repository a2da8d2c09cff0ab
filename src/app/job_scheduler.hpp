// Child processes run at most N at once, costliest first, each with its output in a log file;
// a stop request (SIGINT/SIGTERM to this process) is forwarded to the children as SIGTERM.
// Used by `cdshear sweep`; knows nothing about runs.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace cdshear {

struct Job {
  std::string name;
  std::vector<std::string> argv;  ///< argv[0] is the program (a path: not looked up in PATH)
  std::filesystem::path log;      ///< stdout and stderr, appended
  double cost = 0.0;              ///< estimated cost, any unit: the costliest start first
  std::string where;  ///< if set, in the log's first line (under MPI: the rank and host running it)
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

/// A job started at `start` (by a child process here, or by a worker rank under MPI).
struct StartedJob {
  std::size_t job = 0;
  std::chrono::steady_clock::time_point start;
};

/// The progress after `done` jobs ended, with `running` still going (keyed by pid or by rank)
/// and order[next...] waiting (none once interrupted).
template <class Key>
JobProgress job_progress(std::size_t done, const std::map<Key, StartedJob>& running,
                         const std::vector<std::size_t>& order, std::size_t next,
                         bool interrupted) {
  JobProgress p{done, running.size(), interrupted ? 0 : order.size() - next, {}, {}};
  const auto now = std::chrono::steady_clock::now();
  for (const auto& [key, r] : running)
    p.running_jobs.emplace_back(r.job, std::chrono::duration<double>(now - r.start).count());
  if (!interrupted)
    p.waiting_jobs.assign(order.begin() + static_cast<std::ptrdiff_t>(next), order.end());
  return p;
}

/// Called by a scheduler after each job ends, from its own thread.
using JobEndCallback = std::function<void(const JobEnd&, const JobProgress&)>;

/// A periodic call from a scheduler's loop (the sweep's progress line): `call` with the progress,
/// every `every` seconds from the loop's start; none if `every` <= 0 or `call` is empty, and none
/// once a stop was requested.
struct JobTick {
  double every = 0.0;  ///< [s]
  std::function<void(const JobProgress&)> call;
};

/// Polled by both scheduler loops (run_jobs, and rank 0's under MPI) on each pass: calls the
/// JobTick when it is due. Its timing lives here once.
class JobTicker {
 public:
  explicit JobTicker(const JobTick& tick);
  template <class Key>
  void poll(std::size_t done, const std::map<Key, StartedJob>& running,
            const std::vector<std::size_t>& order, std::size_t next, bool interrupted) {
    if (!active_ || interrupted) return;
    const auto now = std::chrono::steady_clock::now();
    if (now < due_) return;
    due_ = now + period_;
    tick_.call(job_progress(done, running, order, next, interrupted));
  }

 private:
  JobTick tick_;  // a copy: the ticker must not outlive a caller's temporary
  bool active_ = false;
  std::chrono::steady_clock::duration period_{};
  std::chrono::steady_clock::time_point due_;
};

struct ScheduleResult {
  bool interrupted = false;        ///< a stop was requested: no more jobs were started
  std::vector<JobEnd> ends;        ///< in the order they ended
  std::vector<std::size_t> never;  ///< jobs never started (after a stop)
};

/// Runs the jobs, at most `max_parallel` at once, starting the costliest first. After each job
/// ends, `on_end` is called (from this thread); `tick`, if set, every tick.every seconds. Polls
/// g_stop_requested: once it is set, no job is started, SIGTERM is sent to every running child,
/// and the call returns when they have exited. `also_stop`, if given, is polled the same way: a
/// true answer is a stop request like g_stop_requested (the MPI worker passes "rank 0 asked to
/// stop"). A job that cannot start (its log cannot be opened, fork refused) ends at once with exit
/// code 1, its reason on stderr; the others go on.
ScheduleResult run_jobs(const std::vector<Job>& jobs, int max_parallel,
                        const JobEndCallback& on_end, const std::function<bool()>& also_stop = {},
                        const JobTick& tick = {});

/// ::open(path, flags | O_NONBLOCK, 0644) of a file that must be a regular one: a FIFO in its
/// place fails at once (ENXIO without a reader) instead of waiting for one, and anything but a
/// regular file is refused as ConfigError(path, "is not a regular file (a FIFO or a device in
/// <role>'s place): remove it"). Other failures return -1 with errno set, for the caller to
/// report. Writes and locks on a regular file behave as without O_NONBLOCK.
int open_regular_file(const std::filesystem::path& path, int flags, const std::string& role);

/// Refuses, as open_regular_file would, a path where something other than a regular file stands
/// (a folder, a FIFO, a device); an absent path, or one that cannot be looked at, passes. For
/// checks made before any job starts, without creating the file.
void check_regular_file_if_present(const std::filesystem::path& path, const std::string& role);

/// `word` as a POSIX shell reads it back: unchanged if it holds only letters, digits and
/// `_@%+=:,./-`, else in single quotes (a quote inside written '\'').
std::string shell_quoted(const std::string& word);

/// Starts one job as a child process of this one, as run_jobs does (rank 0 of an MPI sweep keeps
/// one of its own beside its workers): the command line (and `where`) appended to the log as its
/// first line, each word shell_quoted so that it can be pasted into a shell, then the job's
/// output. Returns its pid. Throws std::runtime_error if the log cannot
/// be opened or fork fails (exec failures show in the log and as exit status 127).
pid_t start_job(const Job& job);

/// start_job, or nothing when the job cannot start (its log cannot be opened, fork refused): its
/// reason goes to stderr as "cdshear sweep<who>: <name>: <reason>", and the job fails alone
/// (its scheduler counts it ended with exit code 1; the other jobs go on).
std::optional<pid_t> start_job_or_report(const Job& job, const std::string& who);

/// The exit code of the child `pid` started by start_job (128 + signal if a signal ended it) if
/// it has ended, which reaps it; nothing while it runs. Does not wait.
std::optional<int> job_exit_code(pid_t pid);

/// Sends SIGTERM to every child in `pids` (started by start_job), then waits until each has
/// exited (and reaps it): their runs write their checkpoint and stop together. For a failure of
/// the sweep itself, when no run may go on unwatched.
void stop_and_wait(const std::vector<pid_t>& pids);

/// The jobs' indices, costliest first (ties in list order): the order both schedulers start them.
std::vector<std::size_t> costliest_first(const std::vector<Job>& jobs);

}  // namespace cdshear

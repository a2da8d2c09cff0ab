// run_jobs: fork + exec, output to append-only log files, waitpid polling (a signal handler that
// only sets a flag cannot interrupt a blocking wait reliably, so the loop polls every 50 ms).
#include "job_scheduler.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <numeric>
#include <stdexcept>
#include <thread>

#include "config_error.hpp"
#include "stop_signals.hpp"

namespace cdshear {
namespace {

using Clock = std::chrono::steady_clock;

int exit_code_of(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

}  // namespace

namespace {

[[noreturn]] void refuse_not_a_file(const std::filesystem::path& path, const std::string& role) {
  throw ConfigError(
      path.string(), "",
      "is not a regular file (a FIFO or a device in " + role + "'s place): remove it");
}

[[noreturn]] void refuse_folder(const std::filesystem::path& path, const std::string& role) {
  throw ConfigError(path.string(), "", "is a folder in " + role + "'s place: remove it");
}

}  // namespace

int open_regular_file(const std::filesystem::path& path, int flags, const std::string& role) {
  const int fd = ::open(path.c_str(), flags | O_NONBLOCK, 0644);
  if (fd < 0 && errno == ENXIO) refuse_not_a_file(path, role);
  if (fd < 0 && errno == EISDIR) refuse_folder(path, role);
  if (fd < 0) return -1;
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    refuse_not_a_file(path, role);
  }
  return fd;
}

void check_regular_file_if_present(const std::filesystem::path& path, const std::string& role) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return;
  if (S_ISDIR(st.st_mode)) refuse_folder(path, role);
  if (!S_ISREG(st.st_mode)) refuse_not_a_file(path, role);
}

std::string shell_quoted(const std::string& word) {
  const bool plain = !word.empty() && word.find_first_not_of(
                                          "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                          "0123456789_@%+=:,./-") == std::string::npos;
  if (plain) return word;
  std::string quoted = "'";
  for (const char ch : word) quoted += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return quoted + "'";
}

pid_t start_job(const Job& job) {
  std::filesystem::create_directories(job.log.parent_path());
  const int fd =
      open_regular_file(job.log, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, "a run's log");
  if (fd < 0)
    throw std::runtime_error("cannot open log file " + job.log.string() + ": " +
                             std::strerror(errno));
  std::string header = "==== cdshear sweep starts";
  if (!job.where.empty()) header += " (" + job.where + ")";
  header += ":";
  for (const std::string& a : job.argv) header += " " + shell_quoted(a);
  header += "\n";
  if (::write(fd, header.data(), header.size()) < 0) { /* the log is best effort */
  }
  std::vector<char*> argv;
  for (const std::string& a : job.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t parent = ::getpid();
  // The child has the stop signals' default actions until the run installs its own handlers: a
  // stop sent to it before then ends it, before the run starts.
  const pid_t pid = fork_with_default_stops();
  if (pid < 0) {
    ::close(fd);
    throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  }
  if (pid == 0) {  // child: only async-signal-safe calls until exec
    // A sweep that dies without forwarding a stop (SIGKILL, out of memory) stops its runs too:
    // each writes its checkpoint on the SIGTERM, and a rerun resumes it.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(128 + SIGTERM);  // the sweep died before the prctl
    const int null = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    if (null >= 0) ::dup2(null, STDIN_FILENO);
    ::dup2(fd, STDOUT_FILENO);
    ::dup2(fd, STDERR_FILENO);
    // The binary this sweep runs, even if the file at argv[0] was rebuilt meanwhile (a resume
    // must continue with the program that wrote the checkpoint).
    ::execv("/proc/self/exe", argv.data());
    const char msg[] = "cdshear sweep: exec failed\n";
    if (::write(STDERR_FILENO, msg, sizeof msg - 1) < 0) {
    }
    ::_exit(127);
  }
  ::close(fd);
  return pid;
}

std::optional<pid_t> start_job_or_report(const Job& job, const std::string& who) {
  try {
    return start_job(job);
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "cdshear sweep%s: %s: %s\n", who.c_str(), job.name.c_str(), e.what());
    return std::nullopt;
  }
}

std::optional<int> job_exit_code(pid_t pid) {
  int status = 0;
  const pid_t ended = ::waitpid(pid, &status, WNOHANG);
  if (ended == 0 || (ended < 0 && errno == EINTR)) return std::nullopt;
  // -1: not (or no longer) a child of this process, which start_job's caller does not let
  // happen; an exit code rather than "still running" so that nobody waits for it forever.
  return ended == pid ? exit_code_of(status) : 1;
}

void stop_and_wait(const std::vector<pid_t>& pids) {
  for (const pid_t pid : pids) ::kill(pid, SIGTERM);
  for (const pid_t pid : pids) {
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
  }
}

std::vector<std::size_t> costliest_first(const std::vector<Job>& jobs) {
  std::vector<std::size_t> order(jobs.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return jobs[a].cost > jobs[b].cost; });
  return order;
}

JobTicker::JobTicker(const JobTick& tick)
    : tick_(tick), active_(tick.every > 0 && static_cast<bool>(tick.call)) {
  // At most a year: a longer period is "never", and would overflow the clock's duration.
  const double every = std::min(tick.every, 365.0 * 86400.0);
  if (active_)
    period_ = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(every));
  due_ = Clock::now() + period_;
}

ScheduleResult run_jobs(const std::vector<Job>& jobs, int max_parallel,
                        const JobEndCallback& on_end, const std::function<bool()>& also_stop,
                        const JobTick& tick) {
  const std::vector<std::size_t> order = costliest_first(jobs);
  std::map<pid_t, StartedJob> running;
  JobTicker ticker(tick);
  ScheduleResult result;
  std::size_t next = 0;
  bool forwarded = false;
  const std::size_t limit = static_cast<std::size_t>(std::max(1, max_parallel));
  try {
    while (next < order.size() || !running.empty()) {
      if (!result.interrupted && (g_stop_requested.load() || (also_stop && also_stop())))
        result.interrupted = true;
      if (result.interrupted) {
        if (!forwarded) {
          for (const auto& [pid, r] : running) ::kill(pid, SIGTERM);
          forwarded = true;
        }
      }
      while (!result.interrupted && next < order.size() && running.size() < limit) {
        const std::size_t j = order[next++];
        const std::optional<pid_t> pid =
            start_job_or_report(jobs[j], jobs[j].where.empty() ? "" : " (" + jobs[j].where + ")");
        if (!pid) {  // it fails alone; the runs going on are not stopped
          result.ends.push_back({j, 1, 0.0});
          if (on_end)
            on_end(result.ends.back(),
                   job_progress(result.ends.size(), running, order, next, result.interrupted));
          continue;
        }
        running[*pid] = {j, Clock::now()};
      }
      if (running.empty()) break;
      ticker.poll(result.ends.size(), running, order, next, result.interrupted);
      int status = 0;
      const pid_t pid = ::waitpid(-1, &status, WNOHANG);
      if (pid > 0) {
        const auto it = running.find(pid);
        if (it == running.end()) continue;  // not one of ours
        JobEnd end;
        end.job = it->second.job;
        end.exit_code = exit_code_of(status);
        end.seconds = std::chrono::duration<double>(Clock::now() - it->second.start).count();
        running.erase(it);
        result.ends.push_back(end);
        if (on_end)
          on_end(end, job_progress(result.ends.size(), running, order, next, result.interrupted));
        continue;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  } catch (...) {
    // A failure of the sweep itself (a callback): no run may go on unwatched, or a rerun would
    // resume a folder that is still being written.
    std::vector<pid_t> pids;
    for (const auto& [pid, r] : running) pids.push_back(pid);
    stop_and_wait(pids);
    throw;
  }
  for (; next < order.size(); ++next) result.never.push_back(order[next]);
  return result;
}

}  // namespace cdshear

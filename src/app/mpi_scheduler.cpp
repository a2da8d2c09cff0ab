// MPI scheduler of `cdshear sweep` (built only with CDSHEAR_WITH_MPI). Rank 0 runs the sweep as
// without MPI (campaign, folder lock, packings, resume rules, progress, summary, exit code) and
// hands each job, costliest first, to the next free rank, itself included: every rank 0..N-1
// runs one job at a time as a child process (same logs, same SIGTERM forwarding, same
// checkpoint on stop). A worker (rank 1..N-1) runs the job it is sent through run_jobs and
// reports its exit code; rank 0 starts its own with start_job and looks whether it ended
// between two polls of the message queue, so that it still coordinates while its run runs.
// Nothing is shared but the campaign folder, which must be on a file system every node sees
// under the same path.
// Locking: only rank 0 holds DIR/.sweep.lock (and its own runs inherit it); the workers' runs
// do not, so a sweep that dies leaves them to the kernel's PR_SET_PDEATHSIG SIGTERM.
// A stop request (SIGINT/SIGTERM/SIGHUP) on any rank stops the whole sweep: a worker tells rank
// 0, rank 0 tells every busy worker and sends SIGTERM to its own run, each run checkpoints, rank
// 0 waits for them all and exits 130. A job that a rank cannot start (its log cannot be opened,
// fork refused) fails that job only, on rank 0 as on a worker: the error is printed, the job is
// reported as ended with exit code 1, and the sweep goes on (unlike a sweep without MPI, where
// run_jobs throws and the sweep fails).
#include "mpi_scheduler.hpp"

#include <mpi.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "config_error.hpp"
#include "stop_signals.hpp"

namespace cdshear {
namespace {

using Clock = std::chrono::steady_clock;

enum Tag : int {
  kJob = 1,      // 0 -> worker: a job, as NUL-separated strings (name, log, argv...)
  kResult = 2,   // worker -> 0: double[3] {exit code, seconds, 1 if never started}
  kStop = 3,     // 0 -> worker: stop the running job (SIGTERM to it)
  kQuit = 4,     // 0 -> worker: int exit code of the sweep; the worker returns it
  kStopped = 5,  // worker -> 0: a stop was requested on this worker (a signal)
};

/// Between two polls of the message queue (not POSIX pause(): nothing signals a message).
void idle_wait() {
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
}

std::string encode(const Job& j) {
  std::string s = j.name + '\0' + j.log.string() + '\0';
  for (const std::string& a : j.argv) s += a + '\0';
  return s;
}

Job decode(const std::string& s) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s[i] == '\0') {
      parts.push_back(s.substr(start, i - start));
      start = i + 1;
    }
  Job j;
  if (parts.size() >= 2) {
    j.name = parts[0];
    j.log = parts[1];
    j.argv.assign(parts.begin() + 2, parts.end());
  }
  return j;
}

/// "MPI rank R on HOST", in the first line of the log of each job that rank runs.
std::string rank_and_host(int rank) {
  char host[256] = {};
  if (::gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  return "MPI rank " + std::to_string(rank) + " on " + (host[0] != '\0' ? host : "?");
}

/// Rank 0: the jobs to the ranks, costliest first, as they free up. Rank 0 is one of them: its
/// job is its own child process, which it watches between two polls of the message queue.
ScheduleResult schedule_on_ranks(const std::vector<Job>& jobs, int size,
                                 const JobEndCallback& on_end, const JobTick& tick) {
  const std::vector<std::size_t> order = costliest_first(jobs);
  std::vector<int> idle;  // taken from the back: rank 0, 1, 2... at the start
  for (int r = size - 1; r >= 0; --r) idle.push_back(r);
  std::map<int, StartedJob> busy;  // by rank
  pid_t local = -1;                // rank 0's own run, while busy holds rank 0
  const std::string here = rank_and_host(0);
  ScheduleResult result;
  std::size_t next = 0;
  JobTicker ticker(tick);
  // The job of `rank` ended (or was never started: its worker was stopped first).
  const auto ended = [&](int rank, int exit_code, double seconds, bool started) {
    const auto it = busy.find(rank);
    const std::size_t job = it->second.job;
    busy.erase(it);
    idle.push_back(rank);
    if (!started) {
      result.never.push_back(job);
      return;
    }
    JobEnd end{job, exit_code, seconds};
    result.ends.push_back(end);
    if (on_end)
      on_end(end, job_progress(result.ends.size(), busy, order, next, result.interrupted));
  };
  try {
    while (true) {
      if (!result.interrupted && g_stop_requested.load()) {
        result.interrupted = true;
        for (const auto& [rank, b] : busy)
          if (rank != 0) MPI_Send(nullptr, 0, MPI_CHAR, rank, kStop, MPI_COMM_WORLD);
        // As run_jobs does: the run writes its checkpoint and exits; it is waited for below.
        if (local > 0) ::kill(local, SIGTERM);
      }
      while (!result.interrupted && next < order.size() && !idle.empty()) {
        const int rank = idle.back();
        const std::size_t j = order[next];
        bool not_started = false;
        if (rank == 0) {
          Job job = jobs[j];
          job.where = here;
          // As on a worker (serve): a job that cannot start fails with exit code 1, the sweep
          // goes on.
          const std::optional<pid_t> pid = start_job_or_report(job, ", MPI rank 0");
          local = pid.value_or(-1);
          not_started = !pid;
        } else {
          const std::string msg = encode(jobs[j]);
          MPI_Send(msg.data(), static_cast<int>(msg.size()), MPI_CHAR, rank, kJob, MPI_COMM_WORLD);
        }
        idle.pop_back();
        ++next;
        busy[rank] = {j, Clock::now()};
        if (not_started) ended(0, 1, 0.0, true);  // the result a worker sends in that case
      }
      if (busy.empty()) break;
      ticker.poll(result.ends.size(), busy, order, next, result.interrupted);
      if (local > 0) {
        if (const std::optional<int> code = job_exit_code(local)) {
          local = -1;
          ended(0, *code, std::chrono::duration<double>(Clock::now() - busy.at(0).start).count(),
                true);
          continue;
        }
      }
      int flag = 0;
      MPI_Status st;
      MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
      if (!flag) {
        idle_wait();
        continue;
      }
      if (st.MPI_TAG == kStopped) {
        MPI_Recv(nullptr, 0, MPI_CHAR, st.MPI_SOURCE, kStopped, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        g_stop_requested.store(true);  // a signal on any rank stops the sweep
        continue;
      }
      double msg[3] = {1, 0, 0};
      MPI_Recv(msg, 3, MPI_DOUBLE, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      if (st.MPI_TAG != kResult || !busy.contains(st.MPI_SOURCE)) continue;
      // msg[2] != 0: the worker was stopped before it could start the job.
      ended(st.MPI_SOURCE, static_cast<int>(msg[0]), msg[1], msg[2] == 0);
    }
  } catch (...) {
    // The sweep fails (a callback throws): its own run may not go on unwatched, as in run_jobs.
    // The busy workers are told to stop first, so that every run writes its checkpoint at the
    // same time; run_sweep_under_mpi then releases the workers.
    for (const auto& [rank, b] : busy)
      if (rank != 0) MPI_Send(nullptr, 0, MPI_CHAR, rank, kStop, MPI_COMM_WORLD);
    if (local > 0) stop_and_wait({local});
    throw;
  }
  for (; next < order.size(); ++next) result.never.push_back(order[next]);
  return result;
}

/// Rank 0: every worker stops what it runs (if anything) and returns `code`.
void release_workers(int size, int code) {
  // Rank 0's summary is out before any rank can end the job (mpirun kills the others when one
  // exits non-zero).
  std::fflush(stdout);
  std::fflush(stderr);
  for (int r = 1; r < size; ++r) {
    MPI_Send(nullptr, 0, MPI_CHAR, r, kStop, MPI_COMM_WORLD);
    MPI_Send(&code, 1, MPI_INT, r, kQuit, MPI_COMM_WORLD);
  }
}

/// A worker: runs what rank 0 hands it until told to quit.
int serve(int rank) {
  bool told = false;
  while (true) {
    if (g_stop_requested.load() && !told) {
      MPI_Send(nullptr, 0, MPI_CHAR, 0, kStopped, MPI_COMM_WORLD);
      told = true;
    }
    int flag = 0;
    MPI_Status st;
    MPI_Iprobe(0, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
    if (!flag) {
      idle_wait();
      continue;
    }
    if (st.MPI_TAG == kQuit) {
      int code = 1;
      MPI_Recv(&code, 1, MPI_INT, 0, kQuit, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      return code;
    }
    if (st.MPI_TAG != kJob) {  // a stop with nothing running
      MPI_Recv(nullptr, 0, MPI_CHAR, 0, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      continue;
    }
    int count = 0;
    MPI_Get_count(&st, MPI_CHAR, &count);
    std::string text(static_cast<std::size_t>(count), '\0');
    MPI_Recv(text.data(), count, MPI_CHAR, 0, kJob, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    Job job = decode(text);
    job.where = rank_and_host(rank);
    bool stop_from_0 = false;
    const auto asked_to_stop = [&] {
      int pending = 0;
      MPI_Iprobe(0, kStop, MPI_COMM_WORLD, &pending, MPI_STATUS_IGNORE);
      if (pending) {
        MPI_Recv(nullptr, 0, MPI_CHAR, 0, kStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        stop_from_0 = true;
      }
      return stop_from_0;
    };
    double msg[3] = {1, 0, 0};
    try {
      const ScheduleResult r = run_jobs({job}, 1, nullptr, asked_to_stop);
      if (r.ends.empty()) {
        msg[2] = 1;
      } else {
        msg[0] = r.ends.front().exit_code;
        msg[1] = r.ends.front().seconds;
      }
    } catch (const std::exception& e) {  // run_jobs itself failed (not a job that cannot start)
      std::fprintf(stderr, "cdshear sweep, MPI rank %d: %s: %s\n", rank, job.name.c_str(),
                   e.what());
    }
    // A stop that came during the run is told before its result: messages from one rank
    // arrive in order, so rank 0 knows the sweep was interrupted even if this was its last run.
    if (g_stop_requested.load() && !told) {
      MPI_Send(nullptr, 0, MPI_CHAR, 0, kStopped, MPI_COMM_WORLD);
      told = true;
    }
    MPI_Send(msg, 3, MPI_DOUBLE, 0, kResult, MPI_COMM_WORLD);
  }
}

struct MpiSession {
  MpiSession() {
    MPI_Init(nullptr, nullptr);
    install_stop_handlers();  // in case the MPI library installed its own
  }
  ~MpiSession() { MPI_Finalize(); }
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

}  // namespace

bool mpi_launch_detected() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}) {
    const char* v = std::getenv(var);
    if (v != nullptr && std::atoi(v) > 1) return true;
  }
  // srun with PMIx sets no size variable of its own.
  const char* ntasks = std::getenv("SLURM_NTASKS");
  return std::getenv("PMIX_RANK") != nullptr && ntasks != nullptr && std::atoi(ntasks) > 1;
}

int run_sweep_under_mpi(const std::function<int(const RemoteScheduler*, int ranks)>& sweep) {
  MpiSession session;
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size < 2) return sweep(nullptr, 0);
  if (rank != 0) return serve(rank);
  const RemoteScheduler scheduler = [size](const std::vector<Job>& jobs,
                                           const JobEndCallback& on_end, const JobTick& tick) {
    return schedule_on_ranks(jobs, size, on_end, tick);
  };
  int code = 1;
  try {
    code = sweep(&scheduler, size);
  } catch (const ConfigError&) {
    release_workers(size, 2);
    throw;
  } catch (...) {
    release_workers(size, 1);
    throw;
  }
  release_workers(size, code);
  return code;
}

}  // namespace cdshear

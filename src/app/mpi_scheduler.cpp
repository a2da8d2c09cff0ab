// MPI scheduler of `cdshear sweep` (built only with CDSHEAR_WITH_MPI). Rank 0 runs the sweep as
// without MPI (campaign, folder lock, packings, resume rules, progress, summary, exit code) but
// hands each job, costliest first, to the next free worker rank (1..N-1); rank 0 itself runs no
// job. A worker runs one job at a time as a child process through run_jobs (same logs, same
// SIGTERM forwarding, same checkpoint on stop) and reports its exit code. Nothing is shared but
// the campaign folder, which must be on a file system every node sees under the same path.
// Locking: only rank 0 holds DIR/.sweep.lock (and its own children inherit it); the workers'
// runs do not, so a sweep that dies leaves them to the kernel's PR_SET_PDEATHSIG SIGTERM.
// A stop request (SIGINT/SIGTERM/SIGHUP) on any rank stops the whole sweep: a worker tells rank
// 0, rank 0 tells every busy worker, each forwards SIGTERM to its run, and rank 0 exits 130.
#include "mpi_scheduler.hpp"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <numeric>
#include <string>
#include <thread>

#include "config_error.hpp"
#include "run_loop.hpp"

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

/// Rank 0: the jobs to the workers, costliest first, as they free up.
ScheduleResult schedule_on_workers(const std::vector<Job>& jobs, int size,
                                   const JobEndCallback& on_end) {
  const std::vector<std::size_t> order = costliest_first(jobs);
  std::vector<int> idle;
  for (int r = size - 1; r >= 1; --r) idle.push_back(r);
  std::map<int, StartedJob> busy;
  ScheduleResult result;
  std::size_t next = 0;
  while (true) {
    if (!result.interrupted && g_stop_requested.load()) {
      result.interrupted = true;
      for (const auto& [rank, b] : busy)
        MPI_Send(nullptr, 0, MPI_CHAR, rank, kStop, MPI_COMM_WORLD);
    }
    while (!result.interrupted && next < order.size() && !idle.empty()) {
      const int rank = idle.back();
      idle.pop_back();
      const std::size_t j = order[next++];
      const std::string msg = encode(jobs[j]);
      MPI_Send(msg.data(), static_cast<int>(msg.size()), MPI_CHAR, rank, kJob, MPI_COMM_WORLD);
      busy[rank] = {j, Clock::now()};
    }
    if (busy.empty()) break;
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
    const auto it = busy.find(st.MPI_SOURCE);
    if (st.MPI_TAG != kResult || it == busy.end()) continue;
    const std::size_t job = it->second.job;
    busy.erase(it);
    idle.push_back(st.MPI_SOURCE);
    if (msg[2] != 0) {  // the worker was stopped before it could start it
      result.never.push_back(job);
      continue;
    }
    JobEnd end{job, static_cast<int>(msg[0]), msg[1]};
    result.ends.push_back(end);
    if (on_end)
      on_end(end, job_progress(result.ends.size(), busy, order, next, result.interrupted));
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
    const Job job = decode(text);
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
    } catch (const std::exception& e) {  // a log that cannot be opened, fork refused
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

int run_sweep_under_mpi(const std::function<int(const RemoteScheduler*, int workers)>& sweep) {
  MpiSession session;
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size < 2) return sweep(nullptr, 0);
  if (rank != 0) return serve(rank);
  const RemoteScheduler scheduler = [size](const std::vector<Job>& jobs,
                                           const JobEndCallback& on_end) {
    return schedule_on_workers(jobs, size, on_end);
  };
  int code = 1;
  try {
    code = sweep(&scheduler, size - 1);
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

// `cdshear sweep CAMPAIGN.toml`: every run of a campaign (docs/campaigns.md) as a child process
// of this executable (`prepare` once per system and seed, then `run` or `run --resume`), several
// at once, resumable, with one log per run and a progress line after each.
#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <thread>

#include "campaign_file.hpp"
#include "commands.hpp"
#include "config_error.hpp"
#include "job_scheduler.hpp"
#include "mpi_scheduler.hpp"
#include "outputs.hpp"
#include "run_loop.hpp"
#include "run_session.hpp"
#include "toml_reader.hpp"

namespace cdshear {
namespace {

namespace fs = std::filesystem;

struct SweepArgs {
  std::string file;
  std::string out_dir;
  int jobs = 0;     ///< 0: processors / threads
  int threads = 1;  ///< solver threads of each run
  bool quiet = false;
  bool force = false;
};

/// What a run folder holds, from its files (docs/campaigns.md, "Resume rules").
enum class RunState { kNew, kFinished, kInterrupted, kBlownUp };

const char* state_name(RunState s) {
  switch (s) {
    case RunState::kNew:
      return "not started";
    case RunState::kFinished:
      return "finished";
    case RunState::kInterrupted:
      return "interrupted";
    case RunState::kBlownUp:
      return "blown up";
  }
  return "?";
}

/// Finished: final_state.json (written only when the run reached its duration), whether or not
/// a run_info*.json says "finished" too: a run killed between writing the two has every step
/// done, and resuming it would be refused (it reached its end), so it counts as finished.
/// Blown up: blowup_state.json (a resume would repeat the same steps). Interrupted: a
/// checkpoint to resume from. Otherwise new.
RunState run_state(const fs::path& dir) {
  if (!fs::is_directory(dir)) return RunState::kNew;
  if (fs::exists(dir / "final_state.json")) return RunState::kFinished;
  if (fs::exists(dir / "blowup_state.json")) return RunState::kBlownUp;
  if (fs::exists(dir / "checkpoint.cbor")) return RunState::kInterrupted;
  return RunState::kNew;
}

std::string format_seconds(double s) {
  if (s < 60) return fmt::format("{:.0f} s", s);
  if (s < 3600) return fmt::format("{:.0f} min", s / 60);
  return fmt::format("{:.1f} h", s / 3600);
}

/// Refuses a campaign that differs from the one DIR was made for, unless --force.
void check_same_campaign(const fs::path& file, const Campaign& c, bool force) {
  if (!fs::exists(file)) return;
  const toml::table before = parse_toml_file(file.string());
  const std::vector<std::string> diff = campaign_differences(before, campaign_to_toml(c));
  if (diff.empty()) return;
  const std::string list = fmt::format("{}", fmt::join(diff, "; "));
  if (!force)
    throw ConfigError(file.string(), "",
                      fmt::format("this folder holds another campaign ({}); choose another -o, "
                                  "or pass --force to go on with the new campaign (runs already "
                                  "there are kept and reused by name)",
                                  list));
  std::fprintf(stderr, "warning: --force: the campaign changed (%s); runs already there are kept\n",
               list.c_str());
}

/// `remote`: null for a sweep on this machine (run_jobs, --jobs at once); under MPI, the
/// scheduler that hands the jobs to the `ranks` ranks (rank 0 included), one at a time each.
int run_sweep(const SweepArgs& args, const RemoteScheduler* remote, int ranks) {
  const Campaign c = read_campaign(args.file);
  const fs::path dir =
      fs::absolute(args.out_dir.empty() ? fs::path("campaigns") / c.name : fs::path(args.out_dir));
  const fs::path exe = fs::read_symlink("/proc/self/exe");
  const int jobs =
      remote != nullptr ? ranks
      : args.jobs > 0
          ? args.jobs
          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()) / args.threads);
  if (remote != nullptr && args.jobs > 0)
    std::fprintf(stderr,
                 "warning: --jobs is ignored under MPI: each rank runs one run at a time\n");
  const auto schedule = [&](const std::vector<Job>& list, const JobEndCallback& on_end) {
    return remote != nullptr ? (*remote)(list, on_end) : run_jobs(list, jobs, on_end);
  };
  check_same_campaign(dir / "campaign.toml", c, args.force);
  for (const char* sub : {"packings", "runs", "logs"}) fs::create_directories(dir / sub);
  // One sweep per folder at a time: two would start or resume the same runs. The lock is held
  // until this process exits; its runs inherit the descriptor, so runs left behind by a sweep
  // that died still hold it.
  const fs::path lock = dir / ".sweep.lock";
  const int lock_fd = ::open(lock.c_str(), O_RDWR | O_CREAT, 0644);
  if (lock_fd < 0 || ::flock(lock_fd, LOCK_EX | LOCK_NB) != 0)
    throw ConfigError(dir.string(), "",
                      "another sweep (or runs it left behind) is working in this folder; wait "
                      "for it to end, or stop it (its runs checkpoint on SIGTERM)");
  write_file_atomic(dir / "campaign.toml", campaign_file_text(c));
  const std::string threads = std::to_string(args.threads);

  // 1. One packing per (system, seed): copied from [campaign.packing], kept from an earlier
  // sweep, or prepared now (in parallel).
  std::map<std::pair<int, std::uint64_t>, fs::path> packing_of;
  std::vector<Job> prepare_jobs;
  for (const CampaignRun& r : c.runs) {
    const auto key = std::make_pair(r.system, r.seed);
    if (packing_of.contains(key)) continue;
    const fs::path p = dir / "packings" / fmt::format("s{}_seed{}.json", r.system, r.seed);
    packing_of[key] = p;
    if (fs::exists(p)) continue;
    if (const auto given = c.packings.find(r.system); given != c.packings.end()) {
      fs::copy_file(given->second, p);
      continue;
    }
    Job j;
    j.name = fmt::format("prepare_s{}_seed{}", r.system, r.seed);
    j.argv = {exe.string(),
              "prepare",
              "-q",
              "--system",
              std::to_string(r.system),
              "--set",
              fmt::format("system.seed={}", r.seed),
              "--threads",
              threads,
              "-o",
              p.string()};
    for (const std::string& o : c.overrides) j.argv.insert(j.argv.end(), {"--set", o});
    j.log = dir / "logs" / (j.name + ".log");
    j.cost = r.cost();
    prepare_jobs.push_back(j);
  }
  if (!prepare_jobs.empty()) {
    if (!args.quiet)
      std::printf("sweep %s: preparing %zu packing%s\n", c.name.c_str(), prepare_jobs.size(),
                  prepare_jobs.size() == 1 ? "" : "s");
    std::fflush(stdout);
    const ScheduleResult res = schedule(prepare_jobs, [&](const JobEnd& e, const JobProgress&) {
      const Job& j = prepare_jobs[e.job];
      if (!args.quiet || e.exit_code != 0)
        std::printf("sweep: %s %s (%s)%s\n", j.name.c_str(),
                    e.exit_code == 0     ? "done"
                    : e.exit_code == 130 ? "interrupted"
                                         : fmt::format("failed, exit {}", e.exit_code).c_str(),
                    format_seconds(e.seconds).c_str(),
                    e.exit_code == 0 ? "" : (", log " + j.log.string()).c_str());
      std::fflush(stdout);
    });
    if (res.interrupted) {
      std::printf(
          "sweep %s: interrupted while preparing packings; run the same command again "
          "to go on\n",
          c.name.c_str());
      return 130;
    }
  }

  // 2. The runs: skip finished ones, resume interrupted ones, start the rest.
  struct Planned {
    const CampaignRun* run;
    RunState before;
  };
  std::vector<Job> run_jobs_list;
  std::vector<Planned> planned;
  std::vector<std::string> failed;  // "NAME: why, log FILE"
  std::size_t finished_before = 0;
  std::set<std::size_t> analysis_jobs;  // jobs that only analyse a finished run
  for (const CampaignRun& r : c.runs) {
    const fs::path rdir = dir / "runs" / r.name;
    const fs::path log = dir / "logs" / (r.name + ".log");
    const RunState state = run_state(rdir);
    if (state == RunState::kFinished) {
      ++finished_before;
      // Killed after its last step but before (or during) its analysis: analyse and plot it
      // now, as the run would have.
      if (c.analyze && fs::exists(rdir / "run.h5") && !fs::exists(rdir / "summary.json")) {
        Job j;
        j.name = r.name;
        j.log = log;
        j.argv = {exe.string(), "analyze", "-q", "--plot", rdir.string()};
        analysis_jobs.insert(run_jobs_list.size());
        run_jobs_list.push_back(j);
      }
      continue;
    }
    if (state == RunState::kBlownUp) {
      failed.push_back(
          fmt::format("{}: blew up in an earlier sweep (remove {} to try again), log {}", r.name,
                      rdir.string(), log.string()));
      continue;
    }
    const fs::path packing = packing_of.at({r.system, r.seed});
    if (!fs::exists(packing)) {
      failed.push_back(fmt::format(
          "{}: its packing was not prepared, log {}", r.name,
          (dir / "logs" / fmt::format("prepare_s{}_seed{}.log", r.system, r.seed)).string()));
      continue;
    }
    Job j;
    j.name = r.name;
    j.log = log;
    j.cost = r.cost();
    if (state == RunState::kInterrupted) {
      j.argv = {exe.string(), "run", "--resume", rdir.string(), "--threads", threads};
    } else {
      j.argv = {exe.string(), "run",
                "--system",   std::to_string(r.system),
                "-V",         fmt::format("{}", r.velocity),
                "--set",      fmt::format("shear.duration={}", r.duration)};
      for (const std::string& o : run_case_overrides(c, r))
        j.argv.insert(j.argv.end(), {"--set", o});
      j.argv.insert(j.argv.end(),
                    {"--packing", packing.string(), "--threads", threads, "-o", rdir.string()});
      if (fs::is_directory(rdir) && !fs::is_empty(rdir)) j.argv.push_back("--force");
    }
    if (!c.analyze) j.argv.push_back("--no-analyze");
    run_jobs_list.push_back(j);
    planned.push_back({&r, state});
  }
  if (!args.quiet) {
    std::size_t resumed = 0;
    for (const Planned& p : planned) resumed += p.before == RunState::kInterrupted;
    std::printf(
        "sweep %s: %zu runs: %zu finished earlier%s, %zu to resume, %zu to start; up to %d "
        "at once%s, %s thread%s each -> %s\n",
        c.name.c_str(), c.runs.size(), finished_before,
        analysis_jobs.empty() ? "" : fmt::format(" ({} to analyse)", analysis_jobs.size()).c_str(),
        resumed, planned.size() - resumed, jobs, remote != nullptr ? " (MPI: one per rank)" : "",
        threads.c_str(), args.threads == 1 ? "" : "s", dir.c_str());
    std::fflush(stdout);
  }

  double done_cost = 0.0, done_seconds = 0.0;  // runs that ran to the end in this sweep
  std::size_t finished_now = 0;
  std::vector<std::string> interrupted;
  const ScheduleResult res = schedule(run_jobs_list, [&](const JobEnd& e, const JobProgress& p) {
    const Job& j = run_jobs_list[e.job];
    if (analysis_jobs.count(e.job) != 0) {
      if (e.exit_code != 0)
        failed.push_back(fmt::format("{}: finished, but its analysis failed (exit {}), log {}",
                                     j.name, e.exit_code, j.log.string()));
      else if (!args.quiet)
        std::printf("sweep: %s analysed (it had ended before its analysis)\n", j.name.c_str());
      std::fflush(stdout);
      return;
    }
    const RunState after = run_state(dir / "runs" / j.name);
    std::string what = state_name(after);
    if (after == RunState::kFinished) {
      ++finished_now;
      done_cost += j.cost;
      done_seconds += e.seconds;
      if (e.exit_code != 0)
        what += fmt::format(" (but exited with {}: see the log {})", e.exit_code, j.log.string());
    } else if (after != RunState::kBlownUp &&
               (e.exit_code == 130 || (g_stop_requested.load() && e.exit_code == 128 + SIGTERM))) {
      interrupted.push_back(j.name);
      what = "interrupted";
    } else {
      failed.push_back(fmt::format("{}: {}, exit {}, log {}", j.name, state_name(after),
                                   e.exit_code, j.log.string()));
      what = fmt::format("FAILED (exit {}, log {})", e.exit_code, j.log.string());
    }
    if (args.quiet) return;
    std::string eta;
    if (done_cost > 0 && (p.running > 0 || p.waiting > 0)) {
      // Seconds per unit of cost so far, times the cost left (a running job's share done
      // subtracted), shared among the parallel slots.
      const double rate = done_seconds / done_cost;
      double left = 0.0;
      for (const std::size_t w : p.waiting_jobs) left += rate * run_jobs_list[w].cost;
      for (const auto& [r, elapsed] : p.running_jobs)
        left += std::max(0.0, rate * run_jobs_list[r].cost - elapsed);
      eta = "; about " +
            format_seconds(left / std::max<std::size_t>(
                                      1, std::min<std::size_t>(jobs, p.running + p.waiting))) +
            " left";
    }
    std::printf("sweep: %s %s (%s); runs done %zu/%zu, running %zu, left %zu%s\n", j.name.c_str(),
                what.c_str(), format_seconds(e.seconds).c_str(), finished_before + finished_now,
                c.runs.size(), p.running, p.waiting, eta.c_str());
    std::fflush(stdout);
  });

  const std::size_t finished = finished_before + finished_now;
  std::printf(
      "sweep %s: %zu/%zu runs finished (%zu earlier), %zu failed, %zu interrupted, %zu "
      "not started -> %s\n",
      c.name.c_str(), finished, c.runs.size(), finished_before, failed.size(), interrupted.size(),
      res.never.size(), dir.c_str());
  for (const std::string& f : failed) std::printf("  failed: %s\n", f.c_str());
  if (res.interrupted) {
    std::printf("interrupted: run the same command again to resume\n");
    return 130;
  }
  if (!interrupted.empty())
    std::printf("  interrupted (not by this sweep): %s; run the same command again to resume\n",
                fmt::format("{}", fmt::join(interrupted, ", ")).c_str());
  return finished == c.runs.size() ? 0 : 1;
}

}  // namespace

void register_sweep_command(CLI::App& app) {
  auto args = std::make_shared<SweepArgs>();
  CLI::App* s = app.add_subcommand(
      "sweep", "Run a campaign: systems x velocities x seeds (docs/campaigns.md), resumable");
  s->add_option("campaign", args->file, "campaign file (TOML)")->required();
  s->add_option("-o,--output", args->out_dir, "campaign folder; default campaigns/<name>");
  add_count_option(s, "--jobs", args->jobs,
                   "runs at once (default: processors / --threads, at least 1)");
  add_count_option(s, "--threads", args->threads, "solver threads of each run (default 1)");
  s->add_flag("-q,--quiet", args->quiet, "only the final summary (and failures)");
  s->add_flag("--force", args->force,
              "go on in a folder made for a changed campaign (its runs are kept)");
  s->callback([args]() {
    int rc = 0;
#ifdef CDSHEAR_WITH_MPI
    if (mpi_launch_detected())  // only then is MPI initialized (docs/campaigns.md)
      rc = run_sweep_under_mpi([&](const RemoteScheduler* remote, int ranks) {
        return run_sweep(*args, remote, ranks);
      });
    else
#endif
      rc = run_sweep(*args, nullptr, 0);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
}

}  // namespace cdshear

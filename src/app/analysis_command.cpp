#include "analysis_command.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <system_error>

#include "commands.hpp"
#include "stop_signals.hpp"

namespace cdshear {

AnalysisPackage find_analysis_package() {
  namespace fs = std::filesystem;
  const auto has_package = [](const fs::path& dir) {
    std::error_code ec;
    return fs::is_regular_file(dir / "cdshear_analysis" / "__main__.py", ec);
  };
  if (const char* env = std::getenv("CDSHEAR_ANALYSIS_DIR"); env != nullptr && *env != '\0')
    return {env, "CDSHEAR_ANALYSIS_DIR", has_package(env)};
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed =
        (exe.parent_path() / CDSHEAR_INSTALLED_PYTHON_DIR).lexically_normal();
    if (has_package(installed)) return {installed, "install", true};
  }
  return {CDSHEAR_PYTHON_DIR, "source tree", has_package(CDSHEAR_PYTHON_DIR)};
}

namespace {
/// A stop request (SIGINT, SIGTERM, SIGHUP) ended the analysis or came before it: exit 130, as an
/// interrupted run does. The analysis writes each file whole or not at all, and never touches the
/// run's data.
int report_stopped_analysis(const std::string& verb, const std::filesystem::path& dir) {
  std::fprintf(stderr,
               "stopped: %s: `%s` was interrupted before it ended (what it wrote is whole, the "
               "run's data untouched); `cdshear %s %s` does it again\n",
               dir.c_str(), verb.c_str(), verb.c_str(), dir.c_str());
  return 130;
}

// A relative path named like an option ("-x") as "./-x": the package's argument parser would
// take it for one.
std::string not_an_option(const std::filesystem::path& path) {
  return path.string().starts_with('-') ? (std::filesystem::path(".") / path).string()
                                        : path.string();
}
}  // namespace

int run_analysis(const std::string& verb, const std::filesystem::path& run_dir,
                 const std::vector<std::string>& extra) {
  // The interpreter with Debian's numpy/scipy/matplotlib/h5py; CDSHEAR_PYTHON overrides it.
  const char* env_python = std::getenv("CDSHEAR_PYTHON");
  const std::string python = env_python != nullptr ? env_python : "/usr/bin/python3";
  if (access(python.c_str(), X_OK) != 0) {
    std::fprintf(stderr,
                 "error: %s: not found; `cdshear %s` needs Python 3 with numpy, scipy, "
                 "matplotlib and h5py (scripts/setup.sh installs them)\n",
                 python.c_str(), verb.c_str());
    return 1;
  }
  const AnalysisPackage package = find_analysis_package();
  if (!package.found) {
    std::fprintf(stderr,
                 "error: %s/cdshear_analysis: the analysis package is not there (%s); set "
                 "CDSHEAR_ANALYSIS_DIR to the folder that holds cdshear_analysis (a source "
                 "tree's `python` folder, or an install's)\n",
                 package.dir.c_str(),
                 package.source == "CDSHEAR_ANALYSIS_DIR"
                     ? "from CDSHEAR_ANALYSIS_DIR"
                     : "this cdshear is not installed and was built from a source tree that has "
                       "since moved or gone");
    return 1;
  }
  const std::string package_dir = package.dir.string();
  std::vector<std::string> args = {python, "-m", "cdshear_analysis", verb, not_an_option(run_dir)};
  args.insert(args.end(), extra.begin(), extra.end());
  // The child's argument and environment arrays are built here: between fork and exec it may
  // not allocate (another thread of this process may hold the allocator's lock at the fork).
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const char* old_path = std::getenv("PYTHONPATH");
  std::string python_path = "PYTHONPATH=" + package_dir;
  if (old_path != nullptr && *old_path != '\0') python_path += std::string(":") + old_path;
  std::vector<char*> envp;
  for (char** e = environ; *e != nullptr; ++e)
    if (std::strncmp(*e, "PYTHONPATH=", 11) != 0) envp.push_back(*e);
  envp.push_back(python_path.data());
  envp.push_back(nullptr);
  // A stop request before the analysis starts (a run's SIGTERM after its last step, or between
  // `analyze` and `plot`) starts nothing.
  if (g_stop_requested.load()) return report_stopped_analysis(verb, run_dir);
  std::fflush(stdout);
  std::fflush(stderr);
  // A stop sent to the child before Python installs its own handler ends it (default action).
  const pid_t pid = fork_with_default_stops();
  if (pid < 0) {
    std::perror("error: fork");
    return 1;
  }
  if (pid == 0) {  // child: only async-signal-safe calls until exec
    execve(python.c_str(), argv.data(), envp.data());
    const int exec_error = errno;
    const char head[] = "error: cannot start ";
    const char* reason = strerrordesc_np(exec_error);  // a table lookup: no locale, no lock
    if (reason == nullptr) reason = "unknown error";
    if (::write(STDERR_FILENO, head, sizeof head - 1) < 0 ||
        ::write(STDERR_FILENO, python.c_str(), python.size()) < 0 ||
        ::write(STDERR_FILENO, ": ", 2) < 0 ||
        ::write(STDERR_FILENO, reason, std::strlen(reason)) < 0 ||
        ::write(STDERR_FILENO, "\n", 1) < 0) {
    }
    _exit(127);
  }
  // cdshear's stop handlers catch SIGINT, SIGTERM and SIGHUP (stop_signals.cpp), so a signal sent
  // to cdshear alone (`kill PID`, a batch system's signal to the main process) would leave the
  // analysis running. It is passed on as SIGTERM: the analysis writes each file whole or not at
  // all (os.replace), so it stops with nothing half written. Polled every 20 ms, as the handler
  // only sets a flag and waitpid restarts after it. The analysis turns SIGTERM into Python's
  // KeyboardInterrupt, which removes its temporaries; one inside the HDF5 library that does not
  // return to Python within 10 s is killed.
  constexpr int kPollMicroseconds = 20000;
  constexpr int kPollsBeforeKill = 500;  // 10 s
  int status = 0;
  int polls_since_passed_on = -1;  // -1: not passed on
  for (;;) {
    const pid_t ended = waitpid(pid, &status, WNOHANG);
    if (ended == pid) break;
    if (ended < 0 && errno != EINTR) {
      std::perror("error: waiting for the analysis");
      return 1;
    }
    if (polls_since_passed_on < 0 && g_stop_requested.load()) {
      ::kill(pid, SIGTERM);
      polls_since_passed_on = 0;
    } else if (polls_since_passed_on >= 0 && ++polls_since_passed_on == kPollsBeforeKill) {
      ::kill(pid, SIGKILL);
    }
    ::usleep(kPollMicroseconds);
  }
  const int signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  // An analysis that ended on its own as the request came counts as done (the next one, `plot`
  // after `analyze`, is not started).
  const bool stopped_by_request =
      g_stop_requested.load() &&
      (WIFEXITED(status) ? WEXITSTATUS(status) == 130
                         : signal == SIGINT || signal == SIGTERM || signal == SIGHUP ||
                               (signal == SIGKILL && polls_since_passed_on >= kPollsBeforeKill));
  if (stopped_by_request) return report_stopped_analysis(verb, run_dir);
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  // The analysis ends itself by SIGALRM when reading a run.h5 takes longer than its limit
  // (python/cdshear_analysis/rundata.py, read_time_limit_seconds): the HDF5 library looping
  // without end on a damaged file.
  if (signal == SIGALRM) {
    std::fprintf(stderr,
                 "error: %s: the analysis (`%s`) gave up reading run.h5 after its time limit "
                 "(60 s + 0.5 s per MB, or CDSHEAR_READ_TIME_LIMIT seconds): a damaged run.h5 its "
                 "seal does not catch (the HDF5 library loops on it), or a disk that slow; the "
                 "run's data files are left as they were\n",
                 run_dir.c_str(), verb.c_str());
    return 2;
  }
  // Only a crash is blamed on the files; a kill (the OOM killer, kill -9, a closed pipe) is
  // reported as what it is.
  if (signal != SIGSEGV && signal != SIGBUS && signal != SIGABRT && signal != SIGFPE &&
      signal != SIGILL) {
    if (signal != SIGINT && signal != SIGTERM && signal != SIGHUP)
      std::fprintf(stderr, "error: %s: the analysis (`%s`) was killed by signal %d (%s)\n",
                   run_dir.c_str(), verb.c_str(), signal, strsignal(signal));
    return 128 + signal;
  }
  // The interpreter died inside a library (HDF5 reading a damaged file whose seal still matches,
  // typically): it cannot say so itself, so its parent does, and the run's files are untouched.
  std::fprintf(stderr,
               "error: %s: the analysis (`%s`) died of signal %d (%s) while reading the files: a "
               "damaged run.h5 its seal does not catch, or a bug (please report it with the "
               "file); the run's data files are left as they were\n",
               run_dir.c_str(), verb.c_str(), signal, strsignal(signal));
  return 2;
}

void register_analysis_commands(CLI::App& app) {
  struct Args {
    std::string dir, out;
    bool quiet = false;
    bool plot = false;
  };
  auto analyze = std::make_shared<Args>();
  CLI::App* a = app.add_subcommand(
      "analyze",
      "Steady state, averages with uncertainties, flow regime, band switches of a run -> "
      "summary.json");
  a->add_option("run_dir", analyze->dir, "run folder (holding run.h5)")
      ->check(kNonEmptyPath)
      ->required();
  a->add_flag("-q,--quiet", analyze->quiet, "write summary.json without printing the report");
  a->add_flag("--plot", analyze->plot,
              "then write the run's figures too (RUN_DIR/figures/), as `cdshear run` does");
  a->callback([analyze]() {
    int rc = run_analysis(
        "analyze", analyze->dir,
        analyze->quiet ? std::vector<std::string>{"--quiet"} : std::vector<std::string>{});
    if (rc == 0 && analyze->plot) rc = run_analysis("plot", analyze->dir, {});
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
  auto plot = std::make_shared<Args>();
  CLI::App* p = app.add_subcommand("plot", "PNG figures of a run (default: RUN_DIR/figures/)");
  p->add_option("run_dir", plot->dir, "run folder (holding run.h5)")
      ->check(kNonEmptyPath)
      ->required();
  p->add_option("-o,--output", plot->out, "folder for the figures")->check(kNonEmptyPath);
  p->callback([plot]() {
    std::vector<std::string> extra;
    if (!plot->out.empty()) extra = {"-o", not_an_option(plot->out)};
    const int rc = run_analysis("plot", plot->dir, extra);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
  auto report = std::make_shared<Args>();
  CLI::App* r = app.add_subcommand(
      "report",
      "A campaign's runs table, fitted laws mu_eff(I), nu(I), Z(I), figures and index.html "
      "(default: CAMPAIGN_DIR/report/)");
  r->add_option("campaign_dir", report->dir, "campaign folder (made by `cdshear sweep`)")
      ->check(kNonEmptyPath)
      ->required();
  r->add_option("-o,--output", report->out, "folder for the report")->check(kNonEmptyPath);
  r->callback([report]() {
    std::vector<std::string> extra;
    if (!report->out.empty()) extra = {"-o", not_an_option(report->out)};
    const int rc = run_analysis("report", report->dir, extra);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
}

}  // namespace cdshear

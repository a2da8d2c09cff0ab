#include "run_session.hpp"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <fstream>
#include <optional>
#include <string_view>
#include <vector>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "build_info.hpp"
#include "config_error.hpp"
#include "job_scheduler.hpp"
#include "outputs.hpp"

namespace cdshear {

std::uint64_t steps_of(double interval, double dt) {
  return interval > 0 ? std::max<std::uint64_t>(1, std::llround(interval / dt)) : 0;
}

bool folder_is_free(const std::filesystem::path& dir, bool lock_held_here) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return true;
  if (!fs::is_directory(dir, ec)) return false;
  bool only_lock = false;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    if (e.path().filename() != kFolderLockName) return false;
    only_lock = true;
  }
  if (ec) return false;
  // A lock file alone: free unless another command holds it (a run still preparing its
  // packing). flock locks belong to open files, so the caller's own lock would look held here.
  if (only_lock && !lock_held_here) {
    const int fd =
        ::open((dir / kFolderLockName).c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (fd < 0) return false;
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0;
    ::close(fd);
    return !held;
  }
  return true;
}

FolderLock FolderLock::take(const std::filesystem::path& dir) {
  const std::filesystem::path file = dir / kFolderLockName;
  // The file locked must still be the one at the path: a holder that removes its lock file
  // (a run that made the folder and failed) does so while it holds it, and whoever opened the
  // old file meanwhile tries again on the new one.
  for (int attempt = 0;; ++attempt) {
    FolderLock lock = take_once(dir);
    struct stat held {
    }, named{};
    if (::fstat(lock.fd_, &held) == 0 && ::stat(file.c_str(), &named) == 0 &&
        held.st_ino == named.st_ino && held.st_dev == named.st_dev)
      return lock;
    if (attempt >= 8)
      throw ConfigError(file.string(), "", "the folder's lock file keeps being replaced");
  }
}

FolderLock FolderLock::take_once(const std::filesystem::path& dir) {
  const std::filesystem::path file = dir / kFolderLockName;
  FolderLock lock;
  lock.fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0644);
  if (lock.fd_ < 0)
    throw ConfigError(file.string(), "",
                      std::string("cannot open the folder's lock file: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(lock.fd_, &st) != 0 || !S_ISREG(st.st_mode))
    throw ConfigError(file.string(), "", "the folder's lock file is not a regular file");
  if (::flock(lock.fd_, LOCK_EX | LOCK_NB) != 0) {
    char holder[256] = {};
    const ssize_t got = ::pread(lock.fd_, holder, sizeof holder - 1, 0);
    std::string who(holder, got > 0 ? static_cast<std::size_t>(got) : 0);
    while (!who.empty() && (who.back() == '\n' || who.back() == '\0')) who.pop_back();
    throw ConfigError(
        dir.string(), "",
        "another cdshear is writing this folder (" +
            (who.empty() ? std::string("holder unknown") : who) +
            "); wait for it to end, or stop it (SIGTERM stops it after its current step, where a "
            "shear run writes a checkpoint to resume from)");
  }
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  const std::string who = fmt::format("pid {} on {} since {:%Y-%m-%d %H:%M:%S} UTC\n", ::getpid(),
                                      host, fmt::gmtime(std::time(nullptr)));
  if (::ftruncate(lock.fd_, 0) == 0) {
    const ssize_t written = ::pwrite(lock.fd_, who.data(), who.size(), 0);
    (void)written;  // the holder's name is a courtesy; the flock is the lock
  }
  return lock;
}

FolderLock& FolderLock::operator=(FolderLock&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

FolderLock::~FolderLock() {
  if (fd_ >= 0) ::close(fd_);
}

void FolderLock::remove_and_release(const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::remove(dir / kFolderLockName, ec);
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

namespace {

/// `digits` is one or more decimal digits.
bool all_digits(std::string_view digits) {
  return !digits.empty() &&
         std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; });
}

/// The files a run or scene command writes at the top of its folder: fixed names, and
/// run_info.json, run_info_resume_<step>.json, run_info_resume_<step>_<k>.json, and what a
/// killed atomic write of any of them leaves: <name>.tmp.<pid>.
bool is_written_run_file(std::string_view name) {
  if (const auto written = temporary_of(name)) return is_written_run_file(*written);
  for (const char* fixed : {"case.toml", "scene.toml", "run.h5", "summary.json", "checkpoint.cbor",
                            "timeseries.csv", "final_state.json", "interrupted_state.json",
                            "blowup_state.json", "run_info.json", "progress.json"})
    if (name == fixed) return true;
  constexpr std::string_view prefix = "run_info_resume_", suffix = ".json";
  if (!name.starts_with(prefix) || !name.ends_with(suffix) ||
      name.size() <= prefix.size() + suffix.size())
    return false;
  std::string_view middle = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  const auto underscore = middle.find('_');
  if (underscore == std::string_view::npos) return all_digits(middle);
  return all_digits(middle.substr(0, underscore)) && all_digits(middle.substr(underscore + 1));
}

/// The figures `cdshear plot` writes into a run's figures/ (python/cdshear_analysis/plots.py,
/// FIGURES; a test checks the two lists agree).
bool is_run_figure(std::string_view name) {
  for (const char* figure : {"snapshot.png", "velocity_profiles.png", "com_velocity.png",
                             "height_solid_fraction.png", "steady_profiles.png"})
    if (name == figure) return true;
  return false;
}

/// The ParaView files of snapshots/ (observers.cpp): particles_<step>.vtp, contacts_<step>.vtp,
/// particles.pvd, contacts.pvd, and what a killed atomic write of any of them leaves.
bool is_snapshot_file(std::string_view name) {
  if (const auto written = temporary_of(name)) return is_snapshot_file(*written);
  if (name == "particles.pvd" || name == "contacts.pvd") return true;
  for (const std::string_view prefix :
       {std::string_view("particles_"), std::string_view("contacts_")})
    if (name.starts_with(prefix) && name.ends_with(".vtp") &&
        all_digits(name.substr(prefix.size(), name.size() - prefix.size() - 4)))
      return true;
  return false;
}

/// Removes the files of `folder` that `ours` names, then the folder if that left it empty.
template <class Ours>
void remove_written(const std::filesystem::path& folder, const Ours& ours) {
  namespace fs = std::filesystem;
  for (const fs::directory_entry& e : fs::directory_iterator(folder))
    if (!e.is_directory() && ours(e.path().filename().string())) fs::remove(e.path());
  if (fs::is_empty(folder)) fs::remove(folder);
}

}  // namespace

FolderLock lock_output_folder(const std::filesystem::path& dir, bool force,
                              const std::string& hint) {
  namespace fs = std::filesystem;
  if (fs::exists(dir) && !fs::is_directory(dir))
    throw ConfigError(dir.string(), "", "exists and is not a folder");
  // Locked before anything in it is looked at: another run may be writing it.
  FolderLock lock;
  if (fs::is_directory(dir)) lock = FolderLock::take(dir);
  for (const auto& [name, header] : {std::pair{"case.toml", kResolvedCaseHeader},
                                     std::pair{"scene.toml", kResolvedSceneHeader}}) {
    const fs::path file = dir / name;
    std::error_code ec;
    // A link is replaced, not written through (write_file_atomic renames over it).
    if (!fs::is_regular_file(fs::symlink_status(file, ec))) continue;
    std::string start(header.size(), '\0');
    std::ifstream in(file, std::ios::binary);
    in.read(start.data(), static_cast<std::streamsize>(start.size()));
    if (in && start == header) continue;
    throw ConfigError(
        file.string(), "",
        "was not written by cdshear (a case or scene file of your own, kept in the "
        "output folder?): the command would write over it, --force or not; move it out "
        "of the folder or choose another -o");
  }
  if (!force && !folder_is_free(dir, lock.held())) {
    std::vector<std::string> names;
    for (const fs::directory_entry& e : fs::directory_iterator(dir))
      if (e.path().filename() != kFolderLockName) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    if (names.size() > 4) names.resize(4), names.push_back("...");
    throw ConfigError(dir.string(), "",
                      fmt::format("already holds results ({}); {}choose another -o, or pass "
                                  "--force to replace them",
                                  fmt::join(names, ", "), hint.empty() ? "" : hint + ", "));
  }
  std::error_code ec;
  if (fs::is_symlink(fs::symlink_status(dir, ec)) && !fs::exists(dir, ec))
    throw ConfigError(dir.string(), "",
                      "is a symbolic link to " + fs::read_symlink(dir, ec).string() +
                          ", which does not exist: make that folder, or choose another -o");
  fs::create_directories(dir, ec);
  if (ec)  // a file in the path, a read-only or special file system, a name too long...
    throw ConfigError(dir.string(), "", "cannot create the output folder: " + ec.message());
  return lock.held() ? std::move(lock) : FolderLock::take(dir);
}

void remove_written_outputs(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  // What cdshear writes, nothing else (a user's notes, or figures of their own in figures/,
  // stay).
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name == "figures" && e.is_directory()) {
      remove_written(e.path(), is_run_figure);
    } else if (name == "snapshots" && e.is_directory()) {
      remove_written(e.path(), is_snapshot_file);
    } else if (is_written_run_file(name) && !e.is_directory()) {
      fs::remove(e.path());
    }
  }
}

std::optional<std::string> read_run_file(const std::filesystem::path& path,
                                         const std::string& role) {
  int fd = -1;
  try {
    fd = open_regular_file(path, O_RDONLY | O_CLOEXEC, role);
  } catch (const ConfigError&) {
    return std::nullopt;
  }
  if (fd < 0) return std::nullopt;
  std::string text;
  char buffer[4096];
  for (ssize_t got; (got = ::read(fd, buffer, sizeof buffer)) > 0;)
    text.append(buffer, static_cast<std::size_t>(got));
  ::close(fd);
  return text;
}

std::optional<std::uint64_t> recorded_step(const std::filesystem::path& file) {
  const std::optional<std::string> text = read_run_file(file, "a run's file");
  if (!text) return std::nullopt;
  const nlohmann::json j = nlohmann::json::parse(*text, nullptr, false);
  if (!j.is_object()) return std::nullopt;
  const auto step = j.find("step");
  if (step == j.end() || !step->is_number_unsigned()) return std::nullopt;
  return step->get<std::uint64_t>();
}

void check_utf8_path(const std::string& option, const std::string& path) {
  try {
    (void)nlohmann::json(path).dump();
  } catch (const nlohmann::json::type_error&) {
    throw ConfigError(option, "",
                      fmt::format("'{}' is not UTF-8 text, which case.toml and run_info.json "
                                  "need to record it: rename it",
                                  printable(path)));
  }
}

void remove_stale_temporaries(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  const auto remove_in = [](const fs::path& folder, bool (*ours)(std::string_view)) {
    std::error_code ec;
    for (const fs::directory_entry& e : fs::directory_iterator(folder, ec)) {
      const std::string name = e.path().filename().string();
      if (temporary_of(name) && ours(name) && e.is_regular_file(ec)) fs::remove(e.path(), ec);
    }
  };
  remove_in(dir, is_written_run_file);
  std::error_code ec;
  if (fs::is_directory(dir / "snapshots", ec)) remove_in(dir / "snapshots", is_snapshot_file);
}

FolderLock claim_output_folder(const std::filesystem::path& dir, bool force,
                               const std::string& hint) {
  FolderLock lock = lock_output_folder(dir, force, hint);
  if (force) remove_written_outputs(dir);
  return lock;
}

std::uint64_t checked_end_step(double duration, double dt, std::uint64_t current_step,
                               const std::string& source, const std::string& key,
                               bool may_end_here) {
  const double steps = duration / dt;
  if (!std::isfinite(steps) || steps > kMaxRunSteps)
    throw ConfigError(source, key,
                      fmt::format("duration {:.6g} with dt {:.6g} asks for {:.3g} steps, more than "
                                  "the limit of {:.0e} (docs/reliability.md)",
                                  duration, dt, steps, kMaxRunSteps));
  const auto end = static_cast<std::uint64_t>(std::llround(steps));
  if (end < current_step || (end == current_step && !may_end_here))
    throw ConfigError(source, key,
                      current_step == 0
                          ? fmt::format("duration {:.6g} is less than half a time step ({:.6g}): "
                                        "the run would do nothing",
                                        duration, dt)
                          : fmt::format("the run already reached t = {:.6g} (step {}); to "
                                        "continue it, give a longer one: --set {}=T",
                                        static_cast<double>(current_step) * dt, current_step, key));
  return end;
}

int finish_run(const RunEnd& end, const World& world, const RunSummary& summary) {
  namespace fs = std::filesystem;
  const char* state_name = state_file_name(summary.outcome, end.reached_end);
  nlohmann::json state = state_to_json(world);
  if (!end.case_identity.is_null()) state["case"] = end.case_identity;
  write_file_atomic(end.dir / state_name, state.dump(1) + "\n");
  if (end.reached_end && summary.outcome == RunOutcome::kFinished) {
    fs::remove(end.dir / "interrupted_state.json");  // stale once the run is complete, and so
    fs::remove(end.dir / "blowup_state.json");       // is a blow-up a resume went past
  }
  nlohmann::json info = end.info;
  info["program"] = "cdshear";
  info["version"] = CDSHEAR_VERSION;
  const BuildInfo build = build_info();
  info["build"] = {{"commit", build.commit},
                   {"tree_modified", build.modified},
                   {"build_type", build.build_type},
                   {"description", build_description()}};
  // The build's instruction set changes the rounding, so which run repeats which bit for bit
  // (CMakeLists.txt, CDSHEAR_ARCH).
  info["instruction_set"] = CDSHEAR_INSTRUCTION_SET;
  info["step"] = world.step;
  info["time"] = world.time;
  info["state_hash"] = fmt::format("{:016x}", state_hash(world));
  info["summary"] = summary_to_json(summary);
  // Ended by --stop-at before its duration: not finished (a campaign or a study would otherwise
  // take it for a complete run).
  if (!end.reached_end && summary.outcome == RunOutcome::kFinished)
    info["summary"]["outcome"] = "stopped";
  write_file_atomic(end.dir / end.info_name, info.dump(2) + "\n");
  // A step that reaches `max_sweeps` over-relaxed, or that the contact-law bound holds back, goes
  // on with relaxation 1 (the plain finish); "capped" counts those that reach the cap there too.
  const std::string plain_finish =
      summary.plain_finish_steps > 0
          ? fmt::format(
                ", {} finished plain (at the over-relaxed cap or held back by the "
                "contact-law bound)",
                summary.plain_finish_steps)
          : std::string();
  std::printf(
      "%llu steps in %.1f s (%.0f steps/s), sweeps mean %.1f largest %d%s, capped %llu, largest "
      "overlap %.3g\n",
      static_cast<unsigned long long>(summary.steps), summary.wall_seconds,
      summary.wall_seconds > 0 ? summary.steps / summary.wall_seconds : 0.0, summary.mean_sweeps,
      summary.largest_sweeps, plain_finish.c_str(),
      static_cast<unsigned long long>(summary.capped_steps), summary.largest_overlap);
  // The per-step check (docs/step-error.md, "Per-step check"): the bound held off the cap.
  if (end.residual_bound > 0.0 && summary.steps > 0) {
    const double off_cap = summary.velocity_residual_rms_largest_off_cap;
    const std::string at_cap =
        summary.capped_steps > 0
            ? fmt::format("; {} capped, the largest of all steps {:.3g}", summary.capped_steps,
                          summary.velocity_residual_rms_largest)
            : std::string();
    std::printf(
        "contact laws: RMS violation per step at most %.3g d/t off the cap, %.3g of the bound "
        "%.3g%s\n",
        off_cap, off_cap / end.residual_bound, end.residual_bound, at_cap.c_str());
  }
  if (summary.refinement.steps > 0)
    std::printf(
        "refinement: %llu of %llu steps to its tolerance, %.2f iterations per step, largest "
        "residual %.3g; %llu undone (the refined step broke the contact-law bound the sweeps' "
        "met)\n",
        static_cast<unsigned long long>(summary.refinement.steps_to_tolerance),
        static_cast<unsigned long long>(summary.refinement.steps),
        summary.refinement.mean_iterations(), summary.refinement.largest_residual,
        static_cast<unsigned long long>(summary.refinement.steps_undone));
  if (summary.outcome == RunOutcome::kBlownUp) {
    std::fprintf(stderr, "error: step %llu blew up: %s; state written to %s%s\n",
                 static_cast<unsigned long long>(summary.last.step), summary.last.problem.c_str(),
                 (end.dir / state_name).c_str(),
                 fs::exists(end.dir / "checkpoint.cbor") ? ", last good checkpoint kept" : "");
    return 3;
  }
  if (!end.reached_end || summary.outcome == RunOutcome::kInterrupted) {
    std::printf("stopped at step %llu (t %.4f); state in %s%s\n",
                static_cast<unsigned long long>(world.step), world.time,
                (end.dir / state_name).c_str(), end.resume_hint.c_str());
    return summary.outcome == RunOutcome::kInterrupted ? 130 : 0;
  }
  return 0;
}

}  // namespace cdshear

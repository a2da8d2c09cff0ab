// What every run command does once its loop returns, in one place: the state file, the run
// information (JSON with the loop's summary), the summary line, the message for an early stop,
// and the exit status (0 done, 130 interrupted, 3 blown up).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "run_loop.hpp"
#include "toml_reader.hpp"

namespace cdshear {

struct RunEnd {
  std::filesystem::path dir;
  std::string info_name = "run_info.json";
  nlohmann::json info;       ///< the command's own fields; version, state hash, summary are added
  bool reached_end = false;  ///< the run reached its end time
  std::string resume_hint;   ///< for a run stopped early: how to continue (empty: none)
  /// Written into the state file as "case" (null: none, a scene): case_identity of the run.
  nlohmann::json case_identity;
  /// The steps' contact-law bound on the RMS velocity residual e
  /// (SolverOptions::residual_tolerance / dt) [d/t], said on the closing lines; 0: none.
  double residual_bound = 0.0;
};

int finish_run(const RunEnd& end, const World& world, const RunSummary& summary);

/// Whole number of steps in a time interval (0 when the interval is 0: disabled).
std::uint64_t steps_of(double interval, double dt);

/// True when `dir` does not exist or is an empty folder, its lock file aside unless another
/// command holds it (`lock_held_here`: the caller holds it, so it is no one else's).
bool folder_is_free(const std::filesystem::path& dir, bool lock_held_here = false);

/// One writer per run folder: an exclusive flock on DIR/.cdshear.lock, held as long as this
/// object lives (the process's life, for a run), whose file names the holder (pid, host, start).
/// flock is local to one machine except on NFS, where Linux maps it to the server's byte-range
/// locks (docs/reliability.md, "One writer per folder").
class FolderLock {
 public:
  FolderLock() = default;
  /// Takes the lock of `dir` (an existing folder), or throws ConfigError naming the folder and the
  /// holder when another process has it.
  static FolderLock take(const std::filesystem::path& dir);
  FolderLock(FolderLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }
  FolderLock& operator=(FolderLock&& other) noexcept;
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  ~FolderLock();
  bool held() const { return fd_ >= 0; }
  /// Removes the lock file while still holding it, then lets go (for a command that made the
  /// folder and leaves it empty).
  void remove_and_release(const std::filesystem::path& dir);

 private:
  static FolderLock take_once(const std::filesystem::path& dir);
  int fd_ = -1;
};

/// The file of a FolderLock, in the folder it guards.
inline constexpr const char* kFolderLockName = ".cdshear.lock";

/// Why a run folder's case.toml that holds no key is refused (a resume and a sweep alike): read
/// as a case, it would be the defaults, not the run's case.
inline constexpr const char* kEmptyRunCaseProblem =
    "is empty: a run's case.toml holds its whole case (restore it)";

/// The first words of the case.toml a run writes in its folder (the resolved case) and of the
/// scene.toml a scene command writes: a file of that name that does not begin with them is the
/// user's own (the case file being run, kept in its output folder), and no command replaces it.
inline constexpr std::string_view kResolvedCaseHeader = "# Resolved case written by cdshear ";
inline constexpr std::string_view kResolvedSceneHeader = "# Resolved scene written by cdshear ";

/// The one rule of every command that writes a folder: a folder another cdshear is writing is
/// refused (FolderLock); a folder holding a case.toml or scene.toml of the user's own (a regular
/// file without kResolvedCaseHeader, kResolvedSceneHeader) is refused, `force` or not, since
/// `--force` would replace it; a folder holding anything else is refused (ConfigError naming it
/// and what it holds, with `hint` on how to continue) unless `force`. Creates the folder and
/// returns its lock; removes nothing.
FolderLock lock_output_folder(const std::filesystem::path& dir, bool force,
                              const std::string& hint);

/// What `--force` removes: the outputs cdshear writes in `dir`, by name (nothing else).
void remove_written_outputs(const std::filesystem::path& dir);

/// The text of a file a run wrote, opened as the sweep opens the runs' logs: a FIFO or another
/// special file in its place must not block the reader. None when it is missing or unreadable.
std::optional<std::string> read_run_file(const std::filesystem::path& path,
                                         const std::string& role);

/// The "step" a JSON file of a run was written at (final_state.json, interrupted_state.json,
/// run_info.json); none when it cannot be read or holds none.
std::optional<std::uint64_t> recorded_step(const std::filesystem::path& file);

/// Refuses (ConfigError naming `option`) a path given on the command line that is not UTF-8:
/// case.toml, run_info.json and the summary record paths as text, which TOML and JSON hold only
/// in UTF-8.
void check_utf8_path(const std::string& option, const std::string& path);

/// Removes what killed atomic writes left in `dir` and its snapshots/ (<name>.tmp.<pid> of the
/// files a run writes); for the holder of the folder's lock, whose own writes are complete.
void remove_stale_temporaries(const std::filesystem::path& dir);

/// lock_output_folder, then with `force` remove_written_outputs at once (a command with nothing
/// to check before it writes).
FolderLock claim_output_folder(const std::filesystem::path& dir, bool force,
                               const std::string& hint);

/// The step at which a run of `duration` with step `dt` ends, checked: a step count that is not
/// finite or above kMaxRunSteps, or a run with nothing left to do (end before `current_step`, or
/// at it unless `may_end_here`: a resumed run that has yet to write its end's files), is a
/// ConfigError naming `source` and `key`.
std::uint64_t checked_end_step(double duration, double dt, std::uint64_t current_step,
                               const std::string& source, const std::string& key,
                               bool may_end_here = false);

}  // namespace cdshear

// `cdshear sweep CAMPAIGN.toml`: every run of a campaign (docs/campaigns.md) as a child process
// of this executable (`prepare` once per system and seed, then `run` or `run --resume`), several
// at once, resumable, with one log per run, a progress line after each and, every
// --progress-every seconds, one with an estimate from the running runs' progress.json.
#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sys/file.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string_view>
#include <thread>

#include "campaign_file.hpp"
#include "case_file.hpp"
#include "commands.hpp"
#include "config_error.hpp"
#include "job_scheduler.hpp"
#include "json_reading.hpp"
#include "mpi_scheduler.hpp"
#include "outputs.hpp"
#include "packing_file.hpp"
#include "run_data_file.hpp"
#include "run_session.hpp"
#include "stop_signals.hpp"
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
  bool dry_run = false;           ///< print the resolved campaign and exit
  double progress_every = 600.0;  ///< [s] between periodic progress lines; 0: none
};

/// The campaign's folder: -o, or campaigns/<name> under the current directory.
fs::path campaign_folder(const SweepArgs& args, const Campaign& c) {
  return fs::absolute(args.out_dir.empty() ? fs::path("campaigns") / c.name
                                           : fs::path(args.out_dir));
}

/// Whether a new start in the run folder `rdir` replaces files there (`run --force`, which
/// removes cdshear's files): the folder exists and is not empty.
bool start_replaces_files(const fs::path& rdir) {
  std::error_code ec;
  return fs::is_directory(rdir, ec) && !fs::is_empty(rdir, ec);
}

/// What a run folder holds, from its files (docs/campaigns.md, "Resume rules").
enum class RunState { kNew, kFinished, kInterrupted, kBlownUp };

/// What a failed run left in its folder, for the failure's line (the cause is its exit and its
/// log, not this state: a run that failed on resume is still "interrupted").
const char* failed_folder_state(RunState s) {
  switch (s) {
    case RunState::kInterrupted:
      return "its checkpoint kept";
    case RunState::kBlownUp:
      return "blown up";
    case RunState::kNew:
    case RunState::kFinished:
      break;
  }
  return "nothing to resume from";
}

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

/// A run folder's summary.json; an empty object when there is none or it cannot be read.
nlohmann::json run_summary(const fs::path& dir);

/// A summary's "case" object; empty when there is none.
nlohmann::json case_of(const nlohmann::json& summary) {
  const auto it = summary.find("case");
  return it != summary.end() && it->is_object() ? *it : nlohmann::json::object();
}

/// True when the run's progress.json says its last sitting ended before its end step (`step` <
/// `end_step`) and that end lies past the final state's step: an extension of a finished run
/// (`run --resume --set shear.duration=T`), which keeps its earlier final_state.json until it
/// reaches the new end, stopped short. A run that ends writes its progress ("finished", step =
/// end_step) before its final state; where that write failed (a progress file is a courtesy:
/// a full disk or a read-only file only warns), the file still holds an earlier "running" line
/// whose end is the final state's own step, and the run is finished.
bool stopped_before_its_end(const fs::path& dir);

/// True when the folder's interrupted_state.json is of a stop after its final state: an
/// extension that stopped before its new end. Not when it is no later than the final state (a
/// run killed between writing its final state and removing the interrupted one has every step
/// done), nor when there is none. Either state's step unknown: true, as the file says.
bool interrupted_after_final_state(const fs::path& dir);

/// True when the folder's final_state.json is of a step before the end its case.toml asks for:
/// an extension killed after it wrote the longer duration into case.toml but before its new
/// final state (its progress.json may say "finished" by then, or still be the earlier end's).
/// Either file unreadable: false.
bool final_state_short_of_case(const fs::path& dir);

/// True when a folder with a final state holds an extension stopped before its new end (any of
/// the three signs above).
bool extension_stopped(const fs::path& dir) {
  return stopped_before_its_end(dir) || interrupted_after_final_state(dir) ||
         final_state_short_of_case(dir);
}

/// The case.toml that `dir`'s run.h5 records, where the file reads as the data of a run that
/// reached its end; nothing where it is missing, unreadable or unfinished.
std::optional<std::string> finished_run_data(const fs::path& dir) {
  std::error_code ec;
  if (!fs::exists(dir / "run.h5", ec)) return std::nullopt;
  try {
    RunData data = read_run_data(dir / "run.h5");
    if (data.meta.finished) return std::move(data.meta.case_toml);
  } catch (const ConfigError&) {
  }
  return std::nullopt;
}

/// Finished: final_state.json (written only when the run reached its duration), whether or not
/// a run_info*.json says "finished" too: a run killed between writing the two has every step
/// done (a resume would only write its run_info), so it counts as finished; unless
/// an extension of it stopped before its new end, with a checkpoint: interrupted. An extension
/// that stopped says so twice, in progress.json (stopped_before_its_end) and by its
/// interrupted_state.json (removed when a run completes): either is enough, so that a lost or
/// damaged progress.json does not leave the run finished short of its case.toml's duration; and
/// so does a final state short of case.toml's end (killed between the two files' writes).
/// Blown up: blowup_state.json (a resume would repeat the same steps), also where an extension
/// of a finished run blew up (the blow-up no older than the final state). Interrupted: a
/// checkpoint to resume from. Finished too: no checkpoint but a summary.json of a run that
/// reached its end (a campaign folder cloned from git keeps its summaries, not its final states),
/// or a run.h5 marked finished (the checkpoint and final state deleted to save space).
/// Otherwise new.
RunState run_state(const fs::path& dir) {
  if (!fs::is_directory(dir)) return RunState::kNew;
  std::error_code ec;
  const bool blown_up = fs::exists(dir / "blowup_state.json", ec);
  if (fs::exists(dir / "final_state.json", ec)) {
    if (blown_up) {
      const auto blew = fs::last_write_time(dir / "blowup_state.json", ec);
      const bool blew_known = !ec;
      const auto ended = fs::last_write_time(dir / "final_state.json", ec);
      if (blew_known && !ec && blew >= ended) return RunState::kBlownUp;
    }
    return fs::exists(dir / "checkpoint.cbor", ec) && extension_stopped(dir)
               ? RunState::kInterrupted
               : RunState::kFinished;
  }
  if (blown_up) return RunState::kBlownUp;
  if (fs::exists(dir / "checkpoint.cbor")) return RunState::kInterrupted;
  if (case_of(run_summary(dir)).value("finished", nlohmann::json()) == true)
    return RunState::kFinished;
  if (finished_run_data(dir)) return RunState::kFinished;
  return RunState::kNew;
}

/// `remedy`: what the message ends with (empty: nothing).
std::string summary_problem(const fs::path& run_dir,
                            std::string_view remedy = "remove it to run this one again");

/// A finished run whose analysis was cut short: its summary.json missing or unreadable, or not
/// of the run's case.toml as it is now (summary_problem: an extension stopped in its analysis
/// keeps the summary of its earlier duration), or a figure `cdshear plot` always makes missing
/// or older than the summary (an extension stopped in its plot). Each file is written whole or
/// not at all (python/cdshear_analysis/plots.py, plot_run); the profile figures are made when
/// the run has measurement windows, which a summary with steady windows implies.
bool analysis_incomplete(const fs::path& dir) {
  const nlohmann::json summary = run_summary(dir);
  if (summary.empty()) return true;
  if (!summary_problem(dir).empty()) return true;
  std::vector<const char*> figures = {"snapshot.png", "com_velocity.png",
                                      "height_solid_fraction.png"};
  const auto steady = summary.find("steady_windows");
  if (steady != summary.end() && steady->is_number() && steady->get<double>() > 0)
    figures.insert(figures.end(), {"velocity_profiles.png", "steady_profiles.png"});
  std::error_code ec;
  const fs::file_time_type analysed = fs::last_write_time(dir / "summary.json", ec);
  const bool analysed_known = !ec;
  return std::any_of(figures.begin(), figures.end(), [&](const char* f) {
    std::error_code figure_ec;
    const fs::file_time_type plotted = fs::last_write_time(dir / "figures" / f, figure_ec);
    return figure_ec || (analysed_known && plotted < analysed);
  });
}

/// The last line of a run's log that starts with "error:" (at most 300 characters), or empty:
/// what a failed run said, for the sweep's account of it.
std::string last_error_line(const fs::path& log) {
  std::ifstream in(log, std::ios::binary);
  if (!in) return "";
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff start = std::max<std::streamoff>(0, size - 65536);  // its tail is enough
  in.seekg(start);
  std::string line, found;
  while (std::getline(in, line))
    if (line.starts_with("error:")) found = line;
  if (found.size() > 300) found = found.substr(0, 297) + "...";
  return found;
}

/// ": <the log's last error line>" when there is one, else "".
std::string failure_cause(const fs::path& log) {
  const std::string line = last_error_line(log);
  return line.empty() ? "" : ": " + line;
}

std::string format_seconds(double s) {
  if (s < 60) return fmt::format("{:.0f} s", s);
  if (s < 3600) return fmt::format("{:.0f} min", s / 60);
  return fmt::format("{:.1f} h", s / 3600);
}

/// The time left [s] that the progress lines give: the waiting jobs' cost and the running jobs'
/// cost still to do, at `rate` seconds per unit of cost, shared among the parallel slots (`slots`,
/// at most the jobs not done). `share_left(job)`: the share of a running job's cost still to do,
/// where its log tells it; otherwise (or without share_left) its whole cost's time less the time
/// it has run (at least 0).
double seconds_left(double rate, const JobProgress& p, const std::vector<Job>& jobs, int slots,
                    const std::function<std::optional<double>(std::size_t)>& share_left = {}) {
  double left = 0.0;
  for (const std::size_t w : p.waiting_jobs) left += rate * jobs[w].cost;
  for (const auto& [r, elapsed] : p.running_jobs) {
    const std::optional<double> share = share_left ? share_left(r) : std::nullopt;
    left += share ? rate * jobs[r].cost * *share : std::max(0.0, rate * jobs[r].cost - elapsed);
  }
  return left / static_cast<double>(std::max<std::size_t>(
                    1, std::min<std::size_t>(static_cast<std::size_t>(std::max(1, slots)),
                                             p.running + p.waiting)));
}

bool stopped_before_its_end(const fs::path& dir) {
  const std::optional<std::string> text =
      read_run_file(dir / "progress.json", "a run's progress file");
  if (!text) return false;
  const nlohmann::json j = nlohmann::json::parse(*text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return false;
  const auto step = j.find("step");
  const auto end = j.find("end_step");
  if (step == j.end() || end == j.end() || !step->is_number_unsigned() ||
      !end->is_number_unsigned() || step->get<std::uint64_t>() >= end->get<std::uint64_t>())
    return false;
  const std::optional<std::uint64_t> ended = recorded_step(dir / "final_state.json");
  return !ended || end->get<std::uint64_t>() > *ended;
}

bool interrupted_after_final_state(const fs::path& dir) {
  std::error_code ec;
  if (!fs::exists(dir / "interrupted_state.json", ec)) return false;
  const std::optional<std::uint64_t> stopped = recorded_step(dir / "interrupted_state.json");
  const std::optional<std::uint64_t> ended = recorded_step(dir / "final_state.json");
  return !stopped || !ended || *stopped > *ended;
}

nlohmann::json run_summary(const fs::path& dir) {
  const std::optional<std::string> text = read_run_file(dir / "summary.json", "a run's summary");
  if (!text) return nlohmann::json::object();
  const nlohmann::json summary = nlohmann::json::parse(*text, nullptr, false);
  return summary.is_object() ? summary : nlohmann::json::object();
}

/// A run folder's case.toml, read as `cdshear run --resume` reads it; or why it cannot be.
struct FolderCase {
  std::optional<ShearCase> c;
  std::string problem;  ///< "its case.toml cannot be read: ..." when `c` is empty
};
FolderCase folder_case(const fs::path& run_dir) {
  CaseSource source;
  source.file = (run_dir / "case.toml").string();
  try {
    ShearCase c = load_case(source);
    if (parse_toml_file(source.file).empty())  // the defaults, not the run's case
      throw ConfigError(source.file, "", kEmptyRunCaseProblem);
    return {std::move(c), ""};
  } catch (const ConfigError& e) {
    return {std::nullopt, std::string("its case.toml cannot be read: ") + e.what()};
  }
}

/// Empty when a finished run's summary.json (all a clone keeps of it; beside run.h5, its last
/// analysis) is of the run's case.toml: the summary's grain count, height, wall speed, normal
/// stress and duration match, and the folder it names (`run_dir`) has this folder's name (a
/// campaign's run names carry the system, seed and speed). Otherwise why not: a summary copied
/// from another run must not make the sweep skip this one, nor an old one its analysis.
std::string summary_problem(const fs::path& run_dir, std::string_view remedy) {
  const std::string ending = remedy.empty() ? std::string() : ": " + std::string(remedy);
  const nlohmann::json whole = run_summary(run_dir);
  const nlohmann::json summary = case_of(whole);
  const nlohmann::json written_in = whole.value("run_dir", nlohmann::json());
  fs::path written_path = written_in.is_string() ? written_in.get<std::string>() : "";
  if (written_path.filename().empty()) written_path = written_path.parent_path();  // "DIR/"
  // A run analysed from inside its folder by an older analysis recorded "." or "..": a name
  // that says nothing, judged by its case alone (as report.py does).
  const fs::path written_name = written_path.filename();
  const bool says_nothing = written_name.empty() || written_name == "." || written_name == "..";
  if (written_in.is_string() && !says_nothing && written_name != run_dir.filename())
    return fmt::format("{} is of another run (run_dir {}){}", (run_dir / "summary.json").string(),
                       json_shown(written_in, kComparedValueLimit), ending);
  const FolderCase folder = folder_case(run_dir);
  if (!folder.c) return folder.problem;
  const ShearCase& c = *folder.c;
  const nlohmann::json wanted = {{"n", c.n},
                                 {"height", c.height},
                                 {"velocity", c.velocity},
                                 {"normal_stress", c.normal_stress},
                                 {"duration", c.duration},
                                 {"initial_velocity", c.initial_velocity}};
  for (const auto& [key, value] : wanted.items()) {
    if (key == "initial_velocity" && !summary.contains(key)) continue;  // not in older summaries
    if (summary.value(key, nlohmann::json()) != value)
      return fmt::format("{} is of another run ({} = {}, its case.toml says {}){}",
                         (run_dir / "summary.json").string(), key,
                         json_shown(summary.value(key, nlohmann::json()), kComparedValueLimit),
                         json_shown(value, kComparedValueLimit), ending);
  }
  return "";
}

/// Empty when the case identity that `file` of a run folder records (`recorded`, a
/// case_identity) is that of the folder's case.toml; otherwise why not.
std::string recorded_identity_problem(const fs::path& run_dir, const fs::path& file,
                                      const nlohmann::json& recorded) {
  const FolderCase folder = folder_case(run_dir);
  if (!folder.c) return folder.problem;
  const nlohmann::json identity = case_identity(*folder.c);
  if (const std::string key = differing_identity_key(recorded, identity); !key.empty())
    return fmt::format(
        "{} is of another run ({} = {}, its case.toml says {}): remove it to run this one again",
        file.string(), key, json_shown(recorded.at(key), kComparedValueLimit),
        json_shown(identity.at(key), kComparedValueLimit));
  return "";
}

/// Empty when a finished run kept as its run.h5 alone is of the folder's case.toml: the case
/// the run.h5 records (`recorded`) has the same identity; otherwise why not.
std::string run_data_problem(const fs::path& run_dir, const std::string& recorded) {
  const fs::path file = run_dir / "run.h5";
  nlohmann::json theirs;
  try {
    theirs = case_identity(
        case_from_toml(parse_toml_text(recorded, file.string()), file.string(), ShearCase{}));
  } catch (const ConfigError& e) {
    return file.string() + ": the case it records cannot be read: " + e.what();
  }
  return recorded_identity_problem(run_dir, file, theirs);
}

/// Empty when the final state of a finished run belongs to the run's case.toml (the case
/// identity it carries matches); otherwise why not: a final_state.json copied from another run
/// must not make the sweep skip this one as finished. A final state without an identity
/// (written by an earlier cdshear) is taken as it is. A finished run kept only as its summary
/// is checked by summary_problem.
std::string final_state_problem(const fs::path& run_dir) {
  const fs::path file = run_dir / "final_state.json";
  if (!fs::exists(file)) {
    if (fs::exists(run_dir / "summary.json")) return summary_problem(run_dir);
    if (const std::optional<std::string> recorded = finished_run_data(run_dir))
      return run_data_problem(run_dir, *recorded);
    return summary_problem(run_dir);
  }
  const std::optional<std::string> text = read_run_file(file, "a run's final state");
  if (!text) return file.string() + " cannot be read";
  const nlohmann::json state = nlohmann::json::parse(*text, nullptr, false);
  if (state.is_discarded() || !state.is_object()) return file.string() + " is not JSON";
  if (!state.contains("case")) return "";
  if (!state["case"].is_object()) return file.string() + ": its \"case\" is not an object";
  return recorded_identity_problem(run_dir, file, state["case"]);
}

/// Empty when a run folder's case.toml is of the campaign's run `r` (the same case identity:
/// n, L_y, diameters, seed, V, stress, frictions, wall mass, initial velocity), or cannot be
/// read (final_state_problem and the resume name that); otherwise why not: a folder holding
/// another run (copied or renamed into place, or made before a `[set]` of its physics changed
/// under `--force`) must be neither skipped as this run nor resumed as it.
std::string folder_case_problem(const fs::path& run_dir, const CampaignRun& r) {
  const FolderCase folder = folder_case(run_dir);
  if (!folder.c) return "";
  const nlohmann::json held = case_identity(*folder.c);
  if (const std::string key = differing_identity_key(held, r.identity); !key.empty())
    return fmt::format(
        "{} is of another run ({} = {} where the campaign's run has {}): remove {} to run this "
        "one",
        (run_dir / "case.toml").string(), key, json_shown(held.at(key), kComparedValueLimit),
        json_shown(r.identity.at(key), kComparedValueLimit), run_dir.string());
  return "";
}

/// The duration [t] in a run folder's case.toml; none when it cannot be read.
std::optional<double> folder_duration(const fs::path& run_dir) {
  const FolderCase folder = folder_case(run_dir);
  return folder.c ? std::optional<double>(folder.c->duration) : std::nullopt;
}

bool final_state_short_of_case(const fs::path& dir) {
  const std::optional<std::uint64_t> ended = recorded_step(dir / "final_state.json");
  if (!ended) return false;
  FolderCase folder = folder_case(dir);
  if (!folder.c) return false;
  // the end step as the run takes it (plan_run: the time step resolved, checked_end_step)
  resolve_step_rules(*folder.c);
  const double steps = folder.c->duration / folder.c->step.dt;
  return std::isfinite(steps) && steps < 1e18 &&
         *ended < static_cast<std::uint64_t>(std::llround(steps));
}

/// The duration [t] of the run's folder (its case.toml) when the campaign asks the run for a
/// longer one (the campaign file's duration was raised after the run started or finished); none
/// otherwise.
std::optional<double> asks_for_longer(const CampaignRun& r, const fs::path& run_dir) {
  const std::optional<double> had = folder_duration(run_dir);
  if (had && r.duration > *had * (1.0 + 1e-12)) return had;
  return std::nullopt;
}

/// Where a running run stands in its current sitting, from its progress.json (written by `cdshear
/// run` every 2 s of wall time; docs/shear-cell.md, "Outputs of a run").
struct SittingProgress {
  std::optional<double> resumed_at;  ///< [t] where this sitting started (0 for a new run)
  std::optional<double> t;           ///< [t] the time reached
  double age = 0.0;                  ///< [s] since the file was written
};

/// Reads RUN_DIR/progress.json; a file that is missing, unreadable, or older than this sitting
/// (written before `sitting_seconds` ago: a killed earlier sitting's) gives an empty answer.
SittingProgress read_sitting_progress(const fs::path& run_dir, double sitting_seconds) {
  SittingProgress out;
  const std::optional<std::string> text =
      read_run_file(run_dir / "progress.json", "a run's progress file");
  if (!text) return out;
  const nlohmann::json j = nlohmann::json::parse(*text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return out;
  const auto number = [&j](const char* key) -> std::optional<double> {
    const auto it = j.find(key);
    if (it == j.end() || !it->is_number()) return std::nullopt;
    const double x = it->get<double>();
    return std::isfinite(x) ? std::optional<double>(x) : std::nullopt;
  };
  const std::optional<double> updated = number("updated_unix_seconds");
  if (!updated) return out;
  const double now =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  out.age = std::max(0.0, now - *updated);
  if (out.age > sitting_seconds + 1.0) return {};  // 1 s: the clocks' granularity
  out.resumed_at = number("sitting_start_time");
  out.t = number("time");
  return out;
}

/// The folders a sweep makes in its campaign folder.
constexpr std::array<const char*, 3> kCampaignSubfolders = {"packings", "runs", "logs"};

/// Refuses a folder that is neither new, nor empty, nor one a sweep made: a sweep writes
/// campaign.toml, packings/, runs/ and logs/ in it, over whatever holds those names. A sweep's
/// campaign.toml begins with kResolvedCampaignHeader; a folder with only a sweep's subfolders
/// (a sweep stopped before it wrote campaign.toml, or packings put there by hand) is one too.
void check_campaign_folder(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;  // made by the sweep (or refused when it cannot be)
  const fs::path file = dir / "campaign.toml";
  if (fs::exists(file, ec)) {
    // Read as the runs' files are: a FIFO in its place must not block (check_same_campaign
    // then refuses what cannot be read).
    const std::optional<std::string> text = read_run_file(file, "the campaign's file");
    if (text && !text->starts_with(kResolvedCampaignHeader))
      throw ConfigError(file.lexically_normal().string(), "",
                        "this campaign.toml was not written by a sweep (a campaign file of your "
                        "own?): the sweep would write over it; -o names a new folder, or one a "
                        "sweep made");
    return;
  }
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name == ".sweep.lock" || std::find(kCampaignSubfolders.begin(), kCampaignSubfolders.end(),
                                           name) != kCampaignSubfolders.end())
      continue;
    throw ConfigError(dir.lexically_normal().string(), "",
                      fmt::format("the folder holds '{}' and no campaign.toml of a sweep: it is "
                                  "not a campaign's folder; -o names a new or empty folder, or one "
                                  "a sweep made",
                                  name));
  }
}

/// Where the sweep records how a packing of its folder was made (`sK_seedN.source` beside
/// `sK_seedN.json`): "copied from FILE" or "prepared as CACHE_NAME" (packing_cache_name).
fs::path packing_source_file(const fs::path& packing) {
  return fs::path(packing).replace_extension(".source");
}

/// Empty when the folder's packing `p` is the one the campaign makes now (`source`, and for a
/// given packing `given_file`, whose bytes the copy must still have) and was placed with the
/// run's `seed`; otherwise how it differs. A packing without a record (made before the sweep
/// kept one, or put there by hand) is taken as it is once its seed is the run's.
std::string stale_packing(const fs::path& p, const std::string& source,
                          const std::string& given_file, std::uint64_t seed) {
  // Its seed only (any overlap with the walls accepted here): a file that cannot be read is the
  // run's to name, as for a given packing.
  try {
    const double any_overlap = std::numeric_limits<double>::infinity();
    if (const std::uint64_t placed = read_packing(p, any_overlap).seed;
        placed != seed && given_file.empty())
      return fmt::format("it was placed with seed {}, the campaign's run has seed {}", placed,
                         seed);
  } catch (const ConfigError&) {
  }
  std::string recorded =
      read_run_file(packing_source_file(p), "a packing's record").value_or(std::string());
  if (!recorded.empty() && recorded.back() == '\n') recorded.pop_back();
  if (!recorded.empty() && recorded != source)
    return fmt::format("it was {}, the campaign's run is {}", recorded, source);
  if (!given_file.empty() &&
      read_run_file(p, "a campaign's packing") != read_run_file(given_file, "a given packing"))
    return fmt::format("it differs from {}, the campaign's packing (changed since it was copied)",
                       given_file);
  return {};
}

/// Refuses a campaign that differs from the one DIR was made for, unless --force. Swept from
/// DIR/campaign.toml itself, a hand edit of that file shows as no difference: its fingerprint
/// (of the campaign the sweep wrote) then names the change. A folder whose runs/ holds runs and
/// no campaign.toml (deleted, or the runs moved in by hand) cannot be compared: refused too,
/// since a reused run is checked against the campaign by its physics alone (folder_case_problem),
/// not by the rest of [set].
void check_same_campaign(const fs::path& file, const fs::path& campaign_file, const Campaign& c,
                         bool force) {
  if (std::error_code ec; !fs::exists(file, ec)) {
    const fs::path runs = file.parent_path() / "runs";
    const auto held = std::distance(fs::directory_iterator(runs, ec), fs::directory_iterator());
    if (held == 0) return;
    const std::string what =
        fmt::format("{} holds {} run folder{} and the folder no campaign.toml",
                    runs.lexically_normal().string(), held, held == 1 ? "" : "s");
    if (!force)
      throw ConfigError(file.parent_path().lexically_normal().string(), "",
                        what +
                            ": the sweep cannot tell which campaign made them; put the "
                            "folder's campaign.toml back, choose another -o, or pass --force "
                            "to take them as this campaign's runs (each is still checked "
                            "against the campaign's physics by its case.toml)");
    std::fprintf(stderr, "warning: --force: %s; runs already there are taken as this campaign's\n",
                 what.c_str());
    return;
  }
  // Read once, as the runs' files are (a FIFO in its place does not block); what cannot be read
  // goes to parse_toml_file, which names the cause.
  const std::optional<std::string> text = read_run_file(file, "the campaign's file");
  const toml::table before =
      text ? parse_toml_text(*text, file.string()) : parse_toml_file(file.string());
  const toml::table now = campaign_to_toml(c);
  std::vector<std::string> diff = campaign_differences(before, now);
  std::error_code ec;
  if (diff.empty() && fs::equivalent(file, campaign_file, ec)) {
    const std::string recorded = recorded_fingerprint(text.value_or(std::string()));
    // Either fingerprint: a file written by a build that printed its numbers otherwise (17
    // digits) reads back to the same campaign, printed now in other text.
    if (const std::string fingerprint = campaign_fingerprint(now);
        !recorded.empty() && recorded != fingerprint && recorded != printed_fingerprint(now))
      diff.push_back(
          fmt::format("the file was changed after the sweep wrote it: fingerprint {} "
                      "in its header, {} of its campaign",
                      recorded, fingerprint));
  }
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

/// One sweep of a campaign folder, in the order `run` calls its phases: claim the folder,
/// prepare the packings, plan the runs (skip, resume or start each), run them with a progress
/// line after each and every --progress-every seconds, and sum up.
class Sweep {
 public:
  /// `remote`: null for a sweep on this machine (run_jobs, --jobs at once); under MPI, the
  /// scheduler that hands the jobs to the `ranks` ranks (rank 0 included), one at a time each.
  Sweep(const SweepArgs& args, Campaign campaign, const RemoteScheduler* remote, int ranks)
      : args_(args),
        c_(std::move(campaign)),
        remote_(remote),
        dir_(campaign_folder(args, c_)),
        exe_(fs::read_symlink("/proc/self/exe")),
        jobs_(remote != nullptr ? ranks
              : args.jobs > 0   ? args.jobs
                              : std::max(1, static_cast<int>(std::thread::hardware_concurrency()) /
                                                args.threads)),
        threads_(std::to_string(args.threads)),
        tick_every_(args.quiet ? 0.0 : args.progress_every) {
    if (remote != nullptr && args.jobs > 0)
      std::fprintf(stderr,
                   "warning: --jobs is ignored under MPI: each rank runs one run at a time\n");
  }

  int run() {
    claim_folder();
    if (!prepare_packings()) return 130;
    plan_runs();
    const ScheduleResult res = schedule(
        jobs_list_, [this](const JobEnd& e, const JobProgress& p) { on_run_end(e, p); },
        JobTick{tick_every_, [this](const JobProgress& p) { on_tick(p); }});
    return sum_up(res);
  }

 private:
  /// The runs of this sweep, in the order of jobs_list_ (analysis jobs have duration 0).
  struct Planned {
    const CampaignRun* run;
    RunState before;
  };

  ScheduleResult schedule(const std::vector<Job>& list, const JobEndCallback& on_end,
                          const JobTick& tick) const {
    return remote_ != nullptr ? (*remote_)(list, on_end, tick)
                              : run_jobs(list, jobs_, on_end, {}, tick);
  }

  std::string since_start() const {
    return format_seconds(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
  }

  /// The folder: the same campaign as before (or --force), its subfolders, and its lock. One
  /// sweep per folder at a time: two would start or resume the same runs. The lock is held
  /// until this process exits; its runs inherit the descriptor, so runs left behind by a sweep
  /// that died still hold it.
  void claim_folder() {
    check_campaign_folder(dir_);
    check_same_campaign(dir_ / "campaign.toml", args_.file, c_, args_.force);
    // Every name checked before any folder is made, so that a refusal leaves nothing behind.
    for (const char* sub : kCampaignSubfolders) {
      std::error_code ec;
      if (fs::exists(fs::symlink_status(dir_ / sub, ec)) && !fs::is_directory(dir_ / sub, ec))
        throw ConfigError((dir_ / sub).lexically_normal().string(), "",
                          fmt::format("the campaign's folder {}/ goes here, where something "
                                      "else stands: remove or rename it",
                                      sub));
    }
    for (const char* sub : kCampaignSubfolders) {
      std::error_code ec;
      fs::create_directories(dir_ / sub, ec);
      if (ec)
        throw ConfigError(dir_.string(), "",
                          fmt::format("cannot make the campaign's folder {}/ in it: {} (-o names "
                                      "the folder that holds the campaign)",
                                      sub, ec.message()));
    }
    check_log_paths();
    const fs::path lock = dir_ / ".sweep.lock";
    const int lock_fd = open_regular_file(lock, O_RDWR | O_CREAT, "the sweep's lock");
    if (lock_fd < 0)
      throw ConfigError(lock.string(), "",
                        std::string("cannot open the sweep's lock file: ") + std::strerror(errno) +
                            (errno == EISDIR ? " (a folder in its place: remove it)" : ""));
    if (::flock(lock_fd, LOCK_EX | LOCK_NB) != 0)
      throw ConfigError(dir_.string(), "",
                        "another sweep (or runs it left behind) is working in this folder; wait "
                        "for it to end, or stop it (its runs checkpoint on SIGTERM)");
    write_file_atomic(dir_ / "campaign.toml", campaign_file_text(c_));
  }

  /// The log of a job (a run, by its name, or a preparation): logs/<name>.log.
  fs::path log_of(const std::string& job_name) const { return dir_ / "logs" / (job_name + ".log"); }

  /// The job that prepares the packing of a run's (system, seed).
  static std::string preparation_name(const CampaignRun& r) {
    return fmt::format("prepare_s{}_seed{}", r.system, r.seed);
  }

  /// Each run's and each preparation's log is appended to: anything but a file in a log's
  /// place is refused here, before any job starts, rather than when its job starts (which would
  /// stop the sweep and the runs it is watching).
  void check_log_paths() const {
    for (const CampaignRun& r : c_.runs) {
      check_regular_file_if_present(log_of(r.name), "a run's log");
      check_regular_file_if_present(log_of(preparation_name(r)), "a preparation's log");
    }
  }

  /// One packing per (system, seed): copied from [campaign.packing], kept from an earlier
  /// sweep, or prepared now (in parallel). False when interrupted.
  bool prepare_packings() {
    std::vector<Job> prepare_jobs;
    for (const CampaignRun& r : c_.runs) {
      const auto key = std::make_pair(r.system, r.seed);
      if (packing_of_.contains(key)) continue;
      const fs::path p = dir_ / "packings" / fmt::format("s{}_seed{}.json", r.system, r.seed);
      packing_of_[key] = p;
      const auto given = c_.packings.find(r.system);
      const std::string source = given != c_.packings.end() ? "copied from " + given->second
                                                            : "prepared as " + r.preparation;
      if (fs::exists(p)) {
        const std::string stale = stale_packing(
            p, source, given != c_.packings.end() ? given->second : std::string(), r.seed);
        if (stale.empty()) continue;
        if (!args_.force)
          throw ConfigError(p.string(), "",
                            stale +
                                ": pass --force to make it anew (runs already there keep the "
                                "packing they started from), or choose another -o");
        // The given packing may be this very copy (its original moved away): then it is kept
        // and only its record changes, never removed.
        std::error_code same_ec;
        if (given != c_.packings.end() && fs::equivalent(given->second, p, same_ec)) {
          std::fprintf(stderr, "warning: --force: %s: %s; kept, as the campaign's packing\n",
                       p.c_str(), stale.c_str());
          write_file_atomic(packing_source_file(p), source + "\n");
          continue;
        }
        std::fprintf(stderr, "warning: --force: %s: %s; made anew\n", p.c_str(), stale.c_str());
        fs::remove(p);
      }
      write_file_atomic(packing_source_file(p), source + "\n");
      if (given != c_.packings.end()) {
        // Whole or not at all: a sweep killed mid-copy leaves no part-copy to be taken for a
        // changed packing.
        const std::optional<std::string> bytes = read_run_file(given->second, "a given packing");
        if (!bytes)
          throw ConfigError(given->second, "", "cannot be read to copy into " + p.string());
        remove_dead_writers_temporaries(p);  // as write_packing: a killed copy's file goes
        write_file_atomic(p, *bytes);
        continue;
      }
      Job j;
      j.name = preparation_name(r);
      j.argv = {exe_.string(),
                "prepare",
                "-q",
                "--system",
                std::to_string(r.system),
                "--set",
                fmt::format("system.seed={}", r.seed),
                "--threads",
                threads_,
                "-o",
                p.string()};
      for (const std::string& o : c_.overrides) j.argv.insert(j.argv.end(), {"--set", o});
      j.log = log_of(j.name);
      j.cost = r.cost();
      prepare_jobs.push_back(j);
    }
    if (prepare_jobs.empty()) return true;
    if (!args_.quiet)
      std::printf("sweep %s: preparing %zu packing%s\n", c_.name.c_str(), prepare_jobs.size(),
                  prepare_jobs.size() == 1 ? "" : "s");
    std::fflush(stdout);
    const ScheduleResult res = schedule(
        prepare_jobs,
        [&](const JobEnd& e, const JobProgress&) {
          const Job& j = prepare_jobs[e.job];
          if (!args_.quiet || e.exit_code != 0)
            std::printf(
                "sweep: %s %s (%s)%s\n", j.name.c_str(),
                e.exit_code == 0     ? "done"
                : e.exit_code == 130 ? "interrupted"
                                     : fmt::format("failed, exit {}", e.exit_code).c_str(),
                format_seconds(e.seconds).c_str(),
                e.exit_code == 0 ? "" : (", log " + j.log.string() + failure_cause(j.log)).c_str());
          std::fflush(stdout);
        },
        JobTick{tick_every_, [&](const JobProgress& p) {
                  std::printf("sweep: after %s: packings done %zu/%zu, preparing %zu, left %zu\n",
                              since_start().c_str(), p.done, prepare_jobs.size(), p.running,
                              p.waiting);
                  std::fflush(stdout);
                }});
    if (res.interrupted) {
      std::printf(
          "sweep %s: interrupted while preparing packings; run the same command again "
          "to go on\n",
          c_.name.c_str());
      return false;
    }
    return true;
  }

  /// The job of a run that is to be started, resumed or extended (a finished run whose
  /// campaign now asks for a longer duration: `state` kFinished, planned only then). A resume
  /// asks for the campaign's duration where the folder's case.toml has a shorter one.
  Job run_job(const CampaignRun& r, RunState state, const fs::path& packing) const {
    const fs::path rdir = dir_ / "runs" / r.name;
    Job j;
    j.name = r.name;
    j.log = log_of(r.name);
    j.cost = r.cost();
    if (state == RunState::kInterrupted || state == RunState::kFinished) {
      j.argv = {exe_.string(), "run", "--resume", rdir.string(), "--threads", threads_};
      if (state == RunState::kFinished || asks_for_longer(r, rdir))
        j.argv.insert(j.argv.end(), {"--set", fmt::format("shear.duration={}", r.duration)});
    } else {
      j.argv = {exe_.string(), "run",
                "--system",    std::to_string(r.system),
                "-V",          fmt::format("{}", r.velocity),
                "--set",       fmt::format("shear.duration={}", r.duration)};
      for (const std::string& o : run_case_overrides(c_, r))
        j.argv.insert(j.argv.end(), {"--set", o});
      j.argv.insert(j.argv.end(),
                    {"--packing", packing.string(), "--threads", threads_, "-o", rdir.string()});
      if (start_replaces_files(rdir)) j.argv.push_back("--force");
    }
    if (!c_.analyze) j.argv.push_back("--no-analyze");
    return j;
  }

  /// Skips finished runs (analysing those killed before their analysis), reports blown-up ones
  /// and those without a packing, resumes interrupted ones and starts the rest.
  void plan_runs() {
    for (const CampaignRun& r : c_.runs) {
      const fs::path rdir = dir_ / "runs" / r.name;
      const fs::path log = log_of(r.name);
      const RunState state = run_state(rdir);
      if (state != RunState::kNew) {
        if (const std::string problem = folder_case_problem(rdir, r); !problem.empty()) {
          failed_.push_back(fmt::format("{}: {}", r.name, problem));
          continue;
        }
      }
      if (state == RunState::kFinished) {
        if (const std::string problem = final_state_problem(rdir); !problem.empty()) {
          failed_.push_back(fmt::format("{}: {}", r.name, problem));
          continue;
        }
        if (const std::optional<double> had = asks_for_longer(r, rdir)) {
          // The campaign's duration grew: the run goes on from its last checkpoint, bit for
          // bit as if it had been asked for the longer duration from the start.
          if (!fs::exists(rdir / "checkpoint.cbor")) {
            failed_.push_back(fmt::format(
                "{}: finished at {:g} t where the campaign asks for {:g} t; extending it needs "
                "its checkpoint.cbor, which the folder no longer holds (remove {} to run it "
                "again from the start)",
                r.name, *had, r.duration, rdir.string()));
            continue;
          }
          duration_of_.push_back(r.duration);
          jobs_list_.push_back(run_job(r, RunState::kFinished, {}));
          planned_.push_back({&r, RunState::kFinished});
          continue;
        }
        // An extension stopped short of its new end whose checkpoint is gone: nothing to go on
        // from, and not finished either.
        if (!fs::exists(rdir / "checkpoint.cbor") && fs::exists(rdir / "final_state.json") &&
            extension_stopped(rdir)) {
          failed_.push_back(fmt::format(
              "{}: stopped short of the duration its case.toml asks for, and the folder no "
              "longer holds the checkpoint.cbor it would go on from (remove {} to run it again "
              "from the start)",
              r.name, rdir.string()));
          continue;
        }
        // Without run.h5 a finished run stands on its summary.json: one missing, unreadable or
        // another run's cannot be analysed again. Only where a final state made it finished:
        // without one, final_state_problem has judged the summary already.
        if (c_.analyze && !fs::exists(rdir / "run.h5") && fs::exists(rdir / "final_state.json")) {
          const bool missing = run_summary(rdir).empty();
          const std::string problem = missing ? std::string() : summary_problem(rdir, "");
          if (missing || !problem.empty()) {
            failed_.push_back(fmt::format(
                "{}: finished, but {}, and its run.h5, which a new analysis would read, is gone "
                "(remove {} to run it again)",
                r.name,
                missing ? (rdir / "summary.json").string() + " is missing or unreadable" : problem,
                rdir.string()));
            continue;
          }
        }
        ++finished_before_;
        // Killed after its last step but before (or during) its analysis: analyse and plot it
        // now, as the run would have.
        if (c_.analyze && fs::exists(rdir / "run.h5") && analysis_incomplete(rdir)) {
          Job j;
          j.name = r.name;
          j.log = log;
          j.argv = {exe_.string(), "analyze", "-q", "--plot", rdir.string()};
          analysis_jobs_.insert(jobs_list_.size());
          jobs_list_.push_back(j);
          duration_of_.push_back(0.0);
        }
        continue;
      }
      if (state == RunState::kBlownUp) {
        failed_.push_back(
            fmt::format("{}: blew up in an earlier sweep (remove {} to try again), log {}", r.name,
                        rdir.string(), log.string()));
        continue;
      }
      // A folder that holds a run's data and nothing to resume it from (its checkpoint
      // deleted): a start would replace that data; the researcher decides.
      if (state == RunState::kNew && fs::exists(rdir / "run.h5")) {
        failed_.push_back(fmt::format(
            "{}: holds a run's data (run.h5) unfinished or unreadable, and no checkpoint.cbor to "
            "resume it from; a new start would replace it (move {} aside, or remove it, to run "
            "this one again)",
            r.name, rdir.string()));
        continue;
      }
      // A start in a folder that holds files replaces cdshear's files in it (`run --force`):
      // in the campaign's own runs/, but not through a link to a folder elsewhere, which may be
      // another run's or the researcher's.
      if (std::error_code ec;
          state == RunState::kNew && fs::is_symlink(rdir, ec) && start_replaces_files(rdir)) {
        failed_.push_back(fmt::format(
            "{}: {} is a symbolic link to {}, which holds files and no run to resume; a new start "
            "would replace cdshear's files there (empty that folder, or remove the link, to run "
            "this one)",
            r.name, rdir.string(), fs::read_symlink(rdir, ec).string()));
        continue;
      }
      const fs::path packing = packing_of_.at({r.system, r.seed});
      if (!fs::exists(packing)) {
        const fs::path prepare_log = log_of(preparation_name(r));
        failed_.push_back(fmt::format("{}: its packing was not prepared, log {}{}", r.name,
                                      prepare_log.string(), failure_cause(prepare_log)));
        continue;
      }
      duration_of_.push_back(r.duration);
      jobs_list_.push_back(run_job(r, state, packing));
      planned_.push_back({&r, state});
    }
    if (args_.quiet) return;
    std::size_t resumed = 0;
    std::size_t extended = 0;
    for (const Planned& p : planned_) {
      resumed += p.before == RunState::kInterrupted;
      extended += p.before == RunState::kFinished;
    }
    std::printf(
        "sweep %s: %zu runs: %zu finished earlier%s, %zu to resume, %s%zu to start; up to %d "
        "at once%s, %s thread%s each -> %s\n",
        c_.name.c_str(), c_.runs.size(), finished_before_,
        analysis_jobs_.empty() ? ""
                               : fmt::format(" ({} to analyse)", analysis_jobs_.size()).c_str(),
        resumed, extended == 0 ? "" : fmt::format("{} to extend, ", extended).c_str(),
        planned_.size() - resumed - extended, jobs_,
        remote_ != nullptr ? " (MPI: one per rank)" : "", threads_.c_str(),
        args_.threads == 1 ? "" : "s", dir_.c_str());
    std::fflush(stdout);
  }

  /// A job ended: what its folder now says, and a progress line.
  void on_run_end(const JobEnd& e, const JobProgress& p) {
    const Job& j = jobs_list_[e.job];
    if (analysis_jobs_.count(e.job) != 0) {
      if (e.exit_code != 0)
        failed_.push_back(fmt::format("{}: finished, but its analysis failed (exit {}), log {}{}",
                                      j.name, e.exit_code, j.log.string(), failure_cause(j.log)));
      else if (!args_.quiet)
        std::printf("sweep: %s analysed (it had ended before its analysis)\n", j.name.c_str());
      std::fflush(stdout);
      return;
    }
    const RunState after = run_state(dir_ / "runs" / j.name);
    std::string what = state_name(after);
    // Stopped by an interrupt: Ctrl-C (130), or the TERM this sweep passes on when it is stopped
    // (or a TERM or HUP that reached the run before it installed its handlers: 143, 129).
    const bool stopped =
        e.exit_code == 130 ||
        (g_stop_requested.load() && (e.exit_code == 128 + SIGTERM || e.exit_code == 128 + SIGHUP));
    // An extension that ended before it wrote the longer duration into case.toml (a checkpoint
    // it could not read, a stop) leaves the run finished at its earlier end.
    const std::optional<double> had = folder_duration(dir_ / "runs" / j.name);
    const bool not_extended =
        after == RunState::kFinished && had && duration_of_[e.job] > *had * (1.0 + 1e-12);
    if (not_extended && stopped) {
      interrupted_.push_back(
          fmt::format("{} (before its extension; log {})", j.name, j.log.string()));
      what = "interrupted before its extension";
    } else if (not_extended) {
      failed_.push_back(fmt::format(
          "{}: not extended: still finished at {:g} t where the "
          "campaign asks for {:g} t, exit {}, log {}{}",
          j.name, *had, duration_of_[e.job], e.exit_code, j.log.string(), failure_cause(j.log)));
      what = fmt::format("FAILED to extend (exit {}, log {})", e.exit_code, j.log.string());
    } else if (after == RunState::kFinished) {
      ++finished_now_;
      done_cost_ += j.cost;
      done_seconds_ += e.seconds;
      if (e.exit_code != 0 && !stopped) {  // the steps ran to the end; what came after did not
        what += fmt::format(" (but exited with {}: see the log {})", e.exit_code, j.log.string());
        failed_.push_back(
            fmt::format("{}: finished, but exited with {} after its last step (its "
                        "analysis), log {}{}",
                        j.name, e.exit_code, j.log.string(), failure_cause(j.log)));
      } else if (e.exit_code != 0) {  // stopped in its analysis: the next sweep analyses it
        what += " (its analysis interrupted)";
        interrupted_.push_back(fmt::format("{} (its analysis; log {})", j.name, j.log.string()));
      }
    } else if (after != RunState::kBlownUp && stopped) {
      interrupted_.push_back(fmt::format("{} (log {})", j.name, j.log.string()));
      what = "interrupted";
    } else {
      failed_.push_back(fmt::format("{}: exit {}, {}, log {}{}", j.name, e.exit_code,
                                    failed_folder_state(after), j.log.string(),
                                    failure_cause(j.log)));
      what = fmt::format("FAILED (exit {}, log {})", e.exit_code, j.log.string());
    }
    if (args_.quiet) return;
    std::string eta;
    // Seconds per unit of cost of the runs finished in this sweep, times the cost left (a running
    // run's elapsed time subtracted), shared among the parallel slots.
    if (done_cost_ > 0 && (p.running > 0 || p.waiting > 0))
      eta = "; about " +
            format_seconds(seconds_left(done_seconds_ / done_cost_, p, jobs_list_, jobs_)) +
            " left";
    std::printf("sweep: %s %s (%s); runs done %zu/%zu, running %zu, left %zu%s\n", j.name.c_str(),
                what.c_str(), format_seconds(e.seconds).c_str(), finished_before_ + finished_now_,
                c_.runs.size(), p.running, p.waiting, eta.c_str());
    std::fflush(stdout);
  }

  /// Every --progress-every seconds: the same counts, and the time left from the seconds per
  /// unit of cost of the finished runs and of the running ones together (the seconds each has
  /// run in this sitting over the cost it has done since it started or resumed, from its
  /// progress.json), times the cost left (a running run's share from the time its progress.json
  /// has reached).
  void on_tick(const JobProgress& p) const {
    double seconds = done_seconds_, cost = done_cost_;
    std::map<std::size_t, double> share;  // running job -> share of its cost still to do
    for (const auto& [j, elapsed] : p.running_jobs) {
      const double d = duration_of_[j];
      if (!(d > 0)) continue;  // an analysis
      const SittingProgress s = read_sitting_progress(dir_ / "runs" / jobs_list_[j].name, elapsed);
      const double f0 = std::clamp(s.resumed_at.value_or(0.0) / d, 0.0, 1.0);
      if (s.t) {
        const double f = std::clamp(*s.t / d, 0.0, 1.0);
        share[j] = 1.0 - f;
        // Its elapsed time when that file was written (a clock that disagrees: now).
        const double at = s.age < elapsed ? elapsed - s.age : elapsed;
        if (f > f0 && at > 0) {
          seconds += at;
          cost += jobs_list_[j].cost * (f - f0);
        }
      } else if (s.resumed_at) {
        share[j] = 1.0 - f0;
      }
    }
    std::string eta = "; no estimate yet";
    if (cost > 0)
      eta = "; about " +
            format_seconds(seconds_left(seconds / cost, p, jobs_list_, jobs_,
                                        [&](std::size_t j) -> std::optional<double> {
                                          const auto it = share.find(j);
                                          if (it == share.end()) return std::nullopt;
                                          return it->second;
                                        })) +
            " left";
    std::printf("sweep: after %s: runs done %zu/%zu, running %zu, left %zu%s\n",
                since_start().c_str(), finished_before_ + finished_now_, c_.runs.size(), p.running,
                p.waiting, eta.c_str());
    std::fflush(stdout);
  }

  /// The final summary; the exit status: 0 when every run finished, none failed (a finished
  /// run whose analysis failed is listed as failed) and none was stopped by another's signal
  /// (a finished run's analysis included), 130 when interrupted, else 1.
  int sum_up(const ScheduleResult& res) const {
    const std::size_t finished = finished_before_ + finished_now_;
    std::printf(
        "sweep %s: %zu/%zu runs finished (%zu earlier), %zu failed, %zu interrupted, %zu "
        "not started -> %s\n",
        c_.name.c_str(), finished, c_.runs.size(), finished_before_, failed_.size(),
        interrupted_.size(), res.never.size(), dir_.c_str());
    for (const std::string& f : failed_) std::printf("  failed: %s\n", f.c_str());
    if (res.interrupted) {
      std::printf("interrupted: run the same command again to resume\n");
      return 130;
    }
    if (!interrupted_.empty())
      std::printf("  interrupted (not by this sweep): %s; run the same command again to resume\n",
                  fmt::format("{}", fmt::join(interrupted_, ", ")).c_str());
    return finished == c_.runs.size() && failed_.empty() && interrupted_.empty() ? 0 : 1;
  }

  const SweepArgs& args_;
  const Campaign c_;
  const RemoteScheduler* remote_;
  const fs::path dir_, exe_;
  const int jobs_;
  const std::string threads_;  ///< --threads of each run
  const double tick_every_;    ///< [s] between periodic progress lines; 0: none
  const std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();

  std::map<std::pair<int, std::uint64_t>, fs::path> packing_of_;  ///< (system, seed) -> packing
  std::vector<Job> jobs_list_;
  std::vector<Planned> planned_;
  std::vector<double> duration_of_;      ///< per job: the run's duration (0 for an analysis)
  std::set<std::size_t> analysis_jobs_;  ///< jobs that only analyse a finished run
  std::vector<std::string> failed_;      ///< "NAME: why, log FILE"
  std::vector<std::string> interrupted_;
  std::size_t finished_before_ = 0, finished_now_ = 0;
  double done_cost_ = 0.0, done_seconds_ = 0.0;  ///< runs that ran to the end in this sweep
};

int run_sweep(const SweepArgs& args, const RemoteScheduler* remote, int ranks) {
  Campaign c = read_campaign(args.file);
  // the runs' folders: each run records its own path (check_utf8_path)
  const fs::path dir = campaign_folder(args, c);
  check_utf8_path("--output", dir.string());
  if (args.dry_run) {  // before the folder or its lock are touched (under MPI: rank 0 only)
    std::fputs(campaign_file_text(c).c_str(), stdout);
    std::fflush(stdout);
    // The folder checked as the sweep would check it, reading only: one the sweep would refuse
    // (not a campaign's, or another campaign's without --force) is refused now.
    check_campaign_folder(dir);
    check_same_campaign(dir / "campaign.toml", args.file, c, args.force);
    return 0;
  }
  return Sweep(args, std::move(c), remote, ranks).run();
}

}  // namespace

void register_sweep_command(CLI::App& app) {
  auto args = std::make_shared<SweepArgs>();
  CLI::App* s = app.add_subcommand(
      "sweep", "Run a campaign: systems x velocities x seeds (docs/campaigns.md), resumable");
  s->add_option("campaign", args->file, "campaign file (TOML)")->check(kNonEmptyPath)->required();
  s->add_option("-o,--output", args->out_dir, "campaign folder; default campaigns/<name>")
      ->check(kNonEmptyPath);
  add_count_option(s, "--jobs", args->jobs,
                   "runs at once (default: processors / --threads, at least 1)");
  add_count_option(s, "--threads", args->threads, "solver threads of each run (default 1)");
  s->add_flag("-q,--quiet", args->quiet, "only the final summary (and failures)");
  s->add_option_function<double>(
       "--progress-every",
       [args](double seconds) {
         // Below a second the lines would come at every poll of the runs (50 ms).
         if (!(seconds == 0.0 || seconds >= 1.0) || !std::isfinite(seconds))
           throw ConfigError(
               "--progress-every", "",
               fmt::format("must be 0 (no progress lines) or at least 1 s, got {}", seconds));
         args->progress_every = seconds;
       },
       "seconds between progress lines with a time estimate from the running runs' progress "
       "(default 600, at least 1; 0: none)")
      ->transform(kNonEmptyNumber)
      ->type_name("SECONDS");
  s->add_flag("--force", args->force,
              "go on in a folder made for a changed campaign (its runs are kept)");
  s->add_flag("--dry-run", args->dry_run,
              "print the resolved campaign (every run with its duration, dt and cost), check the "
              "folder as a sweep would, and exit: nothing is prepared, run or written");
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

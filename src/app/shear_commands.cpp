// `cdshear prepare` and `cdshear run`: the shear cell of the reference study (docs/model.md
// sections 4 to 6).
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>

#include "analysis_command.hpp"
#include "build_info.hpp"
#include "case_file.hpp"
#include "commands.hpp"
#include "config_error.hpp"
#include "job_scheduler.hpp"
#include "json_reading.hpp"
#include "measurement_state.hpp"
#include "observers.hpp"
#include "outputs.hpp"
#include "packing_file.hpp"
#include "run_data_file.hpp"
#include "run_loop.hpp"
#include "run_session.hpp"
#include "scene.hpp"
#include "stop_signals.hpp"
#include "toml_text.hpp"

namespace cdshear {
namespace {

namespace fs = std::filesystem;

struct CaseArgs {
  std::string file;
  std::optional<int> system;
  std::optional<double> velocity;
  std::vector<std::string> overrides;
  bool quiet = false;
  int threads = processors_available();
  CLI::Option* threads_option = nullptr;  ///< given: exactly that many; else chosen by speed
};

CaseSource to_source(const CaseArgs& a) {
  CaseSource s;
  s.file = a.file;
  s.system = a.system;
  s.velocity = a.velocity;
  s.overrides = a.overrides;
  s.threads = a.threads;
  return s;
}

void add_case_options(CLI::App* cmd, CaseArgs& a, bool threads_chosen_by_speed) {
  add_case_choice_options(cmd, a.file, a.system, a.velocity, a.overrides);
  cmd->add_flag("-q,--quiet", a.quiet, "no status lines or progress bar");
  a.threads_option = add_threads_option(cmd, a.threads, threads_chosen_by_speed);
}

Packing prepare_with_progress(const PreparationOptions& o, bool quiet) {
  std::printf("preparing a packing: n %zu, L_y %g, diameters [%g, %g], seed %llu\n", o.n, o.height,
              o.diameter_min, o.diameter_max, static_cast<unsigned long long>(o.seed));
  std::fflush(stdout);
  Packing p;
  try {
    p = prepare_packing(
        o,
        [quiet](const PreparationProgress& pr) {
          if (quiet) return;
          std::printf(
              "  phase %d (%s)  t %9.2f  Ek/disk %10.3g  piston x %8.4f  v %10.3g  "
              "sweeps %3d\n",
              pr.phase, pr.phase == 1 ? "settling" : "piston", pr.time, pr.kinetic_energy_per_disk,
              pr.piston_x, pr.piston_speed, pr.report.solver.sweeps);
          std::fflush(stdout);
        },
        5.0, &g_stop_requested);
  } catch (const PreparationInterrupted& e) {
    std::fprintf(stderr, "%s\n", e.what());
    throw CLI::RuntimeError(130);  // like an interrupted run
  } catch (const PreparationFailed& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    throw CLI::RuntimeError(1);  // not the input's fault as such (docs/reliability.md)
  } catch (const SceneError& e) {
    // Only the loose random placement can fail this way.
    throw ConfigError("preparation", "preparation.initial_solid_fraction",
                      std::string(e.what()) + " (lower the initial solid fraction)");
  }
  std::printf(
      "prepared: L_x %.6f, solid fraction %.5f, after %.1f time units (%llu steps, %llu "
      "hit the sweep cap, %llu above the displacement bound, largest overlap %.3g)\n",
      p.length_x, p.solid_fraction, p.preparation_time,
      static_cast<unsigned long long>(p.preparation_steps),
      static_cast<unsigned long long>(p.capped_steps),
      static_cast<unsigned long long>(p.displacement_warnings), p.largest_overlap);
  return p;
}

/// Where a case comes from, for error messages: its file (or the built-in default) and whether
/// --set overrides changed it.
std::string case_source_of(const CaseArgs& a) {
  return (a.file.empty() ? std::string("built-in default case") : a.file) +
         (a.overrides.empty() ? "" : " (with --set overrides)");
}

/// Refuses a freshly prepared packing, before it is written to `destination`, whose shear cell
/// cannot be built because its period is under three largest diameters (too few disks for the
/// height): the case's doing, blamed on `case_source`'s system.n. `destination`'s folder is
/// removed if `made_folder` and it is empty. Any other problem of the cell is the packing's,
/// reported by the run's own build with the file named, as for a given packing.
void refuse_a_packing_without_a_cell(const ShearCase& c, const Packing& p,
                                     const fs::path& destination, bool made_folder,
                                     const std::string& case_source) {
  try {
    build_shear_world(c, p);
  } catch (const SceneError& e) {
    if (e.key() != "domain.length_x") return;
    if (made_folder) {
      std::error_code ec;
      fs::remove(destination.parent_path(), ec);  // only if empty
    }
    throw ConfigError(case_source, "system.n",
                      fmt::format("the prepared packing (L_x {:.6g}, not written to {}) makes no "
                                  "shear cell: {}; give more disks or a smaller system.height",
                                  p.length_x, destination.string(), e.what()));
  }
}

/// True when `path`'s folder has yet to be made (check_packing_destination makes it).
bool makes_its_folder(const fs::path& path) {
  return path.has_parent_path() && !fs::exists(path.parent_path());
}

/// The packing of a case: its packing file, or the cache entry (prepared if absent). A packing
/// prepared here whose cell cannot be sheared is refused before it is cached
/// (refuse_a_packing_without_a_cell).
std::pair<Packing, fs::path> obtain_packing(const ShearCase& c, bool quiet,
                                            const std::string& case_source) {
  const double tolerance = packing_wall_tolerance(c);
  if (!c.packing_file.empty()) return {read_packing(c.packing_file, tolerance), c.packing_file};
  const fs::path cached = fs::path("packings") / packing_cache_name(c.preparation);
  if (fs::exists(cached)) {
    Packing p = read_packing(cached, tolerance);
    // The cache's name covers the preparation's settings, not its code: say when another build
    // prepared it, so that a changed preparation is not reused unnoticed (even with --quiet). A
    // packing that records no build (the repository's, written before packings named their
    // build) is only named.
    const std::string here = build_description();
    const bool another_build = !p.build.empty() && p.build != here;
    if (!quiet || another_build) std::printf("reusing packing %s\n", cached.c_str());
    if (another_build)
      std::printf(
          "  prepared by %s;\n  this is %s: delete the file to prepare it with this build\n",
          p.build.c_str(), here.c_str());
    return {std::move(p), cached};
  }
  const bool made_folder = makes_its_folder(cached);
  check_packing_destination(cached);  // before the preparation, not after it
  Packing p = prepare_with_progress(c.preparation, quiet);
  refuse_a_packing_without_a_cell(c, p, cached, made_folder, case_source);
  write_packing(cached, p);
  std::printf("packing written to %s\n", cached.c_str());
  return {p, cached};
}

/// A packing made for another system would silently give another experiment.
void check_packing_matches(const ShearCase& c, const Packing& p, const fs::path& path) {
  const std::string file = path.string();
  check_packing_fits_case(c, p, file);
  if (p.seed != c.seed)
    std::fprintf(stderr, "warning: packing %s was placed with seed %llu, the case says %llu\n",
                 file.c_str(), static_cast<unsigned long long>(p.seed),
                 static_cast<unsigned long long>(c.seed));
  // A packing compressed under another stress is another initial density: the run is valid, but
  // not the experiment the case's preparation describes.
  const double asked = c.preparation.piston_stress;
  if (std::abs(p.piston_stress - asked) > 1e-9 * std::abs(asked))
    std::fprintf(stderr,
                 "warning: packing %s was compressed under piston_stress %.6g, the case's "
                 "preparation.piston_stress is %.6g\n",
                 file.c_str(), p.piston_stress, asked);
}

struct RunArgs {
  CaseArgs c;
  std::string out_dir;
  std::string resume_dir;
  std::string packing;
  std::optional<double> stop_at;
  bool force = false;
  bool no_analyze = false;
};

/// On resume only these may change: how long, what is written, and numerics of later steps.
/// Physics (system, shear, preparation) and the measurement's layout come from the checkpoint.
bool changeable_on_resume(const std::string& key) {
  for (const char* allowed : {"shear.duration", "output.", "step.", "solver."})
    if (key.rfind(allowed, 0) == 0) return true;
  return false;
}

void check_resume_override(const std::string& item) {
  const std::string key = override_key(item);
  if (changeable_on_resume(key)) return;
  throw ConfigError("--set " + item, key,
                    "cannot be changed on --resume (the physics and the measurement windows come "
                    "from the checkpoint); only shear.duration, output.*, step.* and solver.* can");
}

/// A path as a TOML comment may hold it: control characters (a line break would end the
/// comment, the others are refused in one) written as \xNN.
std::string path_for_comment(const fs::path& path) {
  std::string out;
  for (const char ch : path.string()) {
    const auto byte = static_cast<unsigned char>(ch);
    if (byte < 0x20 || byte == 0x7f)
      out += fmt::format("\\x{:02x}", byte);
    else
      out += ch;
  }
  return out;
}

/// The resolved case as TOML text, with the packing actually used.
std::string resolved_case_text(const ShearCase& c, const std::string& packing,
                               const fs::path& dir) {
  toml::table resolved = case_to_toml(c);
  resolved["preparation"].as_table()->insert_or_assign("packing", packing);
  std::ostringstream text;
  text << kResolvedCaseHeader << CDSHEAR_VERSION;
  if (!dir.empty()) text << "; `cdshear run --resume " << path_for_comment(dir) << "` continues it";
  text << ".\n" << toml_document_text(resolved) << '\n';
  return text.str();
}

/// A shear run ready to step: its case, folder, world and contact memory, and for a resumed run
/// the observers' state stored in the checkpoint.
struct ShearSession {
  ShearCase c;
  fs::path dir;
  World world;
  ContactDynamics dynamics;
  std::string packing_used;
  bool resuming = false;
  nlohmann::json observer_state;
  std::string case_source;     ///< where the case comes from, for error messages
  std::uint64_t end_step = 0;  ///< the step the run ends at (plan_run)
  std::string dt_warning;      ///< from the time-step rule, printed at start (empty: none)
  FolderLock lock;             ///< one writer per run folder, held until the command ends
};

/// Whether the run in `dir` wrote the files that end it at `step`: a final_state.json of that
/// step (an extension keeps its earlier end's until it reaches the new one) and a run_info
/// (run_info.json, or run_info_resume_<step>.json for a resumed sitting) of that step.
bool end_files_written(const fs::path& dir, std::uint64_t step) {
  if (recorded_step(dir / "final_state.json") != step) return false;
  return fs::exists(dir / fmt::format("run_info_resume_{}.json", step)) ||
         recorded_step(dir / "run_info.json") == step;
}

/// Resolves the time step and checks the run's size (docs/reliability.md) once the case and the
/// state it starts from are known: a run that asks for too much, or for nothing, is refused
/// before anything is prepared or written.
void plan_run(ShearSession& s) {
  ShearCase& c = s.c;
  s.dt_warning = resolve_step_rules(c);
  // A run killed after its last step's checkpoint and before its end's files (run.h5 marked
  // finished, final_state.json, run_info) resumes with no step left: it writes them.
  const bool may_end_here = s.resuming && !end_files_written(s.dir, s.world.step);
  s.end_step = checked_end_step(c.duration, c.step.dt, s.world.step, s.case_source,
                                "shear.duration", may_end_here);
}

/// A case.toml written by an earlier cdshear lacks the parameters added since: the resume runs
/// them with the current defaults (for example solver.relaxation = 1.6, where the
/// run's first part had plain Gauss-Seidel). Says so, with each value, on stderr.
void warn_of_new_defaults(const std::string& file, const ShearCase& c) {
  toml::table written;
  try {
    written = toml::parse_file(file);
  } catch (const toml::parse_error&) {
    return;  // load_case has read it already; nothing to compare if it cannot be read again
  }
  if (written.empty()) throw ConfigError(file, "", kEmptyRunCaseProblem);
  const toml::table resolved = case_to_toml(c);
  for (const std::string& key : keys_missing_from(written, resolved)) {
    const std::string value = toml_value_text(*resolved.at_path(key).node());  // a key of it
    std::fprintf(stderr,
                 "warning: %s does not set %s (written by an earlier cdshear): this resume runs "
                 "with today's value %s%s\n",
                 file.c_str(), key.c_str(), value.c_str(),
                 changeable_on_resume(key)
                     ? ("; give --set " + key + "=... to choose another").c_str()
                     : " (a resume cannot change it)");
  }
}

void open_resumed(const RunArgs& args, ShearSession& s) {
  s.resuming = true;
  s.dir = args.resume_dir;
  if (!args.c.file.empty() || args.c.system || args.c.velocity || !args.packing.empty() ||
      !args.out_dir.empty() || args.force)
    throw ConfigError("--resume " + s.dir.string(), "",
                      "a case file, --system, --velocity, --packing, -o and --force cannot be "
                      "combined with --resume: the run continues with its own case.toml");
  std::error_code error;
  const fs::file_status status = fs::status(s.dir, error);  // through a link, to what it names
  if (!fs::exists(status))
    throw ConfigError("--resume " + s.dir.string(), "",
                      fs::is_symlink(fs::symlink_status(s.dir, error))
                          ? "a link to nothing: no such folder"
                          : "no such folder");
  if (!fs::is_directory(status) && !fs::is_regular_file(status))
    throw ConfigError("--resume " + s.dir.string(), "", "is not a folder");
  if (fs::is_regular_file(status))
    throw ConfigError("--resume " + s.dir.string(), "",
                      "is a file: --resume takes the run's folder (" +
                          (s.dir.has_parent_path() ? s.dir.parent_path().string() : ".") + ")");
  const bool finished = fs::exists(s.dir / "summary.json");
  const bool checkpointed = fs::exists(s.dir / "checkpoint.cbor");
  if (!checkpointed && !finished && !fs::exists(s.dir / "case.toml"))
    throw ConfigError(s.dir.string(), "", "no checkpoint.cbor here: not a cdshear run folder");
  // Before anything is read: a run still writing this folder (before its first checkpoint too)
  // would overwrite the resume's files, and is named.
  s.lock = FolderLock::take(s.dir);
  if (!checkpointed)
    throw ConfigError(
        s.dir.string(), "",
        finished ? "a finished run without its checkpoint.cbor (git does not keep checkpoints: a "
                   "clone holds finished runs as their summaries), so the run cannot go on; run "
                   "it again from its case.toml in another folder"
                 : "a run folder without checkpoint.cbor: the run stopped before its first "
                   "checkpoint (or the file was removed), so it cannot go on; run it again from "
                   "its case.toml (-o with --force, or another folder)");
  CaseSource src;
  src.file = (s.dir / "case.toml").string();
  src.overrides = args.c.overrides;
  src.threads = args.c.threads;
  s.c = load_case(src);  // refuses an unknown or retired key as any run does
  for (const std::string& item : args.c.overrides) check_resume_override(item);
  s.case_source = src.file + (args.c.overrides.empty() ? "" : " (with --set overrides)");
  warn_of_new_defaults(src.file, s.c);
  // The step counter, the end of the run and every schedule count steps of one dt: a resume
  // that changes it (step.dt, dt_max, displacement_per_step) would end at the wrong time.
  CaseSource as_written;
  as_written.file = src.file;
  ShearCase before = load_case(as_written);
  ShearCase after = s.c;
  resolve_step_rules(before);
  resolve_step_rules(after);
  if (before.step.dt != after.step.dt) {
    // Blamed on the --set of a key of the time-step rule, as given (the last one, which wins).
    std::string blamed = "--set", key = "step.dt";
    for (const std::string& item : args.c.overrides)
      if (const std::string k = override_key(item);
          k == "step.dt" || k == "step.dt_max" || k == "step.displacement_per_step") {
        blamed = "--set " + item;
        key = k;
      }
    throw ConfigError(blamed, key,
                      fmt::format("changes the time step of the run from {} to {}: a resumed run "
                                  "keeps its time step (its steps, end and schedules count in it)",
                                  before.step.dt, after.step.dt));
  }
  const std::string checkpoint_file = (s.dir / "checkpoint.cbor").string();
  Checkpoint cp = read_checkpoint(checkpoint_file);
  const nlohmann::json identity = case_identity(s.c);
  if (!cp.case_identity.is_object())
    throw ConfigError(checkpoint_file, "case",
                      "holds no case identity: not a shear-run checkpoint");
  if (const std::string key = differing_identity_key(cp.case_identity, identity); !key.empty())
    throw ConfigError(checkpoint_file, "case." + key,
                      fmt::format("the checkpoint is of a run with {} = {}, {} says {}: it "
                                  "belongs to another run",
                                  key, json_shown(cp.case_identity.at(key), kComparedValueLimit),
                                  src.file, json_shown(identity.at(key), kComparedValueLimit)));
  if (cp.world.disks.size() != s.c.n)
    throw ConfigError(checkpoint_file, "disks",
                      fmt::format("holds {} disks, the case {}", cp.world.disks.size(), s.c.n));
  // Its world as this run's case makes it (the seal stops accidents, this a crafted file).
  if (const ShearWorldProblem bad = shear_world_problem(cp.world, after); !bad.key.empty())
    throw ConfigError(checkpoint_file, bad.key,
                      bad.problem + ": not a state of the run " + src.file + " describes");
  if (const std::string warning = instruction_set_warning(cp, checkpoint_file); !warning.empty())
    std::fprintf(stderr, "%s\n", warning.c_str());
  s.world = std::move(cp.world);
  s.dynamics.set_contacts(std::move(cp.contacts));
  s.observer_state = std::move(cp.observers);
  s.packing_used = s.c.packing_file;
  plan_run(s);
  std::printf("resuming %s at step %llu, t %.4f\n", s.dir.c_str(),
              static_cast<unsigned long long>(s.world.step), s.world.time);
}

std::uint64_t checked_stop_step(const RunArgs& args, const ShearSession& s);

void open_new(const RunArgs& args, ShearSession& s) {
  ShearCase& c = s.c;
  c = load_case(to_source(args.c));
  s.case_source = case_source_of(args.c);
  if (!args.packing.empty()) c.packing_file = args.packing;
  plan_run(s);  // the new world starts at step 0
  // --stop-at too, before the folder is claimed and the packing prepared
  checked_stop_step(args, s);
  // The output folder is claimed before the packing is obtained: a folder that cannot be used
  // must not be found out after minutes of preparation.
  if (args.out_dir.empty()) {
    // Default folder: named after the case; a new run never overwrites an earlier one but
    // takes the next free suffix (_2, _3, ...).
    const std::string base =
        fmt::format("n{}_h{}_V{}_s{}_seed{}", c.n, c.height, c.velocity, c.normal_stress, c.seed);
    s.dir = fs::path("runs") / base;
    for (int k = 2; !folder_is_free(s.dir) && !args.force; ++k)
      s.dir = fs::path("runs") / fmt::format("{}_{}", base, k);
  } else {
    s.dir = args.out_dir;
  }
  const bool existed = fs::exists(s.dir);
  fs::path outermost_made = s.dir;  // the outermost folder claiming s.dir creates
  while (!outermost_made.parent_path().empty() && outermost_made.parent_path() != outermost_made &&
         !fs::exists(outermost_made.parent_path()))
    outermost_made = outermost_made.parent_path();
  // Locked and checked now; with --force the earlier outputs are removed only once the new run
  // is known to start (its packing obtained and its world built): a refused --force loses nothing.
  s.lock = lock_output_folder(s.dir, args.force,
                              fs::exists(s.dir / "checkpoint.cbor")
                                  ? "continue it with --resume " + s.dir.string()
                                  : std::string());
  try {
    auto [packing, path] = obtain_packing(c, args.c.quiet, s.case_source);
    s.packing_used = path.string();
    check_packing_matches(c, packing, path);
    try {
      s.world = build_shear_world(c, packing);
    } catch (const SceneError& e) {
      throw ConfigError(path.string(), "", std::string("cannot build the shear cell: ") + e.what());
    }
  } catch (...) {  // the folders this command made, and left empty, go again
    if (!existed) {
      std::error_code ec;
      s.lock.remove_and_release(s.dir);
      for (fs::path p = s.dir;; p = p.parent_path()) {
        fs::remove(p, ec);  // only if empty
        if (ec || p == outermost_made || p.parent_path() == p) break;
      }
    }
    throw;
  }
  if (args.force) remove_written_outputs(s.dir);
  write_file_atomic(s.dir / "case.toml", resolved_case_text(c, s.packing_used, s.dir));
}

/// read_run_data, first tried in a child process: HDF5 may crash on a file damaged in a way its
/// seal does not catch (a crafted one), and a crash in this process would take the message with
/// it. The child only reads and exits; then this process reads the file itself.
RunData read_run_data_isolated(const fs::path& path) {
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = fork();
  if (pid == 0) {
    int code = 0;
    try {
      read_run_data(path);
    } catch (...) {
      code = 2;  // this process reads it again below and says why
    }
    _exit(code);
  }
  if (pid > 0) {
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    const int signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
    if (signal == SIGSEGV || signal == SIGBUS || signal == SIGABRT || signal == SIGFPE ||
        signal == SIGILL)  // a crash; any other end (killed, out of memory): read it here
      throw ConfigError(path.string(), "",
                        fmt::format("the HDF5 library crashed reading it (signal {}, {}): the file "
                                    "is damaged in a way its seal does not catch; nothing was "
                                    "written",
                                    signal, strsignal(signal)));
  }  // fork refused: read it here, unprotected
  return read_run_data(path);
}

/// The measurement layer of a session, restored from the checkpoint and run.h5 when resuming.
std::unique_ptr<ShearMeasurement> open_measurement(const ShearSession& s) {
  // A measured run resumed under a case.toml edited to measure nothing would leave run.h5
  // unfinished at the checkpoint's time, and the run "done" without a word.
  if (!s.c.measure.enabled && s.resuming && s.observer_state.contains("measurement"))
    throw ConfigError((s.dir / "case.toml").string(), "measure.enabled",
                      "is false, but the run was measured up to its checkpoint (run.h5): a "
                      "measured run goes on measuring; set it back to true");
  if (!s.c.measure.enabled) return nullptr;
  const MeasureContext context{s.c.step.dt, s.c.velocity, s.c.normal_stress, s.c.height};
  auto m = std::make_unique<ShearMeasurement>(s.c.measure, context, s.world);
  if (!s.resuming) return m;
  const std::string checkpoint = (s.dir / "checkpoint.cbor").string();
  if (!s.observer_state.contains("measurement"))
    throw ConfigError(checkpoint, "observers.measurement",
                      "the checkpoint holds no measurement state");
  MeasurementState state;
  try {
    state = measurement_state_from_json(s.observer_state.at("measurement"), s.world.step);
  } catch (const std::exception& e) {
    throw ConfigError(checkpoint, "observers.measurement", e.what());
  }
  // Rows and windows completed up to the checkpoint; the data file may be ahead of it.
  RunData data = read_run_data_isolated(s.dir / "run.h5");
  const std::string data_file = (s.dir / "run.h5").string();
  // The data must be this run's: another run's run.h5 copied into the folder (a V = 0.2 run's
  // under a V = 0.1 case.toml and checkpoint) would join two flows in one record.
  const auto same_run = [&](const char* key, double in_file, double in_run, const char* where) {
    if (in_file != in_run)
      throw ConfigError(data_file, key,
                        fmt::format("the data are of a run with {} = {}, {} says {}: run.h5 "
                                    "belongs to another run",
                                    key, format_number(in_file), where, format_number(in_run)));
  };
  same_run("n", static_cast<double>(data.meta.n), static_cast<double>(s.c.n), "case.toml");
  same_run("velocity", data.meta.velocity, s.c.velocity, "case.toml");
  same_run("normal_stress", data.meta.normal_stress, s.c.normal_stress, "case.toml");
  same_run("height", data.meta.height, s.c.height, "case.toml");
  same_run("seed", static_cast<double>(data.meta.seed), static_cast<double>(s.c.seed), "case.toml");
  // another realization of the same case (solver.seed) is another flow
  same_run("solver_seed", static_cast<double>(data.meta.solver_seed),
           static_cast<double>(s.c.step.solver.seed), "case.toml");
  same_run("length_x", data.meta.length_x, s.world.domain.length_x, "the checkpoint");
  // The step count, the samples and the windows are tied to the time step: a resume that
  // changes it (step.dt, step.dt_max, step.displacement_per_step) would mix two clocks.
  if (data.meta.dt != s.c.step.dt)
    throw ConfigError(data_file, "step.dt",
                      fmt::format("the run was measured with dt = {}, the resumed case gives dt = "
                                  "{}; a measured run cannot change its time step (start a new "
                                  "run from this one's final state instead)",
                                  data.meta.dt, s.c.step.dt));
  // [measure] is fixed for the whole run: an edit of case.toml is named by its key (the
  // stripes of the checkpoint and run.h5 would not match those of the edited settings). The
  // values are shown as fmt writes them, shortest round trip: two that differ never look alike.
  const MeasureOptions& o = data.options;
  const MeasureOptions& now = s.c.measure;
  const auto same_setting = [&](const char* key, const auto& in_file, const auto& in_case) {
    if (in_file != in_case)
      throw ConfigError((s.dir / "case.toml").string(), std::string("measure.") + key,
                        fmt::format("is {}, but the run was measured with {} up to its checkpoint "
                                    "(run.h5): [measure] cannot change within a run; set it back "
                                    "(or start a new run from this one's final state)",
                                    in_case, in_file));
  };
  same_setting("sample_interval", o.sample_interval, now.sample_interval);
  same_setting("window", o.window, now.window);
  same_setting("stripe_thickness", o.stripe_thickness, now.stripe_thickness);
  same_setting("stripe_span", o.stripe_span, now.stripe_span);
  same_setting("boundary_thickness", o.boundary_thickness, now.boundary_thickness);
  same_setting("force_threshold", o.force_threshold, now.force_threshold);
  same_setting("contact_gap", o.contact_gap, now.contact_gap);
  // The same settings give the same stripes; other stripes mean files of another cell.
  if (data.stripe_centres.size() != m->stripes() ||
      data.top_stripe_depths != m->top_stripe_depths())
    throw ConfigError(data_file, "measure",
                      "was written with other [measure] settings than "
                      "case.toml's: the files do not belong together");
  if (state.grain_moment.size() != s.world.disks.size() ||
      state.window.stripes.area.size() != m->stripes() ||
      state.window.top_stripes.area.size() != m->top_stripe_depths().size())
    throw ConfigError(checkpoint, "observers.measurement",
                      "does not match the run's disks or stripes");
  std::erase_if(data.series, [&](const SeriesRow& r) { return r.step > s.world.step; });
  std::erase_if(data.windows, [&](const WindowProfile& w) {
    return std::llround(w.t_end / s.c.step.dt) > static_cast<long long>(s.world.step);
  });
  if (data.series.empty() ? state.last_sample_step != 0
                          : data.series.back().step != state.last_sample_step)
    throw ConfigError(data_file, "series",
                      "ends before the checkpoint's last sample (step " +
                          std::to_string(state.last_sample_step) +
                          "): run.h5 is older than checkpoint.cbor");
  m->restore(std::move(state), std::move(data.series), std::move(data.windows));
  return m;
}

RunMetadata run_metadata(const ShearSession& s, bool finished) {
  RunMetadata meta;
  // Without the folder in its header: a resumed run's file must not depend on how DIR was spelt.
  meta.case_toml = resolved_case_text(s.c, s.packing_used, "");
  meta.n = s.world.disks.size();
  meta.length_x = s.world.domain.length_x;
  meta.height = s.c.height;
  meta.velocity = s.c.velocity;
  meta.normal_stress = s.c.normal_stress;
  meta.dt = s.c.step.dt;
  meta.seed = s.c.seed;
  meta.solver_seed = s.c.step.solver.seed;
  meta.duration = s.c.duration;
  meta.time = s.world.time;
  meta.step = s.world.step;
  meta.finished = finished;
  return meta;
}

/// progress.json: where a run stands, for `sweep` and any other tool (docs/shear-cell.md,
/// "Outputs of a run"), rewritten every 2 s of wall time and when the run ends. A failure to
/// write it is one warning: a progress file is a courtesy and never stops a run.
void write_progress_file(const fs::path& dir, const RunProgress& p, double duration,
                         std::uint64_t end_step, const char* state) {
  const nlohmann::json j = {
      {"format", "cdshear-progress"},
      {"version", 1},
      {"state", state},
      {"step", p.step},
      {"time", p.time},
      {"duration", duration},
      {"end_step", end_step},
      {"sitting_start_step", p.sitting_step},
      {"sitting_start_time", p.sitting_time},
      {"sitting_wall_seconds", p.sitting_wall_seconds},
      {"updated_unix_seconds",
       std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count()}};
  static bool warned = false;  // one warning, not one every 2 s (a full disk stays full)
  try {
    write_file_atomic(dir / "progress.json", j.dump(1) + "\n");
  } catch (const std::exception& e) {
    if (!warned) std::fprintf(stderr, "warning: %s (progress.json is not kept up)\n", e.what());
    warned = true;
  }
}

/// The step the run loop stops at: the run's end, or --stop-at's step where that comes first.
/// Refused (ConfigError) when it is no later than the state's step (planned: s.end_step and the
/// time step known; a new run's world, at step 0, not yet built).
std::uint64_t checked_stop_step(const RunArgs& args, const ShearSession& s) {
  const double dt = s.c.step.dt;
  if (args.stop_at) {
    // In steps, as the loop counts: a time within half a step of the run's is no later (at the
    // start too: not rounded up to one step, as an interval would be).
    const double steps = *args.stop_at / dt;
    const std::uint64_t stop_step = steps >= static_cast<double>(s.end_step)
                                        ? s.end_step
                                        : static_cast<std::uint64_t>(std::llround(steps));
    if (stop_step <= s.world.step)
      throw ConfigError(
          "--stop-at", "",
          stop_step == s.end_step && steps > static_cast<double>(s.world.step)
              // The run's end, not the time asked for, is what comes no later.
              ? fmt::format("{} is past the run's end, shear.duration = {:.6g}, which is not later "
                            "than the run's time {:.6g} (step {}): nothing to do; give a longer "
                            "--set shear.duration",
                            *args.stop_at, static_cast<double>(s.end_step) * dt, s.world.time,
                            s.world.step)
              : fmt::format("{} is not later than the run's time {:.6g} (step {}, dt {}): "
                            "nothing to do",
                            *args.stop_at, s.world.time, s.world.step, dt));
    return std::min(s.end_step, stop_step);
  }
  return s.end_step;
}

/// How the run loop of a shear run steps, reports and stops (run_loop.hpp): to the case's end or
/// --stop-at, status lines and the progress bar, the thread choice, and the check of the walls.
RunLoopSettings run_loop_settings(const RunArgs& args, const ShearSession& s) {
  const ShearCase& c = s.c;
  const double dt = c.step.dt;
  RunLoopSettings loop;
  loop.choose_threads = args.c.threads_option == nullptr || args.c.threads_option->count() == 0;
  loop.end_step = checked_stop_step(args, s);
  const std::uint64_t status = steps_of(c.status_interval, dt);
  loop.status_every = args.c.quiet ? 0
                      : status > 0 ? status
                                   : std::max<std::uint64_t>(1, s.end_step / 20);
  loop.progress_bar = !args.c.quiet && isatty(STDERR_FILENO);
  // Walls flying apart (or through each other) are a blow-up, not a result: L_y must stay within
  // kHeightRange times the nominal height (shear_case.hpp: a fast start may dilate the cell a
  // hundredfold before its walls come back).
  loop.check_state = [height = c.height](const World& w) {
    return wall_gap_problem(w.walls[kTopWall].point.y - w.walls[kBottomWall].point.y, height);
  };
  return loop;
}

/// What finish_run writes at the end of a shear run or sitting: run_info.json (one file per
/// resume, never overwriting an earlier one) with the run's solver and packing.
RunEnd shear_run_end(const ShearSession& s, int threads, bool threads_chosen) {
  const ShearCase& c = s.c;
  RunEnd end;
  end.dir = s.dir;
  end.case_identity = case_identity(c);
  end.reached_end = s.world.step >= s.end_step;
  end.info_name = "run_info.json";
  if (s.resuming) {
    end.info_name = fmt::format("run_info_resume_{}.json", s.world.step);
    for (int k = 2; fs::exists(s.dir / end.info_name); ++k)
      end.info_name = fmt::format("run_info_resume_{}_{}.json", s.world.step, k);
  }
  end.info = {{"resumed", s.resuming},
              {"packing", s.packing_used},
              {"dt", c.step.dt},
              {"seed", c.seed},
              {"solver_seed", c.step.solver.seed},
              {"solver_threads", threads},
              {"solver_threads_chosen_by_speed", threads_chosen}};
  end.resume_hint = "; continue with: cdshear run --resume " + shell_quoted(s.dir.string());
  end.residual_bound = c.step.solver.residual_tolerance / c.step.dt;
  return end;
}

int run_shear(const RunArgs& args) {
  check_utf8_path("--output", args.out_dir);
  check_utf8_path("--packing", args.packing);
  check_utf8_path("--resume", args.resume_dir);
  ShearSession s;
  if (args.resume_dir.empty())
    open_new(args, s);
  else
    open_resumed(args, s);
  if (!s.dt_warning.empty()) std::fprintf(stderr, "warning: %s\n", s.dt_warning.c_str());
  const ShearCase& c = s.c;
  for (const std::string& note : case_settings_without_effect(c))
    std::fprintf(stderr, "warning: %s\n", note.c_str());
  const double dt = c.step.dt;
  RunLoopSettings loop = run_loop_settings(args, s);
  const std::uint64_t end_step = s.end_step;

  // Observers: measurement (every step), snapshots, then the checkpoint, which writes run.h5
  // first and stores the measurement's running state.
  const std::unique_ptr<ShearMeasurement> measurement = open_measurement(s);
  // Every check passed. What killed writes left goes only now: a refused resume changes nothing
  // (a rename that failed leaves the newest data in such a temporary, named in its error).
  if (s.resuming) remove_stale_temporaries(s.dir);
  // Overrides given to a resume hold for later resumes too.
  if (s.resuming && !args.c.overrides.empty())
    write_file_atomic(s.dir / "case.toml", resolved_case_text(c, c.packing_file, s.dir));
  bool finished = false;
  CheckpointObserver::Hooks hooks;
  if (measurement) {
    hooks.before = [&](const World& world, const ContactDynamics& dynamics) {
      write_run_data(s.dir / "run.h5", run_metadata(s, finished), *measurement, world,
                     dynamics.contacts());
    };
    hooks.observer_state = [&] {
      return nlohmann::json{{"measurement", measurement_state_to_json(measurement->state())}};
    };
  }
  hooks.case_identity = case_identity(c);
  CheckpointObserver checkpoint(s.dir / "checkpoint.cbor", hooks);
  std::vector<ScheduledObserver> observers;
  std::optional<MeasurementObserver> measuring;
  if (measurement) observers.push_back({1, &measuring.emplace(*measurement)});
  std::unique_ptr<SnapshotObserver> snapshots;
  if (const std::uint64_t every = steps_of(c.snapshot_interval, dt); every > 0) {
    snapshots =
        std::make_unique<SnapshotObserver>(s.dir / "snapshots", dt, s.resuming ? s.world.step : 0);
    observers.push_back({every, snapshots.get()});
  }
  if (const std::uint64_t every = steps_of(c.checkpoint_interval, dt); every > 0)
    observers.push_back({every, &checkpoint});

  // Threads serve only the coloured order (docs/performance.md): say how many a step may use.
  const int threads = c.step.solver.order == ContactOrder::kColoured ? c.step.solver.threads : 1;
  std::printf(
      "cdshear run: n %zu, L_x %.4f, L_y %g, V %g, sigma_yy %g, dt %g, steps %llu..%llu, "
      "%s order, alpha %g, residual tolerance %g d, normal compliance %g, up to %d thread%s -> "
      "%s\n",
      s.world.disks.size(), s.world.domain.length_x, c.height, c.velocity, c.normal_stress, dt,
      static_cast<unsigned long long>(s.world.step), static_cast<unsigned long long>(loop.end_step),
      contact_order_name(c.step.solver.order), c.step.solver.alpha,
      c.step.solver.residual_tolerance, c.step.solver.normal_compliance, threads,
      threads == 1 ? "" : "s", s.dir.c_str());
  std::fflush(stdout);
  RunProgress last_progress;
  loop.on_progress = [&](const RunProgress& p) {
    last_progress = p;
    if (!p.last) write_progress_file(s.dir, p, c.duration, end_step, "running");
  };
  const RunSummary summary = run_until(s.world, s.dynamics, c.step, loop, observers);

  // Whatever happened, what was measured and the state reached are kept: run.h5 and the
  // checkpoint (after a blow-up only run.h5: the last good checkpoint stays).
  finished = summary.outcome == RunOutcome::kFinished && s.world.step >= end_step;
  write_progress_file(s.dir, last_progress, c.duration, end_step,
                      finished                                      ? "finished"
                      : summary.outcome == RunOutcome::kBlownUp     ? "blown up"
                      : summary.outcome == RunOutcome::kInterrupted ? "interrupted"
                                                                    : "stopped");
  if (summary.outcome != RunOutcome::kBlownUp)
    checkpoint.observe(s.world, s.dynamics, summary.last);
  else if (hooks.before)
    hooks.before(s.world, s.dynamics);
  const RunEnd end = shear_run_end(s, threads, loop.choose_threads && threads > 1);
  const int status_code = finish_run(end, s.world, summary);
  if (status_code != 0 || !finished) return status_code;
  std::printf(
      "done: output in %s (%scase.toml, final_state.json, %s, checkpoint.cbor, "
      "progress.json%s)\n",
      s.dir.c_str(), measurement ? "run.h5, " : "", end.info_name.c_str(),
      snapshots && snapshots->any() ? ", snapshots/*.pvd" : "");
  if (!measurement || args.no_analyze) return 0;
  std::fflush(stdout);
  if (const int rc = run_analysis("analyze", s.dir, {}); rc != 0) return rc;
  return run_analysis("plot", s.dir, {});
}

struct PrepareArgs {
  CaseArgs c;
  std::string output;
};

int run_prepare(const PrepareArgs& args) {
  const ShearCase c = load_case(to_source(args.c));
  // Where `run` looks for the case's packing: -o, else preparation.packing, else the cache.
  const fs::path out = !args.output.empty() ? fs::path(args.output)
                       : !c.packing_file.empty()
                           ? fs::path(c.packing_file)
                           : fs::path("packings") / packing_cache_name(c.preparation);
  const bool made_folder = makes_its_folder(out);
  check_packing_destination(out);  // before the preparation, not after it
  const Packing p = prepare_with_progress(c.preparation, args.c.quiet);
  refuse_a_packing_without_a_cell(c, p, out, made_folder, case_source_of(args.c));
  write_packing(out, p);
  std::printf("packing written to %s (L_x %.6f, solid fraction %.5f)\n", out.c_str(), p.length_x,
              p.solid_fraction);
  return 0;
}

}  // namespace

void register_shear_commands(CLI::App& app) {
  auto prep = std::make_shared<PrepareArgs>();
  CLI::App* p = app.add_subcommand(
      "prepare",
      "Prepare a packing (model.md section 5): settle, then compress with a piston to equilibrium");
  add_case_options(p, prep->c, false);
  p->add_option("-o,--output", prep->output,
                "packing file; default preparation.packing, else packings/<parameters>.json (the "
                "cache `run` uses)")
      ->check(kNonEmptyPath);
  p->callback([prep]() {
    if (const int rc = run_prepare(*prep); rc != 0) throw CLI::RuntimeError(rc);
  });

  auto run = std::make_shared<RunArgs>();
  CLI::App* r = app.add_subcommand(
      "run",
      "Shear a packing between walls at -V and +V (model.md section 4); no arguments: system 1 "
      "demo");
  add_case_options(r, run->c, true);
  r->add_option("-o,--output", run->out_dir,
                "output folder; default runs/n<n>_h<L_y>_V<V>_s<sigma_yy>_seed<seed>[_2, _3...]")
      ->check(kNonEmptyPath);
  r->add_option("--packing", run->packing, "packing file to shear (default: cached by parameters)")
      ->check(kNonEmptyPath);
  r->add_option("--resume", run->resume_dir, "continue the run in this folder from its checkpoint")
      ->check(kNonEmptyPath);
  r->add_flag("--force", run->force, "overwrite an existing run folder");
  r->add_flag("--no-analyze", run->no_analyze,
              "do not run `cdshear analyze` and `cdshear plot` at the end");
  r->add_option_function<double>(
       "--stop-at",
       [run](double t) {
         if (!(t > 0.0) || !std::isfinite(t))
           throw ConfigError("--stop-at", "", "must be a time > 0, got " + std::to_string(t));
         run->stop_at = t;
       },
       "stop (with a checkpoint) once simulated time reaches this; resume later")
      ->transform(kNonEmptyNumber);
  r->callback([run]() {
    if (const int rc = run_shear(*run); rc != 0) throw CLI::RuntimeError(rc);
  });
}

}  // namespace cdshear

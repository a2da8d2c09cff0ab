// `cdshear scene`: runs any system described by a scene file for its [run] duration.
#include <fmt/format.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "case_settings.hpp"
#include "commands.hpp"
#include "config_error.hpp"
#include "observers.hpp"
#include "outputs.hpp"
#include "run_loop.hpp"
#include "run_session.hpp"
#include "scene_file.hpp"
#include "stop_signals.hpp"
#include "toml_text.hpp"

namespace cdshear {
namespace {

struct SceneArgs {
  std::string file;
  std::vector<std::string> overrides;
  std::string out_dir;
  bool quiet = false;
  bool force = false;
  int threads = processors_available();
};

int run_scene(const SceneArgs& args) {
  SceneFile sf = load_scene_file(args.file, args.overrides);
  sf.step.solver.threads = args.threads;
  for (const std::string& note :
       solver_settings_without_effect(sf.step.solver, SolverOptions{}, "solver"))
    std::fprintf(stderr, "warning: %s\n", note.c_str());
  World world;
  try {
    world = build_world(sf.scene, &g_stop_requested);
  } catch (const SceneError& e) {
    const std::string source =
        e.other_key().empty() ? sf.source_of({e.key()}) : sf.source_of({e.key(), e.other_key()});
    throw ConfigError(source, e.key(), e.what());
  } catch (const PlacementCancelled& e) {
    std::fprintf(stderr, "%s; nothing was written\n", e.what());
    return 130;
  }
  const std::uint64_t end_step = checked_end_step(
      sf.run.duration, sf.step.dt, 0, sf.source_of({"run.duration", "step.dt"}), "run.duration");
  if (sf.run.sample_every > end_step)  // rows are written at the multiples of sample_every
    throw ConfigError(sf.source_of({"run.sample_every", "run.duration", "step.dt"}),
                      "run.sample_every",
                      fmt::format("is {} steps, more than the run's {} (run.duration / step.dt): "
                                  "timeseries.csv would hold no row",
                                  sf.run.sample_every, end_step));
  const std::filesystem::path dir(args.out_dir);
  const FolderLock lock = claim_output_folder(dir, args.force, "");
  write_file_atomic(dir / "scene.toml", std::string(kResolvedSceneHeader) + CDSHEAR_VERSION ".\n" +
                                            toml_document_text(sf.resolved) + '\n');

  RunLoopSettings loop;
  loop.end_step = end_step;
  loop.status_every =
      sf.run.status_every > 0 ? sf.run.status_every : std::max<std::uint64_t>(1, end_step / 20);
  if (args.quiet) loop.status_every = 0;
  loop.progress_bar = !args.quiet && isatty(STDERR_FILENO);

  TimeSeriesObserver series(dir / "timeseries.csv", world, sf.run.sample_every);
  const ScheduledObserver observers[] = {{1, &series}};
  std::printf("cdshear scene %s: %zu disks, %zu walls, dt %g, %llu steps -> %s\n",
              args.file.c_str(), world.disks.size(), world.walls.size(), sf.step.dt,
              static_cast<unsigned long long>(end_step), dir.c_str());
  ContactDynamics dynamics;
  const RunSummary summary = run_until(world, dynamics, sf.step, loop, observers);

  RunEnd end;
  end.dir = dir;
  end.reached_end = world.step >= end_step;
  end.resume_hint =
      "; a scene does not resume: run it again with --force to start over (`cdshear run` "
      "resumes from its checkpoints)";
  end.info = {{"scene", args.file}, {"overrides", args.overrides}, {"seed", sf.step.solver.seed}};
  const int status = finish_run(end, world, summary);
  if (status == 0)
    std::printf("output in %s (timeseries.csv, final_state.json, run_info.json, scene.toml)\n",
                dir.c_str());
  return status;
}

}  // namespace

void register_scene_command(CLI::App& app) {
  auto args = std::make_shared<SceneArgs>();
  CLI::App* cmd = app.add_subcommand("scene", "Run a system described by a scene file (TOML)");
  cmd->add_option("file", args->file, "scene file")->check(kNonEmptyPath)->required();
  cmd->add_option("--set", args->overrides, "override a key: --set step.dt=1e-4 (repeatable)");
  add_threads_option(cmd, args->threads, false);
  cmd->add_option("-o,--output", args->out_dir, "output folder")->check(kNonEmptyPath)->required();
  cmd->add_flag("-q,--quiet", args->quiet, "no status lines or progress bar");
  cmd->add_flag("--force", args->force, "replace the results of an earlier run in the folder");
  cmd->callback([args]() {
    const int rc = run_scene(*args);
    if (rc != 0) throw CLI::RuntimeError(rc);
  });
}

}  // namespace cdshear

#include "run_session.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <vector>

#include <cmath>
#include <cstdio>

#include "build_info.hpp"
#include "config_error.hpp"
#include "outputs.hpp"

namespace cdshear {

std::uint64_t steps_of(double interval, double dt) {
  return interval > 0 ? std::max<std::uint64_t>(1, std::llround(interval / dt)) : 0;
}

bool folder_is_free(const std::filesystem::path& dir) {
  std::error_code ec;
  return !std::filesystem::exists(dir, ec) ||
         (std::filesystem::is_directory(dir, ec) && std::filesystem::is_empty(dir, ec));
}

void claim_output_folder(const std::filesystem::path& dir, bool force, const std::string& hint) {
  namespace fs = std::filesystem;
  if (fs::exists(dir) && !fs::is_directory(dir))
    throw ConfigError(dir.string(), "", "exists and is not a folder");
  if (!folder_is_free(dir)) {
    if (!force) {
      std::vector<std::string> names;
      for (const fs::directory_entry& e : fs::directory_iterator(dir))
        names.push_back(e.path().filename().string());
      std::sort(names.begin(), names.end());
      if (names.size() > 4) names.resize(4), names.push_back("...");
      throw ConfigError(dir.string(), "",
                        fmt::format("already holds results ({}); {}choose another -o, or pass "
                                    "--force to replace them",
                                    fmt::join(names, ", "), hint.empty() ? "" : hint + ", "));
    }
    // --force: remove what cdshear writes, nothing else.
    for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
      const std::string name = e.path().filename().string();
      const bool ours = name == "case.toml" || name == "scene.toml" || name == "run.h5" ||
                        name == "summary.json" || name == "checkpoint.cbor" ||
                        name == "timeseries.csv" || name == "final_state.json" ||
                        name == "interrupted_state.json" || name == "blowup_state.json" ||
                        name == "figures" || name == "snapshots" || name.rfind("run_info", 0) == 0;
      if (ours) fs::remove_all(e.path());
    }
  }
  fs::create_directories(dir);
}

std::uint64_t checked_end_step(double duration, double dt, std::uint64_t current_step,
                               const std::string& source, const std::string& key) {
  const double steps = duration / dt;
  if (!std::isfinite(steps) || steps > kMaxRunSteps)
    throw ConfigError(source, key,
                      fmt::format("duration {:.6g} with dt {:.6g} asks for {:.3g} steps, more than "
                                  "the limit of {:.0e} (docs/reliability.md)",
                                  duration, dt, steps, kMaxRunSteps));
  const auto end = static_cast<std::uint64_t>(std::llround(steps));
  if (end <= current_step)
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
  write_file_atomic(end.dir / state_name, state_to_json(world).dump(1) + "\n");
  if (end.reached_end && summary.outcome == RunOutcome::kFinished)
    fs::remove(end.dir / "interrupted_state.json");  // stale once the run is complete
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
  std::printf(
      "%llu steps in %.1f s (%.0f steps/s), sweeps mean %.1f largest %d, capped %llu, largest "
      "overlap %.3g\n",
      static_cast<unsigned long long>(summary.steps), summary.wall_seconds,
      summary.wall_seconds > 0 ? summary.steps / summary.wall_seconds : 0.0, summary.mean_sweeps,
      summary.largest_sweeps, static_cast<unsigned long long>(summary.capped_steps),
      summary.largest_overlap);
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

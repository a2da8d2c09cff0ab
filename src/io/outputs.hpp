// Output files written during and after a run: the global time series (CSV, appended row by
// row) and full states (JSON, written to a temporary name and renamed, so a reader never sees
// half a state).
#pragma once

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "contact_dynamics.hpp"
#include "interval_stats.hpp"
#include "world.hpp"

namespace cdshear {

/// The temporary file a write to `path` goes through before its rename: `path`.tmp.<pid>, in the
/// same folder, unique per process (two runs sharing a folder or a packing cache never share one).
std::filesystem::path temporary_path(const std::filesystem::path& path);

/// The inverse of temporary_path on a file name: for <name>.tmp.<pid> (what a killed atomic write
/// leaves), <name>; none for any other name.
std::optional<std::string_view> temporary_of(std::string_view name);

/// Removes what killed writes to `path` left: its temporary_path of every process that no longer
/// runs (a process still running may be writing it). For files that can be made again, such as
/// a packing (write_packing calls it); a run's folder keeps its own rule
/// (remove_stale_temporaries, run_session.hpp).
void remove_dead_writers_temporaries(const std::filesystem::path& path);

/// Writes `text` to `path` atomically (temporary_path, then rename).
void write_file_atomic(const std::filesystem::path& path, const std::string& text);

/// Every disk's position (wrapped and unwrapped), velocity, angular velocity, radius; every
/// wall's state and last contact force; time and step.
nlohmann::json state_to_json(const World& world);

/// One CSV row per sample: step, time, kinetic energy, momentum, contacts, active contacts, the
/// solver figures of the interval since the previous row (steps that hit the cap, mean and
/// largest sweeps, largest residual, largest overlap), then position, velocity, contact force of
/// the last step and contact impulse since the start (its time integral) of each wall (columns
/// named after the walls). Rows are flushed at every sample so an interrupted run keeps what it
/// measured.
class TimeSeriesWriter {
 public:
  /// The columns before the walls', then each wall's: its name followed by each suffix.
  static constexpr std::array<std::string_view, 12> kColumns = {
      "step",        "time",       "kinetic_energy",  "momentum_x",
      "momentum_y",  "contacts",   "active_contacts", "capped_steps",
      "sweeps_mean", "sweeps_max", "residual_max",    "max_overlap"};
  static constexpr std::array<std::string_view, 8> kWallColumnSuffixes = {
      "_x", "_y", "_vx", "_vy", "_fx", "_fy", "_jx", "_jy"};

  TimeSeriesWriter(const std::filesystem::path& path, const World& world);
  void write(const World& world, const StepReport& report, const IntervalStats& interval);

 private:
  std::ofstream out_;
};

}  // namespace cdshear

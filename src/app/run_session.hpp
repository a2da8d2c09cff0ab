// What every run command does once its loop returns, in one place: the state file, the run
// information (JSON with the loop's summary), the summary line, the message for an early stop,
// and the exit status (0 done, 130 interrupted, 3 blown up).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "run_loop.hpp"

namespace cdshear {

struct RunEnd {
  std::filesystem::path dir;
  std::string info_name = "run_info.json";
  nlohmann::json info;       ///< the command's own fields; version, state hash, summary are added
  bool reached_end = false;  ///< the run reached its end time
  std::string resume_hint;   ///< for a run stopped early: how to continue (empty: none)
};

int finish_run(const RunEnd& end, const World& world, const RunSummary& summary);

/// Whole number of steps in a time interval (0 when the interval is 0: disabled).
std::uint64_t steps_of(double interval, double dt);

}  // namespace cdshear

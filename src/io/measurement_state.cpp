#include "measurement_state.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "json_reading.hpp"

namespace cdshear {

using nlohmann::json;

void to_json(json& j, const Vec2& v) {
  j = json::array({v.x, v.y});
}
void from_json(const json& j, Vec2& v) {
  v = {j.at(0).get<double>(), j.at(1).get<double>()};
}
void to_json(json& j, const Tensor2& t) {
  j = json::array({t.xx, t.xy, t.yx, t.yy});
}
void from_json(const json& j, Tensor2& t) {
  t = {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>(), j.at(3).get<double>()};
}
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(IntervalStats, steps, capped_steps, sweeps_sum, sweeps_max,
                                   residual_max, overlap_max)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(StripeSums, area, velocity_area, mass, mass_vx, mass_vy,
                                   mass_vxx, mass_vxy, mass_vyy, material_vx, material_vxx,
                                   material_vxy, material_vyy, coordination_area, carrying_area,
                                   stress_xx, stress_xy, stress_yx, stress_yy)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(WindowSums, samples, step_start, bottom_impulse_start,
                                   top_impulse_start, height_sum, com_vx_sum, slip_bottom_sum,
                                   slip_top_sum, slip_bottom_count, slip_top_count, stripes,
                                   top_stripes)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(MeasurementState, window, grain_moment, interval,
                                   last_sample_step, last_sample_time, bottom_impulse_last,
                                   top_impulse_last)

json measurement_state_to_json(const MeasurementState& state) {
  json j = state;
  j["definitions"] = kMeasurementDefinitions;
  return j;
}

namespace {

// The library converts a negative or fractional number into an unsigned field without a word
// (-1 becomes 2^64 - 1), and CBOR holds NaN and infinities that JSON cannot: every count is checked
// to be a whole number >= 0 and every other number to be finite before the state is converted.
void check_numbers(const json& j, const std::string& path) {
  if (j.is_object()) {
    for (const auto& [key, value] : j.items())
      check_numbers(value, path.empty() ? key : path + "." + key);
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i)
      check_numbers(j[i], path + "[" + std::to_string(i) + "]");
  } else if (j.is_number_float() && !std::isfinite(j.get<double>())) {
    throw std::runtime_error("a damaged measurement state: key '" + path + "' is not finite");
  }
}

void check_count(const json& j, const char* pointer, const char* name, std::uint64_t largest) {
  const json::json_pointer at(pointer);
  if (!j.contains(at)) return;  // named by the conversion below
  const json& v = j.at(at);
  if (!is_whole_number(v) || v.get<std::uint64_t>() > largest)
    throw std::runtime_error("a damaged measurement state: key '" + std::string(name) +
                             "' must be a whole number " +
                             (largest == std::numeric_limits<std::uint64_t>::max()
                                  ? std::string(">= 0")
                                  : "from 0 to " + std::to_string(largest)) +
                             ", not " + json_shown(v));
}

}  // namespace

MeasurementState measurement_state_from_json(const json& j, std::uint64_t step) {
  if (!j.is_object() || !j.contains("definitions") ||
      j.at("definitions") != kMeasurementDefinitions)
    throw std::runtime_error(
        "written by a cdshear whose measurements differ from this one's (Z from closed "
        "contacts, the stress without the rotational flux, the top layer's stripes counted "
        "down from the top wall): a measured run cannot be resumed "
        "across the change; "
        "start a new run, from this run's final state if needed");
  check_numbers(j, "");
  constexpr std::uint64_t kAnyCount = std::numeric_limits<std::uint64_t>::max();
  // Nothing measured after the checkpoint's step, at most one sample a step.
  check_count(j, "/window/samples", "window.samples", step + 1);
  check_count(j, "/window/step_start", "window.step_start", step);
  check_count(j, "/window/slip_bottom_count", "window.slip_bottom_count", kAnyCount);
  check_count(j, "/window/slip_top_count", "window.slip_top_count", kAnyCount);
  check_count(j, "/interval/steps", "interval.steps", kAnyCount);
  check_count(j, "/interval/capped_steps", "interval.capped_steps", kAnyCount);
  check_count(j, "/interval/sweeps_max", "interval.sweeps_max",
              static_cast<std::uint64_t>(std::numeric_limits<int>::max()));
  check_count(j, "/last_sample_step", "last_sample_step", step);
  MeasurementState state;
  try {
    state = j.get<MeasurementState>();
  } catch (const json::exception& e) {
    // The library's words without its tag ("key 'window' not found").
    throw std::runtime_error("a damaged measurement state: " + json_message(e));
  }
  if (state.interval.capped_steps > state.interval.steps)
    throw std::runtime_error("a damaged measurement state: key 'interval.capped_steps' (" +
                             std::to_string(state.interval.capped_steps) +
                             ") counts more steps than 'interval.steps' (" +
                             std::to_string(state.interval.steps) + ")");
  for (const StripeSums* sums : {&state.window.stripes, &state.window.top_stripes})
    if (!sums->same_size())
      throw std::runtime_error("its stripe sums have unequal lengths: a damaged checkpoint");
  return state;
}

}  // namespace cdshear

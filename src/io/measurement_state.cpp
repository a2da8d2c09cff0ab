#include "measurement_state.hpp"

#include <stdexcept>

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
MeasurementState measurement_state_from_json(const json& j) {
  if (!j.is_object() || !j.contains("definitions") ||
      j.at("definitions") != kMeasurementDefinitions)
    throw std::runtime_error(
        "written by a cdshear whose measurements differ from this one's (Z from closed "
        "contacts, the stress without the rotational flux, the top layer's stripes counted "
        "down from the top wall): a measured run cannot be resumed "
        "across the change; "
        "start a new run, from this run's final state if needed");
  MeasurementState state;
  try {
    state = j.get<MeasurementState>();
  } catch (const json::exception& e) {
    // The library's words without its tag ("[json.exception.out_of_range.403] key 'window' not
    // found" -> "key 'window' not found").
    const std::string what = e.what();
    const std::size_t tag_end = what.rfind("] ", what.find(' '));
    throw std::runtime_error("a damaged measurement state: " +
                             (tag_end == std::string::npos ? what : what.substr(tag_end + 2)));
  }
  for (const StripeSums* sums : {&state.window.stripes, &state.window.top_stripes})
    if (!sums->same_size())
      throw std::runtime_error("its stripe sums have unequal lengths: a damaged checkpoint");
  return state;
}

}  // namespace cdshear

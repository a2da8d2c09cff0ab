// The measurement layer's running state (open window, per-grain contact moments, interval
// statistics) as JSON, stored in the checkpoint (CBOR keeps doubles bit-exact) so that a resumed
// run measures exactly as the uninterrupted one.
#pragma once

#include <cstdint>

#include <nlohmann/json.hpp>

#include "shear_measurement.hpp"

namespace cdshear {

/// The version of the measurement definitions a checkpoint's open window was summed with (4: Z
/// from closed contacts, the rotational flux beside the stress, the top layer's stripes counted
/// down from the top wall). A window cannot be continued with other definitions.
inline constexpr int kMeasurementDefinitions = 4;

nlohmann::json measurement_state_to_json(const MeasurementState& state);
/// Throws std::exception (caught by the checkpoint reader) on a malformed object, or on one that
/// does not fit the checkpoint's `step` (a window or a sample after it, more samples than steps).
MeasurementState measurement_state_from_json(const nlohmann::json& j, std::uint64_t step);

}  // namespace cdshear

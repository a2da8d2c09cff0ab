// The run's data file `run.h5` (HDF5; layout in docs/run-data.md): the measurement layer's
// series and windows, a snapshot of the state with its force network, and the metadata.
// Written whole to a temporary name and renamed (a reader never sees half a file); read back on
// resume and by tests.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "contact.hpp"
#include "shear_measurement.hpp"
#include "world.hpp"

namespace cdshear {

/// run.h5's format_version. 3: Z counts closed contacts (measure.contact_gap) and the per-step
/// count is force_carrying_coordination; rotational_stress (a diagnostic, not in the stress);
/// the series carry block_vx and closed; stripe_span. 4: the top layer from stripes counted down
/// from the top wall (windows/top_stripes). Versions 1 to 3 are read by the analysis
/// (docs/run-data.md), not resumed.
inline constexpr int kRunDataFormatVersion = 4;

struct RunMetadata {
  std::string case_toml;  ///< the resolved case
  std::size_t n = 0;
  double length_x = 0.0, height = 0.0, velocity = 0.0, normal_stress = 0.0, dt = 0.0;
  std::uint64_t seed = 0, solver_seed = 0;
  double duration = 0.0;
  double time = 0.0;  ///< how far the data goes
  std::uint64_t step = 0;
  bool finished = false;
};

/// What read_run_data gives back (the snapshot is not read: it is for figures).
struct RunData {
  RunMetadata meta;
  MeasureOptions options;
  std::vector<double> stripe_centres;
  std::vector<double> top_stripe_depths;  ///< windows/top_stripes/depth
  std::vector<SeriesRow> series;
  std::vector<WindowProfile> windows;
};

/// Writes everything `measurement` holds, with `world` and `contacts` as the snapshot.
void write_run_data(const std::filesystem::path& path, const RunMetadata& meta,
                    const ShearMeasurement& measurement, const World& world,
                    const std::vector<Contact>& contacts);

/// Reads a run.h5; throws ConfigError naming the file and the dataset for anything missing,
/// truncated or not HDF5.
RunData read_run_data(const std::filesystem::path& path);

}  // namespace cdshear

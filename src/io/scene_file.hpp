// Scene files (TOML) -> SceneDefinition + step and run settings. Schema: docs/scene-files.md.
#pragma once

#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "contact_dynamics.hpp"
#include "scene.hpp"
#include "toml_reader.hpp"

namespace cdshear {

/// How long to run and how often to report and sample.
struct RunSettings {
  double duration = 1.0;           ///< simulated time to run [time]
  std::uint64_t status_every = 0;  ///< steps between status lines (0: about 20 per run)
  std::uint64_t sample_every = 1;  ///< steps between time-series rows
};

struct SceneFile {
  SceneDefinition scene;
  StepOptions step;
  RunSettings run;
  toml::table resolved;  ///< the table after overrides, written beside the results
  std::string file;      ///< the scene file's path
  std::shared_ptr<const OverrideSources> sources;  ///< keys given on the command line
  /// Where a problem at, or between, the full dotted `keys` is blamed (blamed_source).
  std::string source_of(std::initializer_list<std::string> keys) const {
    return blamed_source(file, sources.get(), keys);
  }
};

/// Reads `path`, applies `overrides` ("key=value"), validates. Throws ConfigError naming the
/// file and key of the first problem (unknown key, wrong type, bad value, overlapping disks).
SceneFile load_scene_file(const std::string& path, const std::vector<std::string>& overrides);

/// The [solver] table of a scene file (the rows of solver_settings(), which case files share);
/// absent keys keep `base`'s values.
SolverOptions read_solver_options(TomlReader& solver, SolverOptions base);

/// The [step] and [solver] tables of a scene file.
StepOptions read_step_options(TomlReader& step, TomlReader& solver);

AxisMode parse_axis_mode(TomlReader& t, const std::string& key);

}  // namespace cdshear

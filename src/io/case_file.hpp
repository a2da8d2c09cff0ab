// Shear-case files (TOML) -> ShearCase, with presets and --set overrides. Schema:
// docs/case-files.md. The resolved case is written back as TOML beside the results.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <toml++/toml.h>
#include <nlohmann/json.hpp>

#include "shear_case.hpp"
#include "toml_reader.hpp"

namespace cdshear {

struct CaseSource {
  std::string file;                    ///< case file; empty: built-in default
  std::optional<int> system;           ///< --system K preset, applied before the file
  std::optional<double> velocity;      ///< --velocity V, applied after the file
  std::vector<std::string> overrides;  ///< --set key=value, applied last
  int threads = 1;  ///< --threads: solver threads (not part of the case: no effect on results)
};

/// Builds the case: defaults (system 1), then the preset, then the file, then --velocity, then
/// the overrides. Throws ConfigError naming the file (or "--set ...") and the key.
ShearCase load_case(const CaseSource& source);

/// The case's settings that differ from the defaults and change nothing under the others, each as
/// "key = value has no effect: why": solver_settings_without_effect on [solver], and the slab
/// correction in a cell too short for its bands. Printed as warnings by `run` and `settings`.
std::vector<std::string> case_settings_without_effect(const ShearCase& c);

/// Reads a complete case from a TOML table (as written by case_to_toml); `file` names it in
/// errors.
ShearCase case_from_toml(const toml::table& table, const std::string& file, ShearCase base,
                         std::shared_ptr<const OverrideSources> sources = nullptr);

/// The physics a run's files belong to (the system, the wall speed and stress, the frictions,
/// the wall mass and the initial velocity), stored in its checkpoint and final state: a file
/// copied from another run is refused where it is read against this run's case.toml.
nlohmann::json case_identity(const ShearCase& c);

/// The first key of `wanted` (a case_identity) whose value the `stored` identity (an object)
/// holds differently; empty when none. A key `stored` lacks is not compared: a file of an
/// earlier cdshear did not record it.
std::string differing_identity_key(const nlohmann::json& stored, const nlohmann::json& wanted);

/// Every parameter of the case, as TOML (the resolved case).
toml::table case_to_toml(const ShearCase& c);

/// The dotted keys of `resolved` (case_to_toml of a case) that `table` (a case file as written)
/// does not hold: in a case.toml written by an earlier cdshear, the parameters that the current
/// defaults now fill in (a resume then runs them with today's defaults).
std::vector<std::string> keys_missing_from(const toml::table& table, const toml::table& resolved);

}  // namespace cdshear

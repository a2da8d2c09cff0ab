// Every setting of a shear case, defined once: its table and key, type, unit, range, phase and
// meaning, and where it lives in ShearCase. The case reader and writer (case_file.cpp), `--set`,
// the resolved case.toml, `cdshear settings` and docs/case-files.md all come from this table;
// scene files read their [solver] table from the same solver rows.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <variant>
#include <vector>

#include "nlgs_solver.hpp"
#include "shear_case.hpp"
#include "toml_reader.hpp"

namespace cdshear {

/// What a key holds in TOML.
enum class SettingType {
  kNumber,        ///< a finite number (integers accepted)
  kInteger,       ///< a whole number
  kBoolean,       ///< true or false
  kString,        ///< free text (a path)
  kChoice,        ///< one of `choices`
  kNumberList,    ///< a non-empty array of numbers, each in the range
  kNumberOrAuto,  ///< a number in the range, or the string "auto"
};

/// The phase of a run a setting acts on: the preparation of the packing, the shear run (its
/// step, solver, measurements and outputs), or both (what the packing is made of).
enum class SettingPhase { kBoth, kPreparation, kShear };

/// A value as TOML holds it: "auto" of kNumberOrAuto is the string.
using SettingValue = std::variant<double, std::int64_t, bool, std::string, std::vector<double>>;

/// One key of a settings table over the struct T (ShearCase for case files, SolverOptions for
/// the [solver] table of scene files).
template <class T>
struct Setting {
  std::string table;  ///< TOML table ("" for a scene file's [solver] rows before they are placed)
  std::string key;
  SettingType type = SettingType::kNumber;
  std::string unit;     ///< "d", "t", "d/t", ... ; "" when dimensionless
  std::string meaning;  ///< one or two sentences, for --help-like listings and the docs
  SettingPhase phase = SettingPhase::kShear;
  /// Range of numbers and integers (of every entry of a list); open ends excluded.
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false, hi_open = false;
  std::string range_reason;  ///< why the range, added to its error ("projected SOR diverges")
  std::vector<std::string> choices;  ///< of kChoice
  /// Conditions between keys, in words (checked after every key is read: case_file.cpp).
  std::string constraint;
  std::function<SettingValue(const T&)> get;
  std::function<void(T&, const SettingValue&)> set;

  std::string dotted() const { return table.empty() ? key : table + "." + key; }
};

using CaseSetting = Setting<ShearCase>;

/// Every key of a shear case file, in the order of the docs and of `cdshear settings`.
const std::vector<CaseSetting>& case_settings();

/// The keys of a [solver] table (scene files; lifted into case files' [solver] and, in part,
/// [preparation]).
const std::vector<Setting<SolverOptions>>& solver_settings();

/// Keys an earlier cdshear read that are now fixed parts of the solver (docs/case-files.md, "Keys
/// no longer read"). A [solver] or [preparation] table (`table`: "solver" or "preparation",
/// `options` the solver options read from the rest of the file) may still give one with the
/// value the solver now uses, or with any value where the key has no effect, so that the
/// case.toml of earlier runs still resume; any other value is refused, naming the key. Call after
/// the table's settings are read, before its finish().
void read_retired_solver_keys(TomlReader& reader, const std::string& table,
                              const SolverOptions& options);

/// The solver settings of `o` that differ from `defaults` and change nothing under the others,
/// each as "key = value has no effect: why" (keys prefixed with `table` and a dot unless it is
/// empty): the slab correction's period outside the coloured order or with a normal compliance,
/// the mix's period without a mix. Read as they are and printed as warnings (docs/case-files.md,
/// "Settings without effect"): a value equal to the default is never named, so that a file
/// written by `cdshear settings` stays quiet.
std::vector<std::string> solver_settings_without_effect(const SolverOptions& o,
                                                        const SolverOptions& defaults,
                                                        const std::string& table);

/// Reads `s` from `reader` (which is positioned at s.table) into `target` when the key is
/// present, checking its type and range; an absent key leaves `target` as it is.
template <class T>
void read_setting(const Setting<T>& s, TomlReader& reader, T& target);

/// The range of `s` as a person reads it: "> 0", "0 to 1000", "random, coloured".
template <class T>
std::string range_text(const Setting<T>& s);

/// A value as TOML writes it (`1.0`, `"auto"`, `[5.0]`, `true`).
std::string toml_text(const SettingValue& v);

/// The value as a TOML node, for case_to_toml.
void insert_setting(toml::table& table, const std::string& key, const SettingValue& v);

const char* phase_name(SettingPhase phase);

/// Every setting of `c` as an annotated case file: each key with its value and, in a comment,
/// its unit, range and meaning. `c` is resolved (load_case), so it reads back as the same case.
std::string settings_as_toml(const ShearCase& c, const std::string& header);

/// The settings table of docs/case-files.md: key, default (from `c`), unit, range, phase, meaning.
std::string settings_as_markdown(const ShearCase& c);

/// The [solver] table of docs/scene-files.md: the solver rows with the engine's defaults.
std::string scene_solver_settings_as_markdown();

}  // namespace cdshear

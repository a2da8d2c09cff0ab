// Strict reading of a TOML table: every key read is typed and checked, and finish() rejects
// keys that were never read (typos), naming the file and the full dotted key.
#pragma once

#include <toml++/toml.h>

#include <cstdint>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "config_error.hpp"
#include "vec2.hpp"

namespace cdshear {

/// Limits of integer inputs (docs/reliability.md): far above any real use, low enough that the
/// values fit their types and a typo cannot ask for a machine's worth of memory or time.
inline constexpr std::int64_t kMaxDisks = 1'000'000;
inline constexpr std::int64_t kMaxSweeps = 1'000'000;
inline constexpr std::int64_t kMaxStepInterval = 1'000'000'000'000;
/// The most steps one run may ask for (docs/reliability.md): about 90 days of system 1 at
/// 250 steps/s; a larger count is a typo (dt, duration or V off by orders of magnitude).
/// `cdshear run` (checked_end_step) and campaign files (read_campaign) refuse more.
inline constexpr double kMaxRunSteps = 2e9;
/// The shortest time step (docs/reliability.md): the solver divides gaps by dt and sums squares
/// of the quotients, which overflow for far shorter steps (a shear step of 1e-170 turned the
/// walls' positions to NaN at step 1, a scene step of 5e-324 its forces); the margin keeps every
/// product of dt with the case's numbers finite.
inline constexpr double kMinTimeStep = 1e-100;
inline constexpr std::string_view kMinTimeStepReason =
    "below it the solver's sums of gap / dt squared overflow";

/// The most parts a dotted key of a TOML file may have (`a.b.c` has 3). toml++ builds a dotted
/// key's tables by recursion, one stack frame per part: a key of tens of thousands of parts
/// overflows the stack. No case, scene or campaign key has more than 4 parts.
inline constexpr std::size_t kMaxTomlKeyParts = 16;

/// Where `text` holds a dotted key of more than kMaxTomlKeyParts parts: "line N, ..."; empty
/// where none does. Conservative: a run of dots outside a key (in a string) counts too.
std::string too_deep_toml_key(std::string_view text);

/// Parses a TOML file; throws ConfigError naming the file (missing, unreadable, syntax error, a
/// key of more than kMaxTomlKeyParts parts).
toml::table parse_toml_file(const std::string& path);
/// Parses the TOML `text` read from `path`; throws ConfigError naming `path` (syntax error, a key
/// of more than kMaxTomlKeyParts parts).
toml::table parse_toml_text(const std::string& text, const std::string& path);

/// Where an overridden key's value comes from, by dotted key: "--set a.b=1", "--velocity".
using OverrideSources = std::map<std::string, std::string>;

/// Empty when `key` is a dotted key of bare parts (`shear.velocity`: each part letters, digits,
/// '_' or '-', as TOML writes keys without quotes, the only keys a case has); otherwise what is
/// wrong with it. An override's key is checked so that no '=', '#', quote or space in it can be
/// read as part of its value when the override is passed on as `key=value` text.
std::string case_key_problem(const std::string& key);

/// The key of an override "key=value", spaces and tabs around it dropped
/// (`--set 'shear.velocity = 1'` reads as `shear.velocity=1`).
std::string override_key(const std::string& item);

/// Applies `--set` overrides "a.b.c=value" (value in TOML syntax; a bare word such as `random`
/// is a string) to `root`, creating intermediate tables, and records each key's source in
/// `sources` (if given) so that a bad value is blamed on the --set, not on the file. Throws
/// ConfigError naming the override for a key that is not a case key (case_key_problem), or a
/// value that is not TOML or holds a newline. `file` names where `root`'s own values come from,
/// for an override that reaches inside one of them (`--set shear.velocity=1` where the file gives
/// `shear = 1`); empty when `root` has no file.
void apply_overrides(toml::table& root, const std::vector<std::string>& overrides,
                     OverrideSources* sources = nullptr, const std::string& file = "");

/// The source to blame for a problem of a value, or of a condition between values, at the full
/// dotted `keys`: the command line's --set (or --velocity) of the first of them given there (or
/// of a key inside one, which made it a table), else `file`. A condition between a key of the
/// file and a --set of another is the --set's doing.
std::string blamed_source(const std::string& file, const OverrideSources* sources,
                          std::initializer_list<std::string> keys);
/// The key of `sources` that blamed_source blames (its source: sources->at(key)); empty when
/// the file is blamed.
std::string blamed_key(const OverrideSources* sources, std::initializer_list<std::string> keys);

class TomlReader {
 public:
  TomlReader(const toml::table& table, std::string file, std::string prefix = "",
             std::shared_ptr<const OverrideSources> sources = nullptr);
  /// A reader that writes each default it falls back to into `table` itself (and its tables),
  /// so that the table ends up holding every value read: a scene's resolved scene.toml.
  static TomlReader filling(toml::table& table, std::string file,
                            std::shared_ptr<const OverrideSources> sources);

  bool has(const std::string& key) const;
  /// True when the key holds a table (for keys that take a value or a table of values).
  bool has_table(const std::string& key) const;
  /// True when the key holds a string (for keys that take a number or a word such as "auto").
  bool holds_string(const std::string& key) const;
  double number(const std::string& key, std::optional<double> fallback = std::nullopt);
  std::int64_t integer(const std::string& key, std::optional<std::int64_t> fallback = std::nullopt);
  /// An integer in [lo, hi]: every integer key is range-checked against the type and the limit
  /// it is used with (docs/reliability.md), never silently narrowed.
  std::int64_t integer_in(const std::string& key, std::int64_t lo, std::int64_t hi,
                          std::optional<std::int64_t> fallback = std::nullopt);
  bool boolean(const std::string& key, std::optional<bool> fallback = std::nullopt);
  std::string string(const std::string& key, std::optional<std::string> fallback = std::nullopt);
  Vec2 vec2(const std::string& key, std::optional<Vec2> fallback = std::nullopt);
  /// Numbers with a lower bound (strict or not), for sizes and times.
  double positive(const std::string& key, std::optional<double> fallback = std::nullopt);
  double non_negative(const std::string& key, std::optional<double> fallback = std::nullopt);
  /// An array of numbers (integers accepted).
  std::vector<double> number_array(const std::string& key);
  /// An array of integers, each in [lo, hi].
  std::vector<std::int64_t> integer_array(const std::string& key, std::int64_t lo, std::int64_t hi);
  /// One of `choices`.
  std::string choice(const std::string& key, const std::vector<std::string>& choices,
                     std::optional<std::string> fallback = std::nullopt);

  /// Sub-table (empty reader if absent and optional).
  TomlReader table(const std::string& key);
  /// Array of tables ([[key]]); empty if absent.
  std::vector<TomlReader> tables(const std::string& key);

  /// Throws ConfigError for the first key of this table that was never read.
  void finish() const;

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const;
  /// Fails on the missing `key`: "is required" followed by `how` (how to give it), naming a key of
  /// this table not read so far within a few edits of `key` (near_miss), the likely misspelling,
  /// and blaming its --set where one gave it.
  [[noreturn]] void fail_missing(const std::string& key, const std::string& how = "") const;
  /// The key of this table, not read so far and not a sibling of `key` (`region_max` for
  /// `region_min`), closest to `key` within a third of its length in edits (at least two); empty
  /// if none.
  std::string near_miss(const std::string& key) const;
  /// Fails a condition between this table's `key` and the keys `others` (full dotted keys):
  /// names `key`, blamed on a --set of `key` or of one of `others` (blamed_source).
  [[noreturn]] void fail_between(const std::string& key, std::initializer_list<std::string> others,
                                 const std::string& problem) const;
  std::string full_key(const std::string& key) const;
  /// True when the full dotted `key` was given on the command line (--set, --velocity).
  bool overridden(const std::string& key) const {
    return !blamed_key(sources_.get(), {key}).empty();
  }
  const std::string& file() const { return file_; }
  /// For a filling reader, the table to write the value in use of the absent `key` into (the one
  /// it reads), `key` then counting as read; null for any other reader.
  toml::table* fill_target(const std::string& key) {
    if (fill_ == nullptr) return nullptr;
    used_.insert(key);
    return fill_;
  }

 private:
  const toml::node* lookup(const std::string& key);
  /// Where this reader fills in defaults: `value` at `key` (a filling reader only).
  template <class V>
  void fill(const std::string& key, const V& value);

  const toml::table* table_;
  std::string file_;
  std::string prefix_;
  std::set<std::string> used_;
  std::shared_ptr<const OverrideSources> sources_;  ///< keys given on the command line
  toml::table* fill_ = nullptr;                     ///< table_ itself, when filling defaults
};

/// A number as a person writes it: shortest exact form, exponent for large or small values
/// (never 300 digits).
std::string format_number(double v);

}  // namespace cdshear

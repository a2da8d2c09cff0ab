// Campaign files (TOML) -> Campaign: the runs of a `cdshear sweep` (systems x velocities x
// seeds with one duration or strain, in one or several groups; shared case overrides), resolved
// and checked before anything runs. Schema: docs/campaigns.md.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>
#include <nlohmann/json.hpp>

namespace cdshear {

/// One shear run of a campaign, fully resolved.
struct CampaignRun {
  std::string name;         ///< folder name: s<system>_seed<seed>_V<V>
  int system = 1;           ///< preset of model.md section 6, 1..7
  double velocity = 0.0;    ///< V [d/t]
  std::uint64_t seed = 1;   ///< packing placement seed (case key system.seed)
  double duration = 0.0;    ///< simulated shear time [t] (from `duration`, or from `strain`)
  double dt = 0.0;          ///< the run's resolved time step [t]
  std::size_t n = 0;        ///< disks
  double height = 0.0;      ///< nominal L_y [d]
  nlohmann::json identity;  ///< case_identity of the run's resolved case (src/io/case_file.hpp)
  /// The packing cache name of its resolved preparation (packing_cache_name): two runs whose
  /// packings are prepared alike share it.
  std::string preparation;
  /// Estimated cost: n x duration / dt [disk steps]; the sweep starts the costliest first.
  double cost() const { return static_cast<double>(n) * duration / dt; }
};

/// Runs that share their lists and duration: systems x seeds x velocities. A campaign is one
/// group ([campaign] itself) or several ([[campaign.group]], each with the runs of one purpose,
/// such as the velocities around a transition with two seeds).
struct CampaignGroup {
  std::string purpose;  ///< what the runs are for (free text, kept in the resolved file)
  std::vector<int> systems;
  std::vector<double> velocities;  ///< every V [d/t], in the order given (a range expanded)
  std::vector<std::uint64_t> seeds;
  std::optional<double> duration;            ///< [t], the same for every run; or per system:
  std::map<int, double> duration_of_system;  ///< [t] (`duration = { 1 = 20000, 7 = 13000 }`); or
  std::optional<double> strain;  ///< total shear strain 2 V t / L_y, per run t = strain L_y / 2V
};

struct Campaign {
  std::string file;  ///< where it was read from (for messages)
  std::string name;  ///< [campaign] name: default folder campaigns/<name>
  /// One group read from [campaign] itself, or the [[campaign.group]] tables in order.
  std::vector<CampaignGroup> groups;
  bool grouped = false;                    ///< the runs come from [[campaign.group]] tables
  std::vector<double> boundary_thickness;  ///< measure.boundary_thickness [d]; empty: the case's
  bool analyze = true;                     ///< each run ends with analyze + plot
  std::map<int, std::string> packings;     ///< system -> given packing file (absolute path)
  /// [set]: case-key overrides "key=value" (value as TOML), applied to every run like --set.
  std::vector<std::string> overrides;
  /// Per group, systems x seeds x velocities in that nesting order; a run in two groups is
  /// refused.
  std::vector<CampaignRun> runs;
};

/// The most runs a campaign may list (systems x seeds x velocities, over all groups).
inline constexpr int kMaxCampaignRuns = 10000;

/// Reads and resolves a campaign file. Throws ConfigError naming the file, the key and the
/// problem (unknown key, unknown system, empty or bad velocities, duplicate runs, both or
/// neither of duration/strain, a [set] key the case refuses, ...).
Campaign read_campaign(const std::string& path);

/// The same from a parsed table; `file` names it in errors, `base_dir` anchors relative packing
/// paths.
Campaign campaign_from_toml(const toml::table& table, const std::string& file,
                            const std::string& base_dir);

/// The resolved campaign as TOML: a campaign file itself (velocities expanded, packing paths
/// absolute); reading it back gives the same campaign.
toml::table campaign_to_toml(const Campaign& c);

/// The first words of what a sweep writes as `DIR/campaign.toml`: a file that does not begin
/// with them is no sweep's (a user's own campaign file), and a sweep never writes over it.
inline constexpr std::string_view kResolvedCampaignHeader =
    "# Resolved campaign written by cdshear ";

/// What `DIR/campaign.toml` holds: a header (kResolvedCampaignHeader, the version, the
/// fingerprint), campaign_to_toml, and every run (name, duration, dt, cost) as comment lines.
std::string campaign_file_text(const Campaign& c);

/// A short fingerprint (16 hex digits, FNV-1a 64) of the resolved campaign's TOML text.
std::string campaign_fingerprint(const toml::table& resolved);

/// The fingerprint as builds that printed the campaign through toml++'s own formatter (17-digit
/// numbers, single-quoted strings) recorded it: a folder written by such a build, its
/// campaign.toml unedited, still passes for unedited.
std::string printed_fingerprint(const toml::table& resolved);

/// The fingerprint that campaign_file_text wrote in the header (first line) of `text`, or empty
/// where that line holds none (a user's own campaign file).
std::string recorded_fingerprint(std::string_view text);

/// The keys (dotted) whose values differ between two resolved campaigns, as
/// "key: OLD -> NEW" lines; empty when they are the same.
std::vector<std::string> campaign_differences(const toml::table& before, const toml::table& after);

/// The folder name of a run: s<system>_seed<seed>_V<V> (V with 6 significant digits).
std::string campaign_run_name(int system, std::uint64_t seed, double velocity);

/// The case overrides (`--set KEY=VALUE`) of one run besides its system, V and duration: its
/// seed, the campaign's boundary thicknesses and [set]. The reader checks them with the case
/// loader; the sweep passes the same to `cdshear run`.
std::vector<std::string> run_case_overrides(const Campaign& c, const CampaignRun& r);

}  // namespace cdshear

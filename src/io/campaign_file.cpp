// Campaign files: reading, resolving every run (through the same case loader as `cdshear run`,
// so a bad [set] key is refused before anything runs), writing back, fingerprint and diff.
#include "campaign_file.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <optional>
#include <set>
#include <sstream>

#include "case_file.hpp"
#include "config_error.hpp"
#include "packing_file.hpp"
#include "shear_case.hpp"
#include "toml_reader.hpp"
#include "toml_text.hpp"

namespace cdshear {
namespace {

namespace fs = std::filesystem;

/// Case keys the campaign sets itself for every run: [set] may not override them.
const std::map<std::string, std::string> kOwnedKeys = {
    {"shear.velocity", "give the velocities in [campaign] velocities or velocity_range"},
    {"system.seed", "give the seeds in [campaign] seeds"},
    {"shear.duration", "give [campaign] duration (time units) or strain"},
    {"measure.boundary_thickness", "give [campaign] boundary_thickness"},
    {"preparation.packing", "give [campaign.packing] per system"}};

/// Every leaf of a table as (dotted key, value text), in key order (an empty table has none: a
/// `[set.measure]` header whose keys are all commented out sets nothing). Returns a dotted key
/// that two leaves share (`a.b = 1` beside `"a.b" = 2`), the first found, or "" (the later
/// leaf's value is kept).
std::string flatten(const toml::table& t, const std::string& prefix,
                    std::map<std::string, std::string>& out) {
  std::string twice;
  const auto keep = [&twice](std::string found) {
    if (twice.empty()) twice = std::move(found);
  };
  for (const auto& [k, v] : t) {
    const std::string key =
        prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
    const toml::array* array = v.as_array();
    if (const toml::table* sub = v.as_table()) {
      keep(flatten(*sub, key, out));
    } else if (array != nullptr && !array->empty() && array->is_array_of_tables()) {
      for (std::size_t i = 0; i < array->size(); ++i)  // [[campaign.group]]: group[i].key
        keep(flatten(*(*array)[i].as_table(), key + "[" + std::to_string(i) + "]", out));
    } else {
      if (out.contains(key)) keep(key);
      out[key] = toml_value_text(v);
    }
  }
  return twice;
}

/// Velocities of a range, rounded to 6 significant digits (the precision of the run names).
std::vector<double> velocity_range(TomlReader& r) {
  const double from = r.positive("from");
  const double to = r.positive("to");
  const auto count = static_cast<int>(r.integer_in("count", 1, 10000));
  const std::string spacing = r.choice("spacing", {"log", "linear"}, "log");
  r.finish();
  if (count > 1 && !(to > from)) r.fail("to", "must be above 'from' when count > 1");
  if (count == 1 && to != from) r.fail("count", "is 1: then 'from' and 'to' must be equal");
  std::vector<double> v;
  for (int k = 0; k < count; ++k) {
    const double f = count == 1 ? 0.0 : static_cast<double>(k) / (count - 1);
    // Log spacing through logarithms where to / from overflows (from 0.1 to 1e308).
    const double ratio = to / from;
    const double x = spacing == "linear" ? from + f * (to - from)
                     : std::isfinite(ratio)
                         ? from * std::pow(ratio, f)
                         : std::exp(std::log(from) + f * (std::log(to) - std::log(from)));
    // strtod, not stod: a subnormal speed is a value the case check refuses by its key, not an
    // out_of_range exception.
    v.push_back(std::strtod(fmt::format("{:.6g}", x).c_str(), nullptr));
  }
  v.front() = from;  // exactly as written
  v.back() = to;
  return v;
}

}  // namespace

std::vector<std::string> run_case_overrides(const Campaign& c, const CampaignRun& r) {
  std::vector<std::string> o = {"system.seed=" + std::to_string(r.seed)};
  if (!c.boundary_thickness.empty())
    o.push_back(
        fmt::format("measure.boundary_thickness=[{}]", fmt::join(c.boundary_thickness, ", ")));
  o.insert(o.end(), c.overrides.begin(), c.overrides.end());
  return o;
}

std::string campaign_run_name(int system, std::uint64_t seed, double velocity) {
  return fmt::format("s{}_seed{}_V{}", system, seed, format_number(velocity));
}

Campaign read_campaign(const std::string& path) {
  const toml::table table = parse_toml_file(path);
  const fs::path dir = fs::absolute(fs::path(path)).parent_path();
  return campaign_from_toml(table, path, dir.string());
}

namespace {

/// The keys that list a group's runs: in [campaign] for a one-group campaign, else in each
/// [[campaign.group]].
const std::vector<std::string> kGroupKeys = {"systems", "velocities", "velocity_range",
                                             "seeds",   "duration",   "strain"};

/// One group's lists and duration from `t` ([campaign] itself, or one [[campaign.group]]).
CampaignGroup read_group(TomlReader& t) {
  CampaignGroup g;
  for (const std::int64_t k : t.integer_array("systems", std::numeric_limits<int>::min(),
                                              std::numeric_limits<int>::max())) {
    if (k < 1 || k > 7)
      t.fail("systems", "system " + std::to_string(k) +
                            " is unknown: the systems of docs/model.md section 6 are 1..7");
    g.systems.push_back(static_cast<int>(k));
  }
  if (g.systems.empty()) t.fail("systems", "is empty: name at least one system");
  for (std::size_t i = 0; i < g.systems.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (g.systems[i] == g.systems[j])
        t.fail("systems", "lists system " + std::to_string(g.systems[i]) + " twice");

  const bool has_list = t.has("velocities"), has_range = t.has("velocity_range");
  if (has_list && has_range)
    t.fail("velocity_range", "give either velocities or velocity_range, not both");
  if (!has_list && !has_range) t.fail_missing("velocities", " (or a velocity_range table)");
  if (has_list) {
    g.velocities = t.number_array("velocities");
    if (g.velocities.empty()) t.fail("velocities", "is empty: give at least one V");
    for (const double v : g.velocities)
      if (!(v > 0.0) || !std::isfinite(v))
        t.fail("velocities", "every V must be a finite number > 0, got " + format_number(v));
  } else {
    TomlReader r = t.table("velocity_range");
    g.velocities = velocity_range(r);
  }
  std::set<std::string> velocity_names;  // as the run folders name them
  for (const double v : g.velocities)
    if (!velocity_names.insert(format_number(v)).second)
      t.fail(has_list ? "velocities" : "velocity_range",
             "gives V = " + format_number(v) +
                 " twice (the same run twice; V is told apart to 6 significant digits)");

  if (t.has("seeds")) {
    for (const std::int64_t s :
         t.integer_array("seeds", 0, std::numeric_limits<std::int64_t>::max()))
      g.seeds.push_back(static_cast<std::uint64_t>(s));
    if (g.seeds.empty()) t.fail("seeds", "is empty: give at least one seed (default [1])");
  } else {
    g.seeds = {1};
  }
  std::set<std::uint64_t> seen_seeds;  // n log n: a long list must not take quadratic time
  for (const std::uint64_t seed : g.seeds)
    if (!seen_seeds.insert(seed).second)
      t.fail("seeds", "lists seed " + std::to_string(seed) + " twice (the same runs twice)");

  const bool has_duration = t.has("duration"), has_strain = t.has("strain");
  if (has_duration && has_strain)
    t.fail("strain", "give either duration (time units) or strain, not both");
  if (!has_duration && !has_strain)
    t.fail_missing("duration", ": give duration (time units per run) or strain (2 V t / L_y)");
  if (has_duration) {
    if (t.has_table("duration")) {
      // One duration per system (model.md section 6 gives each its own simulated time).
      TomlReader per = t.table("duration");
      for (const int k : g.systems) {
        const std::string key = std::to_string(k);
        if (!per.has(key))
          per.fail(key,
                   "is missing: a per-system duration must give every system of the "
                   "campaign its own");
        g.duration_of_system[k] = per.positive(key);
      }
      try {
        per.finish();  // a system not in the campaign is refused here
      } catch (const ConfigError& e) {
        throw ConfigError(e.file(), e.key(),
                          fmt::format("{}: the table gives a duration to each of the "
                                      "systems = [{}], named by number, and to no other",
                                      e.problem(), fmt::join(g.systems, ", ")));
      }
    } else {
      g.duration = t.positive("duration");
    }
  }
  if (has_strain) g.strain = t.positive("strain");
  return g;
}

/// One run of group `g` (read by `gr`; `t` reads [campaign]) resolved by the case loader of
/// `cdshear run` with the overrides it will get: its n, L_y, duration and dt, every problem named
/// by its campaign key. Returns the run's resolved case with its duration left out, as TOML: two
/// runs with the same text are one case (their trajectories the same up to the shorter end).
std::string resolve_run(const Campaign& c, const CampaignGroup& g, const TomlReader& gr,
                        const TomlReader& t, CampaignRun& run, int system, std::uint64_t seed,
                        double v, std::set<int>& packings_checked) {
  const std::string& file = c.file;
  run.system = system;
  run.velocity = v;
  run.seed = seed;
  const std::string length_key = g.strain ? "strain" : "duration";
  // The case as the run will get it: the campaign's overrides, and its duration (the sweep's
  // `--set shear.duration`), not the preset's. A strain needs L_y: the case is read first with
  // a unit duration to learn it, unmeasured (the measurements' checks against the duration are
  // for the run's own).
  const auto load = [&](double duration, bool for_height_only = false) {
    CaseSource src;
    src.system = system;
    src.velocity = v;
    src.overrides = run_case_overrides(c, run);
    src.overrides.push_back(fmt::format("shear.duration={}", duration));
    if (for_height_only) src.overrides.push_back("measure.enabled=false");
    try {
      return load_case(src);
    } catch (const ConfigError& e) {
      // The campaign's key that gave the value blamed: a condition between two keys is blamed
      // on the override of either (blamed_source), named then beside the key that failed.
      const std::string given = e.given_key().empty() ? e.key() : e.given_key();
      const std::string key =
          given == "measure.boundary_thickness" ? std::string("campaign.boundary_thickness")
          : given == "shear.velocity"
              ? gr.full_key(gr.has("velocities") ? "velocities" : "velocity_range")
          : given == "shear.duration" ? gr.full_key(length_key)
          : given.empty()             ? std::string("set")
                                      : "set." + given;
      const std::string problem =
          given == e.key() || e.key().empty() ? e.problem() : e.key() + ": " + e.problem();
      throw ConfigError(file, key, problem + " (run " + run.name + ")");
    }
  };
  run.duration = g.duration                      ? *g.duration
                 : !g.duration_of_system.empty() ? g.duration_of_system.at(system)
                                                 : *g.strain * load(1.0, true).height / (2.0 * v);
  ShearCase sc = load(run.duration);
  run.identity = case_identity(sc);
  run.preparation = packing_cache_name(sc.preparation);
  if (c.analyze && !sc.measure.enabled)
    t.fail("analyze", std::string(t.has("analyze") ? "is true" : "is true by default (not given)") +
                          ", but the runs measure nothing ([set] measure.enabled = false): there "
                          "would be no analysis; give analyze = false, or let the runs measure");
  // A given packing is read as the run will read it, once per system: one made for another
  // system, or a damaged one, is refused now rather than in every run.
  if (const auto it = c.packings.find(system);
      it != c.packings.end() && packings_checked.insert(system).second) {
    const std::string key = "campaign.packing." + std::to_string(system);
    Packing given;
    try {
      given = read_packing(it->second, packing_wall_tolerance(sc));
      check_packing_fits_case(sc, given, it->second);
    } catch (const ConfigError& e) {
      throw ConfigError(file, key, e.what());
    }
    // The run's folder and summary name its seed: a packing placed with another would be
    // pooled as that seed's realisation.
    if (given.seed != sc.seed)
      throw ConfigError(file, key,
                        fmt::format("{} was placed with seed {}, the campaign would run it as "
                                    "seed {} (run {}); give seeds = [{}] for system {}",
                                    it->second, given.seed, sc.seed, run.name, given.seed, system));
  }
  run.n = sc.n;
  run.height = sc.height;
  resolve_step_rules(sc);
  run.dt = sc.step.dt;
  // Too many steps is refused by the case loader above, with this duration; too few here.
  const double steps = run.duration / run.dt;
  if (!(steps >= 0.5))
    gr.fail(length_key,
            fmt::format("gives run {} a duration of {:.6g}, less than half a time step ({:.6g})",
                        run.name, run.duration, run.dt));
  sc.duration = 0.0;
  return toml_document_text(case_to_toml(sc));
}

/// [campaign.packing]: a packing file per system (relative to the campaign file's folder),
/// each serving the one seed the campaign runs that system with.
void read_packings(TomlReader& t, const std::set<int>& all_systems, const std::string& base_dir,
                   Campaign& c) {
  TomlReader packings = t.table("packing");
  for (const int k : all_systems) {
    const std::string key = std::to_string(k);
    if (!packings.has(key)) continue;
    std::string p = packings.string(key);
    if (p.empty()) packings.fail(key, "is empty: give a packing file, or leave the key out");
    fs::path abs = fs::path(p).is_absolute() ? fs::path(p) : fs::path(base_dir) / p;
    abs = abs.lexically_normal();
    if (!fs::is_regular_file(abs)) packings.fail(key, "no packing file at " + abs.string());
    std::set<std::uint64_t> seeds;  // of this system, over the groups that run it
    for (const CampaignGroup& g : c.groups)
      if (std::find(g.systems.begin(), g.systems.end(), k) != g.systems.end())
        seeds.insert(g.seeds.begin(), g.seeds.end());
    if (seeds.size() > 1)
      packings.fail(key, "a given packing serves one seed, the campaign lists " +
                             std::to_string(seeds.size()) + " for system " + key);
    c.packings[k] = abs.string();
  }
  packings.finish();  // a packing for a system not in the campaign is refused here
}

/// [set]: case overrides for every run, each a bare case key the campaign does not own.
void read_set(const toml::table& table, TomlReader& root, const std::string& file, Campaign& c) {
  std::map<std::string, std::string> set_items;
  if (const toml::node* set = table.get("set")) {
    if (!set->is_table()) root.fail("set", "must be a table of case keys: [set]");
    if (const std::string twice = flatten(*set->as_table(), "", set_items); !twice.empty())
      throw ConfigError(file, "set." + twice,
                        "is given twice (as a dotted key and as a quoted one holding a dot); "
                        "give it once");
  }
  TomlReader unused_set = root.table("set");  // marks [set] as read for root.finish()
  (void)unused_set;
  for (const auto& [key, value] : set_items) {
    // A quoted TOML key can hold anything ("shear.velocity=5 #"): passed on as `key=value`, its
    // '=' would make it another key with another value. Case keys are bare.
    if (const std::string problem = case_key_problem(key); !problem.empty())
      throw ConfigError(file, "set", "the key " + problem);
    if (const auto it = kOwnedKeys.find(key); it != kOwnedKeys.end())
      throw ConfigError(file, "set." + key, "is set by the campaign: " + it->second);
    if (key == "packing" || key.ends_with(".packing"))  // `run --packing` is no case key
      throw ConfigError(file, "set." + key,
                        "is no case key: a campaign's packing files are given per system in "
                        "[campaign], packing = { 1 = \"FILE\" }");
    c.overrides.push_back(key + "=" + value);
  }
}

}  // namespace

Campaign campaign_from_toml(const toml::table& table, const std::string& file,
                            const std::string& base_dir) {
  Campaign c;
  c.file = file;
  TomlReader root(table, file);
  if (!root.has("campaign")) root.fail_missing("campaign", " (a [campaign] table)");
  TomlReader t = root.table("campaign");

  c.name = t.string("name");
  if (c.name.empty() || c.name == "." || c.name == ".." ||
      c.name.find_first_not_of(
          "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-") != std::string::npos)
    t.fail("name", "must be a folder name: letters, digits, '.', '_', '-', got '" + c.name + "'");
  // A folder name: at most 255 bytes on the file systems a campaign runs on (NAME_MAX).
  if (c.name.size() > 255)
    t.fail("name",
           "must be a folder name of at most 255 characters, got " + std::to_string(c.name.size()));

  // The runs: [campaign] itself, or [[campaign.group]] tables (never both).
  std::vector<TomlReader> group_readers;  // kept to name a group's keys in later errors
  c.grouped = t.has("group");
  if (c.grouped) {
    for (const std::string& key : kGroupKeys)
      if (t.has(key))
        t.fail(key, "is given in each [[campaign.group]] when the campaign has groups");
    group_readers = t.tables("group");
    if (group_readers.empty()) t.fail("group", "is empty: give at least one [[campaign.group]]");
    // A purpose names its group when a changed campaign is compared with the folder's: two
    // groups with one purpose could not be told apart there.
    std::map<std::string, std::size_t> group_of_purpose;
    for (TomlReader& g : group_readers) {
      CampaignGroup group = read_group(g);
      group.purpose = g.string("purpose", "");
      if (const auto [it, added] = group_of_purpose.emplace(group.purpose, c.groups.size());
          !added && !group.purpose.empty())
        g.fail("purpose", fmt::format("\"{}\" is the purpose of campaign.group[{}] already: "
                                      "give each group its own (or none)",
                                      group.purpose, it->second));
      g.finish();
      c.groups.push_back(std::move(group));
    }
  } else {
    c.groups.push_back(read_group(t));
    group_readers.push_back(t);
  }
  std::set<int> all_systems;
  for (const CampaignGroup& g : c.groups) all_systems.insert(g.systems.begin(), g.systems.end());

  if (t.has("boundary_thickness")) {
    c.boundary_thickness = t.number_array("boundary_thickness");
    if (c.boundary_thickness.empty()) t.fail("boundary_thickness", "must list at least one h");
    for (const double h : c.boundary_thickness)
      if (!(h > 0.0) || !std::isfinite(h))
        t.fail("boundary_thickness",
               "every h must be a finite number > 0, got " + format_number(h));
  }
  c.analyze = t.boolean("analyze", true);

  read_packings(t, all_systems, base_dir, c);
  t.finish();

  read_set(table, root, file, c);
  root.finish();

  // A bound on the campaign's size (the whole study of model.md section 6 is a few hundred runs):
  // each run is resolved below, and a folder is made for each.
  double run_count = 0.0;
  for (const CampaignGroup& g : c.groups)
    run_count += static_cast<double>(g.systems.size()) * static_cast<double>(g.seeds.size()) *
                 static_cast<double>(g.velocities.size());
  if (run_count > kMaxCampaignRuns)
    throw ConfigError(file, "campaign",
                      fmt::format("lists {:.0f} runs (systems x seeds x velocities), more than the "
                                  "limit of {}",
                                  run_count, kMaxCampaignRuns));

  // Every run, resolved by the case loader of `cdshear run`.
  std::map<std::string, std::size_t> group_of_run;  // run name -> its group
  std::set<int> packings_checked;                   // systems whose given packing was read
  std::map<std::string, std::string> run_of_case;   // resolved case -> the run that has it
  for (std::size_t gi = 0; gi < c.groups.size(); ++gi) {
    const CampaignGroup& g = c.groups[gi];
    const TomlReader& gr = group_readers[gi];
    for (const int system : g.systems)
      for (const std::uint64_t seed : g.seeds)
        for (const double v : g.velocities) {
          CampaignRun run;
          run.name = campaign_run_name(system, seed, v);
          if (const auto [it, added] = group_of_run.emplace(run.name, gi); !added)
            t.fail(fmt::format("group[{}]", gi),
                   fmt::format("lists run {} again: it is in campaign.group[{}] already (a run "
                               "belongs to one group)",
                               run.name, it->second));
          const std::string resolved =
              resolve_run(c, g, gr, t, run, system, seed, v, packings_checked);
          // Two systems the [set] gives the same values where they differ run one case twice
          // under two names (the study pools runs by system).
          if (const auto [it, added] = run_of_case.emplace(resolved, run.name); !added)
            throw ConfigError(
                file, "set",
                fmt::format("makes runs {} and {} one case (their resolved cases differ in "
                            "nothing but the duration): a campaign runs a case once; leave out "
                            "one of the systems, or the [set] key that gives them one value",
                            it->second, run.name));
          c.runs.push_back(run);
        }
  }
  return c;
}

namespace {

/// A group's lists and duration as TOML keys (into [campaign] or one [[campaign.group]]).
void insert_group(toml::table& into, const CampaignGroup& g) {
  toml::array systems, velocities, seeds;
  for (const int k : g.systems) systems.push_back(k);
  for (const double v : g.velocities) velocities.push_back(v);
  for (const std::uint64_t s : g.seeds) seeds.push_back(static_cast<std::int64_t>(s));
  into.insert("systems", systems);
  into.insert("velocities", velocities);
  into.insert("seeds", seeds);
  if (g.duration) into.insert("duration", *g.duration);
  if (!g.duration_of_system.empty()) {
    toml::table per;
    for (const auto& [k, d] : g.duration_of_system) per.insert(std::to_string(k), d);
    into.insert("duration", per);
  }
  if (g.strain) into.insert("strain", *g.strain);
}

}  // namespace

toml::table campaign_to_toml(const Campaign& c) {
  toml::table campaign{{"name", c.name}, {"analyze", c.analyze}};
  if (c.grouped) {
    toml::array groups;
    for (const CampaignGroup& g : c.groups) {
      toml::table group;
      if (!g.purpose.empty()) group.insert("purpose", g.purpose);
      insert_group(group, g);
      groups.push_back(group);
    }
    campaign.insert("group", groups);
  } else {
    insert_group(campaign, c.groups.at(0));
  }
  if (!c.boundary_thickness.empty()) {
    toml::array boundary;
    for (const double h : c.boundary_thickness) boundary.push_back(h);
    campaign.insert("boundary_thickness", boundary);
  }
  if (!c.packings.empty()) {
    toml::table packing;
    for (const auto& [k, p] : c.packings) packing.insert(std::to_string(k), p);
    campaign.insert("packing", packing);
  }
  toml::table set;
  apply_overrides(set, c.overrides);
  return toml::table{{"campaign", campaign}, {"set", set}};
}

namespace {

/// The words before the fingerprint in the header; the fingerprint ends at the next '.'.
constexpr std::string_view kFingerprintWords = "; fingerprint ";

std::string fingerprint_of(std::string_view text) {
  std::uint64_t h = 14695981039346656037ull;  // FNV-1a 64
  for (const unsigned char ch : text) {
    h ^= ch;
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

}  // namespace

std::string campaign_fingerprint(const toml::table& resolved) {
  return fingerprint_of(toml_document_text(resolved));
}

std::string printed_fingerprint(const toml::table& resolved) {
  std::ostringstream text;
  text << resolved;
  return fingerprint_of(text.str());
}

std::string recorded_fingerprint(std::string_view text) {
  const std::string_view first_line = text.substr(0, text.find('\n'));
  const std::size_t at = first_line.find(kFingerprintWords);
  if (at == std::string_view::npos) return {};
  const std::string_view rest = first_line.substr(at + kFingerprintWords.size());
  return std::string(rest.substr(0, rest.find('.')));
}

std::string campaign_file_text(const Campaign& c) {
  const toml::table t = campaign_to_toml(c);
  std::ostringstream text;
  text << kResolvedCampaignHeader << CDSHEAR_VERSION " sweep" << kFingerprintWords
       << campaign_fingerprint(t) << ".\n"
       << "# A campaign file itself: `cdshear sweep` on it runs the same runs.\n"
       << toml_document_text(t)
       << "\n\n# Runs (name, duration [t], dt [t], cost n x duration / dt):\n";
  for (const CampaignRun& r : c.runs)
    text << fmt::format("#   {}  duration {}  dt {}  cost {:.3g}\n", r.name, r.duration, r.dt,
                        r.cost());
  return text.str();
}

namespace {

using FlatTable = std::map<std::string, std::string>;

/// "key: OLD -> NEW" for every key of either table whose value differs, keys prefixed.
void add_key_differences(const FlatTable& a, const FlatTable& b, const std::string& prefix,
                         std::vector<std::string>& out) {
  std::set<std::string> keys;
  for (const auto& [k, v] : a) keys.insert(k);
  for (const auto& [k, v] : b) keys.insert(k);
  for (const std::string& k : keys) {
    const auto ia = a.find(k), ib = b.find(k);
    const std::string va = ia == a.end() ? "(absent)" : ia->second;
    const std::string vb = ib == b.end() ? "(absent)" : ib->second;
    if (va != vb) out.push_back(prefix + k + ": " + va + " -> " + vb);
  }
}

/// The [[campaign.group]] tables of a resolved campaign, each flattened.
std::vector<FlatTable> flat_groups(const toml::table& resolved) {
  std::vector<FlatTable> groups;
  if (const toml::array* array = resolved["campaign"]["group"].as_array()) {
    for (const toml::node& node : *array) {
      groups.emplace_back();
      if (const toml::table* group = node.as_table()) flatten(*group, "", groups.back());
    }
  }
  return groups;
}

/// The groups' differences, named by the new campaign's group index. A group that is in both
/// campaigns unchanged is no difference wherever it moved (a group inserted before it renumbers
/// it); one whose purpose is in both is paired by it, and one without a purpose with the group at
/// its place, and their keys compared; the rest are added or removed groups.
void add_group_differences(const std::vector<FlatTable>& before,
                           const std::vector<FlatTable>& after, std::vector<std::string>& out) {
  std::vector<bool> used(before.size(), false);
  std::vector<std::optional<std::size_t>> pair(after.size());
  for (std::size_t i = 0; i < after.size(); ++i)
    for (std::size_t j = 0; j < before.size() && !pair[i]; ++j)
      if (!used[j] && before[j] == after[i]) {
        used[j] = true;
        pair[i] = j;
      }
  const auto purpose = [](const FlatTable& g) {
    const auto it = g.find("purpose");
    return it == g.end() ? std::string() : it->second;
  };
  for (std::size_t i = 0; i < after.size(); ++i)
    for (std::size_t j = 0; j < before.size() && !pair[i] && !purpose(after[i]).empty(); ++j)
      if (!used[j] && purpose(before[j]) == purpose(after[i])) {
        used[j] = true;
        pair[i] = j;
      }
  for (std::size_t i = 0; i < after.size() && i < before.size(); ++i)
    if (!pair[i] && !used[i] && (purpose(after[i]).empty() || purpose(before[i]).empty())) {
      used[i] = true;  // a group without a purpose, changed in place
      pair[i] = i;
    }
  for (std::size_t i = 0; i < after.size(); ++i) {
    const std::string name = fmt::format("campaign.group[{}]", i);
    if (pair[i])
      add_key_differences(before[*pair[i]], after[i], name + ".", out);
    else
      out.push_back(name + ": added" +
                    (purpose(after[i]).empty() ? "" : " (purpose " + purpose(after[i]) + ")"));
  }
  for (std::size_t j = 0; j < before.size(); ++j)
    if (!used[j])
      out.push_back(fmt::format("campaign.group[{}] of the folder's campaign: removed", j) +
                    (purpose(before[j]).empty() ? "" : " (purpose " + purpose(before[j]) + ")"));
}

}  // namespace

std::vector<std::string> campaign_differences(const toml::table& before, const toml::table& after) {
  FlatTable a, b;
  flatten(before, "", a);
  flatten(after, "", b);
  const auto not_group = [](const FlatTable& t) {
    FlatTable out;
    for (const auto& [k, v] : t)
      if (k.rfind("campaign.group[", 0) != 0) out.emplace(k, v);
    return out;
  };
  std::vector<std::string> out;
  add_key_differences(not_group(a), not_group(b), "", out);
  add_group_differences(flat_groups(before), flat_groups(after), out);
  return out;
}

}  // namespace cdshear

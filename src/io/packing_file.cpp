#include "packing_file.hpp"

#include <fmt/format.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "build_info.hpp"
#include "config_error.hpp"
#include "json_reading.hpp"
#include "outputs.hpp"
#include "world.hpp"

namespace cdshear {

namespace {

constexpr int kPackingVersion = 1;
constexpr const char* kPackingFormat = "cdshear-packing";  // a packing file's "format"

/// A packing file's content: every key a packing holds is written here, and read_packing refuses
/// any other.
nlohmann::json packing_json(const Packing& p) {
  nlohmann::json disks = nlohmann::json::array();
  for (const PackingDisk& d : p.disks) disks.push_back({d.position.x, d.position.y, d.radius});
  return {{"format", kPackingFormat},
          {"version", kPackingVersion},
          {"program_version", CDSHEAR_VERSION},
          {"build", p.build.empty() ? build_description() : p.build},
          {"n", p.n()},
          {"height", p.height},
          {"length_x", p.length_x},
          {"diameter_min", p.diameter_min},
          {"diameter_max", p.diameter_max},
          {"seed", p.seed},
          // The disks' own, whatever the struct holds: read_packing checks the two agree.
          {"solid_fraction", solid_fraction(p.disks, p.length_x, p.height)},
          {"piston_stress", p.piston_stress},
          {"preparation_time", p.preparation_time},
          {"preparation_steps", p.preparation_steps},
          {"capped_steps", p.capped_steps},
          {"displacement_warnings", p.displacement_warnings},
          {"largest_overlap", p.largest_overlap},
          {"disks_xyr", disks}};
}

}  // namespace

void write_packing(const std::filesystem::path& path, const Packing& p) {
  const nlohmann::json j = packing_json(p);
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  remove_dead_writers_temporaries(path);  // a packing is made again: its killed writes' files go
  write_file_atomic(path, j.dump(1) + "\n");
}

bool is_packing_file(const std::filesystem::path& path) {
  // A packing is at most a few MB; a larger file (a run's run.h5) is none, and is not read.
  constexpr std::uintmax_t kLargestPacking = std::uintmax_t{1} << 30;
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || size > kLargestPacking) return false;
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  char first = 0;
  while (in.get(first) && std::isspace(static_cast<unsigned char>(first))) {
  }
  if (first != '{') return false;  // a case file, an HDF5 file, LAMMPS data...
  in.unget();
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return false;
  const auto format = j.find("format");
  return format != j.end() && format->is_string() && *format == kPackingFormat;
}

void check_packing_destination(const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  const std::string file = path.string();
  const fs::path name = path.filename();
  if (name.empty() || name == "." || name == "..")
    throw ConfigError(file, "", "names a folder: give the packing file's name (e.g. packing.json)");
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (fs::exists(status) && !fs::is_regular_file(status))
    throw ConfigError(file, "",
                      "exists and is not a regular file (a folder, a FIFO or a device): remove it "
                      "or give another name");
  if (fs::exists(status) && !is_packing_file(path))
    throw ConfigError(file, "",
                      "exists and is not a cdshear packing (a JSON object with format "
                      "\"cdshear-packing\"): only a packing is replaced; remove it or give another "
                      "name");
  if (path.has_parent_path()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec)
      throw ConfigError(path.parent_path().string(), "",
                        "cannot make the packing's folder (" + ec.message() + ")");
  }
  // The temporary write_file_atomic writes first, made and removed now.
  const fs::path probe = temporary_path(path);
  {
    std::ofstream out(probe, std::ios::binary | std::ios::trunc);
    if (!out)
      throw ConfigError(file, "",
                        std::string("cannot be written there (") + std::strerror(errno) + ")");
  }
  fs::remove(probe, ec);
}

namespace {

/// Parses JSON, refusing a key given twice in one object (the JSON library keeps the last one
/// silently). Throws ConfigError naming the file.
nlohmann::json parse_without_duplicate_keys(std::istream& in, const std::string& file) {
  using Event = nlohmann::json::parse_event_t;
  std::vector<std::set<std::string>> keys_by_depth;  // one set per open object
  std::string duplicate;
  auto watch = [&](int, Event event, nlohmann::json& parsed) {
    if (event == Event::object_start) {
      keys_by_depth.emplace_back();
    } else if (event == Event::object_end) {
      keys_by_depth.pop_back();
    } else if (event == Event::key && duplicate.empty() &&
               !keys_by_depth.back().insert(parsed.get<std::string>()).second) {
      duplicate = parsed.get<std::string>();
    }
    return true;
  };
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in, watch);
  } catch (const nlohmann::json::exception& e) {  // syntax, or a number out of range
    throw ConfigError(file, "", "not valid JSON: " + json_message(e));
  }
  if (!duplicate.empty()) throw ConfigError(file, duplicate, "is given twice");
  return j;
}

}  // namespace

Packing read_packing(const std::filesystem::path& path, double overlap_tolerance) {
  const std::string file = path.string();
  if (std::filesystem::exists(path) && !std::filesystem::is_regular_file(path))
    throw ConfigError(file, "", "is not a regular file (a folder?)");
  std::ifstream in(path);
  if (!in) throw ConfigError(file, "", "packing file not found (run `cdshear prepare` first)");
  const nlohmann::json j = parse_without_duplicate_keys(in, file);
  if (!j.is_object()) throw ConfigError(file, "", "not a packing file (not a JSON object)");
  auto need = [&](const char* key) -> const nlohmann::json& {
    if (!j.contains(key)) throw ConfigError(file, key, "is missing");
    return j.at(key);
  };
  if (need("format") != kPackingFormat) throw ConfigError(file, "format", "not a packing file");
  const nlohmann::json known = packing_json(Packing{});
  for (const auto& [key, value] : j.items())
    if (!known.contains(key))
      throw ConfigError(file, key,
                        "unknown key (a packing holds the keys `cdshear prepare` writes)");
  if (j.contains("version") && j.at("version") != kPackingVersion)
    throw ConfigError(file, "version",
                      fmt::format("is {}; this cdshear reads version {}",
                                  json_shown(j.at("version")), kPackingVersion));
  auto number = [&](const char* key) {
    const nlohmann::json& v = need(key);
    if (!v.is_number()) throw ConfigError(file, key, "must be a number, not " + json_shown(v));
    return v.get<double>();
  };
  Packing p;
  p.height = number("height");
  p.length_x = number("length_x");
  p.diameter_min = number("diameter_min");
  p.diameter_max = number("diameter_max");
  // The seeds a case can give (a TOML integer): a packing placed with another could never be
  // the case's.
  if (const nlohmann::json& seed = need("seed");
      !is_whole_number(seed) || seed.get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX))
    throw ConfigError(file, "seed",
                      "must be a whole number from 0 to " + std::to_string(INT64_MAX) + ", not " +
                          json_shown(seed));
  p.seed = j.at("seed").get<std::uint64_t>();
  p.piston_stress = number("piston_stress");
  p.preparation_time = j.contains("preparation_time") ? number("preparation_time") : 0.0;
  for (const char* key : {"build", "program_version"})
    if (j.contains(key) && !j.at(key).is_string())
      throw ConfigError(
          file, key,
          "must be a string (the program that prepared the packing), not " + json_shown(j.at(key)));
  if (j.contains("build")) p.build = j.at("build").get<std::string>();
  // How the preparation's numerics behaved: optional (a packing written by hand need not say),
  // but a count is a whole number >= 0 and no count exceeds the steps it counts.
  auto count = [&](const char* key) -> std::uint64_t {
    if (!j.contains(key)) return 0;
    if (!is_whole_number(j.at(key)))
      throw ConfigError(file, key, "must be a whole number >= 0, not " + json_shown(j.at(key)));
    return j.at(key).get<std::uint64_t>();
  };
  p.preparation_steps = count("preparation_steps");
  p.capped_steps = count("capped_steps");
  p.displacement_warnings = count("displacement_warnings");
  for (const auto& [key, value] : {std::pair{"capped_steps", p.capped_steps},
                                   {"displacement_warnings", p.displacement_warnings}})
    if (j.contains("preparation_steps") && value > p.preparation_steps)
      throw ConfigError(file, key,
                        fmt::format("is {}, more than the preparation's {} steps "
                                    "(preparation_steps)",
                                    value, p.preparation_steps));
  if (j.contains("largest_overlap")) {
    p.largest_overlap = number("largest_overlap");
    if (!(p.largest_overlap >= 0) || !std::isfinite(p.largest_overlap))
      throw ConfigError(file, "largest_overlap", "must be a finite number >= 0");
  }
  const nlohmann::json& list = need("disks_xyr");
  if (!list.is_array()) throw ConfigError(file, "disks_xyr", "must be a list of [x, y, r]");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const nlohmann::json& d = list[i];
    if (!d.is_array() || d.size() != 3 || !d[0].is_number() || !d[1].is_number() ||
        !d[2].is_number()) {
      throw ConfigError(file, fmt::format("disks_xyr[{}]", i),
                        "must be [x, y, r], three numbers, not " + json_shown(d));
    }
    p.disks.push_back({{d[0].get<double>(), d[1].get<double>()}, d[2].get<double>()});
  }
  if (j.contains("n") && (!j.at("n").is_number_unsigned() || j.at("n") != p.disks.size()))
    throw ConfigError(
        file, "n",
        fmt::format("is {}, but disks_xyr lists {} disks", json_shown(j.at("n")), p.disks.size()));
  for (const auto& [key, value] : {std::pair{"height", p.height}, {"length_x", p.length_x}})
    if (!(value > 0) || !std::isfinite(value))
      throw ConfigError(file, key, fmt::format("must be a finite number > 0, not {}", value));
  if (!(p.diameter_min > 0) || !std::isfinite(p.diameter_max))
    throw ConfigError(file, "diameter_min", "diameters must be finite numbers > 0");
  if (!(p.diameter_max >= p.diameter_min))
    throw ConfigError(file, "diameter_max", "must be >= diameter_min");
  if (!(p.piston_stress > 0) || !std::isfinite(p.piston_stress))
    throw ConfigError(file, "piston_stress", "must be a finite number > 0");
  if (!(p.preparation_time >= 0) || !std::isfinite(p.preparation_time))
    throw ConfigError(file, "preparation_time", "must be a finite number >= 0");
  // The diameters the metadata give are those the case is checked against
  // (check_packing_fits_case): a disk outside them would be sheared as a grain of another
  // system. The relative 1e-12 allows the rounding of a radius drawn at a bound.
  const double smallest = p.diameter_min * (1 - 1e-12), largest = p.diameter_max * (1 + 1e-12);
  for (std::size_t i = 0; i < p.disks.size(); ++i) {
    const PackingDisk& d = p.disks[i];
    const std::string key = fmt::format("disks_xyr[{}]", i);
    if (!(d.radius > 0)) throw ConfigError(file, key, "radius must be > 0");
    if (!(2 * d.radius >= smallest && 2 * d.radius <= largest))
      throw ConfigError(file, key,
                        fmt::format("diameter {} outside the packing's diameter_min to "
                                    "diameter_max ({} to {})",
                                    2 * d.radius, p.diameter_min, p.diameter_max));
    if (!(std::abs(d.position.x) <= kMaxPeriodsFromOrigin * p.length_x))
      throw ConfigError(file, key,
                        fmt::format("x = {} is more than a million periods (length_x = {}) from "
                                    "0: give the disk's place within the period",
                                    d.position.x, p.length_x));
    if (d.position.y - d.radius < -overlap_tolerance ||
        d.position.y + d.radius > p.height + overlap_tolerance)
      throw ConfigError(
          file, key,
          fmt::format("disk crosses a wall (y = {}, r = {}, L_y = {}) by more than the "
                      "tolerance {:.3g} (in a shear run, a tenth of step.abort_overlap)",
                      d.position.y, d.radius, p.height, overlap_tolerance));
  }
  p.solid_fraction = solid_fraction(p.disks, p.length_x, p.height);
  // The walls rest on the grains: in a cell far wider than its disks fill, the piston's load
  // (sigma_yy L_x) falls on a few grains, and a period typed wrong gives no clearer sign than this.
  if (!p.disks.empty() &&
      !(p.solid_fraction >= kSmallestPackingSolidFraction && p.solid_fraction <= 1.0))
    throw ConfigError(
        file, "length_x",
        fmt::format("the disks fill a fraction {:.3g} of the cell L_x x L_y = {} x "
                    "{}; a packing fills between {} and 1 (is length_x right?)",
                    p.solid_fraction, p.length_x, p.height, kSmallestPackingSolidFraction));
  // The file's own figure is the disks' (written from them): one that disagrees says the disks or
  // the cell were edited without it, or it was.
  if (j.contains("solid_fraction")) {
    const double given = number("solid_fraction");
    if (!(std::abs(given - p.solid_fraction) <= 1e-9 * p.solid_fraction))
      throw ConfigError(file, "solid_fraction",
                        fmt::format("is {}, but the disks fill {} of the cell L_x x L_y = {} x {} "
                                    "(were the disks, length_x or height edited?)",
                                    given, p.solid_fraction, p.length_x, p.height));
  }
  return p;
}

void check_packing_fits_case(const ShearCase& c, const Packing& p, const std::string& file) {
  if (p.n() != c.n)
    throw ConfigError(
        file, "n",
        fmt::format("packing has {} disks, the case asks for {} (system.n)", p.n(), c.n));
  if (std::abs(p.height - c.height) > 1e-9 * c.height)
    throw ConfigError(file, "height",
                      fmt::format("packing has L_y = {}, the case asks for {} (system.height)",
                                  p.height, c.height));
  if (const bool min_differs = std::abs(p.diameter_min - c.diameter_min) > 1e-12;
      min_differs || std::abs(p.diameter_max - c.diameter_max) > 1e-12)
    throw ConfigError(file, min_differs ? "diameter_min" : "diameter_max",
                      fmt::format("packing diameters [{}, {}] differ from the case's [{}, {}]",
                                  p.diameter_min, p.diameter_max, c.diameter_min, c.diameter_max));
}

std::string packing_cache_name(const PreparationOptions& o) {
  // Every option of the protocol enters the name through a hash, so that changing any of them
  // (gravity, thresholds, time steps, solver) never silently reuses an old packing.
  const SolverOptions& s = o.step.solver;
  const std::string all =
      fmt::format("{} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {} {}", o.n,
                  o.height, o.diameter_min, o.diameter_max, o.seed, o.initial_solid_fraction,
                  o.gravity, o.piston_stress, o.piston_mass, o.settle_kinetic_energy_per_disk,
                  o.kinetic_energy_per_disk, o.piston_speed, o.force_balance, o.window_time,
                  o.max_time_per_phase, o.step.dt, o.compression_dt, o.step.contact_margin,
                  o.step.abort_overlap, s.alpha, s.converged_fraction, s.max_sweeps, s.seed);
  // Added only when they differ from the values they were introduced with (relaxation 1, random
  // order, every contact swept, no slab correction), so that the names of packings made before them
  // hold: a packing prepared in the random order keeps its name, and the default, the coloured
  // order, carries " ocoloured".
  std::string added = s.relaxation != 1.0 ? fmt::format(" r{}", s.relaxation) : "";
  if (s.order != ContactOrder::kRandom) added += fmt::format(" o{}", contact_order_name(s.order));
  if (s.skip_dormant) added += " sd";
  if (s.slab_correction_period != 0) added += fmt::format(" sc{}", s.slab_correction_period);
  if (s.normal_compliance != 0.0) added += fmt::format(" nc{}", s.normal_compliance);
  std::uint32_t h = 2166136261u;  // FNV-1a
  for (const unsigned char ch : all + added) h = (h ^ ch) * 16777619u;
  return fmt::format("n{}_h{}_d{}-{}_seed{}_s{}_{:08x}.json", o.n, o.height, o.diameter_min,
                     o.diameter_max, o.seed, o.piston_stress, h);
}

}  // namespace cdshear

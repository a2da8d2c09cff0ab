#include "packing_file.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "config_error.hpp"
#include "outputs.hpp"

namespace cdshear {

void write_packing(const std::filesystem::path& path, const Packing& p) {
  nlohmann::json disks = nlohmann::json::array();
  for (const PackingDisk& d : p.disks) disks.push_back({d.position.x, d.position.y, d.radius});
  const nlohmann::json j = {{"format", "cdshear-packing"},
                            {"version", 1},
                            {"program_version", CDSHEAR_VERSION},
                            {"n", p.n()},
                            {"height", p.height},
                            {"length_x", p.length_x},
                            {"diameter_min", p.diameter_min},
                            {"diameter_max", p.diameter_max},
                            {"seed", p.seed},
                            {"solid_fraction", p.solid_fraction},
                            {"piston_stress", p.piston_stress},
                            {"preparation_time", p.preparation_time},
                            {"preparation_steps", p.preparation_steps},
                            {"capped_steps", p.capped_steps},
                            {"displacement_warnings", p.displacement_warnings},
                            {"largest_overlap", p.largest_overlap},
                            {"disks_xyr", disks}};
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  write_file_atomic(path, j.dump(1) + "\n");
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

Packing read_packing(const std::filesystem::path& path, double overlap_tolerance) {
  const std::string file = path.string();
  if (std::filesystem::exists(path) && !std::filesystem::is_regular_file(path))
    throw ConfigError(file, "", "is not a regular file (a folder?)");
  std::ifstream in(path);
  if (!in) throw ConfigError(file, "", "packing file not found (run `cdshear prepare` first)");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {  // syntax, or a number out of range
    throw ConfigError(file, "", std::string("not valid JSON: ") + e.what());
  }
  auto need = [&](const char* key) -> const nlohmann::json& {
    if (!j.contains(key)) throw ConfigError(file, key, "is missing");
    return j.at(key);
  };
  if (need("format") != "cdshear-packing") throw ConfigError(file, "format", "not a packing file");
  Packing p;
  try {
    p.height = need("height").get<double>();
    p.length_x = need("length_x").get<double>();
    p.diameter_min = need("diameter_min").get<double>();
    p.diameter_max = need("diameter_max").get<double>();
    p.seed = need("seed").get<std::uint64_t>();
    p.piston_stress = need("piston_stress").get<double>();
    p.preparation_time = j.value("preparation_time", 0.0);
    for (const auto& d : need("disks_xyr"))
      p.disks.push_back({{d.at(0).get<double>(), d.at(1).get<double>()}, d.at(2).get<double>()});
  } catch (const nlohmann::json::exception& e) {
    throw ConfigError(file, "", std::string("malformed packing: ") + e.what());
  }
  if (!(p.height > 0) || !(p.length_x > 0))
    throw ConfigError(file, "length_x", "cell sizes must be > 0");
  for (std::size_t i = 0; i < p.disks.size(); ++i) {
    const PackingDisk& d = p.disks[i];
    const std::string key = fmt::format("disks_xyr[{}]", i);
    if (!(d.radius > 0)) throw ConfigError(file, key, "radius must be > 0");
    if (d.position.y - d.radius < -overlap_tolerance ||
        d.position.y + d.radius > p.height + overlap_tolerance)
      throw ConfigError(file, key,
                        fmt::format("disk crosses a wall (y = {}, r = {}, L_y = {})", d.position.y,
                                    d.radius, p.height));
  }
  p.solid_fraction = solid_fraction(p.disks, p.length_x, p.height);
  return p;
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
  std::uint32_t h = 2166136261u;  // FNV-1a
  for (const unsigned char ch : all + added) h = (h ^ ch) * 16777619u;
  return fmt::format("n{}_h{}_d{}-{}_seed{}_s{}_{:08x}.json", o.n, o.height, o.diameter_min,
                     o.diameter_max, o.seed, o.piston_stress, h);
}

}  // namespace cdshear

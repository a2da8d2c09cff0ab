#include "observers.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <vector>

namespace cdshear {

namespace {

/// The time each file of a .pvd that write_pvd wrote is listed at; empty where it cannot be
/// read.
std::map<std::string, double> listed_times(const std::filesystem::path& pvd) {
  std::map<std::string, double> times;
  std::ifstream in(pvd);
  const std::regex entry(R"re(<DataSet timestep="([^"]+)" file="([^"]+)"/>)re");
  std::string line;
  std::smatch m;
  while (std::getline(in, line))
    if (std::regex_search(line, m, entry)) {
      char* end = nullptr;
      const double t = std::strtod(m[1].str().c_str(), &end);
      if (end && *end == '\0' && std::isfinite(t)) times[m[2].str()] = t;
    }
  return times;
}

}  // namespace

SnapshotObserver::SnapshotObserver(std::filesystem::path dir, double dt, std::uint64_t resumed_step)
    : dir_(std::move(dir)), dt_(dt) {
  // The folder is made at the first snapshot: a run that ends before one leaves none.
  std::error_code ec;
  if (resumed_step == 0 || !std::filesystem::is_directory(dir_, ec)) return;
  const std::map<std::string, double> times = listed_times(dir_ / "particles.pvd");
  std::vector<std::uint64_t> steps;
  const std::regex name(R"(particles_([0-9]{10})\.vtp)");
  for (const auto& e : std::filesystem::directory_iterator(dir_, ec)) {
    std::smatch m;
    const std::string file = e.path().filename().string();
    if (!std::regex_match(file, m, name)) continue;
    const std::uint64_t s = std::stoull(m[1].str());
    if (s > 0 && s <= resumed_step) steps.push_back(s);
  }
  std::sort(steps.begin(), steps.end());
  for (const std::uint64_t s : steps) {
    const auto listed = times.find(fmt::format("particles_{:010}.vtp", s));
    add(s, listed != times.end() ? listed->second : static_cast<double>(s) * dt);
  }
}

void SnapshotObserver::add(std::uint64_t step, double time) {
  particles_.push_back({time, fmt::format("particles_{:010}.vtp", step)});
  contacts_.push_back({time, fmt::format("contacts_{:010}.vtp", step)});
}

void SnapshotObserver::observe(const World& world, const ContactDynamics& dynamics,
                               const StepReport&) {
  // Time as step * dt (not the accumulated world.time) so that a resumed run lists the same.
  if (particles_.empty()) std::filesystem::create_directories(dir_);
  add(world.step, static_cast<double>(world.step) * dt_);
  write_particles_vtp(dir_ / particles_.back().file, world, dynamics.contacts());
  write_contacts_vtp(dir_ / contacts_.back().file, world, dynamics.contacts(), dt_);
  write_pvd(dir_ / "particles.pvd", particles_);
  write_pvd(dir_ / "contacts.pvd", contacts_);
}

}  // namespace cdshear

#include "outputs.hpp"

#include <fmt/format.h>
#include <fmt/os.h>
#include <fmt/ranges.h>

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <vector>

#include "config_error.hpp"

namespace cdshear {

std::filesystem::path temporary_path(const std::filesystem::path& path) {
  return path.string() + ".tmp." + std::to_string(::getpid());
}

namespace {

/// A temporary's name split at its infix: the file it writes and its writer's process number.
struct TemporaryName {
  std::string_view written;
  std::string_view pid_digits;
};

std::optional<TemporaryName> split_temporary(std::string_view name) {
  constexpr std::string_view infix = ".tmp.";
  const auto tmp = name.rfind(infix);
  if (tmp == std::string_view::npos || tmp == 0 ||
      name.substr(0, tmp).find(infix) != std::string_view::npos)
    return std::nullopt;
  const std::string_view pid = name.substr(tmp + infix.size());
  if (pid.empty() || pid.find_first_not_of("0123456789") != std::string_view::npos)
    return std::nullopt;
  return TemporaryName{name.substr(0, tmp), pid};
}

}  // namespace

std::optional<std::string_view> temporary_of(std::string_view name) {
  const std::optional<TemporaryName> parts = split_temporary(name);
  return parts ? std::optional<std::string_view>(parts->written) : std::nullopt;
}

void remove_dead_writers_temporaries(const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  const std::string target = path.filename().string();
  const fs::path folder = path.has_parent_path() ? path.parent_path() : fs::path(".");
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(folder, ec)) {
    const std::string name = e.path().filename().string();
    const std::optional<TemporaryName> parts = split_temporary(name);
    if (!parts || parts->written != target) continue;
    // Process numbers have at most 7 digits (Linux's largest is 4194304); a longer number is no
    // process's.
    long pid = 0;
    const std::string_view digits = parts->pid_digits;
    if (digits.size() > 9 ||
        std::from_chars(digits.data(), digits.data() + digits.size(), pid).ec != std::errc())
      continue;
    // kill(pid, 0) sends nothing: ESRCH says no process has that number.
    if (pid > 0 && pid != ::getpid() && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH &&
        e.is_regular_file(ec))
      fs::remove(e.path(), ec);
  }
}

void write_file_atomic(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path tmp = temporary_path(path);
  std::error_code ec;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out)
      throw WriteError(tmp.string(),
                       "cannot open for writing (" + std::string(std::strerror(errno)) + ")");
    out << text;
    out.flush();
    if (!out) {
      out.close();
      std::filesystem::remove(tmp, ec);  // never leave a half-written temporary behind
      throw WriteError(tmp.string(), "write failed (disk full?)");
    }
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec)
    throw WriteError(path.string(), "cannot rename the new file " + tmp.string() + " into place: " +
                                        ec.message() + " (that file holds the new content)");
}

namespace {
const char* mode_name(AxisMode m) {
  return m == AxisMode::kFree ? "free" : m == AxisMode::kImposed ? "imposed" : "fixed";
}
}  // namespace

nlohmann::json state_to_json(const World& world) {
  using nlohmann::json;
  json disks = json::array();
  const Disks& d = world.disks;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const Vec2 u = world.unwrapped_position(i);
    disks.push_back({{"x", d.position[i].x},
                     {"y", d.position[i].y},
                     {"x_unwrapped", u.x},
                     {"radius", d.radius[i]},
                     {"vx", d.velocity[i].x},
                     {"vy", d.velocity[i].y},
                     {"omega", d.omega[i]},
                     {"angle", d.angle[i]}});
  }
  json walls = json::array();
  for (const Wall& w : world.walls) {
    walls.push_back({{"name", w.name},
                     {"point", {w.point.x, w.point.y}},
                     {"normal", {w.normal.x, w.normal.y}},
                     {"velocity", {w.velocity.x, w.velocity.y}},
                     {"mode_x", mode_name(w.mode_x)},
                     {"mode_y", mode_name(w.mode_y)},
                     {"contact_force", {w.contact_force.x, w.contact_force.y}},
                     {"contact_impulse", {w.contact_impulse.x, w.contact_impulse.y}}});
  }
  return {{"time", world.time},
          {"step", world.step},
          {"periodic_x", world.domain.periodic_x},
          {"length_x", world.domain.length_x},
          {"disks", disks},
          {"walls", walls}};
}

TimeSeriesWriter::TimeSeriesWriter(const std::filesystem::path& path, const World& world)
    : out_(path, std::ios::trunc) {
  if (!out_) throw WriteError(path.string(), "cannot open for writing");
  out_ << fmt::format("{}", fmt::join(kColumns, ","));
  for (const Wall& w : world.walls)
    for (const std::string_view suffix : kWallColumnSuffixes) out_ << ',' << w.name << suffix;
  out_ << '\n';
  out_.flush();
}

void TimeSeriesWriter::write(const World& world, const StepReport& r, const IntervalStats& s) {
  const Vec2 p = linear_momentum(world);
  std::string row =
      fmt::format("{},{},{},{},{},{},{},{},{},{},{},{}", world.step, world.time,
                  kinetic_energy(world), p.x, p.y, r.contacts, r.solver.active_contacts,
                  s.capped_steps, s.sweeps_mean(), s.sweeps_max, s.residual_max, s.overlap_max);
  for (const Wall& w : world.walls)
    row +=
        fmt::format(",{},{},{},{},{},{},{},{}", w.point.x, w.point.y, w.velocity.x, w.velocity.y,
                    w.contact_force.x, w.contact_force.y, w.contact_impulse.x, w.contact_impulse.y);
  row += '\n';
  out_ << row;
  out_.flush();
  if (!out_) throw WriteError("time series", "write failed (disk full?)");
}

}  // namespace cdshear

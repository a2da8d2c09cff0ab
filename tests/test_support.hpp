// Shared helpers of the test suite: scene pieces, a world + stepper bundle, temporary files.
// Every world in the tests is built by the project's one scene builder (build_world).
#pragma once

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "contact_dynamics.hpp"
#include "scene.hpp"
#include "scene_presets.hpp"
#include "threads.hpp"
#include "world.hpp"

/// Skips the rest of a test that compares thread counts where only one thread can run (one
/// processor, or a build without OpenMP): it would compare one thread with itself and could not
/// fail. A skipped test is reported as such.
#define CDSHEAR_SKIP_IF_ONE_PROCESSOR()                                                         \
  do {                                                                                          \
    if (::cdshear::processors_available() < 2)                                                  \
      GTEST_SKIP() << "one processor (or a build without OpenMP): no second thread to compare"; \
  } while (false)

namespace cdshear::testing {

/// The shear cell in small: `count` disks compressed in a box periodic in x over `width` under
/// sigma_yy = 0.25 (scene_presets.hpp), its top wall then driven along x at `speed`. Densified
/// once per call; `dense` says whether it settled.
struct ShearedBox {
  World world;
  ContactDynamics dynamics;
  bool dense = false;
};
inline ShearedBox sheared_dense_box(std::size_t count, double width, double speed) {
  CompressedBoxParams p;
  p.count = count;
  p.width = width;
  p.periodic_x = true;
  DenseBox box = make_dense_box(p);
  Wall& top = box.world.walls[kBoxTopWall];
  top.mode_x = AxisMode::kImposed;
  top.velocity.x = speed;
  return {std::move(box.world), std::move(box.dynamics), box.report.dense};
}

/// Mass of a uniform disk of radius r and 2D density rho (docs/model.md section 1).
inline double disk_mass(double r, double rho = 1.0) {
  return rho * std::numbers::pi * r * r;
}

/// A fixed wall through `point` with inward unit `normal`.
inline Wall fixed_wall(std::string name, Vec2 point, Vec2 normal, double friction = 0.5) {
  Wall w;
  w.name = std::move(name);
  w.point = point;
  w.normal = normal;
  w.friction = friction;
  return w;
}

/// A wall free along y (Newton's law with mass and applied force), fixed along x.
inline Wall free_y_wall(std::string name, Vec2 point, Vec2 normal, double mass, Vec2 force,
                        double friction = 0.5) {
  Wall w = fixed_wall(std::move(name), point, normal, friction);
  w.mode_y = AxisMode::kFree;
  w.mass = mass;
  w.applied_force = force;
  return w;
}

inline DiskSpec disk(Vec2 position, double radius, Vec2 velocity = {}, double omega = 0.0) {
  DiskSpec d;
  d.position = position;
  d.radius = radius;
  d.velocity = velocity;
  d.omega = omega;
  return d;
}

/// `count` disks of radius `radius` stacked on a fixed floor (y = 0) under gravity `g`, touching,
/// at rest: disk k at y = radius (2k + 1).
inline SceneDefinition disk_column(int count, double radius, double g) {
  SceneDefinition s;
  s.gravity = {0.0, -g};
  s.walls.push_back(fixed_wall("floor", {0.0, 0.0}, {0.0, 1.0}));
  for (int k = 0; k < count; ++k) s.disks.push_back(disk({0.0, radius + 2.0 * radius * k}, radius));
  return s;
}

/// A world built from a scene definition, with its stepper and the reports of its steps.
struct Simulation {
  World world;
  ContactDynamics dynamics;
  StepOptions options;
  std::vector<StepReport> reports;

  Simulation(const SceneDefinition& scene, const StepOptions& step_options)
      : world(build_world(scene)), options(step_options) {}

  /// Steps n times, calling `after` (if given) after each step. Stops at a blown-up step.
  void run(int n, const std::function<void(const Simulation&, const StepReport&)>& after = {}) {
    for (int k = 0; k < n; ++k) {
      reports.push_back(dynamics.step(world, options));
      if (after) after(*this, reports.back());
      if (reports.back().blown_up) return;
    }
  }

  const StepReport& last() const { return reports.back(); }

  /// The contact with this key in the solver's list, if any.
  std::optional<Contact> contact(int a, int b, int image = 0) const {
    for (const Contact& c : dynamics.contacts())
      if (c.key.body_a == a && c.key.body_b == b && c.key.image_b == image) return c;
    return std::nullopt;
  }

  int hit_cap_steps() const {
    return static_cast<int>(std::count_if(reports.begin(), reports.end(),
                                          [](const StepReport& r) { return r.solver.hit_cap; }));
  }
  double largest_overlap() const {
    double m = 0.0;
    for (const StepReport& r : reports) m = std::max(m, r.max_overlap);
    return m;
  }
};

/// A fresh folder under the system temporary directory, removed with the object.
class TempDir {
 public:
  explicit TempDir(const std::string& tag) {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("cdshear_test_" + tag + "_" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  /// Writes `text` into `name` inside the folder and returns its full path.
  std::string write(const std::string& name, const std::string& text) const {
    const std::filesystem::path p = path_ / name;
    std::ofstream(p) << text;
    return p.string();
  }

 private:
  std::filesystem::path path_;
};

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace cdshear::testing

#include "world.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>

namespace cdshear {

std::size_t Disks::add(Vec2 centre, double radius_value, double density) {
  const double m = density * std::numbers::pi * radius_value * radius_value;
  position.push_back(centre);
  image.push_back(0);
  angle.push_back(0.0);
  velocity.push_back({});
  omega.push_back(0.0);
  radius.push_back(radius_value);
  mass.push_back(m);
  inertia.push_back(0.5 * m * radius_value * radius_value);
  return position.size() - 1;
}

void Disks::clear() {
  *this = Disks{};
}

double kinetic_energy(const World& world) {
  const Disks& d = world.disks;
  double e = 0.0;
  for (std::size_t i = 0; i < d.size(); ++i)
    e += 0.5 * d.mass[i] * length_squared(d.velocity[i]) +
         0.5 * d.inertia[i] * d.omega[i] * d.omega[i];
  return e;
}

Vec2 linear_momentum(const World& world) {
  Vec2 p;
  for (std::size_t i = 0; i < world.disks.size(); ++i)
    p += world.disks.mass[i] * world.disks.velocity[i];
  return p;
}

double angular_momentum(const World& world) {
  const Disks& d = world.disks;
  double l = 0.0;
  for (std::size_t i = 0; i < d.size(); ++i)
    l += d.mass[i] * cross(world.unwrapped_position(i), d.velocity[i]) + d.inertia[i] * d.omega[i];
  return l;
}

double max_radius(const World& world) {
  const auto& r = world.disks.radius;
  return r.empty() ? 0.0 : *std::max_element(r.begin(), r.end());
}

void wrap_positions(World& world) {
  if (!world.domain.periodic_x) return;
  const double lx = world.domain.length_x;
  Disks& d = world.disks;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const double shift = std::floor(d.position[i].x / lx);
    if (shift != 0.0) {
      d.position[i].x -= shift * lx;
      d.image[i] += static_cast<std::int64_t>(shift);
      if (d.position[i].x >= lx) {  // rounding: a tiny negative x + L_x can round to L_x
        d.position[i].x -= lx;
        ++d.image[i];
      }
    }
  }
}

namespace {
struct Fnv1a {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t k = 0; k < n; ++k) h = (h ^ c[k]) * 1099511628211ull;
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    if (!v.empty()) bytes(v.data(), v.size() * sizeof(T));
  }
};
}  // namespace

std::uint64_t state_hash(const World& world) {
  Fnv1a f;
  f.vec(world.disks.position);
  f.vec(world.disks.image);
  f.vec(world.disks.angle);
  f.vec(world.disks.velocity);
  f.vec(world.disks.omega);
  for (const Wall& w : world.walls) {
    f.bytes(&w.point, sizeof w.point);
    f.bytes(&w.velocity, sizeof w.velocity);
  }
  f.bytes(&world.time, sizeof world.time);
  return f.h;
}

}  // namespace cdshear

// Two-dimensional vector and the few operations the engine needs.
#pragma once

#include <cmath>

namespace cdshear {

struct Vec2 {
  double x = 0.0;
  double y = 0.0;

  constexpr Vec2& operator+=(Vec2 o) {
    x += o.x;
    y += o.y;
    return *this;
  }
  constexpr Vec2& operator-=(Vec2 o) {
    x -= o.x;
    y -= o.y;
    return *this;
  }
  constexpr Vec2& operator*=(double s) {
    x *= s;
    y *= s;
    return *this;
  }
  friend constexpr bool operator==(Vec2, Vec2) = default;
};

constexpr Vec2 operator+(Vec2 a, Vec2 b) {
  return {a.x + b.x, a.y + b.y};
}
constexpr Vec2 operator-(Vec2 a, Vec2 b) {
  return {a.x - b.x, a.y - b.y};
}
constexpr Vec2 operator-(Vec2 a) {
  return {-a.x, -a.y};
}
constexpr Vec2 operator*(double s, Vec2 a) {
  return {s * a.x, s * a.y};
}
constexpr Vec2 operator*(Vec2 a, double s) {
  return {s * a.x, s * a.y};
}
constexpr double dot(Vec2 a, Vec2 b) {
  return a.x * b.x + a.y * b.y;
}
/// z-component of the 3D cross product a x b.
constexpr double cross(Vec2 a, Vec2 b) {
  return a.x * b.y - a.y * b.x;
}
/// a rotated by +90 degrees (counter-clockwise).
constexpr Vec2 perp(Vec2 a) {
  return {-a.y, a.x};
}
/// Component-wise product (used for per-axis inverse masses of walls).
constexpr Vec2 hadamard(Vec2 a, Vec2 b) {
  return {a.x * b.x, a.y * b.y};
}
inline double length(Vec2 a) {
  return std::hypot(a.x, a.y);
}
constexpr double length_squared(Vec2 a) {
  return dot(a, a);
}
/// Distance between two disk centres from its square: the square root of the sum of squares,
/// not std::hypot. Centres in contact or near it are a few diameters apart at most, where the sum
/// of squares can neither overflow nor underflow, and both are within about an ulp of the exact
/// distance; hypot's care for extreme magnitudes cost 3% of a step (perf, system 7, one thread),
/// a call per candidate contact. `length` keeps hypot for vectors of any size (user input).
inline double centre_distance(double distance_squared) {
  return std::sqrt(distance_squared);
}

}  // namespace cdshear

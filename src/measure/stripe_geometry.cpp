#include "stripe_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace cdshear {
namespace {

/// A(u) / r^2, M(u) / r^3, Y2(u) / r^4 and X2(u) / r^4 of the header's derivation.
double area_below(double u) {
  return std::asin(u) + u * std::sqrt(1.0 - u * u) + 0.5 * std::numbers::pi;
}
double moment_below(double u) {
  const double c = 1.0 - u * u;
  return -(2.0 / 3.0) * c * std::sqrt(c);
}
double second_y_below(double u) {
  return 0.25 *
         (std::asin(u) - u * std::sqrt(1.0 - u * u) * (1.0 - 2.0 * u * u) + 0.5 * std::numbers::pi);
}
double second_x_below(double u) {
  return (u * std::sqrt(1.0 - u * u) * (5.0 - 2.0 * u * u) + 3.0 * std::asin(u) +
          1.5 * std::numbers::pi) /
         12.0;
}

}  // namespace

StripePart disk_in_stripe(double centre_y, double radius, double y0, double y1) {
  const double u0 = std::clamp((y0 - centre_y) / radius, -1.0, 1.0);
  const double u1 = std::clamp((y1 - centre_y) / radius, -1.0, 1.0);
  if (u1 <= u0) return {};
  const double r2 = radius * radius, r4 = r2 * r2;
  // Rounding can make a sliver's area or second moments a few 1e-16 negative: clamp them.
  return {std::max(0.0, r2 * (area_below(u1) - area_below(u0))),
          r2 * radius * (moment_below(u1) - moment_below(u0)),
          std::max(0.0, r4 * (second_y_below(u1) - second_y_below(u0))),
          std::max(0.0, r4 * (second_x_below(u1) - second_x_below(u0)))};
}

}  // namespace cdshear

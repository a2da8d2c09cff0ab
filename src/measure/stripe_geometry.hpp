// Exact geometry of a disk cut by a horizontal stripe (SPEC 7): the area of the part of the
// disk between two heights and its first moment about the disk's centre height.
//
// Derivation. For a disk of radius r centred at height y_c, write u = (y - y_c) / r clamped to
// [-1, 1]. The chord at height y' (relative to the centre) has length 2 sqrt(r^2 - y'^2), so the
// area below u is
//   A(u) = int_{-r}^{r u} 2 sqrt(r^2 - y'^2) dy' = r^2 (asin u + u sqrt(1 - u^2) + pi/2),
// and the first moment of that area about the centre height is
//   M(u) = int_{-r}^{r u} y' 2 sqrt(r^2 - y'^2) dy' = -(2/3) r^3 (1 - u^2)^(3/2).
// A stripe [y0, y1] holds A(u1) - A(u0) with moment M(u1) - M(u0). The x-velocity of the
// material point at height y of a disk with centre velocity v_x and counter-clockwise angular
// velocity w is v_x - w (y - y_c), so its integral over the part is v_x S - w M exactly.
#pragma once

namespace cdshear {

struct StripePart {
  double area = 0.0;          ///< area of the disk between the two heights [length^2]
  double first_moment = 0.0;  ///< int (y - y_c) dS over that part [length^3]
};

/// The part of the disk (centre height `centre_y`, `radius`) between heights y0 <= y1.
StripePart disk_in_stripe(double centre_y, double radius, double y0, double y1);

}  // namespace cdshear

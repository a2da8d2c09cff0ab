// Exact geometry of a disk cut by a horizontal stripe (docs/model.md section 7): the area of the
// part of the disk between two heights, its first moment about the disk's centre height, and its
// second moments about the centre (for the kinetic stress of the grains' rotation).
//
// Derivation. For a disk of radius r centred at height y_c, write u = (y - y_c) / r clamped to
// [-1, 1] and s = sqrt(1 - u^2). The chord at height y' (relative to the centre) runs over
// |x'| <= sqrt(r^2 - y'^2), so the area below u is
//   A(u)  = int_{-r}^{r u} 2 sqrt(r^2 - y'^2) dy'        = r^2 (asin u + u s + pi/2),
// its first moment about the centre height
//   M(u)  = int_{-r}^{r u} y' 2 sqrt(r^2 - y'^2) dy'     = -(2/3) r^3 s^3,
// and its second moments about the centre
//   Y2(u) = int y'^2 dS = int_{-r}^{r u} y'^2 2 sqrt(r^2 - y'^2) dy'
//         = (r^4 / 4) (asin u - u s (1 - 2 u^2) + pi/2),
//   X2(u) = int x'^2 dS = int_{-r}^{r u} (2/3) (r^2 - y'^2)^(3/2) dy'
//         = (r^4 / 12) (u s (5 - 2 u^2) + 3 asin u + 3 pi / 2),
// each zero at u = -1 and pi r^4 / 4 for the whole disk; int x' dS and int x' y' dS vanish by
// symmetry. A stripe [y0, y1] holds the differences at u1 and u0. The material point at (x', y')
// of a disk with centre velocity v and counter-clockwise angular velocity w moves at
// (v_x - w y', v_y + w x'), so the part's integrals of the velocity and of its products follow
// exactly from S, M, X2 and Y2 (shear_measurement.hpp).
#pragma once

namespace cdshear {

struct StripePart {
  double area = 0.0;             ///< area of the disk between the two heights [length^2]
  double first_moment = 0.0;     ///< int (y - y_c) dS over that part [length^3]
  double second_moment_y = 0.0;  ///< int (y - y_c)^2 dS over that part [length^4]
  double second_moment_x = 0.0;  ///< int (x - x_c)^2 dS over that part [length^4]
};

/// The part of the disk (centre height `centre_y`, `radius`) between heights y0 <= y1.
StripePart disk_in_stripe(double centre_y, double radius, double y0, double y1);

}  // namespace cdshear

#!/usr/bin/python3
"""Where the velocities of a step's impulse error lie: translations of whole bands, spins, and
the contacts' normal and tangential velocities (docs/step-error.md, "Where the velocity error
lies").

Reads the samples that `cdshear_bench --step-error N --dump-samples DIR` writes (each sample's
contacts with the tested and the reference impulses, and the bodies). With e = R_tested -
R_reference over every contact, the error's velocities are dv = M^-1 H^T e (each disk's dv_x,
dv_y, dw) and its kinetic energy |A e|^2 = sum m |dv|^2 + I dw^2 (= e^T W e, W the Delassus
operator). Printed per sample, and as medians over the samples:

- impulse: |e| / |R_reference| (L2 over the contacts, as the bench's impulse_l2);
- band x, band y: the shares of |A e|^2 in each band's mass-weighted mean translation (bands of
  --band d by the disks' height, 4 d as the slab correction's): what a correction of whole bands
  could remove at most;
- spin: the share in the disks' spins; band spin: in each band's mean spin;
- spin corr: sum dw_i dw_j / sum (dw_i^2 + dw_j^2) / 2 over the reference's force-carrying
  contacts between two disks: -1 where neighbours' spin errors are opposite (gears), +1 where
  they are alike, 0 where unrelated;
- u_n, u_t: RMS over the reference's force-carrying contacts (walls' included) of the error's
  normal and tangential relative velocity (u_t from the translations and the spins together),
  divided by V;
- status, on status: of the contacts carrying force in either solve, how many are open,
  sticking or sliding in one and not in the other, and their share of sum u_t^2 over them all.

  cdshear_bench --packing P --velocity V --no-static --steps 40 --warmup 1000 --step-error 4 \
      --step-error-spacing 10 --reference-relaxation 1.6 --reference-anderson 5 --dump-samples DIR
  /usr/bin/python3 bench/error_modes.py DIR/shear_nN --velocity V
"""

import argparse

import numpy as np

from coarse_space import (BODY_A, BODY_B, FRICTION, LEVER_A, LEVER_B, NX, NY, REFERENCE_N,
                          REFERENCE_T, TESTED_N, TESTED_T, contact_status, sample_stems)

# The bodies' height and inverse masses (sample_K_bodies.txt: x, y, 1/m along x, along y, 1/I).
Y, INV_MASS_X, INV_MASS_Y, INV_INERTIA = 1, 2, 3, 4


def modes(stem, band, velocity):
    """The figures of one sample (a dict), from its two files."""
    c = np.loadtxt(stem + "_contacts.txt", comments="#", ndmin=2)
    b = np.loadtxt(stem + "_bodies.txt", comments="#", ndmin=2)
    a_of, b_of = c[:, BODY_A].astype(int), c[:, BODY_B].astype(int)
    e_n, e_t = c[:, TESTED_N] - c[:, REFERENCE_N], c[:, TESTED_T] - c[:, REFERENCE_T]
    normal = c[:, [NX, NY]]
    tangent = np.stack([-normal[:, 1], normal[:, 0]], 1)
    force = normal * e_n[:, None] + tangent * e_t[:, None]
    # Each disk's momentum from e: +R on body a, -R on body b, torques lever * R_t on both.
    momentum = np.zeros((len(b), 3))
    np.add.at(momentum, a_of, np.c_[force, c[:, LEVER_A] * e_t])
    np.add.at(momentum, b_of, np.c_[-force, c[:, LEVER_B] * e_t])
    inverse = b[:, [INV_MASS_X, INV_MASS_Y, INV_INERTIA]]
    dv = momentum * inverse
    # Mass and inertia per axis: 0 where the inverse is (a wall's fixed axes).
    weight = np.where(inverse > 0.0, 1.0 / np.where(inverse > 0.0, inverse, 1.0), 0.0)
    energy = (weight * dv ** 2).sum()
    mass, inertia = weight[:, 0], weight[:, 2]
    disk = b[:, INV_MASS_X] > 0.0  # the walls' x is imposed

    level = np.floor((b[:, Y] - b[disk, Y].min()) / band).astype(int)
    in_bands = {"band x": 0.0, "band y": 0.0, "band spin": 0.0}
    for k in np.unique(level[disk]):
        s = disk & (level == k)
        for key, per_body, column in (("band x", mass, 0), ("band y", mass, 1),
                                      ("band spin", inertia, 2)):
            total = per_body[s].sum()
            mean = (per_body[s] * dv[s, column]).sum() / total
            in_bands[key] += total * mean * mean

    relative = dv[a_of, :2] - dv[b_of, :2]
    u_n_all = (relative * normal).sum(1)
    u_t_all = ((relative * tangent).sum(1) + c[:, LEVER_A] * dv[a_of, 2] +
               c[:, LEVER_B] * dv[b_of, 2])
    carrying = c[:, REFERENCE_N] > 0.0
    between_disks = carrying & disk[a_of] & disk[b_of]
    spin_a, spin_b = dv[a_of[between_disks], 2], dv[b_of[between_disks], 2]
    u_n, u_t = u_n_all[carrying], u_t_all[carrying]
    either = carrying | (c[:, TESTED_N] > 0.0)
    differs = either & (contact_status(c[:, TESTED_N], c[:, TESTED_T], c[:, FRICTION]) !=
                        contact_status(c[:, REFERENCE_N], c[:, REFERENCE_T], c[:, FRICTION]))
    reference = np.hypot(c[:, REFERENCE_N], c[:, REFERENCE_T])
    figures = {"impulse": np.sqrt((e_n ** 2 + e_t ** 2).sum() / (reference ** 2).sum())}
    figures.update({k: v / energy for k, v in in_bands.items()})
    figures["spin"] = (inertia * dv[:, 2] ** 2).sum() / energy
    figures["spin corr"] = (spin_a * spin_b).sum() / (0.5 * (spin_a ** 2 + spin_b ** 2).sum())
    figures["u_n / V"] = np.sqrt((u_n ** 2).mean()) / velocity
    figures["u_t / V"] = np.sqrt((u_t ** 2).mean()) / velocity
    figures["status"] = differs.sum()
    figures["on status"] = (u_t_all[differs] ** 2).sum() / (u_t_all[either] ** 2).sum()
    return figures


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", help="one case's folder of --dump-samples")
    parser.add_argument("--velocity", type=float, required=True, help="the wall speed V")
    parser.add_argument("--band", type=float, default=4.0, help="band height [d]")
    args = parser.parse_args()
    stems = sample_stems(args.folder)
    rows = [modes(s, args.band, args.velocity) for s in stems]
    keys = list(rows[0])
    print("sample  " + "  ".join(f"{k:>9}" for k in keys))
    for stem, row in zip(stems, rows):
        print(f"{stem.split('_')[-1]:>6}  " + "  ".join(f"{row[k]:9.3g}" for k in keys))
    print("median  " + "  ".join(f"{np.median([r[k] for r in rows]):9.3g}" for k in keys))


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""How much of a step's impulse error is the step's own indeterminacy (docs/step-error.md, "How
much of the error the step leaves undetermined").

Rigid frictional contacts need not fix a step's impulses: where the force-carrying network has
loops, a self-stress s (impulses that push no grain: H^T s = 0 on every axis a body is free to move
along) can be added to a solution without changing any velocity, and as long as it keeps every
open contact at zero, every sticking one inside its cone and every sliding one on its cone's edge
(along the edge), the sum is a solution too. The solutions near the reference R_ref therefore
form a set, tangent to T = B null(A B), where

- A = M^-1/2 H^T maps a contact impulse to the (mass-weighted) velocities it gives the bodies (a
  wall's imposed or fixed axes, inverse mass 0, drop out: they take any force);
- B's columns are the directions the reference's statuses leave free: both rows of a sticking
  contact, the cone's edge (1, sign(R_t) mu) / sqrt(1 + mu^2) of a sliding one, none of an open one.

The tested solve's error e = R_tested - R_ref is split into its part along T (a move within the
solution set, to first order) and the rest, e_det = e - B s*, s* the projection of B^T e on
null(A B): the distance from the tested impulses to the set of the step's solutions, to first
order. The projection is computed exactly through the bodies' space: x* = (A B)^T y, (A B)(A B)^T y
= A B z with z = B^T e (one sparse LU of a 3 x bodies matrix, with a regularisation eps times its
largest diagonal entry: directions of A B with a squared singular value below that count as
null), s* = z - x*.

Per sample: |e| / |R_ref| (the per-step error of docs/step-error.md), |e_det| / |R_ref|, the share
of |e| along the set, the largest cone or sign violation of R* = R_ref + B s* (the point of the set
nearest the tested impulses, to first order; a large one means the set's edge is nearer than its
tangent says, and e_det underestimates the distance) relative to the mean |R_ref| per contact, and
|A B s*| / |A e| (zero to round-off: the part along the set moves no grain), and the degenerate
statuses, which could change at no cost and so widen the set beyond its tangent: sliding contacts
slipping, and open ones separating, slower than 1e-9 of the step's largest relative velocity (the
reference's velocities from the dump). With --all-rows, B
holds both rows of every force-carrying contact (W's null space over them, as
bench/coarse_space.py's "null space" line counts it).

  cdshear_bench --packing P --velocity V --no-static --steps 40 --warmup 1000 --step-error 4 \\
      --step-error-spacing 10 --reference-relaxation 1.6 --reference-anderson 5 \\
      --reference-newton 16 --dump-samples DIR
  /usr/bin/python3 bench/solution_set.py DIR/shear_nN [--eps 1e-13,1e-9] [--all-rows]
"""

import argparse

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from coarse_space import (FRICTION, GAP, INV_MASS, REFERENCE_N, REFERENCE_T, TESTED_N, TESTED_T,
                          VELOCITY, contact_jacobian, contact_status, sample_header, sample_stems)

# A status is degenerate where its velocity would let it change at no cost: a sliding contact
# slipping, or an open one separating, slower than this share of the step's largest relative
# velocity.
DEGENERATE = 1e-9


def free_directions(reference, friction, all_rows):
    """B (2 m x columns, orthonormal columns) from the reference impulses' statuses."""
    normal, tangential = reference[:, 0], reference[:, 1]
    status = contact_status(normal, tangential, friction)
    rows, cols, vals = [], [], []
    column = 0
    for k, s in enumerate(status):
        if s == 0:
            continue
        if s == 1 or all_rows:
            rows += [2 * k, 2 * k + 1]
            cols += [column, column + 1]
            vals += [1.0, 1.0]
            column += 2
        else:
            edge = np.array([1.0, np.sign(tangential[k]) * friction[k]])
            edge /= np.linalg.norm(edge)
            rows += [2 * k, 2 * k + 1]
            cols += [column, column]
            vals += list(edge)
            column += 1
    b = sp.csr_matrix((vals, (rows, cols)), shape=(2 * len(status), column))
    return b, status


def split_error(contacts, bodies, dt, eps, all_rows):
    """The shares described above, and the degenerate statuses' counts, as a dict."""
    reference = contacts[:, [REFERENCE_N, REFERENCE_T]]
    friction = contacts[:, FRICTION]
    error = (contacts[:, [TESTED_N, TESTED_T]] - reference).ravel()
    h = contact_jacobian(contacts, bodies)
    a = sp.diags(np.sqrt(bodies[:, INV_MASS].ravel())) @ h.T
    b, status = free_directions(reference, friction, all_rows)
    u = h @ bodies[:, VELOCITY].ravel()  # the reference's relative velocities
    u[0::2] += contacts[:, GAP] / dt
    slow = np.abs(u) < DEGENERATE * np.abs(u).max(initial=0.0)
    ab = (a @ b).tocsr()
    z = b.T @ error
    k = (ab @ ab.T).tocsc()
    shift = eps * max(k.diagonal().max(), 1e-300)
    y = sla.splu(k + shift * sp.identity(k.shape[0], format="csc")).solve(ab @ z)
    along = z - ab.T @ y  # s*: B^T e's part in null(A B)
    determinate = error - b @ along
    r_norm = np.linalg.norm(reference)
    nearest = reference.ravel() + b @ along
    n, t = nearest[0::2], nearest[1::2]
    closed = status > 0
    violation = np.concatenate([np.maximum(0.0, -n[closed]),
                                np.maximum(0.0, np.abs(t) - friction * np.maximum(n, 0.0))[closed]])
    mean_impulse = r_norm / np.sqrt(max(1, int(closed.sum())))
    velocity_error = np.linalg.norm(a @ error)
    return {
        "error": np.linalg.norm(error) / r_norm,
        "determinate": np.linalg.norm(determinate) / r_norm,
        "along": np.linalg.norm(b @ along) / max(np.linalg.norm(error), 1e-300),
        "violation": violation.max(initial=0.0) / mean_impulse,
        "slow_sliding": int(np.sum((status == 2) & slow[1::2])),
        "slow_open": int(np.sum((status == 0) & slow[0::2])),
        "moves": np.linalg.norm(ab @ along) / max(velocity_error, 1e-300),
        "closed": int(closed.sum()),
        "sliding": int((status == 2).sum()),
        "columns": b.shape[1],
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--eps", default="1e-13", help="regularisations, comma-separated")
    parser.add_argument("--all-rows", action="store_true")
    args = parser.parse_args()
    for stem in sample_stems(args.folder):
        contacts = np.loadtxt(stem + "_contacts.txt", comments="#", ndmin=2)
        bodies = np.loadtxt(stem + "_bodies.txt", comments="#", ndmin=2)
        for eps in (float(v) for v in args.eps.split(",") if v):
            s = split_error(contacts, bodies, sample_header(stem)[3], eps, args.all_rows)
            print(f"{stem.split('/')[-1]} eps {eps:g}: {s['closed']} force-carrying "
                  f"({s['sliding']} sliding, {s['columns']} free directions); |e| / |R| "
                  f"{s['error']:.2e}, undetermined share of |e| {s['along']:.3f}, determinate "
                  f"|e_det| / |R| {s['determinate']:.2e}; degenerate statuses "
                  f"{s['slow_sliding']} sliding, {s['slow_open']} open; nearest point's cone "
                  f"violation {s['violation']:.1e} of the mean impulse; moves {s['moves']:.1e} "
                  f"of A e",
                  flush=True)


if __name__ == "__main__":
    main()

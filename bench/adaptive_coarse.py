#!/usr/bin/python3
"""A step's known-statuses system preconditioned by two levels whose coarse space is built from the
network itself (docs/performance.md, "What did not help", "An adaptive two-level correction").

The system is known_statuses.py's: with every contact's status fixed at the reference's, a step is
a linear system M x = b in the closed contacts' impulses. Its slow modes under Gauss-Seidel are
specific to each step's network ("What a coarse correction could reach", docs/step-error.md): no
smooth field holds them. An adaptive aggregation method finds them algebraically instead. K random
vectors are relaxed on M x = 0 by S symmetric Gauss-Seidel iterations; what is left of them is
what the sweeps cannot reduce (the algebraically smooth error). The unknowns are grouped into
aggregates, square cells of C d by their contact's disk (the first, unless it is a wall); each
aggregate's restrictions of the relaxed vectors, orthonormalised (singular vectors above 1e-3 of
the largest), are its coarse basis. The coarse operator is the Galerkin product P^T M P
(factorised exactly); one iteration of the two-level preconditioner is a forward sweep, the coarse
correction on its residual and a backward sweep: a symmetric Gauss-Seidel iteration with a coarse
solve between its halves. Each line gives an iteration's cost in symmetric Gauss-Seidel
iterations (multiply-adds).

Right-preconditioned GMRES from the tested impulses, iterations until the impulses are within
1e-2, 1e-3 and 1e-4 of the reference, for symmetric Gauss-Seidel alone and for the two levels
built (a) from this step's own relaxed vectors, (b) with --stale, from the previous sample's relaxed
vectors (matched by contact and kind, zero on unknowns the previous sample lacks) relaxed again by
one iteration: what a coarse space carried over from step to step would give.

  cdshear_bench ... --dump-samples DIR   (the commands of known_statuses.py)
  /usr/bin/python3 bench/adaptive_coarse.py DIR/shear_nN [--vectors 16] [--relax 30] [--cell 8]
      [--stale]
"""

import argparse

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from coarse_space import BODY_A, BODY_B, StepProblem, sample_stems
from known_statuses import (GaussSeidel, gmres_errors, reached_line, shared_unknowns,
                            status_system, unknown_keys)

INV_INERTIA = 4  # sample_K_bodies.txt's column of 1/I (0 for a wall)


def aggregates(problem, stem, lead, cell):
    """Each unknown's aggregate: the square cell of side CELL (in the positions' units) holding its
    contact's disk (the first body, or the second where the first is a wall: no rotation),
    numbered densely."""
    bodies = np.loadtxt(stem + "_bodies.txt", comments="#", ndmin=2)
    contact = problem.contacts[lead // 2]
    first = contact[:, BODY_A].astype(int)
    disk = np.where(bodies[first, INV_INERTIA] > 0, first, contact[:, BODY_B].astype(int))
    ij = np.floor(bodies[disk, :2] / cell).astype(int)
    _, index = np.unique(ij[:, 0] * 100003 + ij[:, 1], return_inverse=True)
    return index


def coarse_basis(vectors, aggregate):
    """P: per aggregate, the orthonormal left singular vectors of its rows of VECTORS above 1e-3
    of the largest."""
    rows, cols, vals = [], [], []
    column = 0
    for a in range(aggregate.max() + 1):
        members = np.flatnonzero(aggregate == a)
        u, s, _ = np.linalg.svd(vectors[members], full_matrices=False)
        keep = s > 1e-3 * s[0] if s[0] > 0 else np.zeros(len(s), bool)
        for v in u[:, keep].T:
            rows += list(members)
            cols += [column] * len(members)
            vals += list(v)
            column += 1
    return sp.csr_matrix((vals, (rows, cols)), shape=(vectors.shape[0], column))


def two_level(sweeps, p):
    """The preconditioner: forward sweep, exact coarse correction, backward sweep; with its
    cost per application in symmetric Gauss-Seidel iterations (multiply-adds: the two sweeps,
    the residual, P and P^T, the coarse factors' two triangular solves)."""
    coarse = sla.splu((p.T @ sweeps.m @ p).tocsc())
    pt = p.T.tocsr()
    nnz = sweeps.m.nnz
    cost = (3 * nnz + 2 * p.nnz + 2 * (coarse.L.nnz + coarse.U.nnz)) / (2 * nnz)

    def apply(v):
        z = sweeps.forward(np.zeros_like(v), v)
        z = z + p @ coarse.solve(pt @ (v - sweeps.m @ z))
        return sweeps.backward(z, v)

    return apply, cost


def relaxed(sweeps, start, iterations):
    """START (columns) after ITERATIONS symmetric Gauss-Seidel iterations on M x = 0."""
    zero = np.zeros(start.shape[0])
    out = start.copy()
    for j in range(start.shape[1]):
        for _ in range(iterations):
            out[:, j] = sweeps.symmetric(out[:, j], zero)
        out[:, j] /= np.linalg.norm(out[:, j])
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--vectors", type=int, default=16, help="relaxed vectors K")
    parser.add_argument("--relax", type=int, default=30,
                        help="symmetric Gauss-Seidel iterations S on each")
    parser.add_argument("--cell", type=float, default=8.0, help="aggregates' side C, in d")
    parser.add_argument("--stale", action="store_true",
                        help="also build from the previous sample's vectors")
    parser.add_argument("--iterations", type=int, default=200)
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    kept = None  # (vectors, keys) of the previous sample
    for stem in sample_stems(args.folder):
        problem = StepProblem(stem)
        m, b, p_status, x0, sliding, lead = status_system(problem)
        sweeps = GaussSeidel(m)

        def error(x):
            return problem.error(p_status @ x)

        aggregate = aggregates(problem, stem, lead, args.cell)
        vectors = relaxed(sweeps, rng.standard_normal((m.shape[0], args.vectors)), args.relax)
        p = coarse_basis(vectors, aggregate)
        lines = [f"{stem.split('/')[-1]}: {m.shape[0]} unknowns ({sliding} sliding), "
                 f"{aggregate.max() + 1} aggregates, coarse {p.shape[1]}; tested "
                 f"{error(x0):.2e}"]
        runs = {"sgs": (sweeps.preconditioner, 1.0),
                "two-level, own vectors": two_level(sweeps, p)}
        keys = unknown_keys(problem, lead)
        if args.stale and kept is not None:
            here, there = shared_unknowns(kept[1], keys)
            carried = np.zeros_like(vectors)
            carried[here] = kept[0][there]
            runs["two-level, previous vectors"] = two_level(
                sweeps, coarse_basis(relaxed(sweeps, carried, 1), aggregate))
        kept = (vectors, keys)
        for name, (apply, cost) in runs.items():
            lines.append(reached_line(f"{name} ({cost:.1f} symmetric Gauss-Seidel iterations each)",
                                      gmres_errors(m, b, x0, apply, error, args.iterations)))
        print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""A step's known-statuses system preconditioned by two or more levels whose coarse spaces are
built from the network itself (docs/performance.md, "What did not help", "An adaptive two-level
correction" and "An adaptive multilevel cycle").

The system is known_statuses.py's: with every contact's status fixed at the reference's, a step is
a linear system M x = b in the closed contacts' impulses. Its slow modes under Gauss-Seidel are
specific to each step's network ("What a coarse correction could reach", docs/step-error.md): no
smooth field holds them. An adaptive aggregation method finds them algebraically instead. K random
vectors are relaxed on M x = 0 by S symmetric Gauss-Seidel iterations; what is left of them is
what the sweeps cannot reduce (the algebraically smooth error). The unknowns are grouped into
aggregates, square cells of C d by their contact's disk (the first, unless it is a wall); each
aggregate's restrictions of the relaxed vectors, orthonormalised (singular vectors above 1e-3 of
the largest), are its coarse basis. The coarse operator is the Galerkin product P^T M P; one
iteration of the preconditioner is a forward sweep, the coarse correction on its residual and a
backward sweep: a symmetric Gauss-Seidel iteration with a coarse solve between its halves.

With two levels (the default) the coarse operator is factorised exactly. With --levels L the
coarse level is treated the same way, recursively (a V-cycle): its unknowns take their
aggregate's cell halved, so that 2 x 2 cells make the next level's aggregates; its vectors are
the coarse representations P^T V of the finer ones, relaxed by --coarse-relax symmetric
Gauss-Seidel iterations on its operator; the hierarchy stops after L levels or at a level of at
most --coarsest unknowns, factorised. Each line gives an iteration's cost in symmetric
Gauss-Seidel iterations of the finest level (multiply-adds of every level's sweeps, residual,
P and P^T, and of the coarsest factors' triangular solves).

Right-preconditioned GMRES from the tested impulses, iterations until the impulses are within
1e-2, 1e-3 and 1e-4 of the reference, for symmetric Gauss-Seidel alone and for the hierarchy
built (a) from this step's own relaxed vectors, (b) with --stale, from the previous sample's own
relaxed vectors (matched by contact and kind, zero on unknowns the previous sample lacks) relaxed
again by one iteration, (c) with --carry R and no --bootstrap, from vectors carried over the
samples: the first sample's own, then each sample's those of the sample before relaxed R more
times, what a space kept from step to step would be (with the cosines of the principal angles
between the carried vectors' span and the own vectors'), (d) with --bootstrap B, from vectors kept
over the samples the way a bootstrap setup keeps them: the first sample's own, then at each
sample those of the sample before (relaxed --carry R times, none by default) build the current
cycle, B iterations of that cycle on M x = 0 from a random vector leave the mode it reduces
least, and that vector takes the place of the oldest, unless nothing is left of it (with the
upkeep in symmetric Gauss-Seidel iterations, and the cycle's contraction per iteration on that
vector in the energy norm). The header gives the own vectors' participation ratios
(1 / sum v_i^4 for a unit vector, as a share of the unknowns: how local they are).

  cdshear_bench ... --dump-samples DIR   (the commands of known_statuses.py)
  /usr/bin/python3 bench/adaptive_coarse.py DIR/shear_nN [--vectors 16] [--relax 30] [--cell 8]
      [--levels 2] [--coarse-relax 10] [--coarsest 100] [--stale] [--carry R] [--bootstrap B]
"""

import argparse

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from coarse_space import BODY_A, BODY_B, StepProblem, sample_stems
from known_statuses import (GaussSeidel, gmres_errors, reached_line, shared_unknowns,
                            status_system, unknown_keys)

INV_INERTIA = 4  # sample_K_bodies.txt's column of 1/I (0 for a wall)


def disk_cells(problem, stem, lead, cell):
    """Each unknown's cell (i, j): the square of side CELL (in the positions' units) holding its
    contact's disk (the first body, or the second where the first is a wall: no rotation)."""
    bodies = np.loadtxt(stem + "_bodies.txt", comments="#", ndmin=2)
    contact = problem.contacts[lead // 2]
    first = contact[:, BODY_A].astype(int)
    disk = np.where(bodies[first, INV_INERTIA] > 0, first, contact[:, BODY_B].astype(int))
    return np.floor(bodies[disk, :2] / cell).astype(int)


def dense_numbers(cells):
    """The cells (rows (i, j)) numbered densely: each row's aggregate."""
    return np.unique(cells, axis=0, return_inverse=True)[1].reshape(-1)


def coarse_basis(vectors, aggregate):
    """P: per aggregate, the orthonormal left singular vectors of its rows of VECTORS above 1e-3
    of the largest; with each column's aggregate."""
    rows, cols, vals, owner = [], [], [], []
    for a in range(aggregate.max() + 1):
        members = np.flatnonzero(aggregate == a)
        u, s, _ = np.linalg.svd(vectors[members], full_matrices=False)
        keep = s > 1e-3 * s[0] if s[0] > 0 else np.zeros(len(s), bool)
        for v in u[:, keep].T:
            rows += list(members)
            cols += [len(owner)] * len(members)
            vals += list(v)
            owner.append(a)
    p = sp.csr_matrix((vals, (rows, cols)), shape=(vectors.shape[0], len(owner)))
    return p, np.array(owner, dtype=int)


class Level:
    """One level above the coarsest: its operator's sweeps and the basis P to the next."""

    def __init__(self, m, p):
        self.sweeps = GaussSeidel(m)
        self.p = p
        self.pt = p.T.tocsr()


def hierarchy(m, cells, vectors, levels, coarse_relax, coarsest):
    """The levels of the cycle and the coarsest operator. Level l's aggregates are its unknowns'
    cells; its coarse unknowns take their aggregate's cell halved (2 x 2 cells make the next
    level's aggregate), its coarse operator is P^T M P, and the coarse vectors are P^T V, relaxed
    by COARSE_RELAX symmetric Gauss-Seidel iterations on the coarse operator. Stops after LEVELS
    levels, or once a coarse operator has at most COARSEST unknowns (factorised from there)."""
    out = []
    while True:
        aggregate = dense_numbers(cells)
        p, owner = coarse_basis(vectors, aggregate)
        out.append(Level(m, p))
        aggregate_cell = np.zeros((aggregate.max() + 1, 2), dtype=int)
        aggregate_cell[aggregate] = cells
        cells = aggregate_cell[owner] // 2
        m = (p.T @ m @ p).tocsr()
        if m.shape[0] <= coarsest or len(out) == levels - 1:
            break
        vectors = relaxed(GaussSeidel(m), p.T @ vectors, coarse_relax)
    return out, m


def cycle(levels, coarsest):
    """The preconditioner: at each level a forward sweep, the next level's correction on its
    residual and a backward sweep (a V-cycle); the coarsest operator factorised exactly. With its
    cost per application in symmetric Gauss-Seidel iterations of the finest level
    (multiply-adds: each level's two sweeps, residual, P and P^T; the coarse factors' two
    triangular solves), and each level's number of unknowns."""
    factor = sla.splu(coarsest.tocsc())

    def apply_from(level, v):
        if level == len(levels):
            return factor.solve(v)
        here = levels[level]
        z = here.sweeps.forward(np.zeros_like(v), v)
        z = z + here.p @ apply_from(level + 1, here.pt @ (v - here.sweeps.m @ z))
        return here.sweeps.backward(z, v)

    work = sum(3 * level.sweeps.m.nnz + 2 * level.p.nnz for level in levels)
    work += 2 * (factor.L.nnz + factor.U.nnz)
    sizes = [level.sweeps.m.shape[0] for level in levels] + [coarsest.shape[0]]
    return (lambda v: apply_from(0, v)), work / (2 * levels[0].sweeps.m.nnz), sizes


def relaxed(sweeps, start, iterations):
    """START (columns) after ITERATIONS symmetric Gauss-Seidel iterations on M x = 0."""
    zero = np.zeros(start.shape[0])
    out = start.copy()
    for j in range(start.shape[1]):
        for _ in range(iterations):
            out[:, j] = sweeps.symmetric(out[:, j], zero)
        out[:, j] /= np.linalg.norm(out[:, j])
    return out


def principal_cosines(a, b):
    """The cosines of the principal angles between the column spaces of A and B."""
    return np.linalg.svd(np.linalg.qr(a)[0].T @ np.linalg.qr(b)[0], compute_uv=False)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--vectors", type=int, default=16, help="relaxed vectors K")
    parser.add_argument("--relax", type=int, default=30,
                        help="symmetric Gauss-Seidel iterations S on each")
    parser.add_argument("--cell", type=float, default=8.0, help="aggregates' side C, in d")
    parser.add_argument("--levels", type=int, default=2,
                        help="levels of the hierarchy, the finest and the coarsest included")
    parser.add_argument("--coarse-relax", type=int, default=10,
                        help="symmetric Gauss-Seidel iterations on the coarse vectors")
    parser.add_argument("--coarsest", type=int, default=100,
                        help="unknowns at which the hierarchy stops and factorises")
    parser.add_argument("--stale", action="store_true",
                        help="also build from the previous sample's vectors")
    parser.add_argument("--carry", type=int, metavar="R",
                        help="also build from vectors carried over the samples, relaxed R "
                             "times on each")
    parser.add_argument("--bootstrap", type=int, metavar="B",
                        help="also build from vectors kept over the samples, each sample "
                             "replacing the oldest by B iterations of the current cycle on a "
                             "random vector")
    parser.add_argument("--iterations", type=int, default=200)
    args = parser.parse_args()
    if args.levels < 2:
        parser.error(f"--levels {args.levels}: a hierarchy has at least 2 levels")
    if args.bootstrap is not None and args.bootstrap < 1:
        parser.error(f"--bootstrap {args.bootstrap}: at least 1 iteration of the kept cycle")
    rng = np.random.default_rng(1)
    kept = None  # (vectors, keys) of the previous sample
    # (vectors, keys) kept over the samples to the previous one (oldest vector first), with
    # --carry or --bootstrap
    span = None
    fresh_rng = np.random.default_rng(2)  # --bootstrap's random vectors
    for stem in sample_stems(args.folder):
        problem = StepProblem(stem)
        m, b, p_status, x0, sliding, lead = status_system(problem)
        sweeps = GaussSeidel(m)

        def error(x):
            return problem.error(p_status @ x)

        cells = disk_cells(problem, stem, lead, args.cell)

        def cycle_from(vectors):
            return cycle(*hierarchy(m, cells, vectors, args.levels, args.coarse_relax,
                                    args.coarsest))

        vectors = relaxed(sweeps, rng.standard_normal((m.shape[0], args.vectors)), args.relax)
        own, cost, sizes = cycle_from(vectors)
        participation = 1 / (vectors**4).sum(axis=0) / m.shape[0]
        lines = [f"{stem.split('/')[-1]}: {m.shape[0]} unknowns ({sliding} sliding), "
                 f"{dense_numbers(cells).max() + 1} aggregates, coarse {sizes[1]}; levels' "
                 f"unknowns {', '.join(str(n) for n in sizes)}; tested {error(x0):.2e}; own "
                 f"vectors' participation ratios {participation.min():.0%} to "
                 f"{participation.max():.0%} of the unknowns"]
        kind = f"{len(sizes)}-level"
        runs = {"sgs": (sweeps.preconditioner, 1.0), f"{kind}, own vectors": (own, cost)}
        keys = unknown_keys(problem, lead)

        def from_previous(previous, relaxations):
            here, there = shared_unknowns(previous[1], keys)
            start = np.zeros_like(vectors)
            start[here] = previous[0][there]
            return relaxed(sweeps, start, relaxations)

        if args.stale and kept is not None:
            runs[f"{kind}, previous vectors"] = cycle_from(from_previous(kept, 1))[:2]
        if span is not None and args.bootstrap is not None:
            start = from_previous(span, args.carry or 0)
            current, current_cost, _ = cycle_from(start)
            fresh = fresh_rng.standard_normal(m.shape[0])
            energy = np.sqrt(fresh @ (m @ fresh))
            for _ in range(args.bootstrap):
                fresh = fresh - current(m @ fresh)
            left = np.sqrt(max(fresh @ (m @ fresh), 0.0))
            contraction = (left / energy) ** (1 / args.bootstrap)
            if left > 1e-12 * energy:
                start = np.column_stack([start[:, 1:], fresh / np.linalg.norm(fresh)])
            span = (start, keys)  # an exact cycle leaves nothing to add: the space kept
            upkeep = (args.carry or 0) * args.vectors + args.bootstrap * current_cost
            lines[0] += (f"; bootstrap upkeep {upkeep:.0f} symmetric Gauss-Seidel iterations, "
                         f"the kept cycle's contraction {contraction:.3f} per iteration")
            runs[f"{kind}, bootstrapped vectors"] = cycle_from(span[0])[:2]
        elif span is not None:
            span = (from_previous(span, args.carry), keys)
            cosines = principal_cosines(vectors, span[0])
            lines[0] += (f"; carried vectors' principal cosines with the own "
                         f"{', '.join(f'{c:.2f}' for c in cosines)}")
            runs[f"{kind}, carried vectors"] = cycle_from(span[0])[:2]
        elif args.carry is not None or args.bootstrap is not None:
            span = (vectors, keys)  # the first sample's own
        kept = (vectors, keys)
        for name, (apply, cost) in runs.items():
            lines.append(reached_line(f"{name} ({cost:.1f} symmetric Gauss-Seidel iterations each)",
                                      gmres_errors(m, b, x0, apply, error, args.iterations)))
        print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()

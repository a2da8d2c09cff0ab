#!/usr/bin/python3
"""A step's known-statuses system preconditioned by overlapping blocks solved exactly: a Schwarz
method (docs/performance.md, "What did not help", "Overlapping blocks solved exactly").

The system is known_statuses.py's: with every contact's status fixed at the reference's, a step is
a linear system M x = b in the closed contacts' impulses. Symmetric Gauss-Seidel relaxes one
unknown at a time, and its slow modes are local patterns of the network (a participation ratio of 1
to 10% of the unknowns, "An adaptive multilevel cycle"). Blocks solved exactly relax every pattern
that fits inside one block at once. The unknowns are grouped by their contact's disk (the first,
unless it is a wall) into square cells of side C d; each block is a cell's unknowns grown by
--overlap rings of neighbours in M's graph, and its principal submatrix of M is factorised
(SuperLU, minimum degree on the pattern of A + A^T, diagonal pivots). One iteration of the
preconditioner is a multiplicative sweep over the blocks, each solving for its residual, then the
same sweep in reverse (a symmetric block Gauss-Seidel iteration, the blocks overlapping). With
--coarse (no longer symmetric), a correction by an exact solve on a coarse space of each cell's
normal and tangential impulses taken as constants (Galerkin, P^T M P) comes before the forward
sweep.

The cost of an iteration is counted in symmetric Gauss-Seidel iterations, 2 nnz(M) multiply-adds:
each block's residual rows and its factors' two triangular solves, twice, and the coarse
restriction, solve and prolongation (it starts from zero: no residual). The set-up (every block's
factorisation, counted as the multiply-adds sum_k l_k u_k of Gaussian elimination, l_k and u_k the
off-diagonal entries of column k of L and row k of U) is printed in the same units and as SuperLU's
time (best of three; the multiply-adds undercount it: a sparse factorisation runs far below the
sweeps' speed per multiply-add), with the share of the blocks holding an unknown that the previous
sample lacks (a contact that closed or stopped sliding; a lower bound of the blocks whose matrix
changed, since a contact that opened or started sliding only removes an unknown): on consecutive
steps (--step-error-spacing 0), the blocks whose factors a factorisation kept from the step before
could not serve.

Right-preconditioned GMRES from the tested impulses, iterations until the impulses are within
1e-2, 1e-3 and 1e-4 of the reference, for symmetric Gauss-Seidel alone and for the blocks.

  cdshear_bench ... --dump-samples DIR   (the commands of known_statuses.py)
  /usr/bin/python3 bench/schwarz_blocks.py DIR/shear_nN [--cell 8] [--overlap 1] [--coarse]
      [--iterations 300]
"""

import argparse
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from adaptive_coarse import dense_numbers, disk_cells
from coarse_space import StepProblem, sample_stems
from known_statuses import (GaussSeidel, gmres_errors, reached_line, shared_unknowns,
                            status_system, unknown_keys)


def grown(members, graph, rings):
    """MEMBERS (a sorted index array) with RINGS rings of their neighbours in GRAPH added."""
    mask = np.zeros(graph.shape[0], dtype=bool)
    mask[members] = True
    for _ in range(rings):
        wider = mask | ((graph @ mask.astype(np.int8)) > 0)
        if (wider == mask).all():
            break
        mask = wider
    return np.flatnonzero(mask)


def elimination_work(factor):
    """Multiply-adds of the LU factorisation that gave FACTOR: sum over k of the off-diagonal
    entries of column k of L times those of row k of U."""
    lower = sp.csc_matrix(factor.L)
    upper = sp.csr_matrix(factor.U)
    below = np.diff(lower.indptr) - 1  # L's unit diagonal is stored
    right = np.diff(upper.indptr) - 1
    return float((below * right).sum())


def symmetric_lu(block):
    """SuperLU's factors of BLOCK ordered on the pattern of A + A^T (nearly symmetric: only the
    sliding contacts' columns differ) and pivoting on the diagonal, which keeps the fill the
    ordering predicts (SuperLU pivots off the diagonal only where a diagonal pivot is zero)."""
    return sla.splu(block, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                    options=dict(SymmetricMode=True))


class Blocks:
    """The blocks' index sets, their factorised submatrices, and the symmetric sweep over them."""

    def __init__(self, m, aggregate, rings):
        self.m = m.tocsr()
        graph = (abs(self.m) + abs(self.m.T)).tocsr()
        graph.data[:] = 1
        self.members = [grown(np.flatnonzero(aggregate == a), graph, rings)
                        for a in range(aggregate.max() + 1)]
        self.rows = [self.m[k] for k in self.members]
        submatrices = [rows[:, k].tocsc() for rows, k in zip(self.rows, self.members)]
        self.seconds = np.inf  # the factorisations' time, best of three
        for _ in range(3):
            start = time.perf_counter()
            self.factors = [symmetric_lu(block) for block in submatrices]
            self.seconds = min(self.seconds, time.perf_counter() - start)
        self.setup = sum(elimination_work(f) for f in self.factors)
        # L's unit diagonal is stored but costs nothing
        self.work = 2 * sum(r.nnz + f.L.nnz - len(k) + f.U.nnz
                            for r, f, k in zip(self.rows, self.factors, self.members))
        self.sizes = np.array([len(k) for k in self.members])

    def sweep(self, z, v, order):
        for k in order:
            members = self.members[k]
            z[members] += self.factors[k].solve(v[members] - self.rows[k] @ z)
        return z

    def symmetric(self, z, v):
        forward = range(len(self.members))
        return self.sweep(self.sweep(z, v, forward), v, reversed(forward))


def constant_space(aggregate, kind):
    """P: per aggregate and kind (normal, tangential), the indicator of its unknowns, normalised."""
    column = aggregate * 2 + kind
    owner = dense_numbers(column.reshape(-1, 1))
    counts = np.bincount(owner)
    return sp.csr_matrix((1 / np.sqrt(counts[owner]), (np.arange(len(owner)), owner)))


def preconditioner(m, blocks, p):
    """The symmetric block sweep, after an exact coarse correction on P's span when P is given;
    with its cost per application in symmetric Gauss-Seidel iterations."""
    work = blocks.work
    if p is None:
        return (lambda v: blocks.symmetric(np.zeros_like(v), v)), work / (2 * m.nnz), 0
    coarse = (p.T @ m @ p).tocsc()
    factor = sla.splu(coarse)
    pt = p.T.tocsr()
    work += 2 * p.nnz + factor.L.nnz - p.shape[1] + factor.U.nnz

    def apply(v):
        z = p @ factor.solve(pt @ v)
        return blocks.symmetric(z, v)

    return apply, work / (2 * m.nnz), elimination_work(factor)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--cell", type=float, default=8.0, help="blocks' cells' side C, in d")
    parser.add_argument("--overlap", type=int, default=1,
                        help="rings of neighbours in M's graph added to each cell's unknowns")
    parser.add_argument("--coarse", action="store_true",
                        help="also correct on each cell's normal and tangential constants")
    parser.add_argument("--iterations", type=int, default=300)
    args = parser.parse_args()
    if args.cell <= 0:
        parser.error(f"--cell {args.cell}: a cell's side is positive")
    if args.overlap < 0:
        parser.error(f"--overlap {args.overlap}: rings are counted from 0")
    previous_keys = None
    for stem in sample_stems(args.folder):
        problem = StepProblem(stem)
        m, b, p_status, x0, sliding, lead = status_system(problem)
        keys = unknown_keys(problem, lead)

        def error(x):
            return problem.error(p_status @ x)

        aggregate = dense_numbers(disk_cells(problem, stem, lead, args.cell))
        blocks = Blocks(m, aggregate, args.overlap)
        kind = lead % 2
        p = constant_space(aggregate, kind) if args.coarse else None
        apply, cost, coarse_setup = preconditioner(m, blocks, p)
        setup = (blocks.setup + coarse_setup) / (2 * m.nnz)
        changed = ""
        if previous_keys is not None:
            new_unknown = np.ones(m.shape[0], dtype=bool)
            new_unknown[shared_unknowns(previous_keys, keys)[0]] = False
            touched = np.mean([new_unknown[k].any() for k in blocks.members])
            changed = f" ({touched:.0%} of the blocks hold an unknown the previous sample lacks)"
        previous_keys = keys
        lines = [f"{stem.split('/')[-1]}: {m.shape[0]} unknowns ({sliding} sliding), "
                 f"{len(blocks.members)} blocks of {blocks.sizes.min()} to {blocks.sizes.max()} "
                 f"unknowns (overlap {blocks.sizes.sum() / m.shape[0]:.2f})"
                 + (f", coarse {p.shape[1]}" if p is not None else "")
                 + f"; tested {error(x0):.2e}; one iteration costs {cost:.1f}, the "
                 f"set-up {setup:.1f} symmetric Gauss-Seidel iterations{changed}, "
                 f"its factorisations {blocks.seconds * 1e3:.1f} ms"]
        runs = {"sgs": GaussSeidel(m).preconditioner, "blocks": apply}
        for name, run in runs.items():
            lines.append(reached_line(name, gmres_errors(m, b, x0, run, error, args.iterations)))
        print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()

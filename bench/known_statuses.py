#!/usr/bin/python3
"""A step solved by a Krylov method once its contacts' statuses are known (docs/performance.md,
"What did not help", "A Krylov finish with the statuses known").

With every contact's status fixed at the reference's (open: no impulse; sticking: u_n + gap/dt = 0
and u_t = 0; sliding: u_n + gap/dt = 0 with R_t = sign(R_t) mu R_n), a step's contact problem is a
linear system in the closed contacts' normal impulses and the sticking ones' tangential impulses,
M x = -E^T q, M = E^T W P (E the rows the statuses constrain, P the impulses the unknowns give; not
symmetric where contacts slide). Its exact solution is the reference's step where the reference
converged (printed first, as the check of the system). From the tested impulses, right-
preconditioned GMRES (no restart) with three preconditioners, counting iterations until the
impulses are within 1e-2, 1e-3 and 1e-4 of the reference:

- jacobi: M's diagonal;
- sgs: symmetric Gauss-Seidel, (D + L) D^-1 (D + U), a forward and a backward sweep per iteration;
- ilu: an incomplete LU with drop tolerance 1e-4 (SuperLU's), a near-direct solve.

The best case for a hybrid that lets the sweeps find the statuses and a Krylov method finish: the
statuses here are the reference's own.

With --reuse, a fourth: the previous sample's incomplete LU (the first sample's own), as a
factorisation kept over steps would serve. Unknowns are matched by contact (its two bodies) and
kind (normal or tangential); those of contacts or statuses the factorised sample lacks take their
diagonal. Dump consecutive steps for it (--step-error-spacing 0).

  cdshear_bench --packing P --velocity V --no-static --steps S --warmup N --step-error K \\
      --reference-relaxation 1.6 --reference-anderson 5 --reference-newton 16 --dump-samples DIR
  /usr/bin/python3 bench/known_statuses.py DIR/shear_nN [--iterations 300] [--reuse]
"""

import argparse

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from coarse_space import BODY_A, BODY_B, StepProblem, sample_stems
from solution_set import free_directions

LEVELS = (1e-2, 1e-3, 1e-4)


def status_system(problem):
    """(M, right-hand side, P, the tested impulses' unknowns, sliding contacts, each unknown's
    leading row) for the reference's statuses. The unknowns are solution_set.py's free
    directions, each scaled so that its leading row (a contact's normal row, or a sticking
    contact's tangential one) holds 1: R_n for every closed contact, R_t for every sticking one;
    those leading rows are the equations, and the tested impulses there the start."""
    b, status = free_directions(problem.reference.reshape(-1, 2), problem.mu, False)
    b = b.tocsc()
    b.sort_indices()
    lead = b.indices[b.indptr[:-1]]  # each column's first row
    p = b @ sp.diags(1.0 / b.data[b.indptr[:-1]])
    e = sp.csr_matrix((np.ones(len(lead)), (lead, np.arange(len(lead)))),
                      shape=(b.shape[0], len(lead)))
    m = (e.T @ problem.w @ p).tocsr()
    return m, -(e.T @ problem.q), p, problem.tested[lead], int((status == 2).sum()), lead


def unknown_keys(problem, lead):
    """Each unknown's contact (its two bodies) and kind (0 normal, 1 tangential)."""
    c = problem.contacts
    return [(int(c[row // 2, BODY_A]), int(c[row // 2, BODY_B]), int(row % 2)) for row in lead]


def shared_unknowns(other_keys, keys):
    """(here, there): the unknowns of KEYS that OTHER_KEYS hold too, and their places there."""
    index = {k: n for n, k in enumerate(other_keys)}
    here = np.array([n for n, k in enumerate(keys) if k in index], dtype=int)
    return here, np.array([index[keys[n]] for n in here], dtype=int)


def reused_preconditioner(factor, factor_keys, m, keys):
    """An incomplete LU of another step's system applied to this one's unknowns that it shares
    (matched by key), the diagonal on the rest; with the number shared."""
    here, there = shared_unknowns(factor_keys, keys)
    diagonal = m.diagonal()

    def apply(v):
        z = v / diagonal
        full = np.zeros(len(factor_keys))
        full[there] = v[here]
        z[here] = factor.solve(full)[there]
        return z

    return apply, len(here)


def gmres_errors(m, b, x0, apply_preconditioner, error, iterations):
    """Right-preconditioned GMRES without restart from x0: error(x) of each iterate (stops at
    1e-6 or at breakdown)."""
    r0 = b - m @ x0
    beta = np.linalg.norm(r0)
    basis, preconditioned = [r0 / beta], []
    h = np.zeros((iterations + 1, iterations))
    errors = []
    for j in range(iterations):
        z = apply_preconditioner(basis[j])
        preconditioned.append(z)
        w = m @ z
        for _ in range(2):  # Gram-Schmidt twice
            for i in range(j + 1):
                c = w @ basis[i]
                h[i, j] += c
                w = w - c * basis[i]
        h[j + 1, j] = np.linalg.norm(w)
        rhs = np.zeros(j + 2)
        rhs[0] = beta
        y = np.linalg.lstsq(h[:j + 2, :j + 1], rhs, rcond=None)[0]
        errors.append(error(x0 + np.array(preconditioned).T @ y))
        if errors[-1] < 1e-6 or h[j + 1, j] < 1e-14 * beta:
            break
        basis.append(w / h[j + 1, j])
    return errors


def reached_line(name, errors):
    """A run's line: the first iterations whose error is within each of LEVELS, the last error."""
    reached = [next((i + 1 for i, e in enumerate(errors) if e <= level), "-") for level in LEVELS]
    return (f"  {name}: iterations to 1e-2, 1e-3, 1e-4: {', '.join(str(r) for r in reached)}; "
            f"{errors[-1]:.1e} after {len(errors)}")


class GaussSeidel:
    """Gauss-Seidel on M x = b: forward and backward sweeps from x, and the symmetric
    preconditioner, (D + U)^-1 D (D + L)^-1 v (a forward and a backward sweep from zero)."""

    def __init__(self, m):
        self.m = m.tocsr()
        self.diagonal = m.diagonal()
        self.strict_lower = sp.tril(m, -1).tocsr()
        self.strict_upper = sp.triu(m, 1).tocsr()
        self.lower = (sp.diags(self.diagonal) + self.strict_lower).tocsr()
        self.upper = (sp.diags(self.diagonal) + self.strict_upper).tocsr()

    def forward(self, x, b):
        return sla.spsolve_triangular(self.lower, b - self.strict_upper @ x, lower=True)

    def backward(self, x, b):
        return sla.spsolve_triangular(self.upper, b - self.strict_lower @ x, lower=False)

    def symmetric(self, x, b):
        return self.backward(self.forward(x, b), b)

    def preconditioner(self, v):
        y = sla.spsolve_triangular(self.lower, v, lower=True)
        return sla.spsolve_triangular(self.upper, self.diagonal * y, lower=False)


def preconditioners(m, ilu):
    diagonal = m.diagonal()
    return {"jacobi": lambda v: v / diagonal, "sgs": GaussSeidel(m).preconditioner,
            "ilu": ilu.solve}


def incomplete_lu(m):
    return sla.spilu(m.tocsc(), drop_tol=1e-4, fill_factor=10)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder")
    parser.add_argument("--iterations", type=int, default=300)
    parser.add_argument("--reuse", action="store_true",
                        help="also precondition by the previous sample's incomplete LU")
    args = parser.parse_args()
    kept = None  # (factor, keys) of the previous sample, with --reuse
    for stem in sample_stems(args.folder):
        problem = StepProblem(stem)
        m, b, p, x0, sliding, lead = status_system(problem)

        def error(x):
            return problem.error(p @ x)

        exact = error(sla.spsolve(m.tocsc(), b))
        lines = [f"{stem.split('/')[-1]}: {m.shape[0]} unknowns ({sliding} sliding); the "
                 f"statuses' exact solution {exact:.1e} from the reference, tested {error(x0):.2e}"]
        ilu = incomplete_lu(m)
        applies = preconditioners(m, ilu)
        if args.reuse:
            keys = unknown_keys(problem, lead)
            applies["ilu-kept"], shared = reused_preconditioner(*(kept or (ilu, keys)), m, keys)
            lines[0] += f"; {shared} shared with the kept factorisation's"
            kept = (ilu, keys)
        for name, apply in applies.items():
            lines.append(reached_line(name, gmres_errors(m, b, x0, apply, error,
                                                         args.iterations)))
        print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()

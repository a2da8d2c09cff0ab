#!/usr/bin/python3
"""ADMM on one Contact Dynamics step's Delassus operator, from a dumped sample (docs/performance.md,
"What did not help": ADMM on the Delassus operator).

Reads a sample of `cdshear_bench --step-error N --dump-samples DIR` (every candidate contact, the
tested and reference impulses, the bodies with the reference's velocities after the step), forms
H (contact velocities from body velocities: u = H v, rows n and t of each contact), W = H M^-1 H^T
and the free term q = u_ref - W R_ref + (gap / dt, 0), so that u = W R + q at any R, and solves
the step's rigid frictional contact problem (R in Coulomb's cone K, u_n + gap/dt >= 0, each
contact's impulse and velocity complementary) with De Saxce's shift, as Pinocchio's
ADMMContactSolver and Chrono's ChSolverADMM do:

    (W + rho I) r = rho z - y - q - s      (the factorisation made once, here by SuperLU)
    z = proj_K(r + y / rho)
    y = y + rho (r - z)
    s = (mu |u_t(z)|, 0) every --shift-period iterations (De Saxce's shift, which turns Coulomb's
        non-associated law into a cone complementarity problem for a fixed s)

The time step is read from the sample's first line. Starts from the tested impulses (the sweeps'
answer, y = -(u + s) there, so that a solution is a fixed point) or from zero. Prints, at some
iterations, |z - R_ref| / |R_ref| (the per-step error of docs/step-error.md) and the natural-map
residual |R - R'| / |R|, R'_n = max(0, R_n - u_n / w_nn), R'_t = clamp(R_t - u_t / w_tt, -mu R'_n,
mu R'_n). --write-matrix F writes W + F w_nn I (w_nn the mean of W's normal diagonal) as
sample_K_w.mtx for `cdshear_factor_cost`.

  cdshear_bench --packing P --velocity V --no-static --steps 40 --warmup 1000 --step-error 3 \
      --reference-relaxation 1.6 --reference-anderson 5 --dump-samples DIR
  /usr/bin/python3 bench/admm_step.py DIR/shear_nN/sample_1 --rho 1,0.1 [--shift-period K]
"""

import argparse
import time

import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from coarse_space import StepProblem

REPORTED = (1, 2, 5, 10, 20, 50, 100, 200, 500)


def cone_projection(x, mu):
    """Each contact's (n, t) pair projected on |t| <= mu n."""
    xn, xt = x[0::2], x[1::2]
    inside = np.abs(xt) <= mu * xn
    polar = mu * np.abs(xt) <= -xn
    edge = (xn + mu * np.abs(xt)) / (1.0 + mu * mu)
    out = np.empty_like(x)
    out[0::2] = np.where(inside, xn, np.where(polar, 0.0, edge))
    out[1::2] = np.where(inside, xt, np.where(polar, 0.0, edge * mu * np.sign(xt)))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("stem", help="DIR/<case>_n<disks>/sample_K")
    parser.add_argument("--rho", default="1,0.1", help="ADMM's rho, fractions of the mean w_nn")
    parser.add_argument("--shift-period", type=int, default=1,
                        help="iterations between two updates of De Saxce's shift")
    parser.add_argument("--iterations", type=int, default=500)
    parser.add_argument("--write-matrix", type=float, help="write W + F w_nn I, F this value")
    args = parser.parse_args()

    problem = StepProblem(args.stem)
    w, q, mu, w_nn = problem.w, problem.q, problem.mu, problem.w_nn
    reference, tested, error = problem.reference, problem.tested, problem.error

    def residual(r):
        return problem.natural_map_distance(r) / max(np.linalg.norm(r), 1e-300)

    def shift(u):
        s = np.zeros_like(u)
        s[0::2] = mu * np.abs(u[1::2])
        return s

    print(f"{len(mu)} candidates, {int((reference[0::2] > 0).sum())} closed in the "
          f"reference; tested: error {error(tested):.2e}, residual {residual(tested):.2e}; "
          f"reference residual {residual(reference):.2e}")
    if args.write_matrix is not None:
        path = args.stem + "_w.mtx"
        scipy.io.mmwrite(path, (w + args.write_matrix * w_nn * sp.identity(w.shape[0])).tocsc(),
                         symmetry="symmetric")
        print("wrote", path)
    for rho_share in (float(x) for x in args.rho.split(",")):
        rho = rho_share * w_nn
        t0 = time.perf_counter()
        lu = sla.splu((w + rho * sp.identity(w.shape[0])).tocsc(), permc_spec="MMD_AT_PLUS_A")
        factor_ms = 1e3 * (time.perf_counter() - t0)
        for start_name, start in (("tested", tested), ("zero", np.zeros_like(tested))):
            z = start.copy()
            u = w @ z + q
            s = shift(u)
            y = -(u + s)
            line = []
            with np.errstate(all="ignore"):
                for it in range(1, args.iterations + 1):
                    r = lu.solve(rho * z - y - q - s)
                    z = cone_projection(r + y / rho, mu)
                    y = y + rho * (r - z)
                    u = w @ z + q
                    if it % args.shift_period == 0:
                        s = shift(u)
                    if it in REPORTED:
                        line.append(f"{it}: {error(z):.1e} / {residual(z):.1e}")
            print(f"rho {rho_share:g} w_nn, from {start_name} (SuperLU {factor_ms:.0f} ms); "
                  "iteration: error / residual  " + ", ".join(line), flush=True)


if __name__ == "__main__":
    main()

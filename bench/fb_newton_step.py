#!/usr/bin/python3
"""A Fischer-Burmeister semismooth Newton method on one Contact Dynamics step, from a dumped sample
(docs/performance.md, "What did not help": a Fischer-Burmeister semismooth Newton method).

Reads a sample of `cdshear_bench --step-error N --dump-samples DIR` (as `admm_step.py` does: u = W R
+ q at any R, W the Delassus operator over every candidate contact) and writes the step's rigid
frictional contact problem with Fischer and Burmeister's function phi(a, b) = sqrt(a^2 + b^2) - a -
b, which is zero exactly where a >= 0, b >= 0 and a b = 0. In 2D Coulomb's law is a box for R_t
whose bounds move with R_n, which the nested form for a box (Billups) writes per contact:

    Phi_n = phi(R_n, u_n / w)                                 0 <= R_n _|_ u_n >= 0
    Phi_t = phi(R_t + mu R_n, phi(mu R_n - R_t, -u_t / w))    R_t = -mu R_n where u_t > 0,
                                                              mu R_n where u_t < 0, u_t = 0 inside

(w the mean of W's normal diagonal: every entry in impulse units). It solves Phi(R) = 0 by Newton's
method on the semismooth Phi (J an element of its generalized Jacobian: 2 x 2 blocks per contact
plus a row scaling of W; one sparse LU per iteration, SuperLU), with an Armijo search on Psi =
|Phi|^2 / 2 (monotone, or Grippo, Lampariello and Lucidi's non-monotone one with --memory) and the
steepest descent -J^T Phi where the Newton direction does not descend: De Luca, Facchinei and
Kanzow's method, as Siconos' lcp_newton_FB. Where J is singular to SuperLU, or at every iteration
with --lm C, a Levenberg-Marquardt step (J^T J + s I) d = -J^T Phi instead, s = C (|Phi| /
|R_ref|)^p (Yamashita and Fukushima's choice at p = 2, which needs no isolated solution).

Starts from the tested impulses (the sweeps' answer) or from zero; prints at some iterations the
per-step error |R - R_ref| / |R_ref| (docs/step-error.md), the natural-map residual of
`admm_step.py` and |Phi|, both over |R_ref|, and the number of contacts whose status (open,
sticking, sliding) differs from the reference's.

  cdshear_bench --packing P --velocity V --no-static --steps 40 --warmup 1000 --step-error 3 \
      --reference-relaxation 1.6 --reference-anderson 5 --dump-samples DIR
  /usr/bin/python3 bench/fb_newton_step.py DIR/shear_nN/sample_1 [--iterations 50] [--memory 10]
      [--lm 1 --lm-power 2]
"""

import argparse
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from coarse_space import StepProblem, contact_status

REPORTED = (0, 1, 2, 3, 5, 10, 20, 30, 50, 100, 200, 500)
ARMIJO = 1e-4           # sufficient decrease of Psi along a direction


def fb(a, b):
    """phi(a, b) and its generalized derivatives (d/da, d/db); at (0, 0) the element of the
    generalized Jacobian along (1, 1)."""
    norm = np.hypot(a, b)
    zero = norm == 0.0
    safe = np.where(zero, 1.0, norm)
    da = np.where(zero, 1.0 / np.sqrt(2.0), a / safe) - 1.0
    db = np.where(zero, 1.0 / np.sqrt(2.0), b / safe) - 1.0
    return norm - a - b, da, db


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("stem", help="DIR/<case>_n<disks>/sample_K")
    parser.add_argument("--iterations", type=int, default=50)
    parser.add_argument("--shift", type=float, default=1e-8,
                        help="Levenberg-Marquardt shift s where J is singular to SuperLU")
    parser.add_argument("--lm", type=float, default=0.0,
                        help="Levenberg-Marquardt at every iteration, s = C (|Phi| / |R_ref|)^p")
    parser.add_argument("--lm-power", type=float, default=1.0, help="p of --lm")
    parser.add_argument("--memory", type=int, default=1,
                        help="the line search's reference: the largest Psi of this many iterates "
                        "(1: monotone; more: Grippo, Lampariello and Lucidi's non-monotone search)")
    parser.add_argument("--starts", default="tested,zero", help="tested, zero, or tested,zero")
    args = parser.parse_args()

    problem = StepProblem(args.stem)
    w, q, mu, w_nn = problem.w.tocsr(), problem.q, problem.mu, problem.w_nn
    reference, tested, error = problem.reference, problem.tested, problem.error
    m = len(mu)
    impulse_scale = np.linalg.norm(reference)

    def residual(r):
        """The natural map's |R - R'| / |R_ref|."""
        return problem.natural_map_distance(r) / impulse_scale

    def statuses(r):
        """By the impulse alone; open below 1e-9 of the largest R_n (Newton's iterates leave
        round-off where the sweeps leave zeros), sliding to a relative 1e-6 of the cone."""
        n = r[0::2]
        return contact_status(n, r[1::2], mu, 1e-9 * max(n.max(), 1e-300), 1e-6)

    reference_status = statuses(reference)

    def phi_and_jacobian(r, with_jacobian=True):
        """Phi(R) and, if asked, J = an element of its generalized Jacobian (CSC)."""
        u = (w @ r + q) / w_nn
        rn, rt, un, ut = r[0::2], r[1::2], u[0::2], u[1::2]
        phi_n, dn_a, dn_b = fb(rn, un)
        inner, di_a, di_b = fb(mu * rn - rt, -ut)
        phi_t, do_a, do_b = fb(rt + mu * rn, inner)
        phi = np.stack([phi_n, phi_t], 1).ravel()
        if not with_jacobian:
            return phi, None
        # dPhi_n = dn_a dR_n + dn_b dU_n; dPhi_t = do_a (dR_t + mu dR_n)
        #   + do_b (di_a (mu dR_n - dR_t) - di_b dU_t), dU = W dR / w.
        k = np.arange(m)
        rows = np.concatenate([2 * k, 2 * k + 1, 2 * k + 1])
        cols = np.concatenate([2 * k, 2 * k, 2 * k + 1])
        vals = np.concatenate([dn_a, mu * (do_a + do_b * di_a), do_a - do_b * di_a])
        local = sp.csr_matrix((vals, (rows, cols)), shape=(2 * m, 2 * m))
        scale = np.stack([dn_b, -do_b * di_b], 1).ravel() / w_nn
        return phi, (local + sp.diags(scale) @ w).tocsc()

    print(f"{m} candidates, {int((reference[0::2] > 0).sum())} closed in the reference; "
          f"tested: error {error(tested):.2e}, residual {residual(tested):.2e}; "
          f"reference residual {residual(reference):.2e}")
    identity = sp.identity(2 * m, format="csc")
    for start_name in args.starts.split(","):
        z = tested.copy() if start_name == "tested" else np.zeros_like(tested)
        t0 = time.perf_counter()
        counts = {"newton": 0, "gradient": 0, "shifted": 0}
        line = []
        history = []
        for it in range(args.iterations + 1):
            phi, jac = phi_and_jacobian(z, it < args.iterations)
            psi = 0.5 * phi @ phi
            if it in REPORTED or it == args.iterations:
                changed = int((statuses(z) != reference_status).sum())
                line.append(f"{it}: {error(z):.1e} / {residual(z):.1e} / "
                            f"{np.linalg.norm(phi) / impulse_scale:.1e} / {changed}")
            if it == args.iterations or psi == 0.0:
                break
            gradient = jac.T @ phi
            try:
                if args.lm > 0.0:
                    raise RuntimeError("Levenberg-Marquardt asked for")
                d = sla.splu(jac, permc_spec="COLAMD").solve(-phi)
                kind = "newton"
            except RuntimeError:  # singular to SuperLU, or asked for: a Levenberg-Marquardt step
                relative = np.linalg.norm(phi) / impulse_scale
                shift = args.lm * relative ** args.lm_power if args.lm > 0.0 else args.shift
                normal = (jac.T @ jac + shift * identity).tocsc()
                d = sla.splu(normal).solve(-gradient)
                kind = "shifted"
            descent = gradient @ d < 0.0
            if not np.all(np.isfinite(d)) or not descent:
                d = -gradient
                kind = "gradient"
            counts[kind] += 1
            step = 1.0
            slope = gradient @ d
            history = (history + [psi])[-args.memory:]
            while step > 1e-12:
                trial_phi, _ = phi_and_jacobian(z + step * d, False)
                if 0.5 * trial_phi @ trial_phi <= max(history) + ARMIJO * step * slope:
                    break
                step *= 0.5
            z = z + step * d
        seconds = time.perf_counter() - t0
        print(f"from {start_name} ({seconds:.1f} s; {counts['newton']} Newton, {counts['shifted']} "
              f"shifted, {counts['gradient']} gradient directions); iteration: error / residual / "
              "|Phi| / |R_ref| / statuses differing  " + ", ".join(line), flush=True)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""What one exact solve of the window where the contact laws are least met would remove of a
step's impulse error (docs/performance.md, "What did not help": one window solved exactly where
the residual is).

Reads the samples that `cdshear_bench --step-error N --dump-samples DIR` writes (u = W R + q at any
R over every candidate contact, the tested and the reference impulses: coarse_space.StepProblem).
For each sample it measures the natural-map residual of the tested impulses contact by contact
(the distance to the contact laws that a solver can see, never the reference), slides a window
HEIGHT d tall up the cell in steps of STEP d, and takes the window holding the largest share of
the squared residual. The window's contacts, with a ring of OVERLAP d on each side, are then
solved to convergence with every impulse outside them frozen at the tested ones (over-relaxed
projected Gauss-Seidel on the window's dense block of W, the exact fixed point of the step's
laws there), and it prints, as shares of the tested error |R - R_ref|:

- "solved": the error left after the window's exact solve;
- "oracle": the error left with the window's impulses set to the reference ones (the most any
  change of the window alone could remove);
- "best": the same oracle for the window of the same height holding the most squared error
  (chosen from the reference: what a perfect choice of the window would reach);

and the window's share of the step's unknowns (a factorisation's cost grows with it).

  cdshear_bench --sizes 5119 --width 20 --velocity 0.5 --no-static --steps 10 --warmup 1000 \
      --step-error 4 --step-error-spacing 0 --reference-relaxation 1.6 --reference-anderson 5 \
      --reference-newton 16 --threads 1 --dump-samples DIR
  /usr/bin/python3 bench/window_solve.py DIR/shear_nN --height 12 --overlap 2
"""

import argparse
import time

import numpy as np

from coarse_space import ARM_Y, BODY_A, StepProblem, sample_stems


def per_contact(v):
    """|v_k|^2 per contact of a vector with the normal and tangential rows interleaved."""
    return (v ** 2).reshape(-1, 2).sum(1)


def contact_heights(problem):
    """Each candidate contact's point's height (body A's centre plus its arm)."""
    c = problem.contacts
    return problem.bodies[c[:, BODY_A].astype(int), 1] + c[:, ARM_Y]


def in_window(y, bottom, height, overlap):
    """The contacts of the window [bottom, bottom + height) grown by overlap on each side."""
    return (y >= bottom - overlap) & (y < bottom + height + overlap)


def best_window(y, weight, height, step):
    """(bottom, share): the window [bottom, bottom + height) of the given step holding the most
    weight, and that share of the total."""
    bottoms = np.arange(y.min(), max(y.min(), y.max() - height) + step, step)
    sums = np.array([weight[(y >= b) & (y < b + height)].sum() for b in bottoms])
    i = int(np.argmax(sums))
    return float(bottoms[i]), float(sums[i] / weight.sum())


def solve_window(problem, r, inside, relaxation, tolerance, max_sweeps):
    """r with the contacts `inside` solved to convergence, the others frozen: projected
    Gauss-Seidel on the window's dense block (the fixed point R = R' of the natural map on the
    window). Returns (r, sweeps, last change over |R_window|)."""
    rows = np.flatnonzero(np.repeat(inside, 2))   # each contact's normal and tangential row
    w = problem.w.tocsr()
    block = np.asfortranarray(w[rows][:, rows].toarray())
    r = r.copy()
    window = r[rows].copy()
    # the frozen contacts' share of u on the window, and the free term
    q = (w[rows] @ r + problem.q[rows]) - block @ window
    u = block @ window + q
    mu = problem.mu[inside]
    dn, dt = np.diag(block)[0::2], np.diag(block)[1::2]
    scale = max(np.linalg.norm(window), 1e-300)
    for sweep in range(1, max_sweeps + 1):
        change = 0.0
        for k in range(len(mu)):
            i = 2 * k
            n_old, t_old = window[i], window[i + 1]
            n = max(0.0, n_old - u[i] / dn[k])
            n = max(0.0, n_old + relaxation * (n - n_old))
            dn_k = n - n_old
            ut = u[i + 1] + block[i + 1, i] * dn_k
            t = t_old - ut / dt[k]
            t = t_old + relaxation * (t - t_old)
            t = min(max(t, -mu[k] * n), mu[k] * n)
            dt_k = t - t_old
            if dn_k or dt_k:
                u += block[:, i] * dn_k + block[:, i + 1] * dt_k
                window[i], window[i + 1] = n, t
                change += dn_k * dn_k + dt_k * dt_k
        if np.sqrt(change) <= tolerance * scale:
            break
    r[rows] = window
    return r, sweep, np.sqrt(change) / scale


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", help="DIR/<case>_n<disks>")
    parser.add_argument("--height", type=float, default=12.0, help="the window's height [d]")
    parser.add_argument("--step", type=float, default=2.0, help="the window's slide [d]")
    parser.add_argument("--overlap", type=float, default=2.0, help="the ring on each side [d]")
    parser.add_argument("--relaxation", type=float, default=1.3)
    parser.add_argument("--tolerance", type=float, default=1e-10)
    parser.add_argument("--max-sweeps", type=int, default=3000)
    args = parser.parse_args()
    print("sample: tested error; window (its residual share, unknowns share); solved / oracle "
          "/ best (shares of the tested error left); sweeps, last change; seconds")
    for stem in sample_stems(args.folder):
        t0 = time.perf_counter()
        problem = StepProblem(stem)
        tested, reference = problem.tested, problem.reference
        y = contact_heights(problem)
        bottom, share = best_window(y, per_contact(tested - problem.natural_map(tested)),
                                    args.height, args.step)
        inside = in_window(y, bottom, args.height, args.overlap)
        solved, sweeps, change = solve_window(problem, tested, inside, args.relaxation,
                                              args.tolerance, args.max_sweeps)
        error = np.linalg.norm(tested - reference)
        oracle = np.where(np.repeat(inside, 2), reference, tested)
        best_bottom, _ = best_window(y, per_contact(tested - reference), args.height, args.step)
        best_in = in_window(y, best_bottom, args.height, args.overlap)
        best = np.where(np.repeat(best_in, 2), reference, tested)
        print(f"{stem.split('/')[-1]}: {problem.error(tested):.2e}; y {bottom:.1f} to "
              f"{bottom + args.height:.1f} ({share:.2f}, {inside.mean():.3f}); "
              f"{np.linalg.norm(solved - reference) / error:.3g} / "
              f"{np.linalg.norm(oracle - reference) / error:.3g} / "
              f"{np.linalg.norm(best - reference) / error:.3g} (y {best_bottom:.1f}); "
              f"{sweeps}, {change:.1e}; {time.perf_counter() - t0:.1f}", flush=True)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Accelerations of projected Gauss-Seidel on one Contact Dynamics step, from a dumped sample
(docs/performance.md, "What did not help").

Reads a sample of `cdshear_bench --step-error N --dump-samples DIR` as bench/coarse_space.py's
StepProblem (u = W R + q over every candidate contact) and solves it from the tested impulses
(the shear defaults' answer, whose error lies in the modes the sweeps relax slowest; the dump
holds no warm start) or from zero with each method given, counting sweeps (a symmetric sweep
counts two):

- sor W: projected Gauss-Seidel over-relaxed by W, contacts in colour order (greedy colouring of
  the contact-body graph: no two contacts of a colour share a body, so a colour is one block);
- anderson W: the same, the last 5 images of every 4 sweeps mixed (type II, as the solver's
  AndersonMixer) and projected on the cones;
- cheb W RHO: symmetric sweeps (colours forward, then backward) over-relaxed by W, accelerated by
  Chebyshev's semi-iterative method for an iteration matrix whose spectrum lies in [-RHO, RHO]
  (Golub and Varga; Wang 2015 for projective dynamics), each iterate projected on the cones;
- nncg: projected Gauss-Seidel with the nonlinear conjugate-gradient momentum of Silcowski,
  Bruno and Erleben (2015): beta = |r_k|^2 / |r_k-1|^2, restart when beta > 1.

Prints, per method, the sweeps at which |R - R_ref| / |R_ref| first falls below 1e-2, 1e-3 and
1e-4 and the natural-map residual below 1e-3 and 1e-5 of |R_ref| (`-` if not within --sweeps).

  cdshear_bench --sizes 5000 --no-static --steps 60 --warmup 200 --step-error 4 \
      --reference-relaxation 1.6 --reference-anderson 5 --reference-newton 16 --dump-samples DIR
  /usr/bin/python3 bench/accelerated_sweeps.py DIR/shear_n5000/sample_1 --sweeps 1000
"""

import argparse

import numpy as np

from admm_step import cone_projection
from coarse_space import BODY_A, BODY_B, StepProblem

ERROR_LEVELS = (1e-2, 1e-3, 1e-4)
RESIDUAL_LEVELS = (1e-3, 1e-5)


def colour_contacts(contacts):
    """Greedy colouring of the dump's contact rows: each contact the first colour none of its
    bodies holds yet. Returns the colours as arrays of contact indices, in colour order."""
    used = {}
    colour_of = np.empty(len(contacts), dtype=int)
    for k, r in enumerate(contacts):
        a, b = int(r[BODY_A]), int(r[BODY_B])
        taken = used.get(a, set()) | used.get(b, set())
        c = 0
        while c in taken:
            c += 1
        colour_of[k] = c
        used.setdefault(a, set()).add(c)
        used.setdefault(b, set()).add(c)
    return [np.flatnonzero(colour_of == c) for c in range(colour_of.max() + 1)]


class Sweeper:
    """Projected block Gauss-Seidel over colours on u = W R + q."""

    def __init__(self, problem, colours):
        self.p = problem
        self.blocks = []
        for idx in colours:
            rows = np.stack([2 * idx, 2 * idx + 1], 1).ravel()
            self.blocks.append((idx, rows, problem.w[rows, :].tocsr()))

    def sweep(self, r, omega, reverse=False):
        p = self.p
        for idx, rows, w_rows in (reversed(self.blocks) if reverse else self.blocks):
            u = w_rows @ r + p.q[rows]
            rn, rt = r[2 * idx], r[2 * idx + 1]
            n = np.maximum(0.0, rn - omega * u[0::2] / p.diagonal[2 * idx])
            t = rt - omega * u[1::2] / p.diagonal[2 * idx + 1]
            lim = p.mu[idx] * n
            r[2 * idx] = n
            r[2 * idx + 1] = np.clip(t, -lim, lim)
        return r


class Tally:
    def __init__(self, problem):
        self.p = problem
        self.norm = np.linalg.norm(problem.reference)
        self.first_error = {}
        self.first_residual = {}

    def record(self, sweeps, r):
        e = self.p.error(r)
        res = self.p.natural_map_distance(r) / self.norm
        for lv in ERROR_LEVELS:
            if e <= lv and lv not in self.first_error:
                self.first_error[lv] = sweeps
        for lv in RESIDUAL_LEVELS:
            if res <= lv and lv not in self.first_residual:
                self.first_residual[lv] = sweeps
        return e, res

    def line(self, name, e, res):
        cells = [str(self.first_error.get(lv, "-")) for lv in ERROR_LEVELS]
        cells += [str(self.first_residual.get(lv, "-")) for lv in RESIDUAL_LEVELS]
        return f"{name:<22} " + " ".join(f"{c:>6}" for c in cells) + f"   end {e:.2e} {res:.2e}"


def run_sor(s, r, omega, sweeps, tally):
    for k in range(1, sweeps + 1):
        s.sweep(r, omega)
        e, res = tally.record(k, r)
    return e, res


def run_anderson(s, r, omega, sweeps, tally, depth=5, period=4):
    xs, gs = [], []
    k = 0
    e = res = None
    last_f2 = np.inf
    while k < sweeps:
        x = r.copy()
        for _ in range(period):
            s.sweep(r, omega)
            k += 1
            e, res = tally.record(k, r)
        f = r - x
        f2 = f @ f
        if f2 > last_f2:
            xs, gs = [], []
        last_f2 = f2
        xs.append(x)
        gs.append(r.copy())
        xs, gs = xs[-(depth + 1):], gs[-(depth + 1):]
        if len(xs) > 1:
            fs = [g - xx for g, xx in zip(gs, xs)]
            df = np.stack([fs[j + 1] - fs[j] for j in range(len(fs) - 1)], 1)
            dg = np.stack([gs[j + 1] - gs[j] for j in range(len(gs) - 1)], 1)
            gram = df.T @ df
            gram += 1e-10 * np.trace(gram) * np.eye(len(gram))
            gamma = np.linalg.solve(gram, df.T @ fs[-1])
            r = cone_projection(r - dg @ gamma, s.p.mu)
            gs[-1] = r.copy()
    return e, res


def run_chebyshev(s, r, omega, rho, sweeps, tally, warm=0):
    """Chebyshev semi-iteration on the symmetric sweep S: y_k+1 = P(w_k+1 (S(y_k) - y_k-1) +
    y_k-1), P the projection on the cones, y_-1 = y_0, w = 1 for the first `warm` iterations,
    then 2 / (2 - rho^2) and w_k+1 = 4 / (4 - rho^2 w_k) (Wang's recurrence for an iteration
    matrix whose spectrum lies within [-rho, rho]). With warm = 0 (the default) the first
    iteration is S's change over-relaxed by 2 / (2 - rho^2), where Wang's takes it whole."""
    k = 0
    previous = r.copy()
    w = 1.0
    step = 0
    e = res = None
    while k + 2 <= sweeps:
        image = s.sweep(r.copy(), omega)
        image = s.sweep(image, omega, reverse=True)
        k += 2
        step += 1
        if step <= warm:
            w = 1.0
        elif step == warm + 1:
            w = 2.0 / (2.0 - rho * rho)
        else:
            w = 4.0 / (4.0 - rho * rho * w)
        new = cone_projection(w * (image - previous) + previous, s.p.mu)
        previous = r
        r = new
        e, res = tally.record(k, r)
    return e, res


def run_nncg(s, r, sweeps, tally, omega=1.0):
    p = None
    last = None
    e = res = None
    for k in range(1, sweeps + 1):
        x = r.copy()
        s.sweep(r, omega)
        g = r - x
        g2 = g @ g
        if last is None or last == 0.0:
            p = g
        else:
            beta = g2 / last
            if beta > 1.0:
                p = g
            else:
                r = cone_projection(r + beta * p, s.p.mu)
                p = beta * p + g
        last = g2
        e, res = tally.record(k, r)
    return e, res


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("stem", nargs="+", help="DIR/<case>_n<disks>/sample_K")
    parser.add_argument("--sweeps", type=int, default=600)
    parser.add_argument("--start", choices=("zero", "tested"), default="tested",
                        help="start from zero or from the tested impulses (the sweeps' answer: "
                        "its error lies in the modes the sweeps relax slowest)")
    parser.add_argument("--methods", default="sor:1.6,anderson:1.6,cheb:1.0:0.99,nncg")
    args = parser.parse_args()
    for stem in args.stem:
        problem = StepProblem(stem)
        colours = colour_contacts(problem.contacts)
        s = Sweeper(problem, colours)
        if args.start == "zero":
            start = np.zeros_like(problem.reference)
        else:
            start = problem.tested.copy()
        print(f"{stem}: {len(problem.mu)} contacts, {len(colours)} colours, start error "
              f"{problem.error(start):.2e}")
        print(f"{'method':<22} " + " ".join(f"{lv:>6.0e}" for lv in ERROR_LEVELS)
              + " " + " ".join(f"{'r' + format(lv, '.0e'):>6}" for lv in RESIDUAL_LEVELS))
        for spec in args.methods.split(","):
            parts = spec.split(":")
            tally = Tally(problem)
            r = start.copy()
            if parts[0] == "sor":
                e, res = run_sor(s, r, float(parts[1]), args.sweeps, tally)
            elif parts[0] == "anderson":
                e, res = run_anderson(s, r, float(parts[1]), args.sweeps, tally)
            elif parts[0] == "cheb":
                warm = int(parts[3]) if len(parts) > 3 else 0
                e, res = run_chebyshev(s, r, float(parts[1]), float(parts[2]), args.sweeps, tally,
                                       warm)
            elif parts[0] == "nncg":
                e, res = run_nncg(s, r, args.sweeps, tally,
                                  float(parts[1]) if len(parts) > 1 else 1.0)
            else:
                raise SystemExit(f"error: --methods: unknown method {parts[0]!r}")
            print(tally.line(spec, e, res), flush=True)


if __name__ == "__main__":
    main()

"""The profile's decay time (relaxation.py) on synthetic windows whose decay is known."""
import math
import unittest

import numpy as np

from cdshear_analysis import relaxation


def synthetic_windows(tau, window=4.0, duration=400.0, noise=0.01, height=20.0, dilation=0.0,
                      dilation_tau=None, seed=1):
    """Windows of a cell whose vx / V is the steady 0.8 (2 eta - 1) plus a decaying mode
    -0.6 sin(2 pi eta) exp(-t / tau) (eta = y / L_y), with Gaussian noise per stripe; the height
    grows from height to height (1 + dilation) with the time constant dilation_tau (tau if
    None)."""
    rng = np.random.default_rng(seed)
    t_start = np.arange(0.0, duration, window)
    t_mid = t_start + window / 2
    dy = 0.5
    y = np.arange(dy / 2, 1.5 * height * (1 + dilation), dy)
    H = height * (1 + dilation * (1 - np.exp(-t_mid / (dilation_tau or tau))))
    V = 2.0
    vx = np.full((len(t_start), len(y)), np.nan)
    for k, (t, h) in enumerate(zip(t_mid, H)):
        inside = y < h
        eta = y[inside] / h
        vx[k, inside] = V * (0.8 * (2 * eta - 1) - 0.6 * np.sin(2 * np.pi * eta) * np.exp(-t / tau)
                             + noise * rng.standard_normal(inside.sum()))
    return {"t_start": t_start, "t_end": t_start + window, "y": y, "height": H, "vx": vx}, V


class ProfileDecay(unittest.TestCase):
    def test_recovers_the_decay_time_of_a_known_mode(self):
        for tau in (20.0, 60.0):
            w, V = synthetic_windows(tau)
            steady = np.flatnonzero(w["t_start"] >= 300.0)
            out = relaxation.profile_decay(w, V, steady, "rest")
            self.assertIsNone(out["reason"])
            self.assertAlmostEqual(out["tau"] / tau, 1.0, delta=0.08)
            self.assertLess(abs(out["tau"] - tau), 4 * out["tau_err"] + 0.02 * tau)
            self.assertGreaterEqual(out["fit_windows"], relaxation.MIN_FIT_WINDOWS)
            # the noise floor is the stripes' noise seen through the interpolation: about 0.01
            self.assertGreater(out["floor"], 0.003)
            self.assertLess(out["floor"], 0.02)

    def test_a_dilating_cell_is_compared_at_the_same_fractions_of_its_height(self):
        # the cell grows by 20% three times more slowly than the profile decays: compared at
        # fixed heights, the steady profile's stretch would read as a slower decay
        w, V = synthetic_windows(40.0, dilation=0.2, dilation_tau=120.0)
        steady = np.flatnonzero(w["t_start"] >= 300.0)
        out = relaxation.profile_decay(w, V, steady, "rest")
        self.assertAlmostEqual(out["tau"] / 40.0, 1.0, delta=0.08)
        w["height"] = np.full_like(w["height"], w["height"][-1])
        self.assertGreater(relaxation.profile_decay(w, V, steady, "rest")["tau"] / 40.0, 1.2)

    def test_the_last_half_is_the_reference_of_a_run_that_is_not_steady(self):
        w, V = synthetic_windows(30.0)
        out = relaxation.profile_decay(w, V, [], "rest")
        self.assertEqual(out["reference"], "the last half of the run (not steady)")
        self.assertAlmostEqual(out["tau"] / 30.0, 1.0, delta=0.08)

    def test_a_decay_faster_than_the_windows_is_not_measured_and_says_why(self):
        w, V = synthetic_windows(3.0, window=8.0)
        out = relaxation.profile_decay(w, V, np.flatnonzero(w["t_start"] >= 300.0), "rest")
        self.assertIsNone(out["tau"])
        self.assertIn("measure.window", out["reason"])

    def test_a_run_without_windows_has_no_decay(self):
        w, V = synthetic_windows(30.0)
        empty = {k: v[:0] if k != "y" else v for k, v in w.items()}
        out = relaxation.profile_decay(empty, V, [], "linear")
        self.assertIsNone(out["tau"])
        self.assertEqual(out["reason"], "no complete window")


if __name__ == "__main__":
    unittest.main()


class ProfileDecayCommand(unittest.TestCase):
    def test_prints_each_run_against_the_bulk_law_and_refuses_a_file_without_fits(self):
        import contextlib
        import io
        import json
        import os
        import tempfile

        from cdshear_analysis.__main__ import main
        from cdshear_analysis.synthetic import write_synthetic_run
        with tempfile.TemporaryDirectory() as d:
            run = os.path.join(d, "s1_seed1_V2")
            write_synthetic_run(run, kind="A", duration=400.0, window=20.0)
            with contextlib.redirect_stdout(io.StringIO()):
                self.assertEqual(main(["analyze", run, "--quiet"]), 0)
            fits = os.path.join(d, "fits.json")
            law = {"model": "power_plus", "status": "ok",
                   "parameters": {"mu_0": {"value": 0.24}, "A": {"value": 0.89},
                                  "B": {"value": 0.81}}}
            with open(fits, "w") as f:
                json.dump({"fits": {"mu_power": law}}, f)
            out, table = io.StringIO(), os.path.join(d, "decay.json")
            with contextlib.redirect_stdout(out):
                self.assertEqual(main(["profile-decay", run, "--fits", fits, "--json", table]),
                                 0)
            self.assertIn("s1_seed1_V2", out.getvalue())
            with open(table) as f:
                entry = json.load(f)["runs"][0]
            # T_SS = L_y^2 / D with D = A B I^(B-1) sqrt(m / sigma) sigma / (rho nu)
            I, nu, L = entry["I_bulk"], entry["nu_bulk"], entry["L_y"]
            D = 0.89 * 0.81 * I ** -0.19 * math.sqrt(math.pi / 4 / 0.25) * 0.25 / nu
            self.assertAlmostEqual(entry["T_SS"], L ** 2 / D, delta=1e-9 * L ** 2 / D)
            with open(fits, "w") as f:
                json.dump({"runs": []}, f)
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                self.assertEqual(main(["profile-decay", run, "--fits", fits]), 2)
            self.assertIn(fits, err.getvalue())

"""The profile's decay time (relaxation.py) on synthetic windows whose decay is known."""
import contextlib
import io
import json
import math
import os
import shutil
import re
import tempfile
import unittest
from unittest import mock

import numpy as np

from cdshear_analysis import relaxation
from cdshear_analysis.__main__ import main
from cdshear_analysis.synthetic import write_synthetic_run

LAW = {"model": "power_plus", "status": "ok",
       "parameters": {"mu_0": {"value": 0.24}, "A": {"value": 0.89}, "B": {"value": 0.81}}}


def synthetic_windows(tau, window=4.0, duration=600.0, noise=0.01, height=20.0, dilation=0.0,
                      dilation_tau=None, mode="sin", ar_noise=0.0, seed=1):
    """Windows of a cell whose vx / V is the steady 0.3 (2 eta - 1) plus a decaying mode
    -0.3 f(eta) exp(-t / tau) (eta = y / L_y; f = sin(2 pi eta) or cos(pi eta)), with Gaussian
    noise per stripe and, with ar_noise, a noise along the mode correlated from window to window
    (AR(1), 0.8); the height grows from height to height (1 + dilation) with the time constant
    dilation_tau (tau if None)."""
    rng = np.random.default_rng(seed)
    t_start = np.arange(0.0, duration, window)
    t_mid = t_start + window / 2
    dy = 0.5
    y = np.arange(dy / 2, 1.5 * height * (1 + dilation), dy)
    H = height * (1 + dilation * (1 - np.exp(-t_mid / (dilation_tau or tau))))
    f = (lambda e: np.sin(2 * np.pi * e)) if mode == "sin" else (lambda e: np.cos(np.pi * e))
    V = 2.0
    vx = np.full((len(t_start), len(y)), np.nan)
    ar = 0.0
    for k, (t, h) in enumerate(zip(t_mid, H)):
        ar = 0.8 * ar + ar_noise * math.sqrt(1 - 0.8 ** 2) * rng.standard_normal()
        inside = y < h
        eta = y[inside] / h
        vx[k, inside] = V * (0.3 * (2 * eta - 1) - (0.3 * np.exp(-t / tau) + ar) * f(eta)
                             + noise * rng.standard_normal(inside.sum()))
    return {"t_start": t_start, "t_end": t_start + window, "y": y, "height": H, "vx": vx}, V


class ProfileDecay(unittest.TestCase):
    def test_recovers_the_decay_time_and_the_shape_of_a_known_mode(self):
        for tau, mode, other in ((20.0, "sin", "cos_pi_eta"), (60.0, "cos", "sin_2pi_eta")):
            w, V = synthetic_windows(tau, mode=mode)
            out = relaxation.profile_decay(w, V, "rest")
            self.assertIsNone(out["reason"])
            self.assertTrue(out["resolved"])
            self.assertLess(abs(out["tau"] / tau - 1), 0.05)
            self.assertLess(abs(out["tau"] - tau), 3 * out["tau_err"])
            name = "sin_2pi_eta" if mode == "sin" else "cos_pi_eta"
            self.assertGreater(out["shape_overlap"][name], 0.99)
            # the two shapes are close over 0.05 to 0.95 of the height (overlap 0.90)
            self.assertLess(out["shape_overlap"][other], 0.95)
            f = relaxation.MODES[name](relaxation.ETA)
            expected = 0.3 * math.sqrt(np.mean(f ** 2)) * math.exp(-out["fit_range"][0] / tau)
            self.assertLess(abs(out["c_0"] / expected - 1), 0.05)

    def test_the_fit_starts_after_the_peak_when_the_first_window_is_below_it(self):
        # windows 20 t apart, c = exp(-(t - 30) / 100) but the first window still building up:
        # starting at that window would fit the rise too (tau 164 instead of 100)
        t = np.arange(10.0, 800.0, 20.0)
        c = np.exp(-(t - 30.0) / 100.0)
        c[0] = 0.3
        out = relaxation.fit_decay(t, c, 1e-4)
        self.assertIsNone(out["reason"])
        self.assertGreater(out["fit_range"][0], t[1])
        self.assertLess(abs(out["tau"] / 100.0 - 1), 1e-3)

    def test_a_series_that_never_falls_below_its_peak_has_no_decay_and_says_why(self):
        # the largest value in the last window: nothing after it to fit
        t = np.arange(10.0, 800.0, 20.0)
        out = relaxation.fit_decay(t, 1.0 - np.exp(-t / 100.0), 1e-4)
        self.assertIsNone(out["tau"])
        self.assertFalse(out["resolved"])
        self.assertIn("a longer run", out["reason"])

    def test_a_dilating_cell_is_compared_at_the_same_fractions_of_its_height(self):
        # the cell grows by 20% three times more slowly than the profile decays: compared at
        # fixed heights, the steady profile's stretch would read as a slower decay
        w, V = synthetic_windows(40.0, dilation=0.2, dilation_tau=120.0)
        self.assertLess(abs(relaxation.profile_decay(w, V, "rest")["tau"] / 40.0 - 1), 0.05)
        w["height"] = np.full_like(w["height"], w["height"][-1])
        self.assertGreater(relaxation.profile_decay(w, V, "rest")["tau"] / 40.0, 1.2)

    def test_a_reference_that_still_holds_part_of_the_decay_is_taken_up_by_c_inf(self):
        # the last half starts at 2.5 tau: the reference holds 8% of the mode
        w, V = synthetic_windows(80.0, duration=400.0)
        out = relaxation.profile_decay(w, V, "rest")
        self.assertLess(abs(out["tau"] / 80.0 - 1), 0.05)
        self.assertLess(out["c_inf"], -0.005)

    def test_correlated_noise_widens_the_error_as_much_as_it_moves_tau(self):
        pulls = []
        for seed in range(30):
            w, V = synthetic_windows(40.0, ar_noise=0.015, seed=seed)
            out = relaxation.profile_decay(w, V, "rest")
            pulls.append((out["tau"] - 40.0) / out["tau_err"])
            self.assertGreater(out["statistical_inefficiency"], 1.5)
        # 1.7 here, 2.9 without the factor: the short series' autocorrelations come out low
        self.assertLess(np.std(pulls), 2.2)
        self.assertLess(abs(np.mean(pulls)), 0.8)

    def test_windows_without_a_whole_profile_are_left_out(self):
        w, V = synthetic_windows(30.0)
        w["vx"][5] = np.nan
        w["height"][9] = np.nan
        out = relaxation.profile_decay(w, V, "rest")
        self.assertEqual(len(out["t"]), len(w["t_start"]) - 2)
        self.assertLess(abs(out["tau"] / 30.0 - 1), 0.05)

    def test_a_decay_longer_than_the_run_is_not_resolved_and_says_why(self):
        w, V = synthetic_windows(200.0, duration=400.0)
        out = relaxation.profile_decay(w, V, "rest")
        self.assertFalse(out["resolved"])
        self.assertIn("a longer run", out["reason"])

    def test_a_decay_faster_than_the_windows_is_not_measured_and_says_why(self):
        w, V = synthetic_windows(2.0, window=8.0, duration=400.0)
        out = relaxation.profile_decay(w, V, "rest")
        self.assertIsNone(out["tau"])
        self.assertIn("measure.window", out["reason"])

    def test_a_fit_left_at_the_windows_spacing_is_not_a_measured_decay(self):
        # without noise the fit of a decay 16 times faster than the windows stays at its
        # first guess, one spacing
        w, V = synthetic_windows(5.0, window=80.0, duration=2000.0, noise=0.0)
        out = relaxation.profile_decay(w, V, "rest")
        self.assertIsNone(out["tau"])
        self.assertIn("measure.window", out["reason"])
        # spacings not exact in binary: the guess and the median spacing differ in the last bits
        for spacing in (0.3, 0.7, 8.3):
            t = 0.1 + spacing * np.arange(30)
            out = relaxation.fit_decay(t, np.exp(-t / (spacing / 16)), 1e-30)
            self.assertIsNone(out["tau"], spacing)

    def test_a_profile_that_never_changes_has_no_decay(self):
        w, V = synthetic_windows(30.0, noise=0.0)
        w["vx"] = np.where(np.isfinite(w["vx"]), 0.5, np.nan)
        out = relaxation.profile_decay(w, V, "rest")
        self.assertIsNone(out["tau"])
        self.assertEqual(out["reason"], "the profile does not change from window to window")

    def test_a_run_without_windows_has_no_decay(self):
        w, V = synthetic_windows(30.0)
        empty = {k: v[:0] if k != "y" else v for k, v in w.items()}
        out = relaxation.profile_decay(empty, V, "linear")
        self.assertIsNone(out["tau"])
        # the same keys as a measured decay's, for summary.json's readers
        self.assertEqual(set(out), set(relaxation.profile_decay(w, V, "rest")))
        self.assertIn("complete windows", out["reason"])


def summary_of(run, L_y, I, tau, start="rest", regime="A", steady=True, n=511, height=20.0):
    return {"run": run, "regime": regime, "steady": steady, "height": {"mean": L_y},
            "bulk": {"inertial_number": {"mean": I}, "solid_fraction": {"mean": 0.8}},
            "case": {"normal_stress": 0.25, "n": n, "height": height},
            "profile_decay": {"initial_velocity": start, "tau": tau, "tau_err": 0.02 * tau,
                              "resolved": True, "reason": None, "fit_range": [10.0, 900.0],
                              "t": [10.0, 20.0, 30.0], "c": [0.1, None, 0.05], "c_0": 0.1,
                              "c_inf": 0.0}}


class AgainstDiffusion(unittest.TestCase):
    def test_a_decay_time_as_l_squared_over_d_gives_the_exponent_two(self):
        from cdshear_analysis.transitions import steady_state_time
        runs = []
        for L, I, n in ((22.0, 0.10, 511), (43.0, 0.05, 1023), (84.0, 0.025, 2047)):
            T, _ = steady_state_time(LAW, I, L, 0.8, 0.25)
            runs.append(summary_of(f"L{L:g}", L, I, 0.06 * T, n=n))
        runs.append(summary_of("linear", 22.0, 0.1, 5.0, start="linear"))
        runs.append(summary_of("slow", 22.0, 0.01, 5.0, regime="B"))
        entries, exponent = relaxation.decay_against_diffusion(runs, {"mu_power": LAW})
        self.assertEqual([e["used"] for e in entries], [True, True, True, False, False])
        self.assertEqual(entries[3]["reason"], "not started at rest")
        self.assertIn("not steady regime A", entries[4]["reason"])
        for e in entries[:3]:
            self.assertAlmostEqual(e["tau_over_T_SS"], 0.06, places=12)
        self.assertAlmostEqual(exponent["p"], 2.0, places=9)
        self.assertEqual(exponent["runs"], 3)
        # tau as L_y^1.5 / D: the exponent says so
        for r, L in zip(runs, (22.0, 43.0, 84.0)):
            r["profile_decay"]["tau"] *= (22.0 / L) ** 0.5
            r["profile_decay"]["tau_err"] = 0.02 * r["profile_decay"]["tau"]
        self.assertAlmostEqual(
            relaxation.decay_against_diffusion(runs, {"mu_power": LAW})[1]["p"], 1.5, places=9)
        self.assertIsNone(relaxation.exponent_absence(entries))

    def test_one_system_at_several_heights_gives_no_exponent(self):
        # One system whose L_y moves with V by its dilation (23 and 24 rounded): no power law of
        # the height, and the table says why.
        from cdshear_analysis.transitions import steady_state_time
        runs = []
        for L, I in ((22.7, 0.10), (23.7, 0.05)):
            T, _ = steady_state_time(LAW, I, L, 0.8, 0.25)
            runs.append(summary_of(f"L{L:g}", L, I, 0.06 * T))
        entries, exponent = relaxation.decay_against_diffusion(runs, {"mu_power": LAW})
        self.assertEqual([e["used"] for e in entries], [True, True])
        self.assertIsNone(exponent)
        self.assertIn("no exponent of the height: the 2 used runs are of one system (n = 511, "
                      "height 20)", relaxation.format_decay_table(entries, exponent))
        # two systems at one measured height (a wider cell): no slope to fit, said so
        runs[1] = summary_of("wide", 22.7, 0.05, runs[1]["profile_decay"]["tau"], n=1023)
        entries, exponent = relaxation.decay_against_diffusion(runs, {"mu_power": LAW})
        self.assertIsNone(exponent)
        self.assertIn("the used runs' measured heights are one",
                      relaxation.format_decay_table(entries, exponent))
        # one n at two nominal heights: two systems
        runs[1] = summary_of("tall", 43.0, 0.05, runs[1]["profile_decay"]["tau"], height=40.0)
        self.assertIsNotNone(relaxation.decay_against_diffusion(runs, {"mu_power": LAW})[1])

    def test_the_figure_draws_the_used_runs_alone(self):
        from cdshear_analysis.plots import plot_profile_decay
        from cdshear_analysis.transitions import steady_state_time
        T, _ = steady_state_time(LAW, 0.1, 22.0, 0.8, 0.25)
        used = summary_of("L22", 22.0, 0.1, 0.06 * T)
        damaged = summary_of("damaged", 22.0, 0.1, 0.06 * T)
        damaged["profile_decay"]["tau"] = "12"   # read as missing: not used, not drawn
        entries, _ = relaxation.decay_against_diffusion([used, damaged], {"mu_power": LAW})
        self.assertEqual([e["used"] for e in entries], [True, False])
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "decay.png")
            plot_profile_decay([used, damaged], entries, path)
            with open(path, "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
            with self.assertRaisesRegex(ValueError, "no run is used"):
                plot_profile_decay([damaged], entries[1:], os.path.join(d, "none.png"))
            self.assertFalse(os.path.exists(os.path.join(d, "none.png")))

    def test_a_damaged_series_is_not_used(self):
        from cdshear_analysis.transitions import steady_state_time
        T, _ = steady_state_time(LAW, 0.1, 22.0, 0.8, 0.25)
        for change, words in (({"t": [10.0, 20.0]}, "not series of one length"),
                              ({"c": [0.1, "x", 0.05]}, "not a finite number"),
                              ({"c_inf": None}, "c_inf is not a finite number"),
                              ({"fit_range": None}, "fit_range is not two finite numbers")):
            run = summary_of("L22", 22.0, 0.1, 0.06 * T)
            run["profile_decay"].update(change)
            (e,), _ = relaxation.decay_against_diffusion([run], {"mu_power": LAW})
            self.assertFalse(e["used"])
            self.assertIn(words, e["reason"])


    def test_bulk_law_parameters_beyond_the_range_of_a_number_give_a_reason(self):
        # A hand-edited fits.json: I^(B - 1) overflows, or D is below the smallest float (T_SS
        # would divide by 0), or D so large that tau / T_SS overflows. Each run says why.
        run = summary_of("L22", 22.0, 0.01, 1e300)
        power = dict(LAW, parameters=dict(LAW["parameters"], B={"value": -1e5}))
        linear = {"model": "linear_plus", "status": "ok",
                  "parameters": {"a": {"value": 0.1}, "b": {"value": 5e-324}}}
        for fits, words in (({"mu_power": power}, "d mu / d I at I_bulk = 0.01 is beyond"),
                            ({"mu_linear": linear}, "T_SS = L_y^2 / D is beyond")):
            self.assertIsNone(relaxation.bulk_law_problem(fits))
            (e,), _ = relaxation.decay_against_diffusion([run], fits)
            self.assertFalse(e["used"])
            self.assertIn(words, e["reason"])
            self.assertIsNone(e["T_SS"])
        linear["parameters"]["b"]["value"] = 1e308
        (e,), _ = relaxation.decay_against_diffusion([run], {"mu_linear": linear})
        self.assertGreater(e["T_SS"], 0)
        self.assertIsNone(e["tau_over_T_SS"])   # 1e300 / T_SS overflows: left out
        self.assertFalse(e["used"])


class DecayTable(unittest.TestCase):
    def test_columns_align_whatever_the_names_and_values(self):
        from cdshear_analysis.transitions import steady_state_time
        T, _ = steady_state_time(LAW, 0.1, 22.0, 0.8, 0.25)
        runs = [summary_of("L22", 22.0, 0.1, 0.06 * T),
                summary_of("campaign_b/runs/s1_seed1_V0.05_longer_name", 84.0, 0.025, 1e7),
                dict(summary_of("bare", 22.0, 0.1, 0.06 * T), profile_decay=None)]
        entries, exponent = relaxation.decay_against_diffusion(runs, {"mu_power": LAW})
        lines = relaxation.format_decay_table(entries, exponent).splitlines()
        header, rows = lines[0], lines[1:4]
        spans = [m.span() for m in re.finditer(r"\S+", header)]
        columns, note = spans[:11], spans[11][0]   # then "fit / reason"
        self.assertEqual(header[note:], "fit / reason")
        for row, e in zip(rows, entries):
            self.assertTrue(row.startswith(e["run"] + " "), row)
            for k, (start, end) in enumerate(columns):
                if k < 3:   # texts: each begins where its header does
                    self.assertNotEqual(row[start], " ", (row, k))
                    self.assertEqual(row[start - 1] if start else " ", " ", (row, k))
                else:       # numbers ("-" where missing): each ends where its header does
                    self.assertNotEqual(row[end - 1], " ", (row, k))
                    self.assertEqual(row[end], " ", (row, k))
            if len(row) > note:   # the fit's range or the reason, beside each other
                self.assertEqual(row[note - 2:note], "  ", row)
                self.assertNotEqual(row[note], " ", row)
        self.assertIn("(not used: no profile_decay in summary.json", rows[2])
        # its start unknown: "-" as every missing value, not Python's None
        self.assertEqual(rows[2][columns[1][0]:].split()[0], "-")
        self.assertNotIn("None", rows[2])
        # the long name widens its column; no cell runs into the next
        self.assertEqual(columns[1][0], len("campaign_b/runs/s1_seed1_V0.05_longer_name") + 1)


def analysed_run_and_law(test, d, run):
    """A regime-A synthetic run at `run`, analysed, and D/fits.json holding the bulk law LAW:
    the path of the fits file."""
    write_synthetic_run(run, kind="A", duration=400.0, window=20.0)
    with contextlib.redirect_stdout(io.StringIO()):
        test.assertEqual(main(["analyze", run, "--quiet"]), 0)
    fits = os.path.join(d, "fits.json")
    with open(fits, "w") as f:
        json.dump({"fits": {"mu_power": LAW}}, f)
    return fits


class ProfileDecayCommand(unittest.TestCase):
    def test_runs_of_one_folder_name_in_two_campaigns_are_told_apart(self):
        with tempfile.TemporaryDirectory() as d:
            run = os.path.join(d, "a", "runs", "s1_seed1_V2")
            fits = analysed_run_and_law(self, d, run)
            other = os.path.join(d, "campaign_b", "runs", "s1_seed1_V2")
            shutil.copytree(run, other)
            table = os.path.join(d, "decay.json")
            out = io.StringIO()
            # the exponent's absence is judged once, for the fit and for the table
            with contextlib.redirect_stdout(out), mock.patch.object(
                    relaxation, "exponent_absence", wraps=relaxation.exponent_absence) as judged:
                self.assertEqual(main(["profile-decay", run, other, "--fits", fits, "--json",
                                       table]), 0)
            self.assertEqual(judged.call_count, 1)
            names = ["a/runs/s1_seed1_V2", "campaign_b/runs/s1_seed1_V2"]
            rows = out.getvalue().splitlines()[1:3]
            for row, name in zip(rows, names):
                self.assertTrue(row.startswith(name + " "), row)
            self.assertEqual(rows[0].index(" linear"), rows[1].index(" linear"))
            with open(table) as f:
                self.assertEqual([e["run"] for e in json.load(f)["runs"]], names)
            # a folder name given once stays the folder's name alone
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                self.assertEqual(main(["profile-decay", other, "--fits", fits]), 0)
            self.assertTrue(out.getvalue().splitlines()[1].startswith("s1_seed1_V2 "))

    def test_prints_each_run_against_the_bulk_law_and_refuses_bad_files(self):
        with tempfile.TemporaryDirectory() as d:
            run = os.path.join(d, "s1_seed1_V2")
            fits = analysed_run_and_law(self, d, run)
            out, table = io.StringIO(), os.path.join(d, "decay.json")
            with contextlib.redirect_stdout(out):
                self.assertEqual(main(["profile-decay", run, "--fits", fits, "--json", table]),
                                 0)
            self.assertIn("s1_seed1_V2", out.getvalue())
            with open(table) as f:
                entry = json.load(f)["runs"][0]
            self.assertEqual(entry["initial_velocity"], "linear")
            self.assertFalse(entry["used"])
            # model.md section 8 from the run's own bulk: T_SS = L_y^2 / D, D = (d mu / d I)
            # sqrt(m / sigma_yy) sigma_yy / (rho nu), d mu / d I = A B I^(B - 1), rho = 1,
            # m = pi / 4
            I, sigma = entry["I_bulk"], entry["sigma_yy"]
            dmu_dI = 0.89 * 0.81 * I ** (0.81 - 1.0)
            D = dmu_dI * math.sqrt(math.pi / 4 / sigma) * sigma / entry["nu_bulk"]
            self.assertAlmostEqual(entry["T_SS"] / (entry["L_y"] ** 2 / D), 1.0, places=12)
            # One run given twice, or a summary.json copied from another run's folder.
            copy = os.path.join(d, "s5_seed7_V2")
            os.makedirs(copy)
            shutil.copy(os.path.join(run, "summary.json"), copy)
            for runs, problem in (([run, run + os.sep], f"{run + os.sep} is {run} again: each "
                                   "run counts once"),
                                  ([run, copy], f"{copy}/summary.json: summary.json is of "
                                   "another run")):
                err = io.StringIO()
                with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                    self.assertEqual(main(["profile-decay", *runs, "--fits", fits]), 2)
                self.assertIn(problem, err.getvalue())
            for content in ({"runs": []}, [1, 2], "{"):
                with open(fits, "w") as f:
                    f.write(content if isinstance(content, str) else json.dumps(content))
                err = io.StringIO()
                with contextlib.redirect_stderr(err):
                    self.assertEqual(main(["profile-decay", run, "--fits", fits]), 2)
                self.assertIn(fits, err.getvalue())
            fifo = os.path.join(d, "fifo.json")
            os.mkfifo(fifo)   # refused, not waited on (docs/reliability.md)
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                self.assertEqual(main(["profile-decay", run, "--fits", fifo]), 2)
            self.assertIn(fifo, err.getvalue())
            with open(fits, "w") as f:
                json.dump({"fits": {"mu_power": LAW}}, f)
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                self.assertEqual(main(["profile-decay", d, "--fits", fits]), 2)
                self.assertEqual(main(["profile-decay", run, "--fits", fits, "--json",
                                       os.path.join(d, "none", "x.json")]), 2)
            self.assertIn(os.path.join(d, "summary.json"), err.getvalue())
            self.assertIn(os.path.join(d, "none", "x.json"), err.getvalue())
            # Outputs that would replace an input, and bulk laws that cannot be used: refused by
            # name before anything is written.
            summary_path = os.path.join(run, "summary.json")
            with open(summary_path, "rb") as f:
                summary_bytes = f.read()
            for argv, problem in (
                    (["--json", summary_path], "--json: is a file of the input folder"),
                    (["--json", fits], "--json: is one of the command's inputs"),
                    (["--plot", os.path.join(d, "decay.xyz")], "must end in .png"),
                    (["--plot", os.path.join(d, "x.png"), "--json", os.path.join(d, "x.png")],
                     "--plot: the file --json names"),
                    # no run used (the run started from the linear profile): no figure
                    (["--plot", os.path.join(d, "x.png")], "--plot: no run is used"),
                    (["--plot", d], "--plot: is a folder")):
                err = io.StringIO()
                with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                    self.assertEqual(main(["profile-decay", run, "--fits", fits] + argv), 2)
                self.assertIn(problem, err.getvalue())
            with open(summary_path, "rb") as f:
                self.assertEqual(f.read(), summary_bytes)
            params = LAW["parameters"]
            for law, problem in (("ok", "fits.mu_power is not an object"),
                                 # the slope comes from the report's model for the law only
                                 (dict(LAW, model="linear_plus"),
                                  "fits.mu_power.model must be power_plus"),
                                 (dict(LAW, model="banana"), "not 'banana'"),
                                 (dict(LAW, parameters=[1, 2, 3]), "fits.mu_power.parameters"),
                                 (dict(LAW, parameters=0.5),
                                  "fits.mu_power.parameters is not an object"),
                                 (dict(LAW, parameters={"mu_0": params["mu_0"]}),
                                  "must be mu_0, A, B in that order"),
                                 # names read by position: another law's names are refused
                                 (dict(LAW, parameters={"x": params["mu_0"], "y": params["A"],
                                                        "z": params["B"]}),
                                  "not x, y, z"),
                                 (dict(LAW, parameters=dict(params, A={"value": "x"})),
                                  "fits.mu_power.parameters.A.value is not a finite number")):
                with open(fits, "w") as f:
                    json.dump({"fits": {"mu_power": law}}, f)
                err = io.StringIO()
                with contextlib.redirect_stderr(err):
                    self.assertEqual(main(["profile-decay", run, "--fits", fits]), 2)
                self.assertTrue(err.getvalue().startswith(f"error: {fits}: fits.mu_power"))
                self.assertIn(problem, err.getvalue())
            with open(fits, "w") as f:
                json.dump({"fits": {"mu_power": LAW}}, f)
            # A summary whose sigma_yy is not its case.toml's (not above 0): refused as another
            # run's; one whose tau is no number: a reason, no traceback.
            with open(summary_path) as f:
                good = json.load(f)
            with open(summary_path, "w") as f:
                json.dump(dict(good, case=dict(good["case"], normal_stress=-0.25)), f)
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                self.assertEqual(main(["profile-decay", run, "--fits", fits]), 2)
            self.assertIn("summary.json is of another run (normal_stress = -0.25", err.getvalue())
            with open(summary_path, "w") as f:
                json.dump(dict(good, profile_decay=dict(good["profile_decay"], tau="abc",
                                                        reason=None)), f)
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                self.assertEqual(main(["profile-decay", run, "--fits", fits]), 0)
            self.assertIn("no decay time tau", out.getvalue())
            # Values a damaged summary may hold: each run said why it is not used (or shown
            # without the value), never a traceback; a negative tau is not used.
            decay = good["profile_decay"]
            for changed, words in (
                    (dict(decay, tau=-5.0, reason=None), "no decay time tau > 0"),
                    (dict(decay, tau=1.0, tau_err=1e-320, reason=None), "beyond the range"),
                    (dict(decay, tau=1e308, tau_err=1.0, reason=None), "1e+308 +- 1.0"),
                    (dict(decay, fit_range="ab", shape_overlap=[1]), ""),
                    (dict(decay, fit_range=[None, 3], shape_overlap={"sin_2pi_eta": "x"}), "")):
                with open(summary_path, "w") as f:
                    json.dump(dict(good, profile_decay=changed), f)
                out = io.StringIO()
                with contextlib.redirect_stdout(out):
                    self.assertEqual(main(["profile-decay", run, "--fits", fits]), 0)
                self.assertIn(words, out.getvalue())
                self.assertNotRegex(out.getvalue(), "[0-9]{20}")   # no value printed in full
            with open(summary_path, "w") as f:
                json.dump(dict(good, height={"mean": 1e308, "err": 0.1}), f)
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                self.assertEqual(main(["profile-decay", run, "--fits", fits]), 0)
            self.assertIn("beyond the range T_SS can be taken from", out.getvalue())
            # an integer beyond any float (JSON holds one): read as missing, no OverflowError
            with open(summary_path, "w") as f:
                json.dump(dict(good, height={"mean": 10 ** 400, "err": 0.1}), f)
            with contextlib.redirect_stdout(io.StringIO()):
                self.assertEqual(main(["profile-decay", run, "--fits", fits]), 0)
            self.assertIsNone(relaxation.decay_entries(
                [dict(good, height={"mean": 10 ** 400}, run="r")], {"mu_power": LAW})[0]["L_y"])

    def test_the_json_table_holds_no_bare_nan_or_infinity(self):
        # A summary edited by hand may hold NaN or Infinity (Python's json reads them); the
        # table, as every --json output, writes null in their place: standard JSON.
        with tempfile.TemporaryDirectory() as d:
            run = os.path.join(d, "s1_seed1_V2")
            fits = analysed_run_and_law(self, d, run)
            table = os.path.join(d, "decay.json")
            summary_path = os.path.join(run, "summary.json")
            with open(summary_path) as f:
                good = json.load(f)
            decay = dict(good["profile_decay"], initial_velocity=float("inf"))
            with open(summary_path, "w") as f:
                json.dump(dict(good, regime=float("nan"), steady=float("-inf"),
                               profile_decay=decay), f)
            with contextlib.redirect_stdout(io.StringIO()):
                self.assertEqual(main(["profile-decay", run, "--fits", fits, "--json", table]),
                                 0)

            def refuse(constant):
                raise ValueError(f"bare {constant}")
            with open(table) as f:
                entry = json.load(f, parse_constant=refuse)["runs"][0]
            self.assertEqual((entry["regime"], entry["steady"], entry["initial_velocity"]),
                             (None, None, None))


if __name__ == "__main__":
    unittest.main()

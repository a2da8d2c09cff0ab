"""Regimes by positive criteria, window states, band layers and band switches, on synthetic runs
with known answers (synthetic.py) and on hand-made series."""
import os
import tempfile
import unittest

import numpy as np

from cdshear_analysis import analyze, format_report, load_run
from cdshear_analysis import regime as rg
from cdshear_analysis.synthetic import write_synthetic_run

V = 0.5                                    # synthetic runs' wall velocity
MASS = 511 * np.pi / 4 * (1 - 0.8 ** 3) / (3 * 0.2)   # synthetic grains' mass (rho = 1)
SIGMA, LX = 0.25, 20.0
SWITCH_TIMES = [500.25, 1000.25, 1500.25]  # between samples (every 0.5 t)
SETTLING_SWITCH_TIMES = [100.25, 300.25, 1200.25]
RUNS = {
    "A": dict(kind="A"), "B": dict(kind="B"), "C": dict(kind="C"), "noise": dict(kind="noise"),
    "transient": dict(kind="transient"), "rest": dict(kind="rest"),
    "wander": dict(kind="wander"), "C_fast": dict(kind="C_fast"),
    "intermittent": dict(kind="intermittent"),
    "short": dict(kind="B", duration=200.0),
    "C_com": dict(kind="C", block_column=False),
    # switches on window boundaries, 2 t ramps: every window sits on one plateau
    "C_aligned": dict(kind="C", switch_times=[480.0, 960.0, 1440.0], switch_duration=2.0),
    "C_forces": dict(kind="C", switch_times=SWITCH_TIMES, switch_forces=True),
    "C_held": dict(kind="C", switch_times=SWITCH_TIMES, pre_switch_delta_mu=0.04),
    # the block goes from one wall's velocity to the other's and back, slowly, while the run
    # settles (the steady-state test truncates it), then switches once in the averaged span
    "C_settling": dict(kind="C", switch_times=SETTLING_SWITCH_TIMES, switch_duration=100.0),
}


def synthetic_level(kind_args, t):
    """u / V of a SWITCHING synthetic run at times t, without its noise."""
    from cdshear_analysis.synthetic import _levels, _steps
    start, steps = _steps(kind_args["kind"], 2000.0, kind_args.get("switch_times"), 40.0, 400.0)
    return _levels(np.asarray(t, dtype=float), start, steps, kind_args.get("switch_duration", 20))


class Classifier(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.runs, cls.summaries = {}, {}
        for name, args in RUNS.items():
            run_dir = os.path.join(cls.tmp.name, name)
            write_synthetic_run(run_dir, **dict(dict(duration=2000.0, seed=3), **args))
            cls.runs[name] = load_run(run_dir)
            cls.summaries[name] = analyze(cls.runs[name])

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_each_kind_meets_its_regime_s_positive_criteria(self):
        for name, expected in (("A", "A"), ("transient", "A"), ("B", "B"), ("rest", "B"),
                               ("C", "C"), ("C_com", "C"), ("intermittent", "intermittent")):
            s = self.summaries[name]
            crit = s["regime_criteria"]
            self.assertEqual(s["regime"], expected, (name, crit["reason"]))
            self.assertTrue(crit["reason"].startswith(expected + ":"), crit["reason"])
            self.assertGreater(s["regime_confidence"], 0.85, name)
            if name != "intermittent":   # its block velocity holds few independent samples
                self.assertTrue(s["steady"], (name, s["steady_reason"]))
        # the reasons name the statistics and their thresholds
        self.assertIn("B windows 100% >= 70%", self.summaries["rest"]["regime_criteria"]["reason"])
        self.assertIn("|block_vx| <= 0.5 V in 100% of the samples >= 80%",
                      self.summaries["rest"]["regime_criteria"]["reason"])
        self.assertIn("x the mean switch duration",
                      self.summaries["C"]["regime_criteria"]["reason"])
        # the grains at rest with both walls sliding: every window has both layers carrying V
        table = self.summaries["rest"]["regime_criteria"]["windows"]
        np.testing.assert_allclose(table["velocity_jump_bottom"], V, atol=0.02)
        np.testing.assert_allclose(table["velocity_jump_top"], V, atol=0.02)

    def test_undecided_runs_say_why(self):
        for name, why in (("noise", "wanders between rest and the walls"),
                          ("wander", "wanders between rest and the walls"),
                          ("C_fast", "states switch faster than they can be told apart"),
                          ("short", "too short to tell, 1 averaged window < 3")):
            s = self.summaries[name]
            self.assertEqual(s["regime"], "undecided", (name, s["regime_criteria"]["reason"]))
            self.assertIn(why, s["regime_criteria"]["reason"], name)
            self.assertTrue(np.isnan(s["regime_confidence"]), name)    # no claim
        # the wandering block's reason gives its statistics against the thresholds
        reason = self.summaries["wander"]["regime_criteria"]["reason"]
        self.assertRegex(reason, r"\d+% of the samples in the gap 0.3 V < \|block_vx\| < 0.7 V "
                                 r"> 20%")
        self.assertRegex(reason, r"not B: B windows \d+% < 70%")
        fast = self.summaries["C_fast"]["regime_criteria"]
        self.assertLess(fast["mean_dwell"], rg.DWELL_RATIO * fast["mean_switch_duration"])
        self.assertGreater(fast["switch_count"], 40)           # a switch every 40 t
        report = format_report(self.summaries["wander"], "summary.json")
        self.assertIn("regime undecided: the block velocity wanders", report)

    def test_window_states_and_their_shares(self):
        s, args = self.summaries["C_aligned"], RUNS["C_aligned"]
        table = s["regime_criteria"]["windows"]
        self.assertEqual(table["index"], list(s["steady_window_indices"]))
        level = [synthetic_level(args, [0.5 * (t0 + t1)])[0]
                 for t0, t1 in zip(table["t_start"], table["t_end"])]
        self.assertEqual(table["state"], ["C+" if x > 0 else "C-" for x in level])
        # the block with the top wall (+V): the band at the bottom
        self.assertEqual(table["band_wall"], ["bottom" if x > 0 else "top" for x in level])
        shares = s["regime_criteria"]["state_shares"]
        self.assertAlmostEqual(shares["C+"] + shares["C-"], 1.0)
        self.assertAlmostEqual(shares["C+"], np.mean(np.array(level) > 0))
        # the intermittent run: B at rest, C+ and C- with a wall, undecided where it changes
        s, args = self.summaries["intermittent"], RUNS["intermittent"]
        table = s["regime_criteria"]["windows"]
        for t0, t1, state in zip(table["t_start"], table["t_end"], table["state"]):
            lv = synthetic_level(args, np.arange(t0 + 0.5, t1 + 0.25, 0.5))
            if np.ptp(lv) == 0:
                self.assertEqual(state, {0: "B", 1: "C+", -1: "C-"}[lv[0]], (t0, t1))
        shares = s["regime_criteria"]["state_shares"]
        self.assertAlmostEqual(sum(shares.values()), 1.0)
        self.assertGreater(shares["B"], 0.45)
        self.assertGreater(shares["C+"] + shares["C-"], 0.3)
        self.assertEqual(self.summaries["B"]["regime_criteria"]["state_shares"]["B"], 1.0)

    def test_block_velocity_from_block_vx_or_com_vx(self):
        self.assertEqual(self.summaries["C"]["regime_criteria"]["block_velocity_source"],
                         "block_vx")
        crit = self.summaries["C_com"]["regime_criteria"]
        self.assertEqual(crit["block_velocity_source"], "com_vx")
        self.assertIn("|com_vx| > 0.5 V", crit["reason"])
        # com_vx = 0.85 u: its plateaus sit at +-0.85 V, found from its samples
        self.assertEqual([sw["band"] for sw in self.summaries["C_com"]["switches"]],
                         ["bottom->top", "top->bottom", "bottom->top"])
        # and the B run read from com_vx finds no switch in its fluctuations
        run = dict(self.runs["B"], series={k: v for k, v in self.runs["B"]["series"].items()
                                           if k != "block_vx"})
        s = analyze(run)
        self.assertEqual((s["regime"], s["switches"]), ("B", []))
        self.assertEqual(s["regime_criteria"]["block_velocity_source"], "com_vx")

    def test_sheared_and_resting_layers_of_regime_c(self):
        s = self.summaries["C_aligned"]
        n_windows = len(s["steady_window_indices"])
        scale = np.sqrt(np.pi / 4 / SIGMA)
        for label, h in (("h5", 5.0), ("h10", 10.0)):
            reg = s["regions"][label]
            sheared, resting = reg["sheared_layer"], reg["resting_layer"]
            self.assertEqual((sheared["windows"], resting["windows"]), (n_windows, n_windows))
            # the sheared layer takes the jump 2V, the resting one none (bands of 3 < h)
            self.assertAlmostEqual(sheared["velocity_jump"]["mean"], 2 * V, delta=0.01)
            self.assertAlmostEqual(resting["velocity_jump"]["mean"], 0.0, delta=0.01)
            self.assertAlmostEqual(sheared["inertial_number"]["mean"], scale * 2 * V / h,
                                   delta=0.01 * scale * 2 * V / h)
            self.assertLess(sheared["velocity_jump"]["err"], 0.005)
            for q in ("mu_eff", "solid_fraction", "coordination"):
                self.assertAlmostEqual(sheared[q]["mean"], reg["bottom"][q]["mean"], delta=0.01)
                self.assertAlmostEqual(resting[q]["mean"], reg["top"][q]["mean"], delta=0.01)
            self.assertAlmostEqual(sheared["mu_eff"]["mean"], 0.30, delta=0.01)
            # the plain bottom layer mixes windows where it is sheared and where it rests
            share = s["regime_criteria"]["state_shares"]["C+"]
            self.assertAlmostEqual(reg["bottom"]["velocity_jump"]["mean"], share * 2 * V,
                                   delta=0.01)
        # outside regime C no window has a band: the layers are null
        reg = self.summaries["B"]["regions"]["h5"]
        self.assertEqual(reg["sheared_layer"]["windows"], 0)
        self.assertTrue(np.isnan(reg["sheared_layer"]["mu_eff"]["mean"]))

    def test_regime_c_statistics(self):
        s = self.summaries["C"]
        self.assertGreater(s["com_vx"]["bimodality_coefficient"], 5 / 9)
        self.assertLess(self.summaries["A"]["com_vx"]["bimodality_coefficient"], 5 / 9)
        self.assertEqual([sw["band"] for sw in s["switches"]],   # at duration/4, /2, 3/4
                         ["bottom->top", "top->bottom", "bottom->top"])
        hist = s["regime_criteria"]["block_velocity"]["histogram"]
        counts = np.asarray(hist["counts"])
        self.assertGreater(counts[:3].sum() + counts[-3:].sum(), 0.9 * counts.sum())
        for name in ("A", "B", "rest", "transient"):
            self.assertEqual(self.summaries[name]["switches"], [], name)

    def test_switch_durations_and_the_switch_time_they_measure(self):
        # The synthetic block goes from +V to -V in a linear ramp of 20 t, its acceleration
        # carried by the wall forces: delta_mu = mass 2 V / 20 over sigma_yy L_x during the ramp,
        # for which the T of model.md section 8 is the ramp itself. The fitted ramp is that
        # ramp, plateau to plateau.
        from cdshear_analysis.transitions import switch_time
        s = self.summaries["C_forces"]
        ramp_delta_mu = MASS * 2 * V / 20.0 / (SIGMA * LX)
        T = switch_time(V, s["height"]["mean"], MASS / (LX * s["height"]["mean"]),
                        ramp_delta_mu, SIGMA)
        self.assertAlmostEqual(T, 20.0, delta=0.5)
        self.assertEqual(len(s["switches"]), 3)
        for sw, ts in zip(s["switches"], SWITCH_TIMES):
            self.assertAlmostEqual(sw["duration"], 20.0, delta=1.0)
            self.assertAlmostEqual(sw["switch_time"], 20.0, delta=1.0)
            self.assertAlmostEqual(sw["start_time"], ts, delta=1.0)
            self.assertAlmostEqual(sw["end_time"], ts + 20.0, delta=1.0)
            # delta_mu before the switch: the block still on its plateau, not the ramp's force
            self.assertLess(abs(sw["delta_mu"]), 0.02 * ramp_delta_mu)
            self.assertLessEqual(sw["delta_mu_end_time"], sw["start_time"])
        self.assertAlmostEqual(s["switch_time"]["mean"], T, delta=1.0)
        self.assertAlmostEqual(s["switch_duration"]["mean"], T, delta=1.0)
        self.assertTrue(np.isnan(self.summaries["A"]["switch_delta_mu"]["mean"]))  # no switch
        # each wall's friction, the ratio of its time-averaged forces: 0.30 at the top; the
        # synthetic puts the switches' force on the bottom wall only, and over the averaging
        # span the three switches (+V to -V, back, and again) leave the net force of one
        span = 2000.0 - s["averaging_start_time"]
        self.assertAlmostEqual(s["mu_eff_wall_top"]["mean"], 0.30, delta=0.01)
        self.assertAlmostEqual(s["mu_eff_wall_bottom"]["mean"],
                               0.30 + ramp_delta_mu * 20.0 / span, delta=0.005)

    def test_delta_mu_is_taken_before_the_switch(self):
        # the synthetic holds a net force 0.04 times the normal force towards the new plateau
        # (alternating in sign) over the 100 t before each ramp, none during it: delta_mu is
        # 0.04 times the share of its stretch's samples there, positive each time
        s = self.summaries["C_held"]
        t = np.asarray(self.runs["C_held"]["series"]["time"])
        self.assertEqual(len(s["switches"]), 3)
        for sw, ts in zip(s["switches"], SWITCH_TIMES):
            t0, t1 = sw["delta_mu_start_time"], sw["delta_mu_end_time"]
            self.assertAlmostEqual(t1 - t0, rg.PRE_SWITCH_TIME)
            self.assertTrue(ts - 5.0 <= t1 <= sw["start_time"], (t1, ts))
            stretch = t[(t > t0) & (t <= t1)]
            held = np.mean((stretch >= ts - 100.0) & (stretch < ts))
            self.assertAlmostEqual(sw["delta_mu"], 0.04 * held, delta=0.001)
            self.assertGreater(sw["delta_mu"], 0.038)
        self.assertAlmostEqual(s["switch_delta_mu"]["mean"], 0.04, delta=0.002)

    def test_switches_are_counted_over_the_averaged_span_only(self):
        # The summary's switches, their statistics and the regime test's count are the same
        # switches: those that start in the averaged span, none from the transient before it.
        s, args = self.summaries["C_settling"], RUNS["C_settling"]
        series = self.runs["C_settling"]["series"]
        t0 = s["averaging_start_time"]
        found = rg.band_switches(series["time"], series["block_vx"], V)
        self.assertEqual(len(found), 3)
        # the first two switches start before the averaged span, the last one in it
        self.assertEqual([sw["start_time"] < t0 for sw in found], [True, True, False])
        self.assertEqual(s["regime"], "C", s["regime_criteria"]["reason"])
        self.assertEqual(s["regime_criteria"]["switch_count"], 1)
        self.assertEqual(len(s["switches"]), s["regime_criteria"]["switch_count"])
        (sw,) = s["switches"]
        self.assertGreaterEqual(sw["start_time"], t0)
        ts, ramp = args["switch_times"][-1], args["switch_duration"]
        self.assertAlmostEqual(sw["start_time"], ts, delta=5.0)
        self.assertAlmostEqual(s["switch_duration"]["mean"], ramp, delta=5.0)
        self.assertEqual(s["switch_duration"]["mean"], sw["duration"])
        # its delta_mu stretch still stops where the switch before it ended
        self.assertGreaterEqual(sw["delta_mu_start_time"], found[1]["end_time"])

    def test_transient_end_found_in_run(self):
        self.assertGreater(self.summaries["transient"]["transient_end_time"], 150.0)
        self.assertLess(self.summaries["transient"]["transient_end_time"], 700.0)


class RunningMean(unittest.TestCase):
    def test_a_width_beyond_the_series_averages_all_of_it(self):
        t = np.arange(0.0, 10.0, 0.5)
        u = np.sin(t)
        u[3] = np.nan                         # left out of every mean
        whole = np.nanmean(u)
        # a width of 5e-324 / 1e-300 overflows to infinity; NaN is no width at all
        for width in (1e3, 1.0 / 5e-300, np.inf, np.nan):
            np.testing.assert_allclose(rg.running_mean(t, u, width), whole, rtol=1e-12)
        # one sample each side: the mean of three neighbours
        self.assertAlmostEqual(rg.running_mean(t, u, 1.0)[10], np.mean(u[9:12]), places=12)


class Switches(unittest.TestCase):
    def test_durations_run_plateau_to_plateau(self):
        t = np.arange(0.0, 1000.0, 0.5)
        com = np.ones_like(t)
        ramps = ((200.25, 30.0, -1), (500.25, 10.0, 1), (800.25, 60.0, -1))
        for start, width, sign in ramps:
            ramp = np.clip((t - start) / width, 0, 1)
            com = np.where(t >= start, -sign * (1 - ramp) + sign * ramp, com)
        com[t == 100.0] = 0.0                 # excursions off the plateau and back: no switch
        com[t == 300.0] = -0.3
        com[(t > 600.0) & (t < 620.0)] = -0.7  # beyond -V/2 but short of the - plateau
        com[(t > 350.0) & (t < 380.0)] = 0.7
        switches = rg.band_switches(t, 0.5 * com, 0.5)
        self.assertEqual(len(switches), 3)
        for sw, (start, width, sign) in zip(switches, ramps):
            # the fitted ramp is the ramp, plateau to plateau
            self.assertAlmostEqual(sw["start_time"], start, delta=0.5)
            self.assertAlmostEqual(sw["end_time"], start + width, delta=0.5)
            self.assertAlmostEqual(sw["duration"], width, delta=0.5)
            self.assertAlmostEqual(sw["switch_time"], width, delta=0.5)
            self.assertEqual(sw["band"], "top->bottom" if sign > 0 else "bottom->top")
            self.assertEqual(sw["end_time"] - sw["start_time"], sw["duration"])

    def test_noisy_ramps_are_timed_without_bias(self):
        # The plateaus' scatter of system 1 at V = 0.02 (0.18 V, correlated over 5 t) on a
        # 50 t ramp: the first and last threshold crossings of the raw samples make a switch
        # 13% short on average; the fitted ramp's T agrees with 50 within its error.
        from scipy.signal import lfilter
        rng = np.random.default_rng(5)
        V, dt, T, r = 0.02, 0.1, 50.0, np.exp(-0.1 / 5.0)
        t = np.arange(0.0, 1500.0, dt)
        times = []
        for _ in range(40):
            noise = lfilter([np.sqrt(1 - r * r) * 0.18 * V], [1, -r], rng.normal(size=len(t)))
            switches = rg.band_switches(t, V * np.clip(1 - 2 * (t - 700) / T, -1, 1) + noise, V)
            self.assertEqual(len(switches), 1)
            times.append(switches[0]["switch_time"])
        self.assertLess(abs(np.mean(times) - T), 3 * np.std(times) / np.sqrt(len(times)))
        self.assertLess(abs(np.mean(times) - T), 0.05 * T)

    def test_a_touch_of_the_other_plateau_is_no_switch(self):
        # down to the - plateau and straight back (20 t each way): an excursion; down, 60 t
        # on the - plateau, and back: two switches
        t = np.arange(0.0, 1000.0, 0.5)
        touch = np.clip(np.abs(t - 500) / 10 - 1, -1, 1)
        self.assertEqual(rg.band_switches(t, touch, 1.0), [])
        stay = np.clip(np.maximum(480 - t, t - 540) / 10 - 1, -1, 1)
        switches = rg.band_switches(t, stay, 1.0)
        self.assertEqual([sw["band"] for sw in switches], ["bottom->top", "top->bottom"])
        for sw, start in zip(switches, (460.0, 540.0)):
            self.assertAlmostEqual(sw["start_time"], start, delta=0.5)
            self.assertAlmostEqual(sw["duration"], 20.0, delta=0.5)

    def test_a_switch_over_a_gap_in_the_samples_has_no_time(self):
        # any ramp inside the gap fits the samples: the switch is found, its time is NaN
        t = np.arange(0.0, 650.0, 0.1)
        u = np.clip(1 - 2 * (t - 300) / 50, -1, 1)
        u[(t > 280) & (t < 370)] = np.nan
        (sw,) = rg.band_switches(t, 0.02 * u, 0.02)
        self.assertTrue(np.isnan(sw["duration"]) and np.isnan(sw["switch_time"]))
        stats = rg.switch_statistics([sw], 0.0, 650.0)
        self.assertEqual(stats["count"], 1)
        self.assertTrue(np.isnan(stats["mean_duration"]))

    def test_a_slipping_block_s_plateaus_are_its_own(self):
        # block_vx at +-0.75 V (the block slips on the resting layer): its switches are found
        # between its own plateaus, and T is the time from +V to -V at the fitted rate
        t = np.arange(0.0, 1000.0, 0.5)
        u = 0.75 * np.clip((np.abs(t - 500) - 200) / 20, -1, 1)
        switches = rg.band_switches(t, u, 1.0)
        self.assertEqual(len(switches), 2)
        for sw in switches:
            self.assertAlmostEqual(sw["duration"], 40.0, delta=0.5)
            self.assertAlmostEqual(sw["switch_time"], 40.0 * 2 / 1.5, delta=0.5)

    def test_c_needs_the_block_at_a_wall_s_velocity(self):
        # every window C+, the block beyond V/2 throughout: C with the block at 0.95 V, not at
        # 0.6 V (the median of its samples within 0.7 V of 0: no plateau to switch from)
        rng = np.random.default_rng(2)
        table = dict(state=["C+"] * 5, t_start=list(range(0, 400, 80)),
                     t_end=list(range(80, 480, 80)), shear_rate_ratio=[0.0] * 5)
        for level, regime in ((0.95, "C"), (0.6, "undecided")):
            u = level + 0.02 * rng.normal(size=800)
            got, _, crit = rg.classify_run(table, u, [], 1.0, (0.0, 400.0))
            self.assertEqual(got, regime, crit["reason"])
        self.assertIn("no plateau on the + side", crit["reason"])

    def test_no_switch_without_both_plateaus(self):
        t = np.arange(100.0)
        self.assertEqual(rg.band_switches(t, np.full(100, 0.9), 1.0), [])
        self.assertEqual(rg.band_switches(t, np.sin(t) * 0.4, 1.0), [])
        # between the + plateau and -0.6 V (beyond -V/2, 0.4 V short of -V): no switch
        self.assertEqual(rg.band_switches(t, np.where(np.sin(t / 5) > 0, 1.0, -0.6), 1.0), [])

    def test_plateaus_are_measured(self):
        rng = np.random.default_rng(1)
        u = np.concatenate([0.85 + 0.02 * rng.normal(size=500), -0.85 + 0.02 * rng.normal(
            size=500)])
        p_plus, p_minus = rg.plateau_velocities(u, 1.0)
        self.assertAlmostEqual(p_plus, 0.85, delta=0.01)
        self.assertAlmostEqual(p_minus, -0.85, delta=0.01)
        # the tails of a velocity about 0 are no plateau
        self.assertTrue(np.isnan(rg.plateau_velocities(0.2 * rng.normal(size=5000), 1.0)).all())

    def test_bimodality_coefficient(self):
        rng = np.random.default_rng(0)
        self.assertAlmostEqual(rg.bimodality_coefficient(rng.normal(size=20000)), 1 / 3,
                               delta=0.02)
        self.assertGreater(rg.bimodality_coefficient(np.sign(rng.normal(size=2000))), 0.95)


if __name__ == "__main__":
    unittest.main()

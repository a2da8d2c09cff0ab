"""The window states and the run's decision of regime.py on hand-made profiles, tables and
samples: each criterion and each reason for undecided."""
import unittest

import numpy as np

from cdshear_analysis import regime as rg

V = 0.5


def profile(r=0.0, linearity=np.nan, block=0.0, jump_bottom=V, jump_top=V):
    return dict(shear_rate_ratio=r, linearity=linearity, block_velocity=block,
                velocity_jump_bottom=jump_bottom, velocity_jump_top=jump_top)


def shares(rest=1.0, plus=0.0, minus=0.0):
    return dict(rest=rest, plus=plus, minus=minus, gap=0.0)


def table(states, window=80.0, r=0.0):
    n = len(states)
    return dict(state=list(states), t_start=[window * k for k in range(n)],
                t_end=[window * (k + 1) for k in range(n)], shear_rate_ratio=[r] * n)


class WindowStates(unittest.TestCase):
    def test_each_state_from_its_profile_and_samples(self):
        cases = [
            (profile(r=0.8, linearity=0.99), shares(), "A", "r = 0.8 > 0.2, R^2 = 0.99 >= 0.8"),
            (profile(), shares(rest=0.9), "B", "|u| <= 0.5 V in 90% of the samples"),
            (profile(block=V, jump_bottom=2 * V, jump_top=0.0), shares(rest=0.05, plus=0.95),
             "C+", "u > 0.5 V in 95% of the samples"),
            (profile(block=-V, jump_bottom=0.1 * V, jump_top=1.9 * V), shares(0.1, 0, 0.9),
             "C-", "jumps 0.10 V (bottom), 1.90 V (top)"),
        ]
        for p, s, state, text in cases:
            got, reason = rg.window_state(p, s, V)
            self.assertEqual(got, state, reason)
            self.assertIn(text, reason)
        self.assertEqual(rg.BAND_WALL, {"C+": "bottom", "C-": "top"})

    def test_undecided_windows(self):
        cases = [
            (profile(r=0.8, linearity=0.3), shares(), "the bulk profile is not linear"),
            (profile(r=0.15), shares(), "r = 0.15 between 0.1 and 0.2"),
            (profile(r=-0.5), shares(), "r = -0.5 < -0.1: the bulk is sheared against"),
            (profile(jump_bottom=1.3 * V, jump_top=0.2 * V), shares(),
             "neither both layers about V (B) nor one about 2V and the other about 0 (C)"),
            (profile(), shares(rest=0.3, plus=0.35, minus=0.35),
             "|u| <= 0.5 V in only 30% of the samples < 80% (the block changes state)"),
            (profile(block=V, jump_bottom=2 * V, jump_top=0.0), shares(rest=0.5, plus=0.5),
             "u > 0.5 V in only 50% of the samples"),
            (profile(r=np.nan), shares(), "no bulk profile"),
        ]
        for p, s, text in cases:
            state, reason = rg.window_state(p, s, V)
            self.assertEqual(state, "undecided", reason)
            self.assertIn(text, reason)

    def test_window_profile_statistics(self):
        y = np.arange(20) + 0.5
        vx = np.where(y < 3, -V + 2 * V * y / 3, V)   # the block with the top wall, band of 3
        p = rg.window_profile(y, vx, 5.0, 15.0, 20.0, V)
        self.assertAlmostEqual(p["block_velocity"], V)
        self.assertAlmostEqual(p["shear_rate_ratio"], 0.0)
        self.assertAlmostEqual(p["velocity_jump_bottom"], 2 * V)
        self.assertAlmostEqual(p["velocity_jump_top"], 0.0)
        p = rg.window_profile(y, -V + 2 * V * y / 20, 5.0, 15.0, 20.0, V)   # uniform shear
        self.assertAlmostEqual(p["shear_rate_ratio"], 1.0)
        self.assertAlmostEqual(p["linearity"], 1.0)


class RunDecision(unittest.TestCase):
    def setUp(self):
        self.rng = np.random.default_rng(2)

    def rest_samples(self, n=4000, std=0.1):
        return std * V * self.rng.normal(size=n)

    def test_too_short(self):
        regime, confidence, crit = rg.classify_run(table(["B", "B"]), self.rest_samples(), [],
                                                   V, (0.0, 160.0))
        self.assertEqual(regime, "undecided")
        self.assertTrue(np.isnan(confidence))
        self.assertIn("too short to tell, 2 averaged windows < 3", crit["reason"])

    def test_confidence_is_the_share_of_agreeing_windows(self):
        regime, confidence, crit = rg.classify_run(table(["A"] * 8 + ["undecided"] * 2, r=0.8),
                                                   self.rest_samples(), [], V, (0.0, 800.0))
        self.assertEqual(regime, "A")
        self.assertAlmostEqual(confidence, 0.8)
        self.assertEqual(crit["state_shares"], {"A": 0.8, "B": 0.0, "C+": 0.0, "C-": 0.0,
                                                "undecided": 0.2})
        self.assertIn("A windows 80% >= 70%", crit["reason"])
        regime, _, crit = rg.classify_run(table(["A"] * 6 + ["undecided"] * 4, r=0.8),
                                          self.rest_samples(), [], V, (0.0, 800.0))
        self.assertEqual(regime, "undecided")
        self.assertIn("not A: A windows 60% < 70%", crit["reason"])

    def test_no_finite_block_velocity_is_said(self):
        regime, _, crit = rg.classify_run(table(["undecided"] * 5), np.full(100, np.nan), [], V,
                                          (0.0, 400.0))
        self.assertEqual(regime, "undecided")
        self.assertIn("no finite sample of block_vx", crit["reason"])
        self.assertNotIn("wanders", crit["reason"])

    def test_b_needs_one_peak_about_zero(self):
        # B windows throughout, but a tenth of the samples with a wall: two peaks
        u = np.concatenate([self.rest_samples(3600), V + 0.02 * V * self.rng.normal(size=400)])
        regime, _, crit = rg.classify_run(table(["B"] * 10), u, [], V, (0.0, 800.0))
        self.assertEqual(regime, "undecided", crit["reason"])
        self.assertIn("not one peak about 0", crit["reason"])
        regime, _, _ = rg.classify_run(table(["B"] * 10), self.rest_samples(), [], V,
                                       (0.0, 800.0))
        self.assertEqual(regime, "B")

    def test_c_needs_dwell_times_longer_than_switches(self):
        u = np.where(self.rng.random(4000) < 0.5, V, -V)
        fast = [dict(start_time=50.0 * k, duration=20.0) for k in range(1, 16)]
        regime, _, crit = rg.classify_run(table(["C+", "C-"] * 5), u, fast, V, (0.0, 800.0))
        self.assertEqual(regime, "undecided")
        self.assertIn("states switch faster than they can be told apart: mean time on a "
                      "plateau 31.2 t < 5 x the mean switch duration 20 t (15 switches)",
                      crit["reason"])
        self.assertIn("not C: its switches (above)", crit["reason"])
        slow = fast[:1]
        regime, confidence, crit = rg.classify_run(table(["C+", "C-"] * 5), u, slow, V,
                                                   (0.0, 800.0))
        self.assertEqual((regime, confidence), ("C", 1.0))
        self.assertEqual((crit["switch_count"], crit["mean_dwell"]), (1, 390.0))

    def test_intermittent_and_wandering(self):
        u = np.concatenate([self.rest_samples(2000), V + 0.02 * V * self.rng.normal(size=2000)])
        states = ["B"] * 5 + ["C+"] * 4 + ["undecided"]
        regime, confidence, crit = rg.classify_run(table(states), u, [], V, (0.0, 800.0))
        self.assertEqual(regime, "intermittent", crit["reason"])
        self.assertAlmostEqual(confidence, 0.9)
        self.assertIn("B and C each over >= 20% of the time", crit["reason"])
        # the same windows with a block velocity spread between rest and the wall
        u = 0.5 * V * self.rng.normal(size=4000)
        regime, _, crit = rg.classify_run(table(states), u, [], V, (0.0, 800.0))
        self.assertEqual(regime, "undecided")
        self.assertIn("the block velocity wanders between rest and the walls", crit["reason"])
        self.assertIn("not intermittent: B and C present but the states are not told apart",
                      crit["reason"])

    def test_report_line(self):
        regime, confidence, crit = rg.classify_run(table(["C+", "C-"] * 5), np.full(100, V), [],
                                                   V, (0.0, 800.0), source="com_vx")
        line = rg.report_line(regime, confidence, crit, 0)
        self.assertTrue(line.startswith("regime C (100% of the window time agrees): A 0%, B 0%,"
                                        " C+ 50%, C- 50%, undecided 0% of 10 windows"), line)
        self.assertIn("|com_vx| > V/2 in 100% of samples, 0 band switch(es)", line)


if __name__ == "__main__":
    unittest.main()

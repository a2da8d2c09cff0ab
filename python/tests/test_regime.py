"""Regime classifier, com_vx statistics and band switches, on synthetic runs and series."""
import os
import tempfile
import unittest

import numpy as np

from cdshear_analysis import analyze, load_run
from cdshear_analysis.regime import band_switches, bimodality_coefficient, classify_run
from cdshear_analysis.synthetic import write_synthetic_run


class Classifier(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.summaries = {}
        for kind in ("A", "B", "C", "noise", "transient"):
            run_dir = os.path.join(cls.tmp.name, kind)
            write_synthetic_run(run_dir, kind=kind, duration=2000.0, seed=3)
            cls.summaries[kind] = analyze(load_run(run_dir))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_each_kind_gets_its_regime(self):
        for kind, expected in (("A", "A"), ("B", "B"), ("C", "C"), ("transient", "A")):
            s = self.summaries[kind]
            self.assertEqual(s["regime"], expected, (kind, s["regime_criteria"]))
            self.assertGreater(s["regime_confidence"], 0.8, kind)
            self.assertTrue(s["steady"], (kind, s["steady_reason"]))

    def test_noise_is_not_a_confident_regime(self):
        s = self.summaries["noise"]
        self.assertNotEqual(s["regime"], "C")
        self.assertLess(s["regime_confidence"], self.summaries["B"]["regime_confidence"])
        self.assertLess(s["regime_confidence"], 0.9)

    def test_regime_c_statistics(self):
        s = self.summaries["C"]
        self.assertGreater(s["com_vx"]["bimodality_coefficient"], 5 / 9)
        self.assertLess(self.summaries["A"]["com_vx"]["bimodality_coefficient"], 5 / 9)
        self.assertEqual(len(s["switches"]), 3)   # default: switches at duration/4, /2, 3/4
        self.assertEqual([sw["band"] for sw in s["switches"]],
                         ["bottom->top", "top->bottom", "bottom->top"])
        counts = np.asarray(s["com_vx"]["histogram"]["counts"])
        self.assertGreater(counts[:3].sum() + counts[-3:].sum(), 0.9 * counts.sum())
        self.assertEqual(self.summaries["A"]["switches"], [])

    def test_switch_friction_difference_and_predicted_switch_time(self):
        # The synthetic block (mass n <area>, rho = 1) goes from +V to -V in a linear ramp of
        # 20 t, its acceleration carried by the wall forces: delta_mu = mass 2 V / 20 over
        # sigma_yy L_x. The switch detected between +-0.5 V lasts half the ramp, which is what
        # SPEC 8's T times 0.5 predicts from that delta_mu.
        from cdshear_analysis.transitions import COM_LEVEL, switch_time
        run_dir = os.path.join(self.tmp.name, "C_forces")
        write_synthetic_run(run_dir, kind="C", duration=2000.0, seed=3, switch_forces=True)
        s = analyze(load_run(run_dir))
        self.assertEqual(len(s["switches"]), 3)
        mass = 511 * np.pi / 4 * (1 - 0.8 ** 3) / (3 * 0.2)
        expected = mass * 2 * 0.5 / 20.0 / (0.25 * 20.0)
        for sw in s["switches"]:
            self.assertAlmostEqual(sw["delta_mu"], expected, delta=0.05 * expected)
        self.assertAlmostEqual(s["switch_delta_mu"]["mean"], expected, delta=0.05 * expected)
        # each wall's friction, the ratio of its time-averaged forces: 0.30 at the top; the
        # synthetic puts the switches' force on the bottom wall only, and over the averaging
        # span the three switches (+V to -V, back, and again) leave the net force of one, a
        # delta_mu over 20 t: 0.30 + expected 20 / span
        span = 2000.0 - s["averaging_start_time"]
        self.assertAlmostEqual(s["mu_eff_wall_top"]["mean"], 0.30, delta=0.01)
        self.assertAlmostEqual(s["mu_eff_wall_bottom"]["mean"], 0.30 + expected * 20.0 / span,
                               delta=0.005)
        self.assertTrue(np.isnan(self.summaries["A"]["switch_delta_mu"]["mean"]))  # no switch
        # without the forces of the block, the same switches need no friction difference
        self.assertLess(self.summaries["C"]["switch_delta_mu"]["mean"], 0.05 * expected)
        T = switch_time(0.5, s["height"]["mean"], mass / (20.0 * s["height"]["mean"]),
                        s["switch_delta_mu"]["mean"], 0.25)
        self.assertAlmostEqual(COM_LEVEL * T, s["switch_duration"]["mean"], delta=1.5)

    def test_transient_end_found_in_run(self):
        self.assertGreater(self.summaries["transient"]["transient_end_time"], 150.0)
        self.assertLess(self.summaries["transient"]["transient_end_time"], 700.0)

    def test_confidence_from_margin_and_windows(self):
        regime, conf, crit = classify_run(0.31, 0.0, [0.5, 0.1], [0.0, 0.0])
        self.assertEqual(regime, "A")
        self.assertAlmostEqual(crit["window_agreement"], 0.5)
        self.assertAlmostEqual(conf, 0.5 * 0.01 / 0.3 + 0.25)
        self.assertEqual(crit["reason"], "A: r = 0.31 > 0.3")
        self.assertEqual(classify_run(0.1, 0.9, [], [])[2]["reason"],
                         "C: r = 0.1 <= 0.3 and f = 0.9 > 0.6")
        self.assertEqual(self.summaries["B"]["regime_criteria"]["reason"][:2], "B:")


class Switches(unittest.TestCase):
    def test_counts_durations_and_directions(self):
        t = np.arange(0.0, 1000.0, 0.5)
        com = np.ones_like(t)
        for start, end, sign in ((200.0, 230.0, -1), (500.0, 510.0, 1), (800.0, 860.0, -1)):
            ramp = np.clip((t - start) / (end - start), 0, 1)
            com = np.where(t >= start, -sign * (1 - ramp) + sign * ramp, com)
        com[t == 100.0] = 0.0                 # an excursion into the middle band: no switch
        com[t == 300.0] = -0.3
        switches = band_switches(t, 0.5 * com, 0.5)
        self.assertEqual(len(switches), 3)
        # state +-1 beyond |com| > V/2: the ramp crosses the middle band in its middle half
        for sw, (width, band) in zip(switches, ((30, "bottom->top"), (10, "top->bottom"),
                                                (60, "bottom->top"))):
            self.assertAlmostEqual(sw["duration"], 0.5 * width, delta=1.0)
            self.assertEqual(sw["band"], band)
            self.assertEqual(sw["end_time"] - sw["start_time"], sw["duration"])

    def test_no_switch_without_both_states(self):
        t = np.arange(100.0)
        self.assertEqual(band_switches(t, np.full(100, 0.9), 1.0), [])
        self.assertEqual(band_switches(t, np.sin(t) * 0.4, 1.0), [])

    def test_bimodality_coefficient(self):
        rng = np.random.default_rng(0)
        self.assertAlmostEqual(bimodality_coefficient(rng.normal(size=20000)), 1 / 3, delta=0.02)
        self.assertGreater(bimodality_coefficient(np.sign(rng.normal(size=2000))), 0.95)


if __name__ == "__main__":
    unittest.main()

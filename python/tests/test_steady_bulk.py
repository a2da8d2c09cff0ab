"""The bulk at the h = 10 of docs/model.md section 7 (or why not) and the steady-state checks on
the flow itself."""
import os
import tempfile
import unittest

import numpy as np

from cdshear_analysis.rundata import load_run
from cdshear_analysis.steady_state import STEADY_MAX_IMBALANCE, detect_steady_state
from cdshear_analysis.summary import REFERENCE_H, analyze, choose_bulk_range
from cdshear_analysis.synthetic import write_synthetic_run


class BulkThickness(unittest.TestCase):
    def run_with(self, height, thicknesses):
        with tempfile.TemporaryDirectory() as d:
            write_synthetic_run(d, kind="A", duration=400.0, height=height,
                                boundary_thickness=thicknesses)
            run = load_run(d)
            return run, analyze(run)

    def test_the_reference_h_is_taken_where_the_cell_allows_it(self):
        # A 40-d cell measured at h = 3 and 10: the bulk is the reference one (h = 10), not the
        # thinnest h's, which would include the faster-sheared layers near the walls.
        run, summary = self.run_with(40.0, (3.0, 10.0))
        self.assertEqual(choose_bulk_range(run)[0], REFERENCE_H)
        self.assertEqual(summary["bulk"]["h"], REFERENCE_H)
        self.assertTrue(summary["bulk"]["h_reference"])
        self.assertIsNone(summary["bulk"]["h_note"])

    def test_a_thin_cell_says_its_bulk_is_not_the_reference_one(self):
        # L_y = 20 measured at 3, 5, 7: h = 10 leaves no bulk; the h closest to it (7), flagged.
        run, summary = self.run_with(20.0, (3.0, 5.0, 7.0))
        self.assertEqual(summary["bulk"]["h"], 7.0)
        self.assertFalse(summary["bulk"]["h_reference"])
        self.assertIn("too thin for h = 10", summary["bulk"]["h_note"])

    def test_an_unmeasured_reference_h_is_named(self):
        run, summary = self.run_with(40.0, (3.0, 5.0))
        self.assertEqual(summary["bulk"]["h"], 5.0)
        self.assertIn("h = 10 was not measured", summary["bulk"]["h_note"])


def steady_synthetic_run():
    """A loaded steady synthetic run (regime A, 2000 t) whose windows' stress and wall forces are
    copies a test may change."""
    with tempfile.TemporaryDirectory() as d:
        write_synthetic_run(d, kind="A", duration=2000.0)
        run = load_run(d)
    for key in ("stress", "bottom_force", "top_force"):
        run["windows"][key] = run["windows"][key].copy()
    return run


class StressBalance(unittest.TestCase):
    """A steady run's interior friction equals the walls' (momentum balance)."""

    def verdict(self, offset, seed=3):
        rng = np.random.default_rng(seed)
        time = np.arange(0.0, 2000.0, 0.5)
        series = {"mu_wall": 0.3 + 0.01 * rng.standard_normal(len(time)),
                  "height": 20 + 0.05 * rng.standard_normal(len(time))}
        starts = np.arange(0.0, 2000.0, 80.0)[:-1]
        bulk_mu = 0.3 + offset + 0.004 * rng.standard_normal(len(starts))
        balance = bulk_mu - (0.3 + 0.004 * rng.standard_normal(len(starts)))
        return detect_steady_state(time, series, starts, {"bulk_mu_eff": bulk_mu},
                                   balance=lambda windows: balance[windows])

    def assert_not_balanced(self, run, excess, delta):
        """The analysis of `run` is not steady for its stress, and measures `excess` in mu_eff."""
        summary = analyze(run)
        self.assertFalse(summary["steady"])
        self.assertIn("stress not uniform", summary["steady_reason"])
        self.assertAlmostEqual(summary["stress_balance"]["mean"], excess, delta=delta)

    def test_balanced_stress_is_steady(self):
        st = self.verdict(0.0)
        self.assertTrue(st["steady"], st["reason"])
        self.assertLess(st["stress_balance"]["sigmas"], STEADY_MAX_IMBALANCE)

    def test_interior_friction_above_the_walls_is_not_steady(self):
        # As in a tall cell whose momentum still diffuses: the bulk at 0.286, the walls at 0.263
        # (a run that the other signals alone called steady).
        st = self.verdict(0.023)
        self.assertFalse(st["steady"])
        self.assertIn("stress not uniform", st["reason"])
        self.assertAlmostEqual(st["stress_balance"]["mean"], 0.023, delta=0.004)
        # Without a balance to check, none is claimed.
        rng = np.random.default_rng(1)
        unchecked = detect_steady_state(np.arange(0.0, 2000.0, 0.5),
                                        {"height": 20 + 0.05 * rng.standard_normal(4000)},
                                        np.arange(0.0, 1920.0, 80.0), {})
        self.assertTrue(np.isnan(unchecked["stress_balance"]["mean"]))

    def test_analyze_flags_an_interior_friction_above_the_walls(self):
        # The interior's shear stress 8% above what the walls carry (as in a tall cell whose
        # momentum still spreads: system 5 at V = 1, 0.286 inside against 0.263 at the walls).
        run = steady_synthetic_run()
        self.assertTrue(analyze(run)["steady"])
        run["windows"]["stress"][..., 0, 1] *= 1.08
        self.assert_not_balanced(run, 0.08 * 0.30, delta=0.006)

    def test_the_balance_pairs_each_window_with_its_own_walls(self):
        # The shear stress inside and at the walls swinging together by 10% from window to
        # window (the momentum balance ties them), the interior 3% above the walls: 0.009 in
        # mu_eff, under a single error of separate means (0.007) but many of the paired one.
        run = steady_synthetic_run()
        w = run["windows"]
        swing = 1.0 + 0.1 * np.random.default_rng(5).standard_normal(len(w["t_start"]))
        w["stress"][..., 0, 1] *= swing[:, None]
        for side in ("bottom_force", "top_force"):
            w[side][:, 0] *= swing
        balanced = analyze(run)
        self.assertTrue(balanced["steady"], balanced["steady_reason"])
        self.assertLess(balanced["stress_balance"]["err"], 0.002)
        w["stress"][..., 0, 1] *= 1.03
        self.assert_not_balanced(run, 0.03 * 0.30, delta=0.002)

    def test_windows_without_the_walls_forces_do_not_count_toward_the_balance(self):
        # the interior 3% above the walls, but a wall normal force in the first two windows
        # only (in the transient): no steady window to judge it by, and the reason says so;
        # without the wall-force datasets it is not checked either
        run = steady_synthetic_run()
        w = run["windows"]
        w["stress"][..., 0, 1] *= 1.03
        self.assertIn("stress not uniform", analyze(run)["steady_reason"])
        for side in ("bottom_force", "top_force"):
            w[side][2:, 1] = 0.0
        summary = analyze(run)
        self.assertTrue(summary["steady"], summary["steady_reason"])
        self.assertTrue(np.isnan(summary["stress_balance"]["mean"]))
        self.assertIn("stress balance not checked (fewer than 3 steady windows with a bulk "
                      "mu_eff and a wall normal force)", summary["steady_reason"])
        del w["bottom_force"]
        summary = analyze(run)
        self.assertTrue(summary["steady"], summary["steady_reason"])
        self.assertTrue(np.isnan(summary["stress_balance"]["mean"]))

    def test_analyze_checks_the_walls_against_the_interior(self):
        balance = analyze(steady_synthetic_run())["stress_balance"]
        self.assertTrue(np.isfinite(balance["mean"]))
        self.assertLess(balance["sigmas"], STEADY_MAX_IMBALANCE)



class ProfileReach(unittest.TestCase):
    def test_a_cell_taller_than_its_stripes_is_flagged(self):
        with tempfile.TemporaryDirectory() as d:
            write_synthetic_run(d, kind="A", duration=400.0)
            run = load_run(d)
            self.assertEqual(analyze(run)["warnings"], [])
            run["windows"]["height"] = run["windows"]["height"] + 10.0   # above 25 stripes
            (text,) = analyze(run)["warnings"]
            self.assertIn("measure.stripe_span", text)


class StressBalanceTable(unittest.TestCase):
    """stress_balance.py: the interior stress against the walls' over the steady windows."""

    @staticmethod
    def steady_run():
        """A loaded 2000-t synthetic regime-A run, its summary, and its folder's name."""
        with tempfile.TemporaryDirectory() as d:
            write_synthetic_run(d, kind="A", duration=2000.0)
            run = load_run(d)
        return run, analyze(run), d

    def test_a_balanced_run_agrees_and_an_offset_is_measured(self):
        from cdshear_analysis.stress_balance import format_line, stress_balance
        run, summary, d = self.steady_run()
        b = stress_balance(run, summary)
        for name in ("sigma_yy_diff", "sigma_xy_diff", "mu_eff_diff"):
            mean, err = b[name]
            self.assertLess(abs(mean), 4 * err + 1e-12, name)
        # 0.02 more normal stress inside than the walls carry, over the same windows: measured.
        run["windows"]["stress"] = run["windows"]["stress"].copy()
        run["windows"]["stress"][..., 1, 1] += 0.02
        shifted = stress_balance(run, summary)
        self.assertAlmostEqual(shifted["sigma_yy_diff"][0] - b["sigma_yy_diff"][0], 0.02,
                               places=9)
        self.assertIn("sigma_yy", format_line(d, shifted))
        self.assertNotIn("no error estimate", format_line(d, shifted))
        # One window gives no error: the means alone, said so, never "+-nan"; a run that has
        # not reached its duration is named.
        one = stress_balance(run, dict(summary, steady_window_indices=summary[
            "steady_window_indices"][:1], case=dict(summary["case"], finished=False, time=30.0)))
        self.assertEqual(one["windows"], 1)
        line = format_line(d, one)
        self.assertNotIn("nan", line)
        self.assertIn("1 windows (one window: no error estimate) (NOT finished: t = 30 of "
                      f"{summary['case']['duration']:g})", line)

    def test_a_window_without_a_measured_interior_is_not_counted(self):
        from cdshear_analysis.stress_balance import stress_balance
        run, summary, _ = self.steady_run()
        whole = stress_balance(run, summary)
        # the bulk's stripes of one steady window emptied (NaN, as an empty stripe is written)
        first = int(summary["steady_window_indices"][0])
        lo, hi = summary["bulk"]["y_range"]
        y = np.asarray(run["windows"]["y"], dtype=float)
        for name in ("stress", "kinetic_stress", "rotational_stress"):
            run["windows"][name] = np.array(run["windows"][name], dtype=float)
            run["windows"][name][first, (y >= lo) & (y <= hi)] = np.nan
        emptied = stress_balance(run, summary)
        self.assertEqual(emptied["windows"], whole["windows"] - 1)
        # the walls' side is averaged over the same windows as the interior
        rest = dict(summary, steady_window_indices=summary["steady_window_indices"][1:])
        for name, pair in stress_balance(run, rest).items():
            if isinstance(pair, tuple):
                self.assertEqual(emptied[name][0], pair[0], name)


class OlderRunFiles(unittest.TestCase):
    """Files of earlier format versions are read as the current version describes them."""

    def rewrite(self, d, version, change):
        import h5py
        from cdshear_analysis.rundata import seal
        path = os.path.join(d, "run.h5")
        with h5py.File(path, "r+") as f:
            f.attrs["format_version"] = version
            change(f)
        seal(path)

    def test_version_2_stress_loses_the_rotational_flux_again(self):
        with tempfile.TemporaryDirectory() as d:
            write_synthetic_run(d, kind="A", duration=400.0)
            current = load_run(d)

            def add_flux(f):
                rot = np.where(np.isfinite(f["windows/stress"][()]), 0.0, np.nan)
                rot[..., 1, 1] = np.where(np.isfinite(rot[..., 1, 1]), 0.01, np.nan)
                f["windows/rotational_stress"][...] = rot
                f["windows/stress"][...] = f["windows/stress"][()] + rot
            self.rewrite(d, 2, add_flux)
            old = load_run(d)
        np.testing.assert_allclose(old["windows"]["stress"], current["windows"]["stress"],
                                   atol=1e-15, equal_nan=True)
        s = current["windows"]["stress"]
        with np.errstate(invalid="ignore", divide="ignore"):
            mu = np.abs(s[..., 0, 1]) / s[..., 1, 1]
        np.testing.assert_allclose(old["windows"]["mu_eff"], mu, rtol=1e-12, equal_nan=True)
        self.assertIn("rotational flux", old["attrs"]["legacy_note"])

    def test_version_1_coordination_is_the_force_carrying_count(self):
        with tempfile.TemporaryDirectory() as d:
            write_synthetic_run(d, kind="A", duration=400.0)
            current = load_run(d)

            def as_v1(f):
                del f["windows/force_carrying_coordination"]
            self.rewrite(d, 1, as_v1)
            old = load_run(d)
            self.assertTrue(np.isnan(old["windows"]["coordination"]).all())
            np.testing.assert_array_equal(old["windows"]["force_carrying_coordination"],
                                          current["windows"]["coordination"])
            self.assertIn("format version 1", old["attrs"]["legacy_note"])
            self.rewrite(d, 5, lambda f: None)
            with self.assertRaisesRegex(Exception, "newer than this analysis"):
                load_run(d)

    def test_version_3_keeps_its_top_layer_and_says_so(self):
        with tempfile.TemporaryDirectory() as d:
            write_synthetic_run(d, kind="A", duration=400.0)
            current = load_run(d)
            self.assertIsNotNone(current["top_stripes"])
            self.assertNotIn("legacy_note", current["attrs"])

            def as_v3(f):
                del f["windows/top_stripes"]
            self.rewrite(d, 3, as_v3)
            old = load_run(d)
        self.assertIsNone(old["top_stripes"])
        self.assertIn("top boundary layer", old["attrs"]["legacy_note"])
        np.testing.assert_array_equal(old["regions"]["h5"]["top_solid_fraction"],
                                      current["regions"]["h5"]["top_solid_fraction"])


if __name__ == "__main__":
    unittest.main()

"""Block averaging and steady-state detection on synthetic series."""
import unittest

import numpy as np

from cdshear_analysis.profiles import regions_for_h
from cdshear_analysis.statistics import (block_average, ratio_of_means, weighted_mean,
                                         window_mean)
from cdshear_analysis.summary import wall_force_ratio
from cdshear_analysis.steady_state import detect_steady_state, mser_truncation
from cdshear_analysis.synthetic import ar1


def ar1_standard_error(n, phi, std):
    """Exact standard error of the mean of n stationary AR(1) samples."""
    s = (1 + phi) / (1 - phi) - 2 * phi * (1 - phi ** n) / (n * (1 - phi) ** 2)
    return std * np.sqrt(s / n)


class BlockAveraging(unittest.TestCase):
    def test_ar1_error_matches_known_standard_error(self):
        for seed, phi in ((1, 0.9), (2, 0.95), (3, 0.5), (4, 0.0)):
            x = 3.0 + ar1(2 ** 15, phi, 2.0, np.random.default_rng(seed))
            b = block_average(x)
            expected = ar1_standard_error(len(x), phi, 2.0)
            self.assertTrue(b["converged"], (phi, b))
            self.assertLess(abs(b["err"] / expected - 1), 0.3, (phi, b["err"], expected))
            self.assertLess(abs(b["n_independent"] / (2.0 / expected) ** 2 - 1), 0.6)

    def test_ratio_of_means_error_matches_the_scatter_of_realizations(self):
        # r = <mu F + noise> / <F>, F and the noise correlated in time: the delta-method error of
        # each realization against the scatter of r over independent realizations
        rng = np.random.default_rng(7)
        ratios, errors = [], []
        for _ in range(200):
            den = 5.0 * (1 + ar1(2 ** 12, 0.8, 0.3, rng))
            num = 0.25 * den + ar1(2 ** 12, 0.9, 0.4, rng)
            r = ratio_of_means(num, den)
            ratios.append(r["mean"])
            errors.append(r["err"])
        self.assertLess(abs(np.mean(ratios) - 0.25), 3 * np.std(ratios) / np.sqrt(200))
        self.assertLess(abs(np.median(errors) / np.std(ratios) - 1), 0.25)
        # a constant denominator: the error is the numerator's over it
        num = ar1(2 ** 12, 0.9, 1.0, rng)
        r = ratio_of_means(num, np.full_like(num, 4.0))
        self.assertAlmostEqual(r["mean"], num.mean() / 4.0, places=14)
        self.assertAlmostEqual(r["err"], block_average(num)["err"] / 4.0, places=14)
        self.assertTrue(np.isnan(ratio_of_means([1.0], [0.0])["mean"]))

    def test_wall_friction_is_the_ratio_of_time_averaged_forces(self):
        # model.md section 7: |<f_x>| / |<f_y>|, not <|f_x| / |f_y|>: a normal force alternating
        # 10 and 30 under a constant tangential 3 gives 3 / 20 = 0.15 (the mean of the ratios is
        # 0.2)
        fy = np.tile([10.0, 30.0], 500)
        series = {"bottom_fx": np.full_like(fy, 3.0), "bottom_fy": -fy,
                  "top_fx": np.full_like(fy, -1.5), "top_fy": fy}
        keep = np.ones_like(fy, dtype=bool)
        self.assertAlmostEqual(wall_force_ratio(series, ("bottom",), keep)["mean"], 0.15)
        self.assertAlmostEqual(wall_force_ratio(series, ("top",), keep)["mean"], 0.075)
        self.assertAlmostEqual(wall_force_ratio(series, ("bottom", "top"), keep)["mean"],
                               4.5 / 40.0)
        keep[1::2] = False  # only the samples at 10: 0.3 and 0.15, as the ratio of those
        self.assertAlmostEqual(wall_force_ratio(series, ("bottom",), keep)["mean"], 0.3)

    def test_short_and_nan_input(self):
        self.assertTrue(np.isnan(block_average([])["mean"]))
        self.assertTrue(np.isnan(block_average([1.0])["err"]))
        b = block_average([1.0, np.nan, 3.0])
        self.assertEqual((b["mean"], b["n"]), (2.0, 2))

    def test_window_mean(self):
        mean, err = window_mean([[1.0, np.nan], [3.0, np.nan], [5.0, 2.0]])
        np.testing.assert_allclose(mean, [3.0, 2.0])
        self.assertAlmostEqual(err[0], 2.0 / np.sqrt(3))
        self.assertTrue(np.isnan(err[1]))

    def test_weighted_mean(self):
        # equal errors: the plain mean, its scatter error std(ddof=1) / sqrt(k)
        ys = [1.0, 2.0, 4.0]
        mean, prop, scatter = weighted_mean(ys, [0.5] * 3)
        self.assertAlmostEqual(mean, np.mean(ys))
        self.assertAlmostEqual(prop, 0.5 / np.sqrt(3))
        self.assertAlmostEqual(scatter, np.std(ys, ddof=1) / np.sqrt(3))
        # unequal errors: weights 1:4, the scatter about the weighted mean, weighted
        mean, prop, scatter = weighted_mean([0.24, 0.27], [0.004, 0.002])
        self.assertAlmostEqual(mean, (0.24 + 4 * 0.27) / 5)
        self.assertAlmostEqual(prop, 1 / np.sqrt(1 / 0.004 ** 2 + 1 / 0.002 ** 2))
        self.assertAlmostEqual(scatter, np.sqrt(0.2 * 0.024 ** 2 + 0.8 * 0.006 ** 2))
        # one estimate: no scatter
        mean, prop, scatter = weighted_mean([3.0], [0.1])
        self.assertEqual((mean, prop), (3.0, 0.1))
        self.assertTrue(np.isnan(scatter))


def relaxing(t, tau, amplitude, noise, rng):
    return 1.0 + amplitude * np.exp(-t / tau) + ar1(len(t), 0.9, noise, rng)


class SteadyState(unittest.TestCase):
    window = 80.0

    def detect(self, t, series, window_signals=None):
        starts = np.arange(0.0, t[-1] - self.window + 1e-9, self.window)
        return detect_steady_state(t, series, starts, window_signals or {})

    def test_mser_finds_a_step(self):
        z = np.r_[np.full(30, 5.0), np.zeros(170)] + np.random.default_rng(0).normal(0, 0.1, 200)
        self.assertEqual(mser_truncation(z), (30, False))
        self.assertEqual(mser_truncation(np.linspace(1, 0, 200)), (100, True))   # still drifting

    def test_transient_end_found(self):
        t = 0.5 * np.arange(1, 6001)
        for seed in range(3):
            rng = np.random.default_rng(seed)
            st = self.detect(t, {"mu": relaxing(t, 100.0, 0.25, 0.02, rng),
                                 "height": relaxing(t, 100.0, 1.0, 0.05, rng)})
            self.assertTrue(st["steady"], st["reason"])
            self.assertGreater(st["transient_end_time"], 150.0)
            self.assertLess(st["transient_end_time"], 700.0)
            self.assertTrue(all(self.window * k >= st["transient_end_time"] for k in st["windows"]))

    def test_stationary_noise_is_steady_from_the_start(self):
        t = 0.5 * np.arange(1, 6001)
        rng = np.random.default_rng(5)
        st = self.detect(t, {"mu": rng.normal(0.3, 0.02, len(t)), "h": ar1(len(t), 0.9, 0.1, rng)},
                         {"bulk": rng.normal(0.3, 0.01, 37)})
        self.assertTrue(st["steady"], st["reason"])
        self.assertLess(st["transient_end_time"], 0.2 * t[-1])

    def test_still_drifting_is_not_steady(self):
        t = 0.5 * np.arange(1, 2001)
        st = self.detect(t, {"mu": relaxing(t, 1000.0, 0.25, 0.02, np.random.default_rng(1))})
        self.assertFalse(st["steady"])
        self.assertIn("still drifting", st["reason"])
        self.assertGreaterEqual(st["averaging_start_time"], 0.5 * t[-1] - 1e-9)

    def test_a_change_within_its_tolerance_does_not_count(self):
        # The same slow relaxation of a block speed (in units of V), still going at the end of
        # the run: from 0.03, as regime A's wander, and from 0.9, a block leaving a wall.
        t = 0.5 * np.arange(1, 8001)
        rng = np.random.default_rng(7)
        mu = rng.normal(0.3, 0.02, len(t))
        decay = np.exp(-t / (0.5 * t[-1]))
        creep = 0.03 * decay + np.abs(ar1(len(t), 0.9, 0.003, rng))
        jump = 0.9 * decay + np.abs(ar1(len(t), 0.9, 0.003, rng))
        starts = np.arange(0.0, t[-1] - self.window + 1e-9, self.window)
        for speed, tolerated in ((creep, True), (jump, False)):
            series = {"mu": mu, "speed": speed}
            plain = detect_steady_state(t, series, starts, {}, stationarity_only=("speed",))
            self.assertFalse(plain["steady"])
            self.assertIn("speed still drifting", plain["reason"])
            st = detect_steady_state(t, series, starts, {}, stationarity_only=("speed",),
                                     tolerances={"speed": 0.1})
            self.assertEqual(st["steady"], tolerated, st["reason"])
            self.assertEqual(np.isnan(st["truncation_times"]["speed"]), tolerated)

    def test_too_short_is_not_steady(self):
        t = 0.5 * np.arange(1, 241)          # 120 time units: one window
        st = self.detect(t, {"mu": np.random.default_rng(2).normal(0.3, 0.02, len(t))})
        self.assertFalse(st["steady"])
        self.assertIn("window", st["reason"])
        self.assertEqual(list(st["windows"]), [0])


class Regions(unittest.TestCase):
    def test_linear_profile(self):
        V, H, h = 0.5, 20.0, 5.0
        y = np.arange(25) + 0.5
        inside = y < H
        vx = np.where(inside, -V + 2 * V * y / H, np.nan)[None]
        stress = np.zeros((1, 25, 2, 2))
        stress[..., 0, 1], stress[..., 1, 1] = -0.1, 0.25
        windows = dict(y=y, height=np.array([H]), vx=vx, stress=stress,
                       solid_fraction=np.where(inside, 0.8, 0.0)[None],
                       coordination=np.where(inside, 3.0, np.nan)[None])
        r = regions_for_h(windows, h, V, 0.25)
        self.assertAlmostEqual(r["bulk_shear_rate"][0], 2 * V / H)
        self.assertAlmostEqual(r["bulk_inertial_number"][0], 2 * V / H * np.sqrt(np.pi))
        self.assertAlmostEqual(r["bulk_mu_eff"][0], 0.4)
        self.assertAlmostEqual(r["top_coordination"][0], 3.0)
        self.assertAlmostEqual(r["bottom_velocity_jump"][0], 2 * V * h / H)
        self.assertAlmostEqual(r["top_velocity_jump"][0], 2 * V * h / H)
        self.assertAlmostEqual(r["top_inertial_number"][0], np.sqrt(np.pi) * 2 * V / H)

    def test_a_stripe_centred_on_h_is_the_bulks(self):
        # h = 5.5 on stripes centred at k + 0.5: the stripes at 5.5 and H - h = 14.5 are the
        # bulk's (h <= y <= H - h, as src/measure takes it), not the layers': the bulk's solid
        # fraction counts eight stripes of 0.8 and those two of 0.5, each layer five of 0.8
        V, H, h = 0.5, 20.0, 5.5
        y = np.arange(25) + 0.5
        inside = y < H
        nu = np.where(inside, 0.8, 0.0)
        nu[[5, 14]] = 0.5
        windows = dict(y=y, height=np.array([H]), vx=np.where(inside, 0.0, np.nan)[None],
                       stress=np.zeros((1, 25, 2, 2)), solid_fraction=nu[None],
                       coordination=np.where(inside, 3.0, np.nan)[None])
        r = regions_for_h(windows, h, V, 0.25)
        self.assertAlmostEqual(r["bulk_solid_fraction"][0], (8 * 0.8 + 2 * 0.5) / 10)
        self.assertAlmostEqual(r["bottom_solid_fraction"][0], 0.8)
        self.assertAlmostEqual(r["top_solid_fraction"][0], 0.8)

    def test_top_layer_from_the_stripes_counted_down_from_the_top_wall(self):
        # The window's profile says one thing near the top, the top stripes another: the top
        # layer (depth < h) is taken from the top stripes only, as src/measure does.
        V, H, h = 0.5, 20.0, 3.0
        y = np.arange(25) + 0.5
        inside = y < H
        stress = np.zeros((1, 25, 2, 2))
        stress[..., 0, 1], stress[..., 1, 1] = -0.1, 0.25
        windows = dict(y=y, height=np.array([H]), vx=np.where(inside, 0.0, np.nan)[None],
                       stress=stress, solid_fraction=np.where(inside, 0.8, 0.0)[None],
                       coordination=np.where(inside, 3.0, np.nan)[None])
        depth = np.arange(4) + 0.5
        top_stress = np.zeros((1, 4, 2, 2))
        top_stress[..., 0, 1], top_stress[..., 1, 1] = -0.05, 0.25
        top = dict(depth=depth, vx=(V - 0.1 * depth)[None], solid_fraction=np.full((1, 4), 0.7),
                   coordination=np.array([[2.0, 2.0, 2.0, 9.0]]),
                   force_carrying_coordination=np.full((1, 4), 1.5), stress=top_stress)
        r = regions_for_h(windows, h, V, 0.25, top_stripes=top)
        self.assertAlmostEqual(r["top_solid_fraction"][0], 0.7)
        self.assertAlmostEqual(r["top_coordination"][0], 2.0)   # depth 3.5 is not in the layer
        self.assertAlmostEqual(r["top_force_carrying_coordination"][0], 1.5)
        self.assertAlmostEqual(r["top_mu_eff"][0], 0.2)
        self.assertAlmostEqual(r["top_velocity_jump"][0], 0.1 * h)
        self.assertAlmostEqual(r["bottom_solid_fraction"][0], 0.8)
        self.assertAlmostEqual(r["bulk_mu_eff"][0], 0.4)


if __name__ == "__main__":
    unittest.main()

"""plots._envelope: what a series line keeps of a long run's samples; the axes' limits and
ticks that the figures set from their values."""
import unittest

import numpy as np

from cdshear_analysis.plots import _envelope, _velocity_limits


class SeriesEnvelope(unittest.TestCase):
    def test_short_series_are_drawn_as_they_are(self):
        x = np.arange(40.0)
        y = np.sin(x)
        ex, ey = _envelope(x, y, bins=20)
        np.testing.assert_array_equal(ex, x)
        np.testing.assert_array_equal(ey, y)

    def test_each_bin_keeps_its_lowest_and_highest_sample_in_time_order(self):
        rng = np.random.default_rng(3)
        x = np.linspace(0.0, 1000.0, 10_007)
        y = np.cumsum(rng.normal(size=x.size))
        bins = 50
        ex, ey = _envelope(x, y, bins=bins)
        self.assertEqual(len(ex), 2 * bins)
        self.assertTrue(np.all(np.diff(ex) >= 0), "points out of time order")
        edges = np.linspace(0, x.size, bins + 1).astype(int)
        for b in range(bins):
            seg = y[edges[b]:edges[b + 1]]
            self.assertEqual(sorted(ey[2 * b:2 * b + 2]), [seg.min(), seg.max()])
        # The series' own extremes are kept, whatever the binning.
        self.assertEqual(ey.min(), y.min())
        self.assertEqual(ey.max(), y.max())
        # Every point kept is a sample of the series (its time and its value).
        for t, v in zip(ex, ey):
            i = np.searchsorted(x, t)
            self.assertEqual(y[i], v)

    def test_nan_samples_stay_out_of_the_extremes_and_a_bin_of_nan_is_a_gap(self):
        x = np.arange(1000.0)
        y = np.cos(x / 50.0)
        y[100:110] = np.nan           # inside the first bin (samples 0..499)
        y[500:] = np.nan              # the whole second bin
        ex, ey = _envelope(x, y, bins=2)
        self.assertEqual(sorted(ey[:2]), [np.nanmin(y[:500]), np.nanmax(y[:500])])
        self.assertTrue(np.all(np.isnan(ey[2:])))


class VelocityLimits(unittest.TestCase):
    def test_velocities_within_the_walls_keep_the_fixed_limits(self):
        self.assertEqual(_velocity_limits([np.array([-1.0, 0.3, 1.0]), np.array([0.9])]),
                         (-1.25, 1.35))
        self.assertEqual(_velocity_limits([]), (-1.25, 1.35))
        self.assertEqual(_velocity_limits([np.array([np.nan])]), (-1.25, 1.35))

    def test_overshoots_past_the_walls_velocities_stay_in_view(self):
        low, high = _velocity_limits([np.array([0.5, 1.8]), np.array([-1.6, np.nan])])
        self.assertLess(low, -1.6)
        self.assertGreater(high, 1.8)


class LogAxisTicks(unittest.TestCase):
    """campaign_figures._label_log_axis on an axis of less than two decades."""

    def ticks_in_view(self, lo, hi, values):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from cdshear_analysis.campaign_figures import _label_log_axis
        fig, ax = plt.subplots()
        ax.set_xscale("log")
        ax.set_xlim(lo, hi)
        _label_log_axis(ax, values)
        ticks = ax.xaxis.get_major_locator().tick_values(lo, hi)
        plt.close(fig)
        return [float(f"{t:.6g}") for t in ticks if lo <= t <= hi]

    def test_one_to_five_ticks_where_two_are_in_view(self):
        self.assertEqual(self.ticks_in_view(0.03, 0.6, [0.05, 0.5]), [0.05, 0.1, 0.2, 0.5])

    def test_every_digit_where_one_two_five_leave_one_tick(self):
        # a single V of 0.02 drawn from V / 1.6 to 1.6 V: only 0.02 of 1, 2, 5 is in view
        self.assertEqual(self.ticks_in_view(0.0125, 0.032, [0.02]), [0.02, 0.03])

    def test_the_values_themselves_where_no_two_digits_are_in_view(self):
        self.assertEqual(self.ticks_in_view(0.019, 0.021, [0.02]), [0.02])


class ForceKeepsOnlyItsOwnFigures(unittest.TestCase):
    """`cdshear run --force` removes from figures/ only the files plot_run writes; its list is in
    src/app/run_session.cpp (is_run_figure) and must name the same files as plots.FIGURES."""

    def test_the_executable_knows_every_figure_plot_writes(self):
        import re
        from cdshear_analysis.plots import FIGURES
        from tests.cpp_source import source_part
        body = source_part("src/app/run_session.cpp", "bool is_run_figure(", "return false;")
        self.assertEqual(set(re.findall(r'"([\w.]+\.png)"', body)), set(FIGURES))


if __name__ == "__main__":
    unittest.main()

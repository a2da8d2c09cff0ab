"""plots._envelope: what a series line keeps of a long run's samples."""
import unittest

import numpy as np

from cdshear_analysis.plots import _envelope


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



class ForceKeepsOnlyItsOwnFigures(unittest.TestCase):
    """`cdshear run --force` removes from figures/ only the files plot_run writes; its list is in
    src/app/run_session.cpp (is_run_figure) and must name the same files as plots.FIGURES."""

    def test_the_executable_knows_every_figure_plot_writes(self):
        import os
        import re
        from cdshear_analysis.plots import FIGURES
        source = os.path.join(os.path.dirname(__file__), "..", "..", "src", "app",
                              "run_session.cpp")
        with open(source) as f:
            text = f.read()
        body = text[text.index("bool is_run_figure("):]
        body = body[:body.index("return false;")]
        self.assertEqual(set(re.findall(r'"([\w.]+\.png)"', body)), set(FIGURES))


if __name__ == "__main__":
    unittest.main()

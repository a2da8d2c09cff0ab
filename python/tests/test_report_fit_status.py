"""The status of a fit (fitting.assess): "ok" for synthetic points of known laws with noise of
their error bars, "undetermined" for points that do not constrain the form, "poor" for points
that scatter far more than their error bars; each with a reason that names the numbers, shown in
fits.json, index.html and the printed output of `report`; the predictions take ok and poor
laws only."""
import contextlib
import io
import json
import math
import os
import tempfile
import unittest

import numpy as np

from cdshear_analysis import boundary_laws as bl
from cdshear_analysis import fitting, report, transitions as tr
from cdshear_analysis.__main__ import main as cli_main
from tests.test_boundary_laws import within
from tests.test_report import fake_campaign

MU = fitting.law("power_plus", ["mu_0", "A", "B"], "mu", "I")
LINE = fitting.law("linear_minus", ["nu_max", "c"], "nu", "I")
Z = fitting.law("power_minus", ["Z_0", "c", "e"], "Z", "I")


def points(x, y, err):
    return [(float(a), float(b), float(e), f"p{k}") for k, (a, b, e) in
            enumerate(zip(x, y, np.broadcast_to(err, np.shape(x))))]


def noisy(f, x, err, seed, factor=1.0):
    """f(x) with Gaussian noise of factor x the error bar err."""
    rng = np.random.default_rng(seed)
    return f(np.asarray(x)) + factor * err * rng.standard_normal(len(x))


class StatusTest(unittest.TestCase):
    I = np.geomspace(0.003, 0.3, 16)

    def assert_recovered(self, fit, truth, sigmas=2.5):
        within(self, fit, truth, sigmas)
        self.assertIn(f"chi2/dof = {fit['chi2_dof']:.3g} with {fit['dof']} dof", fit["reason"])
        self.assertGreaterEqual(fit["chi2_p"], fitting.P_POOR)

    def test_known_laws_are_ok_and_recovered_within_their_errors(self):
        for seed in (1, 2, 3):
            mu = noisy(lambda x: 0.25 + 0.5 * x ** 0.6, self.I, 0.003, seed)
            self.assert_recovered(fitting.fit(MU, points(self.I, mu, 0.003)),
                                  {"mu_0": 0.25, "A": 0.5, "B": 0.6})
            nu = noisy(lambda x: 0.82 - 0.35 * x, self.I, 0.002, seed)
            self.assert_recovered(fitting.fit(LINE, points(self.I, nu, 0.002)),
                                  {"nu_max": 0.82, "c": 0.35})
            z = noisy(lambda x: 3.2 - 2.0 * x ** 0.7, self.I, 0.01, seed)
            self.assert_recovered(fitting.fit(Z, points(self.I, z, 0.01)),
                                  {"Z_0": 3.2, "c": 2.0, "e": 0.7})

    def test_a_logarithm_fitted_by_a_power_law_is_undetermined(self):
        # Z = 2 - 0.3 ln(I) within its error bars: Z_0 - c I^e follows it only with e -> 0 and
        # Z_0, c growing together (Z_0 = 64 ± 184 kind of numbers): chi2 is fine, the
        # parameters mean nothing
        z = noisy(lambda x: 2.0 - 0.3 * np.log(x), self.I, 0.02, 4)
        fit = fitting.fit(Z, points(self.I, z, 0.02))
        self.assertEqual(fit["status"], "undetermined", fit["reason"])
        self.assertGreater(fit["chi2_p"], fitting.P_POOR)    # not a chi2 matter
        self.assertIn("the points do not constrain the form", fit["reason"])
        p = fit["parameters"]
        self.assertGreater(p["Z_0"]["err_scaled"], abs(p["Z_0"]["value"]))
        # the reason names the numbers
        self.assertIn(f"Z_0 = {p['Z_0']['value']:.3g} ± {p['Z_0']['err_scaled']:.3g}",
                      fit["reason"])
        self.assertFalse(fitting.usable(fit))
        self.assertTrue(fitting.fitted(fit))     # still drawn, its status on the legend

    def test_flat_points_fitted_by_a_power_law_are_undetermined(self):
        # a horizontal line: A -> 0 and the exponent anything
        mu = noisy(lambda x: 0.3 + 0 * x, self.I, 0.003, 5)
        fit = fitting.fit(MU, points(self.I, mu, 0.003))
        self.assertEqual(fit["status"], "undetermined", fit["reason"])
        self.assertIn("larger than the value", fit["reason"])

    def test_few_points_over_little_x_are_undetermined(self):
        # five points over 5% of x: the three parameters trade off without bound
        x = np.linspace(0.1, 0.105, 5)
        mu = noisy(lambda v: 0.25 + 0.5 * v ** 0.6, x, 0.003, 6)
        fit = fitting.fit(MU, points(x, mu, 0.003))
        self.assertEqual(fit["status"], "undetermined", fit["reason"])
        self.assertGreater(max(v["err"] / abs(v["value"]) for v in
                               fit["parameters"].values()), 1.0)
        # the same law over two decades of x is determined
        self.assertEqual(fitting.fit(MU, points(self.I, noisy(
            lambda v: 0.25 + 0.5 * v ** 0.6, self.I, 0.003, 6), 0.003))["status"], "ok")

    def test_scatter_far_larger_than_the_error_bars_is_poor(self):
        mu = noisy(lambda x: 0.25 + 0.5 * x ** 0.6, self.I, 0.003, 7, factor=6.0)
        fit = fitting.fit(MU, points(self.I, mu, 0.003))
        self.assertEqual(fit["status"], "poor", fit["reason"])
        self.assertLess(fit["chi2_p"], fitting.P_POOR)
        self.assertGreater(fit["chi2_dof"], 10)
        self.assertIn(f"chi2/dof = {fit['chi2_dof']:.3g} with 13 dof", fit["reason"])
        self.assertIn(f"< {fitting.P_POOR:g}", fit["reason"])
        # its parameters are determined (usable) and their scaled errors cover the truth
        self.assertTrue(fitting.usable(fit))
        for p, value in {"mu_0": 0.25, "A": 0.5, "B": 0.6}.items():
            v = fit["parameters"][p]
            self.assertAlmostEqual(v["err_scaled"], v["err"] * math.sqrt(fit["chi2_dof"]))
            self.assertLess(abs(v["value"] - value), 3 * v["err_scaled"], p)
        # a linear law through points on a curve: poor too
        nu = noisy(lambda x: 0.82 - 3.0 * x ** 2, self.I, 0.002, 7)
        self.assertEqual(fitting.fit(LINE, points(self.I, nu, 0.002))["status"], "poor")

    def test_the_threshold_is_the_chi2_tail_probability(self):
        # 2 dof: P(chi2 >= x) = exp(-x / 2), 1e-3 at x = 13.8155
        params = {"a": {"value": 1.0, "err": 0.1, "err_scaled": 0.1}}
        edge = -2 * math.log(fitting.P_POOR)
        self.assertEqual(fitting.assess(params, True, [], edge * 0.99, 2)[0], "ok")
        self.assertEqual(fitting.assess(params, True, [], edge * 1.01, 2)[0], "poor")
        # chi2/dof = 4 is ok with 2 dof (P = 0.018), poor with 50 (P = 1e-20)
        self.assertEqual(fitting.assess(params, True, [], 8.0, 2)[0], "ok")
        self.assertEqual(fitting.assess(params, True, [], 200.0, 50)[0], "poor")
        # an infinite covariance or a parameter on its bound: undetermined, even with a
        # good chi2; undetermined wins over poor, which the reason adds
        status, reason, _ = fitting.assess(params, False, [], 1.0, 2)
        self.assertEqual(status, "undetermined")
        self.assertIn("covariance infinite or NaN", reason)
        status, reason, _ = fitting.assess(params, True, [("a", 10.0, 1e-3, 10.0)], 100.0, 2)
        self.assertEqual(status, "undetermined")
        self.assertIn("a = 10 on the bound of its range [0.001, 10]", reason)
        self.assertIn("also chi2/dof = 50 with 2 dof", reason)

    def test_a_poor_laws_draws_take_its_scaled_covariance(self):
        mu = noisy(lambda x: 0.25 + 0.5 * x ** 0.6, self.I, 0.003, 7, factor=6.0)
        fit = fitting.fit(MU, points(self.I, mu, 0.003))
        draws = fitting.parameter_samples(fit, 20000, np.random.default_rng(1))
        self.assertAlmostEqual(np.std(draws[:, 0]) / fit["parameters"]["mu_0"]["err_scaled"],
                               1.0, delta=0.03)


class PredictionsTakeDeterminedLawsTest(unittest.TestCase):
    def test_an_undetermined_bulk_law_gives_no_prediction(self):
        undetermined = {"status": "undetermined", "reason": "mu_0 = 1 ± 9", "model": "power_plus",
                        "parameters": {"mu_0": {"value": 1.0}, "A": {"value": 1.0},
                                       "B": {"value": 1.0}}}
        linear = {"status": "ok", "model": "linear_plus", "range": [0.03, 0.2],
                  "parameters": {"a": {"value": 0.3}, "b": {"value": 0.5}}}
        rows = [{"run": "s1_seed1_V1", "system": 1, "V": 1.0, "regime": "A", "steady": True,
                 "I_bulk": 0.1, "L_y": 20.0, "nu_bulk": 0.8, "_sigma_yy": 0.25}]
        # mu_power undetermined: the time to steady state takes mu_linear
        (e,) = tr.steady_state_predictions(rows, {"mu_power": undetermined, "mu_linear": linear})
        self.assertEqual((e["law"], e["law_status"]), ("mu_linear", "ok"))
        # neither: the reason gives both statuses
        (e,) = tr.steady_state_predictions(rows, {"mu_power": undetermined,
                                                  "mu_linear": {"status": "skipped",
                                                                "reason": "too few points"}})
        self.assertIsNone(e["predicted_T_SS"])
        self.assertIn("mu_power undetermined: mu_0 = 1 ± 9", e["reason"])
        self.assertIn("mu_linear skipped: too few points", e["reason"])
        # V_AB needs mu_0 of the bulk
        v_ab = bl.predict_v_ab(rows, {"mu_power": undetermined},
                               {"thicknesses": [], "all_h": {}})
        self.assertEqual(v_ab["status"], "not available")
        self.assertIn("mu_power (mu_0) is undetermined: mu_0 = 1 ± 9", v_ab["reason"])


class ReportShowsStatusTest(unittest.TestCase):
    def test_fits_json_index_and_printed_output_give_status_and_reason(self):
        # bulk mu on its power law (ok), Z on a logarithm of I (Z_power undetermined), nu
        # scattering by five error bars (nu_linear poor)
        rng = np.random.default_rng(8)
        runs = {1: []}
        for I in np.geomspace(0.003, 0.3, 16):
            runs[1].append((float(10 * I), float(I),
                            0.25 + 0.5 * I ** 0.6 + 0.003 * rng.standard_normal(),
                            0.82 - 0.35 * I + 0.01 * rng.standard_normal(),
                            2.0 - 0.3 * math.log(I) + 0.02 * rng.standard_normal()))
        with tempfile.TemporaryDirectory() as d:
            fake_campaign(d, "status", runs)
            out = io.StringIO()
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
                self.assertEqual(cli_main(["report", d]), 0)
            printed = out.getvalue()
            with open(os.path.join(d, "report", "fits.json")) as f:
                doc = json.load(f)
            with open(os.path.join(d, "report", "index.html")) as f:
                text = f.read()
        fits = doc["fits"]
        expected = {"mu_power": "ok", "Z_power": "undetermined", "nu_linear": "poor"}
        for name, status in expected.items():
            fit = fits[name]
            self.assertEqual(fit["status"], status, fit["reason"])
            self.assertTrue(fit["reason"])
            # printed: one line per bulk law with its status and reason
            self.assertIn(f"note: fit {name}: {status}: {fit['reason']}\n", printed)
            # index.html: the status and its reason beside the law
            self.assertIn(f"<b>{status}</b><br><small>{report.html.escape(fit['reason'])}",
                          text)
        self.assertEqual(sum(doc["fit_status_counts"].values()),
                         len(report.all_fits(fits, doc["fits_per_system"], doc["boundary"])))
        self.assertEqual(doc["fit_status_counts"]["undetermined"] > 0, True)
        self.assertIn("note: fits: ", printed)
        self.assertIn(f"{doc['fit_status_counts']['poor']} poor", printed)
        self.assertIn("<b>undetermined</b>, the points do not constrain the form", text)
        # the Z(I) figure still draws the undetermined law, which says so on its legend:
        # drawn or not, the report has no error (the figure exists)
        self.assertTrue(fits["Z_power"]["parameters"])


if __name__ == "__main__":
    unittest.main()

"""Seeds of one (system, V) combined into one point of a fit, the bulk laws fitted per system,
whether a law depends on the system, and delta_mu of a regime-C switch from the boundary law, on
synthetic campaigns with known parameters (report.py, fitting.py, boundary_laws.py,
transitions.py)."""
import json
import math
import os
import tempfile
import unittest

import numpy as np

from cdshear_analysis import boundary_laws as bl
from cdshear_analysis import fitting, report, transitions as tr
from tests.test_boundary_laws import BC_LAW, SCALE, campaign_rows
from tests.test_report import fake_summary, main, within


def write_campaign(d, runs, name="seeds"):
    """Run folders of runs: dicts with system, seed, V, I, mu, nu, Z and optional errs, steady,
    regime; a campaign.toml that lists them."""
    names = []
    for r in runs:
        run = f"s{r['system']}_seed{r['seed']}_V{r['V']:.6g}"
        names.append(run)
        fake_summary(os.path.join(d, "runs", run), r["V"], r["I"], r["mu"], r["nu"], r["Z"],
                     errs=r.get("errs", (0.003, 0.002, 0.02)), steady=r.get("steady", True),
                     regime=r.get("regime", "A"))
    with open(os.path.join(d, "campaign.toml"), "w") as f:
        f.write(f"[campaign]\nname = '{name}'\n\n# Runs (name, duration [t], dt [t], cost):\n")
        for run in names:
            f.write(f"#   {run}  duration 1000  dt 0.001  cost 5.1e+08\n")


def mu_law(I, mu_0, A, B):
    return mu_0 + A * I ** B


class SeedsCombinedTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.d = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def two_seed_campaign(self):
        """System 1, six V, two seeds each: seed 1 with error bars half those of seed 2; the
        seeds' values differ by `gap` (small at some V, large at others), I differs too."""
        self.velocities = [0.05, 0.1, 0.2, 0.5, 1.0, 2.0]
        self.gaps = [0.001, 0.02, 0.002, 0.03, 0.0005, 0.015]
        runs = []
        for V, gap in zip(self.velocities, self.gaps):
            I = 0.05 * V
            mu = mu_law(I, 0.25, 0.5, 0.6)
            runs.append(dict(system=1, seed=1, V=V, I=I, mu=mu - gap / 2, nu=0.8, Z=3.0,
                             errs=(0.003, 0.002, 0.02)))
            runs.append(dict(system=1, seed=2, V=V, I=1.1 * I, mu=mu + gap / 2, nu=0.8, Z=3.0,
                             errs=(0.006, 0.002, 0.02)))
        write_campaign(self.d, runs)

    def test_seeds_without_their_averaged_time_combine_by_1_over_err2(self):
        # the fake summaries do not say where the averaging starts: the weights are 1/err^2
        # (statistics.weighted_mean); with the averaged time see the next test
        self.two_seed_campaign()
        rows = report.collect(self.d)["rows"]
        fit = report.fit_law("mu_power", rows)
        self.assertEqual(fit["status"], "ok", fit["reason"])
        self.assertEqual((fit["n_points"], fit["n_runs"]), (6, 12))
        self.assertEqual(len(fit["runs"]), 12)
        self.assertEqual(len(fit["combined"]), 6)
        hand = []
        for V, gap, c in zip(self.velocities, self.gaps, fit["combined"]):
            I, mu = 0.05 * V, mu_law(0.05 * V, 0.25, 0.5, 0.6)
            y1, y2, e1, e2 = mu - gap / 2, mu + gap / 2, 0.003, 0.006
            w1, w2 = 1 / e1 ** 2, 1 / e2 ** 2     # w1 = 4 w2
            y = (w1 * y1 + w2 * y2) / (w1 + w2)
            x = (w1 * I + w2 * 1.1 * I) / (w1 + w2)
            e_prop = 1 / math.sqrt(w1 + w2)
            # the scatter about the weighted mean, weighted, k - 1 = 1: 0.4 |y2 - y1| here
            # (a plain mean's std (ddof 1) / sqrt(2) would be 0.5 |y2 - y1|)
            e_seeds = math.sqrt((w1 * (y1 - y) ** 2 + w2 * (y2 - y) ** 2) / (w1 + w2))
            self.assertAlmostEqual(e_seeds, 0.4 * gap, places=12)
            self.assertEqual(sorted(c["runs"]), [f"s1_seed1_V{V:g}", f"s1_seed2_V{V:g}"])
            self.assertAlmostEqual(c["y"], y, places=12)
            self.assertAlmostEqual(c["x"], x, places=12)
            self.assertAlmostEqual(c["err_propagated"], e_prop, places=12)
            self.assertAlmostEqual(c["err_seeds"], e_seeds, places=12)
            self.assertAlmostEqual(c["err"], max(e_prop, e_seeds), places=12)
            # the weighted mean, not the plain one (seed 1 weighs 4 times seed 2)
            self.assertGreater(abs(c["y"] - (y1 + y2) / 2), 0.2 * gap)
            hand.append((x, y, max(e_prop, e_seeds), str(V)))
        # both kinds of error occur: the scatter wins where the seeds differ most
        kinds = {c["err_seeds"] > c["err_propagated"] for c in fit["combined"]}
        self.assertEqual(kinds, {True, False})
        # the fit is the fit of the hand-combined points
        by_hand = fitting.fit(report.FITS["mu_power"], hand)
        for p in ("mu_0", "A", "B"):
            self.assertAlmostEqual(fit["parameters"][p]["value"],
                                   by_hand["parameters"][p]["value"], places=6)
            self.assertAlmostEqual(fit["parameters"][p]["err"],
                                   by_hand["parameters"][p]["err"], places=6)
        # and not the fit of the twelve runs as separate points
        separate = fitting.fit(report.FITS["mu_power"], [
            (r["I_bulk"], r["mu_eff_bulk"], r["mu_eff_bulk_err"], r["run"]) for r in rows])
        self.assertEqual(separate["n_points"], 12)
        self.assertGreater(abs(separate["chi2"] - fit["chi2"]), 1e-3)

    def test_seeds_that_say_their_averaged_time_are_weighted_by_it(self):
        # the same two seeds, but their summaries say where the averaging starts: seed 1's
        # averages cover 900 t, seed 2's 300 t (time 1000). Their error bars (seed 1 half of
        # seed 2's) no longer weigh: the weights are the times, 3 to 1.
        self.two_seed_campaign()
        starts = {1: 100.0, 2: 700.0}
        for run in os.listdir(os.path.join(self.d, "runs")):
            path = os.path.join(self.d, "runs", run, "summary.json")
            with open(path) as f:
                s = json.load(f)
            s["averaging_start_time"] = starts[int(run.split("_seed")[1].split("_")[0])]
            with open(path, "w") as f:
                json.dump(s, f)
        rows = report.collect(self.d)["rows"]
        fit = report.fit_law("mu_power", rows)
        self.assertEqual(fit["status"], "ok", fit["reason"])
        self.assertEqual((fit["n_points"], fit["n_runs"], len(fit["combined"])), (6, 12, 6))
        for V, gap, c in zip(self.velocities, self.gaps, fit["combined"]):
            I, mu = 0.05 * V, mu_law(0.05 * V, 0.25, 0.5, 0.6)
            y1, y2 = mu - gap / 2, mu + gap / 2
            self.assertEqual(c["weights"], "time")
            self.assertEqual(c["averaged_time_runs"], [900.0, 300.0])
            self.assertAlmostEqual(c["y"], 0.75 * y1 + 0.25 * y2, places=12)
            self.assertAlmostEqual(c["x"], 0.75 * I + 0.25 * 1.1 * I, places=12)
            # propagated: sqrt(sum (w_i e_i)^2) with w = 0.75, 0.25 and e = 0.003, 0.006
            self.assertAlmostEqual(c["err_propagated"], math.hypot(0.75 * 0.003, 0.25 * 0.006),
                                   places=12)
            # seeds' scatter about that mean, time-weighted, k - 1 = 1: sqrt(3/16) |y2 - y1|
            self.assertAlmostEqual(c["err_seeds"], math.sqrt(3 / 16) * gap, places=12)
        # the boundary layers' points (per h, and pooled over h) are weighted the same way
        boundary = bl.fit_boundary(rows, report.FITS)
        for f in (boundary[bl.h_label(boundary["thicknesses"][0])]["mu_power"],
                  boundary["all_h"]["mu_hI_A"]):
            self.assertTrue(f["combined"])
            self.assertEqual({p["weights"] for p in f["combined"]}, {"time"})
        # without the averaging start (the test above) the same seeds are weighted by 1/err^2
        for r in rows:
            r["_averaged_time"] = None
        self.assertEqual({c["weights"] for c in report.fit_law("mu_power", rows)["combined"]},
                         {"error"})

    def test_one_seed_per_v_is_not_changed(self):
        # single runs: each run its own point, no `combined` entries, and the fit is a plain
        # weighted least-squares fit of the raw points (scipy's curve_fit called here directly,
        # from the known parameters: not through fitting.py)
        from scipy.optimize import curve_fit
        self.two_seed_campaign()
        rows = [r for r in report.collect(self.d)["rows"] if r["seed"] == 1]
        fit = report.fit_law("mu_power", rows)
        # seed 1 lies off the law by up to 5 error bars (gap / 2): "poor", and still fitted
        self.assertEqual(fit["status"], "poor", fit["reason"])
        self.assertEqual((fit["n_points"], fit["n_runs"], fit["combined"]), (6, 6, []))
        x = np.array([0.05 * V for V in self.velocities])
        y = np.array([mu_law(I, 0.25, 0.5, 0.6) - gap / 2 for I, gap in zip(x, self.gaps)])
        p, cov = curve_fit(mu_law, x, y, p0=(0.25, 0.5, 0.6), sigma=np.full(6, 0.003),
                           absolute_sigma=True, bounds=([-np.inf, -np.inf, 1e-3], np.inf))
        for k, name in enumerate(("mu_0", "A", "B")):
            self.assertAlmostEqual(fit["parameters"][name]["value"], p[k], places=5)
            self.assertAlmostEqual(fit["parameters"][name]["err"], math.sqrt(cov[k][k]),
                                   places=5)
        chi2 = float(np.sum(((y - mu_law(x, *p)) / 0.003) ** 2))
        self.assertAlmostEqual(fit["chi2"], chi2, places=5)
        # a combining that changed single points (x, y or err) would move the fit
        self.assertEqual(sorted(fit["runs"]), sorted(f"s1_seed1_V{V:g}" for V in self.velocities))

    def test_only_seeds_that_qualify_are_combined(self):
        # at V = 0.1 seed 2 is not steady, at V = 0.2 it is in regime B: those seeds of 1 stand
        # alone; a seed without an error bar is counted, not combined
        self.two_seed_campaign()
        rows = report.collect(self.d)["rows"]
        for r in rows:
            if r["run"] == "s1_seed2_V0.1":
                r["steady"] = False
            if r["run"] == "s1_seed2_V0.2":
                r["regime"] = "B"
            if r["run"] == "s1_seed2_V0.5":
                r["mu_eff_bulk_err"] = None
        fit = report.fit_law("mu_power", rows)
        self.assertEqual((fit["n_points"], fit["n_runs"], fit["points_without_error"]),
                         (6, 9, 1))
        self.assertEqual(len(fit["combined"]), 3)
        for run in ("s1_seed2_V0.1", "s1_seed2_V0.2", "s1_seed2_V0.5"):
            self.assertNotIn(run, fit["runs"])
        self.assertIn("s1_seed1_V0.1", fit["runs"])

    def test_the_report_gives_the_combined_points(self):
        self.two_seed_campaign()
        self.assertEqual(main(["report", self.d]), 0)
        with open(os.path.join(self.d, "report", "fits.json")) as f:
            fits = json.load(f)
        mu = fits["fits"]["mu_power"]
        self.assertEqual((mu["n_points"], mu["n_runs"], len(mu["combined"])), (6, 12, 6))
        self.assertEqual(fits["fits_per_system"]["1"]["mu_power"]["parameters"],
                         mu["parameters"])
        with open(os.path.join(self.d, "report", "index.html")) as f:
            self.assertIn("<td>6 (12 runs)</td>", f.read())

    def test_boundary_layers_of_c_seeds_combine_whichever_wall_is_sheared(self):
        rows = campaign_rows()
        one = bl.fit_boundary(rows, report.FITS)["all_h"]["mu_hI_BC"]
        twin = []
        for r in rows:
            if r["regime"] != "C":
                continue
            t = dict(r, run=r["run"].replace("seed1", "seed2"), seed=2)
            for h in r["_layers"]:   # seed 2 sheared at the top
                for q in ("I", "mu_eff", "nu", "Z", "velocity_jump"):
                    for suffix in ("", "_err"):
                        b, tp = (f"{bl.h_label(h)}_{s}_{q}{suffix}" for s in ("bottom", "top"))
                        t[b], t[tp] = r[tp], r[b]
            twin.append(t)
        both = bl.fit_boundary(rows + twin, report.FITS)["all_h"]["mu_hI_BC"]
        self.assertEqual(both["n_points"], one["n_points"])
        self.assertEqual(both["n_runs"], one["n_runs"] + len(twin) * 3)   # three h
        c = [p for p in both["combined"] if any(":top" in run for run in p["runs"])]
        self.assertEqual(len(c), len(twin) * 3)
        for p in c:   # the same sheared layer twice: the mean is that layer's value
            self.assertAlmostEqual(p["y"], p["y_runs"][0])
            self.assertEqual({run.split(":")[1] for run in p["runs"]}, {"bottom", "top"})


class PerSystemTest(unittest.TestCase):
    # per system: mu = mu_0 + A I^B, nu = nu_max - c I; system 2's seeds 1 and 2 at each V
    TRUTH = {1: {"mu_power": {"mu_0": 0.25, "A": 0.5, "B": 0.6},
                 "nu_linear": {"nu_max": 0.82, "c": 0.35}},
             2: {"mu_power": {"mu_0": 0.32, "A": 0.9, "B": 0.9},
                 "nu_linear": {"nu_max": 0.78, "c": 0.20}}}

    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.d = cls.tmp.name
        rng = np.random.default_rng(11)
        runs = []
        for system, seeds in ((1, (1,)), (2, (1, 2))):
            t = cls.TRUTH[system]
            for V in np.geomspace(0.06, 6.0, 12):
                I = 0.05 * float(V)
                for seed in seeds:
                    runs.append(dict(
                        system=system, seed=seed, V=float(V), I=I,
                        mu=mu_law(I, **t["mu_power"]) + 0.003 * rng.standard_normal(),
                        nu=t["nu_linear"]["nu_max"] - t["nu_linear"]["c"] * I
                        + 0.002 * rng.standard_normal(), Z=3.0 - I))
        # system 3: two steady A runs (two seeds each) and B runs, which the bulk laws ignore
        for V in (1.0, 2.0):   # I = 0.05, 0.1: inside the range of the linear laws
            for seed in (1, 2):
                runs.append(dict(system=3, seed=seed, V=V, I=0.05 * V, mu=0.3, nu=0.8, Z=3.0))
        for V in (0.01, 0.02, 0.05):
            runs.append(dict(system=3, seed=1, V=V, I=1e-5, mu=0.2, nu=0.81, Z=3.5,
                             regime="B"))
        write_campaign(cls.d, runs, "per_system")
        assert main(["report", cls.d]) == 0
        with open(os.path.join(cls.d, "report", "fits.json")) as f:
            cls.fits = json.load(f)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_per_system_fits_recover_each_systems_parameters(self):
        per = self.fits["fits_per_system"]
        self.assertEqual(sorted(per), ["1", "2", "3"])
        for system, laws in self.TRUTH.items():
            for name, truth in laws.items():
                fit = per[str(system)][name]
                self.assertEqual(fit["status"], "ok", fit["reason"])
                within(self, fit, truth, sigmas=2.5)
                self.assertLess(fit["chi2_dof"], 3.0)
            self.assertEqual(per[str(system)]["mu_power"]["n_points"], 12)
        self.assertEqual(per["2"]["mu_power"]["n_runs"], 24)   # two seeds per V
        # each system's fit misses the other's parameters: the test can fail
        with self.assertRaises(AssertionError):
            within(self, per["2"]["mu_power"], self.TRUTH[1]["mu_power"], sigmas=2.5)
        # the pooled fit is still there, under its own key, over every system: the two laws
        # do not make one (its chi2/dof shows it, and its status)
        pooled = self.fits["fits"]["mu_power"]
        self.assertEqual((pooled["status"], pooled["n_points"]), ("poor", 26))
        self.assertGreater(pooled["chi2_dof"], 10.0)
        self.assertLess(pooled["chi2_p"], fitting.P_POOR)
        # and the test of one law against an offset per system says so
        dep = self.fits["system_dependence"]["mu_power"]
        self.assertEqual((dep["systems"], dep["verdict"]), (["1", "2", "3"],
                                                             "depends on the system"))

    def test_runs_md_lists_every_run_with_its_errors(self):
        with open(os.path.join(self.d, "report", "runs.md")) as f:
            lines = f.read().splitlines()
        rows = [line for line in lines if line.startswith("| s")]
        self.assertEqual(len(rows), 12 + 24 + 4 + 3)   # every run, seeds not combined
        cells = rows[0].strip("| ").split(" | ")
        self.assertEqual(cells[:3], ["s1_seed1_V0.06", "A", "yes"])
        # the fake summaries' mu error is 0.003: two significant digits, the value to match
        self.assertRegex(cells[4], r"^0\.\d{4} \+- 0\.0030$")
        self.assertEqual(cells[-1], "100")   # the transient's end of a steady run
        self.assertIn("| s3_seed1_V0.01 | B | yes |", "\n".join(rows))

    def test_plus_minus_text_rounds_the_value_to_its_error(self):
        self.assertEqual(report._pm_text(0.41559, 0.001094), "0.4156 +- 0.0011")
        self.assertEqual(report._pm_text(2.51273, 0.0036), "2.5127 +- 0.0036")
        self.assertEqual(report._pm_text(1.31e-4, 1.7e-5), "1.3e-04 +- 1.7e-05")
        self.assertEqual(report._pm_text(880.0, 25.0), "880 +- 25")
        self.assertEqual(report._pm_text(0.5, None), "0.5")
        self.assertEqual(report._pm_text(None, 0.1), "")

    def test_a_system_with_too_few_points_is_skipped_with_the_reason(self):
        s3 = self.fits["fits_per_system"]["3"]
        for name, (points, needed) in {"mu_power": (2, 4), "Z_power": (2, 4),
                                       "mu_linear": (2, 3), "nu_linear": (2, 3)}.items():
            fit = s3[name]
            self.assertEqual(fit["status"], "skipped", name)
            self.assertIsNone(fit["parameters"])
            # two points from four runs: the seeds are no separate points
            self.assertIn(f"too few points: {points}", fit["reason"])
            self.assertIn("from 4 runs, seeds of a (system, V) combined", fit["reason"])
            self.assertIn(f"{needed} needed", fit["reason"])
        with open(os.path.join(self.d, "report", "index.html")) as f:
            text = f.read()
        self.assertIn("The bulk laws per system", text)
        self.assertIn("<td>system 3: mu_power</td>", text)
        self.assertIn("<td>system 1: nu_linear</td>", text)
        self.assertIn("<b>skipped</b><br><small>too few points: 2", text)


class SystemDependenceTest(unittest.TestCase):
    """report.system_dependence: three systems on one law mu = 0.25 + 0.5 I^0.6, nu = 0.82 -
    0.35 I with scatter at their error bars, then the same with system 2 shifted by SHIFT in
    mu and nu: no dependence detected, then the dependence found with system 2's offset."""
    SHIFT = {"mu": 0.02, "nu": -0.008}

    def fits_of(self, shift):
        rng = np.random.default_rng(5)
        runs = []
        for system in (1, 2, 3):
            dy = shift if system == 2 else {"mu": 0.0, "nu": 0.0}
            for V in np.geomspace(0.5, 4.0, 8) * (1 + 0.03 * system):
                I = 0.05 * float(V)
                runs.append(dict(system=system, seed=1, V=float(V), I=I,
                                 mu=mu_law(I, 0.25, 0.5, 0.6) + dy["mu"]
                                 + 0.003 * rng.standard_normal(),
                                 nu=0.82 - 0.35 * I + dy["nu"] + 0.002 * rng.standard_normal(),
                                 Z=3.0 - I))
        with tempfile.TemporaryDirectory() as d:
            write_campaign(d, runs, "dependence")
            self.assertEqual(main(["report", d]), 0)
            with open(os.path.join(d, "report", "fits.json")) as f:
                fits = json.load(f)
            with open(os.path.join(d, "report", "index.html")) as f:
                self.html = f.read()
        return fits["system_dependence"]

    def test_one_law_is_not_split_by_system(self):
        dep = self.fits_of({"mu": 0.0, "nu": 0.0})
        for name in ("mu_power", "nu_linear"):
            e = dep[name]
            self.assertEqual(e["systems"], ["1", "2", "3"])
            self.assertEqual(e["verdict"], "no dependence detected", (name, e))
            self.assertGreater(e["p_F"], 0.01)
            self.assertEqual(e["dof"] - e["dof_offsets"], 2)   # one offset per system but one
            for system, o in e["offsets"].items():
                self.assertLess(abs(o["value"]), 3 * o["err"], (name, system, o))
        self.assertIn("Does each law depend on the system?", self.html)

    def test_a_shifted_system_is_found_with_its_offset(self):
        dep = self.fits_of(self.SHIFT)
        for name, y in (("mu_power", "mu"), ("nu_linear", "nu")):
            e = dep[name]
            self.assertEqual(e["verdict"], "depends on the system", (name, e))
            self.assertLess(e["p_F"], 1e-3)
            self.assertLess(e["chi2_offsets"], e["chi2"])
            # systems tied at 8 points: the reference is the lowest, system 1
            self.assertEqual(e["reference"], "1")
            o2, o3 = e["offsets"]["2"], e["offsets"]["3"]
            self.assertLess(abs(o2["value"] - self.SHIFT[y]), 3 * o2["err"], (name, o2))
            self.assertLess(abs(o3["value"]), 3 * o3["err"], (name, o3))


class DeltaMuFromTheLawTest(unittest.TestCase):
    """Regime C runs of test_boundary_laws' campaign: bottom layer sheared with dv = V, top
    layer dv = 0.001 V; the B and C layers follow mu = 0.2 + 0.4 (h I_b)^0.5."""

    @classmethod
    def setUpClass(cls):
        cls.rows = campaign_rows()
        for r in cls.rows:
            r["L_y"] = 20.0
        cls.fits = report.fit_laws(cls.rows)
        cls.boundary = bl.fit_boundary(cls.rows, report.FITS)
        cls.switch = predictions_c(cls.rows, cls.fits, cls.boundary)

    def test_delta_mu_from_the_law_at_the_walls_velocity_jumps(self):
        self.assertEqual(len(self.switch), 4)    # two C velocities, two systems
        law = self.boundary["all_h"]["mu_hI_BC"]
        p = [v["value"] for v in law["parameters"].values()]
        for e in self.switch:
            d = e["delta_mu_law"]
            self.assertEqual(d["status"], "ok", d["reason"])
            self.assertEqual(sorted(d["by_h"]), ["h3", "h5", "h7"])
            for label, x in d["by_h"].items():
                V = e["V"]
                truth = BC_LAW["A"] * ((SCALE * V) ** 0.5 - (SCALE * 0.001 * V) ** 0.5)
                # by hand from the fitted law
                hand = abs(mu_law(SCALE * V, *p) - mu_law(SCALE * 0.001 * V, *p))
                self.assertAlmostEqual(x["delta_mu"], hand, places=10)
                self.assertAlmostEqual(x["hI_bottom"], SCALE * V)
                lo, hi = x["interval"]
                self.assertTrue(lo < x["delta_mu"] < hi)
                self.assertLess(abs(x["delta_mu"] - truth), 2 * (hi - lo), label)
                # T of that delta_mu: 2 rho nu V L_y / (delta_mu sigma_yy)
                self.assertAlmostEqual(x["predicted_T"], tr.switch_time(
                    V, 20.0, e["nu_bulk"], x["delta_mu"], 0.25))
                self.assertLess(x["predicted_T_interval"][0], x["predicted_T"])
                self.assertGreater(x["predicted_T_interval"][1], x["predicted_T"])
                # the top layer (dv = 0.001 V) lies far below the law's points
                self.assertIn("top h I_b", x["note"])
                self.assertIn("extrapolated", x["note"])
                self.assertIs(x["extrapolated"], True)
                self.assertIs(x["mu_negative"], False)   # 0.2 + 0.4 sqrt(h I_b) > 0
            # the prediction's delta_mu is the law's at the h nearest 10; the plateau's net
            # friction is summary.json's (none here)
            best = min(e["delta_mu_law"]["by_h"].values(), key=lambda x: abs(x["h"] - 10.0))
            self.assertEqual(e["delta_mu"], best["delta_mu"])
            self.assertEqual(e["predicted_T"], best["predicted_T"])
            self.assertIsNone(e["delta_mu_plateau"])

    def test_a_wrong_law_is_caught(self):
        # the prediction follows the law: a law twice as steep doubles delta_mu
        boundary = json.loads(json.dumps(self.boundary))
        boundary["all_h"]["mu_hI_BC"]["parameters"]["A"]["value"] *= 2
        e = predictions_c(self.rows, self.fits, boundary)[0]["delta_mu_law"]["by_h"]["h5"]
        ref = self.switch[0]["delta_mu_law"]["by_h"]["h5"]
        self.assertAlmostEqual(e["delta_mu"], 2 * ref["delta_mu"])

    def test_without_a_law_or_a_velocity_jump_it_says_why(self):
        skipped = json.loads(json.dumps(self.boundary))
        skipped["all_h"]["mu_hI_BC"].update(status="skipped", reason="too few points: 2")
        d = predictions_c(self.rows, self.fits, skipped)[0]["delta_mu_law"]
        self.assertEqual(d["status"], "not available")
        self.assertIn("mu_hI_BC is skipped: too few points", d["reason"])
        (e,) = tr.switch_predictions([self.c_row()])
        self.assertEqual(e["delta_mu_law"]["status"], "not available")
        row = dict(self.c_row(), h5_top_velocity_jump=None)
        d = bl.predict_delta_mu(row, self.boundary)
        self.assertIsNone(d["by_h"]["h5"]["delta_mu"])
        self.assertIn("no velocity jump of the top layer", d["by_h"]["h5"]["reason"])
        self.assertIsNotNone(d["by_h"]["h3"]["delta_mu"])

    def test_a_jump_without_a_finite_error_is_drawn_without_scatter(self):
        # NaN or None as the error of a velocity jump: the draws use the jump itself (error 0),
        # not NaN draws
        rows = {}
        for err in (0.0, math.nan, None):
            row = dict(self.c_row())
            for label in ("h3", "h5", "h7"):
                for s in ("bottom", "top"):
                    row[f"{label}_{s}_velocity_jump_err"] = err
            rows[err if err is None or err == 0 else "nan"] = bl.predict_delta_mu(
                row, self.boundary)
        for label in ("h3", "h5", "h7"):
            iv = rows[0.0]["by_h"][label]["interval"]
            self.assertTrue(iv and all(math.isfinite(v) for v in iv), iv)
            self.assertEqual(rows["nan"]["by_h"][label]["interval"], iv)
            self.assertEqual(rows[None]["by_h"][label]["interval"], iv)

    def test_the_flags_are_keys_that_the_html_reads(self):
        d = bl.predict_delta_mu(self.c_row(), self.boundary)
        for e in d["by_h"].values():
            e["predicted_T"] = None     # (transitions fills it in)

        def h5_cell():
            return next(c for c in report._delta_mu_law_text(d, report._Footnotes()).split("<br>")
                        if c.startswith("h5: "))
        self.assertIn("<small>(extrapolated)</small>", h5_cell())
        # the flags come from the keys, not from the note's text
        d["by_h"]["h5"].update(extrapolated=False, mu_negative=True, note="extrapolated, < 0")
        self.assertIn("<small>(mu &lt; 0)</small>", h5_cell())
        d["by_h"]["h5"].update(mu_negative=False)
        self.assertNotIn("<small>", h5_cell())

    def test_a_law_at_its_bound_gives_no_interval(self):
        boundary = json.loads(json.dumps(self.boundary))
        boundary["all_h"]["mu_hI_BC"]["note"] = "B at the bound of its range"
        d = bl.predict_delta_mu(self.c_row(), boundary)
        self.assertEqual(d["law_note"], "B at the bound of its range")
        self.assertIsNone(d["by_h"]["h5"]["interval"])
        self.assertIn("no interval", d["by_h"]["h5"]["interval_note"])
        self.assertIsNotNone(d["by_h"]["h5"]["delta_mu"])

    def c_row(self):
        return next(r for r in self.rows if r["regime"] == "C")


def predictions_c(rows, fits, boundary):
    return tr.predictions(rows, fits, boundary)["switch_time_C"]


if __name__ == "__main__":
    unittest.main()

"""The campaign report: rows from fake summary.json files, the fits, runs left out, index.html."""
import contextlib
import csv
import io
import json
import os
import re
import shutil
import tempfile
import time
import unittest

import numpy as np

from cdshear_analysis import campaign_figures, report
from cdshear_analysis.__main__ import main as cli_main
from cdshear_analysis.summary import SUMMARY_FORMAT, SUMMARY_VERSION
from cdshear_analysis.synthetic import write_synthetic_run


def main(argv):
    """The command line, its printed paths kept out of the test output."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        return cli_main(argv)


def entry(mean, err):
    return {"mean": mean, "err": err}


def fake_summary(run_dir, V, I, mu, nu, Z, errs=(0.003, 0.002, 0.02), steady=True, regime="A",
                 layers=(5.0, 10.0), bulk_reference=True):
    """A run folder with the parts of summary.json (docs/analysis.md) that a report reads."""
    os.makedirs(run_dir, exist_ok=True)
    e_mu, e_nu, e_z = errs
    layer = {"mu_eff": entry(mu + 0.05, e_mu), "solid_fraction": entry(nu - 0.03, e_nu),
             "coordination": entry(Z - 0.2, e_z), "velocity_jump": entry(0.3 * V, 0.01 * V),
             "inertial_number": entry(3 * I, 0.1 * I)}
    s = {
        "format": SUMMARY_FORMAT, "version": SUMMARY_VERSION, "run_dir": run_dir,
        "case": {"n": 511, "velocity": V, "normal_stress": 0.25, "length_x": 20.0,
                 "height": 20.0, "duration": 1000.0, "time": 1000.0, "finished": True,
                 "window": 80.0, "boundary_thickness": list(layers)},
        "steady": steady, "steady_reason": "transient over at t = 100" if steady else
        "a series still drifts", "transient_end_time": 100.0, "transient_end_strain": 5.0,
        "regime": regime, "regime_confidence": 0.9,
        "mu_eff_wall": entry(mu, e_mu), "height": entry(20.1, 0.01),
        "solid_fraction": entry(nu, e_nu),
        # the bulk of the laws: the h = 10 of model.md section 7 (bulk_h_reference) unless the test
        # says otherwise
        "bulk": {"h": 10.0, "h_reference": bulk_reference,
                 "h_note": None if bulk_reference else ("bulk at h = 5, not the h = 10 of model.md "
                                                        "section 7: the cell is too thin"),
                 "y_range": [10, 10.1], "mu_eff": entry(mu, e_mu),
                 "solid_fraction": entry(nu, e_nu), "coordination": entry(Z, e_z),
                 "shear_rate": entry(I * 0.5, I * 0.01), "inertial_number": entry(I, 0.01 * I)},
        "slip": {"bottom": entry(0.1 * V, 0.01 * V), "top": entry(0.12 * V, 0.01 * V)},
        "com_vx": {"mean": 0.02 * V, "err": 0.01 * V, "std": 0.1 * V},
        "regions": {report._h_label(h): {"h": h, "bulk": {}, "bottom": layer, "top": layer}
                    for h in layers},
        "switches": [], "switch_duration": entry(None, None),
    }
    with open(os.path.join(run_dir, "summary.json"), "w") as f:
        json.dump(s, f)
    return s


def fake_campaign(d, name, system_runs, listed_extra=()):
    """campaign.toml as `cdshear sweep` writes it (name + the runs' comment) and the run folders
    of system_runs: {system: [(V, I, mu, nu, Z), ...]}."""
    names = []
    for system, runs in system_runs.items():
        for V, I, mu, nu, Z in runs:
            run = f"s{system}_seed1_V{V:.6g}"
            names.append(run)
            fake_summary(os.path.join(d, "runs", run), V, I, mu, nu, Z)
    with open(os.path.join(d, "campaign.toml"), "w") as f:
        f.write("# Resolved campaign written by cdshear 0.1.0 sweep; fingerprint 0\n"
                f"[campaign]\nname = '{name}'\nsystems = [1]\n"
                f"velocities = [1.0]\nseeds = [1]\nduration = 1000.0\n\n[set]\n\n"
                "# Runs (name, duration [t], dt [t], cost n x duration / dt):\n")
        for run in names + list(listed_extra):
            f.write(f"#   {run}  duration 1000  dt 0.001  cost 5.1e+08\n")


@contextlib.contextmanager
def edited_summary(campaign_dir, run):
    """RUN's summary.json in campaign_dir as a dict to edit, written back on leaving."""
    path = os.path.join(campaign_dir, "runs", run, "summary.json")
    with open(path) as f:
        summary = json.load(f)
    yield summary
    with open(path, "w") as f:
        json.dump(summary, f)


def within(test, fit, truth, sigmas=2.0):
    for p, value in truth.items():
        got = fit["parameters"][p]
        test.assertLessEqual(abs(got["value"] - value), sigmas * got["err"],
                             f"{p}: {got['value']} ± {got['err']}, truth {value}")


class ReportTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.d = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def power_law_campaign(self, seed=7):
        """Two systems, 16 runs, I from 0.003 to 0.3: mu = 0.25 + 0.5 I^0.6, nu = 0.82 - 0.35 I,
        Z = 3.2 - 2.0 I^0.7, each with Gaussian noise of its error bar."""
        rng = np.random.default_rng(seed)
        self.truth = {"mu_power": {"mu_0": 0.25, "A": 0.5, "B": 0.6},
                      "nu_linear": {"nu_max": 0.82, "c": 0.35},
                      "Z_power": {"Z_0": 3.2, "c": 2.0, "e": 0.7}}
        runs = {1: [], 2: []}
        for k, I in enumerate(np.geomspace(0.003, 0.3, 16)):
            runs[1 + k % 2].append((float(10 * I), float(I),
                                    0.25 + 0.5 * I ** 0.6 + 0.003 * rng.standard_normal(),
                                    0.82 - 0.35 * I + 0.002 * rng.standard_normal(),
                                    3.2 - 2.0 * I ** 0.7 + 0.02 * rng.standard_normal()))
        fake_campaign(self.d, "test_campaign", runs)

    def test_a_run_folder_or_the_runs_folder_is_refused_as_the_report_folder(self):
        self.power_law_campaign()
        run = os.path.join(self.d, "runs", "s1_seed1_V0.03")
        os.makedirs(os.path.join(run, "figures"))
        with open(os.path.join(run, "figures", "profiles.png"), "w") as f:
            f.write("the run's own figure")
        before = sorted(os.listdir(run))
        other_run = os.path.join(self.d, "another_campaigns_run")  # a run of no campaign here
        fake_summary(other_run, 0.1, 0.01, 0.3, 0.8, 3.0)
        err = io.StringIO()
        other_campaign = os.path.join(self.d, "another_campaign")  # run folders in runs/
        fake_summary(os.path.join(other_campaign, "runs", "s1_seed1_V0.03"), 0.1, 0.01, 0.3, 0.8,
                     3.0)
        for out in (run, os.path.join(self.d, "runs"), os.path.join(self.d, "runs", "new"),
                    other_run, self.d, other_campaign):
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
                self.assertEqual(cli_main(["report", self.d, "-o", out]), 2, out)
        self.assertIn("holds a run's files (summary.json)", err.getvalue())
        self.assertIn("is inside the campaign's runs folder", err.getvalue())
        self.assertEqual(err.getvalue().count("is a campaign's folder (campaign.toml or run "
                                              "folders in runs/)"), 2)
        self.assertEqual(sorted(os.listdir(run)), before)
        self.assertFalse(os.path.exists(os.path.join(self.d, "runs.csv")))
        self.assertFalse(os.path.exists(os.path.join(other_campaign, "runs.csv")))
        with open(os.path.join(run, "figures", "profiles.png")) as f:
            self.assertEqual(f.read(), "the run's own figure")
        self.assertFalse(os.path.exists(os.path.join(self.d, "runs", "new")))
        self.assertFalse(os.path.exists(os.path.join(self.d, "runs", "runs.csv")))
        self.assertEqual(os.listdir(other_run), ["summary.json"])
        # no folder: named as what it is (a link into a loop said "cannot write" after the
        # whole report was made)
        loop = os.path.join(self.d, "loop")
        os.symlink(loop, loop)
        for out, what in ((os.devnull, "a device or socket"),
                          (os.path.join(self.d, "campaign.toml"), "a file"),
                          (loop, "a link that cannot be followed")):
            err = io.StringIO()
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
                self.assertEqual(cli_main(["report", self.d, "-o", out]), 2, out)
            self.assertIn(f"error: {out}: -o: is {what}", err.getvalue())
            self.assertIn("not a folder", err.getvalue())
        os.remove(loop)
        # elsewhere, the same report is written
        self.assertEqual(main(["report", self.d, "-o", os.path.join(self.d, "elsewhere")]), 0)

    def test_a_run_figure_that_cannot_be_read_is_left_out_and_nothing_is_half_new(self):
        self.power_law_campaign()
        figures = os.path.join(self.d, "runs", "s1_seed1_V0.03", "figures")
        os.makedirs(figures)
        with open(os.path.join(figures, "profiles.png"), "wb") as f:
            f.write(b"the run's own figure")
        dangling = os.path.join(figures, "zz.png")
        os.symlink(os.path.join(self.d, "nonexistent"), dangling)
        out = io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
            self.assertEqual(cli_main(["report", self.d]), 0)
        self.assertIn(f"note: {dangling}: is a link that cannot be followed", out.getvalue())
        copies = os.path.join(self.d, "report", "runs", "s1_seed1_V0.03")
        self.assertEqual(os.listdir(copies), ["profiles.png"])
        # A copy that cannot be written fails before any file of the report is replaced.
        os.remove(os.path.join(copies, "profiles.png"))
        os.makedirs(os.path.join(copies, "profiles.png", "x"))
        made = os.path.join(self.d, "report")
        before = {n: os.stat(os.path.join(made, n)).st_ino for n in
                  ["fits.json", "index.html", "runs.csv"]
                  + ["figures/" + f for f in os.listdir(os.path.join(made, "figures"))]}
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            self.assertEqual(cli_main(["report", self.d]), 1)
        self.assertIn(os.path.join(copies, "profiles.png"), err.getvalue())
        self.assertEqual({n: os.stat(os.path.join(made, n)).st_ino for n in before}, before)

    def test_a_report_of_another_campaign_is_not_replaced(self):
        self.power_law_campaign()
        other = os.path.join(self.d, "other")
        fake_campaign(other, "other_campaign", {1: [(0.5, 0.025, 0.35, 0.8, 3.0)]})
        out = os.path.join(self.d, "shared_report")
        self.assertEqual(main(["report", self.d, "-o", out]), 0)
        self.assertEqual(main(["report", self.d, "-o", out]), 0)   # its own: written again
        with open(os.path.join(out, "fits.json"), "rb") as f:
            before = f.read()
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            self.assertEqual(cli_main(["report", other, "-o", out]), 2)
        self.assertIn(f"error: {out}: holds the report of campaign 'test_campaign'",
                      err.getvalue())
        self.assertIn("not of 'other_campaign'", err.getvalue())
        with open(os.path.join(out, "fits.json"), "rb") as f:
            self.assertEqual(f.read(), before)

    def test_power_law_fits_recover_the_parameters(self):
        self.power_law_campaign()
        self.assertEqual(main(["report", self.d]), 0)
        with open(os.path.join(self.d, "report", "fits.json")) as f:
            fits = json.load(f)
        self.assertEqual(fits["format"], "cdshear-report-fits")
        self.assertEqual(fits["campaign"], "test_campaign")
        for name, truth in self.truth.items():
            fit = fits["fits"][name]
            self.assertEqual(fit["status"], "ok", fit["reason"])
            within(self, fit, truth)
            self.assertLess(fit["chi2_dof"], 3.0)
        self.assertEqual(fits["fits"]["mu_power"]["n_points"], 16)
        # only 0.03 < I < 0.2 for the linear ones
        self.assertEqual(fits["fits"]["nu_linear"]["n_points"],
                         sum(1 for I in np.geomspace(0.003, 0.3, 16) if 0.03 < I < 0.2))
        # a wrong truth is caught: the test can fail
        with self.assertRaises(AssertionError):
            within(self, fits["fits"]["mu_power"], {"mu_0": 0.27})

    def test_linear_fit_recovers_the_parameters_on_its_range_only(self):
        rng = np.random.default_rng(3)
        runs = {1: []}
        for I in np.geomspace(0.005, 0.5, 20):
            # linear inside 0.03 < I < 0.2; far off outside, so that a fit not restricted to
            # the range misses the parameters
            mu = 0.28 + 0.9 * I if 0.03 < I < 0.2 else 0.1
            runs[1].append((float(I), float(I), mu + 0.003 * rng.standard_normal(), 0.8, 3.0))
        fake_campaign(self.d, "lin", runs)
        rows = report.collect(self.d)["rows"]
        fit = report.fit_law("mu_linear", rows)
        self.assertEqual(fit["status"], "ok", fit["reason"])
        within(self, fit, {"a": 0.28, "b": 0.9})
        self.assertEqual(fit["range"], [0.03, 0.2])
        self.assertTrue(all(0.03 < r["I_bulk"] < 0.2 for r in rows if r["run"] in fit["runs"]))

    def test_parameter_errors_follow_the_error_bars(self):
        # absolute_sigma: twice the error bars on the same points give twice the errors (a fit
        # that rescaled them by its scatter would give the same errors both times)
        self.power_law_campaign()
        rows = report.collect(self.d)["rows"]
        first = report.fit_law("mu_power", rows)
        for r in rows:
            r["mu_eff_bulk_err"] *= 2
        second = report.fit_law("mu_power", rows)
        for p in ("mu_0", "A", "B"):
            self.assertAlmostEqual(second["parameters"][p]["value"],
                                   first["parameters"][p]["value"], places=5)
            self.assertAlmostEqual(second["parameters"][p]["err"] / first["parameters"][p]["err"],
                                   2.0, places=3)
        self.assertAlmostEqual(second["chi2"], first["chi2"] / 4, places=6)

    def test_nan_values_are_left_out(self):
        # Python's json writes and reads NaN; a summary edited by hand may hold it
        self.power_law_campaign()
        with edited_summary(self.d, "s1_seed1_V0.03") as s:
            s["bulk"]["mu_eff"]["mean"] = float("nan")
        huge = next(r for r in sorted(os.listdir(os.path.join(self.d, "runs")))
                    if r != "s1_seed1_V0.03")
        with edited_summary(self.d, huge) as s:
            s["bulk"]["mu_eff"]["mean"] = 1e300   # its square would overflow a seeds' scatter
        rows = report.collect(self.d)["rows"]
        self.assertIn("s1_seed1_V0.03", [r["run"] for r in rows])
        self.assertIsNone(next(r for r in rows if r["run"] == huge)["mu_eff_bulk"])
        fit = report.fit_law("mu_power", rows)
        self.assertEqual((fit["status"], fit["n_points"]), ("ok", 14))   # 16 runs, 2 left out
        self.assertEqual(main(["report", self.d]), 0)

    def test_not_steady_runs_are_not_fitted(self):
        self.power_law_campaign()
        rows = report.collect(self.d)["rows"]
        for r in rows[:10]:
            r["steady"] = False
        fit = report.fit_law("mu_power", rows)
        self.assertEqual(fit["n_points"], 6)
        self.assertNotIn(rows[0]["run"], fit["runs"])

    def test_too_few_points_skip_the_fit_with_the_reason(self):
        fake_campaign(self.d, "few", {1: [(0.1, 0.05, 0.3, 0.8, 3.0), (0.2, 0.1, 0.33, 0.79,
                                                                        2.9),
                                          (0.4, 0.15, 0.36, 0.78, 2.8)]})
        self.assertEqual(main(["report", self.d]), 0)
        with open(os.path.join(self.d, "report", "fits.json")) as f:
            fits = json.load(f)["fits"]
        self.assertEqual(fits["mu_power"]["status"], "skipped")   # 3 points, 3 parameters
        self.assertIn("too few points: 3", fits["mu_power"]["reason"])
        self.assertIsNone(fits["mu_power"]["parameters"])
        self.assertEqual(fits["mu_linear"]["status"], "ok")       # 3 points, 2 parameters
        with open(os.path.join(self.d, "report", "index.html")) as f:
            self.assertIn("<b>skipped</b><br><small>too few points: 3", f.read())

    def test_degenerate_points_skip_the_fit_instead_of_giving_no_errors(self):
        # four runs at the same I: a line through them is not determined
        fake_campaign(self.d, "same", {1: [(v, 0.1, 0.3 + 0.01 * k, 0.8, 3.0)
                                           for k, v in enumerate((0.1, 0.2, 0.4, 0.8))]})
        self.assertEqual(main(["report", self.d]), 0)
        with open(os.path.join(self.d, "report", "fits.json")) as f:
            fits = json.load(f)["fits"]
        self.assertEqual(fits["mu_linear"]["status"], "skipped")
        self.assertIn("covariance not estimable", fits["mu_linear"]["reason"])

    def test_runs_not_analysed_or_not_started_are_listed_and_left_out(self):
        fake_campaign(self.d, "partial", {1: [(0.1, 0.05, 0.3, 0.8, 3.0)]},
                      listed_extra=["s1_seed1_V1", "s1_seed1_V10"])
        os.makedirs(os.path.join(self.d, "runs", "s1_seed1_V1"))   # running: no summary.json
        r = report.collect(self.d)
        self.assertEqual([row["run"] for row in r["rows"]], ["s1_seed1_V0.1"])
        skipped = dict(r["skipped"])
        self.assertIn("not analysed", skipped["s1_seed1_V1"])
        self.assertIn("not started", skipped["s1_seed1_V10"])
        self.assertEqual(main(["report", self.d, "-o", os.path.join(self.d, "out")]), 0)
        with open(os.path.join(self.d, "out", "index.html")) as f:
            text = f.read()
        self.assertIn("s1_seed1_V1: not analysed", text)
        with open(os.path.join(self.d, "out", "runs.csv")) as f:
            self.assertEqual(len(list(csv.DictReader(f))), 1)

    def test_a_run_still_going_or_stopped_is_named_so(self):
        fake_campaign(self.d, "partial", {1: [(0.1, 0.05, 0.3, 0.8, 3.0)]},
                      listed_extra=["s1_seed1_V1", "s1_seed1_V2", "s1_seed1_V3"])
        now = time.time()
        for run, state, updated in (("s1_seed1_V1", "running", now - 1),
                                    ("s1_seed1_V2", "running", now - 3600),
                                    ("s1_seed1_V3", "stopped", now - 3600)):
            os.makedirs(os.path.join(self.d, "runs", run))
            with open(os.path.join(self.d, "runs", run, "progress.json"), "w") as f:
                json.dump({"format": "cdshear-progress", "version": 1, "state": state,
                           "step": 137000, "time": 685.0, "duration": 16000.0,
                           "updated_unix_seconds": updated}, f)
        skipped = dict(report.collect(self.d)["skipped"])
        self.assertEqual(skipped["s1_seed1_V1"],
                         "still running (t = 685 of 16000, progress.json): analysed at its end")
        self.assertIn("t = 685 of 16000; progress.json: running, not updated for 36",
                      skipped["s1_seed1_V2"])
        self.assertIn("killed or paused", skipped["s1_seed1_V2"])
        self.assertIn("stopped before its end (t = 685 of 16000; progress.json: stopped)",
                      skipped["s1_seed1_V3"])
        progress = os.path.join(self.d, "runs", "s1_seed1_V3", "progress.json")

        def reason(text):
            with open(progress, "w") as f:
                f.write(text)
            return dict(report.collect(self.d)["skipped"])["s1_seed1_V3"]

        good = dict(state="blown up", time=685.0, duration=16000.0, updated_unix_seconds=now)
        self.assertIn("blew up (t = 685 of 16000, progress.json)", reason(json.dumps(good)))
        self.assertIn("remove the folder", reason(json.dumps(good)))
        # a progress.json that cannot be used: the plain reason, and why
        for text, why in (("{", "cannot be read"), ("[1]", "not a JSON object"),
                          (json.dumps(dict(good, state=None)), "state is 'None'"),
                          (json.dumps(dict(good, time="685")), "not a valid number"),
                          (json.dumps(dict(good, duration=-5.0)), "not a valid number"),
                          (json.dumps(dict(good, time=10 ** 400)), "cannot be read"),
                          ("[" * 100000 + "]" * 100000, "cannot be read")):
            with self.subTest(why=why):
                got = reason(text)
                self.assertIn("not analysed: no summary.json", got)
                self.assertIn("; its progress.json: ", got)
                self.assertIn(why, got)

    def test_a_run_analysed_before_its_end_is_marked(self):
        fake_campaign(self.d, "partial", {1: [(0.1, 0.05, 0.3, 0.8, 3.0),
                                              (0.2, 0.08, 0.32, 0.79, 2.9)]})
        with edited_summary(self.d, "s1_seed1_V0.2") as s:
            s["case"].update(finished=False, time=650.0, duration=16000.0)
        r = report.collect(self.d)
        self.assertEqual(len(r["rows"]), 2)        # kept, and said
        note = [n for n in r["notes"] if n.startswith("not finished")]
        self.assertEqual(len(note), 1)
        self.assertIn("s1_seed1_V0.2 (t = 650 of 16000)", note[0])
        self.assertNotIn("s1_seed1_V0.1", note[0])
        self.assertIn("| s1_seed1_V0.2 (not finished: t = 650 of 16000) |",
                      report.runs_markdown(r["rows"], "partial"))
        self.assertNotIn("s1_seed1_V0.1 (not", report.runs_markdown(r["rows"], "partial"))
        # the run has ended since (progress.json): the summary is outdated, analysed again
        # from run.h5 (there is none here: left out, saying why)
        with open(os.path.join(self.d, "runs", "s1_seed1_V0.2", "progress.json"), "w") as f:
            json.dump({"state": "finished", "time": 16000.0, "duration": 16000.0,
                       "updated_unix_seconds": time.time()}, f)
        skipped = dict(report.collect(self.d)["skipped"])
        self.assertIn("summary.json is of t = 650, before the run's end at t = 16000 "
                      "(progress.json) and there is no run.h5", skipped["s1_seed1_V0.2"])

    def test_no_analysed_run_is_an_error_that_leaves_an_earlier_report_alone(self):
        fake_campaign(self.d, "running", {}, listed_extra=["s1_seed1_V1"])
        os.makedirs(os.path.join(self.d, "runs", "s1_seed1_V1"))   # running: no summary.json
        out = os.path.join(self.d, "out")
        os.makedirs(out)
        with open(os.path.join(out, "index.html"), "w") as f:
            f.write("an earlier report")
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            self.assertEqual(cli_main(["report", self.d, "-o", out]), 2)
        self.assertIn("s1_seed1_V1: not analysed", err.getvalue())
        self.assertIn("no analysed run", err.getvalue())
        self.assertEqual(os.listdir(out), ["index.html"])
        with open(os.path.join(out, "index.html")) as f:
            self.assertEqual(f.read(), "an earlier report")

    def test_a_failed_report_leaves_the_earlier_one_whole(self):
        """A report that fails half-way (here in its fits) writes no file: each is made first and
        then replaces the earlier one whole, so runs.md is not left empty beside an old
        fits.json."""
        self.power_law_campaign()
        out = os.path.join(self.d, "report")
        self.assertEqual(main(["report", self.d]), 0)
        before = {}
        for name in ("runs.csv", "runs.md", "fits.json", "index.html"):
            with open(os.path.join(out, name), "rb") as f:
                before[name] = f.read()
        runs = os.path.join(self.d, "runs")
        shutil.rmtree(os.path.join(runs, sorted(os.listdir(runs))[0]))   # a table that differs
        fit_laws = report.fit_laws

        def failing(rows):
            raise RuntimeError("a fit that fails")
        report.fit_laws = failing
        try:
            with self.assertRaisesRegex(RuntimeError, "a fit that fails"):
                report.write_report(report.collect(self.d), out)
        finally:
            report.fit_laws = fit_laws
        for name, data in before.items():
            with open(os.path.join(out, name), "rb") as f:
                self.assertEqual(f.read(), data, name)
        self.assertEqual([n for n in os.listdir(out) if n.endswith(".tmp")], [])

    def test_a_regime_that_is_not_a_text_is_no_regime(self):
        """A damaged summary's regime (a number, a list) is left blank, not joined as text."""
        fake_campaign(self.d, "damaged", {1: [(0.1, 0.05, 0.3, 0.8, 3.0)]})
        with edited_summary(self.d, "s1_seed1_V0.1") as summary:
            summary["regime"] = 5
        self.assertEqual(main(["report", self.d, "-o", os.path.join(self.d, "out")]), 0)
        self.assertIsNone(report.collect(self.d)["rows"][0]["regime"])

    def test_a_campaign_runs_files_are_not_written_over_without_run_h5(self):
        """A committed campaign keeps case.toml, summary.json and run_info.json without run.h5:
        they are a run's all the same, and an output naming one of them is refused."""
        from cdshear_analysis.rundata import output_problem
        run = os.path.join(self.d, "runs", "s1_seed1_V0.1")
        fake_summary(run, 0.1, 0.05, 0.3, 0.8, 3.0)
        for name in ("case.toml", "run_info.json"):
            with open(os.path.join(run, name), "w") as f:
                f.write("{}\n")
        for name in ("summary.json", "case.toml", "run_info.json"):
            self.assertIn("is a run's own file", output_problem(os.path.join(run, name)) or "")
        self.assertIsNone(output_problem(os.path.join(run, "other.json")))
        lone = os.path.join(self.d, "lone")
        os.makedirs(lone)
        with open(os.path.join(lone, "summary.json"), "w") as f:
            f.write("{}\n")
        self.assertIsNone(output_problem(os.path.join(lone, "summary.json")))

    def test_state_campaign_and_packing_files_are_not_written_over(self):
        """A run's sitting records, a campaign's (or any) TOML file and a packing are refused as
        outputs: `switch-times --json` once replaced a campaign.toml and its packings."""
        from cdshear_analysis.rundata import output_problem
        run = os.path.join(self.d, "runs", "s1_seed1_V0.1")
        fake_summary(run, 0.1, 0.05, 0.3, 0.8, 3.0)
        with open(os.path.join(run, "case.toml"), "w") as f:
            f.write("[shear]\n")
        for name in ("progress.json", "interrupted_state.json", "blowup_state.json",
                     "run_info_resume_400.json", "run_info_resume_400_2.json"):
            with open(os.path.join(run, name), "w") as f:
                f.write("{}\n")
            self.assertIn("is a run's own file", output_problem(os.path.join(run, name)) or "")
        campaign = os.path.join(self.d, "campaign.toml")
        with open(campaign, "w") as f:
            f.write("[campaign]\n")
        self.assertIn("is a TOML file", output_problem(campaign) or "")
        self.assertIsNone(output_problem(os.path.join(self.d, "new.toml")))
        packing = os.path.join(self.d, "p.json")
        with open(packing, "w") as f:  # as `cdshear prepare` writes it: keys in order
            f.write('{"disks_xyr": [' + ", ".join(["[1.0, 2.0, 0.5]"] * 2000) +
                    '], "format": "cdshear-packing", "n": 2000}\n')
        self.assertIn("is a cdshear packing", output_problem(packing) or "")
        other = os.path.join(self.d, "other.json")
        with open(other, "w") as f:
            f.write('{"format": "something else"}\n')
        self.assertIsNone(output_problem(other))

    def test_a_run_folder_that_is_a_file_or_a_loop_is_named_as_such(self):
        fake_campaign(self.d, "odd", {1: [(0.1, 0.05, 0.3, 0.8, 3.0)]},
                      listed_extra=["s1_seed1_V1", "s1_seed1_V2"])
        runs = os.path.join(self.d, "runs")
        open(os.path.join(runs, "s1_seed1_V1"), "w").close()
        os.symlink("s1_seed1_V2", os.path.join(runs, "s1_seed1_V2"))
        skipped = dict(report.collect(self.d)["skipped"])
        self.assertEqual(skipped["s1_seed1_V1"], "not a run folder: a file")
        self.assertIn("a link that cannot be followed", skipped["s1_seed1_V2"])
        shutil.rmtree(runs)
        open(runs, "w").close()
        with self.assertRaisesRegex(report.ReportError, "is a file, not the folder of the runs"):
            report.collect(self.d)

    def test_a_run_folder_is_named_as_one(self):
        # a run's own folder given where a campaign's is expected: said so, with what to run
        run = os.path.join(self.d, "s1_seed1_V0.5")
        fake_summary(run, 0.5, 0.01, 0.3, 0.8, 3.0)
        open(os.path.join(run, "case.toml"), "w").close()
        with self.assertRaisesRegex(report.ReportError, "cdshear analyze") as caught:
            report.collect(run)
        self.assertEqual(caught.exception.path, run)
        self.assertIn("is a run's folder (it holds case.toml)", caught.exception.problem)
        # an empty folder is not taken for one
        empty = os.path.join(self.d, "empty")
        os.makedirs(empty)
        with self.assertRaisesRegex(report.ReportError, "no run folders"):
            report.collect(empty)

    def test_a_copy_of_a_run_inside_runs_is_noted(self):
        fake_campaign(self.d, "copied", {1: [(0.1, 0.05, 0.3, 0.8, 3.0)]})
        fake_summary(os.path.join(self.d, "runs", "s1_seed1_V0.10"), 0.1, 0.05, 0.3, 0.8, 3.0)
        r = report.collect(self.d)
        self.assertEqual(len(r["rows"]), 2)
        self.assertTrue(any("s1_seed1_V0.1, s1_seed1_V0.10 are the same run" in n
                            for n in r["notes"]), r["notes"])

    def test_profile_labels_name_the_seed_where_several_runs_share_a_v(self):
        rows = [{"V": 0.1, "seed": 1, "regime": "B", "steady": False},
                {"V": 0.1, "seed": 2, "regime": "B", "steady": True},
                {"V": 1.0, "seed": 1, "regime": "A", "steady": True},
                {"V": 1.0, "seed": None, "run": "custom", "regime": None, "steady": True},
                {"V": 2.0, "seed": 3, "run": "x_seed3", "regime": "A", "steady": True},
                {"V": 2.0, "seed": 3, "run": "y_seed3", "regime": "A", "steady": True},
                {"V": None, "seed": 1, "run": "noV", "regime": "A", "steady": True}]
        self.assertEqual(campaign_figures.profile_labels(rows),
                         ["V = 0.1, seed 1 (B, not steady)", "V = 0.1, seed 2 (B)",
                          "V = 1, seed 1 (A)", "V = 1, custom (?)",
                          "V = 2, x_seed3 (A)", "V = 2, y_seed3 (A)", "V = ? (A)"])
        self.assertEqual(campaign_figures.profile_labels(rows[2:3]), ["V = 1 (A)"])

    def test_index_references_only_files_that_exist(self):
        self.power_law_campaign()
        out = os.path.join(self.d, "report")
        self.assertEqual(main(["report", self.d]), 0)
        with open(os.path.join(out, "index.html")) as f:
            text = f.read()
        self.assertIn("<h1>Campaign test_campaign</h1>", text)
        # the resolved campaign file and what made the runs (no run_info.json in fake runs)
        self.assertIn("The resolved campaign file (campaign.toml)", text)
        self.assertIn("name = &#x27;test_campaign&#x27;", text)
        self.assertIn("unknown (no readable run_info.json) (16 runs)", text)
        self.assertIn("<p>16 analysed runs (", text)
        self.assertIn("Campaign resolved by cdshear 0.1.0", text)
        refs = re.findall(r"(?:src|href)='([^']+)'", text)
        images = [r for r in refs if r.endswith(".png")]
        # every figure written is shown, and nothing else (no profiles: fake summaries lack them)
        self.assertEqual(sorted(images), sorted(
            "figures/" + f for f in os.listdir(os.path.join(out, "figures"))))
        self.assertGreaterEqual(len(images), 12)
        for ref in refs:
            self.assertFalse(os.path.isabs(ref) or ref.startswith(".."), ref)
            self.assertTrue(os.path.isfile(os.path.join(out, ref)), ref)

    def test_missing_quantities_give_empty_cells(self):
        fake_campaign(self.d, "holes", {1: [(0.1, 0.05, 0.3, 0.8, 3.0),
                                            (0.2, 0.1, 0.33, 0.79, 2.9)]})
        with edited_summary(self.d, "s1_seed1_V0.2") as s:
            del s["slip"], s["regions"], s["regime_confidence"]
            s["bulk"]["coordination"] = {"mean": None, "err": None}   # NaN is written as null
            s["bulk"]["solid_fraction"]["err"] = None                  # single window: no error
            s["regime"] = None
            s["com_vx"] = {"mean": "0.1", "err": None, "std": -0.01}  # a text, none, negative
        self.assertEqual(main(["report", self.d]), 0)
        with open(os.path.join(self.d, "report", "runs.csv")) as f:
            rows = {r["run"]: r for r in csv.DictReader(f)}
        full, holes = rows["s1_seed1_V0.1"], rows["s1_seed1_V0.2"]
        for col in ("slip_bottom", "slip_top_err", "Z_bulk", "Z_bulk_err", "nu_bulk_err",
                    "regime", "regime_confidence", "h10_top_I", "h5_bottom_mu_eff_err",
                    "com_vx", "com_vx_err", "com_vx_std"):
            self.assertEqual(holes[col], "", col)
            self.assertNotEqual(full[col], "", col)
        self.assertAlmostEqual(float(holes["nu_bulk"]), 0.79)
        self.assertEqual(holes["system"], "1")
        self.assertEqual(holes["steady"], "true")
        self.assertAlmostEqual(float(full["h10_bottom_I"]), 3 * 0.05)

    def test_summaries_written_by_analyze(self):
        # The real keys: synthetic runs analysed by `analyze`, a regime C one with switches and
        # one too short for any window (not steady, window quantities null).
        runs = os.path.join(self.d, "runs")
        write_synthetic_run(os.path.join(runs, "s1_seed1_V0.5"), kind="A", duration=800.0)
        write_synthetic_run(os.path.join(runs, "s1_seed2_V0.05"), kind="C", velocity=0.05,
                            duration=1600.0, seed=2)
        write_synthetic_run(os.path.join(runs, "s1_seed2_V0.5"), kind="A", duration=40.0, seed=2)
        for name in os.listdir(runs):
            self.assertEqual(main(["analyze", os.path.join(runs, name), "--quiet"]), 0)
        self.assertEqual(main(["report", self.d]), 0)   # no campaign.toml: the folder's name
        out = os.path.join(self.d, "report")
        with open(os.path.join(out, "runs.csv")) as f:
            rows = {r["run"]: r for r in csv.DictReader(f)}
        with open(os.path.join(runs, "s1_seed1_V0.5", "summary.json")) as f:
            s = json.load(f)
        a = rows["s1_seed1_V0.5"]
        self.assertEqual((a["system"], a["seed"], a["regime"], a["steady"]), ("1", "1", "A",
                                                                               "true"))
        self.assertAlmostEqual(float(a["I_bulk"]), s["bulk"]["inertial_number"]["mean"])
        self.assertAlmostEqual(float(a["mu_eff_bulk_err"]), s["bulk"]["mu_eff"]["err"])
        self.assertAlmostEqual(float(a["slip_top"]), s["slip"]["top"]["mean"])
        self.assertAlmostEqual(float(a["h10_top_I"]),
                               s["regions"]["h10"]["top"]["inertial_number"]["mean"])
        self.assertAlmostEqual(float(a["h5_bottom_Z"]),
                               s["regions"]["h5"]["bottom"]["coordination"]["mean"])
        self.assertAlmostEqual(float(a["L_y"]), s["height"]["mean"])
        self.assertAlmostEqual(float(a["com_vx"]), s["com_vx"]["mean"])
        self.assertAlmostEqual(float(a["com_vx_err"]), s["com_vx"]["err"])
        self.assertAlmostEqual(float(a["com_vx_std"]), s["com_vx"]["std"])
        c = rows["s1_seed2_V0.05"]
        # regime C: the centre of mass near +V or -V, its scatter of the order of V
        self.assertGreater(float(c["com_vx_std"]), 0.2 * 0.05)
        self.assertGreater(float(c["com_vx_std"]), 5 * float(a["com_vx_std"]) * 0.05 / 0.5)
        self.assertEqual(c["regime"], "C")
        self.assertGreater(int(c["band_switches"]), 0)
        self.assertNotEqual(c["switch_duration"], "")
        short = rows["s1_seed2_V0.5"]
        self.assertEqual((short["steady"], short["regime"], short["I_bulk"]), ("false", "", ""))
        with open(os.path.join(out, "fits.json")) as f:
            fits = json.load(f)
        self.assertEqual(fits["campaign"], os.path.basename(self.d))
        self.assertEqual(fits["fits"]["mu_power"]["status"], "skipped")
        with open(os.path.join(out, "index.html")) as f:
            text = f.read()
        # a note about the folder, not a run left out
        self.assertIn("Note: campaign.toml is missing", text)
        self.assertNotIn("<li>campaign.toml", text)
        self.assertIn(" 0 left out", text)

    def test_a_campaign_toml_without_a_name_is_noted(self):
        self.power_law_campaign()
        for text in ("", "garbage = 1\n", "[campaign]\nname = 5\n"):
            with open(os.path.join(self.d, "campaign.toml"), "w") as f:
                f.write(text)
            collected = report.collect(self.d)
            self.assertEqual(collected["campaign"], os.path.basename(self.d), text)
            self.assertTrue(any(n.startswith("campaign.toml gives no [campaign] name")
                                for n in collected["notes"]), text)
        # given as "." (the report run from inside the folder): still the folder's own name
        here = os.getcwd()
        try:
            os.chdir(self.d)
            self.assertEqual(report.collect(".")["campaign"], os.path.basename(self.d))
            os.chdir("runs")
            self.assertEqual(report.collect("..")["campaign"], os.path.basename(self.d))
        finally:
            os.chdir(here)

    def test_a_set_value_no_sweep_runs_is_the_campaign_files_error(self):
        self.power_law_campaign()
        path = os.path.join(self.d, "campaign.toml")
        for table, line in (("system", "height = -5"), ("system", "n = 2.5"),
                            ("shear", "normal_stress = 'x'"), ("shear", "normal_stress = nan")):
            with open(path, "w") as f:
                f.write(f"[campaign]\nname = 'c'\n[set.{table}]\n{line}\n")
            key = line.split()[0]
            with self.assertRaises(report.ReportError, msg=line) as caught:
                report.collect(self.d)
            self.assertEqual(caught.exception.path, path)
            self.assertIn(f"[set.{table}] {key}: must be a positive", caught.exception.problem)
            self.assertEqual(main(["report", self.d]), 2)
        # a value a sweep runs is the runs' yardstick, not an error
        with open(path, "w") as f:
            f.write("[campaign]\nname = 'c'\n[set.system]\nn = 511\n")
        self.assertEqual(report.collect(self.d)["campaign"], "c")

    def test_bad_campaign_folder_is_an_error(self):
        self.assertEqual(main(["report", os.path.join(self.d, "nothing")]), 2)
        self.assertEqual(main(["report", self.d]), 2)   # no runs/ and no campaign.toml
        os.makedirs(os.path.join(self.d, "runs", "s1_seed1_V1"))
        with open(os.path.join(self.d, "runs", "s1_seed1_V1", "summary.json"), "w") as f:
            f.write("{not json")
        # a summary that cannot be read leaves its run out, with the reason, not the report
        skipped = dict(report.collect(self.d)["skipped"])
        self.assertIn("summary.json: cannot read", skipped["s1_seed1_V1"])
        self.assertIn("no run.h5 to analyse it again", skipped["s1_seed1_V1"])



class BulkThicknessTest(unittest.TestCase):
    """The bulk laws take only runs whose bulk is that of model.md section 7 (h = 10); the others
    are listed."""

    def test_runs_of_a_cell_too_thin_for_h_10_stay_out_of_the_bulk_laws(self):
        with tempfile.TemporaryDirectory() as d:
            rows = []
            for k, I in enumerate((0.04, 0.06, 0.08, 0.12, 0.16, 0.19)):
                for reference in (True, False):
                    run = os.path.join(d, f"s{1 if reference else 2}_seed1_V{I:g}")
                    # the thin cell's points are off the law: they would move the fit
                    mu = 0.25 + 0.5 * I + (0.0 if reference else 0.1)
                    fake_summary(run, V=I, I=I, mu=mu, nu=0.8 - 0.2 * I, Z=3 - I,
                                 bulk_reference=reference)
                    rows.append(report.read_run(run))
            fits = report.fit_laws(rows)
            mu = fits["mu_linear"]
            self.assertEqual(mu["n_runs"], 6)
            self.assertAlmostEqual(mu["parameters"]["a"]["value"], 0.25, delta=0.01)
            self.assertTrue(all(r["bulk_h_note"] for r in rows if not r["bulk_h_reference"]))


class FootnotesTest(unittest.TestCase):
    """A reason that a table's cells would repeat is written once, below the table."""

    def test_a_reason_repeated_or_quoted_by_other_cells_is_written_once(self):
        notes = report._Footnotes()
        law = "no B/C law in h I_b is determined: mu_hI_BC is undetermined (a < b)"
        cells = [notes.text(law), notes.text(f"not computed: no delta_mu ({law})"),
                 notes.text(law), notes.text("other")]
        self.assertEqual(cells, ["see note 1", "not computed: no delta_mu (see note 1)",
                                 "see note 1", "see note 2"])
        text = notes.html()
        self.assertEqual(text.count("mu_hI_BC is undetermined"), 1)
        self.assertIn("(a &lt; b)", text)    # escaped once, in the note
        self.assertIn("note 2: other", text)

    def test_the_regime_a_table_writes_a_shared_reason_once(self):
        reason = "not computed: no mu_eff(I) law whose parameters are determined (a < b)"
        rows = [dict(run=f"s1_seed1_V{V}", V=V, I_bulk=0.1 * V, law=None, dmu_dI=None, D=None,
                     predicted_T_SS=None, reason=reason, measured_transient_end_time=100.0)
                for V in (1, 2, 3)]
        preds = {"V_AB": {"status": "not available", "reason": "none"},
                 "symmetric_state_stability": {"status": "not available", "reason": "none"},
                 "switch_time_C": [], "steady_state_time_A": rows}
        text = "".join(report._html_transitions({}, preds))
        self.assertEqual(text.count("no mu_eff(I) law"), 1)
        self.assertEqual(text.count("see note 1"), 3)

    def test_the_v_ab_table_writes_a_reason_shared_by_systems_once(self):
        undetermined = "the boundary law is undetermined: the points do not constrain the form"
        no_interval = "no interval: the parameter draws do not bracket V_AB"
        law = dict(V_AB=0.58, interval=[0.5, 0.7], reason=None, interval_note=None,
                   law="mu_hI_BC")
        systems = {str(s): {"from_hI_law": law,
                            "h3": dict(V_AB=None, interval=None, reason=undetermined,
                                       interval_note=None),
                            "h10": dict(V_AB=0.39 * s, interval=None, reason=None,
                                        interval_note=no_interval)} for s in (1, 2, 3)}
        text = "".join(report._html_v_ab({"status": "ok", "method": "m", "systems": systems}))
        self.assertEqual(text.count("do not constrain the form"), 1)
        self.assertEqual(text.count("do not bracket V_AB"), 1)
        self.assertEqual(text.count("see note 1"), 3)
        self.assertEqual(text.count("see note 2"), 3)
        self.assertIn("1.17 <small>(see note 2)</small>", text)   # the value stays in its cell

    def test_no_note_writes_nothing(self):
        self.assertEqual(report._Footnotes().html(), "")


if __name__ == "__main__":
    unittest.main()

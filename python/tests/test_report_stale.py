"""summary.json files of another format or version than this code's (summary.SUMMARY_FORMAT,
summary.SUMMARY_VERSION) are not pooled by `report`: a stale one is analysed again from run.h5
(as `analyze` does) or, without run.h5, left out; another format and a newer version are left
out; every one is listed with its reason in the printed output, index.html and fits.json."""
import contextlib
import csv
import io
import json
import os
import re
import shutil
import tempfile
import unittest

from cdshear_analysis import report
from cdshear_analysis.__main__ import main as cli_main
from cdshear_analysis.summary import SUMMARY_FORMAT, SUMMARY_VERSION
from cdshear_analysis.synthetic import write_synthetic_run
from tests.test_report import edited_summary, fake_campaign
from tests.cpp_source import source_part

OLD = SUMMARY_VERSION - 1


def run_report(d):
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        rc = cli_main(["report", d])
    return rc, out.getvalue()


def two_runs_with_their_cases(d):
    """A campaign in D of two system-1 runs, s1_seed1_V0.5 and s1_seed1_V1, each with the
    case.toml values that tell a run's system, seed and V; returns the folder of its runs."""
    fake_campaign(d, "named", {1: [(0.5, 0.025, 0.35, 0.8, 3.0), (1.0, 0.05, 0.4, 0.8, 3.0)]})
    runs = os.path.join(d, "runs")
    for run, v in (("s1_seed1_V0.5", 0.5), ("s1_seed1_V1", 1.0)):
        with open(os.path.join(runs, run, "case.toml"), "w") as f:
            f.write(f"[system]\nseed = 1\nn = 511\nheight = 20.0\n[shear]\n"
                    f"velocity = {v!r}\nnormal_stress = 0.25\nduration = 1000.0\n")
    return runs


class StaleSummaryTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        """Five current runs (system 1) and, beside them: `{}`; an older version with run.h5
        (a synthetic regime-A run analysed, then its summary's version lowered); an older
        version without run.h5; another format; a newer version; a JSON list; no format or
        version; an older version whose run.h5 is empty."""
        cls.tmp = tempfile.TemporaryDirectory()
        d = cls.d = cls.tmp.name
        fake_campaign(d, "stale", {1: [(V, 0.05 * V, 0.3 + 0.1 * V, 0.8, 3.0)
                                       for V in (0.5, 1.0, 1.5, 2.0, 2.5)]})
        runs = os.path.join(d, "runs")

        def write(name, content):
            os.makedirs(os.path.join(runs, name), exist_ok=True)
            with open(os.path.join(runs, name, "summary.json"), "w") as f:
                json.dump(content, f)

        def current(name):
            with open(os.path.join(runs, "s1_seed1_V0.5", "summary.json")) as f:
                s = json.load(f)
            return dict(s, run_dir=os.path.join(runs, name))

        write("s2_seed1_V0.1", {})
        # older, with run.h5: analysed for real, then made stale
        cls.rerun = os.path.join(runs, "s2_seed1_V0.5")
        write_synthetic_run(cls.rerun, kind="A", duration=800.0, n=1023, height=40.0)
        assert cli_main(["analyze", cls.rerun, "--quiet"]) == 0
        with open(os.path.join(cls.rerun, "summary.json")) as f:
            fresh = json.load(f)
        cls.fresh_I = fresh["bulk"]["inertial_number"]["mean"]
        write("s2_seed1_V0.5", dict(fresh, version=OLD, bulk={"inertial_number": {
            "mean": 123.0, "err": 1.0}}))
        # figures of the old analysis, which the report must not copy as they are
        os.makedirs(os.path.join(cls.rerun, "figures"))
        with open(os.path.join(cls.rerun, "figures", "snapshot.png"), "wb") as f:
            f.write(b"stale")
        write("s2_seed1_V0.2", dict(current("s2_seed1_V0.2"), version=OLD))
        cls.other = dict(current("s2_seed1_V0.3"), format="cdshear-packing")
        write("s2_seed1_V0.3", cls.other)
        write("s2_seed1_V0.4", dict(current("s2_seed1_V0.4"), version=SUMMARY_VERSION + 1))
        write("s2_seed1_V0.6", [1, 2, 3])
        s = current("s2_seed1_V0.7")
        del s["format"], s["version"]
        write("s2_seed1_V0.7", s)
        write("s2_seed1_V0.8", dict(current("s2_seed1_V0.8"), version=OLD))
        open(os.path.join(runs, "s2_seed1_V0.8", "run.h5"), "w").close()
        cls.rc, cls.printed = run_report(d)
        with open(os.path.join(d, "report", "fits.json")) as f:
            cls.doc = json.load(f)
        with open(os.path.join(d, "report", "index.html")) as f:
            cls.html = f.read()
        with open(os.path.join(d, "report", "runs.csv")) as f:
            cls.csv = {r["run"]: r for r in csv.DictReader(f)}

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def excluded(self):
        return {e["run"]: e["reason"] for e in self.doc["excluded_runs"]}

    def test_the_report_runs(self):
        self.assertEqual(self.rc, 0)
        self.assertEqual((self.doc["summary_format"], self.doc["summary_version"]),
                         (SUMMARY_FORMAT, SUMMARY_VERSION))

    def test_an_older_summary_with_run_h5_is_analysed_again(self):
        self.assertEqual([e["run"] for e in self.doc["reanalysed_runs"]], ["s2_seed1_V0.5"])
        reason = self.doc["reanalysed_runs"][0]["reason"]
        self.assertIn(f"version {OLD} is older than this code's {SUMMARY_VERSION}", reason)
        # summary.json rewritten by analyze, and its new values pooled (not the stale 123)
        with open(os.path.join(self.rerun, "summary.json")) as f:
            s = json.load(f)
        self.assertEqual((s["format"], s["version"]), (SUMMARY_FORMAT, SUMMARY_VERSION))
        self.assertAlmostEqual(float(self.csv["s2_seed1_V0.5"]["I_bulk"]), self.fresh_I)
        self.assertIn(f"note: re-analysed s2_seed1_V0.5: {reason}\n", self.printed)
        self.assertIn(f"<li>s2_seed1_V0.5: {report.html.escape(reason)}</li>", self.html)
        self.assertIn("1 run re-analysed from run.h5", self.html)

    def test_a_reanalysed_run_has_its_figures_redrawn(self):
        for folder in (os.path.join(self.rerun, "figures"),
                       os.path.join(self.d, "report", "runs", "s2_seed1_V0.5")):
            with open(os.path.join(folder, "snapshot.png"), "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n", folder)
            self.assertIn("steady_profiles.png", os.listdir(folder))

    def test_a_figure_that_cannot_be_redrawn_is_named_as_a_figure(self):
        with tempfile.TemporaryDirectory() as d:
            run = os.path.join(d, "s2_seed1_V0.5")
            write_synthetic_run(run, kind="A", duration=300.0, n=255, height=20.0)
            with contextlib.redirect_stdout(io.StringIO()):
                self.assertEqual(cli_main(["analyze", run, "--quiet"]), 0)
            path = os.path.join(run, "summary.json")
            with open(path) as f:
                s = json.load(f)
            with open(path, "w") as f:
                json.dump(dict(s, version=OLD), f)
            blocked = os.path.join(run, "figures", "snapshot.png")
            os.makedirs(blocked)   # a folder where the figure goes
            summary, why = report.usable_summary(run, [])
            self.assertIsNone(summary)
            self.assertIn(f"summary.json rewritten, but drawing its figures failed: {blocked}",
                          why)
            self.assertNotIn("writing the new summary.json", why)
            with open(path) as f:
                self.assertEqual(json.load(f)["version"], SUMMARY_VERSION)   # kept

    def test_stale_summaries_without_run_h5_are_left_out_with_the_reason(self):
        ex = self.excluded()
        self.assertIn("summary.json is empty ({}) and there is no run.h5", ex["s2_seed1_V0.1"])
        self.assertIn(f"version {OLD} is older than this code's {SUMMARY_VERSION} and there "
                      "is no run.h5", ex["s2_seed1_V0.2"])
        self.assertIn("not a JSON object but list", ex["s2_seed1_V0.6"])
        self.assertIn("has no format and no version key", ex["s2_seed1_V0.7"])
        # a run.h5 that cannot be read: left out with what failed
        self.assertIn("analysing run.h5 again failed: empty file", ex["s2_seed1_V0.8"])
        for run in ("s2_seed1_V0.1", "s2_seed1_V0.2", "s2_seed1_V0.6", "s2_seed1_V0.7",
                    "s2_seed1_V0.8"):
            self.assertNotIn(run, self.csv)
            self.assertIn(f"left out {run}: {ex[run]}\n", self.printed)
            self.assertIn(f"<li>{run}: {report.html.escape(ex[run])}</li>", self.html)

    def test_another_format_and_a_newer_version_are_left_out_untouched(self):
        ex = self.excluded()
        self.assertIn("format 'cdshear-packing', not 'cdshear-summary'", ex["s2_seed1_V0.3"])
        self.assertIn(f"version {SUMMARY_VERSION + 1} is newer than this code's "
                      f"{SUMMARY_VERSION}", ex["s2_seed1_V0.4"])
        for run in ("s2_seed1_V0.3", "s2_seed1_V0.4"):
            self.assertNotIn(run, self.csv)
            self.assertIn(f"left out {run}: ", self.printed)
        with open(os.path.join(self.d, "runs", "s2_seed1_V0.3", "summary.json")) as f:
            self.assertEqual(json.load(f), self.other)

    def test_only_current_summaries_are_pooled(self):
        self.assertEqual(sorted(self.csv), sorted(
            [f"s1_seed1_V{V:g}" for V in (0.5, 1.0, 1.5, 2.0, 2.5)] + ["s2_seed1_V0.5"]))
        self.assertEqual(self.doc["runs_analysed"], 6)
        self.assertEqual(len(self.doc["excluded_runs"]), 7)

    def test_summary_state(self):
        current = {"format": SUMMARY_FORMAT, "version": SUMMARY_VERSION}
        self.assertIsNone(report.summary_state(current))
        for s, kind in (({}, "stale"), ([], "stale"), (None, "stale"), ("x", "stale"),
                        (dict(current, version=OLD), "stale"),
                        (dict(current, version=str(SUMMARY_VERSION)), "stale"),
                        (dict(current, version=True), "stale"),
                        (dict(current, format=None), "stale"),
                        ({"format": SUMMARY_FORMAT}, "stale"),
                        (dict(current, format="other"), "other format"),
                        (dict(current, version=SUMMARY_VERSION + 1), "newer")):
            self.assertEqual(report.summary_state(s)[0], kind, s)


if __name__ == "__main__":
    unittest.main()


class DamagedSummaryTest(unittest.TestCase):
    """A current summary.json edited or damaged by hand is left out with the reason, before the
    report draws anything from it; a JSON file nested too deeply is a ReportError."""

    def test_a_wall_speed_that_is_no_positive_number_is_left_out(self):
        with tempfile.TemporaryDirectory() as d:
            fake_campaign(d, "damaged", {1: [(0.5, 0.025, 0.35, 0.8, 3.0)]})
            run = os.path.join(d, "runs", "s1_seed1_V0.5")
            with open(os.path.join(run, "summary.json")) as f:
                good = json.load(f)
            self.assertIsNone(report.case_problem(good))
            self.assertIsNotNone(report.usable_summary(run, [])[0])
            for bad in ("abc", None, True, 0, -0.5, [0.5], float("nan")):
                s = dict(good, case=dict(good["case"], velocity=bad))
                with open(os.path.join(run, "summary.json"), "w") as f:
                    json.dump(s, f)
                summary, why = report.usable_summary(run, [])
                self.assertIsNone(summary, bad)
                self.assertIn(f"case.velocity {bad!r} is not a positive number", why)
            self.assertIn("no `case` object", report.case_problem(dict(good, case=[])))

    def test_a_summary_of_another_run_is_left_out(self):
        with tempfile.TemporaryDirectory() as d:
            fake_campaign(d, "copied", {1: [(0.5, 0.025, 0.35, 0.8, 3.0),
                                            (1.0, 0.05, 0.4, 0.8, 3.0)]})
            runs = os.path.join(d, "runs")
            run = os.path.join(runs, "s1_seed1_V0.5")
            with open(os.path.join(runs, "s1_seed1_V1", "summary.json")) as f:
                other = json.load(f)
            with open(os.path.join(run, "summary.json")) as f:
                own = json.load(f)
            self.assertIsNone(report.identity_problem(run, own))
            # copied whole: it names the other run's folder
            with open(os.path.join(run, "summary.json"), "w") as f:
                json.dump(other, f)
            summary, why = report.usable_summary(run, [])
            self.assertIsNone(summary)
            self.assertIn("summary.json is of another run (run_dir", why)
            # its folder edited to this one's: the case.toml tells the wall speeds apart
            with open(os.path.join(run, "summary.json"), "w") as f:
                json.dump(dict(other, run_dir=run), f)
            self.assertIsNotNone(report.usable_summary(run, [])[0])   # no case.toml yet
            with open(os.path.join(run, "case.toml"), "w") as f:
                f.write(f"[shear]\nvelocity = 0.5\nduration = {own['case']['duration']!r}\n")
            summary, why = report.usable_summary(run, [])
            self.assertIsNone(summary)
            self.assertIn("velocity = 1.0, its case.toml says 0.5", why)
            with open(os.path.join(run, "summary.json"), "w") as f:
                json.dump(own, f)
            self.assertIsNotNone(report.usable_summary(run, [])[0])
            # The initial velocity too, where the summary records it (older ones do not).
            with open(os.path.join(run, "case.toml"), "a") as f:
                f.write("initial_velocity = 'rest'\n")
            started = dict(own, case=dict(own["case"], initial_velocity="linear"))
            self.assertIn("initial_velocity = 'linear', its case.toml says 'rest'",
                          report.identity_problem(run, started))
            self.assertIsNone(report.identity_problem(
                run, dict(started, case=dict(started["case"], initial_velocity="rest"))))
            self.assertNotIn("initial_velocity", own["case"])
            self.assertIsNone(report.identity_problem(run, own))
            # case.toml asking for a longer run: the run's own summary, before a resume
            with open(os.path.join(run, "case.toml"), "w") as f:
                f.write(f"[shear]\nvelocity = 0.5\nduration = {2 * own['case']['duration']!r}\n")
            summary, why = report.usable_summary(run, [])
            self.assertIsNone(summary)
            self.assertIn("before its case.toml asked for duration = 2000.0", why)
            self.assertIn(f"`cdshear run --resume {run}`", why)
            self.assertNotIn("cdshear analyze", why)

    def test_a_run_analysed_from_inside_its_folder_is_its_own(self):
        with tempfile.TemporaryDirectory() as d:
            run = os.path.join(d, "s1_seed1_V0.5")
            write_synthetic_run(run, kind="A", duration=300.0, n=255, height=20.0)
            here = os.getcwd()
            try:
                os.chdir(run)
                with contextlib.redirect_stdout(io.StringIO()):
                    self.assertEqual(cli_main(["analyze", ".", "--quiet"]), 0)
            finally:
                os.chdir(here)
            with open(os.path.join(run, "summary.json")) as f:
                own = json.load(f)
            # the folder itself, not "."
            self.assertEqual(own["run_dir"], os.path.abspath(run))
            self.assertIsNone(report.identity_problem(run, own))
            # summaries written that way before: a name that says nothing is not judged
            for said_nothing in (".", "..", "./", ""):
                self.assertIsNone(report.identity_problem(run, dict(own, run_dir=said_nothing)))
            self.assertIn("another run", report.identity_problem(
                run, dict(own, run_dir="s1_seed1_V1")))

    def test_a_run_folder_renamed_to_another_seed_or_speed_is_left_out(self):
        """The report reads a run's seed from its folder's name: a folder renamed (or copied in)
        by hand would be pooled as another seed, or listed under another V."""
        with tempfile.TemporaryDirectory() as d:
            runs = two_runs_with_their_cases(d)
            self.assertEqual(len(report.collect(d)["rows"]), 2)
            os.rename(os.path.join(runs, "s1_seed1_V1"), os.path.join(runs, "s1_seed3_V1"))
            shutil.copytree(os.path.join(runs, "s1_seed1_V0.5"), os.path.join(runs, "s1_seed1_V2"))
            collected = report.collect(d)
            self.assertEqual([r["run"] for r in collected["rows"]], ["s1_seed1_V0.5"])
            why = dict(collected["skipped"])
            self.assertIn("its name says seed 3, its case.toml seed 1", why["s1_seed3_V1"])
            self.assertIn("its name says V = 2, its case.toml 0.5", why["s1_seed1_V2"])

    def test_a_run_of_another_system_copied_in_under_a_systems_name_is_left_out(self):
        """The report reads a run's system from its folder's name, and fits each system's runs
        together: a system-1 run copied in as a system-2 run (seed and V matching) would be
        pooled with system 2's. Its n, L_y and sigma_yy are compared with those that the
        campaign gives system 2: the preset's unless the campaign's [set] changes them."""
        with tempfile.TemporaryDirectory() as d:
            runs = two_runs_with_their_cases(d)
            for copy in ("s2_seed1_V1", "s3_seed1_V1"):
                shutil.copytree(os.path.join(runs, "s1_seed1_V1"), os.path.join(runs, copy))
                with edited_summary(d, copy) as s:
                    s["run_dir"] = os.path.join(runs, copy)
            collected = report.collect(d)
            self.assertEqual([r["run"] for r in collected["rows"]],
                             ["s1_seed1_V0.5", "s1_seed1_V1"])
            why = dict(collected["skipped"])
            self.assertIn("its name says system 2, whose runs have system.n = 1023 in this "
                          "campaign, its case.toml 511", why["s2_seed1_V1"])
            self.assertIn("system 3", why["s3_seed1_V1"])
            # a campaign of small cells: [set] gives every system its n and L_y
            with open(os.path.join(d, "campaign.toml")) as f:
                text = f.read()
            with open(os.path.join(d, "campaign.toml"), "w") as f:
                f.write(text.replace("[set]\n", "[set.system]\nn = 511\nheight = 20.0\n"))
            collected = report.collect(d)
            self.assertEqual([r["run"] for r in collected["rows"]],
                             ["s1_seed1_V0.5", "s1_seed1_V1", "s2_seed1_V1"])
            # s3 holds sigma_yy 0.25, where system 3's is 0.0625
            self.assertIn("its name says system 3, whose runs have shear.normal_stress = 0.0625 "
                          "in this campaign, its case.toml 0.25",
                          dict(collected["skipped"])["s3_seed1_V1"])

    def test_the_system_presets_are_the_executables(self):
        body = source_part("src/shear/shear_case.cpp", "void apply_system_preset(", "};",
                           after="rows[] = {")
        rows = re.findall(r"\{(\d+),\s*(\d+),\s*([\d.]+),\s*\d+\}", body)
        self.assertEqual(len(rows), 7)
        self.assertEqual({k + 1: (int(n), float(h), float(s)) for k, (n, h, s) in enumerate(rows)},
                         report.SYSTEM_PRESETS)

    def test_a_run_folder_whose_name_is_not_utf8_is_left_out_before_anything_is_written(self):
        with tempfile.TemporaryDirectory() as d:
            fake_campaign(d, "latin", {1: [(0.5, 0.025, 0.35, 0.8, 3.0),
                                           (1.0, 0.05, 0.4, 0.8, 3.0)]})
            runs = os.fsencode(os.path.join(d, "runs"))
            os.rename(os.path.join(runs, b"s1_seed1_V1"), os.path.join(runs, b"s1_seed1_V1\xe9"))
            out = os.path.join(d, "out")
            with contextlib.redirect_stdout(io.StringIO()) as printed:
                self.assertEqual(cli_main(["report", d, "-o", out]), 0)
            self.assertIn("left out s1_seed1_V1\\xe9: its folder's name is not UTF-8 text",
                          printed.getvalue())
            with open(os.path.join(out, "runs.csv")) as f:
                self.assertEqual([r["run"] for r in csv.DictReader(f)], ["s1_seed1_V0.5"])

    def test_a_summary_cut_short_is_left_out_not_fatal(self):
        with tempfile.TemporaryDirectory() as d:
            fake_campaign(d, "cut", {1: [(0.5, 0.025, 0.35, 0.8, 3.0),
                                         (1.0, 0.05, 0.4, 0.8, 3.0)]})
            run = os.path.join(d, "runs", "s1_seed1_V0.5")
            with open(os.path.join(run, "summary.json"), "r+") as f:
                f.truncate(100)
            summary, why = report.usable_summary(run, [])
            self.assertIsNone(summary)
            self.assertIn("cannot read", why)
            self.assertIn("no run.h5 to analyse it again", why)
            rc, out = run_report(d)
            self.assertIn("s1_seed1_V0.5", out)
            self.assertIn("cannot read", out)

    def test_the_builds_of_a_run_come_from_every_sitting_it_records(self):
        with tempfile.TemporaryDirectory() as d:
            fake_campaign(d, "resumed", {1: [(0.5, 0.025, 0.35, 0.8, 3.0)]})
            run = os.path.join(d, "runs", "s1_seed1_V0.5")
            for name in os.listdir(run):
                if name.startswith("run_info"):
                    os.remove(os.path.join(run, name))

            def record(name, build):
                with open(os.path.join(run, name), "w") as f:
                    json.dump({"build": {"description": build}}, f)
            # the first sitting killed: only the resumed one's record
            record("run_info_resume_400000.json", "cdshear 1.0 (abc)")
            self.assertEqual(report.software("", [run])["runs"], {"cdshear 1.0 (abc)": 1})
            record("run_info.json", "cdshear 0.9 (def)")
            record("run_info_resume_800000_1.json", "cdshear 1.0 (abc)")
            self.assertEqual(report.software("", [run])["runs"],
                             {"cdshear 0.9 (def)": 1, "cdshear 1.0 (abc)": 1})

    def test_a_run_info_or_case_nested_too_deeply_is_no_traceback(self):
        with tempfile.TemporaryDirectory() as d:
            fake_campaign(d, "deep", {1: [(0.5, 0.025, 0.35, 0.8, 3.0)]})
            run = os.path.join(d, "runs", "s1_seed1_V0.5")
            with open(os.path.join(run, "run_info.json"), "w") as f:
                f.write("[" * 100000 + "]" * 100000)
            self.assertIn("unknown (no readable run_info.json)", report.software("", [run])["runs"])
            with open(os.path.join(run, "case.toml"), "w") as f:
                f.write("x = " + "[" * 5000 + "1" + "]" * 5000 + "\n")
            self.assertIsNone(report.identity_problem(run, {"run_dir": run}))
            toml_path = os.path.join(d, "campaign.toml")
            with open(toml_path, "w") as f:
                f.write("x = " + "[" * 5000 + "1" + "]" * 5000 + "\n")
            with self.assertRaisesRegex(report.ReportError, "nested too deeply"):
                report.campaign_runs(toml_path)

    def test_profiles_beyond_any_float_are_read_as_none(self):
        # an integer too large for a float (JSON holds one): no profile, no OverflowError
        good = {"y": [1.0, 2.0], "vx": {"mean": [0.1, None]}, "mu_eff": {"mean": [0.3, 0.4]}}
        self.assertEqual(report._profiles(good)["y"], [1.0, 2.0])
        for bad in (dict(good, y=[1.0, 10 ** 400]), dict(good, vx={"mean": [0.1, -10 ** 400]})):
            self.assertIsNone(report._profiles(bad))

    def test_json_nested_too_deeply_is_a_report_error(self):
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "summary.json")
            with open(path, "w") as f:
                f.write("[" * 100000 + "]" * 100000)
            with self.assertRaises(report.ReportError) as caught:
                report.read_json(path)
            self.assertIn("nested too deeply", str(caught.exception))

    def test_a_key_given_twice_is_a_report_error_naming_it(self):
        # json keeps the last value silently; a summary or fits.json edited into holding two
        # answers for one key is refused, as cdshear refuses such a file
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "summary.json")
            with open(path, "w") as f:
                f.write('{"format": "cdshear-summary", "regime": "A", "x": {"regime": "B"}, '
                        '"regime": "C"}')
            with self.assertRaises(report.ReportError) as caught:
                report.read_json(path)
            self.assertIn("the key 'regime' is given twice", str(caught.exception))
            with open(path, "w") as f:
                f.write('{"regime": "A", "x": {"regime": "B"}}')   # once per object: read
            self.assertEqual(report.read_json(path)["x"], {"regime": "B"})

"""load_run round trip against docs/run-data.md, bad input, and analyze/plot end to end."""
import json
import os
import re
import subprocess
import sys
import tempfile
import unittest

import warnings

import h5py
import numpy as np

from cdshear_analysis import RunDataError, analyze, format_report, load_run
from cdshear_analysis.plots import plot_run
from cdshear_analysis.rundata import RUN_FILE, seal
from cdshear_analysis.summary import jsonable
from cdshear_analysis.synthetic import write_synthetic_run

PYTHON_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUN_DATA_DOC = os.path.join(PYTHON_DIR, "..", "docs", "run-data.md")
SUMMARY_KEYS = {
    "format", "version", "run_dir", "case", "steady", "steady_reason", "transient_end_time",
    "transient_end_strain", "averaging_start_time", "averaging_start_strain", "truncation_times",
    "independent_samples", "drift_sigmas", "stress_balance", "warnings", "steady_windows",
    "steady_window_indices",
    "window_errors", "regime", "regime_confidence", "regime_criteria", "mu_eff_wall", "height",
    "solid_fraction", "com_vx", "bulk", "slip", "regions", "profiles", "switches",
    "switch_duration", "switch_time", "solver", "mu_eff_wall_bottom", "mu_eff_wall_top",
    "switch_delta_mu", "whole_run_switches",
    "profile_decay"}
FIGURES = ["snapshot.png", "velocity_profiles.png", "com_velocity.png",
           "height_solid_fraction.png", "steady_profiles.png"]


def documented_names():
    """{section: names} from the tables of docs/run-data.md (first column, in backquotes)."""
    names, section = {}, None
    with open(RUN_DATA_DOC, encoding="utf-8") as f:
        for line in f:
            if line.startswith("#"):
                section = ("attrs" if "Root attributes" in line else "regions" if "regions" in line
                           else "top_stripes" if "top_stripes" in line
                           else "series" if "/series" in line else "windows" if "/windows" in line
                           else "snapshot" if "/snapshot" in line else None)
            elif section == "snapshot":
                names.setdefault(section, set()).update(re.findall(r"`(\w+)`", line))
            elif section and line.startswith("| `"):
                names.setdefault(section, set()).update(re.findall(r"`(\w+)`", line.split("|")[1]))
    return names


def run_module(*args):
    env = dict(os.environ, PYTHONPATH=PYTHON_DIR)
    return subprocess.run([sys.executable, "-m", "cdshear_analysis", *args], env=env,
                          capture_output=True, text=True, timeout=120)


class RunData(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.run_dir = os.path.join(cls.tmp.name, "runC")
        write_synthetic_run(cls.run_dir, kind="C", duration=1600.0, seed=2)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_round_trip_has_every_documented_name(self):
        run = load_run(self.run_dir)
        doc = documented_names()
        self.assertGreater(len(doc["series"]), 15)
        self.assertEqual(doc["attrs"] - set(run["attrs"]), set())
        self.assertEqual(doc["series"] - set(run["series"]), set())
        self.assertEqual(doc["windows"] - set(run["windows"]), set())
        self.assertEqual(doc["top_stripes"] - set(run["top_stripes"]), set())
        self.assertEqual(doc["snapshot"] - {"n"} - set(run["snapshot"]), set())
        self.assertEqual(list(run["regions"]), ["h5", "h10"])
        for region in run["regions"].values():
            self.assertEqual(doc["regions"] - set(region), set())
        w = run["windows"]
        n_windows, n_stripes = 20, 25
        self.assertEqual(w["stress"].shape, (n_windows, n_stripes, 2, 2))
        self.assertEqual(run["series"]["time"].shape, (3200,))
        self.assertEqual(run["case"]["shear"]["velocity"], 0.5)
        self.assertEqual(run["attrs"]["format"], "cdshear-run")
        np.testing.assert_allclose(run["windows"]["t_end"] - run["windows"]["t_start"], 80.0)

    def test_bad_input_exits_2_naming_the_file(self):
        d = self.tmp.name
        os.makedirs(os.path.join(d, "not_a_run"))
        for name, content in (("empty", b""), ("text", b"time,com_vx\n0,1\n" * 50)):
            os.makedirs(os.path.join(d, name))
            with open(os.path.join(d, name, "run.h5"), "wb") as f:
                f.write(content)
        truncated = os.path.join(d, "truncated")
        write_synthetic_run(truncated, kind="A", duration=400.0)
        size = os.path.getsize(os.path.join(truncated, "run.h5"))
        os.truncate(os.path.join(truncated, "run.h5"), size // 2)
        missing = os.path.join(d, "missing")
        write_synthetic_run(missing, kind="A", duration=400.0)
        with h5py.File(os.path.join(missing, "run.h5"), "a") as f:
            del f["series/com_vx"]
        seal(os.path.join(missing, "run.h5"))   # a sealed file that lacks a dataset
        nodata = os.path.join(d, "nodata")   # written before the first sample
        write_synthetic_run(nodata, kind="A", duration=400.0, time_reached=0.0)
        unmeasured = os.path.join(d, "unmeasured")   # a run with measure.enabled = false
        os.makedirs(unmeasured)
        with open(os.path.join(unmeasured, "case.toml"), "w") as f:
            f.write("[system]\nn = 511\n\n[measure]\nenabled = false\nwindow = 40.0\n")
        stopped = os.path.join(d, "stopped")   # killed before its first checkpoint
        os.makedirs(stopped)
        with open(os.path.join(stopped, "case.toml"), "wb") as f:
            f.write(b"[system]\nn = 511 # \xff not UTF-8\n")
        deep = os.path.join(d, "deep")   # stopped, its case.toml nested beyond Python's recursion
        os.makedirs(deep)
        with open(os.path.join(deep, "case.toml"), "w") as f:
            f.write("a = " + "[" * 100000 + "]" * 100000 + "\n")
        looped = os.path.join(d, "looped")   # run.h5 a link to itself: named with the reason
        os.makedirs(looped)
        os.symlink("run.h5", os.path.join(looped, "run.h5"))
        foldered = os.path.join(d, "foldered")   # a folder in run.h5's place
        os.makedirs(os.path.join(foldered, "run.h5"))
        cloned = os.path.join(d, "cloned")   # a clone keeps a finished run's summary only
        os.makedirs(cloned)
        with open(os.path.join(cloned, "summary.json"), "w") as f:
            f.write("{}")
        cases = [("nowhere", os.path.join(d, "nowhere"), "no such folder"),
                 ("not_a_run", os.path.join(d, "not_a_run"), "not a run folder (no run.h5)"),
                 ("unmeasured", unmeasured, "measure.enabled = false: it wrote no run.h5"),
                 ("stopped", stopped, "the run stopped before its first checkpoint"),
                 ("deep", deep, "the run stopped before its first checkpoint"),
                 ("looped", os.path.join(looped, "run.h5"),
                  "cannot be read: Too many levels of symbolic links"),
                 ("foldered", os.path.join(foldered, "run.h5"), "not a regular file (a folder)"),
                 ("cloned", cloned, "a finished run without its run.h5"),
                 ("empty", os.path.join(d, "empty", "run.h5"), "empty file"),
                 ("text", os.path.join(d, "text", "run.h5"), "HDF5"),
                 ("truncated", os.path.join(truncated, "run.h5"), "damaged"),
                 ("missing", os.path.join(missing, "run.h5"), "/series/com_vx"),
                 ("nodata", os.path.join(nodata, "run.h5"), "no samples in /series")]
        for command in ("analyze", "plot"):
            for name, path, problem in cases:
                with self.subTest(command=command, case=name):
                    folders = ("nowhere", "not_a_run", "unmeasured", "stopped", "deep", "cloned")
                    folder = path if name in folders else os.path.dirname(path)
                    result = run_module(command, folder)
                    self.assertEqual(result.returncode, 2, result.stderr)
                    self.assertTrue(result.stderr.startswith(f"error: {path}: "), result.stderr)
                    self.assertIn(problem, result.stderr)
                    self.assertNotIn("Traceback", result.stderr)
        with self.assertRaises(RunDataError):
            load_run(os.path.join(d, "empty"))

    def test_an_empty_argument_is_refused_not_taken_for_the_current_folder(self):
        for argv in (("analyze", ""), ("report", self.tmp.name, "-o", ""),
                     ("campaign-compare", "", self.tmp.name)):
            with self.subTest(argv=argv):
                result = run_module(*argv)
                self.assertEqual(result.returncode, 2, result.stderr)
                self.assertIn("is empty (an unset shell variable?)", result.stderr)
                self.assertFalse(os.path.exists(os.path.join(self.tmp.name, "report")))


class EndToEnd(unittest.TestCase):
    def test_analyze_and_plot(self):
        with tempfile.TemporaryDirectory() as d:
            run_dir = os.path.join(d, "run")
            write_synthetic_run(run_dir, kind="C", duration=1600.0, seed=4)
            result = run_module("analyze", run_dir)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn("regime C", result.stdout)
            self.assertIn(os.path.join(run_dir, "summary.json"), result.stdout)
            self.assertLessEqual(len(result.stdout.splitlines()), 14)
            with open(os.path.join(run_dir, "summary.json")) as f:
                summary = json.loads(f.read(), parse_constant=lambda c: self.fail(c))
            self.assertEqual(set(summary), SUMMARY_KEYS)
            self.assertEqual((summary["format"], summary["version"]), ("cdshear-summary", 3))
            self.assertEqual(set(summary["regions"]["h10"]),
                             {"h", "bulk", "bottom", "top", "sheared_layer", "resting_layer"})
            self.assertEqual(set(summary["regions"]["h5"]["bulk"]),
                             {"mu_eff", "solid_fraction", "coordination",
                              "force_carrying_coordination", "shear_rate", "inertial_number"})
            self.assertEqual(set(summary["slip"]["top"]), {"mean", "err"})
            self.assertAlmostEqual(summary["mu_eff_wall"]["mean"], 0.30, delta=0.01)
            self.assertEqual(len(summary["profiles"]["vx"]["mean"]), 25)
            self.assertEqual([f for f in os.listdir(run_dir) if f.startswith(".summary")], [])

            result = run_module("plot", run_dir)
            self.assertEqual(result.returncode, 0, result.stderr)
            for name in FIGURES:
                path = os.path.join(run_dir, "figures", name)
                self.assertIn(path, result.stdout)
                with open(path, "rb") as f:
                    self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
            out = os.path.join(d, "elsewhere")
            self.assertEqual(run_module("plot", run_dir, "-o", out).returncode, 0)
            self.assertEqual(sorted(os.listdir(out)), sorted(FIGURES))
            # A figure that cannot be written (a folder in its place) is named, exit 1, and the
            # others are written; a backend named in the environment plays no part.
            blocked = os.path.join(d, "blocked")
            first = next(iter(FIGURES))
            os.makedirs(os.path.join(blocked, first, "inside"))
            env = dict(os.environ, PYTHONPATH=PYTHON_DIR, MPLBACKEND="no_such_backend")
            result = subprocess.run([sys.executable, "-m", "cdshear_analysis", "plot", run_dir,
                                     "-o", blocked], env=env, capture_output=True, text=True,
                                    timeout=120)
            self.assertEqual(result.returncode, 1, result.stderr)
            self.assertIn(f"error: {os.path.join(blocked, first)}: cannot write:", result.stderr)
            self.assertNotIn("Traceback", result.stderr)
            self.assertEqual(sorted(os.listdir(blocked)), sorted(FIGURES))
            for name in list(FIGURES)[1:]:
                self.assertIn(os.path.join(blocked, name), result.stdout)
            # Its own folder may hold them; another run's folder or figures/ may not.
            self.assertEqual(run_module("plot", run_dir, "-o", run_dir).returncode, 0)
            other = os.path.join(d, "other")
            write_synthetic_run(other, kind="A", duration=400.0, seed=5)
            os.mkdir(os.path.join(other, "figures"))
            for target in (other, os.path.join(other, "figures"),
                           os.path.join(other, "figures", "..")):
                with self.subTest(target=target):
                    result = run_module("plot", run_dir, "-o", target)
                    self.assertEqual(result.returncode, 2, result.stderr)
                    self.assertTrue(result.stderr.startswith(f"error: {target}: -o: "),
                                    result.stderr)
                    self.assertIn("another run's folder", result.stderr)
                    self.assertIn(f"holds {RUN_FILE}", result.stderr)
                    self.assertEqual(os.listdir(os.path.join(other, "figures")), [])
                    self.assertFalse(any(f.endswith(".png") for f in os.listdir(other)))
            # Not a folder: named as what it is, where making the folder said "File exists".
            loop = os.path.join(d, "loop")
            os.symlink(loop, loop)
            a_file = os.path.join(d, "a_file")
            open(a_file, "w").close()
            for target, what in ((os.devnull, "a device or socket"), (a_file, "a file"),
                                 (loop, "a link that cannot be followed")):
                with self.subTest(target=target):
                    result = run_module("plot", run_dir, "-o", target)
                    self.assertEqual(result.returncode, 2, result.stderr)
                    self.assertIn(f"error: {target}: -o: is {what}", result.stderr)
                    self.assertIn("not a folder", result.stderr)
            # A campaign's runs/ folder holds runs only: figures there would be listed as one.
            campaign = os.path.join(d, "campaign")
            os.makedirs(os.path.join(campaign, "runs"))
            with open(os.path.join(campaign, "campaign.toml"), "w") as f:
                f.write("")
            runs = os.path.join(campaign, "runs")
            for target in (runs, os.path.join(runs, "figs")):
                with self.subTest(target=target):
                    result = run_module("plot", run_dir, "-o", target)
                    self.assertEqual(result.returncode, 2, result.stderr)
                    self.assertIn("a campaign's runs folder", result.stderr)
                    self.assertEqual(os.listdir(runs), [])

    def test_interrupted_short_run_is_not_steady_but_analyzed(self):
        with tempfile.TemporaryDirectory() as d:
            write_synthetic_run(d, kind="B", duration=2000.0, time_reached=130.0)
            result = run_module("analyze", d)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn("not steady: ", result.stdout)
            self.assertIn("NOT finished", result.stdout)
            with open(os.path.join(d, "summary.json")) as f:
                summary = json.load(f)
            self.assertFalse(summary["steady"])
            self.assertFalse(summary["case"]["finished"])
            self.assertEqual(summary["steady_windows"], 1)
            self.assertIsNone(summary["bulk"]["mu_eff"]["err"])
            self.assertIsNotNone(summary["bulk"]["mu_eff"]["mean"])
            # One window of 130 t: too short to tell, and the reason says so.
            self.assertEqual(summary["regime"], "undecided")
            self.assertIn("too short", summary["regime_criteria"]["reason"])
            self.assertEqual(run_module("analyze", d, "--quiet").stdout, "")
            written = plot_run(load_run(d), analyze(load_run(d)), os.path.join(d, "figures"))
            self.assertEqual(sorted(map(os.path.basename, written)), sorted(FIGURES))


class WithoutCompleteWindow(unittest.TestCase):
    """Runs shorter than one averaging window (80): analysed and plotted, flagged, exit 0."""

    def test_analyze_and_plot_a_run_shorter_than_a_window(self):
        with tempfile.TemporaryDirectory() as d:
            write_synthetic_run(d, kind="A", duration=20.0)     # cdshear run, duration = 20
            result = run_module("analyze", d)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertEqual(result.stderr, "")
            head = result.stdout.splitlines()[:4]
            self.assertIn("t = 20 of 20, finished", head[0])
            self.assertTrue(head[1].startswith("not steady: run too short for steady state, "
                                               "no complete averaging window (t = 20 < window "
                                               "80)"), head[1])
            self.assertIn("only indicative", head[3])
            self.assertIn(f"cdshear run --resume {d} --set shear.duration=340", result.stdout)
            self.assertIn("regime undetermined", result.stdout)
            self.assertLessEqual(len(result.stdout.splitlines()), 14)
            with open(os.path.join(d, "summary.json")) as f:
                s = json.loads(f.read(), parse_constant=lambda c: self.fail(c))
            self.assertEqual(set(s), SUMMARY_KEYS)
            self.assertFalse(s["steady"])
            self.assertIn("no complete averaging window (t = 20 < window 80)", s["steady_reason"])
            self.assertIsNone(s["regime"])
            self.assertIsNone(s["regime_confidence"])
            self.assertIn("no complete averaging window", s["regime_criteria"]["reason"])
            self.assertIsNone(s["regime_criteria"]["shear_rate_ratio"])
            self.assertEqual(s["regime_criteria"]["com_fraction"], 0.0)
            self.assertIsNone(s["transient_end_time"])
            self.assertEqual((s["steady_windows"], s["steady_window_indices"]), (0, []))
            self.assertEqual(s["averaging_start_time"], 10.0)
            self.assertIsNone(s["bulk"]["mu_eff"]["mean"])
            self.assertIsNone(s["bulk"]["h"])
            self.assertIsNone(s["slip"]["bottom"]["mean"])
            self.assertEqual(list(s["regions"]), ["h5", "h10"])
            self.assertIsNone(s["regions"]["h10"]["bulk"]["mu_eff"]["mean"])
            self.assertEqual(len(s["profiles"]["y"]), 25)
            self.assertEqual(s["profiles"]["vx"]["mean"], [None] * 25)
            # the series quantities, over the last half (samples at t = 10 .. 20)
            self.assertAlmostEqual(s["mu_eff_wall"]["mean"], 0.30, delta=0.03)
            self.assertAlmostEqual(s["height"]["mean"], 20.0, delta=0.2)
            self.assertIsNotNone(s["solid_fraction"]["err"])
            self.assertEqual(sum(s["com_vx"]["histogram"]["counts"]), 21)
            self.assertIsNotNone(s["com_vx"]["std"])
            self.assertIsNotNone(s["solver"]["max_sweeps"])

            result = run_module("plot", d)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertEqual(result.stderr, "")
            made = ["snapshot.png", "com_velocity.png", "height_solid_fraction.png"]
            self.assertEqual(sorted(os.listdir(os.path.join(d, "figures"))), sorted(made))
            for name in made:
                self.assertIn(os.path.join(d, "figures", name), result.stdout)
                with open(os.path.join(d, "figures", name), "rb") as f:
                    self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
            for name in ("velocity_profiles.png", "steady_profiles.png"):
                self.assertIn(f"skipped {name}: ", result.stdout)
            self.assertIn("no complete averaging window", result.stdout)

    def test_interrupted_before_the_first_window_and_few_samples(self):
        with tempfile.TemporaryDirectory() as d:
            for reached, samples in ((50.0, 100), (1.0, 2), (0.5, 1)):
                with self.subTest(time_reached=reached):
                    run_dir = os.path.join(d, f"t{reached:g}")
                    write_synthetic_run(run_dir, kind="C", duration=400.0, time_reached=reached)
                    run = load_run(run_dir)
                    self.assertEqual(len(run["series"]["time"]), samples)
                    with warnings.catch_warnings():
                        warnings.simplefilter("error")
                        s = analyze(run)
                    self.assertFalse(s["steady"])
                    self.assertIn(f"(t = {reached:g} < window 80)", s["steady_reason"])
                    self.assertIsNone(s["regime"])
                    report = format_report(s, "summary.json")
                    self.assertIn("NOT finished", report.splitlines()[0])
                    self.assertIn("not steady: run too short", report.splitlines()[1])
                    json.dumps(jsonable(s), allow_nan=False)
                    skipped = []
                    written = plot_run(run, s, os.path.join(run_dir, "figures"), skipped)
                    self.assertEqual(len(written), 3)
                    self.assertEqual(sorted(name for name, _ in skipped),
                                     ["steady_profiles.png", "velocity_profiles.png"])

    def test_scalar_boundary_thickness_and_snapshot_time_as_dataset(self):
        with tempfile.TemporaryDirectory() as d:
            write_synthetic_run(d, kind="B", duration=200.0, boundary_thickness=(10.0,))
            with h5py.File(os.path.join(d, "run.h5"), "a") as f:
                self.assertEqual(f.attrs["boundary_thickness"].shape, (1,))
                f.attrs["boundary_thickness"] = 10.0                  # scalar
                f.attrs["window"] = np.array([80.0])                  # one-element array
                snap = f["snapshot"]
                for k in ("time", "length_x", "height"):             # datasets, not attributes
                    value = snap.attrs[k]
                    del snap.attrs[k]
                    snap.create_dataset(k, data=value)
            seal(os.path.join(d, "run.h5"))
            run = load_run(d)
            np.testing.assert_array_equal(run["attrs"]["boundary_thickness"], [10.0])
            self.assertEqual(run["attrs"]["window"], 80.0)
            self.assertEqual(run["snapshot"]["time"], 200.0)
            self.assertIsInstance(run["snapshot"]["height"], float)
            s = analyze(run)
            self.assertEqual(len(run["windows"]["t_start"]), 2)
            self.assertEqual(s["case"]["boundary_thickness"].tolist(), [10.0])
            self.assertEqual(list(s["regions"]), ["h10"])
            written = plot_run(run, s, os.path.join(d, "figures"))
            self.assertEqual(len(written), len(FIGURES))


class SpecialFiles(unittest.TestCase):
    """A FIFO where a file is read is refused at once: opening it would wait for a writer that
    never comes (an alarm turns such a wait into a failure)."""

    def setUp(self):
        import signal
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)
        signal.signal(signal.SIGALRM, lambda *_: (_ for _ in ()).throw(TimeoutError("blocked")))
        signal.alarm(20)
        self.addCleanup(signal.alarm, 0)

    def fifo(self, *parts):
        path = os.path.join(self.tmp.name, *parts)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        os.mkfifo(path)
        return path

    def test_readers_refuse_a_fifo_naming_it(self):
        from cdshear_analysis.report import ReportError, read_summary, software
        from cdshear_analysis.rundata import open_regular
        path = self.fifo("run", "summary.json")
        with self.assertRaises(OSError) as e:
            open_regular(path)
        self.assertIn("not a regular file (a FIFO)", str(e.exception))
        self.assertIn(path, str(e.exception))
        with self.assertRaises(ReportError) as r:
            read_summary(os.path.dirname(path))
        self.assertIn("a FIFO", str(r.exception))
        self.fifo("run", "run_info.json")
        self.assertEqual(software("", [os.path.dirname(path)])["runs"],
                         {"unknown (no readable run_info.json)": 1})

    def test_analyze_of_a_run_whose_case_toml_is_a_fifo_finishes(self):
        run_dir = os.path.join(self.tmp.name, "runC")
        write_synthetic_run(run_dir, kind="C", duration=400.0, seed=3)
        os.remove(os.path.join(run_dir, "case.toml"))
        self.fifo("runC", "case.toml")
        result = run_module("analyze", run_dir)
        self.assertEqual(result.returncode, 0, result.stderr)

    def test_analyze_of_a_run_whose_case_toml_cannot_be_decoded_reads_run_h5s_own(self):
        # run.h5 carries its case; a damaged case.toml beside it is not blamed on run.h5.
        run_dir = os.path.join(self.tmp.name, "runD")
        write_synthetic_run(run_dir, kind="A", duration=400.0, seed=4)
        with open(os.path.join(run_dir, "case.toml"), "wb") as f:
            f.write(b"\xff\xfe not UTF-8\n")
        result = run_module("analyze", run_dir)
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertTrue(os.path.isfile(os.path.join(run_dir, "summary.json")))


class OutputEncoding(unittest.TestCase):
    def test_a_folder_name_that_is_not_utf8_prints_as_its_bytes_under_a_strict_locale(self):
        # stdout strict, as under en_US.UTF-8 (C.UTF-8 escapes surrogates itself): the name's
        # bytes come back as they were, not a UnicodeEncodeError traceback.
        with tempfile.TemporaryDirectory() as tmp:
            run = os.path.join(os.fsencode(tmp), b"run\xff")
            write_synthetic_run(os.fsdecode(run), kind="A", duration=100.0)
            env = dict(os.environ, PYTHONPATH=PYTHON_DIR, PYTHONIOENCODING="utf-8:strict")
            out = subprocess.run([sys.executable, "-m", "cdshear_analysis", "stress-balance",
                                  run], env=env, capture_output=True, timeout=120)
            self.assertEqual(out.returncode, 0, out.stderr)
            self.assertNotIn(b"Traceback", out.stderr)
            self.assertIn(run, out.stdout)


if __name__ == "__main__":
    unittest.main()

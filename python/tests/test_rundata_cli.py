"""load_run round trip against docs/run-data.md, bad input, and analyze/plot end to end."""
import json
import os
import re
import subprocess
import sys
import tempfile
import unittest

import h5py
import numpy as np

from cdshear_analysis import RunDataError, load_run
from cdshear_analysis.synthetic import write_synthetic_run

PYTHON_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUN_DATA_DOC = os.path.join(PYTHON_DIR, "..", "docs", "run-data.md")
SUMMARY_KEYS = {
    "format", "version", "run_dir", "case", "steady", "steady_reason", "transient_end_time",
    "transient_end_strain", "averaging_start_time", "averaging_start_strain", "truncation_times",
    "independent_samples", "drift_sigmas", "steady_windows", "steady_window_indices",
    "window_errors", "regime", "regime_confidence", "regime_criteria", "mu_eff_wall", "height",
    "solid_fraction", "com_vx", "bulk", "slip", "regions", "profiles", "switches",
    "switch_duration", "solver"}
FIGURES = ["snapshot.png", "velocity_profiles.png", "com_velocity.png",
           "height_solid_fraction.png", "steady_profiles.png"]


def documented_names():
    """{section: names} from the tables of docs/run-data.md (first column, in backquotes)."""
    names, section = {}, None
    with open(RUN_DATA_DOC, encoding="utf-8") as f:
        for line in f:
            if line.startswith("#"):
                section = ("attrs" if "Root attributes" in line else "regions" if "regions" in line
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
        young = os.path.join(d, "young")
        write_synthetic_run(young, kind="A", duration=400.0, time_reached=50.0)
        cases = [("nowhere", os.path.join(d, "nowhere"), "no such folder"),
                 ("not_a_run", os.path.join(d, "not_a_run"), "no run.h5"),
                 ("empty", os.path.join(d, "empty", "run.h5"), "empty file"),
                 ("text", os.path.join(d, "text", "run.h5"), "HDF5"),
                 ("truncated", os.path.join(truncated, "run.h5"), "HDF5"),
                 ("missing", os.path.join(missing, "run.h5"), "/series/com_vx"),
                 ("young", os.path.join(young, "run.h5"), "no complete averaging window")]
        for command in ("analyze", "plot"):
            for name, path, problem in cases:
                with self.subTest(command=command, case=name):
                    folder = path if name in ("nowhere", "not_a_run") else os.path.dirname(path)
                    result = run_module(command, folder)
                    self.assertEqual(result.returncode, 2, result.stderr)
                    self.assertTrue(result.stderr.startswith(f"error: {path}: "), result.stderr)
                    self.assertIn(problem, result.stderr)
                    self.assertNotIn("Traceback", result.stderr)
        with self.assertRaises(RunDataError):
            load_run(os.path.join(d, "empty"))


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
            self.assertEqual((summary["format"], summary["version"]), ("cdshear-summary", 1))
            self.assertEqual(set(summary["regions"]["h10"]), {"h", "bulk", "bottom", "top"})
            self.assertEqual(set(summary["regions"]["h5"]["bulk"]),
                             {"mu_eff", "solid_fraction", "coordination", "shear_rate",
                              "inertial_number"})
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
            self.assertEqual(run_module("analyze", d, "--quiet").stdout, "")


if __name__ == "__main__":
    unittest.main()

"""The parameter-study collector: rows from analysed runs, agreement with the reference."""
import io
import json
import math
import os
import shutil
import tempfile
import unittest
from contextlib import redirect_stderr, redirect_stdout

from cdshear_analysis import study
from cdshear_analysis.__main__ import main
from cdshear_analysis.rundata import seal


def fake_run(folder, mu, mu_err, sweeps, wall_seconds, time=100.0, averaging_start=None,
             case=None):
    """A run folder with the parts of summary.json and run_info.json that a study reads;
    `case`: more values of summary.json's `case`."""
    os.makedirs(folder)
    entry = lambda m, e: {"mean": m, "err": e}  # noqa: E731
    summary = {
        "steady": True, "case": dict(case or {}, time=time),
        "mu_eff_wall": entry(mu, mu_err), "solid_fraction": entry(0.8, 0.001),
        "height": entry(20.0, 0.01),
        "bulk": {"mu_eff": entry(mu, mu_err), "solid_fraction": entry(0.81, 0.001),
                 "coordination": entry(1.6, 0.02), "inertial_number": entry(0.02, 0.002)},
        "slip": {"bottom": entry(0.05, 0.005), "top": entry(0.05, 0.005)},
        "com_vx": {"std": 0.02},
    }
    if averaging_start is not None:
        summary["averaging_start_time"] = averaging_start
    info = {"summary": {"steps": 1000, "mean_sweeps": sweeps, "capped_steps": 250,
                        "largest_overlap": 1e-5, "wall_seconds": wall_seconds}}
    with open(os.path.join(folder, "summary.json"), "w") as f:
        json.dump(summary, f)
    with open(os.path.join(folder, "run_info.json"), "w") as f:
        json.dump(info, f)


class StudyTest(unittest.TestCase):
    def test_rows_agreement_and_outputs(self):
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.260, 0.004, 900.0, 500.0)
            fake_run(os.path.join(d, "solver.max_sweeps=50"), 0.300, 0.004, 50.0, 30.0)
            fake_run(os.path.join(d, "solver.max_sweeps=200"), 0.265, 0.004, 180.0, 100.0)
            fake_run(os.path.join(d, "solver.order=coloured"), 0.262, 0.004, 180.0, 100.0)
            rows = study.collect(d)
            self.assertEqual(len(rows), 4)
            ref = next(r for r in rows if r["key"] is None)
            by_value = {r["value"]: r for r in rows if r["key"] is not None}
            # 0.300 is 0.040 away: more than 2 * sqrt(2) * 0.004 = 0.0113; 0.265 is within.
            self.assertFalse(study.agrees(by_value[50.0], ref, "mu_eff_wall"))
            self.assertTrue(study.agrees(by_value[200.0], ref, "mu_eff_wall"))
            self.assertTrue(study.agrees(by_value["coloured"], ref, "mu_eff_wall"))
            self.assertAlmostEqual(by_value[50.0]["wall_s_per_time"], 0.3)
            self.assertAlmostEqual(by_value[50.0]["capped_share"], 0.25)
            self.assertEqual(main(["study", d]), 0)
            with open(os.path.join(d, "study.md")) as f:
                text = f.read()
            self.assertIn("solver.max_sweeps=50 | yes | 0.3000 ± 0.0040 (differs)", text)
            self.assertIn("solver.max_sweeps=200 | yes | 0.2650 ± 0.0040 |", text)
            self.assertTrue(os.path.isfile(os.path.join(d, "figures", "mu_eff_wall.png")))

    def test_a_steady_flag_that_is_not_true_is_not_steady(self):
        """Only the JSON true of summary.json is steady: a text "false" is not (bool("false") is
        True)."""
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.26, 0.004, 100.0, 10.0)
            path = os.path.join(d, "reference", "summary.json")
            with open(path) as f:
                summary = json.load(f)
            for flag, steady in ((True, True), ("false", False), ("no", False), (1, False)):
                with open(path, "w") as f:
                    json.dump(dict(summary, steady=flag), f)
                self.assertIs(study.collect(d)[0]["steady"], steady, flag)

    def test_resumed_parts_count_in_the_cost(self):
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.26, 0.004, 100.0, 50.0, time=300.0)
            # A resumed part: 3000 more steps at 200 sweeps, 250 s, a larger overlap.
            with open(os.path.join(d, "reference", "run_info_resume_1000.json"), "w") as f:
                json.dump({"summary": {"steps": 3000, "mean_sweeps": 200.0, "capped_steps": 750,
                                       "largest_overlap": 4e-5, "wall_seconds": 250.0}}, f)
            ref = study.collect(d)[0]
            self.assertAlmostEqual(ref["mean_sweeps"], (1000 * 100.0 + 3000 * 200.0) / 4000)
            self.assertAlmostEqual(ref["capped_share"], 1000 / 4000)
            self.assertAlmostEqual(ref["wall_s_per_time"], 300.0 / 300.0)
            self.assertAlmostEqual(ref["largest_overlap"], 4e-5)

    def test_a_run_whose_first_sitting_was_killed_costs_what_its_records_hold(self):
        # killed in its first sitting (no run_info.json), resumed at t = 200 (step 2000) to its
        # end at 300 (step 3000): the cost per time unit is over the 100 t the record covers
        with tempfile.TemporaryDirectory() as d:
            run = os.path.join(d, "reference")
            fake_run(run, 0.26, 0.004, 100.0, 50.0, time=300.0)
            os.remove(os.path.join(run, "run_info.json"))
            with open(os.path.join(run, "run_info_resume_3000.json"), "w") as f:
                json.dump({"dt": 0.1, "summary": {"steps": 1000, "mean_sweeps": 80.0,
                                                  "capped_steps": 10, "largest_overlap": 1e-5,
                                                  "wall_seconds": 20.0}}, f)
            ref = study.collect(d)[0]
            self.assertAlmostEqual(ref["wall_s_per_time"], 20.0 / 100.0)
            self.assertAlmostEqual(ref["mean_sweeps"], 80.0)
            os.remove(os.path.join(run, "run_info_resume_3000.json"))
            with self.assertRaises(study.StudyError) as e:
                study.collect(d)
            self.assertIn("run_info.json: missing, and no run_info_resume_*.json either",
                          str(e.exception))

    def test_reference_realizations_are_combined_by_their_errors(self):
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.24, 0.004, 900.0, 500.0)
            fake_run(os.path.join(d, "reference_seed2"), 0.27, 0.002, 900.0, 500.0)
            fake_run(os.path.join(d, "solver.max_sweeps=50"), 0.25, 0.004, 50.0, 30.0)
            rows = study.collect(d)
            self.assertEqual(len(rows), 2)
            ref = rows[0]
            self.assertIsNone(ref["key"])
            self.assertEqual(ref["realizations"], 2)
            # weights 1/0.004^2 and 1/0.002^2 (1:4)
            self.assertAlmostEqual(ref["mu_eff_wall"], (0.24 + 4 * 0.27) / 5)
            # Their scatter about that mean, sqrt(sum w (x - mean)^2 / ((k - 1) sum w)) =
            # sqrt(0.2 * 0.024^2 + 0.8 * 0.006^2) = 0.012 (the weighted mean's; a plain mean's
            # would be 0.015), exceeds the combined error 1/sqrt(1/0.004^2 + 1/0.002^2) = 0.0018
            # and sets the error...
            self.assertAlmostEqual(ref["mu_eff_wall_err"], 0.012)
            # ...while for the solid fraction (equal values) the combined error does.
            self.assertAlmostEqual(ref["solid_fraction_err"], 0.001 / 2 ** 0.5)
            self.assertEqual(main(["study", d]), 0)
            with open(os.path.join(d, "study.md")) as f:
                self.assertIn("| reference (2 runs combined) | yes |", f.read())

    def test_a_copy_of_a_realization_is_refused(self):
        """Runs are deterministic: two realizations that end in the same state at the same step
        (their run_info files) are one run, which combined would shrink the error by sqrt(2)."""
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.24, 0.004, 900.0, 500.0)
            fake_run(os.path.join(d, "reference_seed2"), 0.27, 0.002, 900.0, 500.0)
            for name, state in (("reference", "1a2b"), ("reference_seed2", "3c4d")):
                with open(os.path.join(d, name, "run_info.json"), "r+") as f:
                    info = json.load(f)
                    f.seek(0)
                    json.dump(dict(info, step=1000, state_hash=state), f)
            self.assertEqual(study.collect(d)[0]["realizations"], 2)
            shutil.copytree(os.path.join(d, "reference"), os.path.join(d, "reference_seed3"))
            with self.assertRaisesRegex(study.StudyError, "reference_seed3 holds the run "
                                        f"{os.path.join(d, 'reference')} holds .both end at "
                                        "step 1000 in state 1a2b"):
                study.collect(d)
            err = io.StringIO()
            with redirect_stderr(err):
                self.assertEqual(main(["study", d]), 2)
            self.assertIn("realizations of the reference:", err.getvalue())

    def test_realizations_that_say_their_averaged_time_are_weighted_by_it(self):
        with tempfile.TemporaryDirectory() as d:
            # Averages over 300 and 100 time units (weights 3:1), whatever their error bars:
            # the smaller error bar goes with the shorter run here.
            fake_run(os.path.join(d, "reference"), 0.24, 0.004, 900.0, 500.0, time=400.0,
                     averaging_start=100.0)
            fake_run(os.path.join(d, "reference_seed2"), 0.28, 0.002, 900.0, 500.0, time=200.0,
                     averaging_start=100.0)
            ref = study.collect(d)[0]
            self.assertEqual(ref["realizations"], 2)
            self.assertAlmostEqual(ref["mu_eff_wall"], (3 * 0.24 + 0.28) / 4)
            # Scatter: sqrt((300 * 0.01^2 + 100 * 0.03^2) / (1 * 400)) = 0.01732, more than the
            # propagated sqrt(0.75^2 0.004^2 + 0.25^2 0.002^2) = 0.00304.
            self.assertAlmostEqual(ref["mu_eff_wall_err"], (0.12 / 400) ** 0.5)
            # Equal values: the propagated error sets it, sqrt(0.75^2 + 0.25^2) * 0.001.
            self.assertAlmostEqual(ref["solid_fraction_err"], 0.001 * (0.625 ** 0.5))
            # One realization without the time: back to the weights 1/err^2 for all.
            fake_run(os.path.join(d, "reference_seed3"), 0.26, 0.004, 900.0, 500.0)
            ref = study.collect(d)[0]
            self.assertAlmostEqual(ref["mu_eff_wall"], (0.24 + 4 * 0.28 + 0.26) / 6)

    def test_two_folders_of_realizations_compared_in_combined_errors(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            # a: two seeds at 0.25 +- 0.004 (combined 0.25 +- 0.004 / sqrt 2); b: one at 0.27.
            fake_run(os.path.join(a, "reference"), 0.25, 0.004, 60.0, 10.0)
            fake_run(os.path.join(a, "reference_seed2"), 0.25, 0.004, 40.0, 10.0)
            fake_run(os.path.join(b, "reference"), 0.27, 0.003, 30.0, 5.0)
            os.makedirs(os.path.join(b, "reference_seed2"))    # still running: no summary.json
            ra, rb, lines, skipped = study.compare_references(a, b)
            self.assertEqual(skipped, [os.path.join(b, "reference_seed2")])
            self.assertEqual(ra["realizations"], 2)
            self.assertAlmostEqual(ra["mean_sweeps"], 50.0)
            by_name = {line[0]: line for line in lines}
            _, xa, ea, xb, eb, diff, p = by_name["mu_eff_wall"]
            self.assertTrue(math.isnan(p))   # one realization in b: no Welch test
            self.assertAlmostEqual(xa, 0.25)
            self.assertAlmostEqual(ea, 0.004 / 2 ** 0.5)
            self.assertAlmostEqual(diff, 0.02 / (0.004 ** 2 / 2 + 0.003 ** 2) ** 0.5)
            self.assertAlmostEqual(by_name["solid_fraction"][5], 0.0)   # same value in both
            out = io.StringIO()
            with redirect_stdout(out):
                self.assertEqual(main(["study-compare", a, b]), 0)
            # 0.02 / 0.0041 = 4.9 combined errors: more than the study's 2.
            self.assertIn(f"| mu_eff_wall | 0.25 ± 0.0028 | 0.27 ± 0.003 | {diff:+.2f} (differs) "
                          "| n/a |", out.getvalue())
            self.assertIn("| solid_fraction | 0.8 ± 0.00071 | 0.8 ± 0.001 | +0.00 | n/a |",
                          out.getvalue())
            self.assertIn("| mean_sweeps | 50.0 | 30.0 | | |", out.getvalue())
            self.assertNotIn("Bonferroni", out.getvalue())   # no p-value to read
            self.assertIn(f"| quantity | {a} (2 runs) | {b} (1 run) |", out.getvalue())
            self.assertEqual(study.counted(1, "analysed run"), "1 analysed run")
            self.assertEqual(study.counted(0, "run"), "0 runs")
            self.assertIn(f"left out {os.path.join(b, 'reference_seed2')}: no summary.json yet",
                          out.getvalue())
            # A folder without an analysed reference is an error naming it.
            err = io.StringIO()
            with redirect_stderr(err):
                self.assertEqual(main(["study-compare", a, os.path.join(d, "none")]), 2)
            self.assertIn("none", err.getvalue())

    def test_welch_p_value_against_its_closed_form(self):
        # a = (0, 2), b = (1, 3): means 1 and 2, variances 2, t = -1 / sqrt(2), Welch's degrees
        # of freedom (1 + 1)^2 / (1 + 1) = 2, where the two-sided p is 1 - |t| / sqrt(t^2 + 2).
        t = 1 / math.sqrt(2)
        self.assertAlmostEqual(study.welch_p([0.0, 2.0], [1.0, 3.0]), 1 - t / math.sqrt(t * t + 2),
                               places=12)
        self.assertLess(study.welch_p([0.0, 0.1, 0.2], [5.0, 5.1, 5.2]), 1e-4)
        self.assertTrue(math.isnan(study.welch_p([1.0], [1.0, 2.0])))        # one value
        self.assertTrue(math.isnan(study.welch_p([1.0, 1.0], [2.0, 2.0])))   # no scatter
        self.assertTrue(math.isnan(study.welch_p([1.0, math.nan], [1.0, 2.0])))
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            for folder, values in ((a, (0.24, 0.26)), (b, (0.25, 0.27))):
                for k, mu in enumerate(values):
                    fake_run(os.path.join(folder, f"reference_seed{k + 1}"), mu, 0.004, 50.0,
                             10.0)
            *_, lines, _ = study.compare_references(a, b)
            p = {line[0]: line[6] for line in lines}
            # (0.24, 0.26) against (0.25, 0.27): a = (0, 2), b = (1, 3) scaled by 0.01
            self.assertAlmostEqual(p["mu_eff_wall"], 1 - t / math.sqrt(t * t + 2), places=9)
            out = io.StringIO()
            with redirect_stdout(out):
                self.assertEqual(main(["study-compare", a, b]), 0)
            self.assertIn(f"| {1 - t / math.sqrt(t * t + 2):.2g} |", out.getvalue())
            self.assertIn("up to 37% of the time; below 0.0056 (0.05 / 9, Bonferroni)",
                          out.getvalue())

    def test_windows_show_a_drift_and_where_two_folders_part(self):
        import h5py
        import numpy as np

        def series_run(folder, slope, offset, mu, end=100.0):
            """A realization whose solid fraction rises linearly, offset + slope t, and whose
            walls carry |f_x| / |f_y| = mu (bottom and top alike), sampled every 0.5."""
            fake_run(folder, mu, 0.004, 50.0, 10.0)
            t = np.arange(0.5, end + 0.25, 0.5)
            path = os.path.join(folder, "run.h5")
            with h5py.File(path, "w", userblock_size=512) as f:
                g = f.create_group("series")
                g["time"] = t
                g["solid_fraction"] = offset + slope * t
                g["bottom_fx"], g["top_fx"] = -mu * np.ones_like(t), mu * np.ones_like(t)
                g["bottom_fy"], g["top_fy"] = np.ones_like(t), -np.ones_like(t)
            seal(path)

        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            # a: flat, 0.80 and 0.81; b: both rise by 1e-4 per time unit from 0.80 and 0.81.
            series_run(os.path.join(a, "reference"), 0.0, 0.80, 0.2)
            series_run(os.path.join(a, "reference_seed2"), 0.0, 0.81, 0.3)
            series_run(os.path.join(b, "reference"), 1e-4, 0.80, 0.2)
            series_run(os.path.join(b, "reference_seed2"), 1e-4, 0.81, 0.2, end=50.0)
            edges, k, means = study.windowed_means(a, 2)
            self.assertEqual(k, 2)
            self.assertEqual(list(edges), [0.0, 50.0, 100.0])
            # Mean of the two realizations, error std / sqrt 2 = 0.005 (ddof 1).
            for mean, err in means["solid_fraction"]:
                self.assertAlmostEqual(mean, 0.805)
                self.assertAlmostEqual(err, 0.005)
            self.assertAlmostEqual(means["mu_eff_wall"][0][0], 0.25)
            # b's windows end where its shortest realization ends (t = 50): samples 0.5 to 25
            # average t = 12.75, samples 25.5 to 50 average t = 37.75.
            edges_b, _, means_b = study.windowed_means(b, 2)
            self.assertEqual(list(edges_b), [0.0, 25.0, 50.0])
            self.assertAlmostEqual(means_b["solid_fraction"][0][0], 0.805 + 1e-4 * 12.75)
            self.assertAlmostEqual(means_b["solid_fraction"][1][0], 0.805 + 1e-4 * 37.75)
            out = io.StringIO()
            with redirect_stdout(out):
                self.assertEqual(main(["study-compare", a, b, "--windows", "2"]), 0)
            text = out.getvalue()
            self.assertIn(f"| solid_fraction, time window | {a} (2 runs) | {b} (2 runs) |", text)
            # both folders cut at b's end, t = 50: a's rows hold the same stretches as b's
            self.assertIn("| 0 to 25 | 0.805 ± 0.005 | ", text)
            self.assertNotIn("to 100", text)
            (edges_a, _, _), (edges_b, _, _) = study.common_windows(a, b, 2)
            self.assertEqual(list(edges_a), list(edges_b))
            # b's drift: 1e-4 x 25 = 0.0025 over errors of 0.005 each: 0.0025 / 0.00707.
            self.assertIn(f"drift of solid_fraction in {b}, last window - first: +0.0025 "
                          "(+0.35 combined errors)", text)
            self.assertIn(f"drift of solid_fraction in {a}, last window - first: +0 ", text)
            # One realization has no error, and one window no drift: said so, never "nan".
            c = os.path.join(d, "c")
            series_run(os.path.join(c, "reference"), 1e-4, 0.80, 0.2)
            with redirect_stdout(io.StringIO()) as out:
                self.assertEqual(main(["study-compare", a, c, "--windows", "1"]), 0)
            windows = out.getvalue()[out.getvalue().index("time window"):]
            c_mean = np.mean(0.80 + 1e-4 * np.arange(0.5, 100.25, 0.5))   # its samples' mean
            self.assertIn(f"| 0 to 100 | 0.805 ± 0.005 | {c_mean:.5g} (no error) | n/a |",
                          windows)
            self.assertIn("A folder of one realization has no error", windows)
            self.assertNotIn("nan", windows)
            self.assertNotIn("drift", windows)
            with redirect_stderr(io.StringIO()) as err:
                with redirect_stdout(io.StringIO()) as plain:
                    self.assertEqual(main(["study-compare", a, b, "--windows", "0"]), 0)
                    self.assertNotIn("time window", plain.getvalue())
                    self.assertEqual(main(["study-compare", a, b, "--windows", "-1"]), 2)
                os.remove(os.path.join(b, "reference_seed2", "run.h5"))
                with redirect_stdout(io.StringIO()) as out:
                    self.assertEqual(main(["study-compare", a, b, "--windows", "2"]), 2)
                self.assertEqual(out.getvalue(), "")   # no table above the error
            self.assertIn(os.path.join(b, "reference_seed2", "run.h5") + ": missing",
                          err.getvalue())
            # A damaged or unsealed run.h5, a FIFO in its place, and more windows than samples
            # are refused by name, as `analyze` refuses them.
            path = os.path.join(b, "reference_seed2", "run.h5")
            shutil.rmtree(os.path.dirname(path))
            series_run(os.path.dirname(path), 1e-4, 0.81, 0.2, end=50.0)
            with open(path, "r+b") as f:
                f.seek(-8, os.SEEK_END)
                f.write(b"\xff" * 8)
            with self.assertRaisesRegex(study.StudyError, "damaged"):
                study.windowed_means(b, 2)
            os.remove(path)
            os.mkfifo(path)
            with self.assertRaisesRegex(study.StudyError, "not a regular file"):
                study.windowed_means(b, 2)
            shutil.rmtree(os.path.dirname(path))
            series_run(os.path.dirname(path), 1e-4, 0.81, 0.2, end=50.0)
            with self.assertRaisesRegex(study.StudyError, "--windows 101: more windows than the "
                                                          "100 samples"):
                study.windowed_means(b, 101)

    def test_runs_not_analysed_are_left_out_and_a_reference_is_required(self):
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "step.dt=0.002"), 0.26, 0.004, 100.0, 10.0)
            with self.assertRaises(study.StudyError) as e:
                study.collect(d)
            self.assertIn("reference", e.exception.problem)
            os.makedirs(os.path.join(d, "reference"))  # still running: no summary.json
            with self.assertRaises(study.StudyError) as e:
                study.collect(d)
            self.assertEqual(main(["study", d]), 2)
            fake_run(os.path.join(d, "ref2"), 0.26, 0.004, 100.0, 10.0)
            os.rename(os.path.join(d, "ref2"), os.path.join(d, "reference_done"))
            os.rmdir(os.path.join(d, "reference"))
            os.rename(os.path.join(d, "reference_done"), os.path.join(d, "reference"))
            os.makedirs(os.path.join(d, "step.dt=0.004"))  # running
            skipped = []
            rows = study.collect(d, skipped)
            self.assertEqual(len(rows), 2)
            self.assertEqual(skipped, ["step.dt=0.004"])

    def test_quantities_without_values_give_empty_panels(self):
        # Runs too short to measure anything (NaN means) still give a table and figures.
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), float("nan"), float("nan"), 100.0, 10.0)
            fake_run(os.path.join(d, "solver.order=coloured"), float("nan"), float("nan"),
                     100.0, 10.0)
            self.assertEqual(main(["study", d]), 0)
            self.assertTrue(os.path.isfile(os.path.join(d, "figures", "mu_eff_wall.png")))

    def test_values_analyze_never_writes_are_left_out(self):
        # a summary edited by hand: a negative or NaN error, an infinite mean, a mean whose
        # square overflows; each such quantity is left out of its row, the others kept
        edits = {"mu_eff_wall": {"mean": 0.3, "err": -5.0},
                 "height": {"mean": 20.0, "err": float("nan")},
                 "solid_fraction": {"mean": float("inf"), "err": 0.001},
                 "slip": {"bottom": {"mean": 1e300, "err": 0.005},
                          "top": {"mean": 0.05, "err": 0.005}}}
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.26, 0.004, 100.0, 10.0)
            for k in (1, 2):
                run = os.path.join(d, f"solver.max_sweeps={50 * k}")
                fake_run(run, 0.30, 0.004, 50.0, 30.0)
                with open(os.path.join(run, "summary.json")) as f:
                    summary = json.load(f)
                with open(os.path.join(run, "summary.json"), "w") as f:
                    json.dump(dict(summary, **edits), f)
            rows = study.collect(d)
            for row in rows[1:]:
                for name in ("mu_eff_wall", "height", "solid_fraction", "slip_bottom"):
                    self.assertTrue(math.isnan(row[name]) and math.isnan(row[name + "_err"]))
                self.assertEqual((row["slip_top"], row["bulk_mu_eff"]), (0.05, 0.30))
            with redirect_stderr(io.StringIO()) as err, redirect_stdout(io.StringIO()):
                self.assertEqual(main(["study", d]), 0)
            self.assertNotIn("Traceback", err.getvalue())
            with open(os.path.join(d, "study.md"), encoding="utf-8") as f:
                table = f.read()
            line = next(x for x in table.splitlines() if x.startswith("| solver.max_sweeps=50 "))
            # mu_eff_wall, solid_fraction and slip_bottom of the shown five: said not there
            self.assertEqual(line.count("| n/a "), 3, line)
            self.assertNotIn("nan", line)
            # a reference realization holding 1e300: the realizations' scatter stays finite
            fake_run(os.path.join(d, "reference_seed2"), 0.26, 0.004, 100.0, 10.0)
            with open(os.path.join(d, "reference_seed2", "summary.json")) as f:
                summary = json.load(f)
            summary["bulk"]["mu_eff"]["mean"] = 1e300
            with open(os.path.join(d, "reference_seed2", "summary.json"), "w") as f:
                json.dump(summary, f)
            twin = d + "_twin"   # the same values in a second folder (a folder is not
            shutil.copytree(d, twin)   # compared with itself)
            self.addCleanup(shutil.rmtree, twin)
            with redirect_stdout(io.StringIO()) as out:
                self.assertEqual(main(["study-compare", d, twin]), 0)
            with redirect_stdout(io.StringIO()):
                self.assertEqual(main(["study", d]), 0)
            with open(os.path.join(d, "study.md"), encoding="utf-8") as f:
                line = next(x for x in f.read().splitlines() if x.startswith("| reference "))
            self.assertIn("(1 of 2 runs)", line)   # bulk_mu_eff, from reference alone
            # the value left out is said beside the mean of the other realization
            line = next(x for x in out.getvalue().splitlines() if x.startswith("| bulk_mu_eff"))
            self.assertEqual(line.count("(1 of 2 runs)"), 2, line)
            line = next(x for x in out.getvalue().splitlines() if x.startswith("| slip_top"))
            self.assertNotIn(" of 2 runs", line)

    def test_unreadable_summary_is_an_error_naming_the_file(self):
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.26, 0.004, 100.0, 10.0)
            with open(os.path.join(d, "reference", "summary.json"), "w") as f:
                f.write("{not json")
            with self.assertRaises(study.StudyError) as e:
                study.collect(d)
            self.assertTrue(e.exception.path.endswith("summary.json"))
            self.assertEqual(main(["study", d]), 2)

    def test_malformed_values_and_a_run_of_another_setting_are_named(self):
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.26, 0.004, 100.0, 10.0)
            run = os.path.join(d, "solver.max_sweeps=50")
            fake_run(run, 0.30, 0.004, 50.0, 30.0)
            with open(os.path.join(run, "summary.json")) as f:
                good = json.load(f)
            with open(os.path.join(run, "run_info.json")) as f:
                info = json.load(f)["summary"]
            for name, content, problem in (
                    ("summary.json", [1, 2], "summary.json: is not a JSON object"),
                    ("summary.json", dict(good, case={"time": "abc"}), "of the wrong type"),
                    ("summary.json", dict(good, com_vx=3), "summary.json: com_vx is not an "
                                                           "object"),
                    ("run_info.json", "str", "run_info.json: is not a JSON object"),
                    ("run_info.json", {"summary": {"steps": "many"}},
                     'run_info.json: summary.steps = "many": expected a whole number from 0'),
                    ("summary.json", dict(good, com_vx={"std": 10 ** 400}),
                     "summary.json: com_vx.std is 10000"),
                    ("summary.json", dict(good, com_vx={"std": -0.5}),
                     "summary.json: com_vx.std is -0.5: it must be a finite number >= 0"),
                    ("summary.json", dict(good, com_vx={"std": "abc"}), "com_vx.std is 'abc'"),
                    ("summary.json", dict(good, com_vx={"std": float("inf")}),
                     "com_vx.std is inf"),
                    ("run_info.json", {"summary": {"steps": 10 ** 400}},
                     "summary.steps = 1000000000000000000000000000000000000..."),
                    # figures `cdshear run` never writes, which the sums took as numbers or as 0
                    ("run_info.json", {"summary": dict(info, wall_seconds=-30.0)},
                     "summary.wall_seconds = -30.0: expected a number from 0 to 1e+100"),
                    ("run_info.json", {"summary": dict(info, mean_sweeps="1e9")},
                     'summary.mean_sweeps = "1e9"'),
                    ("run_info.json", {"summary": dict(info, steps=12.5)},
                     "summary.steps = 12.5: expected a whole number"),
                    ("run_info.json", {"summary": dict(info, capped_steps=2000)},
                     "summary.capped_steps = 2000 is more than summary.steps = 1000"),
                    ("run_info.json", {"a": 1}, "run_info.json: has no 'summary' object"),
                    ("summary.json", "deep", "summary.json: cannot read: nested too deeply")):
                shutil.rmtree(run)
                fake_run(run, 0.30, 0.004, 50.0, 30.0)
                with open(os.path.join(run, name), "w") as f:
                    if content == "deep":
                        f.write("[" * 100000 + "]" * 100000)
                    else:
                        json.dump(content, f)
                with self.assertRaises(study.StudyError) as e:
                    study.collect(d)
                self.assertIn(problem, f"{e.exception.path}: {e.exception.problem}")
                with redirect_stderr(io.StringIO()) as err:
                    self.assertEqual(main(["study", d]), 2)
                self.assertNotIn("Traceback", err.getvalue())
            # The folder's setting against the run's case.toml.
            shutil.rmtree(run)
            fake_run(run, 0.30, 0.004, 50.0, 30.0)
            with open(os.path.join(run, "case.toml"), "w") as f:
                f.write("[solver]\nmax_sweeps = 200\n")
            with self.assertRaisesRegex(study.StudyError, "max_sweeps = 200, not the folder's 50"):
                study.collect(d)
            with open(os.path.join(run, "case.toml"), "w") as f:
                f.write("[solver]\nmax_sweeps = 50\n")
            self.assertEqual(len(study.collect(d)), 2)
            # A folder name that names no setting, or a value no case key takes.
            for bad, problem in (("=50", "'' before '=' is not a case key"),
                                 ("solver..max_sweeps=50", "'solver..max_sweeps' before '='"),
                                 ("solver max_sweeps=50", "'solver max_sweeps' before '='"),
                                 ("solver.relaxation=nan", "solver.relaxation = nan: not a "
                                  "finite number"),
                                 ("solver.relaxation=-inf", "= -inf: not a finite number")):
                os.rename(run, os.path.join(d, bad))
                run = os.path.join(d, bad)
                with self.assertRaises(study.StudyError) as e:
                    study.collect(d)
                self.assertEqual(e.exception.path, run)
                self.assertIn(problem, e.exception.problem)
            os.rename(run, os.path.join(d, "solver.max_sweeps=50"))
            run = os.path.join(d, "solver.max_sweeps=50")
            # Outputs that cannot be written: exit 1 naming them, no traceback.
            os.mkdir(os.path.join(d, "study.csv"))
            with redirect_stderr(io.StringIO()) as err, redirect_stdout(io.StringIO()):
                self.assertEqual(main(["study", d]), 1)
            self.assertIn("study.csv: cannot write", err.getvalue())

    def test_runs_of_another_case_than_the_reference_are_named(self):
        case = {"n": 511, "height": 20.0, "velocity": 0.5, "normal_stress": 0.25,
                "initial_velocity": "rest"}
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.26, 0.004, 100.0, 10.0, case=case)
            run = os.path.join(d, "solver.max_sweeps=50")
            fake_run(run, 0.30, 0.004, 50.0, 30.0, case=dict(case, velocity=0.05))
            with self.assertRaisesRegex(study.StudyError, "shear.velocity = 0.05 where the "
                                        "reference .reference. has 0.5"):
                study.collect(d)
            with redirect_stderr(io.StringIO()) as err:
                self.assertEqual(main(["study", d]), 2)
            self.assertIn("solver.max_sweeps=50", err.getvalue())
            # The varied setting itself differs, and a value an earlier summary lacks is skipped.
            shutil.rmtree(run)
            run = os.path.join(d, "shear.velocity=0.05")
            older = {k: v for k, v in case.items() if k != "initial_velocity"}
            fake_run(run, 0.30, 0.004, 50.0, 30.0, case=dict(older, velocity=0.05))
            self.assertEqual([r["key"] for r in study.collect(d)], [None, "shear.velocity"])
            # A realization of the reference of another system is not combined with it.
            seed2 = os.path.join(d, "reference_seed2")
            fake_run(seed2, 0.26, 0.004, 100.0, 10.0, case=dict(case, n=1000))
            with self.assertRaisesRegex(study.StudyError, "system.n = 1000 where"):
                study.collect(d)
            # Nor are two folders of realizations of different cases compared.
            shutil.rmtree(seed2)
            other = os.path.join(d, "other")
            fake_run(os.path.join(other, "reference"), 0.26, 0.004, 100.0, 10.0,
                     case=dict(case, initial_velocity="linear"))
            with self.assertRaisesRegex(study.StudyError, "shear.initial_velocity = 'linear'"):
                study.compare_references(d, other)
            with self.assertRaisesRegex(study.StudyError, "a folder compared with itself"):
                study.compare_references(d, d)
            twin = os.path.join(d, "twin")
            shutil.copytree(os.path.join(d, "reference"), os.path.join(twin, "reference"))
            self.assertEqual(len(study.compare_references(d, twin)[2]), len(study.QUANTITIES))

    def test_folders_and_settings_that_would_compare_unlike_runs_are_refused(self):
        def write_case(run, text):
            with open(os.path.join(run, "case.toml"), "w") as f:
                f.write(text)

        measure = "[measure]\nwindow = 5.0\n"
        with tempfile.TemporaryDirectory() as d:
            fake_run(os.path.join(d, "reference"), 0.26, 0.004, 100.0, 10.0)
            write_case(os.path.join(d, "reference"), measure + "[solver]\nnewton_iterations = 8\n")
            # a misspelt key: case.toml, which holds every key of a case, lacks it
            run = os.path.join(d, "solver.newton_iteration=0")
            fake_run(run, 0.30, 0.004, 50.0, 30.0)
            write_case(run, measure + "[solver]\nnewton_iterations = 0\n")
            with self.assertRaisesRegex(study.StudyError, "holds no key solver.newton_iteration "
                                                          r"\(misspelt\?\)"):
                study.collect(d)
            os.rename(run, os.path.join(d, "bogus.key=7"))
            with self.assertRaisesRegex(study.StudyError, "holds no key bogus.key"):
                study.collect(d)
            run = os.path.join(d, "solver.newton_iterations=0")
            os.rename(os.path.join(d, "bogus.key=7"), run)
            self.assertEqual(len(study.collect(d)), 2)
            # measured otherwise: refused, unless the window is the setting studied
            write_case(run, "[measure]\nwindow = 2.0\n[solver]\nnewton_iterations = 0\n")
            with self.assertRaisesRegex(study.StudyError, "measure.window = 2.0 where .*reference"
                                                          ".case.toml has 5.0"):
                study.collect(d)
            os.rename(run, os.path.join(d, "measure.window=2"))
            write_case(os.path.join(d, "measure.window=2"), "[measure]\nwindow = 2.0\n")
            self.assertEqual([r["key"] for r in study.collect(d)], [None, "measure.window"])
            # study-compare: another folder measured otherwise, one realization in both, and
            # realizations that stand at other times (noted)
            other = os.path.join(d, "other")
            fake_run(os.path.join(other, "reference"), 0.26, 0.004, 100.0, 10.0, time=40.0)
            write_case(os.path.join(other, "reference"), "[measure]\nwindow = 2.0\n")
            with self.assertRaisesRegex(study.StudyError, "measure.window = 2.0 where"):
                study.compare_references(d, other)
            write_case(os.path.join(other, "reference"), measure)
            with redirect_stdout(io.StringIO()) as out:
                self.assertEqual(main(["study-compare", d, other]), 0)
            self.assertIn(f"note: the realizations stand at t = 100 in {d} and 40 in {other}",
                          out.getvalue())
            for folder in (os.path.join(d, "reference"), os.path.join(other, "reference")):
                with open(os.path.join(folder, "run_info.json")) as f:
                    info = json.load(f)
                with open(os.path.join(folder, "run_info.json"), "w") as f:
                    json.dump(dict(info, step=1000, state_hash="0954b4486515332d"), f)
            # the same end state from another case.toml (or build): one flow computed twice,
            # compared; from the same case.toml and build: a copy, refused
            self.assertEqual(len(study.compare_references(d, other)[2]), len(study.QUANTITIES))
            shutil.copy(os.path.join(d, "reference", "case.toml"),
                        os.path.join(other, "reference"))
            with self.assertRaisesRegex(study.StudyError, "shares a realization with .* is a "
                                                          "copy of .*step 1000"):
                study.compare_references(d, other)


if __name__ == "__main__":
    unittest.main()

"""series_means: means of run.h5 series after a time, and the command's errors."""
import io
import json
import os
import shutil
import tempfile
import unittest
from contextlib import redirect_stderr, redirect_stdout

import numpy as np

from cdshear_analysis import load_run
from cdshear_analysis.__main__ import main
from cdshear_analysis.series_means import (SeriesError, format_paired_differences,
                                           format_series_means, paired_differences,
                                           series_means)
from cdshear_analysis.statistics import block_average
from cdshear_analysis.synthetic import write_synthetic_run


class SeriesMeans(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.run_dir = os.path.join(cls.tmp.name, "run")
        write_synthetic_run(cls.run_dir, kind="A", duration=100.0)
        cls.run_data = load_run(cls.run_dir)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_mean_error_and_count_of_the_samples_after_the_time(self):
        series = self.run_data["series"]
        time = np.asarray(series["time"])
        after = float(time[len(time) // 2])
        chosen = np.asarray(series["height"])[time > after]
        means = series_means(self.run_data, after, ["height"])
        mean, error, count, block, _ = means["height"]
        self.assertEqual(count, int((time > after).sum()))
        self.assertGreater(count, 1)
        self.assertAlmostEqual(mean, chosen.mean(), places=12)
        # The error is the blocking one: the synthetic height is an AR(1) series with
        # correlation 0.95 per sample, so blocks of several samples and an error well above the
        # one of independent samples (about sqrt((1 + 0.95) / (1 - 0.95)) = 6 times, once the
        # blocks are long enough).
        self.assertEqual(error, block_average(chosen)["err"])
        self.assertGreater(block, 1)
        self.assertGreater(error, 2.0 * chosen.std(ddof=1) / np.sqrt(count))
        # A later start leaves fewer samples out of the same series.
        later = series_means(self.run_data, float(time[-3]), ["height"])["height"]
        self.assertEqual(later[2], 2)
        # Two samples cannot be blocked: the error is flagged as a lower bound.
        self.assertFalse(later[4])
        self.assertIn("no plateau: a lower bound",
                      format_series_means(series_means(self.run_data, float(time[-3]),
                                                       ["height"])))

    def test_a_window_keeps_the_samples_between_its_two_times(self):
        series = self.run_data["series"]
        time = np.asarray(series["time"])
        after, before = float(time[len(time) // 4]), float(time[len(time) // 2])
        chosen = np.asarray(series["height"])[(time > after) & (time <= before)]
        mean, _, count, _, _ = series_means(self.run_data, after, ["height"], before)["height"]
        self.assertEqual(count, len(time) // 2 - len(time) // 4)
        self.assertAlmostEqual(mean, chosen.mean(), places=12)
        out = io.StringIO()
        with redirect_stdout(out):
            status = main(["series-means", self.run_dir, "--after", str(after), "--before",
                           str(before), "--key", "height"])
        self.assertEqual(status, 0)
        self.assertIn(f"({count} samples; error by blocks of", out.getvalue())
        with self.assertRaises(SeriesError) as e:
            series_means(self.run_data, before, ["height"], after)
        self.assertIn("up to t =", e.exception.problem)

    def test_a_window_past_the_last_sample_or_a_series_without_two_numbers_is_an_error(self):
        time = np.asarray(self.run_data["series"]["time"])
        step = float(time[1] - time[0])
        last = float(time[-1])
        # A --before up to one sample interval past the end is the whole run; further, the mean
        # would cover a shorter stretch than the one asked for (a run stopped early).
        self.assertEqual(series_means(self.run_data, 0.0, ["height"], last + step)["height"][2],
                         len(time))
        with self.assertRaises(SeriesError) as e:
            series_means(self.run_data, 0.0, ["height"], last + 3 * step)
        self.assertIn(f"the samples end at t = {last:g}, before t = {last + 3 * step:g}",
                      e.exception.problem)
        err = io.StringIO()
        with redirect_stderr(err):
            status = main(["series-means", self.run_dir, "--after", "0", "--before",
                           str(2 * last), "--key", "height"])
        self.assertEqual(status, 2)
        self.assertIn(f"give --before {last:g}", err.getvalue())
        # NaN where the time has samples (a wall without normal force has no friction ratio):
        # one finite value, or none, is refused as one sample is; the pairs' table keeps NaN.
        for finite in (1, 0):
            values = np.full(len(time), np.nan)
            values[len(time) - finite:] = 0.3
            run = {"series": dict(self.run_data["series"], bottom_mu=values)}
            with self.assertRaises(SeriesError) as e:
                series_means(run, 0.0, ["bottom_mu"])
            self.assertIn(f"bottom_mu: {finite} finite of its {len(time)} samples",
                          e.exception.problem)
            self.assertEqual(series_means(run, 0.0, ["bottom_mu"], finite_needed=0)
                             ["bottom_mu"][2], finite)

    def test_no_sample_after_the_time_and_unknown_series_are_errors(self):
        last = float(np.asarray(self.run_data["series"]["time"])[-1])
        with self.assertRaises(SeriesError) as e:
            series_means(self.run_data, last, ["height"])
        self.assertIn("no sample after", e.exception.problem)
        # one sample: a mean with no error bar, which used to print as "+- nan"
        next_to_last = float(np.asarray(self.run_data["series"]["time"])[-2])
        with self.assertRaises(SeriesError) as e:
            series_means(self.run_data, next_to_last, ["height"])
        self.assertIn("one sample after", e.exception.problem)
        with self.assertRaises(SeriesError) as e:
            series_means(self.run_data, 0.0, ["no_such_series"])
        self.assertIn("no series 'no_such_series'", e.exception.problem)

    def test_command_prints_the_means_and_names_the_file_on_error(self):
        out = io.StringIO()
        with redirect_stdout(out):
            status = main(["series-means", self.run_dir, "--after", "10", "--key", "height"])
        self.assertEqual(status, 0)
        self.assertRegex(out.getvalue(),
                         r"^height\s+\S+ \+- \S+ \(\d+ samples; error by blocks of \d+")
        err = io.StringIO()
        with redirect_stderr(err):
            status = main(["series-means", self.run_dir, "--after", "1e9"])
        self.assertEqual(status, 2)
        self.assertIn(os.path.join(self.run_dir, "run.h5"), err.getvalue())


class PairedDifferences(unittest.TestCase):
    """scripts/paired_check.sh's folders: pairs a/ b/ resumed from one checkpoint each."""

    def test_differences_after_each_checkpoint_with_the_pairs_scatter(self):
        # three pairs from checkpoints at t = 10, 20, 30; each side's series is 100 before its
        # checkpoint (left out) and a constant after it: a = 50 + k, b = a + offset_k with
        # offsets 1, 2, 6 (mean 3, std 2.646, error 2.646 / sqrt 3)
        offsets = (1.0, 2.0, 6.0)
        runs = {}
        with tempfile.TemporaryDirectory() as d:
            for k, offset in enumerate(offsets):
                start = 10.0 * (k + 1)
                for side, value in (("a", 50.0 + k), ("b", 50.0 + k + offset)):
                    folder = os.path.join(d, f"{k + 1}_seed{k}", side)
                    os.makedirs(folder)
                    with open(os.path.join(folder, "paired_check.start"), "w") as f:
                        f.write(f"{start!r}\n")
                    open(os.path.join(folder, "paired_check.done"), "w").close()
                    t = np.arange(0.5, start + 20.0, 0.5)
                    runs[folder] = {"series": {"time": t, "x": np.where(t > start, value, 100.0)}}
            # an unfinished pair (b not done) is left out
            os.makedirs(os.path.join(d, "4_seed9", "a"))
            out, pairs, notes = paired_differences(d, ("x",), load=lambda folder: runs[folder])
            self.assertEqual(pairs, 3)
            self.assertEqual(notes, [f"left out: {os.path.join(d, '4_seed9')}: neither side "
                                     "done (paired_check.sh stopped before it; run it again to "
                                     "finish)"])
            base, diff, err = out["x"]
            self.assertAlmostEqual(base, 51.0)
            self.assertAlmostEqual(diff, 3.0)
            self.assertAlmostEqual(err, np.std(offsets, ddof=1) / np.sqrt(3))
            text = format_paired_differences((out, pairs, notes))
            self.assertIn("3 pairs", text)
            self.assertIn("note: left out: ", text)
            self.assertIn("b - a +3 +- 1.5 (+5.88% +- 3.00%)", text)

    def test_no_pair_done_is_an_error_naming_the_folder(self):
        with tempfile.TemporaryDirectory() as d:
            with self.assertRaises(SeriesError):
                paired_differences(d)
            err = io.StringIO()
            with redirect_stderr(err):
                self.assertEqual(main(["series-pairs", d]), 2)
            self.assertIn(f"{d}: no pair with both sides done", err.getvalue())
            # a folder that is not there, or a file, is said to be so, not to hold no pair
            missing, a_file = os.path.join(d, "none"), os.path.join(d, "file")
            open(a_file, "w").close()
            for path, problem in ((missing, "no such folder"), (a_file, "not a folder")):
                err = io.StringIO()
                with redirect_stderr(err):
                    self.assertEqual(main(["series-pairs", path]), 2)
                self.assertIn(f"{path}: {problem}", err.getvalue())

    def test_bad_start_or_window_names_the_pair(self):
        with tempfile.TemporaryDirectory() as d:
            runs = {}
            for side in ("a", "b"):
                folder = os.path.join(d, "1_seed1", side)
                os.makedirs(folder)
                open(os.path.join(folder, "paired_check.done"), "w").close()
                runs[folder] = {"series": {"time": np.arange(0.5, 10.0, 0.5),
                                           "x": np.ones(19)}}
            start = os.path.join(d, "1_seed1", "a", "paired_check.start")
            pair = os.path.join(d, "1_seed1")
            for text, problem in (("abc\n", f"{start}: 'abc' is not a time"),
                                  ("nan", f"{start}: 'nan' is not a time"),
                                  ("0", f"{start}: '0' is not a time > 0"),
                                  ("-1", f"{start}: '-1' is not a time > 0"),
                                  ("1e9", f"{pair}: no sample after t = 1e+09")):
                with open(start, "w") as f:
                    f.write(text)
                with self.assertRaises(SeriesError) as caught:
                    paired_differences(d, ("x",), load=lambda folder: runs[folder])
                self.assertTrue(caught.exception.problem.startswith(problem),
                                caught.exception.problem)
            # Not text, or a FIFO (refused, not waited on): named, not a traceback.
            with open(start, "wb") as f:
                f.write(b"\xff\xfe")
            with self.assertRaisesRegex(SeriesError, f"{start}: cannot read: .*utf-8"):
                paired_differences(d, ("x",), load=lambda folder: runs[folder])
            os.remove(start)
            os.mkfifo(start)
            with self.assertRaisesRegex(SeriesError, f"{start}: cannot read: .*FIFO"):
                paired_differences(d, ("x",), load=lambda folder: runs[folder])

    def test_sides_not_resumed_from_one_checkpoint_are_refused(self):
        # Two runs' folders put side by side as a pair (another velocity, say) differ before the
        # start; their difference would be the cases', so the pair is refused, naming it.
        with tempfile.TemporaryDirectory() as d:
            pair = os.path.join(d, "1_seed1")
            runs = {}
            for side in ("a", "b"):
                folder = os.path.join(pair, side)
                os.makedirs(folder)
                open(os.path.join(folder, "paired_check.done"), "w").close()
                with open(os.path.join(folder, "paired_check.start"), "w") as f:
                    f.write("5\n")
                t = np.arange(0.5, 10.0, 0.5)
                runs[folder] = {"series": {"time": t, "x": np.where(t > 5.0, 2.0, 1.0)}}

            def pairs():
                return paired_differences(d, ("x",), load=lambda folder: runs[folder])

            self.assertEqual(pairs()[1], 1)   # one shared history: accepted
            b = os.path.join(pair, "b")
            runs[b]["series"]["x"] = np.where(runs[b]["series"]["time"] > 5.0, 2.0, 1.5)
            with self.assertRaisesRegex(SeriesError, f"^{pair}: a/ and b/ differ in 'x' up to "
                                        "t = 5: not resumed from one checkpoint"):
                pairs()
            runs[b]["series"] = {"time": np.arange(0.25, 10.0, 0.5), "x": np.ones(20)}
            with self.assertRaisesRegex(SeriesError, "other sample times up to t = 5"):
                pairs()
            runs[b]["series"] = dict(runs[os.path.join(pair, "a")]["series"])
            self.assertEqual(pairs()[1], 1)
            with open(os.path.join(b, "paired_check.start"), "w") as f:
                f.write("6\n")
            with self.assertRaisesRegex(SeriesError, f"^{pair}: b/ started at t = 6, a/ at "
                                        "t = 5: not resumed"):
                pairs()
            # Before any sample there is no history to compare: refused, not taken as shared.
            for side in ("a", "b"):
                with open(os.path.join(pair, side, "paired_check.start"), "w") as f:
                    f.write("0.25\n")
            with self.assertRaisesRegex(SeriesError, "no sample up to t = 0.25"):
                pairs()
            for side in ("a", "b"):
                with open(os.path.join(pair, side, "paired_check.start"), "w") as f:
                    f.write("5\n")
            # Two cases (another wall speed) are refused though their histories agree.
            self.assertEqual(pairs()[1], 1)
            runs[os.path.join(pair, "a")]["case"] = {"shear": {"velocity": 0.5}}
            runs[b]["case"] = {"shear": {"velocity": 1.0}}
            with self.assertRaisesRegex(SeriesError, "other cases \\(shear.velocity 0.5 and 1.0"):
                pairs()

    def test_a_side_or_a_run_counted_twice_or_made_otherwise_is_refused(self):
        # Three pairs from checkpoints at t = 5: a = 1 after it, b = 1 + k for pair k.
        with tempfile.TemporaryDirectory() as d:
            runs = {}

            def side(pair, name, value, state, made="build/cdshear", end=10.0):
                folder = os.path.join(d, pair, name)
                os.makedirs(folder, exist_ok=True)
                for file, text in (("paired_check.done", ""), ("paired_check.start", "5\n"),
                                   ("paired_check.side", made + "\n"),
                                   ("run_info.json", json.dumps({"step": 2000,
                                                                 "state_hash": state}))):
                    with open(os.path.join(folder, file), "w") as f:
                        f.write(text)
                t = np.arange(0.5, end + 0.25, 0.5)
                runs[folder] = {"series": {"time": t, "x": np.where(t > 5.0, value, 0.0)}}

            for k in (1, 2, 3):
                side(f"{k}_run{k}", "a", 1.0, f"a{k}")
                side(f"{k}_run{k}", "b", 1.0 + k, f"b{k}", "build/cdshear --set s=1")

            def pairs():
                return paired_differences(d, ("x",), load=lambda folder: runs[folder])

            out, count, notes = pairs()
            self.assertEqual((count, out["x"][1], notes), (3, 2.0, []))
            # A pair linked under another name, or a run's pair copied: one run's sides twice.
            os.symlink(os.path.join(d, "1_run1"), os.path.join(d, "4_link"))
            with self.assertRaisesRegex(SeriesError, f"^{d}: two pairs hold one run's sides: "
                                        f"{d}/4_link/a is {d}/1_run1/a again"):
                pairs()
            os.remove(os.path.join(d, "4_link"))
            side("4_copy", "a", 1.0, "a2")
            side("4_copy", "b", 3.0, "b2", "build/cdshear --set s=1")
            with self.assertRaisesRegex(SeriesError, f"{d}/4_copy/a holds the run {d}/2_run2/a "
                                        "holds \\(both end at step 2000 in state a2"):
                pairs()
            shutil.rmtree(os.path.join(d, "4_copy"))
            # A fourth pair run for 2 t after its checkpoint, where the others ran 5 t.
            side("4_run4", "a", 1.0, "a4", end=7.0)
            side("4_run4", "b", 2.0, "b4", "build/cdshear --set s=1", end=7.0)
            with self.assertRaisesRegex(SeriesError, f"^{d}: the pairs ran for other durations "
                                        f"\\({d}/1_run1: 5 t, {d}/4_run4: 2 t after"):
                pairs()
            shutil.rmtree(os.path.join(d, "4_run4"))
            # A side without one of the series (an older build's run.h5): named, not a KeyError.
            a1 = os.path.join(d, "1_run1", "a")
            whole = runs[a1]
            runs[a1] = {"series": {"time": whole["series"]["time"]}}
            with self.assertRaisesRegex(SeriesError, f"^{d}/1_run1: no series 'x' \\(have: "
                                        "time\\)"):
                pairs()
            runs[a1] = whole
            # A fourth pair made with another setting on its b/ side: not pooled with the others.
            side("4_run4", "a", 1.0, "a4")
            side("4_run4", "b", 2.0, "b4", "build/cdshear --set s=2")
            with self.assertRaisesRegex(SeriesError, "the pairs' b/ sides were made otherwise "
                                        f"\\({d}/1_run1: 'build/cdshear --set s=1', {d}/4_run4: "
                                        "'build/cdshear --set s=2' in paired_check.side\\)"):
                pairs()
            shutil.rmtree(os.path.join(d, "4_run4"))
            # b/ a link to a/, or a copy of it (made as a/ was): no second side.
            pair = os.path.join(d, "3_run3")
            shutil.rmtree(os.path.join(pair, "b"))
            os.symlink("a", os.path.join(pair, "b"))
            with self.assertRaisesRegex(SeriesError, f"^{pair}: b/ is a/ \\(a link\\)"):
                pairs()
            os.remove(os.path.join(pair, "b"))
            shutil.copytree(os.path.join(pair, "a"), os.path.join(pair, "b"))
            runs[os.path.join(pair, "b")] = runs[os.path.join(pair, "a")]
            with self.assertRaisesRegex(SeriesError, f"^{pair}: b/ was made as a/ was "
                                        "\\('build/cdshear' in both"):
                pairs()
            # Sides made otherwise that computed one flow (one end state): kept, with a note.
            with open(os.path.join(pair, "b", "paired_check.side"), "w") as f:
                f.write("build/cdshear --set s=1\n")
            out, count, notes = pairs()
            self.assertEqual((count, out["x"][1]), (3, 1.0))
            self.assertEqual(notes, ["1 of the 3 pairs ended in one state on both sides (3_run3): "
                                     "the two sides computed one flow there, a difference of "
                                     "zero"])
            # A b/ side that ran for a shorter time (kept from a check with another DURATION).
            side("3_run3", "b", 4.0, "b3", "build/cdshear --set s=1", end=7.0)
            with self.assertRaisesRegex(SeriesError, f"^{pair}: a/ ends at t = 10, b/ at t = 7: "
                                        "sides of other durations"):
                pairs()
            # One pair: its difference, without an error it cannot have.
            for k in (2, 3):
                shutil.rmtree(os.path.join(d, f"{k}_run{k}"))
            text = format_paired_differences(pairs())
            self.assertIn("1 pair (b - a, from one checkpoint; an error needs", text)
            self.assertIn("x                a 1  b - a +1 (+100.00%)", text)
            self.assertNotIn("nan", text)


if __name__ == "__main__":
    unittest.main()

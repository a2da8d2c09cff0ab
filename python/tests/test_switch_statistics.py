"""Band switches over whole runs, pooled and compared (switch_statistics.py), on synthetic
regime-C runs whose switches are known: ramps of a given duration at given times."""
import contextlib
import io
import json
import math
import os
import shutil
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from scipy import stats  # noqa: E402

from cdshear_analysis import switch_statistics as ss  # noqa: E402
from cdshear_analysis.__main__ import main  # noqa: E402
from cdshear_analysis.rundata import RunDataError, load_run  # noqa: E402
from cdshear_analysis.summary import analyze, jsonable, write_summary  # noqa: E402
from cdshear_analysis.synthetic import write_synthetic_run  # noqa: E402

DURATION = 2000.0
V = 0.05


class SwitchStatistics(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        d = cls.tmp.name
        # group a: ramps of 20 t, three and two switches; group b: ramps of 40 t, two and one
        cls.a = [os.path.join(d, "a", f"s1_seed{k}_V0.05") for k in (1, 2)]
        cls.b = [os.path.join(d, "b", f"s2_seed{k}_V0.05") for k in (1, 2)]
        for path, times, ramp, seed in ((cls.a[0], [400, 900, 1400], 20.0, 1),
                                        (cls.a[1], [700, 1500], 20.0, 2),
                                        (cls.b[0], [500, 1300], 40.0, 3),
                                        (cls.b[1], [1000], 40.0, 4)):
            write_synthetic_run(path, kind="C", duration=DURATION, velocity=V,
                                switch_times=times, switch_duration=ramp, seed=seed)

        # a run stopped at 1200 t of its 2000, and one without a switch (regime A)
        cls.short = os.path.join(d, "c", "s1_seed3_V0.05")
        write_synthetic_run(cls.short, kind="C", duration=DURATION, velocity=V,
                            switch_times=[400, 900, 1400], switch_duration=20.0, seed=5,
                            time_reached=1200.0)
        cls.none = os.path.join(d, "c", "s1_seed4_V0.05")
        write_synthetic_run(cls.none, kind="A", duration=DURATION, velocity=V, seed=6)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_each_switch_is_found_and_timed_by_its_ramp(self):
        for path, count, ramp in ((self.a[0], 3, 20.0), (self.a[1], 2, 20.0),
                                  (self.b[0], 2, 40.0), (self.b[1], 1, 40.0)):
            r = ss.run_switches(path)
            self.assertEqual(r["switches"], count, path)
            self.assertEqual(len(r["switch_times"]), count)
            for t in r["switch_times"]:
                self.assertAlmostEqual(t, ramp, delta=0.15 * ramp)
            self.assertAlmostEqual(r["time"], DURATION, delta=1.0)   # first to last sample
            self.assertAlmostEqual(r["L_y"], 20.0, delta=0.2)
            self.assertEqual(r["V"], V)

    def test_a_group_pools_its_runs(self):
        runs = [ss.run_switches(p) for p in self.a]
        g = ss.group_statistics(runs)
        self.assertEqual((g["runs"], g["switches"], g["timed"]), (2, 5, 5))
        self.assertAlmostEqual(g["time"], 2 * DURATION, delta=2.0)
        self.assertAlmostEqual(g["rate"], 5 / g["time"])
        times = [t for r in runs for t in r["switch_times"]]
        self.assertAlmostEqual(g["T"], sum(times) / 5)
        self.assertAlmostEqual(g["T_over_V"], g["T"] / V)
        self.assertEqual((g["T_min"], g["T_max"]), (min(times), max(times)))

    def test_two_groups_compared(self):
        a = [ss.run_switches(p) for p in self.a]
        b = [ss.run_switches(p) for p in self.b]
        c = ss.compare_groups(a, b)
        self.assertAlmostEqual(c["T_ratio"], 0.5, delta=0.08)
        lo, hi = c["T_ratio_interval"]
        self.assertLessEqual(lo, c["T_ratio"])
        self.assertGreaterEqual(hi, c["T_ratio"])
        self.assertEqual(c["T_ratio_interval"], ss.compare_groups(a, b)["T_ratio_interval"])
        ga, gb = ss.group_statistics(a), ss.group_statistics(b)
        self.assertAlmostEqual(c["rate_ratio"], (5 / ga["time"]) / (3 / gb["time"]))
        self.assertAlmostEqual(
            c["rate_p"], stats.binomtest(5, 8, ga["time"] / (ga["time"] + gb["time"])).pvalue)
        # one timed switch in a group: a ratio, no interval
        single = ss.compare_groups(a, [ss.run_switches(self.b[1])])
        self.assertIsNone(single["T_ratio_interval"])
        self.assertAlmostEqual(single["T_ratio"], 0.5, delta=0.08)

    def test_a_run_not_finished_is_counted_over_its_time_and_said_so(self):
        r = ss.run_switches(self.short)
        self.assertFalse(r["finished"])
        self.assertEqual(r["switches"], 2)                # the switch at 1400 t not reached
        self.assertAlmostEqual(r["time"], 1200.0, delta=1.0)
        self.assertTrue(ss.run_switches(self.a[0])["finished"])
        text = ss.format_table([r, ss.run_switches(self.a[0])])
        self.assertIn("(not finished: its duration is 2000)", text)
        self.assertIn("warning: s1_seed3_V0.05 not finished", text)
        self.assertNotIn("warning", ss.format_table([ss.run_switches(self.a[0])]))

    def test_a_group_without_switches(self):
        a = [ss.run_switches(p) for p in self.a]
        none = [ss.run_switches(self.none)]
        g = ss.group_statistics(none)
        self.assertEqual((g["switches"], g["timed"], g["rate"]), (0, 0, 0.0))
        self.assertTrue(math.isnan(g["T"]))
        c = ss.compare_groups(a, none)
        self.assertEqual(c["rate_ratio"], math.inf)       # switches against none
        self.assertTrue(math.isnan(c["T_ratio"]))
        self.assertIsNone(c["T_ratio_interval"])
        # by hand: a spans 2/3 of the time; two-sided, the outcomes of 5 switches no likelier
        # than all 5 in a: 5 in a, 0 in a, 1 in a
        q = 2 / 3
        self.assertAlmostEqual(c["rate_p"], q ** 5 + (1 - q) ** 5 + 5 * q * (1 - q) ** 4,
                               delta=1e-3)
        self.assertIn("rate ratio (runs / against): inf", ss.format_table(a, none, c))

    def test_a_clone_times_the_switches_from_the_summary_alone(self):
        # the summary of a run whose averaged span holds fewer switches than its whole series
        # (a clone keeps summary.json, not run.h5): the same record as from run.h5
        clone = os.path.join(self.tmp.name, "clone", "s1_seed1_V0.05")
        shutil.copytree(self.a[0], clone)
        from_run = ss.run_switches(clone)
        summary = analyze(load_run(clone))
        self.assertLess(len(summary["switches"]), from_run["switches"])
        write_summary(summary, clone)
        os.remove(os.path.join(clone, "run.h5"))
        self.assertEqual(ss.run_switches(clone), from_run)
        # a run stopped short, and one without a switch: counted alike from their summaries
        for path in (self.short, self.none):
            copy = os.path.join(self.tmp.name, "clone", os.path.basename(path))
            shutil.copytree(path, copy)
            write_summary(analyze(load_run(copy)), copy)
            os.remove(os.path.join(copy, "run.h5"))
            self.assertEqual(ss.run_switches(copy), ss.run_switches(path))

    def test_each_run_counts_once_and_a_group_is_of_one_system(self):
        d = os.path.join(self.tmp.name, "once")
        os.makedirs(d)
        link = os.path.join(d, "link")
        os.symlink(self.a[0], link)
        other = os.path.join(d, "s1_seed9_V0.05")   # another normal stress
        write_synthetic_run(other, kind="C", duration=DURATION, velocity=V, normal_stress=1.0,
                            switch_times=[500], seed=9)
        copied = os.path.join(d, "s1_seed8_V0.05")   # a summary.json of another run alone
        os.makedirs(copied)
        write_summary(analyze(load_run(self.a[1])), copied)
        with open(os.path.join(copied, "summary.json")) as f:
            summary = json.load(f)
        summary["run_dir"] = self.a[1]
        with open(os.path.join(copied, "summary.json"), "w") as f:
            json.dump(summary, f)
        # a run copied to another folder: its last sitting's record ends in the same state
        kept = os.path.join(d, "kept", "s1_seed1_V0.05")
        shutil.copytree(self.a[0], kept)
        with open(os.path.join(kept, "run_info.json"), "w") as f:
            json.dump({"step": 400000, "state_hash": "0954b4486515332d"}, f)
        copy = os.path.join(d, "copy", "s1_seed1_V0.05")
        shutil.copytree(kept, copy)
        # a run.h5 with its case.toml alone (no run_info file to tell a copy by), and a run.h5
        # in the folder of another seed
        bare = os.path.join(d, "bare", "a")
        os.makedirs(bare)
        shutil.copy(os.path.join(self.a[0], "run.h5"), bare)
        if os.path.exists(os.path.join(self.a[0], "case.toml")):
            shutil.copy(os.path.join(self.a[0], "case.toml"), bare)
        moved = os.path.join(d, "moved", "s1_seed2_V0.05")
        shutil.copytree(self.a[1], moved)
        shutil.copy(os.path.join(self.a[0], "run.h5"), moved)
        for args, problem in (
                ([self.a[0], self.a[0] + os.sep], f"{self.a[0] + os.sep} is {self.a[0]} again"),
                ([kept, self.a[1], copy], f"{copy} holds the run {kept} holds (both end at step "
                                          "400000 in state 0954b4486515332d"),
                ([kept, "--against", copy], f"{copy} holds the run {kept} holds"),
                ([self.a[0], link], f"{link} is {self.a[0]} again: each run counts once"),
                ([self.a[0], "--against", self.b[0], link], f"{link} is {self.a[0]} again"),
                ([self.a[0], other], f"{other} has normal_stress 1, {self.a[0]} 0.25: a group "
                                     "pools the seeds of one system and normal stress"),
                ([self.a[0], copied], "no run.h5 beside it, and summary.json is of another "
                                      f"run (run_dir '{self.a[1]}')"),
                ([self.a[0], self.a[1], bare], f"{bare} holds the run {self.a[0]} holds (the "
                                               "same case.toml, seeds included"),
                ([self.a[0], moved], f"{moved}/run.h5: run.h5 is of another run (system.seed = "
                                     "1, the folder's case.toml says 2)")):
            err = io.StringIO()
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
                self.assertEqual(main(["switch-times", *args]), 2, args)
            self.assertIn(problem, err.getvalue())
        # groups of other systems are what --against compares
        with contextlib.redirect_stdout(io.StringIO()):
            self.assertEqual(main(["switch-times", self.a[0], "--against", other]), 0)

    def test_a_summary_that_cannot_time_its_switches_says_which_key(self):
        d = os.path.join(self.tmp.name, "bad", "s1_seed1_V0.05")
        shutil.copytree(self.a[0], d)
        good = json.loads(json.dumps(jsonable(analyze(load_run(d)))))
        os.remove(os.path.join(d, "run.h5"))
        path = os.path.join(d, "summary.json")
        older = {k: v for k, v in good.items() if k != "whole_run_switches"}
        uneven = json.loads(json.dumps(good))
        uneven["whole_run_switches"]["starts"].pop()
        boolean = json.loads(json.dumps(good))
        boolean["whole_run_switches"]["time"] = True
        negative = json.loads(json.dumps(good))
        negative["whole_run_switches"]["switch_times"][0] = -20.0
        slowless = json.loads(json.dumps(good))
        slowless["case"]["velocity"] = 0
        endless = json.loads(json.dumps(good))
        endless["whole_run_switches"]["switch_times"][0] = math.inf
        unmeasured = json.loads(json.dumps(good))
        unmeasured["whole_run_switches"]["L_y"] = math.nan
        longer = json.loads(json.dumps(good))   # a ramp longer than the series
        longer["whole_run_switches"]["switch_times"][0] = 2 * good["whole_run_switches"]["time"]
        before = json.loads(json.dumps(good))
        before["whole_run_switches"]["starts"][0] = -1.0
        newer = dict(good, version=good["version"] + 1)
        for summary, key in ((older, "no whole_run_switches key"),
                             (uneven, "whole_run_switches.switch_times"),
                             (boolean, "whole_run_switches.time"),
                             (negative, "whole_run_switches.switch_times"),
                             (slowless, "case.velocity"), ([], "no JSON object"),
                             (endless, "whole_run_switches.switch_times"),
                             (unmeasured, "whole_run_switches.L_y"),
                             (longer, "whole_run_switches.switch_times"),
                             (before, "whole_run_switches.starts"), (newer, "newer")):
            with open(path, "w") as f:
                json.dump(summary, f)
            with self.assertRaises(RunDataError) as caught:
                ss.run_switches(d)
            self.assertEqual(caught.exception.path, path)
            self.assertIn(key, caught.exception.problem)
        for broken in ("{not json", None):   # broken JSON; a folder in the file's place
            os.remove(path)
            if broken is None:
                os.mkdir(path)
            else:
                with open(path, "w") as f:
                    f.write(broken)
            with self.assertRaises(RunDataError) as caught:
                ss.run_switches(d)
            self.assertEqual(caught.exception.path, path)
            self.assertIn("cannot be read", caught.exception.problem)

    def test_command_line(self):
        out = os.path.join(self.tmp.name, "switches.json")
        text = io.StringIO()
        with contextlib.redirect_stdout(text):
            self.assertEqual(main(["switch-times", *self.b, "--against", *self.a,
                                   "--json", out]), 0)
        self.assertIn("against: 2 runs (L_y 20), 5 switches", text.getvalue())
        self.assertIn("T ratio (runs / against): 2", text.getvalue())
        with open(out) as f:   # strict JSON: no NaN or Infinity
            data = json.load(f, parse_constant=lambda c: self.fail(f"{c} in the JSON"))
        self.assertEqual(data["group"]["switches"], 3)
        self.assertEqual(data["against_group"]["switches"], 5)
        self.assertAlmostEqual(data["comparison"]["T_ratio"], 2.0, delta=0.35)
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            missing = os.path.join(self.tmp.name, "nowhere")
            self.assertEqual(main(["switch-times", missing]), 2)
            self.assertIn(f"error: {missing}: no such folder", err.getvalue())
            # the output may not overwrite an input
            inside = os.path.join(self.a[0], "run.h5")
            self.assertEqual(main(["switch-times", self.a[0], "--json", inside]), 2)
        # nothing to time in one group: nulls in the JSON
        with contextlib.redirect_stdout(io.StringIO()):
            self.assertEqual(main(["switch-times", *self.a, "--against", self.none,
                                   "--json", out]), 0)
        with open(out) as f:
            data = json.load(f, parse_constant=lambda c: self.fail(f"{c} in the JSON"))
        self.assertIsNone(data["against_group"]["T"])
        self.assertIsNone(data["comparison"]["rate_ratio"])

    def test_each_runs_end_state_is_read_once(self):
        # The checks of both groups (a folder twice, a copy, one case twice, a run in both
        # groups) share one reading of each folder's end state, the records kept or not.
        from unittest import mock
        from cdshear_analysis import rundata
        d = os.path.join(self.tmp.name, "read_once")
        kept = [os.path.join(d, f"s1_seed{k}_V0.05") for k in (1, 2)]
        for k, (source, path) in enumerate(zip(self.a, kept)):
            shutil.copytree(source, path)
            with open(os.path.join(path, "run_info.json"), "w") as f:
                json.dump({"step": 400000, "state_hash": f"state{k}"}, f)
        for group, against in ((kept, self.b), (self.a, self.b)):
            with mock.patch.object(rundata, "end_state", wraps=rundata.end_state) as read, \
                    mock.patch.object(ss, "end_state", read), \
                    contextlib.redirect_stdout(io.StringIO()):
                self.assertEqual(main(["switch-times", *group, "--against", *against]), 0)
            self.assertEqual(sorted(c.args[0] for c in read.call_args_list),
                             sorted(group + against))
        # the checks called alone read them themselves, as before
        with mock.patch.object(rundata, "end_state", wraps=rundata.end_state) as read, \
                mock.patch.object(ss, "end_state", read):
            self.assertIsNone(ss.group_problem([ss.run_switches(p) for p in kept], kept))
        self.assertEqual(sorted(c.args[0] for c in read.call_args_list), sorted(kept))


if __name__ == "__main__":
    unittest.main()

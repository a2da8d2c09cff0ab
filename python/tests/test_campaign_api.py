"""The notebook API: load_campaign gives runs.csv's table as arrays, never writes, and leaves out
stale summaries with the reason; the package's version is the program's."""
import contextlib
import csv
import io
import json
import math
import os
import re
import shutil
import tempfile
import unittest

import numpy as np

import cdshear_analysis
from cdshear_analysis.__main__ import main as cli_main
from cdshear_analysis import load_campaign
from cdshear_analysis.campaign import (compare_campaigns, format_comparison,
                                       format_paired_markdown, lone_unsteady_runs, other_packings,
                                       paired_differences, unequal_times, unpaired)
from cdshear_analysis.report import ReportError, shared_end

from cdshear_analysis.synthetic import write_synthetic_run

from .test_report import fake_summary, main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def write_run_info(run_dir, state):
    """A run_info.json that ends the run at step 1000 in `state`."""
    with open(os.path.join(run_dir, "run_info.json"), "w") as f:
        json.dump({"step": 1000, "state_hash": state}, f)


def seeds_at_slow_wall(d, shifts, state_of=lambda side, seed: f"{os.path.basename(side)}{seed}"):
    """Campaigns d/a and d/b, seeds 1, 2, ... of system 1 at V = 0.05, mu_eff 0.2 in a and 0.2 +
    shifts[seed - 1] in b; each run's run_info ends at step 1000 in state state_of(side, seed)."""
    a, b = os.path.join(d, "a"), os.path.join(d, "b")
    for seed, shift in enumerate(shifts, start=1):
        name = f"s1_seed{seed}_V0.05"
        for side, mu in ((a, 0.2), (b, 0.2 + shift)):
            fake_summary(os.path.join(side, "runs", name), 0.05, 1e-4, mu, 0.83, 2.8)
            write_run_info(os.path.join(side, "runs", name), state_of(side, seed))
    return a, b


class LoadCampaign(unittest.TestCase):
    def setUp(self):
        self._tmp = tempfile.TemporaryDirectory()
        self.d = self._tmp.name
        runs = os.path.join(self.d, "runs")
        fake_summary(os.path.join(runs, "s2_seed1_V1"), 1.0, 0.05, 0.30, 0.80, 3.0)
        fake_summary(os.path.join(runs, "s2_seed1_V2"), 2.0, 0.10, 0.34, 0.79, 2.9)
        fake_summary(os.path.join(runs, "s2_seed1_V0.1"), 0.1, 1e-5, 0.2, 0.81, 3.1, regime="B")
        with open(os.path.join(self.d, "campaign.toml"), "w") as f:
            f.write('[campaign]\nname = "api"\n\n# Runs (name, duration [t], dt [t], cost):\n'
                    "#   s2_seed1_V1  duration 1000  dt 0.002  cost 5e8\n"
                    "#   s2_seed1_V4  duration 1000  dt 0.0005  cost 2e9\n")

    def tearDown(self):
        self._tmp.cleanup()

    def test_columns_are_the_report_table(self):
        c = load_campaign(self.d)
        self.assertEqual(c.name, "api")
        self.assertEqual(len(c.rows), 3)
        # the same values as runs.csv, column by column
        self.assertEqual(main(["report", self.d]), 0)
        with open(os.path.join(self.d, "report", "runs.csv")) as f:
            table = list(csv.DictReader(f))
        self.assertEqual(list(table[0].keys()), list(c.columns.keys()))
        for k, row in enumerate(table):
            for col in ("V", "I_bulk", "mu_eff_bulk", "mu_eff_bulk_err", "h10_top_I"):
                self.assertAlmostEqual(c.columns[col][k], float(row[col]), msg=col)
            self.assertEqual(c.columns["regime"][k], row["regime"])
        self.assertEqual(c.columns["I_bulk"].dtype, np.float64)
        self.assertEqual([r["run"] for r in c.select(regime="A")], ["s2_seed1_V1", "s2_seed1_V2"])
        self.assertIn(("s2_seed1_V4", "not started: no run folder"), c.skipped)

    def test_stale_summary_is_left_out_without_writing(self):
        path = os.path.join(self.d, "runs", "s2_seed1_V2", "summary.json")
        with open(path) as f:
            s = json.load(f)
        s["version"] -= 1
        with open(path, "w") as f:
            json.dump(s, f)
        before = os.stat(path).st_mtime_ns
        c = load_campaign(self.d)
        self.assertEqual([r["run"] for r in c.rows], ["s2_seed1_V0.1", "s2_seed1_V1"])
        reasons = dict(c.skipped)
        self.assertIn("older", reasons["s2_seed1_V2"])
        self.assertEqual(os.stat(path).st_mtime_ns, before)

    def test_frame_or_a_clear_message(self):
        c = load_campaign(self.d)
        try:
            import pandas  # noqa: F401
        except ImportError:
            with self.assertRaisesRegex(ImportError, "python3-pandas"):
                c.frame()
        else:
            self.assertEqual(list(c.frame()["run"]), [r["run"] for r in c.rows])

    def test_not_a_campaign_folder(self):
        with self.assertRaises(ReportError):
            load_campaign(os.path.join(self.d, "missing"))


class CompareCampaigns(unittest.TestCase):
    def test_shared_runs_in_combined_errors(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            fake_summary(os.path.join(a, "runs", "s1_seed1_V0.1"), 0.1, 0.01, 0.20, 0.80, 3.0)
            fake_summary(os.path.join(a, "runs", "s1_seed1_V1"), 1.0, 0.05, 0.30, 0.80, 3.0)
            # b: one shared run with mu_eff 0.012 higher (errors 0.003 each: 2.83 combined)
            fake_summary(os.path.join(b, "runs", "s1_seed1_V1"), 1.0, 0.05, 0.312, 0.80, 3.0,
                         regime="B")
            items = compare_campaigns(a, b)
            self.assertEqual([it["run"] for it in items], ["s1_seed1_V1"])
            mu = items[0]["mu_eff_bulk"]
            self.assertAlmostEqual(mu["diff"], 0.012)
            self.assertAlmostEqual(mu["combined_errors"], 0.012 / (0.003 * 2 ** 0.5))
            self.assertAlmostEqual(items[0]["nu_bulk"]["combined_errors"], 0.0)
            self.assertEqual((items[0]["regime_a"], items[0]["regime_b"]), ("A", "B"))
            self.assertEqual(main(["campaign-compare", a, b]), 0)
            self.assertEqual(main(["campaign-compare", a, os.path.join(d, "none")]), 2)

    def test_runs_of_other_cases_one_folder_or_one_campaign_are_not_compared(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            for name in ("s1_seed1_V1", "s1_seed2_V1", "s1_seed3_V1", "s1_seed4_V1"):
                fake_summary(os.path.join(a, "runs", name), 1.0, 0.05, 0.30, 0.80, 3.0)
                if name != "s1_seed4_V1":
                    fake_summary(os.path.join(b, "runs", name), 1.0, 0.05, 0.31, 0.80, 3.0)
            # b's seed 4 is a's own folder, linked; seeds 2 and 3 are of another case
            os.symlink(os.path.join(a, "runs", "s1_seed4_V1"),
                       os.path.join(b, "runs", "s1_seed4_V1"))
            for name, key, value in (("s1_seed2_V1", "normal_stress", 0.5),
                                     ("s1_seed3_V1", "initial_velocity", "rest")):
                path = os.path.join(b, "runs", name, "summary.json")
                with open(path) as f:
                    summary = json.load(f)
                summary["case"][key] = value
                with open(path, "w") as f:
                    json.dump(summary, f)
            items = {it["run"]: it for it in compare_campaigns(a, b)}
            self.assertNotIn("mismatch", items["s1_seed1_V1"])
            self.assertEqual(items["s1_seed2_V1"]["mismatch"], "normal_stress 0.25 in a, 0.5 in b")
            # a's summaries say nothing of the initial velocity (older ones): not compared
            self.assertNotIn("mismatch", items["s1_seed3_V1"])
            path = os.path.join(a, "runs", "s1_seed3_V1", "summary.json")
            with open(path) as f:
                summary = json.load(f)
            summary["case"]["initial_velocity"] = "linear"
            with open(path, "w") as f:
                json.dump(summary, f)
            items = {it["run"]: it for it in compare_campaigns(a, b)}
            self.assertEqual(items["s1_seed3_V1"]["mismatch"],
                             "initial_velocity linear in a, rest in b")
            self.assertEqual(items["s1_seed4_V1"]["mismatch"],
                             "one run folder in both campaigns (a link)")
            # One campaign twice, by another path or through a link: refused.
            os.symlink(a, os.path.join(d, "a_link"))
            for again in (a, os.path.join(d, "a_link"), os.path.join(a, ".")):
                with contextlib.redirect_stderr(io.StringIO()) as err:
                    self.assertEqual(cli_main(["campaign-compare", a, again]), 2)
                self.assertIn(f"{again}: is {a} again", err.getvalue())

    def test_one_run_in_both_or_a_copy_in_runs_is_compared_once(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = seeds_at_slow_wall(d, (0.01, 0.02, 0.06))
            self.assertEqual(paired_differences(compare_campaigns(a, b))[0]["runs"], 3)
            # b's seed 3 ends in a's state: one run in both campaigns (a copy), not a pair
            write_run_info(os.path.join(b, "runs", "s1_seed3_V0.05"), "a3")
            # a backup of seed 1 kept beside it in both runs/: that seed pairs once
            for side in (a, b):
                fake_summary(os.path.join(side, "runs", "s1_seed1_V0.05.bak"), 0.05, 1e-4, 0.5,
                             0.83, 2.8)
            items = {it["run"]: it for it in compare_campaigns(a, b)}
            self.assertEqual(items["s1_seed3_V0.05"]["mismatch"],
                             "one run in both campaigns (both end at step 1000 in state a3, from "
                             "the same case.toml and build): a copy")
            self.assertEqual(items["s1_seed1_V0.05.bak"]["mismatch"],
                             "s1_seed1_V0.05 is system 1, seed 1, V = 0.05 too and is compared: "
                             "each seed pairs once (a copy kept in runs/)")
            (group,) = paired_differences(list(items.values()))
            self.assertEqual(group["runs"], 2)
            self.assertAlmostEqual(group["mu_eff_bulk"]["mean"], 0.015)
            # A backup whose name sorts first (V written ".05") is still the one left out when
            # campaign.toml lists the run's own folder; without the file, the folder whose name
            # reads as a run's goes first.
            for side in (a, b):
                shutil.rmtree(os.path.join(side, "runs", "s1_seed1_V0.05.bak"))
                fake_summary(os.path.join(side, "runs", "s1_seed1_V.05"), 0.05, 1e-4, 0.5, 0.83,
                             2.8)
            self.assertLess("s1_seed1_V.05", "s1_seed1_V0.05")
            items = {it["run"]: it for it in compare_campaigns(a, b)}
            self.assertIn("each seed pairs once", items["s1_seed1_V0.05"]["mismatch"])
            with open(os.path.join(b, "campaign.toml"), "w") as f:
                f.write('[campaign]\nname = "b"\n# runs:\n#   s1_seed1_V0.05  duration 100\n'
                        '#   s1_seed2_V0.05  duration 100\n#   s1_seed3_V0.05  duration 100\n')
            listed_first = compare_campaigns(a, b)
            items = {it["run"]: it for it in listed_first}
            self.assertNotIn("mismatch", items["s1_seed1_V0.05"])
            # the items keep b's rows' order, listed or not
            self.assertEqual([it["run"] for it in listed_first],
                             [r["run"] for r in load_campaign(b).rows
                              if r["run"] in {it["run"] for it in listed_first}])
            self.assertEqual(listed_first[0]["run"], "s1_seed1_V.05")
            self.assertEqual(items["s1_seed1_V.05"]["mismatch"],
                             "s1_seed1_V0.05 is system 1, seed 1, V = 0.05 too and is compared: "
                             "each seed pairs once (a copy kept in runs/)")
            self.assertAlmostEqual(paired_differences(list(items.values()))[0]["mu_eff_bulk"]
                                   ["mean"], 0.015)
            os.remove(os.path.join(b, "campaign.toml"))
            for side in (a, b):
                shutil.rmtree(os.path.join(side, "runs", "s1_seed1_V.05"))
                fake_summary(os.path.join(side, "runs", "s1_seed1_V0.05.bak"), 0.05, 1e-4, 0.5,
                             0.83, 2.8)
            # the campaign's notes are on its file; the report's on its copies (each pooled in a
            # report) do not hold here
            self.assertEqual(load_campaign(a).notes,
                             ["campaign.toml is missing: the campaign name is the folder's"])
            with contextlib.redirect_stdout(io.StringIO()) as out:
                self.assertEqual(cli_main(["campaign-compare", a, b]), 0)
            self.assertIn(f"note on {a}: campaign.toml is missing", out.getvalue())
            self.assertNotIn("are the same run", out.getvalue())
            self.assertIn("s1_seed3_V0.05: not compared: one run in both", out.getvalue())
            # The same end state from another case (a setting that changes nothing there) is
            # one flow computed twice: compared, a difference of zero, with a note.
            with open(os.path.join(b, "runs", "s1_seed3_V0.05", "case.toml"), "w") as f:
                f.write("[output]\nstatus_interval = 7.0\n")
            items = {it["run"]: it for it in compare_campaigns(a, b)}
            self.assertNotIn("mismatch", items["s1_seed3_V0.05"])
            self.assertTrue(items["s1_seed3_V0.05"]["one_flow"])
            with contextlib.redirect_stdout(io.StringIO()) as out:
                self.assertEqual(cli_main(["campaign-compare", a, b]), 0)
            self.assertIn("note: 1 of the 4 shared runs end in the same state in both campaigns "
                          "(s1_seed3_V0.05): the two computed one flow there", out.getvalue())
            os.remove(os.path.join(b, "runs", "s1_seed3_V0.05", "case.toml"))
            # Nothing left to compare (every shared run one in both): an error, exit 2.
            for seed in (1, 2):
                write_run_info(os.path.join(b, "runs", f"s1_seed{seed}_V0.05"), f"a{seed}")
            for side in (a, b):
                shutil.rmtree(os.path.join(side, "runs", "s1_seed1_V0.05.bak"))
            with contextlib.redirect_stdout(io.StringIO()) as out, \
                    contextlib.redirect_stderr(io.StringIO()) as err:
                self.assertEqual(cli_main(["campaign-compare", a, b]), 2)
            self.assertIn("s1_seed2_V0.05: not compared: one run in both", out.getvalue())
            self.assertIn(f"error: {b}: none of the runs it shares with {a} could be compared",
                          err.getvalue())

    def test_runs_started_from_other_packings_are_named(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            packings = {}
            for side, content in ((a, "[1]"), (b, "[2]")):
                run = os.path.join(side, "runs", "s1_seed1_V0.05")
                fake_summary(run, 0.05, 1e-4, 0.2, 0.83, 2.8)
                packings[side] = os.path.join(side, "packing.json")
                with open(packings[side], "w") as f:
                    f.write(content)
                with open(os.path.join(run, "case.toml"), "w") as f:
                    f.write(f"[preparation]\npacking = {json.dumps(packings[side])}\n")
            ca, cb = load_campaign(a), load_campaign(b)
            items = compare_campaigns(ca, cb)
            self.assertEqual(other_packings(items, ca, cb),
                             [("s1_seed1_V0.05", packings[a], packings[b])])
            with contextlib.redirect_stdout(io.StringIO()) as out:
                self.assertEqual(cli_main(["campaign-compare", a, b]), 0)
            self.assertIn(f"note: 1 of the 1 shared runs start from other packings in the two "
                          f"campaigns (s1_seed1_V0.05: {packings[a]} and {packings[b]} differ)",
                          out.getvalue())
            with open(packings[b], "w") as f:   # the same packing, copied: nothing to say
                f.write("[1]")
            self.assertEqual(other_packings(items, ca, cb), [])

    def test_lone_seed_outside_regime_a_is_noted(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            # system 1: one seed at V = 0.05 in C, then B; one seed at V = 1 in A in both; two
            # seeds at V = 0.1 in C (paired, no note); system 2: one seed at V = 0.2, A then
            # undecided
            runs = (("s1_seed1_V0.05", 0.05, "C", "B"), ("s1_seed1_V1", 1.0, "A", "A"),
                    ("s1_seed1_V0.1", 0.1, "C", "C"), ("s1_seed2_V0.1", 0.1, "C", "C"),
                    ("s2_seed1_V0.2", 0.2, "A", "undecided"))
            for name, velocity, regime_a, regime_b in runs:
                for side, mu, regime in ((a, 0.2, regime_a), (b, 0.25, regime_b)):
                    fake_summary(os.path.join(side, "runs", name), velocity, 1e-4, mu, 0.83, 2.8,
                                 regime=regime)
            items = compare_campaigns(a, b)
            self.assertEqual(sorted(lone_unsteady_runs(items)),
                             [("s1_seed1_V0.05", "C", "B"), ("s2_seed1_V0.2", "A", "undecided")])
            with contextlib.redirect_stdout(io.StringIO()) as out:
                self.assertEqual(cli_main(["campaign-compare", a, b]), 0)
            notes = [line for line in out.getvalue().splitlines() if "the one seed" in line]
            self.assertEqual(len(notes), 1)
            self.assertIn("note: 2 of the compared runs are the one seed", notes[0])
            # two seeds of each: every run paired, no note
            for name, velocity, regime_a, regime_b in runs:
                for side, mu, regime in ((a, 0.21, regime_a), (b, 0.27, regime_b)):
                    fake_summary(os.path.join(side, "runs", name.replace("seed1", "seed3")),
                                 velocity, 1e-4, mu, 0.83, 2.8, regime=regime)
            self.assertEqual(lone_unsteady_runs(compare_campaigns(a, b)), [])

    def test_seeds_paired_by_system_and_velocity(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            # three seeds at V = 0.05 whose mu_eff differ by +0.01, +0.02, +0.06 from a to b,
            # although a's seeds scatter by 0.1; one seed at V = 1 (no pair statistics)
            for seed, mu_a, shift in ((1, 0.10, 0.01), (2, 0.20, 0.02), (3, 0.30, 0.06)):
                name = f"s1_seed{seed}_V0.05"
                fake_summary(os.path.join(a, "runs", name), 0.05, 1e-4, mu_a, 0.83, 2.8)
                fake_summary(os.path.join(b, "runs", name), 0.05, 1e-4, mu_a + shift, 0.83, 2.8)
            fake_summary(os.path.join(a, "runs", "s1_seed1_V1"), 1.0, 0.05, 0.30, 0.80, 3.0)
            fake_summary(os.path.join(b, "runs", "s1_seed1_V1"), 1.0, 0.05, 0.35, 0.80, 3.0)
            groups = paired_differences(compare_campaigns(a, b))
            self.assertEqual([(g["system"], g["V"], g["runs"]) for g in groups],
                             [(1, 0.05, 3), (1, 1.0, 1)])
            mu = groups[0]["mu_eff_bulk"]
            self.assertEqual((mu["n"], mu["higher"]), (3, 3))
            self.assertAlmostEqual(mu["mean"], 0.03)
            sd = ((0.02 ** 2 + 0.01 ** 2 + 0.03 ** 2) / 2) ** 0.5
            self.assertAlmostEqual(mu["sd"], sd)
            t = 0.03 / (sd / 3 ** 0.5)
            self.assertAlmostEqual(mu["t"], t)
            # Student's t with 2 degrees of freedom in closed form:
            # P(|T| > t) = 1 - t / sqrt(2 + t^2)
            self.assertAlmostEqual(mu["p"], 1.0 - t / math.sqrt(2.0 + t * t))
            self.assertTrue(math.isnan(groups[0]["nu_bulk"]["t"]))  # no difference at all
            self.assertNotIn("mu_eff_bulk", groups[1])
            # each campaign's own mean over the pairs and its standard error (the packings'
            # scatter): a 0.1, 0.2, 0.3; b 0.11, 0.22, 0.36
            self.assertAlmostEqual(mu["a"]["mean"], 0.2)
            self.assertAlmostEqual(mu["a"]["se"], 0.1 / 3 ** 0.5)
            self.assertAlmostEqual(mu["b"]["mean"], 0.23)
            sd_b = ((0.12 ** 2 + 0.01 ** 2 + 0.13 ** 2) / 2) ** 0.5
            self.assertAlmostEqual(mu["b"]["se"], sd_b / 3 ** 0.5)
            table = format_paired_markdown(compare_campaigns(a, b), "A", "B")
            self.assertIn("| quantity | A | B | B minus A, paired (t) |", table)
            self.assertIn(f"| mu_eff_bulk | 0.200 +- 0.058 | 0.230 +- 0.072 | +0.030 +- 0.015 "
                          f"({t:+.2f}) |", table)
            self.assertIn("| nu_bulk | 0.83 +- 0 | 0.83 +- 0 | +0 +- 0 (+nan) |", table)
            self.assertIn("| com_vx_std | 0.005 +- 0 | 0.005 +- 0 | +0 +- 0 (+nan) |", table)
            text = format_comparison(compare_campaigns(a, b))
            # com_vx_std has no error: no combined errors for it; com_vx has
            self.assertIn("  com_vx_std             0.005 -> 0.005  diff +0\n", text)
            self.assertRegex(text, r"  com_vx .*diff \+0  \(\+0\.00 combined errors\)")
            # one seed: nothing to pair, no table; named below them with the reason
            self.assertNotIn("System 1, V = 1,", table)
            self.assertIn("- `s1_seed1_V1`: the one run of system 1, V = 1 compared", table)
            with contextlib.redirect_stdout(io.StringIO()) as out:
                self.assertEqual(cli_main(["campaign-compare", a, b, "--markdown"]), 0)
            self.assertIn(f"| quantity | {a} | {b} | {b} minus {a}, paired (t) |", out.getvalue())
            self.assertIn(table.splitlines()[5], out.getvalue())


class SharedEnd(unittest.TestCase):
    def test_a_copy_one_flow_or_two_runs(self):
        def run(path, state, case="", build="cdshear 1.0"):
            os.makedirs(path)
            if state is not None:
                with open(os.path.join(path, "run_info.json"), "w") as f:
                    json.dump({"step": 1000, "state_hash": state,
                               "build": {"description": build}}, f)
            with open(os.path.join(path, "case.toml"), "w") as f:
                f.write(case)
            return path

        with tempfile.TemporaryDirectory() as d:
            a = run(os.path.join(d, "a"), "x1", "[output]\nstatus_interval = 7.0\n")
            copy = run(os.path.join(d, "copy"), "x1", "[output]\nstatus_interval = 7.0\n")
            other_case = run(os.path.join(d, "case"), "x1")
            other_build = run(os.path.join(d, "build"), "x1", "[output]\nstatus_interval = 7.0\n",
                              build="cdshear 1.1")
            self.assertEqual(shared_end(a, copy), "copy")
            self.assertEqual(shared_end(copy, a, ("1000", "ignored")), None)   # ends given
            self.assertEqual(shared_end(a, copy, (1000, "x1"), (1000, "x1")), "copy")
            self.assertEqual(shared_end(a, other_case), "one_flow")
            self.assertEqual(shared_end(a, other_build), "one_flow")
            self.assertIsNone(shared_end(a, run(os.path.join(d, "two"), "x2")))
            unknown = run(os.path.join(d, "unknown"), None)
            self.assertIsNone(shared_end(unknown, run(os.path.join(d, "unknown2"), None)))
            self.assertIsNone(shared_end(a, unknown))


class CompareEdgeCases(unittest.TestCase):
    def test_markdown_lists_runs_in_no_table_and_runs_of_one_flow(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = seeds_at_slow_wall(
                d, (0.01, 0.02, 0.0),
                lambda side, seed: "same" if seed == 3 else f"{os.path.basename(side)}{seed}")
            # seed 3 ends in one state in both from another case.toml: one flow, compared
            with open(os.path.join(b, "runs", "s1_seed3_V0.05", "case.toml"), "w") as f:
                f.write("[output]\nstatus_interval = 7.0\n")
            # one seed at V = 1: compared, no pair; seed 4 at other V in the two: not compared
            fake_summary(os.path.join(a, "runs", "s1_seed1_V1"), 1.0, 0.05, 0.30, 0.80, 3.0)
            fake_summary(os.path.join(b, "runs", "s1_seed1_V1"), 1.0, 0.05, 0.35, 0.80, 3.0)
            fake_summary(os.path.join(a, "runs", "s1_seed4_V0.05"), 0.05, 1e-4, 0.2, 0.83, 2.8)
            fake_summary(os.path.join(b, "runs", "s1_seed4_V0.05"), 2.0, 1e-2, 0.4, 0.8, 3.0)
            items = compare_campaigns(a, b)
            self.assertEqual(unpaired(items), [("s1_seed1_V1", "the one run of system 1, V = 1 "
                                                "compared: no other seed to pair it with")])
            table = format_paired_markdown(items)
            self.assertIn("System 1, V = 0.05, 3 seeds paired:", table)
            self.assertTrue(table.endswith(
                "\n\nNot compared:\n\n- `s1_seed4_V0.05`: V 0.05 in a, 2.0 in b"
                "\n\nCompared, in no paired table:\n\n- `s1_seed1_V1`: the one run of system 1, "
                "V = 1 compared: no other seed to pair it with"
                "\n\nOne flow in both:\n\n- `s1_seed3_V0.05`: ends in the same state in both "
                "campaigns from other cases or builds: the two computed one flow there, a "
                "difference of zero"), table)
            with contextlib.redirect_stdout(io.StringIO()) as out:
                self.assertEqual(cli_main(["campaign-compare", a, b, "--markdown"]), 0)
            self.assertIn(table.split("\n\nNot compared:")[1], out.getvalue())
            # runs of one system and V that share no quantity: compared, nothing to pair
            bare = [{"run": f"r{k}", "system": 2, "V": 0.5} for k in (1, 2)]
            self.assertEqual(unpaired(bare), [
                (f"r{k}", "no quantity that two of the 2 runs of system 2, V = 0.5 give: nothing "
                          "to pair") for k in (1, 2)])
            self.assertNotIn("One flow in both", format_paired_markdown(bare))

    def test_only_like_runs_paired_over_every_quantity_any_has(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            for seed in (1, 2, 3):
                name = f"s1_seed{seed}_V0.05"
                fake_summary(os.path.join(a, "runs", name), 0.05, 1e-4, 0.2, 0.83, 2.8)
                s = fake_summary(os.path.join(b, "runs", name), 0.05, 1e-4, 0.22, 0.83, 2.8)
                if seed == 1:  # the first pair lacks the bulk's Z; b's error of mu_eff negative,
                    # its solid fraction a text: both read as missing, not as numbers
                    s["bulk"]["coordination"] = {"mean": None, "err": None}
                    s["bulk"]["mu_eff"]["err"] = -0.003
                    s["bulk"]["solid_fraction"]["mean"] = "0.83"
                    s["case"]["time"] = 500.0
                    with open(os.path.join(b, "runs", name, "summary.json"), "w") as f:
                        json.dump(s, f)
            # the same name at another V and size in b: not compared
            fake_summary(os.path.join(a, "runs", "s1_seed4_V0.05"), 0.05, 1e-4, 0.2, 0.83, 2.8)
            s = fake_summary(os.path.join(b, "runs", "s1_seed4_V0.05"), 2.0, 1e-2, 0.4, 0.8, 3.0)
            s["case"]["n"] = 4000
            with open(os.path.join(b, "runs", "s1_seed4_V0.05", "summary.json"), "w") as f:
                json.dump(s, f)
            items = compare_campaigns(a, b)
            mismatched = [it for it in items if "mismatch" in it]
            self.assertEqual([it["run"] for it in mismatched], ["s1_seed4_V0.05"])
            self.assertEqual(mismatched[0]["mismatch"],
                             "V 0.05 in a, 2.0 in b; n 511 in a, 4000 in b")
            first = next(it for it in items if it["run"] == "s1_seed1_V0.05")
            self.assertTrue(math.isnan(first["mu_eff_bulk"]["combined_errors"]))
            self.assertNotIn("nu_bulk", first)
            (group,) = paired_differences(items)
            self.assertEqual(group["runs"], 3)
            self.assertEqual(group["Z_bulk"]["n"], 2)  # in the paired table though pair 1 lacks it
            # the same +0.02 in every pair: no scatter, an infinite t
            self.assertEqual(group["mu_eff_bulk"]["t"], math.inf)
            self.assertEqual(group["mu_eff_bulk"]["p"], 0.0)
            table = format_paired_markdown(items)
            self.assertIn("| Z_bulk (2 pairs) |", table)
            # the run not compared is named in the Markdown as well, with its reason
            self.assertTrue(table.endswith("\n\nNot compared:\n\n- `s1_seed4_V0.05`: V 0.05 in "
                                           "a, 2.0 in b; n 511 in a, 4000 in b"))
            self.assertIn("no system and V with two seeds in both campaigns\n\nNot compared:",
                          format_paired_markdown(mismatched))
            self.assertEqual(unequal_times(items), [("s1_seed1_V0.05", 1000.0, 500.0)])
            with contextlib.redirect_stdout(io.StringIO()) as out:
                self.assertEqual(cli_main(["campaign-compare", a, b]), 0)
            self.assertIn("note: 1 of the 4 shared runs stand at different times", out.getvalue())
            self.assertIn("s1_seed4_V0.05: not compared: V 0.05 in a, 2.0 in b", out.getvalue())

    def test_a_difference_that_rounds_to_zero_has_no_minus_sign(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            # b - a of mu_eff: -0.00002, +0.003, -0.003: a mean of -6.7e-6 +- 0.0017, a t of -0.004
            for seed, dmu in ((1, -0.00002), (2, 0.003), (3, -0.003)):
                name = f"s1_seed{seed}_V0.05"
                fake_summary(os.path.join(a, "runs", name), 0.05, 1e-4, 0.2, 0.83, 2.8)
                fake_summary(os.path.join(b, "runs", name), 0.05, 1e-4, 0.2 + dmu, 0.83, 2.8)
            items = compare_campaigns(a, b)
            (group,) = paired_differences(items)
            self.assertLess(group["mu_eff_bulk"]["mean"], 0.0)
            self.assertLess(group["mu_eff_bulk"]["t"], 0.0)
            row = next(line for line in format_paired_markdown(items).splitlines()
                       if line.startswith("| mu_eff_bulk |"))
            self.assertIn("| +0.0000 +- 0.0017 (+0.00) |", row)
            self.assertNotIn("-0.0", row)

    def test_until_before_the_first_sample_leaves_the_run_out(self):
        with tempfile.TemporaryDirectory() as d:
            for side in ("a", "b"):
                write_synthetic_run(os.path.join(d, side, "runs", "s1_seed1_V1"), velocity=1.0)
            # Nothing left to compare is an error, as a report with no run to report on.
            with contextlib.redirect_stdout(io.StringIO()) as out, \
                    contextlib.redirect_stderr(io.StringIO()) as err:
                self.assertEqual(cli_main(["campaign-compare", os.path.join(d, "a"),
                                           os.path.join(d, "b"), "--until", "1e-6"]), 2)
            self.assertIn("cannot be analysed as it stood at t = 1e-06", out.getvalue())
            self.assertIn("nothing to compare", err.getvalue())


class Version(unittest.TestCase):
    def test_package_version_is_the_programs(self):
        with open(os.path.join(ROOT, "CMakeLists.txt")) as f:
            program = re.search(r"project\(cdshear VERSION (\S+)", f.read()).group(1)
        with open(os.path.join(ROOT, "python", "pyproject.toml")) as f:
            packaged = re.search(r'^version = "([^"]+)"', f.read(), re.M).group(1)
        self.assertEqual(cdshear_analysis.__version__, program)
        self.assertEqual(packaged, program)


if __name__ == "__main__":
    unittest.main()


class CompareUntil(unittest.TestCase):
    def test_runs_analysed_as_they_stood_at_a_time(self):
        with tempfile.TemporaryDirectory() as d:
            a, b = os.path.join(d, "a"), os.path.join(d, "b")
            # the same transient run (mu_eff relaxing from 0.55 to 0.30) in both campaigns, and
            # one that stopped at 300 t in b only
            for c in (a, b):
                write_synthetic_run(os.path.join(c, "runs", "s1_seed1_V0.5"), kind="transient",
                                    duration=800.0, transient_tau=200.0)
            write_synthetic_run(os.path.join(b, "runs", "s1_seed2_V0.5"), duration=800.0,
                                time_reached=300.0, seed=2)
            for run in ("a/runs/s1_seed1_V0.5", "b/runs/s1_seed1_V0.5", "b/runs/s1_seed2_V0.5"):
                # summaries of the runs as they ended: what --until must not read
                self.assertEqual(main(["analyze", os.path.join(d, run)]), 0)
            whole = load_campaign(a)
            early = load_campaign(a, until=400.0)
            self.assertEqual(early.columns["time_reached"][0], 400.0)
            self.assertEqual(whole.columns["time_reached"][0], 800.0)
            # the transient weighs more over the first 400 t than over all 800
            self.assertGreater(early.columns["mu_eff_wall"][0], whole.columns["mu_eff_wall"][0])
            skipped = dict(load_campaign(b, until=400.0).skipped)
            self.assertIn("reached t = 300 only, before 400", skipped["s1_seed2_V0.5"])
            self.assertEqual(len(load_campaign(b, until=300.0).rows), 2)
            items = compare_campaigns(a, b, until=400.0)
            self.assertEqual([it["run"] for it in items], ["s1_seed1_V0.5"])
            self.assertEqual(items[0]["mu_eff_wall"]["diff"], 0.0)
            self.assertEqual(main(["campaign-compare", a, b, "--until", "400"]), 0)
            self.assertEqual(main(["campaign-compare", a, b, "--until", "-1"]), 2)
            # past every run: the error names --until, not the campaigns
            with contextlib.redirect_stderr(io.StringIO()) as err:
                self.assertEqual(cli_main(["campaign-compare", a, b, "--until", "900"]), 2)
            self.assertIn("error: --until: no run that both campaigns hold is left to compare "
                          "at t = 900: 3 were left out above", err.getvalue())
            # A run.h5 copied from another seed's folder: its summary.json is not read, so
            # its own case (seed 1) is checked against the folder's (seed 3).
            third = os.path.join(b, "runs", "s1_seed3_V0.5")
            write_synthetic_run(third, duration=800.0, seed=3)
            shutil.copy(os.path.join(b, "runs", "s1_seed1_V0.5", "run.h5"), third)
            skipped = dict(load_campaign(b, until=400.0).skipped)
            self.assertEqual(skipped["s1_seed3_V0.5"], "run.h5 is of another run (system.seed "
                                                       "= 1, the folder's case.toml says 3)")

"""The report's warning on steps at the sweep cap: the share of steps, and what a large one
costs."""
import os
import tempfile
import unittest

import numpy as np

from cdshear_analysis import analyze, format_report, load_run
from cdshear_analysis.summary import CAPPED_SHARE_WARNING, sweep_cap_warning
from cdshear_analysis.synthetic import write_synthetic_run


class SweepCapWarning(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        run_dir = os.path.join(cls.tmp.name, "run")
        write_synthetic_run(run_dir, kind="A", duration=400.0)
        cls.run_data = load_run(run_dir)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def report_with_capped(self, capped_per_sample):
        series = self.run_data["series"]
        series["capped_steps"] = np.full(len(series["time"]), capped_per_sample, dtype=np.int64)
        summary = analyze(self.run_data)
        return summary, format_report(summary, "summary.json")

    def test_the_steps_are_counted_from_the_series(self):
        summary, _ = self.report_with_capped(0)
        self.assertEqual(summary["solver"]["steps"], int(self.run_data["series"]["step"][-1]))
        self.assertGreater(summary["solver"]["steps"], len(self.run_data["series"]["time"]))

    def test_no_warning_without_capped_steps(self):
        _, report = self.report_with_capped(0)
        self.assertNotIn("sweep cap", report)

    def test_a_few_capped_steps_give_their_share_only(self):
        summary, report = self.report_with_capped(1)
        steps, capped = summary["solver"]["steps"], summary["solver"]["capped_steps"]
        self.assertLess(capped / steps, CAPPED_SHARE_WARNING)
        share = f"{capped / steps:.1%}"
        self.assertIn(f"warning: {capped} of {steps} steps ({share}) hit the sweep cap", report)
        self.assertNotIn("not converged", report)

    def test_many_capped_steps_say_what_moves(self):
        series = self.run_data["series"]
        per_sample = int(np.ceil(0.5 * series["step"][-1] / len(series["time"])))
        summary, report = self.report_with_capped(per_sample)
        self.assertGreaterEqual(summary["solver"]["capped_steps"] / summary["solver"]["steps"],
                                CAPPED_SHARE_WARNING)
        self.assertIn("not converged", report)
        self.assertIn("the count of force-carrying contacts moves first", report)

    def test_without_a_step_count_the_count_alone(self):
        self.assertEqual(sweep_cap_warning({"capped_steps": 3, "steps": 0}),
                         ["warning: 3 steps hit the sweep cap"])
        self.assertEqual(sweep_cap_warning({"capped_steps": 0, "steps": 10}), [])


if __name__ == "__main__":
    unittest.main()

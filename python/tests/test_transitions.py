"""Transition velocities from synthetic sweeps and the model.md section 8 predictions against hand
computations (transitions.py), and their place in the report."""
import json
import math
import os
import tempfile
import unittest

from cdshear_analysis import fitting, report, transitions as tr
from tests.test_report import fake_summary, main


def row(V, regime, seed=1, steady=True, system=1, **kw):
    r = {"run": f"s{system}_seed{seed}_V{V:g}", "system": system, "seed": seed, "V": V,
         "regime": regime, "steady": steady}
    r.update(kw)
    return r


def sweep(regimes, velocities=(0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)):
    return [row(V, g) for V, g in zip(velocities, regimes)]


class TransitionTest(unittest.TestCase):
    def system(self, rows):
        return tr.find_transitions(rows)["1"]

    def test_clean_sequence_gives_both_brackets(self):
        t = self.system(sweep("CCBBBAA"))
        self.assertTrue(t["monotonic"])
        self.assertEqual(t["flags"], [])
        self.assertEqual(t["V_AB"]["bracket"], [0.2, 0.5])
        self.assertEqual(t["V_AB"]["status"], "bracketed")
        self.assertAlmostEqual(t["V_AB"]["estimate"], math.sqrt(0.2 * 0.5))
        self.assertEqual(t["V_BC"]["bracket"], [0.02, 0.05])
        self.assertAlmostEqual(t["V_BC"]["estimate"], math.sqrt(0.02 * 0.05))
        self.assertEqual(t["sequence"], "C C B B B A A")

    def test_order_of_rows_does_not_matter(self):
        rows = sweep("CCBBBAA")
        self.assertEqual(self.system(rows[::-1])["V_AB"], self.system(rows)["V_AB"])

    def test_non_monotonic_sequence_is_flagged(self):
        t = self.system(sweep("BBABAAA"))
        self.assertFalse(t["monotonic"])
        self.assertTrue(any(f.startswith("not monotonic") for f in t["flags"]), t["flags"])
        # the last change to A: everything above the bracket is A
        self.assertEqual(t["V_AB"]["bracket"], [0.1, 0.2])

    def test_no_a_leaves_v_ab_unbracketed_above(self):
        t = self.system(sweep("CCBBB", velocities=(0.01, 0.02, 0.05, 0.1, 0.2)))
        self.assertEqual(t["V_AB"]["status"], "unbracketed")
        self.assertEqual(t["V_AB"]["bracket"], [0.2, None])
        self.assertIsNone(t["V_AB"]["estimate"])
        self.assertIn("V_AB above the largest V run", t["V_AB"]["note"])
        self.assertEqual(t["V_BC"]["bracket"], [0.02, 0.05])

    def test_only_a_and_no_c(self):
        t = self.system(sweep("AAA", velocities=(0.5, 1.0, 2.0)))
        self.assertEqual(t["V_AB"]["bracket"], [None, 0.5])
        self.assertIn("below the smallest V run", t["V_AB"]["note"])
        self.assertEqual(t["V_BC"]["status"], "unbracketed")
        t = self.system(sweep("BBA", velocities=(0.1, 0.2, 0.5)))
        self.assertEqual(t["V_BC"]["bracket"], [None, 0.1])
        self.assertIn("V_BC below the smallest V run", t["V_BC"]["note"])

    def test_c_then_a_without_b(self):
        t = self.system(sweep("CCA", velocities=(0.1, 0.2, 0.5)))
        self.assertEqual(t["V_AB"]["bracket"], [0.2, 0.5])
        self.assertEqual(t["V_BC"]["bracket"], [0.2, None])
        self.assertIn("followed by A at 0.5", t["V_BC"]["note"])

    def test_seeds_vote_per_velocity(self):
        rows = [row(0.1, "B", 1), row(0.1, "B", 2), row(0.1, "A", 3, steady=False),
                row(0.2, "A", 1), row(0.2, "A", 2), row(0.2, "B", 3),
                row(0.5, "A", 1), row(0.5, "B", 2)]
        t = self.system(rows)
        v = {e["V"]: e for e in t["velocities"]}
        self.assertEqual(v[0.1]["regime"], "B")
        # seed 3 at 0.1 is not steady: it does not vote, and is named with the reason
        self.assertEqual(v[0.1]["votes"], {"B": 2})
        self.assertEqual(v[0.1]["not_steady"], ["s1_seed3_V0.1"])
        self.assertEqual(v[0.1]["not_voting"], [{"run": "s1_seed3_V0.1",
                                                 "reason": "not steady"}])
        self.assertEqual(v[0.2]["regime"], "A")
        self.assertIsNone(v[0.5]["regime"])        # tie: no vote
        self.assertIn("tie", v[0.5]["note"])
        self.assertEqual(t["V_AB"]["bracket"], [0.1, 0.2])
        self.assertTrue(any("tie" in f for f in t["flags"]))

    def test_only_steady_runs_classified_a_b_or_c_vote(self):
        # the truth: C below 0.03, B up to 0.3, A above. A run not steady, one undecided, one
        # intermittent and one without a regime sit on the wrong side of each transition:
        # had they voted, V_AB would be [0.1, 0.2] and V_BC [0.05, 0.1]
        rows = [row(0.01, "C"), row(0.02, "C"), row(0.05, "B"), row(0.1, "B"),
                row(0.2, "B"), row(0.5, "A"), row(1.0, "A"),
                row(0.2, "A", seed=2, steady=False), row(0.2, "A", seed=3, steady=None),
                row(0.1, "C", seed=2, steady=False), row(0.05, "undecided", seed=2),
                row(0.1, "intermittent", seed=3), row(0.5, None, seed=2)]
        t = self.system(rows)
        self.assertEqual(t["V_AB"]["bracket"], [0.2, 0.5])
        self.assertEqual(t["V_BC"]["bracket"], [0.02, 0.05])
        self.assertTrue(t["monotonic"])
        self.assertEqual(t["flags"], [])
        self.assertEqual(t["sequence"], "C C B B B A A")
        self.assertEqual({e["run"]: e["reason"] for e in t["not_voting"]}, {
            "s1_seed2_V0.2": "not steady", "s1_seed3_V0.2": "steady state unknown",
            "s1_seed2_V0.1": "not steady",
            "s1_seed2_V0.05": "regime 'undecided' (only A, B and C vote)",
            "s1_seed3_V0.1": "regime 'intermittent' (only A, B and C vote)",
            "s1_seed2_V0.5": "no regime"})
        v = {e["V"]: e for e in t["velocities"]}
        self.assertEqual(v[0.2]["votes"], {"B": 1})
        self.assertEqual(v[0.1]["votes"], {"B": 1})
        # a V where no run votes gives no regime, and says why
        t = self.system([row(0.1, "B"), row(0.2, "undecided"), row(0.5, "A", steady=False)])
        v = {e["V"]: e for e in t["velocities"]}
        self.assertIsNone(v[0.2]["regime"])
        self.assertIn("no run votes (s1_seed1_V0.2: regime 'undecided'", v[0.2]["note"])
        self.assertEqual(t["V_AB"]["bracket"], [0.1, None])

    def test_runs_without_regime_do_not_crash(self):
        t = self.system([row(0.1, None), row(0.2, None)])
        self.assertEqual(t["V_AB"]["status"], "unbracketed")
        self.assertEqual(t["sequence"], "? ?")

    def test_systems_are_separate(self):
        rows = sweep("BBA", velocities=(0.1, 0.2, 0.5)) + \
            [row(V, g, system=2) for V, g in ((0.1, "B"), (0.2, "A"), (0.5, "A"))]
        t = tr.find_transitions(rows)
        self.assertEqual(t["1"]["V_AB"]["bracket"], [0.2, 0.5])
        self.assertEqual(t["2"]["V_AB"]["bracket"], [0.1, 0.2])


class PredictionTest(unittest.TestCase):
    def c_row(self, **kw):
        r = row(0.01, "C", L_y=20.0, nu_bulk=0.8, _sigma_yy=0.25, time_reached=5000.0,
                switch_duration=30.0, switch_duration_err=2.0, switch_time=32.0,
                switch_time_err=2.0, switch_delta_mu=0.02,
                switch_delta_mu_err=0.004,
                _switches=[{"start_time": 1000.0}, {"start_time": 2500.0},
                           {"start_time": 4000.0}])
        r.update(kw)
        return r

    def test_switch_time_against_hand_computation(self):
        # 2 * 1 * 0.8 * 0.01 * 20 / (0.02 * 0.25) = 0.32 / 0.005 = 64
        self.assertAlmostEqual(tr.switch_time(0.01, 20.0, 0.8, 0.02, 0.25), 64.0)
        (e,) = tr.switch_predictions([self.c_row(), row(1.0, "A")])
        # The plateau's net friction is a diagnostic; without a boundary law, no prediction.
        self.assertAlmostEqual(e["delta_mu_plateau"], 0.02)
        self.assertIsNone(e["predicted_T"])
        self.assertIn("boundary law", e["reason"])
        self.assertEqual(e["switch_count"], 3)
        self.assertAlmostEqual(e["mean_interval"], 1500.0)
        self.assertAlmostEqual(e["time_per_switch"], 5000.0 / 3)
        # from the measured T: 2 * 0.8 * 0.01 * 20 / (32 * 0.25) = 0.32 / 8
        self.assertAlmostEqual(e["delta_mu_implied"], 0.32 / 8.0)
        self.assertEqual((e["switch_time"], e["switch_time_err"]), (32.0, 2.0))
        (e,) = tr.switch_predictions([self.c_row(switch_time=None)])
        self.assertIsNone(e["delta_mu_implied"])

    def test_switches_are_timed_over_the_averaged_span(self):
        # summary.json keeps the switches of the averaged span: the time per switch is over it
        (e,) = tr.switch_predictions([self.c_row(_averaged_time=4500.0)])
        self.assertAlmostEqual(e["observed_time"], 4500.0)
        self.assertAlmostEqual(e["time_per_switch"], 4500.0 / 3)
        (e,) = tr.switch_predictions([self.c_row(_averaged_time=4500.0, _switches=[])])
        self.assertIn("no switch in 4500 time units", e["measured_note"])
        # without the averaged time (NaN: the summary does not say), the time reached
        (e,) = tr.switch_predictions([self.c_row(_averaged_time=math.nan)])
        self.assertAlmostEqual(e["time_per_switch"], 5000.0 / 3)

    def test_switch_time_without_wall_frictions_says_what_is_missing(self):
        (e,) = tr.switch_predictions([self.c_row(switch_delta_mu=None, _switches=[],
                                                 switch_duration=None, switch_time=None)])
        self.assertIsNone(e["predicted_T"])
        self.assertIn("delta_mu", e["reason"])
        self.assertIsNone(e["delta_mu_plateau"])
        self.assertIn("no switch", e["measured_note"])
        self.assertIsNone(e["mean_interval"])
        self.assertIsNone(e["delta_mu_implied"])

    def linear_fit(self, a=0.3, b=0.5):
        return {"status": "ok", "model": "linear_plus", "range": [0.03, 0.2],
                "parameters": {"a": {"value": a}, "b": {"value": b}}}

    def test_steady_state_time_for_a_linear_law(self):
        # mu = 0.3 + 0.5 I, I = gamma_dot sqrt(m / sigma): d mu / d gamma_dot = 0.5 sqrt(m / s)
        m, s, nu, L = math.pi / 4, 0.25, 0.8, 20.0
        D = 0.5 * math.sqrt(m / s) * s / (1.0 * nu)
        T, D_got = tr.steady_state_time(self.linear_fit(), 0.1, L, nu, s)
        self.assertAlmostEqual(D_got, D)
        self.assertAlmostEqual(T, L * L / D)
        self.assertAlmostEqual(T, 400 / (0.5 * math.sqrt(math.pi) * 0.25 / 0.8))
        fits = {"mu_power": {"status": "skipped"}, "mu_linear": self.linear_fit()}
        rows = [row(1.0, "A", I_bulk=0.1, L_y=L, nu_bulk=nu, _sigma_yy=s,
                    transient_end_time=300.0), row(0.01, "B")]
        (e,) = tr.steady_state_predictions(rows, fits)
        self.assertEqual(e["law"], "mu_linear")
        self.assertAlmostEqual(e["predicted_T_SS"], L * L / D)
        self.assertEqual(e["measured_transient_end_time"], 300.0)

    def test_power_law_slope_and_preference(self):
        power = {"status": "ok", "model": "power_plus",
                 "parameters": {"mu_0": {"value": 0.25}, "A": {"value": 1.0},
                                "B": {"value": 2.0}}}
        self.assertAlmostEqual(fitting.slope(power, 0.1), 0.2)
        fits = {"mu_power": power, "mu_linear": self.linear_fit()}
        (e,) = tr.steady_state_predictions(
            [row(1.0, "A", I_bulk=0.1, L_y=20.0, nu_bulk=0.8, _sigma_yy=0.25)], fits)
        self.assertEqual(e["law"], "mu_power")
        self.assertAlmostEqual(e["dmu_dI"], 0.2)

    def test_steady_state_time_without_fit_or_values_gives_reasons(self):
        fits = {"mu_power": {"status": "skipped"}, "mu_linear": {"status": "skipped"}}
        (e,) = tr.steady_state_predictions([row(1.0, "A", I_bulk=0.1)], fits)
        self.assertIn("no mu_eff(I) law whose parameters are determined", e["reason"])
        fits["mu_linear"] = self.linear_fit()
        (e,) = tr.steady_state_predictions([row(1.0, "A", I_bulk=0.1)], fits)
        self.assertIn("missing L_y, nu_bulk, sigma_yy", e["reason"])
        fits["mu_linear"] = self.linear_fit(b=-0.1)
        (e,) = tr.steady_state_predictions(
            [row(1.0, "A", I_bulk=0.1, L_y=20.0, nu_bulk=0.8, _sigma_yy=0.25)], fits)
        self.assertIn("no diffusion", e["reason"])

    def test_v_ab_is_not_invented(self):
        p = tr.predictions([], {})
        self.assertEqual(p["V_AB"]["status"], "not available")
        self.assertIn("boundary friction law", p["V_AB"]["reason"])


class ReportTransitionTest(unittest.TestCase):
    def report(self):
        """`report` over the campaign folder: (its output folder, the parsed fits.json)."""
        self.assertEqual(main(["report", self.d]), 0)
        out = os.path.join(self.d, "report")
        with open(os.path.join(out, "fits.json")) as f:
            return out, json.load(f)

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.d = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def test_a_run_that_is_not_steady_does_not_move_a_bracket(self):
        # summaries as analyze writes them: B up to 0.2, A from 1.0; the one run at 0.5, A but
        # not steady, would move V_AB down to [0.2, 0.5] if it voted; an undecided run at 0.05
        # and an intermittent one at 1.5, both steady, do not vote either. The report draws
        # them in the regime diagram and fits the boundary laws without them.
        runs = [(0.02, "B", 1, True), (0.05, "B", 1, True), (0.1, "B", 1, True),
                (0.2, "B", 1, True), (0.5, "A", 1, False), (1.0, "A", 1, True),
                (1.5, "A", 1, True), (2.0, "A", 1, True), (0.05, "undecided", 2, True),
                (1.5, "intermittent", 2, True)]
        for V, g, seed, steady in runs:
            fake_summary(os.path.join(self.d, "runs", f"s1_seed{seed}_V{V:g}"), V, 0.1 * V,
                         0.3 + 0.2 * V, 0.8 - 0.05 * V, 3.5, regime=g, steady=steady)
        out, fits = self.report()
        t = fits["transitions"]["1"]
        self.assertEqual(t["V_AB"]["bracket"], [0.2, 1.0])
        self.assertEqual(t["monotonic"], True)
        self.assertEqual({e["run"]: e["reason"] for e in t["not_voting"]}, {
            "s1_seed1_V0.5": "not steady",
            "s1_seed2_V0.05": "regime 'undecided' (only A, B and C vote)",
            "s1_seed2_V1.5": "regime 'intermittent' (only A, B and C vote)"})
        self.assertIn("V = 0.5: no run votes (s1_seed1_V0.5: not steady)", t["flags"])
        # had it voted (the old rule: every run with a regime), the bracket would move
        rows = report.collect(self.d)["rows"]
        for r in rows:
            if r["run"] == "s1_seed1_V0.5":
                r["steady"] = True
        self.assertEqual(tr.find_transitions(rows)["1"]["V_AB"]["bracket"], [0.2, 0.5])
        with open(os.path.join(out, "index.html")) as f:
            text = f.read()
        self.assertIn("s1_seed1_V0.5 (not steady)", text)
        self.assertIn("s1_seed2_V0.05 (regime &#x27;undecided&#x27; (only A, B and C vote))",
                      text)
        self.assertTrue(os.path.isfile(os.path.join(out, "figures", "regimes.png")))
        # the boundary laws take the layers of A, B and C runs only
        boundary_runs = {run.split(":")[0] for f in (fits["boundary"]["h5"]["mu_power"],)
                         for run in f["runs"]}
        self.assertNotIn("s1_seed2_V0.05", boundary_runs)
        self.assertNotIn("s1_seed2_V1.5", boundary_runs)
        self.assertIn("s1_seed1_V1.5", boundary_runs)

    def test_report_writes_transitions_predictions_and_the_diagram(self):
        runs = ((0.01, "C"), (0.05, "B"), (0.2, "B"), (1.0, "A"), (1.5, "A"), (2.0, "A"),
                (3.0, "A"))
        for V, g in runs:
            s = fake_summary(os.path.join(self.d, "runs", f"s1_seed1_V{V:g}"), V, 0.1 * V,
                             0.3 + 0.2 * V, 0.8 - 0.05 * V, 3.5, regime=g, steady=V > 0.02)
            if g == "C":   # one C run with switches and a friction per wall
                s["switches"] = [{"start_time": 100.0, "duration": 40.0},
                                 {"start_time": 700.0, "duration": 50.0}]
                s["switch_duration"] = {"mean": 45.0, "err": 5.0}
                s["switch_delta_mu"] = {"mean": 0.02, "err": 0.004}
                with open(os.path.join(s["run_dir"], "summary.json"), "w") as f:
                    json.dump(s, f)
        out, fits = self.report()
        t = fits["transitions"]["1"]
        self.assertEqual(t["V_AB"]["bracket"], [0.2, 1.0])
        # the C run at 0.01 is not steady: it does not vote, so V_BC is below the smallest
        # V that votes (0.05, B)
        self.assertEqual(t["V_BC"]["bracket"], [None, 0.05])
        self.assertEqual(t["velocities"][0]["not_steady"], ["s1_seed1_V0.01"])
        self.assertEqual(t["not_voting"], [{"run": "s1_seed1_V0.01", "reason": "not steady"}])
        (c,) = fits["predictions"]["switch_time_C"]
        self.assertAlmostEqual(c["delta_mu_plateau"], 0.02)
        # Both walls' layers of the fixture are alike: the boundary law gives delta_mu = 0 at
        # their jumps, hence no switch time, and the entry says why (a T from the law:
        # test_report_fits).
        self.assertIsNone(c["predicted_T"])
        self.assertTrue(c["reason"].startswith("not computed: no delta_mu from the boundary law"),
                        c["reason"])
        self.assertEqual(c["mean_interval"], 600.0)
        self.assertEqual(len(fits["predictions"]["steady_state_time_A"]), 4)
        # the bulk laws take the regime A runs only (the bulk of B and C does not flow)
        mu = fits["fits"]["mu_power"]
        self.assertEqual(mu["regimes"], ["A"])
        self.assertEqual(sorted(mu["runs"]), sorted(f"s1_seed1_V{V:g}" for V, g in runs
                                                    if g == "A"))
        self.assertTrue(os.path.isfile(os.path.join(out, "figures", "regimes.png")))
        with open(os.path.join(out, "index.html")) as f:
            text = f.read()
        self.assertIn("Transition velocities", text)
        self.assertIn("V_AB from the laws", text)
        self.assertIn("Boundary-layer laws", text)
        self.assertEqual(sorted(fits["predictions"]["V_AB"]["systems"]), ["1"])
        self.assertEqual(fits["predictions"]["V_AB"]["systems"]["1"]["measured"]["bracket"],
                         [0.2, 1.0])


if __name__ == "__main__":
    unittest.main()

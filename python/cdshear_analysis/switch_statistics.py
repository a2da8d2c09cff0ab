"""Band switches over whole runs, pooled over seeds and compared between two groups of runs.
`python3 -m cdshear_analysis switch-times RUN_DIR... [--against RUN_DIR...]`; docs/validation.md,
claim 7.

A run's summary.json holds the switches of its averaged span only (the steady windows, or the
last half of a run that is not steady). The switch time of regime C (model.md section 8, T = 2
rho nu V L_y / (delta_mu sigma_yy)) belongs to every switch, so here each run's whole series of
the block's velocity is searched (regime.band_switches: each switch timed by the straight ramp
fitted between the plateaus), the runs of one group (the seeds of one system and V) pooled, and
two groups (two heights) compared:

- a group: its switches and the time its runs span (each run's first to last sample, the
  start-up included, as a switch can come at any time); the switch rate (switches per time);
  the switch time T over its switches with a finite time, its mean +- standard error (the
  sample standard deviation / sqrt(count)), median and range, and T / V (each switch's T over
  its run's V: groups at several V);
- two groups: the ratio of their mean T with a 68% bootstrap interval (the switches of each group
  drawn with replacement, RESAMPLES times, with a fixed seed: the same interval on every call),
  and the ratio of their rates with the two-sided binomial test conditional on the total count
  (under equal rates, each switch falls in the first group with the share of the time its runs
  span).

The switch times spread over a factor of ten in the runs measured (docs/campaigns.md, "What the
taller cell shows"): a ratio of means needs a few tens of switches per group to be told from 1 or
from 2. The bootstrap assumes the switches are independent; those of one run share its packing.
"""
import math
import os

import numpy as np

from . import regime as rg
from .rundata import (RUN_FILE, RunDataError, end_state, is_measured_number, load_run,
                      repeated_folder)
from .statistics import window_mean
from .summary import pm as summary_pm

RESAMPLES = 20000          # bootstrap draws of the T ratio
BOOTSTRAP_SEED = 1
INTERVAL = (0.16, 0.84)    # the 68% interval's quantiles


def run_switches(run_dir):
    """One run's switches over its whole series: {"run", "V", "L_y" (the mean height), "time"
    (its first to last sample), "finished" (the run reached its duration), "duration",
    "switches" (count), "switch_times" (each switch's T, None for one across a gap in the
    samples, which has none) and "starts" (each switch's start time)}. From run.h5 where the
    folder holds one (refused when it is of another run than the folder's case.toml), else from
    its summary.json's `whole_run_switches` (what a clone keeps).
    Raises rundata.RunDataError for a run it cannot read."""
    # lexists: a broken link or a folder in a file's place is read, and its error named
    if not os.path.lexists(os.path.join(run_dir, RUN_FILE)) and os.path.lexists(
            os.path.join(run_dir, "summary.json")):
        return summary_switches(run_dir)
    from .report import run_file_identity_problem
    run = load_run(run_dir)
    if why := run_file_identity_problem(run, run_dir):
        raise RunDataError(os.path.join(run_dir, RUN_FILE), why)
    s, attrs = run["series"], run["attrs"]
    time = np.asarray(s["time"], dtype=float)
    u, source = rg.block_velocity(s)
    V = float(attrs["velocity"])
    whole = rg.whole_run_switches(time, rg.band_switches(time, u, V, source=source),
                                  s["height"])
    case = {key: float(attrs[key]) for key in CASE_KEYS}
    return _record(run_dir, V, bool(attrs.get("finished", 0)), float(attrs["duration"]), whole,
                   case)


def _counted(k, one, many):
    """k and its noun: "1 run", "2 runs"."""
    return f"{k} {one if k == 1 else many}"


# The case values the runs of one group share (a group is the seeds of one system, at one or
# several V): the grain count, the cell's nominal height and the normal stress.
CASE_KEYS = ("n", "height", "normal_stress")


def _record(run_dir, V, finished, duration, whole, case):
    return {"run": os.path.basename(os.path.normpath(run_dir)), "V": V, "L_y": whole["L_y"],
            "time": whole["time"], "finished": finished, "duration": duration,
            "switches": len(whole["starts"]), "switch_times": whole["switch_times"],
            "starts": whole["starts"], **case}


def group_problem(runs, dirs, end_states=None):
    """Why the runs of one group (run_switches records, read from `dirs`) cannot be pooled, or
    None: a folder given twice or one run copied (repeated_folder), two folders without an end
    state to tell a copy by whose case.toml files are one (the same_case_problem), or runs of
    another system or normal stress (CASE_KEYS) than the first's. `end_states`: {folder:
    rundata.end_state} already read (the rest read here)."""
    if end_states is None:
        end_states = {d: end_state(d) for d in dirs}
    if repeated := repeated_folder(dirs, end_states) or same_case_problem(dirs, end_states):
        return repeated
    for run, d in zip(runs, dirs):
        for key in CASE_KEYS:
            if run[key] != runs[0][key]:
                return (f"{d} has {key} {run[key]:g}, {dirs[0]} {runs[0][key]:g}: a group pools "
                        "the seeds of one system and normal stress")
    return None


def _case_identity(case):
    """A resolved case (case.toml) as one comparable text, less what does not change the flow:
    its [output] table and the packing file's path (a copy of the run keeps the packing but may
    name it from elsewhere)."""
    import json
    kept = {table: values for table, values in case.items() if table != "output"}
    if isinstance(kept.get("preparation"), dict):
        kept["preparation"] = {k: v for k, v in kept["preparation"].items() if k != "packing"}
    return json.dumps(kept, sort_keys=True, default=str)


def same_case_problem(dirs, end_states=None):
    """Why two of the folders hold one run, told by their case.toml where neither has an end
    state in a run_info file (rundata.end_state, which repeated_folder compares: such a folder
    was copied with its run.h5 alone, or its records are lost): one case, seeds included, is one
    run, runs being deterministic; or None. `end_states`: {folder: end_state} already read."""
    from .rundata import folder_case
    end_states = end_states if end_states is not None else {}
    seen = {}
    for d in dirs:
        state = end_states[d] if d in end_states else end_state(d)
        if state is not None or (case := folder_case(d)) is None:
            continue
        identity = _case_identity(case)
        if identity in seen:
            return (f"{d} holds the run {seen[identity]} holds (the same case.toml, seeds "
                    f"included, and no run_info file to tell them apart): each run counts once")
        seen[identity] = d
    return None


def summary_switches(run_dir):
    """run_switches' record from RUN_DIR/summary.json alone: its `whole_run_switches` (the
    analysis that wrote it searched the whole series of run.h5) and its case's velocity,
    duration and finished flag. Raises rundata.RunDataError naming the file and the key that
    is missing or not what it should be."""
    from .report import ReportError, identity_problem, read_summary, summary_state
    path = os.path.join(run_dir, "summary.json")
    try:
        summary = read_summary(run_dir)
    except ReportError as e:
        raise RunDataError(path, f"no {RUN_FILE} beside it, and it cannot be read ({e.problem})")
    if not isinstance(summary, dict):
        raise RunDataError(path, f"no {RUN_FILE} beside it, and it holds no JSON object")
    if (state := summary_state(summary)) is not None:
        raise RunDataError(path, f"no {RUN_FILE} beside it, and {state[1]}")
    whole = summary.get("whole_run_switches")
    if whole is None:
        raise RunDataError(path, f"no {RUN_FILE} beside it, and no whole_run_switches key (an "
                           "analysis older than that key wrote it): to time its switches, "
                           "remove the run's folder and sweep its campaign again")
    case = summary.get("case")

    def bad(key, what):
        return RunDataError(path, f"{key} is {what}")

    # numbers through is_measured_number: Python reads Infinity and NaN, which analyze never
    # writes
    if not isinstance(case, dict):
        raise bad("case", "not an object")
    V, duration, finished = case.get("velocity"), case.get("duration"), case.get("finished")
    if not (is_measured_number(V) and V > 0):
        raise bad("case.velocity", f"{V!r}, not a finite positive number")
    if not (is_measured_number(duration) and duration > 0):
        raise bad("case.duration", f"{duration!r}, not a finite positive number")
    if not isinstance(finished, bool):
        raise bad("case.finished", f"{finished!r}, not true or false")
    for key in CASE_KEYS:
        if not (is_measured_number(case.get(key)) and case[key] > 0):
            raise bad(f"case.{key}", f"{case.get(key)!r}, not a finite positive number")
    if other := identity_problem(run_dir, summary):
        raise RunDataError(path, f"no {RUN_FILE} beside it, and {other}")
    if not isinstance(whole, dict):
        raise bad("whole_run_switches", "not an object")
    span, height = whole.get("time"), whole.get("L_y")
    times, starts = whole.get("switch_times"), whole.get("starts")
    if not (is_measured_number(span) and span >= 0):
        raise bad("whole_run_switches.time", f"{span!r}, not a finite number of at least 0")
    if not (height is None or (is_measured_number(height) and height > 0)):
        raise bad("whole_run_switches.L_y", f"{height!r}, not a positive number or null")
    if not (isinstance(starts, list) and all(is_measured_number(t) and t >= 0 for t in starts)):
        raise bad("whole_run_switches.starts", "not a list of numbers of at least 0")
    # a switch's ramp lies within the series: 0 < T <= its span
    if not (isinstance(times, list) and len(times) == len(starts)
            and all(t is None or (is_measured_number(t) and 0 < t <= span) for t in times)):
        raise bad("whole_run_switches.switch_times",
                  f"not a list of numbers in (0, {span!r}] (the time the series spans) or "
                  "nulls, one per start")
    whole = {"time": float(span), "L_y": math.nan if height is None else float(height),
             "switch_times": [None if t is None else float(t) for t in times],
             "starts": [float(t) for t in starts]}
    return _record(run_dir, float(V), finished, float(duration), whole,
                   {key: float(case[key]) for key in CASE_KEYS})


def _timed(runs, per_velocity=False):
    """The finite switch times of a group's runs (over each run's V with per_velocity)."""
    return np.array([t / r["V"] if per_velocity else t for r in runs
                     for t in r["switch_times"] if t is not None], dtype=float)


def group_statistics(runs):
    """The pooled switches of a group of runs (run_switches' dicts): {"runs", "switches", "time",
    "rate" (switches per time unit; NaN without time), "timed" (switches with a finite T), "T"
    and "T_err" (mean and standard error; the error NaN below two), "T_median", "T_min",
    "T_max", "T_over_V" and "T_over_V_err", "L_y" (the runs' mean height)}."""
    times, per_v = _timed(runs), _timed(runs, per_velocity=True)
    count = sum(r["switches"] for r in runs)
    span = sum(r["time"] for r in runs)
    T, T_err = window_mean(times)
    T_v, T_v_err = window_mean(per_v)
    heights = [r["L_y"] for r in runs if math.isfinite(r["L_y"])]
    return {"runs": len(runs), "switches": count, "time": span,
            "rate": count / span if span > 0 else math.nan, "timed": len(times),
            "T": T, "T_err": T_err,
            "T_median": float(np.median(times)) if len(times) else math.nan,
            "T_min": float(times.min()) if len(times) else math.nan,
            "T_max": float(times.max()) if len(times) else math.nan,
            "T_over_V": T_v, "T_over_V_err": T_v_err,
            "L_y": float(np.mean(heights)) if heights else math.nan}


def compare_groups(runs, against, resamples=RESAMPLES, seed=BOOTSTRAP_SEED):
    """The first group (`runs`) against the second: {"T_ratio" (mean T of the first over the
    second's), "T_ratio_interval" ([16%, 84%] of the bootstrap; None with fewer than two timed
    switches in a group), "resamples", "seed", "rate_ratio", "rate_p" (two-sided binomial test of
    equal rates given the total count; NaN without switches or time)}."""
    from scipy import stats
    a, b = _timed(runs), _timed(against)
    ga, gb = group_statistics(runs), group_statistics(against)
    ratio = ga["T"] / gb["T"] if len(a) and len(b) and gb["T"] > 0 else math.nan
    interval = None
    if len(a) > 1 and len(b) > 1 and b.min() > 0:   # a T is positive: a ramp takes time
        rng = np.random.default_rng(seed)
        ratios = (rng.choice(a, (resamples, len(a))).mean(axis=1)
                  / rng.choice(b, (resamples, len(b))).mean(axis=1))
        interval = [float(q) for q in np.quantile(ratios, INTERVAL)]
    n_a, n_b, t_a, t_b = ga["switches"], gb["switches"], ga["time"], gb["time"]
    rate_ratio = (ga["rate"] / gb["rate"] if gb["rate"] > 0 else
                  math.inf if ga["rate"] > 0 else math.nan)
    p = (float(stats.binomtest(n_a, n_a + n_b, t_a / (t_a + t_b)).pvalue)
         if n_a + n_b > 0 and t_a > 0 and t_b > 0 else math.nan)
    return {"T_ratio": ratio, "T_ratio_interval": interval, "resamples": resamples,
            "seed": seed, "rate_ratio": rate_ratio, "rate_p": p}


def _g(x, digits=3):
    return "n/a" if x is None or math.isnan(x) else f"{x:.{digits}g}"


def _pm(mean, err):
    return summary_pm({"mean": mean, "err": err})


def format_table(runs, against=None, comparison=None):
    """The printed table: each run, each group's pooled line, and the comparison."""
    lines = [f"{'run':<24} {'V':>7} {'L_y':>6} {'time':>8} {'switches':>8}  T of each [t]"]
    groups = [("runs", runs)] + ([("against", against)] if against else [])
    for name, group in groups:
        for r in group:
            lines.append(f"{r['run']:<24} {r['V']:>7g} {_g(r['L_y']):>6} {r['time']:>8.0f} "
                         f"{r['switches']:>8}  "
                         + (", ".join(_g(t) for t in r["switch_times"]) or "-")
                         + ("" if r["finished"] else
                            f"  (not finished: its duration is {r['duration']:g})"))
    for name, group in groups:
        g = group_statistics(group)
        lines.append(
            f"{name}: {_counted(g['runs'], 'run', 'runs')} (L_y {_g(g['L_y'])}), "
            f"{_counted(g['switches'], 'switch', 'switches')} in "
            f"{g['time']:.0f} t (one per {_g(1 / g['rate'] if g['rate'] > 0 else math.nan, 4)} "
            f"t); T = {_pm(g['T'], g['T_err'])} t (median {_g(g['T_median'])}, "
            f"{_g(g['T_min'])} to {_g(g['T_max'])}; {g['timed']} timed), T / V = "
            f"{_pm(g['T_over_V'], g['T_over_V_err'])}")
    unfinished = [r["run"] for _, group in groups for r in group if not r["finished"]]
    if unfinished:
        lines.append(f"warning: {', '.join(unfinished)} not finished (still running or "
                     "stopped): counted over the time they reached")
    if comparison:
        iv = comparison["T_ratio_interval"]
        lines.append(
            f"T ratio (runs / against): {_g(comparison['T_ratio'])}, 68% bootstrap interval "
            + (f"{_g(iv[0])} to {_g(iv[1])}" if iv else "n/a (fewer than two timed switches)")
            + f" ({comparison['resamples']} resamples of the switches, seed {comparison['seed']})")
        lines.append(
            f"rate ratio (runs / against): {_g(comparison['rate_ratio'])}; two-sided p = "
            f"{_g(comparison['rate_p'], 2)} (binomial test of equal rates, conditional on the "
            "total count)")
    return "\n".join(lines)

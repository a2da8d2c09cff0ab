"""Means of a run's time series after a given time: what a short solver check reads.

`series_means(run_data, after, keys, before)` averages `series/KEY` of run.h5 over the samples with
after < time <= before (docs/run-data.md; `before` defaults to the end), so that runs of different
lengths, or whose analyses chose different averaging windows, compare over one window. The standard
error of the mean comes from block averaging (statistics.block_average, the analysis' own method),
since neighbouring samples are correlated: as if they were independent it was up to 2.5 times too
small on the solver checks of docs/step-error.md ("Tall cells"). When the blocks find no plateau (a
short window) the largest error over the levels is given and the output says so: then it is still a
lower bound. It serves scripts/solver_check.sh (docs/accuracy-methods.md, "Checkpoint copies"),
which resumes copies of a run's checkpoint with other solver settings and compares, for example, the
force-carrying contacts.

`paired_differences(check_dir, keys)` serves scripts/paired_check.sh: copies of several runs'
checkpoints, each resumed as two sides (a/ and b/: two executables or two settings), compared
pair by pair.
"""
import math
import os

import numpy as np

from .rundata import DistinctRuns, end_state, identity_pairs, open_regular
from .statistics import block_average


class SeriesError(Exception):
    def __init__(self, problem):
        super().__init__(problem)
        self.problem = problem


def series_means(run_data, after, keys, before=float("inf"), finite_needed=2):
    """{key: (mean, standard error, samples, samples per block, plateau found)} over the samples
    with after < time <= before; the error by block averaging. Raises SeriesError when the window
    holds fewer than two samples, when `before` lies past the last sample by more than a sample
    interval (the mean would cover a shorter stretch than the one asked for: a run stopped
    early), or when a key has fewer than `finite_needed` finite values there (NaN: a wall that
    carries no normal force has no friction ratio)."""
    series = run_data["series"]
    time = np.asarray(series["time"], dtype=float)
    chosen = (time > after) & (time <= before)
    count = int(chosen.sum())
    window = f"after t = {after:g}" + ("" if np.isinf(before) else f" up to t = {before:g}")
    if np.isfinite(before) and time.size > 1 and \
            before > time[-1] + _sample_interval(time) * (1 + 1e-9):
        raise SeriesError(f"the samples end at t = {time[-1]:g}, before t = {before:g}: a mean "
                          f"{window} would cover a shorter stretch (a run stopped early: resume "
                          f"it, or give --before {time[-1]:g})")
    if count == 0:
        raise SeriesError(f"no sample {window} (samples from t = {time.min():g} to {time.max():g})"
                          if time.size else "the run has no samples")
    if count == 1:   # a mean without an error bar would be printed as "+- nan"
        raise SeriesError(f"one sample {window}: a mean's error needs at least two "
                          f"(samples from t = {time.min():g} to {time.max():g})")
    out = {}
    for key in keys:
        if key not in series:
            raise SeriesError(f"no series '{key}' (have: {', '.join(sorted(series))})")
        values = np.asarray(series[key], dtype=float)[chosen]
        b = block_average(values)   # its mean, error and count leave out non-finite samples
        if int(b["n"]) < finite_needed:
            raise SeriesError(f"{key}: {int(b['n'])} finite of its {count} samples {window} (the "
                              f"others are NaN or infinite): a mean's error needs at least two")
        out[key] = (float(b["mean"]), float(b["err"]), int(b["n"]), b["block_size"], b["converged"])
    return out


def format_series_means(means):
    return "\n".join(
        f"{key:<16} {mean:.6g} +- {error:.2g} ({count} samples; error by blocks of {block}"
        + ("" if converged else ", no plateau: a lower bound") + ")"
        for key, (mean, error, count, block, converged) in means.items())


PAIRED_KEYS = ("sweeps_mean", "force_carrying", "capped_steps", "solid_fraction", "bottom_mu",
               "top_mu")


def paired_differences(check_dir, keys=PAIRED_KEYS, load=None):
    """The pairs of a scripts/paired_check.sh folder: every subfolder with a/ and b/ both done
    (paired_check.done), each side resumed from one checkpoint at the time in
    paired_check.start. Per pair and key, the difference b - a of the series' means after that
    time; over the pairs, {key: (mean of a's means, mean difference, its standard error from the
    pairs' scatter, std(ddof 1) / sqrt(k), NaN for one pair)}, the pair count and notes [text]
    (pairs left out, pairs whose sides ran one flow). Raises SeriesError when no pair is done,
    when a pair's b/ is its a/ (a link, or a copy made as a/ was), when two pairs hold one run
    (a run given twice, a pair copied or linked), when the pairs' sides were made with other
    executables or settings (paired_check.side), when a pair's sides end at other times, or
    when the pairs ran for other durations."""
    if load is None:
        from .rundata import load_run as load
    diffs, bases, pairs = {key: [] for key in keys}, {key: [] for key in keys}, 0
    if not os.path.isdir(check_dir):
        raise SeriesError(f"{check_dir}: " + ("not a folder" if os.path.lexists(check_dir)
                                              else "no such folder"))
    names = sorted(os.listdir(check_dir))
    notes, a_sides, made_with, same_flow, spans = [], DistinctRuns(), ({}, {}), [], {}
    for name in names:
        pair = os.path.join(check_dir, name)
        sides = [os.path.join(pair, side) for side in ("a", "b")]
        done = [os.path.exists(os.path.join(d, "paired_check.done")) for d in sides]
        if not all(done):
            if os.path.isdir(pair) and any(os.path.lexists(d) for d in sides):
                undone = "neither side done" if not any(done) else \
                    ("b/ not done" if done[0] else "a/ not done")
                notes.append(f"left out: {pair}: {undone} (paired_check.sh stopped before it; "
                             "run it again to finish)")
            continue
        if os.path.realpath(sides[0]) == os.path.realpath(sides[1]):
            raise SeriesError(f"{pair}: b/ is a/ (a link): a side compared with itself")
        texts = [_read_side(d) for d in sides]
        if texts[0] is not None and texts[0] == texts[1]:
            raise SeriesError(f"{pair}: b/ was made as a/ was ({texts[0]!r} in both "
                              "paired_check.side): a copy of a/, not a second side")
        for k, text in enumerate(texts):
            if text is not None:
                made_with[k].setdefault(text, pair)
        if why := a_sides.add(sides[0]):   # before its run.h5 files are read
            raise SeriesError(f"{check_dir}: two pairs hold one run's sides: {why}")
        start = _read_start(os.path.join(sides[0], "paired_check.start"))
        b_start_file = os.path.join(sides[1], "paired_check.start")
        if os.path.lexists(b_start_file) and (b_start := _read_start(b_start_file)) != start:
            raise SeriesError(f"{pair}: b/ started at t = {b_start:g}, a/ at t = {start:g}: "
                              "not resumed from one checkpoint")
        try:
            runs = [load(d) for d in sides]
            for run in runs:   # named before the history is compared
                missing = [k for k in ("time",) + tuple(keys) if k not in run["series"]]
                if missing:
                    raise SeriesError(f"no series '{missing[0]}' (have: "
                                      f"{', '.join(sorted(run['series']))})")
            if problem := _history_difference(runs, start, keys):
                raise SeriesError(f"{problem}: not resumed from one checkpoint")
            end = _common_end(runs)
            # a key without finite values there gives NaN, named in the table
            a, b = (series_means(run, start, keys, finite_needed=0) for run in runs)
        except SeriesError as e:
            raise SeriesError(f"{pair}: {e.problem}") from None
        spans.setdefault(round(end - start, 9), pair)
        if (state := end_state(sides[0])) is not None and state == end_state(sides[1]):
            same_flow.append(name)
        for key in keys:
            diffs[key].append(b[key][0] - a[key][0])
            bases[key].append(a[key][0])
        pairs += 1
    if pairs == 0:
        raise SeriesError(f"{check_dir}: no pair with both sides done (a/ and b/)")
    for k, side in enumerate("ab"):
        if len(made_with[k]) > 1:
            (text_1, pair_1), (text_2, pair_2) = list(made_with[k].items())[:2]
            raise SeriesError(f"{check_dir}: the pairs' {side}/ sides were made otherwise "
                              f"({pair_1}: {text_1!r}, {pair_2}: {text_2!r} in "
                              "paired_check.side): pooled, they would mix two comparisons")
    if len(spans) > 1:
        (span_1, pair_1), (span_2, pair_2) = list(spans.items())[:2]
        raise SeriesError(f"{check_dir}: the pairs ran for other durations ({pair_1}: {span_1:g} "
                          f"t, {pair_2}: {span_2:g} t after the checkpoint): pooled, their "
                          "differences would be over other windows")
    if same_flow:
        notes.append(f"{len(same_flow)} of the {pairs} pairs ended in one state on both sides "
                     f"({', '.join(same_flow)}): the two sides computed one flow there, a "
                     "difference of zero")
    out = {}
    for key in keys:
        d = np.asarray(diffs[key])
        err = float(np.std(d, ddof=1) / math.sqrt(pairs)) if pairs > 1 else math.nan
        out[key] = (float(np.mean(bases[key])), float(np.mean(d)), err)
    return out, pairs, notes


def _sample_interval(time):
    """The series' time between two samples (the median step; 0 for fewer than two samples)."""
    return float(np.median(np.diff(time))) if len(time) > 1 else 0.0


def _read_side(side_dir):
    """The text of a side's paired_check.side (the executable and settings it was made with),
    or None where there is none to read."""
    try:
        with open_regular(os.path.join(side_dir, "paired_check.side"), encoding="utf-8") as f:
            return f.read().strip()
    except (OSError, ValueError):
        return None


def _common_end(runs):
    """The time both sides' series reach: their last samples must agree (to a thousandth of a
    sample interval), else the sides ran for other durations (a side kept from a check with
    another DURATION) and their means would cover other windows. SeriesError if not."""
    ends = []
    for run in runs:
        time = np.asarray(run["series"]["time"], dtype=float)
        if not time.size:
            raise SeriesError("a side has no samples")
        ends.append((float(time[-1]), _sample_interval(time)))
    (end_a, step_a), (end_b, _) = ends
    if abs(end_a - end_b) > max(1e-3 * step_a, 1e-12 * abs(end_a)):
        raise SeriesError(f"a/ ends at t = {end_a:g}, b/ at t = {end_b:g}: sides of other "
                          "durations (a side kept from a check with another DURATION); give "
                          "paired_check.sh a new OUT_DIR")
    return end_a


def _read_start(start_file):
    """The time in a side's paired_check.start."""
    try:
        with open_regular(start_file, encoding="utf-8") as f:
            text = f.read().strip()
    except (OSError, ValueError) as e:
        raise SeriesError(f"{start_file}: cannot read: {e}") from None
    try:
        start = float(text)
    except ValueError:
        start = math.nan
    if not math.isfinite(start) or start <= 0:
        raise SeriesError(f"{start_file}: {text!r} is not a time > 0 (a checkpoint's, which both "
                          "sides resume)")
    return start


def _history_difference(runs, start, keys):
    """How the two sides' series differ up to the start, or None. Both sides resume one copied
    checkpoint, so what run.h5 holds up to that time is the original run's, sample for sample;
    sides that differ there are two runs' (another seed, velocity or system), and their
    difference would be the cases', not the executables' or settings'. Their cases must agree
    too (the seed and the identity keys but the duration), and the history must hold a sample."""
    for table, key, a, b in identity_pairs(*(run.get("case") or {} for run in runs)):
        if a != b:
            return f"a/ and b/ are other cases ({table}.{key} {a!r} and {b!r})"
    kept = []
    for run in runs:
        time = np.asarray(run["series"]["time"], dtype=float)
        kept.append((time <= start, time))
    (chosen_a, time_a), (chosen_b, time_b) = kept
    if not chosen_a.any() or not chosen_b.any():
        return f"no sample up to t = {start:g} to compare the two sides' history with"
    if not np.array_equal(time_a[chosen_a], time_b[chosen_b]):
        return f"a/ and b/ have other sample times up to t = {start:g}"
    for key in keys:
        values = [np.asarray(run["series"][key], dtype=float)[chosen]
                  for run, (chosen, _) in zip(runs, kept)]
        if not np.array_equal(values[0], values[1], equal_nan=True):
            return f"a/ and b/ differ in '{key}' up to t = {start:g}"
    return None


def format_paired_differences(result):
    out, pairs, notes = result
    lines = [f"note: {text}" for text in notes]
    lines.append(f"{pairs} pairs (b - a, each pair from one checkpoint; error from the pairs' "
                 "scatter):" if pairs > 1 else "1 pair (b - a, from one checkpoint; an error "
                 "needs the scatter of two pairs or more):")
    for key, (base, diff, err) in out.items():
        if pairs > 1:
            rel = f" ({100 * diff / base:+.2f}% +- {100 * err / abs(base):.2f}%)" if base else ""
            lines.append(f"{key:<16} a {base:.6g}  b - a {diff:+.4g} +- {err:.2g}{rel}")
        else:
            rel = f" ({100 * diff / base:+.2f}%)" if base else ""
            lines.append(f"{key:<16} a {base:.6g}  b - a {diff:+.4g}{rel}")
    return "\n".join(lines)

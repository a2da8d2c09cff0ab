"""Means of a run's time series after a given time: what a short solver check reads.

`series_means(run_data, after, keys, before)` averages `series/KEY` of run.h5 over the samples
with after < time <= before (docs/run-data.md; `before` defaults to the end), so that runs of
different lengths, or whose analyses chose different averaging windows, compare over one
window. The standard error of the mean comes from block averaging (statistics.block_average,
the analysis' own method), since neighbouring samples are correlated: as if they were
independent it was up to 2.5 times too small on the solver checks of docs/accuracy.md. When the
blocks find no plateau (a short window) the largest error over the levels is given and the
output says so: then it is still a lower bound. It serves
scripts/solver_check.sh (docs/accuracy.md, "checkpoint copies"), which resumes copies of a run's
checkpoint with other solver settings and compares, for example, the force-carrying contacts.
"""
import numpy as np

from .statistics import block_average


class SeriesError(Exception):
    def __init__(self, problem):
        super().__init__(problem)
        self.problem = problem


def series_means(run_data, after, keys, before=float("inf")):
    """{key: (mean, standard error, samples, samples per block, plateau found)} over the samples
    with after < time <= before; the error by block averaging."""
    series = run_data["series"]
    time = np.asarray(series["time"], dtype=float)
    chosen = (time > after) & (time <= before)
    count = int(chosen.sum())
    if count == 0:
        window = f"after t = {after:g}" + ("" if np.isinf(before) else f" up to t = {before:g}")
        raise SeriesError(f"no sample {window} (samples from t = {time.min():g} to {time.max():g})"
                          if time.size else "the run has no samples")
    out = {}
    for key in keys:
        if key not in series:
            raise SeriesError(f"no series '{key}' (have: {', '.join(sorted(series))})")
        values = np.asarray(series[key], dtype=float)[chosen]
        b = block_average(values)   # its mean, error and count leave out non-finite samples
        out[key] = (float(b["mean"]), float(b["err"]), int(b["n"]), b["block_size"], b["converged"])
    return out


def format_series_means(means):
    return "\n".join(
        f"{key:<16} {mean:.6g} +- {error:.2g} ({count} samples; error by blocks of {block}"
        + ("" if converged else ", no plateau: a lower bound") + ")"
        for key, (mean, error, count, block, converged) in means.items())

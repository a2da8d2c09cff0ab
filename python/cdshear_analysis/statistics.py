"""Error bars for correlated data: block averaging and means over windows.

Uncertainty everywhere is the standard error of the mean.

- `block_average(x)`: Flyvbjerg & Petersen (J. Chem. Phys. 91, 461, 1989) blocking of a
  time series sampled at equal intervals. Level k averages pairs of level k-1, so blocks hold
  B = 2^k samples; the naive standard error sqrt(var_k / (n_k - 1)) grows with k and reaches a
  plateau once blocks are longer than the correlation time. The plateau level is the first k
  with B^3 > 2 N (err_k / err_0)^4 (Lee, Kent, Needs, Rios, Phys. Rev. B 84, 245117, 2011,
  the rule of pyblock). If no level with at least `BLOCKING_MIN_BLOCKS` blocks meets it, the
  largest error over those levels is taken and `converged` is False.
- `ratio_of_means(num, den)`: mean(num) / mean(den) of two series sampled together (the ratio
  of two time averages), its error by the delta method: the blocked standard error of the
  mean of num - r den, divided by mean(den).
- `window_mean(values)`: mean over averaging windows (axis 0) and standard error
  std(ddof=1) / sqrt(n) over the finite entries; NaN error with fewer than 2.
- `weighted_mean(values, errs)`: the inverse-variance weighted mean of independent estimates
  (the seeds or realizations of one setting), with its propagated error and the error from
  their scatter about it; the callers (fitting.combine, study.combine) take the larger.
- `time_weighted_mean(values, errs, times)`: the same for time averages of one flow, weighted
  by the time each covers instead of by its error bar (study.combine and fitting.combine, when
  the runs say what time they cover).
"""
import math
import warnings

import numpy as np

BLOCKING_MIN_BLOCKS = 8  # fewest blocks whose error estimate is trusted


def block_average(x):
    """Mean, standard error, std and statistical inefficiency of a correlated series.

    Returns a dict: mean, err, std, n (finite samples), n_independent = (std / err)^2,
    block_size (samples per block at the chosen level), converged (plateau found).
    Non-finite samples are dropped.
    """
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    n = len(x)
    out = dict(mean=float(x.mean()) if n else np.nan, err=np.nan, std=np.nan, n=n,
               n_independent=np.nan, block_size=1, converged=False)
    if n < 2:
        return out
    out["std"] = float(x.std(ddof=1))
    errors, sizes, y = [], [], x
    while len(y) >= BLOCKING_MIN_BLOCKS:
        errors.append(np.sqrt(y.var() / (len(y) - 1)))
        sizes.append(n // len(y))
        m = len(y) // 2 * 2
        y = 0.5 * (y[0:m:2] + y[1:m:2])
    if not errors:  # too short to block: naive error
        errors, sizes = [np.sqrt(x.var() / (n - 1))], [1]
    errors = np.array(errors)
    level = None
    if errors[0] > 0:
        for k, (b, e) in enumerate(zip(sizes, errors)):
            if float(b) ** 3 > 2.0 * n * (e / errors[0]) ** 4:
                level = k
                break
    out["converged"] = level is not None
    if level is None:
        level = int(np.argmax(errors))
    out["err"] = float(errors[level])
    out["block_size"] = int(sizes[level])
    if out["err"] > 0:
        out["n_independent"] = float((out["std"] / out["err"]) ** 2)
    return out


def ratio_of_means(num, den):
    """r = mean(num) / mean(den) of two series sampled at the same times, and its standard
    error: num - r den has mean 0 and, to first order in the fluctuations of the two means,
    r's error is that of its mean (block_average, so correlations count) over |mean(den)|.
    Samples where either series is not finite are dropped. Returns {"mean", "err"}, as
    mean_err; both NaN without samples or with mean(den) = 0."""
    num, den = np.asarray(num, dtype=float), np.asarray(den, dtype=float)
    keep = np.isfinite(num) & np.isfinite(den)
    num, den = num[keep], den[keep]
    if len(num) == 0 or den.mean() == 0:
        return mean_err(np.nan, np.nan)
    r = float(num.mean() / den.mean())
    return mean_err(r, float(block_average(num - r * den)["err"] / abs(den.mean())))


def window_mean(values):
    """Mean and standard error over axis 0 (windows), ignoring NaN. Returns (mean, err) arrays
    (or floats for 1D input); err is NaN where fewer than 2 finite windows."""
    v = np.asarray(values, dtype=float)
    count = np.sum(np.isfinite(v), axis=0)
    with warnings.catch_warnings(), np.errstate(invalid="ignore", divide="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)
        mean = np.nanmean(v, axis=0) if v.shape[0] else np.full(v.shape[1:], np.nan)
        std = np.nanstd(v, axis=0, ddof=1) if v.shape[0] > 1 else np.full(v.shape[1:], np.nan)
        err = np.where(count >= 2, std / np.sqrt(np.maximum(count, 1)), np.nan)
    if np.ndim(mean) == 0:
        return float(mean), float(err)
    return mean, err


def mean_err(mean, err):
    """The {"mean": x, "err": e} pair used throughout summary.json."""
    return {"mean": mean, "err": err}


def _weighted_mean_and_scatter(values, weights):
    """(mean, sum of weights, err_scatter) of values with weights > 0: mean = sum(w y) / sum(w),
    err_scatter = sqrt(sum(w (y - mean)^2) / ((k - 1) sum w)), the standard error of that mean
    from the values' scatter about it when each value's variance is proportional to 1 / w
    (std(ddof=1) / sqrt(k) for equal weights; NaN for k < 2). The shared core of weighted_mean
    and time_weighted_mean."""
    total = sum(weights)
    mean = sum(w * y for w, y in zip(weights, values)) / total
    k = len(values)
    if k < 2:
        return mean, total, math.nan
    scatter = math.sqrt(sum(w * (y - mean) ** 2 for w, y in zip(weights, values))
                        / ((k - 1) * total))
    return mean, total, scatter


def weighted_mean(values, errs):
    """Inverse-variance weighted mean of independent estimates values[i] +- errs[i] (finite,
    errs > 0). Returns (mean, err_propagated, err_scatter): weights w = 1 / err^2, mean =
    sum(w y) / sum(w), err_propagated = 1 / sqrt(sum w) (right when the error bars are), and
    err_scatter = sqrt(sum(w (y - mean)^2) / ((k - 1) sum w)), the standard error of the weighted
    mean from the estimates' scatter about it (std(ddof=1) / sqrt(k) for equal errors; NaN for
    k < 2, and only a rough figure for k = 2 or 3: one or two degrees of freedom)."""
    ys = [float(y) for y in values]
    if not ys:
        return math.nan, math.nan, math.nan
    weights = [1.0 / float(e) ** 2 for e in errs]
    mean, total, scatter = _weighted_mean_and_scatter(ys, weights)
    return mean, 1.0 / math.sqrt(total), scatter


def time_weighted_mean(values, errs, times):
    """Mean of independent time averages values[i] +- errs[i] over lengths times[i] (> 0),
    weighted by length: w = t / sum t, mean = sum(w y). The variance of a time average is
    c / t for one flow (c: twice the integrated autocorrelation of the quantity), so these are
    the weights of least variance, known without the estimates' errors. Returns (mean,
    err_propagated, err_scatter): err_propagated = sqrt(sum(w^2 err^2)) from the estimates' own
    errors, and err_scatter = sqrt(sum(t (y - mean)^2) / ((k - 1) sum t)), the error of the
    mean with c estimated from the scatter (std(ddof=1) / sqrt(k) for equal lengths; NaN for
    k < 2)."""
    ys = [float(y) for y in values]
    if not ys:
        return math.nan, math.nan, math.nan
    ts = [float(t) for t in times]
    mean, total, scatter = _weighted_mean_and_scatter(ys, ts)
    propagated = math.sqrt(sum((t / total) ** 2 * float(e) ** 2 for e, t in zip(errs, ts)))
    return mean, propagated, scatter

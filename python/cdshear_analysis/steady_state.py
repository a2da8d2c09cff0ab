"""Where the transient ends: MSER truncation of several signals, and the steady-state verdict.

MSER, the marginal standard error rule (White, Simulation 69, 323, 1997), applied to batch
means z_1..z_k of a signal: truncate the first d batches where d minimises
    MSER(d) = sum_{i>d} (z_i - mean_{i>d} z)^2 / (k - d)^2,
the squared standard error of the remaining mean, d searched over 0..floor(k/2) (beyond half
MSER is unreliable). A series is cut into batches of b samples, b = the statistical
inefficiency N err^2 / std^2 (about twice the correlation time, in samples) of its second half,
from block averaging, and at least MSER_MIN_BATCH; a per-window signal uses the windows as
batches.

Signals (see summary.py): the wall friction mu_wall = (|bottom_fx|+|top_fx|)/(|bottom_fy|+|top_fy|),
the height L_y and the block's speed |block_vx| (the centre-of-mass statistics) from /series,
and, with >= MSER_MIN_WINDOWS windows, the bulk mu_eff, bulk solid fraction and bulk shear rate
(the velocity profile) of each window. The block's speed takes part only when its level
changes by more than regime.BLOCK_SPEED_TOLERANCE V (batch means further apart than that): below
it no regime criterion can tell the difference. The transient ends at the latest truncation
time. The run is steady unless
  - a signal with >= MSER_MIN_BATCHES batches has its MSER minimum at the search limit (half
    of the data): the transient may last longer than half the run;
  - fewer than STEADY_MIN_WINDOWS complete windows start after the transient;
  - a series holds fewer than STEADY_MIN_INDEPENDENT independent samples (std/err)^2 after it;
  - a series still drifts after it: the means of the two halves of what remains differ by more
    than STEADY_MAX_DRIFT combined standard errors, 2 err with err the block-averaging error of
    the whole remaining mean (MSER misses slow drifts);
  - the stress is not uniform (`balance`: the interior mu_eff minus the walls' friction, window
    by window, over the steady windows, with its error): in steady shear the momentum balance
    makes the interior friction equal the walls', while momentum still diffuses across the cell
    it does not. With at least BALANCE_MIN_WINDOWS steady windows, the difference must be
    within STEADY_MAX_IMBALANCE standard errors of zero or within IMBALANCE_FLOOR (a floor for
    the grain-scale scatter of stripe stresses and the correlation of windows, which long runs
    would otherwise turn into a verdict). With fewer windows it is not checked,
    and the reason says so.
When not steady, averages are taken over the last half of the run (flagged): series samples
at t >= t_end / 2, windows starting there (or the last window if none does).
"""
import numpy as np

from .statistics import block_average, window_mean

MSER_MIN_BATCH = 5            # samples per batch at least (MSER-5)
MSER_MAX_TRUNCATION = 0.5     # MSER searches truncations up to this fraction of the batches
MSER_MIN_BATCHES = 20         # fewest batches for the "minimum at the search limit" verdict
MSER_MIN_WINDOWS = 10         # per-window signals take part only with this many windows
STEADY_MIN_WINDOWS = 2        # complete windows needed after the transient
STEADY_MIN_INDEPENDENT = 20   # independent samples needed after the transient, per series
STEADY_MAX_DRIFT = 5.0        # largest difference of the two halves' means, in standard errors
BALANCE_MIN_WINDOWS = 3       # steady windows needed to judge the stress balance
STEADY_MAX_IMBALANCE = 3.0    # largest interior-minus-wall friction, in standard errors ...
IMBALANCE_FLOOR = 0.005       # ... and in friction: smaller offsets (2% of mu) never count


def mser_truncation(z):
    """(d, at_limit): d in 0..floor(k/2) minimising MSER over z[d:]; at_limit when the minimum
    sits on the search limit with at least MSER_MIN_BATCHES batches (still drifting)."""
    z = np.asarray(z, dtype=float)
    k = len(z)
    limit = int(k * MSER_MAX_TRUNCATION)
    if limit < 1:
        return 0, False
    tail_sum = np.cumsum(z[::-1])[::-1][: limit + 1]
    tail_sq = np.cumsum((z * z)[::-1])[::-1][: limit + 1]
    m = k - np.arange(limit + 1, dtype=float)          # entries left after truncating d
    mser = np.maximum(tail_sq - tail_sum ** 2 / m, 0.0) / m ** 2
    d = int(np.argmin(mser))
    return d, d == limit and k >= MSER_MIN_BATCHES


def series_batches(time, x):
    """(times, means): the finite samples of a series cut into batches of b samples, b its
    statistical inefficiency over its second half (at least MSER_MIN_BATCH); each batch's first
    time and mean. Empty arrays without finite samples."""
    ok = np.isfinite(x)
    time, x = np.asarray(time)[ok], np.asarray(x, dtype=float)[ok]
    if len(x) == 0:
        return np.zeros(0), np.zeros(0)
    tail = block_average(x[len(x) // 2:])
    inefficiency = (tail["n"] / tail["n_independent"]) if tail["n_independent"] > 0 else 1.0
    b = max(MSER_MIN_BATCH, int(np.ceil(inefficiency)))
    k = len(x) // b
    return time[: k * b: b], x[: k * b].reshape(k, b).mean(axis=1)


def batch_truncation(times, means):
    """MSER on a series' batches (series_batches): (truncation time, at_limit)."""
    if len(means) == 0:
        return np.nan, False
    d, at_limit = mser_truncation(means)
    return float(times[d]), at_limit


def stress_balance(balance, windows):
    """(mean, standard error, z) over the windows of balance(windows), one value per window;
    NaNs with fewer than BALANCE_MIN_WINDOWS finite values."""
    values = np.asarray(balance(windows), dtype=float) if len(windows) else np.zeros(0)
    values = values[np.isfinite(values)]
    if len(values) < BALANCE_MIN_WINDOWS:
        return np.nan, np.nan, np.nan
    mean, err = window_mean(values)
    if not (np.isfinite(mean) and np.isfinite(err)):
        return np.nan, np.nan, np.nan
    return mean, err, (abs(mean) / err if err > 0 else (0.0 if mean == 0 else np.inf))


def detect_steady_state(time, series, window_start, window_signals, balance=None,
                        stationarity_only=(), tolerances=None):
    """Steady-state verdict for one run.

    time: series sample times; series: {name: samples}; window_start: window start times;
    window_signals: {name: one value per window}; balance: balance(windows) -> the interior mu_eff
    minus the walls' friction in each of those windows (NaN where not known; None: not checked);
    stationarity_only: series that must not drift but need not hold STEADY_MIN_INDEPENDENT
    independent samples (a slowly correlated signal whose mean is not reported, such as the
    block's speed); tolerances: {name: size} for series whose changes matter
    only from that size on: a series whose batch means all lie within it takes no part in the
    transient's end nor in the drift test (its truncation time is NaN). Returns a dict with steady
    (bool), reason, transient_end_time (NaN if unknown), averaging_start_time, windows (indices
    averaged), truncation_times {name: t}, independent_samples {name: n}, drift_sigmas {name: z} and
    stress_balance {mean, err, sigmas} over the steady windows (NaN if not checked).
    """
    time = np.asarray(time, dtype=float)
    window_start = np.asarray(window_start, dtype=float)
    t_end = float(time[-1])
    truncation, problems = {}, []
    tolerances = tolerances or {}
    level = set()   # series whose batch means all lie within their tolerance of each other
    for name, x in series.items():
        times, means = series_batches(time, x)
        if name in tolerances and len(means) and float(np.ptp(means)) <= tolerances[name]:
            level.add(name)
            truncation[name] = np.nan
            continue
        truncation[name], at_limit = batch_truncation(times, means)
        if at_limit:
            problems.append(f"{name} still drifting (MSER truncation at t = "
                            f"{truncation[name]:.4g}, the limit of its search: half the data)")
    if len(window_start) >= MSER_MIN_WINDOWS:
        for name, x in window_signals.items():
            x = np.asarray(x, dtype=float)
            ok = np.flatnonzero(np.isfinite(x))
            if len(ok) < MSER_MIN_WINDOWS:
                continue
            d, at_limit = mser_truncation(x[ok])
            truncation[name] = float(window_start[ok[d]])
            if at_limit:
                problems.append(f"{name} still drifting (MSER truncation at window {ok[d]} of "
                                f"{len(window_start)}, the limit of its search)")
    cuts = [t for t in truncation.values() if np.isfinite(t)]
    transient_end = max(cuts) if cuts else np.nan
    steady_windows = np.flatnonzero(window_start >= transient_end - 1e-9)
    after = time >= (transient_end if np.isfinite(transient_end) else 0.5 * t_end)
    independent, drift = {}, {}
    for name, x in series.items():
        x = np.asarray(x, dtype=float)[after]
        whole = block_average(x)
        independent[name] = whole["n_independent"]
        half = len(x) // 2     # each half's mean has an error of about sqrt(2) * whole error
        drift[name] = (abs(np.mean(x[:half]) - np.mean(x[half:])) / (2 * whole["err"])
                       if half else np.nan)
    if not problems:
        if len(steady_windows) < STEADY_MIN_WINDOWS:
            problems.append(f"only {len(steady_windows)} complete window(s) after the transient "
                            f"(t = {transient_end:.4g}), need {STEADY_MIN_WINDOWS}")
        for name, n_ind in independent.items():
            if name not in stationarity_only and not n_ind >= STEADY_MIN_INDEPENDENT:
                problems.append(f"only {n_ind:.3g} independent samples of {name} after the "
                                f"transient, need {STEADY_MIN_INDEPENDENT}")
        for name, z in drift.items():
            if name not in level and z > STEADY_MAX_DRIFT:
                problems.append(f"{name} still drifting (the two halves after t = "
                                f"{transient_end:.4g} differ by {z:.2g} standard errors)")
    imbalance = (stress_balance(balance, steady_windows)
                 if balance is not None and np.isfinite(transient_end)
                 else (np.nan, np.nan, np.nan))
    if not problems and imbalance[2] > STEADY_MAX_IMBALANCE \
            and abs(imbalance[0]) > IMBALANCE_FLOOR:
        problems.append(f"stress not uniform: the interior mu_eff differs from the walls' by "
                        f"{imbalance[0]:+.3g} ± {imbalance[1]:.2g} ({imbalance[2]:.2g} standard "
                        f"errors) over the windows after t = {transient_end:.4g}: momentum is "
                        f"still spreading across the cell")
    steady = not problems
    if steady:
        start, windows = transient_end, steady_windows
    else:
        start = 0.5 * t_end
        windows = np.flatnonzero(window_start >= start - 1e-9)
        if len(windows) == 0 and len(window_start):
            windows = np.array([len(window_start) - 1])
    reason = ("transient over at t = %.4g; %d steady windows" % (transient_end, len(windows))
              if steady else "; ".join(problems))
    if steady and balance is not None and not np.isfinite(imbalance[0]):
        reason += (f"; stress balance not checked (fewer than {BALANCE_MIN_WINDOWS} steady "
                   f"windows with a bulk mu_eff and a wall normal force)")
    return dict(steady=steady, reason=reason, transient_end_time=transient_end,
                averaging_start_time=float(start), windows=windows,
                truncation_times=truncation, independent_samples=independent,
                drift_sigmas=drift,
                stress_balance=dict(mean=imbalance[0], err=imbalance[1], sigmas=imbalance[2]))

"""Weighted least-squares fits of the laws of docs/model.md section 8, shared by the bulk and the
boundary laws.

A law (LAWS) is a model y(x; parameters) with its starting points and bounds; `fit(law, points)`
fits it to points (x, y, err, label[, group[, averaged_time]]) with scipy.optimize.curve_fit
weighted by the error bars (sigma = the standard error of y, absolute_sigma=True; the error of x
is not used). Points without a finite positive error are left out (counted in
`points_without_error`); the points of one group (the seeds of a (system, V), `group_key`) are
combined into one first (`combine`: the mean weighted by the time each seed's averages cover,
or by 1/err^2 where a seed does not say it, its error at least that of the seeds' scatter about
it); a fit with fewer points than parameters + 1 is skipped with its reason. Several starting
points are tried and the smallest chi2 kept, so a power law is found whether its exponent is
below or above 1.

Every fit has a status (`STATUSES`, rules in `assess`) and a `reason` that names the numbers:
  "ok"            the parameters are determined and the points agree with the law within
                  their error bars;
  "poor"          the parameters are determined but the points scatter far more than their
                  error bars: the chi2 tail probability P(chi2 >= observed | dof) is below
                  P_POOR (the form does not describe the points, or their error bars are too
                  small; err_scaled is the honest error then);
  "undetermined"  the points do not constrain the form: a parameter's error (err_scaled) is
                  larger than its value's magnitude, the covariance is infinite or NaN, or a
                  parameter ends on a bound of its range (an exponent at 0.001 or 10);
  "skipped"       not fitted: too few points, fewer distinct x than parameters, no convergence.
Curves are drawn for every fitted law (`fitted`); predictions take the laws whose parameters are
determined, "ok" and "poor" (`usable`; a poor law's draws with its covariance scaled by
chi2/dof, `parameter_samples`).

The result is a dict with the keys of fits.json (docs/reports.md): law, x, y,
range, status, reason, n_points (after combining), points_without_error, runs (every run of the
points), n_runs, combined (the points made of 2+ runs), x_span, parameters ({name: {value, err,
err_scaled}}), covariance (rows and columns in the order of parameters), chi2, dof, chi2_dof,
chi2_p (the chi2 tail probability), note (a parameter at the bound of its range, e.g. an
exponent at 0.001: the points do not follow the form). err_scaled multiplies err by
sqrt(chi2/dof) when that exceeds 1 (the scatter is larger than the error bars say).
"""
import math
import warnings
from collections import Counter

import numpy as np

from .statistics import time_weighted_mean, weighted_mean


def finite(x):
    """float(x) if it is a finite number, else None."""
    try:
        x = float(x)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an int beyond any float
        return None
    return x if math.isfinite(x) else None


def power_plus(x, y0, a, b):
    return y0 + a * np.power(x, b)


def power_minus(x, y0, c, e):
    return y0 - c * np.power(x, e)


def log_plus(x, y1, b):
    """y1 + b ln x: the limit of y0 + A x^B as B -> 0 with A B = b and y0 + A = y1 (x^B = 1 + B
    ln x + O(B^2)), the form a power law takes when its points fix only its slope in ln x."""
    return y1 + b * np.log(x)


def linear_plus(x, y0, a):
    return y0 + a * x


def linear_minus(x, y0, c):
    return y0 - c * x


def p0_power(x, y, sign):
    """Starting points (y0, amplitude, exponent) of y0 + sign * amplitude * x^exponent: y0 just
    beyond the smallest (sign +1) or largest (-1) y, the amplitude spanning the data."""
    y0 = float(np.min(y) if sign > 0 else np.max(y))
    spread = float(np.ptp(y)) or 0.1
    return [(y0 - sign * 0.1 * spread, spread / max(float(np.max(x)), 1e-12) ** e, e)
            for e in (0.5, 1.0, 2.0)]


def p0_log(x, y):
    """(value at x = 1, slope in ln x) of the straight line through (ln x, y)."""
    lx = np.log(x)
    slope, icpt = np.polyfit(lx, y, 1) if len(np.unique(x)) > 1 else (0.0, float(np.mean(y)))
    return [(float(icpt), float(slope))]


def p0_linear(x, y, sign):
    """(intercept, sign * slope) of the straight line through the points."""
    slope, icpt = np.polyfit(x, y, 1) if len(np.unique(x)) > 1 else (0.0, float(np.mean(y)))
    return [(float(icpt), sign * float(slope))]


EXPONENT_BOUNDS = ([-np.inf, -np.inf, 1e-3], [np.inf, np.inf, 10.0])

STATUSES = ("ok", "poor", "undetermined", "skipped")
FITTED = ("ok", "poor", "undetermined")   # fitted: parameters and a curve
USABLE = ("ok", "poor")                   # parameters determined: predictions take these
# A fit is "poor" when its chi2 tail probability is below P_POOR. With error bars that are
# right and a law that describes the points, chi2 follows the chi2 law with dof degrees of
# freedom, so a correct fit is called poor once in 1000: the threshold adapts to dof, unlike a
# fixed chi2/dof (chi2/dof > 3 happens by chance in 5% of fits with 2 dof, while 1.8 is already
# far off with 50 dof; the threshold is chi2/dof = 6.9 with 2 dof, 3.0 with 10, 1.73 with 50).
# The runs' error bars are themselves estimates (they scatter by 14 to 20% between seeds,
# docs/accuracy.md): error bars 20% too small (chi2/dof 1.56 on average) make a correct fit
# poor in 4% of fits with 10 dof; poor means far more scatter than that.
P_POOR = 1e-3

# The model families: formula (with X and Y for the variables), model, parameter names,
# starting points, bounds
MODELS = {
    "power_plus": dict(formula="Y = {0} + {1} * X^{2}", model=power_plus,
                       p0=lambda x, y: p0_power(x, y, +1), bounds=EXPONENT_BOUNDS),
    "power_minus": dict(formula="Y = {0} - {1} * X^{2}", model=power_minus,
                        p0=lambda x, y: p0_power(x, y, -1), bounds=EXPONENT_BOUNDS),
    "log_plus": dict(formula="Y = {0} + {1} * ln X", model=log_plus, p0=p0_log,
                     bounds=(-np.inf, np.inf)),
    "linear_plus": dict(formula="Y = {0} + {1} * X", model=linear_plus,
                        p0=lambda x, y: p0_linear(x, y, +1), bounds=(-np.inf, np.inf)),
    "linear_minus": dict(formula="Y = {0} - {1} * X", model=linear_minus,
                         p0=lambda x, y: p0_linear(x, y, -1), bounds=(-np.inf, np.inf)),
}


def law(model, params, y, x, x_range=None, regimes=None):
    """A law: model family, parameter names, the names of y and x, an optional open x range,
    and the regimes whose runs it is fitted to (None: every steady run)."""
    text = MODELS[model]["formula"].format(*params).replace("Y", y).replace(
        "X", f"({x})" if " " in x else x)
    if x_range:
        text += f"  ({x_range[0]:g} < {x} < {x_range[1]:g})"
    return {"model": model, "params": list(params), "y": y, "x": x, "range": x_range,
            "regimes": list(regimes) if regimes else None, "law": text}


def group_key(row):
    """The (system, V) of a campaign run, V to 6 significant digits as in its folder name: the
    runs of one key (its seeds) are one point of a fit. None (a run alone) without either."""
    system, V = row.get("system"), finite(row.get("V"))
    return None if system is None or V is None else (system, f"{V:.6g}")


def combine(points):
    """One point per group of seeds: points (x, y, err, label, group, averaged_time) with a
    usable error -> (x, y, err, [labels], detail), in the order of each group's first point. A
    point whose group is None stands alone. The weights are the times the seeds' averages cover
    (averaged_time, statistics.time_weighted_mean: equal weights for seeds of one length), as in
    study.combine and for the same reason: a seed's own error bar is itself an estimate that
    scatters by 14 to 20% between seeds and correlates with its value, so 1/err^2 weights move
    the mean by up to one standard error (docs/accuracy.md, "Effect on the averaged
    quantities"). Where a seed of the group does not say its averaged time (None or not
    positive), the weights are w = 1 / err^2 (statistics.weighted_mean). y and x are the
    weighted means; the error is the propagated one, or with 2 seeds or more the error of the
    weighted mean from the seeds' scatter,
    sqrt(sum w (y - y_w)^2 / ((k - 1) sum w)) (std / sqrt(k) for equal weights), when that is
    larger: the seeds scatter more than their error bars say. detail (None for a point of one
    run): runs, weights ("time" or "error"), x, y, err, err_propagated, err_seeds and the
    seeds' own y, err and averaged time, for fits.json `combined`."""
    groups = {}
    for k, (x, y, e, label, group, averaged) in enumerate(points):
        groups.setdefault(("alone", k) if group is None else ("group", group), []).append(
            (x, y, e, label, averaged))
    out = []
    for members in groups.values():
        if len(members) == 1:
            x, y, e, label, _ = members[0]
            out.append((x, y, e, [label], None))
            continue
        xs, ys, es = ([float(m[i]) for m in members] for i in range(3))
        times = [finite(m[4]) for m in members]
        by_time = all(t is not None and t > 0 for t in times)
        def mean(values):
            return time_weighted_mean(values, es, times) if by_time else weighted_mean(values, es)
        y, e_prop, e_seeds = mean(ys)
        x = mean(xs)[0]   # x with the weights of y
        labels = [m[3] for m in members]
        out.append((x, y, max(e_prop, e_seeds), labels, {
            "runs": labels, "weights": "time" if by_time else "error", "x": x, "y": y,
            "err": max(e_prop, e_seeds), "err_propagated": e_prop, "err_seeds": e_seeds,
            "y_runs": ys, "err_runs": es, "averaged_time_runs": times}))
    return out


def select(points, x_range=None):
    """(points kept, count without a usable error): x > 0, finite y and a finite positive error,
    the seeds of one (system, V) combined (`combine`), then the combined x inside x_range.
    points: iterable of (x, y, err, label), (x, y, err, label, group) or (x, y, err, label, group,
    averaged_time); a point without a usable error is counted when its own x lies inside
    x_range."""
    usable, no_err = [], 0
    for p in points:
        x, y, e = finite(p[0]), finite(p[1]), finite(p[2])
        if x is None or y is None or x <= 0:
            continue
        if e is None or e <= 0:
            if not x_range or x_range[0] < x < x_range[1]:
                no_err += 1
            continue
        usable.append((x, y, e, p[3], p[4] if len(p) > 4 else None,
                       p[5] if len(p) > 5 else None))
    kept = [p for p in combine(usable) if not x_range or x_range[0] < p[0] < x_range[1]]
    return kept, no_err


def fit(spec, points):
    """Fit a law (see `law`) to points (x, y, err, label[, group[, averaged_time]]), group the
    key of the seeds to combine into one point (`group_key`; None or absent: the point stands
    alone, see `select` and `combine`), averaged_time the time its averages cover (its weight
    there); the fits.json dict."""
    from scipy.optimize import OptimizeWarning, curve_fit
    family = MODELS[spec["model"]]
    k = len(spec["params"])
    kept, no_err = select(points, spec["range"])
    out = {"law": spec["law"], "model": spec["model"], "x": spec["x"], "y": spec["y"],
           "range": list(spec["range"]) if spec["range"] else None,
           "regimes": spec.get("regimes"), "status": "skipped", "reason": None,
           "n_points": len(kept), "points_without_error": no_err,
           "runs": [label for p in kept for label in p[3]],
           "n_runs": sum(len(p[3]) for p in kept),
           "combined": [p[4] for p in kept if p[4] is not None],
           "x_span": [min(p[0] for p in kept), max(p[0] for p in kept)] if kept else None,
           "parameters": None,
           "covariance": None, "chi2": None, "dof": None, "chi2_dof": None,
           "chi2_p": None, "note": None}
    if len(kept) < k + 1:
        where = (f" with {spec['range'][0]:g} < {spec['x']} < {spec['range'][1]:g}"
                 if spec["range"] else "")
        runs = (f" (from {out['n_runs']} runs, seeds of a (system, V) combined)"
                if out["n_runs"] > len(kept) else "")
        out["reason"] = (f"too few points: {len(kept)}{where} with {spec['y']} and its error"
                         f"{runs}, {k + 1} needed for {k} parameters")
        return out
    x, y, e = (np.array([p[i] for p in kept]) for i in range(3))
    if len(np.unique(x)) < k:
        # for example every run at the same x: the parameters are not determined
        out["reason"] = (f"covariance not estimable: {len(np.unique(x))} distinct {spec['x']} "
                         f"for {k} parameters")
        return out
    best, last = None, None
    for p0 in family["p0"](x, y):
        try:
            with warnings.catch_warnings():
                # a covariance that cannot be estimated is handled below, not printed
                warnings.simplefilter("ignore", OptimizeWarning)
                p, cov = curve_fit(family["model"], x, y, p0=p0, sigma=e, absolute_sigma=True,
                                   bounds=family["bounds"], maxfev=20000)
        except (RuntimeError, ValueError) as err:
            last = str(err)
            continue
        chi2 = float(np.sum(((y - family["model"](x, *p)) / e) ** 2))
        if best is None or chi2 < best[2]:
            best = (p, cov, chi2)
    if best is None:
        out["reason"] = f"no convergence: {last}"
        return out
    # (a covariance that is infinite or NaN, a parameter on its bound, errors larger than the
    # values: "undetermined", see assess)
    p, cov, chi2 = best
    dof = len(kept) - k
    cov = np.asarray(cov, float)
    finite_cov = bool(np.all(np.isfinite(cov)))
    scale = math.sqrt(max(1.0, chi2 / dof))
    errs = [finite(math.sqrt(c)) if math.isfinite(c) and c >= 0 else None
            for c in np.diag(cov)]
    lo, hi = family["bounds"]
    at_bound = [(pn, float(p[k_]), lo[k_], hi[k_]) for k_, pn in enumerate(spec["params"])
                if np.ndim(lo) and (np.isclose(p[k_], lo[k_]) or np.isclose(p[k_], hi[k_]))]
    if at_bound:
        # e.g. an exponent pushed to 0.001: the points follow another form (a logarithm), and
        # the other parameters then trade off without bound (huge errors)
        out["note"] = (f"{', '.join(b[0] for b in at_bound)} at the bound of its range: the "
                       "points do not follow this form; read the parameters with care")
    parameters = {pn: {"value": float(v), "err": se,
                       "err_scaled": finite(se * scale) if se is not None else None}
                  for pn, v, se in zip(spec["params"], p, errs)}
    status, reason, chi2_p = assess(parameters, finite_cov, at_bound, chi2, dof)
    out.update(status=status, reason=reason, chi2=chi2, dof=dof, chi2_dof=chi2 / dof,
               chi2_p=chi2_p, parameters=parameters,
               covariance=[[finite(c) for c in row] for row in cov])
    return out


def fit_with_offsets(spec, points, system_of, pooled):
    """The law of `pooled` (a fit of `spec` to the same points, status fitted) with one more
    parameter per system but one, an offset added to y: y = law(x) + delta_s. points as for
    `fit`; system_of: {label: system} for every label of the points. The reference (offset 0) is
    the system with the most points (the lowest of those tied). Returns (chi2, dof, offsets
    {system: {value, err}}, the reference) or None where it does not converge or leaves no dof.
    Used by report.system_dependence."""
    from scipy.optimize import OptimizeWarning, curve_fit
    family = MODELS[spec["model"]]
    k = len(spec["params"])
    kept, _ = select(points, spec["range"])
    count = Counter(system_of[p[3][0]] for p in kept)
    systems = sorted(count, key=lambda sy: (-count[sy], str(sy)))
    m = len(systems)
    dof = len(kept) - k - (m - 1)
    if m < 2 or dof <= 0:
        return None
    x, y, e = (np.array([p[i] for p in kept], float) for i in range(3))
    which = np.array([systems.index(system_of[p[3][0]]) for p in kept])

    def model(index, *params):
        index = np.asarray(index, int)
        shift = np.concatenate([[0.0], params[k:]])
        return family["model"](x[index], *params[:k]) + shift[which[index]]

    lo, hi = (np.broadcast_to(b, (k,)) for b in family["bounds"])
    bounds = (np.concatenate([lo, np.full(m - 1, -np.inf)]),
              np.concatenate([hi, np.full(m - 1, np.inf)]))
    p0 = np.concatenate([[v["value"] for v in pooled["parameters"].values()], np.zeros(m - 1)])
    p0 = np.clip(p0, bounds[0], bounds[1])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", OptimizeWarning)
            p, cov = curve_fit(model, np.arange(len(x)), y, p0=p0, sigma=e, absolute_sigma=True,
                               bounds=bounds, maxfev=20000)
    except (RuntimeError, ValueError):
        return None
    chi2 = float(np.sum(((y - model(np.arange(len(x)), *p)) / e) ** 2))
    errs = np.sqrt(np.abs(np.diag(np.asarray(cov, float))))
    offsets = {str(systems[j]): {"value": float(p[k + j - 1]), "err": finite(errs[k + j - 1])}
               for j in range(1, m)}
    return chi2, dof, offsets, str(systems[0])


def _g(v):
    return f"{v:.3g}"


def assess(parameters, finite_cov, at_bound, chi2, dof):
    """(status, reason, chi2_p) of a fitted law (the module's doc): "undetermined" when the
    covariance is not finite, a parameter sits on a bound of its range (at_bound: (name, value,
    low, high)) or a parameter's error (err_scaled) exceeds its value's magnitude; else "poor"
    when P(chi2 >= observed | dof) < P_POOR; else "ok". The reason names the numbers."""
    from scipy.stats import chi2 as chi2_law
    chi2_p = float(chi2_law.sf(chi2, dof))
    chi_text = f"chi2/dof = {_g(chi2 / dof)} with {dof} dof, P(chi2 >= {_g(chi2)}) = {chi2_p:.2g}"
    loose = []
    if not finite_cov:
        loose.append("covariance infinite or NaN")
    for name, value, low, high in at_bound:
        loose.append(f"{name} = {_g(value)} on the bound of its range [{_g(low)}, {_g(high)}]")
    if finite_cov and any(v["err_scaled"] is None for v in parameters.values()):
        loose.append("a parameter without an error (negative variance)")
    wide = [f"{name} = {_g(v['value'])} ± {_g(v['err_scaled'])}"
            for name, v in parameters.items()
            if finite_cov and v["err_scaled"] is not None and v["err_scaled"] > abs(v["value"])]
    if wide:
        loose.append(", ".join(wide) + (" (errors larger than the values)" if len(wide) > 1
                                        else " (error larger than the value)"))
    poor = chi2_p < P_POOR
    if loose:
        reason = "the points do not constrain the form: " + "; ".join(loose)
        if poor:
            reason += f"; also {chi_text} < {P_POOR:g}"
        return "undetermined", reason, chi2_p
    if poor:
        return "poor", (f"{chi_text} < {P_POOR:g}: the points scatter far more than their "
                        "error bars (read err_scaled)"), chi2_p
    return "ok", f"{chi_text}; every parameter's error below its value", chi2_p


def fitted(result):
    """True for a fit with parameters (status ok, poor or undetermined): it has a curve."""
    return bool(result) and result.get("status") in FITTED and bool(result.get("parameters"))


def usable(result):
    """True for a fit whose parameters the points determine (status ok or poor): the ones the
    predictions take."""
    return bool(result) and result.get("status") in USABLE and bool(result.get("parameters"))


def status_text(result):
    """"status: reason" of a fit, for the printed and HTML reports."""
    if not result:
        return "not fitted"
    return f"{result.get('status')}: {result.get('reason')}" if result.get("reason") \
        else str(result.get("status"))


def fit_columns(spec, rows, x=None, y=None):
    """Fit a law to the steady rows (report.read_run) of the law's regimes with the columns x
    and y (default: the law's own), the error of y from the column y + "_err"; the seeds of one
    (system, V) are one point (`combine`)."""
    x, y = x or spec["x"], y or spec["y"]
    spec = dict(law(spec["model"], spec["params"], y, x, spec["range"], spec.get("regimes")))
    return fit(spec, column_points(spec, rows))


def column_points(spec, rows):
    """The points of `fit` for a law from the steady rows of its regimes: (x, y, err, run,
    group_key, averaged_time) with the law's columns x, y and y + "_err"."""
    x, y, regimes = spec["x"], spec["y"], spec.get("regimes")
    return [(r.get(x), r.get(y), r.get(y + "_err"), r["run"], group_key(r),
             r.get("_averaged_time"))
            for r in rows if r.get("steady") is True
            and (not regimes or r.get("regime") in regimes)]


def curve(result, x):
    """A fit's curve at x (None when it was skipped: `fitted`)."""
    if not fitted(result):
        return None
    return MODELS[result["model"]]["model"](
        np.asarray(x, float), *[v["value"] for v in result["parameters"].values()])


def slope(result, x):
    """d y / d x of a fit at x (power or linear family)."""
    p = [v["value"] for v in result["parameters"].values()]
    sign = -1.0 if result["model"].endswith("minus") else 1.0
    if result["model"] == "log_plus":
        return p[1] / x
    if result["model"].startswith("power"):
        return sign * p[1] * p[2] * x ** (p[2] - 1)
    return sign * p[1]


def parameter_samples(result, count, rng, widen=1.0):
    """count parameter vectors drawn from the fit's Gaussian (value, covariance), for
    propagating its uncertainty into a derived quantity; shape (count, k). The covariance of a
    "poor" fit is multiplied by chi2/dof (its error bars are too small for its scatter: the
    err_scaled of each parameter), and by widen (> 1 where the fit counted as independent
    points that are not)."""
    mean = np.array([v["value"] for v in result["parameters"].values()])
    cov = np.array(result["covariance"], float) * widen
    if result.get("status") == "poor" and (result.get("chi2_dof") or 0) > 1:
        cov = cov * result["chi2_dof"]
    return rng.multivariate_normal(mean, cov, size=count, check_valid="ignore")


def solve_for_x(result, target, params=None):
    """The x > 0 at which the fit's y equals target (monotonic families), or None (also where
    that x is beyond the float range, above about 1e304 or below 1e-304). params: a parameter
    vector instead of the fitted values."""
    p = params if params is not None else [v["value"] for v in result["parameters"].values()]
    y0, amp = p[0], p[1]
    sign = -1.0 if result["model"].endswith("minus") else 1.0
    if amp == 0:
        return None
    u = sign * (target - y0) / amp   # = X^exponent (power), ln X (log) or X (linear)
    if result["model"] == "log_plus":
        return float(math.exp(u)) if -700 < u < 700 else None
    if u <= 0:
        return None
    if result["model"].startswith("power"):
        if not p[2] > 0:
            return None
        ln_x = math.log(u) / p[2]   # u ** (1 / p[2]) in logarithms: a small exponent overflows
        return float(math.exp(ln_x)) if -700 < ln_x < 700 else None
    return float(u)

"""How fast the velocity profile reaches its steady shape: the decay time of its distance from
that shape, measured per run, against the time to steady state of model.md section 8.

The prediction (model.md section 8) treats the momentum balance as a diffusion of the shear rate,
D = (d mu_eff / d gamma_dot) sigma_yy / (rho nu), across the height: T_SS = L_y^2 / D. A profile's
distance from the steady one then decays as a sum of modes, the slowest excited one last, as
exp(-t / tau). From the bulk at rest (`shear.initial_velocity = "rest"`) that distance is minus the
steady profile, antisymmetric about the mid-height, and its slowest mode depends on what the walls
impose: walls that hold the grains next to them (velocity fixed) leave sin(2 pi y / L_y), tau =
T_SS / (4 pi^2); walls that slide at a fixed friction (stress fixed) leave cos(pi y / L_y), tau =
T_SS / pi^2. The study's walls slide: a measured tau between the two bounds, and tau D / L_y^2 the
same at every height, is what the diffusion picture predicts (a slip length that does not grow with
L_y moves the constant from one bound towards the other as the cell grows).

The measurement, per run (docs/analysis.md, "Profile decay"):
- each window's vx profile divided by V, read at fixed fractions ETA of the window's own height,
  so that a cell that dilates is compared at the same places;
- its distance from the reference profile, the mean over the run's last half;
- the distance's dominant shape over the first half (its first singular vector), and the signed
  coefficient c(t) of every window along it, in units of V (the shape has a root mean square of 1);
- c(t) = c_0 exp(-(t - t_0) / tau) + c_inf fitted from the first window after c's largest value
  where c has fallen to START_FRACTION of it (the higher modes and the start's dilation gone) over
  FIT_SPANS tau (found again from each fit's tau until the span stays; the rest of the run holds
  only the steady flow's slow fluctuations): the noise averages out along the shape, and c_inf takes
  up what of the decay the reference still holds. A tau shorter than the windows' spacing, or a c_0
  within SIGNAL_TO_NOISE of c's noise over the last half, is no measurement (shorter windows resolve
  a faster decay). tau's error is the fit's, scaled by the square root of the residuals' statistical
  inefficiency (consecutive windows are correlated);
- the decay counts as resolved when the run after the fit's start is at least RESOLVED_SPANS tau
  long.
"""
import math
import warnings

import numpy as np

from .rundata import is_number

ETA = np.linspace(0.05, 0.95, 37)  # heights / L_y of the profile's comparison points
START_FRACTION = 0.6   # the fit starts once c has fallen to this share of its largest value
MIN_FIT_WINDOWS = 8
FIT_SPANS = 5.0        # the fit spans this many tau from its start (or the whole run)
RESOLVED_SPANS = 4.0   # a decay is resolved when the run after the fit's start holds this many tau
SIGNAL_TO_NOISE = 5.0  # the fitted c_0 must be this many times c's noise
MODES = {"sin_2pi_eta": lambda eta: np.sin(2 * np.pi * eta),   # walls holding the grains
         "cos_pi_eta": lambda eta: np.cos(np.pi * eta)}         # walls sliding at fixed stress
TAU_OVER_T_SS = {"sin_2pi_eta": 1 / (4 * math.pi ** 2), "cos_pi_eta": 1 / math.pi ** 2}


def window_profiles(windows, velocity):
    """vx / V of each window at heights ETA x (the window's mean L_y): a W x len(ETA) array, NaN
    rows where fewer than two stripes hold a finite velocity."""
    y = np.asarray(windows["y"], dtype=float)
    vx = np.asarray(windows["vx"], dtype=float)
    height = np.asarray(windows["height"], dtype=float)
    out = np.full((vx.shape[0], len(ETA)), np.nan)
    for k in range(vx.shape[0]):
        ok = np.isfinite(vx[k])
        if ok.sum() >= 2 and np.isfinite(height[k]) and height[k] > 0:
            out[k] = np.interp(ETA * height[k], y[ok], vx[k][ok] / velocity)
    return out


def statistical_inefficiency(r):
    """1 + 2 sum of the autocorrelations of r up to the first that is not positive: the factor by
    which correlated residuals inflate a fit's variance."""
    r = np.asarray(r, dtype=float) - np.mean(r)
    var = float(r @ r)
    if len(r) < 3 or var == 0:
        return 1.0
    g = 1.0
    for k in range(1, len(r) // 2):
        rho = float(r[:-k] @ r[k:]) / var
        if rho <= 0:
            break
        g += 2 * rho
    return g


def _exponential(t, c0, tau, c_inf):
    return c0 * np.exp(-t / tau) + c_inf


def _no_fit():
    return {"tau": None, "tau_err": None, "c_0": None, "c_inf": None, "fit_range": None,
            "fit_windows": 0, "statistical_inefficiency": None, "resolved": False, "reason": None}


def fit_decay(t, c, noise):
    """c(t) = c_0 exp(-(t - t_0) / tau) + c_inf from the first t after c's largest value where
    c <= START_FRACTION max(c) (a first window below the peak, a mode still building up, is not
    part of the decay).
    Refused (tau None, with the reason) when tau is shorter than the windows' spacing or c_0 is
    within SIGNAL_TO_NOISE of the noise (c's scatter over the run's last half). Returns a dict: tau,
    tau_err, c_0, c_inf, fit_range, fit_windows, statistical_inefficiency, resolved, reason (None
    when tau is measured)."""
    from scipy.optimize import curve_fit
    out = _no_fit()
    if not np.max(np.abs(c)) > 0:
        out["reason"] = "the profile does not change from window to window"
        return out
    peak = int(np.argmax(c))
    fallen = np.flatnonzero(c[peak:] <= START_FRACTION * c[peak])
    if not len(fallen):
        out["reason"] = (f"c does not fall to {START_FRACTION} of its largest value (at "
                         f"t {t[peak]:.3g}) within the run: no decay to fit (a longer run)")
        return out
    start = peak + int(fallen[0])
    x, z = t[start:] - t[start], c[start:]
    out["fit_windows"] = len(x)
    if len(x) < MIN_FIT_WINDOWS:
        out["reason"] = (f"{len(x)} windows after c fell to {START_FRACTION} of its largest "
                         f"value; {MIN_FIT_WINDOWS} needed (shorter windows, measure.window)")
        return out
    below = np.flatnonzero(z <= z[0] / math.e)
    guess = x[below[0]] if len(below) and x[below[0]] > 0 else x[-1] / 4
    # Fitted over FIT_SPANS tau from the start (the rest holds no more of the decay, only the
    # steady flow's slow fluctuations), the span found again from each fit's tau until it repeats;
    # the last fit is over the span kept.
    def fit(count, tau_guess):
        with warnings.catch_warnings():   # a covariance it cannot estimate is inf: no error
            warnings.simplefilter("ignore")
            return curve_fit(_exponential, x[:count], z[:count], p0=(z[0], tau_guess, 0.0),
                             bounds=([-np.inf, 1e-9 * x[-1], -np.inf], [np.inf, np.inf, np.inf]))
    n, fitted, tried = len(x), None, set()
    try:
        while n not in tried:
            tried.add(n)
            (p, cov), fitted = fit(n, guess), n
            guess = p[1]
            n = max(MIN_FIT_WINDOWS, int(np.searchsorted(x, FIT_SPANS * p[1], side="right")))
        if n != fitted:
            p, cov = fit(n, guess)
    except (RuntimeError, ValueError) as e:
        out["reason"] = f"the exponential fit did not converge ({e})"
        return out
    x, z = x[:n], z[:n]
    out["fit_windows"] = n
    spacing = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    # (a fit left at its first guess, one spacing, equals it up to the rounding of the times)
    if p[1] <= spacing * (1 + 1e-9) or abs(p[0]) < SIGNAL_TO_NOISE * noise:
        out["reason"] = (f"the decay is not resolved by the windows (tau {p[1]:.3g} t against "
                         f"windows {spacing:.3g} t apart; c_0 {p[0]:.3g} against the noise "
                         f"{noise:.3g}): shorter windows (measure.window)")
        return out
    g = statistical_inefficiency(z - _exponential(x, *p))
    out.update(tau=float(p[1]), tau_err=float(math.sqrt(cov[1, 1] * g)), c_0=float(p[0]),
               c_inf=float(p[2]), fit_range=[float(t[start]), float(t[start] + x[-1])],
               statistical_inefficiency=g)
    after = t[-1] - t[start]
    out["resolved"] = bool(after >= RESOLVED_SPANS * p[1] and math.isfinite(out["tau_err"]))
    if not out["resolved"]:
        out["reason"] = (f"not resolved: the run's span after the fit's start ({after:.0f} t) is "
                         f"shorter than {RESOLVED_SPANS:g} tau ({p[1]:.0f} t), or tau's error is "
                         f"unknown: a longer run")
    return out


def profile_decay(windows, velocity, initial_velocity):
    """summary.json `profile_decay` of a run (see the module's text): the coefficient series c
    along the decaying shape, the shape's overlaps with the two walls' slowest modes, the noise
    and the fitted decay (fit_decay)."""
    t_all = 0.5 * (np.asarray(windows["t_start"], float) + np.asarray(windows["t_end"], float))
    profiles = window_profiles(windows, velocity)
    ok = np.all(np.isfinite(profiles), axis=1)
    t, profiles = t_all[ok], profiles[ok]
    out = {"initial_velocity": initial_velocity, "t": t, "c": None, "shape_overlap": None,
           "noise": None, "reference": "the last half of the run"}
    late = t >= 0.5 * (t[-1] if len(t) else 0.0)
    if len(t) < 2 * MIN_FIT_WINDOWS or late.sum() < 2 or (~late).sum() < 2:
        out.update(_no_fit(), reason=f"{len(t)} complete windows with a whole profile; "
                                     f"{2 * MIN_FIT_WINDOWS} needed")
        return out
    distance = profiles - profiles[late].mean(axis=0)
    shape = np.linalg.svd(distance[~late], full_matrices=False)[2][0]
    shape /= math.sqrt(np.mean(shape ** 2))
    c = distance @ shape / len(ETA)
    if c[np.argmax(np.abs(c))] < 0:
        shape, c = -shape, -c
    out.update(c=c, noise=float(np.std(c[late], ddof=1)),
               shape_overlap={name: float(abs(shape @ f(ETA)) / (np.linalg.norm(shape) *
                                                                  np.linalg.norm(f(ETA))))
                              for name, f in MODES.items()})
    out.update(fit_decay(t, c, out["noise"]))
    return out


def _mean(summary, *keys):
    v = summary
    for k in keys:
        v = v.get(k) if isinstance(v, dict) else None
    v = _number(v.get("mean") if isinstance(v, dict) else v)
    return None if v is None else float(v)


def _number(v):
    """v when it is a finite number (not a boolean) a float can hold, else None (an integer too
    large for any float, which JSON can hold, is none)."""
    try:
        return v if is_number(v) and math.isfinite(v) else None
    except OverflowError:
        return None


# The model family and parameters of the bulk laws as a report names them (report.FITS).
BULK_LAWS = {"mu_power": ("power_plus", ("mu_0", "A", "B")),
             "mu_linear": ("linear_plus", ("a", "b"))}


def _range(v):
    """A fit range [t0, t1] of two finite numbers, else None."""
    ok = isinstance(v, list) and len(v) == 2 and all(_number(x) is not None for x in v)
    return v if ok else None


def _overlaps(v):
    """The shape overlaps {sin_2pi_eta, cos_pi_eta} that are finite numbers."""
    v = v if isinstance(v, dict) else {}
    return {k: v[k] for k in ("sin_2pi_eta", "cos_pi_eta") if _number(v.get(k)) is not None}


def bulk_law_problem(fits):
    """Why the bulk laws of fits.json's `fits` (`mu_power`, `mu_linear`, where given) cannot be
    used by decay_against_diffusion, naming the key; None when they can."""
    for key in ("mu_power", "mu_linear"):
        if key not in fits:
            continue
        law = fits[key]
        if not isinstance(law, dict):
            return f"fits.{key} is not an object"
        params = law.get("parameters")
        if not params:
            continue   # a law not fitted: not usable, and said so per run
        model, wanted = BULK_LAWS[key]
        # the slope is taken from the model's formula (fitting.slope): the report's model only
        if law.get("model") != model:
            return (f"fits.{key}.model must be {model} (a report's fits.json), not "
                    f"{law.get('model')!r}")
        if not isinstance(params, dict):
            return f"fits.{key}.parameters is not an object (a report's fits.json)"
        # read by position (fitting.slope): the report's names, in its order
        if list(params) != list(wanted):
            return (f"fits.{key}.parameters must be {', '.join(wanted)} in that order (a "
                    f"report's fits.json), not {', '.join(map(str, params)) or 'none'}")
        for name, p in params.items():
            if not (isinstance(p, dict) and _number(p.get("value")) is not None):
                return f"fits.{key}.parameters.{name}.value is not a finite number"
    return None


def _bulk_slope(law, I):
    """d mu / d I of a bulk law at I (fitting.slope), None where it is beyond the range of a
    float (a hand-edited exponent: I^(B - 1) overflows)."""
    from . import fitting
    try:
        slope = fitting.slope(law, I)
    except (OverflowError, ZeroDivisionError):
        return None
    return slope if math.isfinite(slope) else None


def _steady_state_time(law, e):
    """(T_SS, D) of transitions.steady_state_time for the entry e, None where D or T_SS is not
    a finite number above 0 (D below the smallest float, or L_y^2 / D beyond the largest)."""
    from .transitions import steady_state_time
    try:
        T, D = steady_state_time(law, e["I_bulk"], e["L_y"], e["nu_bulk"], e["sigma_yy"])
    except (OverflowError, ZeroDivisionError):
        return None
    return (T, D) if all(math.isfinite(v) and v > 0 for v in (T, D)) else None


def decay_against_diffusion(summaries, fits):
    """One entry per run (summary.json dicts with "run" added): the measured tau beside T_SS =
    L_y^2 / D (D from the bulk law `mu_power` of fits.json's `fits`, or `mu_linear`, at the run's
    steady I_bulk and nu_bulk) and tau / T_SS; `used` for runs started at rest, in regime A, steady,
    with a resolved tau (T_SS is a regime-A prediction; `reason` says why another is not). Over the
    used runs, the exponent p of tau D proportional to L_y^p (2 for a diffusion with the same
    boundary condition at every height), fitted to the logarithms weighted by tau's errors (the
    bulk law's own errors not propagated). Returns (entries, exponent dict or None)."""
    entries = decay_entries(summaries, fits)
    return entries, height_exponent(entries, exponent_absence(entries))


def decay_entries(summaries, fits):
    """decay_against_diffusion's entries, one per run."""
    from . import fitting
    law = next((k for k in ("mu_power", "mu_linear") if fitting.usable(fits.get(k))), None)
    entries = []
    for s in summaries:
        d = s.get("profile_decay") if isinstance(s.get("profile_decay"), dict) else {}
        e = {"run": s["run"], "initial_velocity": d.get("initial_velocity"),
             "regime": s.get("regime"), "steady": s.get("steady"),
             "L_y": _mean(s, "height"), "I_bulk": _mean(s, "bulk", "inertial_number"),
             "nu_bulk": _mean(s, "bulk", "solid_fraction"),
             "sigma_yy": _mean(s, "case", "normal_stress"), "tau": _number(d.get("tau")),
             "tau_err": _number(d.get("tau_err")), "fit_range": _range(d.get("fit_range")),
             "shape_overlap": _overlaps(d.get("shape_overlap")), "law": law, "D": None,
             "system": _system(s.get("case")),
             "T_SS": None,
             "tau_over_T_SS": None, "used": False, "reason": None}
        # Each must be a number above 0 (L_y^2 / D and sqrt(m / sigma_yy) need it).
        missing = [k for k in ("L_y", "I_bulk", "nu_bulk", "sigma_yy")
                   if e[k] is None or e[k] <= 0]
        if not d:
            e["reason"] = "no profile_decay in summary.json (analyze the run again)"
        elif law is None:
            e["reason"] = "no bulk law whose parameters are determined"
        elif missing:
            e["reason"] = "missing or not above 0: " + ", ".join(missing)
        elif (slope := _bulk_slope(fits[law], e["I_bulk"])) is None:
            e["reason"] = (f"d mu / d I at I_bulk = {e['I_bulk']:.3g} is beyond the range of a "
                           f"number (the bulk law's parameters)")
        elif slope <= 0:
            e["reason"] = f"d mu / d I <= 0 at I_bulk = {e['I_bulk']:.3g}: no diffusion"
        elif not (1e-150 < e["L_y"] < 1e150   # L_y^2 / D
                  and _finite_products(e["sigma_yy"], 1.0 / e["nu_bulk"], 1.0 / e["sigma_yy"])):
            e["reason"] = "L_y, nu_bulk or sigma_yy beyond the range T_SS can be taken from"
        elif (T_and_D := _steady_state_time(fits[law], e)) is None:
            e["reason"] = (f"T_SS = L_y^2 / D is beyond the range of a number (d mu / d I = "
                           f"{slope:.3g} from the bulk law's parameters)")
        else:
            e["T_SS"], e["D"] = T_and_D
            if e["tau"] is not None and math.isfinite(ratio := e["tau"] / e["T_SS"]):
                e["tau_over_T_SS"] = ratio
            if isinstance(d.get("reason"), str) and d["reason"]:
                e["reason"] = d["reason"]
            elif e["tau"] is None or not (e["tau_err"] or 0) > 0 or not e["tau"] > 0:
                e["reason"] = "no decay time tau > 0 with an error above 0 in summary.json"
            elif not _finite_products(e["tau"] * e["D"], e["tau"] / e["tau_err"],
                                      e["T_SS"]) or e["tau"] / e["tau_err"] > 1e150:
                e["reason"] = "tau or its error beyond the range a weight can be taken from"
            elif (why := _series_problem(d)) is not None:
                e["reason"] = why
            elif e["initial_velocity"] != "rest":
                e["reason"] = "not started at rest"
            elif e["regime"] != "A" or not e["steady"]:
                e["reason"] = f"not steady regime A (regime {e['regime']}, steady {e['steady']})"
            else:
                e["used"] = True
        entries.append(e)
    return entries


def height_exponent(entries, absence):
    """decay_against_diffusion's exponent over the used entries, or None; `absence`:
    exponent_absence(entries), which the caller has (it prints it too)."""
    use = [e for e in entries if e["used"]]
    exponent = None
    # Heights of other systems (numbers of disks and nominal heights): one system's L_y moves
    # with V by its dilation alone, a few percent, which no power law of the height is to be read
    # from; and two measured heights at least, or the fit has no slope to take.
    if absence is None and len(use) >= 2:
        x = np.log([e["L_y"] for e in use])
        z = np.log([e["tau"] * e["D"] for e in use])
        w = np.array([(e["tau"] / e["tau_err"]) ** 2 for e in use])
        A = np.vstack([x, np.ones_like(x)]).T * np.sqrt(w)[:, None]
        coef = np.linalg.lstsq(A, z * np.sqrt(w), rcond=None)[0]
        cov = np.linalg.inv(A.T @ A)
        dof = len(use) - 2
        chi2 = float(np.sum(w * (z - coef[0] * x - coef[1]) ** 2))
        exponent = {"p": float(coef[0]), "runs": len(use), "dof": dof,
                    "chi2_per_dof": chi2 / dof if dof > 0 else None,
                    "p_err": float(math.sqrt(cov[0, 0] * max(1.0, chi2 / dof if dof else 1.0))),
                    "note": "error from tau's errors alone, scaled by sqrt(chi2/dof) when above 1"
                            + ("" if dof > 0 else "; no degree of freedom left to check it")}
    return exponent


def _system(case):
    """(n, nominal height) of a summary's case, the system a run is of; None where either is
    missing or not a number."""
    case = case if isinstance(case, dict) else {}
    n, height = case.get("n"), _number(case.get("height"))
    whole = isinstance(n, int) and not isinstance(n, bool)
    return (n, height) if whole and height is not None else None


def _series_problem(d):
    """Why summary.json's profile_decay holds no series to draw (`t`, `c`: lists of one length,
    times finite, coefficients numbers or null; `c_0`, `c_inf` finite numbers; `fit_range` two),
    or None."""
    t, c = d.get("t"), d.get("c")
    if not isinstance(t, list) or not isinstance(c, list) or len(t) != len(c) or not t:
        return "profile_decay.t and .c are not series of one length in summary.json"
    if not all(_number(v) is not None for v in t) or \
            not all(v is None or _number(v) is not None for v in c):
        return "profile_decay.t or .c holds a value that is not a finite number in summary.json"
    if _number(d.get("c_0")) is None or _number(d.get("c_inf")) is None:
        return "profile_decay.c_0 or .c_inf is not a finite number in summary.json"
    if _range(d.get("fit_range")) is None:
        return "profile_decay.fit_range is not two finite numbers in summary.json"
    return None


def exponent_absence(entries):
    """Why no exponent of the height is fitted over the used entries (decay_against_diffusion),
    or None where one is (or no run is used): it needs used runs of two systems or more (n and
    nominal height) at two measured heights or more."""
    use = [e for e in entries if e["used"]]
    systems = {e["system"] for e in use}
    if not use:
        return None
    if None in systems:
        return ("no exponent of the height: a used run's summary gives no number of disks or "
                "nominal height")
    if len(systems) < 2:
        n, height = use[0]["system"]
        return (f"no exponent of the height: the {len(use)} used "
                f"run{'s are' if len(use) > 1 else ' is'} of one system (n = {n}, height "
                f"{height:g}); it needs two systems or more")
    if len({e["L_y"] for e in use}) < 2:
        return "no exponent of the height: the used runs' measured heights are one"
    return None


def _finite_products(*values):
    """True when every value (a product or quotient the decay's comparison takes) is a finite
    number above 0 and above underflow: a damaged summary's 1e308 or 1e-320 is not."""
    return all(math.isfinite(v) and abs(v) > 1e-300 for v in values)


def format_decay_table(entries, exponent, absence=False):
    """The table `profile-decay` prints, each column as wide as its widest cell; `absence`:
    exponent_absence(entries) where the caller has it (False: found here)."""
    def fixed(v, decimals):
        # Fixed-point in the table's columns; beyond them (a damaged or diverged value, or one
        # that would print as 0), 3 significant digits.
        return f"{v:.{decimals}f}" if v == 0 or 10.0 ** -decimals <= abs(v) < 1e6 \
            else f"{v:.3g}"

    def f(v, decimals):
        return "-" if v is None else fixed(v, decimals)

    def text(v):
        return "-" if v is None else str(v)
    header = ("run", "start", "regime", "L_y", "I_bulk", "D", "T_SS", "tau", "tau/T_SS", "sin2",
              "cos1")
    texts = 3   # the first columns hold texts, left-aligned; numbers right-aligned
    rows = []
    for e in entries:
        tau = f"{fixed(e['tau'], 1)} +- {fixed(e['tau_err'], 1)}" if e["tau"] is not None and \
            e["tau_err"] is not None else "-"
        ov = e["shape_overlap"] or {}
        note = (f"{fixed(e['fit_range'][0], 0)}-{fixed(e['fit_range'][1], 0)} t"
                if e["fit_range"] else "") \
            + ("" if e["used"] else f" (not used: {e['reason']})")
        rows.append(((str(e["run"]), text(e["initial_velocity"]), text(e["regime"]),
                      f(e["L_y"], 2), f(e["I_bulk"], 4), f(e["D"], 3), f(e["T_SS"], 0), tau,
                      f(e["tau_over_T_SS"], 4), f(ov.get("sin_2pi_eta"), 2),
                      f(ov.get("cos_pi_eta"), 2)), note.strip()))
    widths = [max(len(cells[k]) for cells in [header] + [r[0] for r in rows])
              for k in range(len(header))]

    def line(cells, note):
        return (" ".join(c.ljust(w) if k < texts else c.rjust(w)
                         for k, (c, w) in enumerate(zip(cells, widths))) + "  " + note).rstrip()
    lines = [line(header, "fit / reason")] + [line(cells, note) for cells, note in rows]
    lines.append(f"slowest mode from rest: tau / T_SS = 1 / (4 pi^2) = "
                 f"{TAU_OVER_T_SS['sin_2pi_eta']:.4f} (sin(2 pi y / L_y), walls holding the "
                 f"grains) to 1 / pi^2 = {TAU_OVER_T_SS['cos_pi_eta']:.4f} (cos(pi y / L_y), "
                 f"walls sliding); sin2, cos1: the decaying shape's overlap with each")
    if absence is False:
        absence = exponent_absence(entries)
    if absence:
        lines.append(absence)
    if exponent:
        lines.append(f"tau D proportional to L_y^p: p = {exponent['p']:.2f} +- "
                     f"{exponent['p_err']:.2f} over {exponent['runs']} runs (2 for a diffusion; "
                     f"{exponent['note']})")
    return "\n".join(lines)

"""How fast the velocity profile reaches its steady shape: the decay time of its distance from
that shape, measured per run, against the time to steady state of model.md section 8.

The prediction (model.md section 8) treats the momentum balance as a diffusion of the shear rate,
D = (d mu_eff / d gamma_dot) sigma_yy / (rho nu), across the height: T_SS = L_y^2 / D. A profile's
distance from the steady one then decays as a sum of modes, the slowest excited one last, as
exp(-t / tau) with tau = L_y^2 / (k^2 pi^2 D) for the mode sin(k pi y / L_y) between walls that
hold the grains next to them. From the bulk at rest (`shear.initial_velocity = "rest"`) that
distance is minus the steady profile, antisymmetric about the mid-height, so its slowest mode is
k = 2: tau = T_SS / (4 pi^2). The measured tau against L_y^2 / D tests the diffusion picture,
whatever the walls' slip does to the constant: tau D / L_y^2 is the same for every height if it
holds.

The measurement, per window of the run (docs/analysis.md, "Profile decay"):
- the window's vx profile divided by V, interpolated at fixed fractions of the window's own height
  (ETA), so that a cell that dilates is compared at the same places;
- its distance from the reference profile (the mean over the steady windows, or over the run's
  last half when it is not steady): the root mean square over ETA, a(t);
- the reference windows' own root mean square distance is the noise floor f; a is corrected to
  sqrt(a^2 - f^2);
- ln a is fitted by a straight line over the windows from the first where the corrected amplitude
  is below START_LEVEL (the late, near-linear decay) to the last before the raw amplitude first
  falls below END_FACTOR f; tau = -1 / slope, its error the fit's (the windows taken as
  independent: a lower bound).
"""
import math

import numpy as np

ETA = np.linspace(0.05, 0.95, 37)  # heights / L_y of the profile's comparison points
START_LEVEL = 0.3   # the fit starts once the amplitude (in units of V) is below this
END_FACTOR = 2.0    # ... and stops before the raw amplitude first falls below this many floors
MIN_FIT_WINDOWS = 5


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


def decay_amplitude(profiles, reference_windows):
    """(a, floor): the root mean square over ETA of each window's distance from the mean profile of
    reference_windows, and that distance's root mean square over the reference windows."""
    ref = np.nanmean(profiles[reference_windows], axis=0)
    with np.errstate(invalid="ignore"):
        a = np.sqrt(np.nanmean((profiles - ref) ** 2, axis=1))
    floor = float(np.sqrt(np.nanmean(a[reference_windows] ** 2)))
    return a, floor


def fit_decay(t, a, floor):
    """The decay time of a(t) (see the module's text). Returns a dict: tau, tau_err, fit_range
    [t_first, t_last], fit_windows, reason (None when tau is measured)."""
    out = {"tau": None, "tau_err": None, "fit_range": None, "fit_windows": 0, "reason": None}
    corrected = np.sqrt(np.maximum(a ** 2 - floor ** 2, 0.0))
    below = np.flatnonzero(np.isfinite(a) & (corrected < START_LEVEL))
    if len(below) == 0:
        out["reason"] = f"the amplitude never falls below {START_LEVEL} V"
        return out
    first = int(below[0])
    end = first
    while end < len(a) and np.isfinite(a[end]) and a[end] >= END_FACTOR * floor:
        end += 1
    fit = np.arange(first, end)
    fit = fit[corrected[fit] > 0]
    out["fit_windows"] = len(fit)
    if len(fit) < MIN_FIT_WINDOWS:
        out["reason"] = (f"{len(fit)} windows between the amplitude's fall below {START_LEVEL} V "
                         f"and its reaching {END_FACTOR} x the noise floor ({floor:.3g} V); "
                         f"{MIN_FIT_WINDOWS} needed (shorter windows, measure.window, resolve a "
                         f"faster decay)")
        return out
    x, z = t[fit], np.log(corrected[fit])
    A = np.vstack([x, np.ones_like(x)]).T
    coef, *_ = np.linalg.lstsq(A, z, rcond=None)
    residual = z - A @ coef
    s2 = float(residual @ residual) / (len(x) - 2)
    slope_err = math.sqrt(s2 / float(np.sum((x - x.mean()) ** 2)))
    slope = float(coef[0])
    out["fit_range"] = [float(x[0]), float(x[-1])]
    if slope >= 0:
        out["reason"] = f"the amplitude does not decay over {out['fit_range']} (slope {slope:.3g})"
        return out
    out["tau"] = -1.0 / slope
    out["tau_err"] = slope_err / slope ** 2
    return out


def profile_decay(windows, velocity, steady_windows, initial_velocity):
    """summary.json `profile_decay` of a run: the amplitude series, its floor, the reference and the
    fitted decay time (fit_decay)."""
    n = len(windows["t_start"])
    t = 0.5 * (np.asarray(windows["t_start"], float) + np.asarray(windows["t_end"], float))
    out = {"initial_velocity": initial_velocity, "t": t, "amplitude": np.full(n, np.nan),
           "floor": None, "reference": None}
    if n == 0:
        out.update(fit_decay(t, np.zeros(0), 0.0), reason="no complete window")
        return out
    if len(steady_windows) >= 2:
        reference, out["reference"] = np.asarray(steady_windows), "the steady windows"
    else:
        reference = np.flatnonzero(t >= 0.5 * t[-1])
        out["reference"] = "the last half of the run (not steady)"
    if len(reference) < 2:
        out.update(fit_decay(t, np.zeros(0), 0.0), reason="fewer than two reference windows")
        return out
    a, floor = decay_amplitude(window_profiles(windows, velocity), reference)
    out.update(amplitude=a, floor=floor)
    out.update(fit_decay(t, a, floor))
    return out


def _mean(summary, *keys):
    v = summary
    for k in keys:
        v = v.get(k) if isinstance(v, dict) else None
    v = v.get("mean") if isinstance(v, dict) else v
    return float(v) if isinstance(v, (int, float)) and math.isfinite(v) else None


def decay_against_diffusion(summaries, fits):
    """One entry per run (summary.json dicts with "run" added): the measured tau beside T_SS =
    L_y^2 / D (D from the bulk law `mu_power` of fits.json's `fits`, or `mu_linear`, at the run's
    steady I_bulk and nu_bulk) and tau / T_SS; and, over the runs with a tau, the exponent p of
    tau D proportional to L_y^p (2 if the diffusion picture holds), fitted to the logarithms with
    tau's errors. Returns (entries, exponent dict or None)."""
    from . import fitting
    from .transitions import steady_state_time
    law = next((k for k in ("mu_power", "mu_linear") if fitting.usable(fits.get(k))), None)
    entries = []
    for s in summaries:
        d = s.get("profile_decay") or {}
        e = {"run": s["run"], "initial_velocity": d.get("initial_velocity"),
             "L_y": _mean(s, "height"), "I_bulk": _mean(s, "bulk", "inertial_number"),
             "nu_bulk": _mean(s, "bulk", "solid_fraction"),
             "sigma_yy": _mean(s, "case", "normal_stress"), "tau": d.get("tau"),
             "tau_err": d.get("tau_err"), "fit_range": d.get("fit_range"), "law": law,
             "D": None, "T_SS": None, "tau_over_T_SS": None,
             "reason": d.get("reason") if d else "no profile_decay in summary.json (analyze "
                                                  "the run again)"}
        missing = [k for k in ("L_y", "I_bulk", "nu_bulk", "sigma_yy") if e[k] is None]
        if law is None:
            e["reason"] = e["reason"] or "no bulk law whose parameters are determined"
        elif missing:
            e["reason"] = e["reason"] or "missing " + ", ".join(missing)
        elif fitting.slope(fits[law], e["I_bulk"]) > 0:
            e["T_SS"], e["D"] = steady_state_time(fits[law], e["I_bulk"], e["L_y"], e["nu_bulk"],
                                                  e["sigma_yy"])
            if e["tau"] is not None:
                e["tau_over_T_SS"] = e["tau"] / e["T_SS"]
        entries.append(e)
    use = [e for e in entries if e["tau"] is not None and e["D"] is not None]
    exponent = None
    if len({round(e["L_y"]) for e in use}) >= 2:
        x = np.log([e["L_y"] for e in use])
        z = np.log([e["tau"] * e["D"] for e in use])
        w = np.array([(e["tau"] / e["tau_err"]) ** 2 if e["tau_err"] else 1.0 for e in use])
        A = np.vstack([x, np.ones_like(x)]).T * np.sqrt(w)[:, None]
        coef, *_ = np.linalg.lstsq(A, z * np.sqrt(w), rcond=None)
        cov = np.linalg.inv(A.T @ A)
        dof = len(use) - 2
        chi2 = float(np.sum(w * (z - coef[0] * x - coef[1]) ** 2))
        scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
        exponent = {"p": float(coef[0]), "p_err": float(math.sqrt(cov[0, 0] * scale)),
                    "runs": len(use), "chi2_per_dof": chi2 / dof if dof > 0 else None,
                    "note": "errors scaled by sqrt(chi2/dof) when above 1"}
    return entries, exponent


def format_decay_table(entries, exponent):
    """The table `profile-decay` prints."""
    def f(v, spec):
        return format(v, spec) if v is not None else "-"
    lines = [f"{'run':<16} {'start':<7} {'L_y':>6} {'I_bulk':>7} {'D':>7} {'T_SS':>8} "
             f"{'tau':>14} {'tau/T_SS':>9}  fit range"]
    for e in entries:
        tau = f"{e['tau']:.1f} +- {e['tau_err']:.1f}" if e["tau"] is not None else "-"
        fr = f"{e['fit_range'][0]:.0f}-{e['fit_range'][1]:.0f} t" if e["fit_range"] else \
            (e["reason"] or "")
        lines.append(f"{e['run']:<16} {str(e['initial_velocity']):<7} {f(e['L_y'], '6.2f')} "
                     f"{f(e['I_bulk'], '7.4f')} {f(e['D'], '7.3f')} {f(e['T_SS'], '8.0f')} "
                     f"{tau:>14} {f(e['tau_over_T_SS'], '9.4f')}  {fr}")
    lines.append(f"the slowest mode of a diffusion between walls that hold the grains, from rest: "
                 f"tau / T_SS = 1 / (4 pi^2) = {1 / (4 * math.pi ** 2):.4f}")
    if exponent:
        lines.append(f"tau D proportional to L_y^p: p = {exponent['p']:.2f} +- "
                     f"{exponent['p_err']:.2f} over {exponent['runs']} runs (2 for a diffusion)")
    return "\n".join(lines)

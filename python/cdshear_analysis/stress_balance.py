"""The check of docs/model.md section 7 of the measured stress against the walls: over a run's
steady windows (those with a measured interior), the interior (bulk) sigma_yy, sigma_xy and mu_eff
against the walls' normal stress, shear stress and friction, each difference as mean and standard
error over the windows (the windows are 80 t long: nearly independent), and the sizes of the
kinetic and rotational parts.

The walls' stresses of a window come from its exact mean forces: sigma_yy,wall = (|f_y,bottom| +
|f_y,top|) / (2 L_x), sigma_xy,wall = (f_x,top - f_x,bottom) / (2 L_x) (the grains' force on each
wall; at the top wall a stripe's sigma_xy is f_x / L_x, at the bottom -f_x / L_x), and mu_wall =
(|f_x| + |f_x|) / (|f_y| + |f_y|). The interior is the summary's bulk (summary.choose_bulk_range).
In steady shear the momentum balance makes them equal; the grain-scale scatter of stripe
stresses (docs/measurements.md) averages out over the bulk's stripes and the windows.

`python3 -m cdshear_analysis stress-balance RUN_DIR...` prints one line per run."""
import math
import warnings

import numpy as np

from .rundata import RunDataError
from .statistics import window_mean
from .summary import analyze, window_wall_friction


def _pm(x):
    mean, err = window_mean(np.asarray(x, dtype=float))
    return float(mean), float(err) if err is not None and np.isfinite(err) else float("nan")


def stress_balance(run, summary=None):
    """The check for one loaded run: a dict of (mean, err) pairs over its steady windows (the
    summary's `steady_window_indices`; analyze(run) when no summary is given)."""
    summary = summary or analyze(run)
    w = run["windows"]
    if missing := [k for k in ("bottom_force", "top_force") if k not in w]:
        raise RunDataError(run["path"], "missing dataset(s) "
                           + ", ".join(f"/windows/{k}" for k in missing)
                           + ": the walls' stress is not known")
    sel = np.asarray(summary["steady_window_indices"], dtype=int)
    lx = float(run["attrs"]["length_x"])
    y = np.asarray(w["y"], dtype=float)
    lo, hi = summary["bulk"]["y_range"]
    if lo is None or hi is None or len(sel) == 0:
        return None
    inside = (y >= lo) & (y <= hi)   # closed, as the bulk's regions (profiles.region_quantities)
    if "stress" in w:
        # only the windows with a measured interior: one whose bulk stripes are all empty has
        # no interior stress, and counting it would claim a window the means do not hold
        interior_stress = np.asarray(w["stress"], dtype=float)[sel][:, inside]
        sel = sel[np.isfinite(interior_stress).any(axis=1).all(axis=(1, 2))]
        if len(sel) == 0:
            return None
    fb = np.asarray(w["bottom_force"], dtype=float).reshape(-1, 2)[sel]
    ft = np.asarray(w["top_force"], dtype=float).reshape(-1, 2)[sel]

    def interior(name, i, j):
        if name not in w:
            return np.full(len(sel), np.nan)
        with warnings.catch_warnings():   # a stripe-less kinetic part is NaN, and stays so
            warnings.simplefilter("ignore", RuntimeWarning)
            return np.nanmean(np.asarray(w[name], dtype=float)[sel][:, inside, i, j], axis=1)
    syy, sxy = interior("stress", 1, 1), interior("stress", 0, 1)
    wall_yy = (np.abs(fb[:, 1]) + np.abs(ft[:, 1])) / (2 * lx)
    wall_xy = (ft[:, 0] - fb[:, 0]) / (2 * lx)
    mu_in = np.abs(sxy) / syy
    mu_wall = window_wall_friction(w)[sel]
    return {
        "velocity": float(run["attrs"]["velocity"]), "windows": int(len(sel)),
        "steady": bool(summary["steady"]), "bulk_h": summary["bulk"]["h"],
        "finished": bool(summary["case"]["finished"]), "time": summary["case"]["time"],
        "duration": summary["case"]["duration"],
        "sigma_yy": _pm(syy), "sigma_yy_wall": _pm(wall_yy), "sigma_yy_diff": _pm(syy - wall_yy),
        "sigma_xy": _pm(sxy), "sigma_xy_wall": _pm(wall_xy), "sigma_xy_diff": _pm(sxy - wall_xy),
        "mu_eff": _pm(mu_in), "mu_eff_wall": _pm(mu_wall), "mu_eff_diff": _pm(mu_in - mu_wall),
        "kinetic_yy": _pm(interior("kinetic_stress", 1, 1)),
        "rotational_yy": _pm(interior("rotational_stress", 1, 1)),
        "kinetic_xy": _pm(interior("kinetic_stress", 0, 1)),
        "rotational_xy": _pm(interior("rotational_stress", 0, 1)),
    }


def format_line(name, b):
    """One line of the printed table: each mean +- its error over the windows (the mean alone
    where one window gives no error), and whether the run is steady and finished."""
    def f(pair, digits=4):
        return f"{pair[0]:+.{digits}f}" + (f"±{pair[1]:.{digits}f}" if math.isfinite(pair[1])
                                            else "")
    steady = '' if b['steady'] else ' (NOT steady)'
    if b['windows'] < 2:
        steady += ' (one window: no error estimate)'
    if not b.get('finished', True):
        steady += f" (NOT finished: t = {b['time']:g} of {b['duration']:g})"
    return (f"{name}  V {b['velocity']:g}  {b['windows']} windows{steady}"
            f"  sigma_yy {f(b['sigma_yy'])} wall {f(b['sigma_yy_wall'])}"
            f" diff {f(b['sigma_yy_diff'])}"
            f"  sigma_xy {f(b['sigma_xy'])} wall {f(b['sigma_xy_wall'])}"
            f" diff {f(b['sigma_xy_diff'])}"
            f"  mu {f(b['mu_eff'])} wall {f(b['mu_eff_wall'])} diff {f(b['mu_eff_diff'])}"
            f"  kinetic_yy {f(b['kinetic_yy'], 5)} rotational_yy {f(b['rotational_yy'], 5)}")

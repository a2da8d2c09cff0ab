"""`analyze(run)`: steady state, averages with errors, regime, switches -> the summary dict
written as RUN_DIR/summary.json (keys documented in docs/analysis.md), and the printed report.

Averages: series (wall friction, height, solid fraction, com_vx) by block averaging over the
samples at t >= averaging_start_time; window quantities (profiles, regions, slip, bulk) as
mean and standard error over the averaged windows (t_start >= averaging_start_time).
A run without any complete window (shorter than `window`) is not steady: its window quantities
are null, its regime None (reason in regime_criteria), its series averaged over the last half.
"""
import json
import math
import os

import numpy as np

from . import regime as rg
from .relaxation import profile_decay
from .profiles import QUANTITIES, region_quantities, stripe_width
from .rundata import RunDataError, write_text_atomically
from .statistics import block_average, mean_err, ratio_of_means, window_mean
from .steady_state import detect_steady_state

SUMMARY_FORMAT, SUMMARY_VERSION = "cdshear-summary", 3
REFERENCE_H = 10.0     # model.md section 7: the bulk is h < y < L_y - h with h = 10
BULK_MIN_STRIPES = 3   # a bulk holds at least this many stripes
PROFILE_FIELDS = ("solid_fraction", "vx", "mu_eff", "coordination",
                  "force_carrying_coordination", "inertial_number", "shear_rate")
STRESS_COMPONENTS = {"stress_xx": (0, 0), "stress_xy": (0, 1), "stress_yy": (1, 1)}
STRESS_PARTS = ("kinetic_stress", "rotational_stress")   # their xy and yy profiles as well


def wall_friction_series(series):
    """mu_wall = (|bottom_fx| + |top_fx|) / (|bottom_fy| + |top_fy|) per sample (NaN if 0/0)."""
    num = np.abs(series["bottom_fx"]) + np.abs(series["top_fx"])
    den = np.abs(series["bottom_fy"]) + np.abs(series["top_fy"])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, np.nan)


def wall_force_ratio(series, sides, keep):
    """The walls' friction reported beside the interior's mu_eff (model.md section 7): the ratio
    of the time-averaged tangential and normal forces, (|<f_x>| summed over `sides`) / (|<f_y>|
    summed likewise), over the samples `keep`, with its standard error (statistics.ratio_of_means).
    Not the mean of each sample's ratio: where the forces fluctuate, that mean is biased (by -0.007
    on system 7, 0.2404 against 0.2472, while the bulk gave 0.2478)."""
    num = np.zeros(int(np.sum(keep)))
    den = np.zeros_like(num)
    if len(num) == 0:
        return mean_err(np.nan, np.nan)
    for side in sides:
        fx = np.asarray(series[f"{side}_fx"], dtype=float)[keep]
        fy = np.asarray(series[f"{side}_fy"], dtype=float)[keep]
        # each force's sign over the samples, so that the sums' means are |<f_x>| and |<f_y>|
        num += np.sign(np.nanmean(fx)) * fx
        den += np.sign(np.nanmean(fy)) * fy
    return ratio_of_means(num, den)


def window_wall_friction(windows):
    """The walls' friction of each window, (|bottom f_x| + |top f_x|) / (|bottom f_y| + |top
    f_y|) of the window's exact mean forces (NaN without a normal force)."""
    fb = np.asarray(windows["bottom_force"], dtype=float).reshape(-1, 2)
    ft = np.asarray(windows["top_force"], dtype=float).reshape(-1, 2)
    den = np.abs(fb[:, 1]) + np.abs(ft[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, (np.abs(fb[:, 0]) + np.abs(ft[:, 0])) / den, np.nan)


def switch_friction_difference(series, time, switch):
    """delta_mu before one band switch: the mean of the walls' net tangential force on the
    grains, -(bottom_fx + top_fx), along the switch's direction (to_state: +1 towards +V) / the
    mean normal force of a wall, over the samples delta_mu_start_time < t <= delta_mu_end_time
    (the stretch of the old plateau before the ramp, regime.band_switches): positive where the
    walls already push the block towards the new plateau (model.md section 8: T = 2 rho nu V
    L_y / (delta_mu sigma_yy)). By momentum balance it equals the grains' momentum change over
    the stretch, so on a plateau it measures how far the block already accelerates there. NaN
    without samples in the stretch."""
    sel = (time > switch["delta_mu_start_time"]) & (time <= switch["delta_mu_end_time"])
    if not sel.any():
        return np.nan
    fx = np.asarray(series["bottom_fx"], float)[sel] + np.asarray(series["top_fx"], float)[sel]
    fy = 0.5 * (np.abs(np.asarray(series["bottom_fy"], float)[sel])
                + np.abs(np.asarray(series["top_fy"], float)[sel]))
    return (float(-switch["to_state"] * np.mean(fx) / np.mean(fy)) if np.mean(fy) > 0
            else np.nan)


def holds_a_bulk(y, height, h):
    """Whether h < y < height - h holds BULK_MIN_STRIPES stripe centres y."""
    return np.sum((y > h) & (y < height - h)) >= BULK_MIN_STRIPES


def choose_bulk_range(run):
    """(h, lo, hi): the bulk h <= y <= H - h (H the mean window height) of the measured h closest
    to REFERENCE_H among those whose bulk holds BULK_MIN_STRIPES stripes (the smaller on a tie),
    else h = None and the central half H/4 < y < 3H/4. lo and hi are per window."""
    y, height = run["windows"]["y"], np.asarray(run["windows"]["height"], dtype=float)
    mean_height = np.nanmean(height)
    usable = [region["h"] for region in run["regions"].values()
              if holds_a_bulk(y, mean_height, region["h"])]
    if usable:
        h = min(usable, key=lambda h: (abs(h - REFERENCE_H), h))
        return h, np.full_like(height, h), height - h
    return None, 0.25 * height, 0.75 * height


def bulk_h_note(run, h):
    """None when the bulk is that of model.md section 7 (h = REFERENCE_H), else why it is not, in
    words."""
    height = np.asarray(run["windows"]["height"], dtype=float)
    if h == REFERENCE_H or not np.isfinite(height).any():   # the reference h, or no window: no bulk
        return None
    y = np.asarray(run["windows"]["y"], dtype=float)
    mean_height = float(np.nanmean(height))
    measured = [region["h"] for region in run["regions"].values()]
    where = f"bulk at h = {h:g}" if h is not None else "bulk taken as the central half"
    if not holds_a_bulk(y, mean_height, REFERENCE_H):
        why = (f"the cell (L_y = {mean_height:.3g}) is too thin for h = {REFERENCE_H:g} "
               f"to leave {BULK_MIN_STRIPES} stripes of bulk")
    else:
        why = (f"h = {REFERENCE_H:g} was not measured (measure.boundary_thickness = "
               f"{[float(m) for m in measured]})")
    return f"{where}, not the h = {REFERENCE_H:g} of model.md section 7: {why}"


def profile_warnings(run):
    """Lines on what the profiles miss: a window whose mean height is above the stripes' top
    (a dilated fast flow: measure.stripe_span too small)."""
    y = np.asarray(run["windows"]["y"], dtype=float)
    height = np.asarray(run["windows"]["height"], dtype=float)
    if len(y) < 2 or not np.isfinite(height).any():
        return []
    top = y[-1] + 0.5 * stripe_width(y)
    if np.nanmax(height) <= top:
        return []
    above = int(np.sum(height > top))
    return [f"the stripes stop at y = {top:.4g} below the top wall in {above} window(s) "
            f"(L_y up to {np.nanmax(height):.4g}): the profiles and the top layer miss the "
            f"grains above; rerun with a larger measure.stripe_span"]


def no_window_reason(run, time):
    """The steady_reason of a run without any complete averaging window."""
    t, window = float(run["attrs"]["time"]), float(run["attrs"]["window"])
    if not np.isfinite(t) or t <= 0:
        t = float(time[-1])
    return (f"no complete averaging window (t = {t:.4g} < window {window:.4g})" if t < window
            else f"no complete averaging window in the file (t = {t:.4g}, window {window:.4g})")


def analyze(run):
    """The summary dict of a loaded run (see docs/analysis.md for every key)."""
    a, s, w = run["attrs"], run["series"], run["windows"]
    V, H0, sigma = float(a["velocity"]), float(a["height"]), float(a["normal_stress"])
    mass = float(a.get("inertial_mass", np.pi / 4))
    time = np.asarray(s["time"], dtype=float)
    if len(time) == 0:
        raise RunDataError(run["path"], "no samples in /series yet")
    no_window = len(w["t_start"]) == 0
    strain = 2 * V / H0
    mu_wall, com = wall_friction_series(s), np.asarray(s["com_vx"], dtype=float)
    if no_window:   # too short: nothing from windows, series over the last half (indicative)
        bulk_h, lo, hi = None, np.zeros(0), np.zeros(0)
        bulk_w = {q: np.zeros(0) for q in QUANTITIES}
    else:
        bulk_h, lo, hi = choose_bulk_range(run)
        bulk_w = region_quantities(w, lo, hi, sigma, mass, closed=True)
    u, u_source = rg.block_velocity(s)   # the block's velocity per sample (regime.py)
    if no_window:
        window_signals, balance = {}, None
    else:
        window_signals = {"bulk_mu_eff": bulk_w["mu_eff"],
                          "bulk_solid_fraction": bulk_w["solid_fraction"],
                          "bulk_shear_rate": bulk_w["shear_rate"]}
        bulk_mu = bulk_w["mu_eff"]

        def paired_balance(windows):
            # window by window, the bulk's mu_eff minus the walls' friction of the same window
            # (window_wall_friction, its exact mean forces): paired, so the fluctuations the
            # momentum balance makes the two share leave the error over the windows (the
            # errors of two separate means, combined, were several times too large)
            return (np.asarray(bulk_mu, dtype=float)[windows]
                    - window_wall_friction(w)[windows])
        # not checked in a hand-made file without the windows' wall forces
        balance = (paired_balance if all(k in w for k in ("bottom_force", "top_force"))
                   else None)
    st = detect_steady_state(time, {"mu_wall": mu_wall, "height": s["height"],
                                    "abs_block_vx": np.abs(u)},
                             w["t_start"], window_signals, balance=balance,
                             stationarity_only=("abs_block_vx",),
                             tolerances={"abs_block_vx": rg.BLOCK_SPEED_TOLERANCE * V})
    if no_window:
        st.update(steady=False, reason=no_window_reason(run, time),
                  transient_end_time=np.nan)   # no transient end is claimed
    sel, after = st["windows"], time >= st["averaging_start_time"]

    def series_avg(x):
        b = block_average(np.asarray(x, dtype=float)[after])
        return mean_err(b["mean"], b["err"])

    def win(x):
        return mean_err(*window_mean(np.asarray(x, dtype=float)[sel]))

    # regime: window states, the block velocity, band switches (regime.py)
    table = rg.window_table(w, sel, lo, hi, time, u, V)
    span = (float(st["averaging_start_time"]), float(time[-1]))
    # found over the whole series (each delta_mu stretch stops at the previous switch's end),
    # kept over the averaged span only, as the regime test counts them: before it the block
    # may still wander between the walls' velocities with no band formed
    every_switch = rg.band_switches(time, u, V, source=u_source)
    switches = rg.switches_in(every_switch, *span)
    for sw in switches:
        sw["delta_mu"] = switch_friction_difference(s, time, sw)
    regime, confidence, criteria = rg.classify_run(table, u[after], switches, V, span, u_source)
    if no_window:
        regime, confidence = None, np.nan
        criteria["reason"] = (f"undetermined: {st['reason']}; the window states need a "
                              f"complete window")
    y_range = [float(np.mean(lo[sel])), float(np.mean(hi[sel]))] if len(sel) else [np.nan] * 2
    criteria.update(bulk_h=bulk_h, bulk_y_range=y_range)
    visits_both = rg.visits_both_walls(com, V)
    edges, counts = rg.com_histogram(com[after], V)
    com_block = block_average(com[after])

    def slip(side):
        v, n = np.asarray(w[f"slip_{side}"], float)[sel], w.get(f"slip_{side}_count")
        n = np.ones_like(v) if n is None else np.asarray(n, float)[sel]
        ok = np.isfinite(v) & (n > 0)
        mean = float(np.sum(v[ok] * n[ok]) / np.sum(n[ok])) if ok.any() else np.nan
        return mean_err(mean, window_mean(v)[1])

    regions = {}
    for label, reg in run["regions"].items():
        regions[label] = {"h": reg["h"]}
        for part in ("bulk", "bottom", "top"):
            regions[label][part] = {k[len(part) + 1:]: win(v) for k, v in reg.items()
                                    if k.startswith(part + "_")}
        # regime C: the sheared and the resting layer of each window with a band
        layers = rg.band_layers({k: np.asarray(v, dtype=float)[sel] for k, v in reg.items()
                                 if k.startswith(("bottom_", "top_"))}, table["band_wall"])
        n_band = sum(b is not None for b in table["band_wall"])
        for name, values in zip(("sheared_layer", "resting_layer"), layers):
            regions[label][name] = {q: mean_err(*window_mean(v)) for q, v in values.items()}
            regions[label][name]["windows"] = n_band
    profiles = {"y": np.asarray(w["y"], dtype=float)}
    for field in PROFILE_FIELDS:
        profiles[field] = win(w[field])
    for name, (i, j) in STRESS_COMPONENTS.items():
        profiles[name] = win(w["stress"][..., i, j])
    for part in STRESS_PARTS:
        if part in w:
            for name, (i, j) in (("xy", (0, 1)), ("yy", (1, 1))):
                profiles[f"{part}_{name}"] = win(np.asarray(w[part])[..., i, j])
    get = lambda k, fn: float(fn(s[k])) if k in s and len(s[k]) else np.nan  # noqa: E731

    def per_switch_mean(key):
        """Mean and error of the switches' finite values of `key` (NaN, NaN without any)."""
        values = [sw[key] for sw in switches if np.isfinite(sw[key])]
        return (mean_err(*window_mean(np.array(values, dtype=float))) if values
                else mean_err(np.nan, np.nan))

    # the absolute folder: a run analysed from inside itself ("." or "..") would otherwise
    # record a name that says nothing of which run the summary is (report's identity check)
    return {
        "format": SUMMARY_FORMAT, "version": SUMMARY_VERSION,
        "run_dir": os.path.abspath(run["run_dir"]),
        "case": dict(n=a["n"], velocity=V, normal_stress=sigma, length_x=a["length_x"],
                     height=H0, duration=a.get("duration"), time=a["time"],
                     finished=bool(a.get("finished", 0)), window=a["window"],
                     sample_interval=a.get("sample_interval"),
                     boundary_thickness=a.get("boundary_thickness")),
        "steady": st["steady"], "steady_reason": st["reason"],
        "transient_end_time": st["transient_end_time"],
        "transient_end_strain": st["transient_end_time"] * strain,
        "averaging_start_time": st["averaging_start_time"],
        "averaging_start_strain": st["averaging_start_time"] * strain,
        "truncation_times": st["truncation_times"],
        "independent_samples": st["independent_samples"],
        "drift_sigmas": st["drift_sigmas"],
        "stress_balance": st["stress_balance"],
        "warnings": profile_warnings(run) + ([a["legacy_note"]] if a.get("legacy_note")
                                             else []),
        "steady_windows": len(sel),
        "steady_window_indices": sel,
        "window_errors": (f"standard error over {len(sel)} windows" if len(sel) > 1 else
                          "single window: no error estimate for window quantities (null)"
                          if len(sel) else "no complete window: window quantities are null"),
        "regime": regime, "regime_confidence": confidence, "regime_criteria": criteria,
        "mu_eff_wall": wall_force_ratio(s, ("bottom", "top"), after),
        "mu_eff_wall_bottom": wall_force_ratio(s, ("bottom",), after),
        "mu_eff_wall_top": wall_force_ratio(s, ("top",), after),
        "height": series_avg(s["height"]),
        "solid_fraction": series_avg(s["solid_fraction"]),
        "com_vx": dict(mean=com_block["mean"], err=com_block["err"], std=com_block["std"],
                       histogram=dict(edges=edges, counts=counts),
                       bimodality_coefficient=rg.bimodality_coefficient(com[after]),
                       visits_both_walls=visits_both),
        "bulk": dict(h=bulk_h, y_range=criteria["bulk_y_range"],
                     h_reference=bulk_h == REFERENCE_H, h_note=bulk_h_note(run, bulk_h),
                     **{q: win(bulk_w[q]) for q in QUANTITIES}),
        "slip": {"bottom": slip("bottom"), "top": slip("top")},
        "regions": regions,
        "profiles": profiles,
        "switches": switches,
        "whole_run_switches": rg.whole_run_switches(time, every_switch, s["height"]),
        "profile_decay": profile_decay(
            w, V, run["case"].get("shear", {}).get("initial_velocity", "linear")),
        "switch_duration": per_switch_mean("duration"),
        "switch_time": per_switch_mean("switch_time"),
        "switch_delta_mu": per_switch_mean("delta_mu"),
        "solver": dict(capped_steps=int(np.nansum(s.get("capped_steps", [0]))),
                       steps=int(s["step"][-1]) if "step" in s and len(s["step"]) else 0,
                       max_sweeps=get("sweeps_max", np.nanmax),
                       mean_sweeps=get("sweeps_mean", np.nanmean),
                       max_residual=get("residual_max", np.nanmax),
                       max_overlap=get("overlap_max", np.nanmax)),
    }


def jsonable(obj):
    """numpy -> plain Python, NaN/inf -> None, recursively."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in (obj.tolist() if isinstance(obj, np.ndarray) else obj)]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj


def write_summary(summary, run_dir):
    """Write RUN_DIR/summary.json atomically (temporary file + rename); returns its path."""
    path = os.path.join(run_dir, "summary.json")
    write_text_atomically(path, json.dumps(jsonable(summary), indent=1, allow_nan=False) + "\n")
    return path


def pm(pair):
    """'mean ± err', err to 2 significant digits and the mean to the same decimal."""
    m, e = pair["mean"], pair["err"]
    if m is None or not np.isfinite(m):
        return "n/a"
    if e is None or not np.isfinite(e) or e <= 0:
        return f"{m:.4g} ± ? (no error estimate)"
    decimals = max(0, 1 - math.floor(math.log10(e)))
    return f"{m:.{decimals}f} ± {e:.{decimals}f}"


def format_report(summary, summary_path):
    """The few lines printed at the end of `analyze`."""
    c, crit, b = summary["case"], summary["regime_criteria"], summary["bulk"]
    state = "finished" if c["finished"] else "NOT finished (interrupted or still running)"
    lines = [f"run {summary['run_dir']}: n = {c['n']}, V = {c['velocity']:g}, "
             f"sigma_yy = {c['normal_stress']:g}; t = {c['time']:g} of {c['duration']:g}, {state}"]
    if not summary["steady_windows"]:
        return "\n".join([lines[0]] + _too_short_report(summary) + [f"summary: {summary_path}"])
    if summary["steady"]:
        lines.append(f"steady state from strain {summary['transient_end_strain']:.3g} "
                     f"(t = {summary['transient_end_time']:.4g}); {summary['steady_windows']} "
                     f"windows averaged")
    else:
        lines.append(f"not steady: {summary['steady_reason']}")
        idx = summary["steady_window_indices"]
        lines.append(f"  values below are only indicative: series over the last half (t >= "
                     f"{summary['averaging_start_time']:.4g}), windows {idx[0]}-{idx[-1]}")
        lines.append(_continue_hint(summary))
    lines.append(rg.report_line(summary["regime"], summary["regime_confidence"], crit,
                                len(summary["switches"])))
    where = f"h = {b['h']:g}" if b["h"] is not None else "central half"
    lo, hi = b["y_range"]
    if b.get("h_note"):
        lines.append(f"note: {b['h_note']}")
    lines += [f"bulk ({where}, {lo:.3g} <= y <= {hi:.3g}):",
              f"  I_bulk        = {pm(b['inertial_number'])}",
              f"  mu_eff bulk   = {pm(b['mu_eff'])}",
              f"  mu_eff walls  = {pm(summary['mu_eff_wall'])}",
              f"  nu bulk       = {pm(b['solid_fraction'])}",
              f"  Z bulk        = {pm(b['coordination'])}",
              f"  slip velocity   bottom {pm(summary['slip']['bottom'])}, "
              f"top {pm(summary['slip']['top'])}"]
    lines += sweep_cap_warning(summary["solver"])
    lines += [f"warning: {text}" for text in summary.get("warnings", [])]
    lines.append(f"summary: {summary_path}")
    return "\n".join(lines)


# Share of steps at the sweep cap from which the report says what it costs: on system 7 in its
# slow phase without the slab correction, 27% (alpha 1e-5) and 79% (1e-6) of the steps at the cap
# of 200 left 2.6% and 4.3% of the force-carrying contacts open against a converged solve; with
# it (a shear default in cells of 20 bands or more) they come within 0.3 to 1.1%
# (docs/step-error.md, "Tall cells"). System 1's runs, with 2 to 10% at the cap, gave the same Z at
# both tolerances. Those shares were measured before the plain finish (docs/performance.md), which
# leaves 0 to 2% of the steps at the cap where they had up to 81%: a run written since counts only
# the steps capped after it.
CAPPED_SHARE_WARNING = 0.15


def sweep_cap_warning(solver):
    """The report's lines on the steps that hit the sweep cap (none when no step did)."""
    capped, steps = solver["capped_steps"], solver.get("steps", 0)
    if not capped:
        return []
    if not steps:
        return [f"warning: {capped} steps hit the sweep cap"]
    share = capped / steps
    lines = [f"warning: {capped} of {steps} steps ({share:.1%}) hit the sweep cap"]
    if share >= CAPPED_SHARE_WARNING:
        lines.append("  with so many steps at the cap the contact forces are not converged: the "
                     "count of force-carrying contacts moves first (docs/step-error.md, \"Tall "
                     "cells\"); a stretch rerun with a tighter solver.alpha and a larger "
                     "solver.max_sweeps tells how far")
    return lines


def _continue_hint(summary):
    """How to extend the run towards a steady state: resume it with a longer duration."""
    c = summary["case"]
    longer = max(2.0 * c["time"], c["time"] + 4.0 * c.get("window", 80.0))
    return (f"  to continue it towards a steady state: cdshear run --resume {summary['run_dir']} "
            f"--set shear.duration={longer:.0f}")


def _too_short_report(summary):
    """The report's lines for a run without any complete averaging window."""
    com, crit = summary["com_vx"], summary["regime_criteria"]
    V = summary["case"]["velocity"]
    f = crit["com_fraction"]
    f = "n/a" if f is None or not np.isfinite(f) else f"{f:.0%}"
    com_v = {k: (com[k] / V if com[k] is not None and np.isfinite(com[k]) else np.nan)
             for k in ("mean", "err")}
    lines = [f"not steady: run too short for steady state, {summary['steady_reason']}",
             "  no profiles, bulk, boundary layers, slip or regime (they need a complete window);",
             f"  the values below are from the series over the last half (t >= "
             f"{summary['averaging_start_time']:.4g}) and only indicative",
             _continue_hint(summary),
             "regime undetermined",
             f"  mu_eff walls  = {pm(summary['mu_eff_wall'])}",
             f"  L_y           = {pm(summary['height'])}",
             f"  nu (global)   = {pm(summary['solid_fraction'])}",
             f"  com_vx / V    = {pm(com_v)}, "
             f"|{crit.get('block_velocity_source', 'com_vx')}| > V/2 in {f} of samples"]
    lines += sweep_cap_warning(summary["solver"])
    return lines

"""Figures of one run (docs/model.md section 9), PNG via matplotlib's Agg backend.

snapshot.png              disks (coloured by v_x / V) and force chains (width ~ normal force)
velocity_profiles.png     v_x / V against y for several windows, coloured by strain
com_velocity.png          com_vx / V (and block_vx / V) against strain, com_vx's histogram
height_solid_fraction.png L_y and global solid fraction against strain, transient end marked
steady_profiles.png       mu_eff, nu, I, Z profiles averaged over the steady windows
Strain is 2 V t / L_y with the nominal L_y; lengths in d (largest diameter). Across runs,
`plot_profile_decay` draws the figure of `profile-decay --plot` (relaxation.py).
A run without any complete averaging window gets the figures of its series and snapshot; the
two profile figures are skipped (plot_run reports them in `skipped`).
"""
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import EllipseCollection, LineCollection  # noqa: E402

from .rundata import RunDataError, run_files_in, save_figure, what_is  # noqa: E402

DPI = 120
MAX_PROFILES = 10          # velocity profiles drawn at most
FORCE_LINE_WIDTH = 2.5     # points, for the FORCE_PERCENTILE-th percentile of the normal forces
FORCE_PERCENTILE = 95      # (widths proportional to the force ...
FORCE_LINE_WIDTH_MAX = 6.0  # ... capped here: rigid contacts have rare huge instantaneous forces)
SERIES_BINS = 2000         # a series line keeps each bin's lowest and highest sample (_envelope)


def _title(run, summary, what):
    a = run["attrs"]
    head = f"n = {a['n']}, V = {a['velocity']:g}, $\\sigma_{{yy}}$ = {a['normal_stress']:g}: {what}"
    if not summary["steady_windows"]:
        head += ("\nTOO SHORT (no complete averaging window): last half shown as averaged, "
                 "indicative")
    elif not summary["steady"]:
        head += "\nNOT STEADY: last half of the run shown as averaged"
    return head


def _regime_text(summary):
    regime, confidence = summary["regime"], summary["regime_confidence"]
    if regime is None:
        return "regime undetermined"
    if confidence is None or not np.isfinite(confidence):
        return f"regime {regime}"
    return f"regime {regime} ({confidence:.0%} of the window time agrees)"


class SkipFigure(Exception):
    """A figure that this run cannot have (the message says why)."""


def _need_windows(run, summary):
    if len(run["windows"]["t_start"]) == 0:
        raise SkipFigure(f"no profiles to draw: {summary['steady_reason']}")


def _mark_transient(ax, summary):
    """Vertical line at the transient end (or where the averaging starts when not steady)."""
    g = summary["transient_end_strain"]
    if summary["steady"] and np.isfinite(g):
        x, text, style = g, f" transient end (strain {g:.3g})", dict(color="crimson", ls="--")
    else:
        x, text, style = summary["averaging_start_strain"], " averaged from (not steady)", \
            dict(color="0.4", ls=":")
    ax.axvline(x, lw=1, **style)
    ax.text(x, 0.98, text, transform=ax.get_xaxis_transform(), va="top", fontsize=8,
            color=style["color"])


def _envelope(x, y, bins=SERIES_BINS):
    """The points of a time series line that a figure can show: the series cut into `bins` bins of
    consecutive samples, each bin replaced by its lowest and highest sample, in time order.

    A figure is about 1000 pixels wide, so a 20000-t run's 200 000 samples put about 200 in each
    pixel column, and the line drawn there spans their lowest to their highest value: keeping the
    two extremes of every bin (at least two bins per pixel column) draws the same band, while
    matplotlib no longer builds paths of every sample (the series figures of that run took 55 MB
    of the plot's 182 MB peak). Series of at most 2 * bins samples are returned as they are. NaN
    samples are kept out of the extremes; only a bin of NaN alone gives NaN (a gap), so gaps
    shorter than a bin are not drawn."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = len(y)
    if n <= 2 * bins:
        return x, y
    edges = np.linspace(0, n, bins + 1).astype(int)
    xs, ys = np.empty(2 * bins), np.empty(2 * bins)
    for b in range(bins):
        lo, hi = edges[b], edges[b + 1]
        seg = y[lo:hi]
        if np.all(np.isnan(seg)):
            xs[2 * b:2 * b + 2], ys[2 * b:2 * b + 2] = x[lo], np.nan
            continue
        i, j = lo + np.nanargmin(seg), lo + np.nanargmax(seg)
        first, second = (i, j) if i <= j else (j, i)
        xs[2 * b], ys[2 * b] = x[first], y[first]
        xs[2 * b + 1], ys[2 * b + 1] = x[second], y[second]
    return xs, ys


def snapshot(run, summary):
    snap = run["snapshot"]
    if snap is None or "x" not in snap:
        raise RunDataError(run["path"], "missing group /snapshot (needed for snapshot.png)")
    lx = float(snap.get("length_x", run["attrs"]["length_x"]))
    height = float(snap.get("height", run["attrs"]["height"]))
    V = float(run["attrs"]["velocity"])
    scale = min(8.0 / lx, 14.0 / (height + 2))
    fig, ax = plt.subplots(figsize=(lx * scale + 2.0, (height + 2) * scale + 1.0))
    x, y, r = (np.asarray(snap[k], dtype=float) for k in ("x", "y", "radius"))
    x = np.mod(x, lx)
    force = np.asarray(snap.get("contact_normal_force", []), dtype=float)
    segments = np.stack([np.column_stack([snap["contact_ax"], snap["contact_ay"]]),
                         np.column_stack([snap["contact_bx"], snap["contact_by"]])], axis=1) \
        if len(force) else np.zeros((0, 2, 2))
    segments[:, :, 0] -= lx * np.floor(segments[:, :1, 0] / lx)   # a's centre into [0, L_x)
    scale = np.percentile(force, FORCE_PERCENTILE) if len(force) else 0.0
    widths = (np.minimum(FORCE_LINE_WIDTH * force / scale, FORCE_LINE_WIDTH_MAX)
              if scale > 0 else 1.0)
    for shift in (-lx, 0.0, lx):   # periodic images, clipped by the axes
        disks = EllipseCollection(2 * r, 2 * r, 0, units="xy",
                                  offsets=np.column_stack([x + shift, y]),
                                  offset_transform=ax.transData, cmap="coolwarm",
                                  edgecolors="0.4", linewidths=0.3, alpha=0.6)
        disks.set_array(np.asarray(snap["vx"], dtype=float) / V)
        disks.set_clim(-1, 1)
        ax.add_collection(disks)
        ax.add_collection(LineCollection(segments + [shift, 0], linewidths=widths, colors="k"))
    for wall_y in (0.0, height):
        ax.axhline(wall_y, color="0.2", lw=3)
    fig.colorbar(disks, ax=ax, label="$v_x / V$", shrink=0.8)
    ax.set(xlim=(0, lx), ylim=(-1, height + 1), aspect="equal", xlabel="x / d", ylabel="y / d")
    ax.set_title(_title(run, summary, f"t = {float(snap.get('time', np.nan)):g}, "
                 f"{len(force)} force-carrying contacts"), fontsize=9)
    return fig


def velocity_profiles(run, summary):
    _need_windows(run, summary)
    w, a = run["windows"], run["attrs"]
    V, strain = float(a["velocity"]), 2 * float(a["velocity"]) / float(a["height"])
    n_windows = len(w["t_start"])
    picks = np.unique(np.linspace(0, n_windows - 1, min(MAX_PROFILES, n_windows)).round()
                      .astype(int))
    norm = plt.Normalize(0, max(w["t_end"][-1] * strain, 1e-12))
    cmap = plt.get_cmap("viridis")
    fig, ax = plt.subplots(figsize=(6, 5))
    for k in picks:
        ok = np.isfinite(w["vx"][k])
        ax.plot(w["vx"][k][ok] / V, w["y"][ok], color=cmap(norm(w["t_end"][k] * strain)), lw=1.5)
    prof = summary["profiles"]
    ok = np.isfinite(prof["vx"]["mean"])
    ax.errorbar(prof["vx"]["mean"][ok] / V, prof["y"][ok],
                xerr=np.nan_to_num(prof["vx"]["err"][ok]) / V,
                color="k", ls="--", lw=1.5, elinewidth=0.8, capsize=2,
                label="steady mean" if summary["steady"] else "mean, last half")
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax,
                 label="strain $2Vt/L_y$ at the window end")
    ax.axvline(-1, color="0.6", lw=0.8)
    ax.axvline(1, color="0.6", lw=0.8)
    ax.set(xlabel="$v_x / V$", ylabel="y / d", xlim=(-1.2, 1.2))
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(_title(run, summary, f"{len(picks)} of {n_windows} window profiles"), fontsize=9)
    return fig


def _velocity_limits(series):
    """y limits of velocities in units of V: -1.25 to 1.35 (-V to +V, room for a label above),
    widened to every finite value of `series` (arrays) with a 5% margin, so that overshoots past
    the walls' velocities are drawn rather than cut."""
    values = np.concatenate([np.asarray(v, dtype=float).ravel() for v in series] or [[]])
    values = values[np.isfinite(values)]
    if not values.size:
        return -1.25, 1.35
    return min(-1.25, 1.05 * values.min()), max(1.35, 1.05 * values.max() + 0.1)


def com_velocity(run, summary):
    s, a = run["series"], run["attrs"]
    V, strain = float(a["velocity"]), 2 * float(a["velocity"]) / float(a["height"])
    fig, (ax, side) = plt.subplots(1, 2, figsize=(9, 4), sharey=True,
                                   gridspec_kw=dict(width_ratios=[4, 1], wspace=0.05))
    com = _envelope(np.asarray(s["time"]) * strain, np.asarray(s["com_vx"]) / V)
    ax.plot(*com, lw=0.5, color="tab:blue", label="centre of mass")
    shown = [com[1]]
    if "block_vx" in s:     # the block (central half) the regime classifier reads
        block = _envelope(np.asarray(s["time"]) * strain, np.asarray(s["block_vx"]) / V)
        ax.plot(*block, lw=0.5, color="tab:orange", alpha=0.8, label="block (central half)")
        shown.append(block[1])
        ax.legend(loc="lower left", fontsize=7)
    for level in (-0.5, 0.5):
        ax.axhline(level, color="0.5", ls=":", lw=0.8)
    _mark_transient(ax, summary)
    ax.set(xlabel="strain $2Vt/L_y$", ylabel="$v_{x,\\mathrm{com}} / V$",
           ylim=_velocity_limits(shown))
    hist = summary["com_vx"]["histogram"]
    edges, counts = np.asarray(hist["edges"]) / V, np.asarray(hist["counts"], dtype=float)
    side.barh(0.5 * (edges[1:] + edges[:-1]), counts / max(counts.sum(), 1), height=np.diff(edges),
              color="tab:blue", alpha=0.7)
    side.set(xlabel="fraction")
    fig.suptitle(_title(run, summary, f"{_regime_text(summary)}, "
                 f"{len(summary['switches'])} band switches"), fontsize=9)
    return fig


def height_solid_fraction(run, summary):
    s, a = run["series"], run["attrs"]
    strain = 2 * float(a["velocity"]) / float(a["height"])
    g = np.asarray(s["time"]) * strain
    fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    for ax, key, label in ((axes[0], "height", "$L_y$ / d"),
                           (axes[1], "solid_fraction", "solid fraction")):
        ax.plot(*_envelope(g, s[key]), lw=0.5, color="tab:green")
        mean = summary[key]["mean"]
        if mean is not None and np.isfinite(mean):
            ax.axhline(mean, color="k", lw=0.8, label=f"mean {mean:.4g}")
        _mark_transient(ax, summary)
        ax.set_ylabel(label)
        ax.legend(loc="best", fontsize=8)  # clear of the series, whichever way it runs
    axes[1].set_xlabel("strain $2Vt/L_y$")
    axes[0].set_title(_title(run, summary, "height and global solid fraction"), fontsize=9)
    return fig


def steady_profiles(run, summary):
    _need_windows(run, summary)
    prof, y = summary["profiles"], summary["profiles"]["y"]
    height = summary["height"]["mean"]
    fig, axes = plt.subplots(2, 2, figsize=(8, 7), sharey=True)
    panels = (("mu_eff", "$\\mu_\\mathrm{eff}$"), ("solid_fraction", "solid fraction $\\nu$"),
              ("inertial_number", "inertial number $I$"), ("coordination", "coordination $Z$"))
    for ax, (key, label) in zip(axes.flat, panels):
        ok = np.isfinite(prof[key]["mean"]) & (y < height)
        ax.errorbar(prof[key]["mean"][ok], y[ok], xerr=np.nan_to_num(prof[key]["err"][ok]),
                    fmt="o-", ms=3, lw=1, capsize=2)
        for i, region in enumerate(run["regions"].values()):
            h = region["h"]
            if h < height:
                style = dict(color=f"C{i + 1}", ls="--", lw=0.8)
                ax.axhline(h, label=f"h = {h:g}", **style)
                ax.axhline(height - h, **style)
        ax.set_xlabel(label)
    mu_wall = summary["mu_eff_wall"]["mean"]
    if mu_wall is not None and np.isfinite(mu_wall):
        axes[0, 0].axvline(mu_wall, color="k", lw=0.8, ls=":", label="walls")
    axes[0, 0].legend(fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel("y / d")
    idx, w = summary["steady_window_indices"], run["windows"]
    what = (f"profiles over {len(idx)} window(s), t = {w['t_start'][idx[0]]:.4g} "
            f"to {w['t_end'][idx[-1]]:.4g}")
    fig.suptitle(_title(run, summary, what), fontsize=9)
    return fig


FIGURES = {"snapshot.png": snapshot, "velocity_profiles.png": velocity_profiles,
           "com_velocity.png": com_velocity, "height_solid_fraction.png": height_solid_fraction,
           "steady_profiles.png": steady_profiles}


def check_figure_folder(run_dir, out_dir):
    """Raises RunDataError when out_dir is another run's folder or that run's figures/ folder:
    the figures written there would replace that run's own (its figures/ is where `cdshear sweep`
    looks for them), or a campaign's runs/ folder or a new folder in it (a report reads each folder
    there as a run's), or something other than a folder (a file, /dev/null, a link that leads
    nowhere or into a loop). The run's own folder and anything else are accepted."""
    if os.path.lexists(out_dir) and not os.path.isdir(out_dir):
        raise RunDataError(out_dir, f"-o: is {what_is(out_dir)}, not a folder")
    own = os.path.realpath(run_dir)
    where = os.path.realpath(out_dir)
    for runs in (where, os.path.dirname(where)):
        if os.path.basename(runs) == "runs" and where != own and \
                os.path.isfile(os.path.join(os.path.dirname(runs), "campaign.toml")):
            raise RunDataError(out_dir, f"-o: is {'' if runs == where else 'in '}a campaign's "
                                        f"runs folder ({runs}), where `cdshear report` reads "
                                        f"each folder as a run's; choose another -o (default: "
                                        f"{os.path.join(run_dir, 'figures')})")
    for folder in (where, os.path.dirname(where)):
        if folder == own:
            continue
        if found := run_files_in(folder):
            whose = "is another run's folder" if folder == where else \
                "is in another run's folder"
            raise RunDataError(out_dir, f"-o: {whose} ({folder} holds {', '.join(found)}): "
                                        f"this run's figures would replace that run's; choose "
                                        f"another -o (default: "
                                        f"{os.path.join(run_dir, 'figures')})")


def plot_run(run, summary, out_dir, skipped=None, failed=None):
    """Write every figure the run can have into out_dir; returns the paths written. Figures it
    cannot have (the profiles of a run without a complete window) are appended to `skipped`
    (when given) as (file name, reason). A figure that cannot be written raises its OSError, or,
    with a list `failed`, is appended to it (the OSError) and the other figures are written."""
    summary = _arrays(summary)
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as e:
        raise RunDataError(out_dir, f"cannot create the figure folder: {e.strerror or e}")
    written = []
    for name, make in FIGURES.items():
        path = os.path.join(out_dir, name)
        try:
            fig = make(run, summary)
        except SkipFigure as e:
            if skipped is not None:
                skipped.append((name, str(e)))
            continue
        # Written whole or not at all (temporary file + rename): a sweep that finds a figure
        # takes it for complete (sweep_command.cpp, analysis_incomplete).
        try:
            save_figure(fig, path, dpi=DPI, bbox_inches="tight")
        except OSError as e:
            if failed is None:
                raise
            failed.append(e)
            continue
        finally:
            plt.close(fig)
        written.append(path)
    return written


def _arrays(summary):
    """Profiles as float arrays (NaN for missing) whatever the summary came from."""
    prof = {"y": np.asarray(summary["profiles"]["y"], dtype=float)}
    for k, v in summary["profiles"].items():
        if k != "y":
            prof[k] = {e: np.asarray(v[e], dtype=float) for e in ("mean", "err")}
    return dict(summary, profiles=prof)


def plot_profile_decay(summaries, entries, path):
    """profile-decay --plot: each run's coefficient along its decaying shape, less the fitted
    c_inf (relaxation.py), against t / T_SS on a log scale, with its fitted exponential and the
    slopes of the two walls' slowest modes from rest, exp(-4 pi^2 t / T_SS) and exp(-pi^2 t /
    T_SS), over the fit's range. The used runs alone (decay_against_diffusion's `used`: their
    series checked, their fits resolved); ValueError when there is none."""
    from .relaxation import TAU_OVER_T_SS
    used = [(s.get("profile_decay"), e) for s, e in zip(summaries, entries) if e["used"]]
    if not used:
        raise ValueError("no run is used (each row of the table says why): no figure to draw")
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    bounds_drawn, low, high = False, np.inf, 0.0
    for d, e in used:
        t = np.asarray(d["t"], dtype=float)
        c = np.asarray([np.nan if v is None else v for v in d["c"]], dtype=float) - d["c_inf"]
        label = f"{e['run']} (L_y {e['L_y']:.0f}): tau / T_SS {e['tau_over_T_SS']:.3f}"
        positive = np.where(c > 0, c, np.nan)
        points = ax.plot(t / e["T_SS"], positive, ".", ms=3, label=label)[0]
        if np.isfinite(positive).any():
            low, high = min(low, np.nanmin(positive)), max(high, np.nanmax(positive))
        t0, t1 = e["fit_range"]
        x = np.linspace(t0, t1, 100)
        ax.plot(x / e["T_SS"], d["c_0"] * np.exp(-(x - t0) / e["tau"]), "-", lw=1,
                color=points.get_color())
        for (mode, ratio), style in zip(TAU_OVER_T_SS.items(), (":", "--")):
            ax.plot(x / e["T_SS"], d["c_0"] * np.exp(-(x - t0) / (ratio * e["T_SS"])), style,
                    lw=0.8, color="k",
                    label=None if bounds_drawn else f"slowest mode {mode}: tau / T_SS {ratio:.4f}")
        bounds_drawn = True
    ax.set_yscale("log")
    if high > 0:
        ax.set_ylim(low / 3, high * 2)
    ax.set_xlabel("t / T_SS   (T_SS = L_y^2 / D, D from the bulk law)")
    ax.set_ylabel("c - c_inf: distance from the steady profile / V")
    ax.set_title("Velocity profile's decay towards steady state")
    # Below the axes: inside, it covered the thin cells' late points.
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    fig.tight_layout()
    save_figure(fig, path, dpi=DPI, bbox_inches="tight")
    plt.close(fig)

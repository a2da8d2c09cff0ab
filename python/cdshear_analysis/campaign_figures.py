"""The figures of a campaign report (docs/model.md section 9, across runs), written by
report.write_report.

Bulk laws (mu_eff_I, nu_I, Z_I) and slip against V with their fits; the regime diagram; the
boundary laws (boundary_mu_I, boundary_mu_hI, boundary_nu_I, boundary_nu_ratio, boundary_Z_I)
and the bulk law for each h (bulk_mu_by_h); switch time / V against L_y (switch_time); and per
system the steady velocity and mu_eff profiles of every V (profiles_sK). Every point has its
error bars (standard errors of `analyze`); open markers are runs that are not steady, crosses
steady runs outside the regimes a law is fitted to (regime B and C runs on the bulk laws). Every
fitted law is drawn (fitting.fitted), its legend saying its status when that is not "ok"
("poor", "undetermined"); a skipped law is not drawn. In the regime diagram a run whose regime is
none of A, B, C (undecided, intermittent, ...) is a grey diamond labelled with its regime, a run
without a regime a grey cross.
"""
import os
import textwrap

import numpy as np

from . import fitting
from .boundary_laws import h_label, layer_points, profile_crossing
from .rundata import save_figure

FIGURES = [
    ("mu_eff_I.png", "mu_eff (bulk) against I_bulk", "I_bulk", "mu_eff_bulk",
     ["mu_power", "mu_linear"]),
    ("nu_I.png", "solid fraction nu (bulk) against I_bulk", "I_bulk", "nu_bulk", ["nu_linear"]),
    ("Z_I.png", "coordination Z (bulk) against I_bulk", "I_bulk", "Z_bulk", ["Z_power"]),
    ("slip_V.png", "slip velocity at each wall against V", "V", None, []),
]


AXIS_LABELS = {"V": "wall velocity V [d/t]", "I_bulk": "bulk inertial number I"}


def _label_log_axis(ax, values=()):
    """A log x axis spanning less than two decades shows one labelled tick or none: label 1, 2
    and 5 of every decade instead, in plain numbers; 1 to 9 where that gives fewer than two ticks
    in view, and the plotted values themselves where even that does (matplotlib would otherwise
    fall back to dense linear ticks whose labels run into each other)."""
    from matplotlib.ticker import (FixedLocator, FormatStrFormatter, LogLocator,
                                   NullFormatter)
    lo, hi = ax.get_xlim()
    if hi / lo >= 100:
        return
    decades = range(int(np.floor(np.log10(lo))), int(np.ceil(np.log10(hi))) + 1)
    locator = None
    for subs in ((1.0, 2.0, 5.0), tuple(float(k) for k in range(1, 10))):
        # counted here: LogLocator itself turns to linear ticks when one or none is in view
        if sum(lo <= s * 10.0**e <= hi for e in decades for s in subs) >= 2:
            locator = LogLocator(base=10, subs=subs)
            break
    if locator is None:
        locator = FixedLocator(sorted({float(v) for v in values if lo <= v <= hi}))
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(NullFormatter())


BULK_LAWS = ("mu_power", "mu_linear", "nu_linear", "Z_power")   # report.FITS, fitted on bulk_rows


def _plot(path, title, xcol, ycol, fit_names, rows, fits):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5.5, 4.0))
    systems = sorted({r["system"] for r in rows}, key=lambda s: (s is None, s or 0))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    series = [(ycol, "", "o")] if ycol else [("slip_bottom", " bottom", "v"),
                                             ("slip_top", " top", "^")]
    plotted = False
    xs_all = []
    # runs outside the regimes the fits take (bulk laws: A only) are drawn as crosses
    regimes = next((fits[f].get("regimes") for f in fit_names if fits.get(f)), None)
    kinds = [("steady", True, ""), ("not steady", False, " (not steady)")]
    if regimes:
        kinds.insert(1, ("other regime", True, f" (regime not {'/'.join(regimes)}, not fitted)"))
    # the bulk laws take only runs whose bulk is at h = 10 (report.bulk_rows): others as "+"
    bulk_law = any(f in BULK_LAWS for f in fit_names)
    if bulk_law:
        kinds.insert(1, ("thin", True, " (bulk not at h = 10, not fitted)"))

    def kind_of(r):
        if not r["steady"]:
            return "not steady"
        if regimes and r.get("regime") not in regimes:
            return "other regime"
        if bulk_law and r.get("bulk_h_reference") is not True:
            return "thin"
        return "steady"
    for i, system in enumerate(systems):
        c = colours[i % len(colours)]
        for col, label, marker in series:
            for kind, steady, suffix in kinds:
                sel = [r for r in rows if r["system"] == system and r[xcol] is not None and
                       r[col] is not None and kind_of(r) == kind]
                if not sel:
                    continue
                x = [r[xcol] for r in sel]
                xs_all += x
                yerr = [r[col + "_err"] or 0.0 for r in sel]
                xerr = [r.get(xcol + "_err") or 0.0 for r in sel]
                name = f"system {system}" if system is not None else "other runs"
                ax.errorbar(x, [r[col] for r in sel], yerr=yerr, xerr=xerr,
                            fmt={"other regime": "x", "thin": "+"}.get(kind, marker), color=c,
                            mfc=c if kind == "steady" else "none", capsize=2, ms=5,
                            label=f"{name}{label}{suffix}")
                plotted = True
    for j, fname in enumerate(fit_names):
        f = fits.get(fname)
        if not fitting.fitted(f):
            continue
        _curve(ax, f, _fitted_x(rows, f, xcol) or xs_all, "-" if j == 0 else "--",
               f"{fname}: {f['law']}")
    if not plotted:
        ax.text(0.5, 0.5, "no values", ha="center", va="center", transform=ax.transAxes)
    elif min(xs_all) > 0 and max(xs_all) / min(xs_all) >= 10:
        ax.set_xscale("log")
        _label_log_axis(ax, xs_all)
    ax.set_xlabel(AXIS_LABELS.get(xcol, xcol))
    ax.set_ylabel(ycol or "slip velocity [d/t]")
    ax.set_title(title, fontsize=9)
    if plotted:
        ax.legend(fontsize=6)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


REGIME_MARKERS = {"A": ("o", "tab:red"), "B": ("s", "tab:blue"), "C": ("^", "tab:green"),
                  "other": ("D", "0.55"), None: ("x", "0.4")}


def _plot_regimes(path, rows, transitions):
    """The regime diagram: V (log) against system, one marker per run (seeds side by side),
    open when not steady; the V_AB and V_BC brackets as bars, their estimates as ticks."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    systems = sorted({r["system"] for r in rows if r["system"] is not None})
    fig, ax = plt.subplots(figsize=(6.0, 1.2 + 0.6 * max(1, len(systems))))
    seen = set()
    others = set()   # the regime labels other than A, B, C
    vs = []
    for i, system in enumerate(systems):
        sel = [r for r in rows if r["system"] == system and r["V"] is not None and r["V"] > 0]
        seeds = sorted({r["seed"] for r in sel if r["seed"] is not None})
        for r in sel:
            k = seeds.index(r["seed"]) if r["seed"] in seeds else 0
            y = i + 0.12 * (k - (len(seeds) - 1) / 2)
            g = r.get("regime")
            if g is not None and g not in ("A", "B", "C"):
                others.add(str(g))
                g = "other"
            marker, colour = REGIME_MARKERS[g]
            seen.add(g)
            ax.plot([r["V"]], [y], marker, color=colour, ms=7,
                    mfc=colour if r["steady"] or marker == "x" else "none")
            vs.append(r["V"])
        t = transitions.get(str(system), {})
        for key, dy, ls in (("V_AB", 0.3, "-"), ("V_BC", -0.3, "--")):
            b = t.get(key)
            if not b or b["estimate"] is None:
                continue
            lo, hi = b["bracket"]
            ax.plot([lo, hi], [i + dy] * 2, ls, color="k", lw=1)
            ax.plot([b["estimate"]], [i + dy], "|", color="k", ms=10)
            ax.annotate(key, (b["estimate"], i + dy), fontsize=6, xytext=(3, 2),
                        textcoords="offset points")
    if vs:
        ax.set_xscale("log")
        ax.set_xlim(min(vs) / 1.6, max(vs) * 1.6)
        _label_log_axis(ax, vs)
        names = {None: "no regime", "other": "regime " + ", ".join(sorted(others))}
        handles = [ax.plot([], [], REGIME_MARKERS[g][0], color=REGIME_MARKERS[g][1], ms=7,
                           label=names.get(g, f"regime {g}"))[0]
                   for g in ("A", "B", "C", "other", None) if g in seen]
        ax.legend(handles=handles, fontsize=6, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    else:
        ax.text(0.5, 0.5, "no runs", ha="center", va="center", transform=ax.transAxes)
    ax.set_yticks(range(len(systems)), [f"system {s}" for s in systems])
    ax.set_ylim(-0.6, max(1, len(systems)) - 0.4)
    ax.set_xlabel(AXIS_LABELS["V"])
    ax.set_title("regime diagram\n(open: not steady; open and grey markers do not vote;\n"
                 "bars: V_AB above, V_BC below)", fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------
# Boundary layers, h, switches, profiles

# Legends of more entries than this go beside the axes.
LEGEND_INSIDE_MAX = 10
H_MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*"]
H_STYLES = ["-", "--", ":", "-."]


def _figure(size=(5.5, 4.0), columns=1):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, columns, figsize=size, sharey=columns > 1)
    return plt, fig, ax


def _finish(plt, fig, ax, path, title, xlabel, ylabel, xs, legend=True):
    if not xs:
        ax.text(0.5, 0.5, "no values", ha="center", va="center", transform=ax.transAxes)
    elif min(xs) > 0 and max(xs) / min(xs) >= 10:
        ax.set_xscale("log")
        _label_log_axis(ax, xs)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    # Titles longer than the axes are wrapped rather than cut at the figure's edge.
    ax.set_title(textwrap.fill(title, 64), fontsize=9)
    outside = False
    if xs and legend:
        # Many entries (one per system and h, and the fits) hide the points inside the axes:
        # beside them, the figure widened by the legend's width.
        outside = len(ax.get_legend_handles_labels()[0]) > LEGEND_INSIDE_MAX
        if outside:
            box = ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0))
            fig.canvas.draw()  # the legend's size, to widen the figure by it
            extra = box.get_window_extent().width / fig.dpi + 0.2
            fig.set_size_inches(fig.get_figwidth() + extra, fig.get_figheight())
        else:
            ax.legend(fontsize=6)
    fig.tight_layout()
    save_figure(fig, path, dpi=110, bbox_inches="tight" if outside else None)
    plt.close(fig)


def _fitted_x(rows, fit, xcol):
    """x of the rows a fit took: its curve spans those, not the runs of other regimes."""
    runs = set((fit or {}).get("runs") or [])
    return [r[xcol] for r in rows if r.get("run") in runs and (r.get(xcol) or 0) > 0]


def _curve(ax, fit, xs, style, label):
    """The fit's curve over the points' x range (inside its own range), if it was fitted; the
    label says the status when it is not "ok"."""
    xs = [x for x in xs if x > 0]
    if not fitting.fitted(fit) or not xs:
        return
    if fit["status"] != "ok":
        label += f" [{fit['status']}]"
    lo, hi = fit["range"] if fit["range"] else (min(xs), max(xs))
    grid = np.geomspace(max(lo, min(xs)), min(hi, max(xs)), 200)
    ax.plot(grid, fitting.curve(fit, grid), style, color="k", lw=1, label=label)


def _mu_0_line(ax, fits):
    f = fits.get("mu_power")
    if fitting.usable(f):
        mu_0 = f["parameters"]["mu_0"]["value"]
        ax.axhline(mu_0, color="0.5", lw=0.8, ls=":", label=f"bulk mu_0 = {mu_0:.3g}")


def boundary_law_figure(path, rows, boundary, y, ylabel, law, fits=None):
    """A boundary-layer quantity against I_boundary: colour per system, marker per h, the law
    of each h."""
    plt, fig, ax = _figure()
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    systems = sorted({r["system"] for r in rows if r.get("system") is not None})
    xs = []
    for k, h in enumerate(boundary["thicknesses"]):
        pts = layer_points(rows, h)
        for i, system in enumerate(systems):
            sel = [p for p in pts if p["system"] == system and p[y] is not None]
            if not sel:
                continue
            xs += [p["I"] for p in sel]
            ax.errorbar([p["I"] for p in sel], [p[y] for p in sel],
                        yerr=[p[y + "_err"] or 0 for p in sel], fmt=H_MARKERS[k % 8],
                        color=colours[i % len(colours)], ms=4, capsize=2,
                        label=f"system {system}, h = {h:g}")
        _curve(ax, boundary[h_label(h)][law], [p["I"] for p in pts], H_STYLES[k % 4],
               f"h = {h:g}: {boundary[h_label(h)][law]['law']}")
    if fits is not None:
        _mu_0_line(ax, fits)
    _finish(plt, fig, ax, path, f"{ylabel} of the boundary layers (sheared layers of steady "
            "runs)", "boundary inertial number I_boundary", ylabel, xs)


def boundary_collapse_figure(path, rows, boundary, fits):
    """mu_eff of the layers against h I_boundary: colour per regime, marker per h, the pooled
    laws of B and C and of A (model.md section 8: B and C collapse in h I, A does not)."""
    plt, fig, ax = _figure()
    xs = {"BC": [], "A": []}
    for k, h in enumerate(boundary["thicknesses"]):
        pts = layer_points(rows, h)
        for g in ("A", "B", "C"):
            sel = [p for p in pts if p["regime"] == g and p["mu"] is not None]
            if not sel:
                continue
            xs["A" if g == "A" else "BC"] += [p["hI"] for p in sel]
            ax.errorbar([p["hI"] for p in sel], [p["mu"] for p in sel],
                        yerr=[p["mu_err"] or 0 for p in sel], fmt=H_MARKERS[k % 8],
                        color=REGIME_MARKERS[g][1], ms=4, capsize=2,
                        label=f"regime {g}, h = {h:g}")
    all_h = boundary["all_h"]
    _curve(ax, all_h["mu_hI_BC"], xs["BC"], "-", "B and C: " + all_h["mu_hI_BC"]["law"])
    if (boundary.get("prediction_law") or {}).get("name") == "mu_hI_BC_log":
        # drawn on to where it reaches the bulk mu_0: the crossing V_AB is read from
        log, reach = all_h["mu_hI_BC_log"], []
        if fitting.usable(fits.get("mu_power")):
            x = fitting.solve_for_x(log, fits["mu_power"]["parameters"]["mu_0"]["value"])
            reach = [x] if x is not None else []
        _curve(ax, log, xs["BC"] + reach, "-.", "B and C, its B -> 0 limit (the predictions'): "
               + log["law"])
    _form_edge(ax, boundary, fits, xs["BC"])
    _curve(ax, all_h["mu_hI_A"], xs["A"], "--", "A: " + all_h["mu_hI_A"]["law"])
    _mu_0_line(ax, fits)
    _finish(plt, fig, ax, path, "boundary mu_eff against h * I_boundary (= sqrt(m/sigma) dv)",
            "h * I_boundary [d]", "mu_eff (boundary layer)", xs["BC"] + xs["A"])


def _form_edge(ax, boundary, fits, xs):
    """The B/C law at the largest exponent its points allow (prediction_law.exponent_profile),
    drawn on to where it reaches the bulk mu_0: the other end of V_AB's form_range."""
    profile = (boundary.get("prediction_law") or {}).get("exponent_profile")
    xs = [x for x in xs if x > 0]
    if not profile or not profile.get("allowed") or not xs:
        return
    edge = profile["allowed"][-1]
    B, (c0, c1) = edge["B"], edge["params"]
    if B == 0 or c1 == 0:
        return
    hi = max(xs)
    if fitting.usable(fits.get("mu_power")):
        x = profile_crossing(edge, fits["mu_power"]["parameters"]["mu_0"]["value"])
        hi = max(hi, x) if x is not None else hi
    grid = np.geomspace(min(xs), hi, 200)
    ax.plot(grid, fitting.power_plus(grid, c0, c1, B), ":", color="k", lw=1,
            label=f"B and C, the largest exponent its points allow (B = {B:g})")


def bulk_by_h_figure(path, rows, boundary):
    """The bulk mu_eff(I) measured with each h (bulk h < y < L_y - h), with each h's fit."""
    plt, fig, ax = _figure()
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    xs = []
    for k, h in enumerate(boundary["thicknesses"]):
        c = h_label(h)
        sel = [r for r in rows if r.get("steady") is True and r.get(f"{c}_bulk_I")
               and r[f"{c}_bulk_I"] > 0 and r.get(f"{c}_bulk_mu_eff") is not None]
        if not sel:
            continue
        fit = boundary[c]["bulk"]["mu_power"]
        regimes = fit.get("regimes") if fit else None
        for fitted in (True, False):
            part = [r for r in sel if not regimes or (r.get("regime") in regimes) == fitted]
            if not part:
                continue
            x = [r[f"{c}_bulk_I"] for r in part]
            xs += x
            ax.errorbar(x, [r[f"{c}_bulk_mu_eff"] for r in part],
                        yerr=[r.get(f"{c}_bulk_mu_eff_err") or 0 for r in part],
                        fmt=H_MARKERS[k % 8] if fitted else "x", color=colours[k % len(colours)],
                        ms=4, capsize=2, label=f"bulk with h = {h:g}" + (
                            "" if fitted else f" (regime not {'/'.join(regimes)}, not fitted)"))
        _curve(ax, fit, _fitted_x(sel, fit, f"{c}_bulk_I"), H_STYLES[k % 4],
               f"h = {h:g}: mu_power")
    _finish(plt, fig, ax, path, "bulk mu_eff(I) measured with each boundary thickness h",
            "bulk inertial number I", "mu_eff (bulk)", xs)


def switch_time_figure(path, switch_predictions):
    """Regime C: switch time / V against L_y. Measured: the run's mean switch time T (the time
    from +V to -V at each switch's fitted rate, regime.band_switches) / V, comparable to the
    predicted T / V = 2 rho nu L_y / (delta_mu sigma_yy), the mean interval
    between switches / V, and for a run without a switch the time it was watched / V (open
    triangles: the interval lies above); time / V on a logarithmic axis where its values span
    more than a factor of 10."""
    plt, fig, ax = _figure()
    xs, ys = [], []
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    systems = sorted({e["system"] for e in switch_predictions if e["system"] is not None})
    for i, system in enumerate(systems):
        c = colours[i % len(colours)]
        sel = [e for e in switch_predictions if e["system"] == system and e["L_y"]]
        for key, marker, label in (
                ("switch_time", "o", "measured T / V"),
                ("predicted_T", "x", "predicted T / V"),
                ("mean_interval", "s", "mean interval / V")):
            pts = [(e["L_y"], e[key] / e["V"]) for e in sel if e.get(key)]
            if pts:
                xs += [p[0] for p in pts]
                ys += [p[1] for p in pts]
                ax.plot(*zip(*pts), marker, color=c, mfc="none" if marker == "s" else c,
                        label=f"system {system}: {label}")
        # A run without a switch bounds the interval from below: the time it was watched.
        bounds = [(e["L_y"], e["observed_time"] / e["V"]) for e in sel
                  if e.get("switch_count") == 0 and e.get("observed_time")]
        if bounds:
            xs += [p[0] for p in bounds]
            ys += [p[1] for p in bounds]
            ax.plot(*zip(*bounds), "^", color=c, mfc="none",
                    label=f"system {system}: no switch in time / V (interval above)")
    if xs and max(xs) < 10 * min(xs):
        # T / V grows in proportion to L_y: both axes from 0 (on a linear L_y axis), so that the
        # runs of one height are not spread over the whole axis by their L_y's small scatter
        ax.set_xlim(0, 1.1 * max(xs))
        # The points in the lower part of the axes, the legend above them in the rest: each of
        # its lines (font size 6 on axes about 3 inches tall) takes about 4.5% of the height;
        # a legend too long for the axes goes beside them (_finish) and needs no room.
        entries = len(ax.get_legend_handles_labels()[0])
        points_share = 0.95 - (0.045 * entries if entries <= LEGEND_INSIDE_MAX else 0.0)
        if max(ys) > 10 * min(ys):
            # a measured switch time beside a watched time without switch can differ by a
            # factor of 100: on a linear axis the switch times would sit on the axis
            ax.set_yscale("log")
            low, top = min(ys) / 2, max(ys) * 1.5
            ax.set_ylim(low, low * (top / low) ** (1.0 / points_share))
        else:
            ax.set_ylim(0, ax.get_ylim()[1] / points_share)
    _finish(plt, fig, ax, path, "regime C: band switch time / V against L_y", "L_y [d]",
            "time / V [t^2 / d]", xs)


def profile_labels(rows):
    """The legend label of each row's profile: V, the regime, "not steady" where it is not, and
    where several rows share a V the seed (the run's name where the seed does not tell them
    apart)."""
    labels = []
    for r in rows:
        same_v = [q for q in rows if q.get("V") == r.get("V")]
        tag = ""
        if len(same_v) > 1:
            seed = r.get("seed")
            unique = seed is not None and sum(1 for q in same_v if q.get("seed") == seed) == 1
            tag = f", seed {seed}" if unique else f", {r.get('run', '?')}"
        v = f"{r['V']:g}" if r.get("V") is not None else "?"
        labels.append(f"V = {v}{tag} "
                      f"({r.get('regime') or '?'}{'' if r.get('steady') else ', not steady'})")
    return labels


def profile_figures(fig_dir, rows):
    """Per system, the profiles of every V (the steady part; for a run that is not steady, its
    last half): v_x / V and mu_eff against y / L_y.
    Returns the file names."""
    names = []
    systems = sorted({r["system"] for r in rows if r.get("system") is not None})
    for system in systems:
        sel = sorted((r for r in rows if r["system"] == system and r.get("_profiles")),
                     key=lambda r: r["V"] or 0)
        if not sel:
            continue
        plt, fig, axes = _figure((11.0, 4.0), columns=2)
        cmap = plt.get_cmap("viridis")
        for k, (r, label) in enumerate(zip(sel, profile_labels(sel))):
            p = r["_profiles"]
            height = r.get("L_y") or max(p["y"])
            colour = cmap(k / max(1, len(sel) - 1))
            y = np.asarray(p["y"], float) / height
            # Stripes centred above the mean top wall hold grains only while the wall is above
            # its mean: left out, so that y / L_y ends at 1.
            inside = y <= 1.0
            axes[0].plot((np.asarray(p["vx"], float) / r["V"])[inside], y[inside], "-",
                         color=colour, label=label)
            axes[1].plot(np.asarray(p["mu_eff"], float)[inside], y[inside], "-", color=colour)
        axes[0].set_xlabel("v_x / V")
        axes[0].set_ylabel("y / L_y")
        axes[0].axvline(0, color="0.7", lw=0.6)
        axes[1].set_xlabel("mu_eff")
        fig.suptitle(f"system {system}: velocity and mu_eff profiles (steady part; not steady: "
                     "last half of the run)", fontsize=9)
        fig.tight_layout(rect=(0.0, 0.0, 0.8, 1.0))  # the legend beside the curves, not on them
        fig.legend(*axes[0].get_legend_handles_labels(), fontsize=6, loc="center left",
                   bbox_to_anchor=(0.8, 0.5))
        name = f"profiles_s{system}.png"
        save_figure(fig, os.path.join(fig_dir, name), dpi=110)
        plt.close(fig)
        names.append(name)
    return names


def write_figures(fig_dir, rows, fits, transitions, boundary, preds):
    """Every figure of the report into fig_dir; returns their file names."""
    names = []
    for fname, title, xcol, ycol, fit_names in FIGURES:
        _plot(os.path.join(fig_dir, fname), title, xcol, ycol, fit_names, rows, fits)
        names.append(fname)
    _plot_regimes(os.path.join(fig_dir, "regimes.png"), rows, transitions)
    names.append("regimes.png")
    for name, y, label, law in (("boundary_mu_I.png", "mu", "mu_eff", "mu_power"),
                                ("boundary_nu_I.png", "nu", "solid fraction nu", "nu_linear"),
                                ("boundary_nu_ratio.png", "nu_ratio", "nu_boundary / nu_bulk",
                                 "nu_ratio_linear"),
                                ("boundary_Z_I.png", "Z", "coordination Z", "Z_power")):
        boundary_law_figure(os.path.join(fig_dir, name), rows, boundary, y, label, law,
                            fits if y == "mu" else None)
        names.append(name)
    boundary_collapse_figure(os.path.join(fig_dir, "boundary_mu_hI.png"), rows, boundary, fits)
    names.append("boundary_mu_hI.png")
    bulk_by_h_figure(os.path.join(fig_dir, "bulk_mu_by_h.png"), rows, boundary)
    names.append("bulk_mu_by_h.png")
    switch_time_figure(os.path.join(fig_dir, "switch_time.png"), preds["switch_time_C"])
    names.append("switch_time.png")
    names += profile_figures(fig_dir, rows)
    return names

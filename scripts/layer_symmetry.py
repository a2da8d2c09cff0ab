#!/usr/bin/python3
"""The two boundary layers of regime-A runs against each other (docs/measurements.md, "Bulk and
boundary layers"): by symmetry they are equivalent, so their differences measure the
measurement's own error. For each h and quantity: the runs, the mean |top - bottom| in combined
errors, the share of runs beyond two, and the correlation of the difference with the edge offset
that runs written before run.h5 format version 4 had (their top layer's stripes, counted from
the bottom wall, ended at the stripe boundary nearest H - h: thickness h + offset); from version
4 the top layer is counted down from the top wall and the offset should not matter.
With --legacy (runs of format version 4): the same runs' top layer as the former definition
measured it, recomputed from the profiles, beside the current one, each paired with the bottom
layer window by window (mean |top - bottom|, mean |z| and the share beyond two errors).
Usage: scripts/layer_symmetry.py [--legacy] CAMPAIGN_DIR [CAMPAIGN_DIR ...]"""
import glob
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python"))

from cdshear_analysis.profiles import stripe_width  # noqa: E402
from cdshear_analysis.summary import SUMMARY_FORMAT, SUMMARY_VERSION  # noqa: E402

QUANTITIES = ("solid_fraction", "coordination", "mu_eff")


def edge_offset(height, h, dy=1.0):
    """Top layer thickness minus h: its stripes are those whose centre lies above H - h."""
    lowest = math.floor((height - h) / dy - 0.5) + 1
    return height - lowest * dy - h


def steady_regime_a(dirs):
    """(run folder, summary) of each steady regime-A run of the campaigns `dirs`; a summary.json
    that is not a cdshear summary of this package's version stops the script with its path."""
    for d in dirs:
        for path in sorted(glob.glob(os.path.join(d, "runs", "*", "summary.json"))):
            with open(path, encoding="utf-8") as f:
                s = json.load(f)
            if (s.get("format"), s.get("version")) != (SUMMARY_FORMAT, SUMMARY_VERSION):
                sys.exit(f"{path}: not a cdshear summary of version {SUMMARY_VERSION} (format "
                         f"{s.get('format')!r}, version {s.get('version')!r}); run `cdshear "
                         "analyze` on its run again")
            if s.get("regime") == "A" and s.get("steady") is True:
                yield os.path.dirname(path), s


def points(dirs):
    out = []
    for _, s in steady_regime_a(dirs):
        height = s["height"]["mean"]
        dy = stripe_width(s["profiles"]["y"])
        for label, region in s.get("regions", {}).items():
            h = region.get("h")
            for q in QUANTITIES:
                b, t = region["bottom"].get(q, {}), region["top"].get(q, {})
                if None in (b.get("mean"), t.get("mean"), b.get("err"), t.get("err")):
                    continue
                err = math.hypot(b["err"], t["err"])
                if err > 0:
                    z = (t["mean"] - b["mean"]) / err
                    out.append((label, q, edge_offset(height, h, dy), z))
    return out


def legacy_top(run, h):
    """The top layer's nu and Z per window as runs before format version 4 measured them
    (profiles.former_regions)."""
    from cdshear_analysis.profiles import former_regions
    w = run["windows"]
    nu_out, z_out = [], []
    for k, height in enumerate(np.asarray(w["height"], dtype=float)):
        parts, inside = former_regions(w["y"], height, h, np.isfinite(w["vx"][k]))
        sel = parts["top"]
        nu, z = w["solid_fraction"][k][sel], w["coordination"][k][sel]
        nu_out.append(nu.sum() / inside[sel].sum() if sel.any() else np.nan)
        z_out.append((nu * z).sum() / nu.sum() if nu.sum() > 0 else np.nan)
    return {"solid_fraction": np.array(nu_out), "coordination": np.array(z_out)}


def legacy_table(dirs):
    from cdshear_analysis import load_run
    from cdshear_analysis.statistics import window_mean
    rows = []
    for run_dir, s in steady_regime_a(dirs):
        run = load_run(run_dir)
        if run["top_stripes"] is None:
            continue
        sel = np.asarray(s["steady_window_indices"], dtype=int)
        for label, region in run["regions"].items():
            legacy = legacy_top(run, region["h"])
            for q in ("solid_fraction", "coordination"):
                bottom = region[f"bottom_{q}"][sel]
                for name, top in (("current", region[f"top_{q}"][sel]),
                                  ("legacy", legacy[q][sel])):
                    mean, err = window_mean(top - bottom)
                    rows.append((label, q, name, abs(mean), abs(mean) / err))
    print("h     quantity        top layer  runs  mean |top - bottom|  mean |z|  |z| > 2")
    for label in sorted({r[0] for r in rows}, key=lambda x: float(x[1:])):
        for q in ("solid_fraction", "coordination"):
            for name in ("current", "legacy"):
                sel = np.array([r[3:] for r in rows if r[:3] == (label, q, name)])
                if len(sel):
                    print(f"{label:5s} {q:15s} {name:9s}  {len(sel):4d}  {np.mean(sel[:, 0]):19.4f}"
                          f"  {np.mean(sel[:, 1]):8.2f}  {np.mean(sel[:, 1] > 2):7.2f}")
    return 0


def main(args):
    dirs = [a for a in args if a != "--legacy"]
    if not dirs:
        print(__doc__.splitlines()[-1], file=sys.stderr)
        return 2
    if "--legacy" in args:
        return legacy_table(dirs)
    rows = points(dirs)
    print("h     quantity        runs  mean |z|  |z| > 2  corr(z, offset)")
    for label in sorted({r[0] for r in rows}, key=lambda x: float(x[1:])):
        for q in QUANTITIES:
            sel = [(off, z) for lab, qq, off, z in rows if lab == label and qq == q]
            if len(sel) < 3:
                continue
            off, z = np.array(sel).T
            corr = np.corrcoef(off, z)[0, 1] if np.std(off) > 0 else float("nan")
            print(f"{label:5s} {q:15s} {len(sel):4d}  {np.mean(np.abs(z)):8.2f}  "
                  f"{np.mean(np.abs(z) > 2):7.2f}  {corr:15.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

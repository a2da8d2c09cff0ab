#!/usr/bin/python3
"""The two boundary layers of regime-A runs against each other (docs/measurements.md, "Bulk and
boundary layers"): by symmetry they are equivalent, so their differences measure the
measurement's own error. For each h and quantity: the runs, the mean |top - bottom| in combined
errors, the share of runs beyond two, and the correlation of the difference with the edge offset
that runs written before run.h5 format version 4 had (their top layer's stripes, counted from
the bottom wall, ended at the stripe boundary nearest H - h: thickness h + offset); from version
4 the top layer is counted down from the top wall and the offset should not matter.
Usage: scripts/layer_symmetry.py CAMPAIGN_DIR [CAMPAIGN_DIR ...]"""
import glob
import json
import math
import os
import sys

import numpy as np

QUANTITIES = ("solid_fraction", "coordination", "mu_eff")


def edge_offset(height, h, dy=1.0):
    """Top layer thickness minus h: its stripes are those whose centre lies above H - h."""
    lowest = math.floor((height - h) / dy - 0.5) + 1
    return height - lowest * dy - h


def points(dirs):
    out = []
    for d in dirs:
        for path in sorted(glob.glob(os.path.join(d, "runs", "*", "summary.json"))):
            with open(path, encoding="utf-8") as f:
                s = json.load(f)
            if s.get("regime") != "A" or s.get("steady") is not True:
                continue
            height = s["height"]["mean"]
            for label, region in s.get("regions", {}).items():
                h = region.get("h")
                for q in QUANTITIES:
                    b, t = region["bottom"].get(q, {}), region["top"].get(q, {})
                    if None in (b.get("mean"), t.get("mean"), b.get("err"), t.get("err")):
                        continue
                    err = math.hypot(b["err"], t["err"])
                    if err > 0:
                        out.append((label, q, edge_offset(height, h),
                                    (t["mean"] - b["mean"]) / err))
    return out


def main(dirs):
    if not dirs:
        print(__doc__.splitlines()[-1], file=sys.stderr)
        return 2
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

"""Bulk and boundary-layer quantities of each window, from its stripe profiles.

Same definitions as /windows/regions in docs/run-data.md. A stripe belongs to a region by its
centre y; only stripes with a finite velocity count (stripes above the top wall are NaN).
- mu_eff = |mean sigma_xy| / mean sigma_yy over the region's stripes;
- solid_fraction: mean; coordination (closed contacts) and force_carrying_coordination (contacts
  carrying force at the sampled steps; absent from files without it): means weighted by the
  solid fraction;
- shear_rate: least-squares slope of v_x(y); inertial_number = |shear_rate| sqrt(m / sigma_yy);
- boundary layers: the bottom one the stripes with y < h, the top one the stripes counted down
  from the top wall (/windows/top_stripes) with depth < h; they add the velocity jumps
  dv_bottom = v_x(h) + V, dv_top = V - v_x(depth h) (linear interpolation in the profiles)
  and I_boundary = sqrt(m / sigma_yy) dv / h. Without top stripes (files before format
  version 4) the top layer is the stripes with y > H - h, H the window's mean height.
"""
import numpy as np

QUANTITIES = ("mu_eff", "solid_fraction", "coordination", "force_carrying_coordination",
              "shear_rate", "inertial_number")
LAYER_QUANTITIES = QUANTITIES[:4]   # a boundary layer's shear is its velocity jump


def stripe_width(y):
    """The stripes' width dy (measure.dy) from their centres y = (k + 1/2) dy: the spacing of two,
    twice the centre of one, 1 with none."""
    return y[1] - y[0] if len(y) > 1 else 2 * y[0] if len(y) else 1.0


def former_regions(y, height, h, finite):
    """The stripes of each region as files before format version 4 assigned them, all counted
    from the bottom wall: ({"bottom", "top", "bulk"}: boolean masks over the stripe centres y,
    each stripe's share inside a cell of mean height `height`). `finite`: the stripes with a
    velocity. Bottom y < h; top y > height - h and the stripe cut by the top wall (counted for
    its share inside); bulk the rest."""
    y = np.asarray(y, dtype=float)
    dy = stripe_width(y)
    inside = np.clip((height - (y - 0.5 * dy)) / dy, 0.0, 1.0)
    ok = (inside > 0) & finite
    upper = (y > height - h) | (inside < 1)
    return {"bottom": ok & (y < h), "top": ok & (y >= h) & upper,
            "bulk": ok & (y >= h) & ~upper}, inside


def region_quantities(windows, lo, hi, normal_stress, inertial_mass=np.pi / 4, closed=False):
    """Per-window region averages over stripes with lo < y < hi (lo, hi scalars or per window),
    or lo <= y <= hi when `closed` (the bulk, as the run's own regions take it: a stripe centred
    on h belongs to the bulk, docs/measurements.md).

    Returns {quantity: array of length W} for QUANTITIES, NaN where the region is empty."""
    y = np.asarray(windows["y"], dtype=float)
    vx, nu = windows["vx"], windows["solid_fraction"]
    counts = {"coordination": windows["coordination"],
              "force_carrying_coordination": windows.get("force_carrying_coordination")}
    stress = windows["stress"]
    n_windows = len(vx)
    lo, hi = np.broadcast_to(lo, (n_windows,)), np.broadcast_to(hi, (n_windows,))
    out = {q: np.full(n_windows, np.nan) for q in QUANTITIES}
    for w in range(n_windows):
        inside = (y >= lo[w]) & (y <= hi[w]) if closed else (y > lo[w]) & (y < hi[w])
        sel = inside & np.isfinite(vx[w])
        if not sel.any():
            continue
        sxy, syy = np.nanmean(stress[w, sel, 0, 1]), np.nanmean(stress[w, sel, 1, 1])
        out["mu_eff"][w] = abs(sxy) / syy if syy > 0 else np.nan
        out["solid_fraction"][w] = np.mean(nu[w, sel])
        for name, z in counts.items():
            if z is None:
                continue
            weight = np.where(np.isfinite(z[w, sel]), nu[w, sel], 0.0)
            if weight.sum() > 0:
                out[name][w] = np.nansum(weight * z[w, sel]) / weight.sum()
        if sel.sum() >= 2:
            out["shear_rate"][w] = np.polyfit(y[sel], vx[w, sel], 1)[0]
    out["inertial_number"] = np.abs(out["shear_rate"]) * np.sqrt(inertial_mass / normal_stress)
    return out


def regions_for_h(windows, h, velocity, normal_stress, inertial_mass=np.pi / 4,
                  top_stripes=None):
    """The datasets of /windows/regions/h<h> (bulk_*, bottom_*, top_*), one value per window;
    `top_stripes` the run's /windows/top_stripes (None: the top layer from `windows`)."""
    height = np.asarray(windows["height"], dtype=float)
    parts = {"bulk": (h, height - h), "bottom": (-np.inf, h)}
    if top_stripes is None:
        parts["top"] = (height - h, np.inf)
    out = {}
    for name, (lo, hi) in parts.items():
        q = region_quantities(windows, lo, hi, normal_stress, inertial_mass,
                              closed=name == "bulk")
        keep = QUANTITIES if name == "bulk" else LAYER_QUANTITIES
        out.update({f"{name}_{k}": q[k] for k in keep})
    if top_stripes is not None:
        depth_profiles = dict(top_stripes, y=top_stripes["depth"])
        q = region_quantities(depth_profiles, -np.inf, h, normal_stress, inertial_mass)
        out.update({f"top_{k}": q[k] for k in LAYER_QUANTITIES})
    y = np.asarray(windows["y"], dtype=float)
    jump_bottom, jump_top = np.full(len(height), np.nan), np.full(len(height), np.nan)
    for w, vx in enumerate(windows["vx"]):
        ok = np.isfinite(vx)
        if ok.sum() >= 2:
            jump_bottom[w] = np.interp(h, y[ok], vx[ok]) + velocity
            if top_stripes is None:
                jump_top[w] = velocity - np.interp(height[w] - h, y[ok], vx[ok])
        if top_stripes is not None:
            depth, top_vx = np.asarray(top_stripes["depth"], dtype=float), top_stripes["vx"][w]
            ok = np.isfinite(top_vx)
            if ok.sum() >= 2:
                jump_top[w] = velocity - np.interp(h, depth[ok], top_vx[ok])
    scale = np.sqrt(inertial_mass / normal_stress) / h
    out.update(bottom_velocity_jump=jump_bottom, top_velocity_jump=jump_top,
               bottom_inertial_number=scale * jump_bottom, top_inertial_number=scale * jump_top)
    return out

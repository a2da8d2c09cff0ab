"""Bulk and boundary-layer quantities of each window, from its stripe profiles.

Same definitions as /windows/regions in docs/run-data.md. A stripe belongs to a region by its
centre y; only stripes with a finite velocity count (stripes above the top wall are NaN).
- mu_eff = |mean sigma_xy| / mean sigma_yy over the region's stripes;
- solid_fraction: mean; coordination (closed contacts) and force_carrying_coordination (contacts
  carrying force at the sampled steps; absent from files without it): means weighted by the
  solid fraction;
- shear_rate: least-squares slope of v_x(y); inertial_number = |shear_rate| sqrt(m / sigma_yy);
- boundary layers (bottom y < h, top y > H - h, H the window's mean height) add the velocity
  jumps dv_bottom = v_x(h) + V, dv_top = V - v_x(H - h) (linear interpolation in the profile)
  and I_boundary = sqrt(m / sigma_yy) dv / h.
"""
import numpy as np

QUANTITIES = ("mu_eff", "solid_fraction", "coordination", "force_carrying_coordination",
              "shear_rate", "inertial_number")


def region_quantities(windows, lo, hi, normal_stress, inertial_mass=np.pi / 4):
    """Per-window region averages over stripes with lo < y < hi (lo, hi scalars or per window).

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
        sel = (y > lo[w]) & (y < hi[w]) & np.isfinite(vx[w])
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


def regions_for_h(windows, h, velocity, normal_stress, inertial_mass=np.pi / 4):
    """The datasets of /windows/regions/h<h> (bulk_*, bottom_*, top_*), one value per window."""
    height = np.asarray(windows["height"], dtype=float)
    parts = {"bulk": (h, height - h), "bottom": (-np.inf, h), "top": (height - h, np.inf)}
    out = {}
    for name, (lo, hi) in parts.items():
        q = region_quantities(windows, lo, hi, normal_stress, inertial_mass)
        keep = QUANTITIES if name == "bulk" else ("mu_eff", "solid_fraction", "coordination",
                                                  "force_carrying_coordination")
        out.update({f"{name}_{k}": q[k] for k in keep})
    y = np.asarray(windows["y"], dtype=float)
    jump_bottom, jump_top = np.full(len(height), np.nan), np.full(len(height), np.nan)
    for w, vx in enumerate(windows["vx"]):
        ok = np.isfinite(vx)
        if ok.sum() >= 2:
            jump_bottom[w] = np.interp(h, y[ok], vx[ok]) + velocity
            jump_top[w] = velocity - np.interp(height[w] - h, y[ok], vx[ok])
    scale = np.sqrt(inertial_mass / normal_stress) / h
    out.update(bottom_velocity_jump=jump_bottom, top_velocity_jump=jump_top,
               bottom_inertial_number=scale * jump_bottom, top_inertial_number=scale * jump_top)
    return out

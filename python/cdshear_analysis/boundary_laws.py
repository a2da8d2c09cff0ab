"""The boundary-layer laws of docs/model.md section 8 over a campaign, the influence of h on the
bulk law, and the predictions that need the boundary law (V_AB, stability of the symmetric state).

Points. One point per (steady run in regime A, B or C, boundary thickness h, wall) from the
run's `hK_bottom_*` and `hK_top_*` columns (report.read_run), with I_boundary > 0. In regime C
only the sheared layer counts: the `hK_sheared_layer_*` columns (the layer that carries the
band in each window; summaries without them: the wall whose mean velocity jump is the larger);
the other layer moves with its wall and is not sheared (its I_boundary is noise about 0), so it
is no point of a flow law. The two walls of an A or B run give two points (they share the run's
shear stress). A run with any other regime label (undecided, intermittent, ...) or none gives no
point: which of its layers is sheared, and how, is not known.

Fits (fitting.py, weighted by the error bars; the seeds of one (system, V) give one point per
h and layer, fitting.combine), fits.json `boundary`:
  per h, key "hK": `mu_power` mu_b = mu_0 + A I_b^B, `nu_linear` nu_b = nu_max - c I_b,
    `nu_ratio_linear` nu_b / nu_bulk = r_0 - c I_b (nu_bulk of the same run and h), `Z_power`
    Z_b = Z_0 - c I_b^e, `mu_hI_BC`, `mu_hI_BC_log` and `prediction_law` as under "all_h" but
    for the B and C layers at this h alone, and under "bulk" the bulk laws of report.FITS with
    that h's bulk (h < y < L_y - h): how the bulk law depends on h (creep next to the boundary
    layers);
  pooled over every h, key "all_h": mu_eff against I_b and against h I_b, for the layers of runs
    in regime B or C and, separately, in regime A (`mu_I_BC`, `mu_hI_BC`, `mu_I_A`, `mu_hI_A`),
    with `collapse`: per group the chi2/dof of the two fits; the variable with the smaller one
    collapses the thicknesses (model.md section 8 expects h I for B and C, I for A). Needs two h
    at least and both fits fitted (whatever their status: the one that does not collapse is "poor").
    Beside them `mu_hI_BC_log`, mu_b = a + b ln(h I_b): the limit of mu_0 + A x^B as B -> 0 with
    A B = b and mu_0 + A = a, the form the power law takes when its points fix only its slope in
    ln x (the power law's three parameters then trade off without bound). Each pooled law also
    has `independent_points`: its (system, V), one shear stress each (`widening`).

The predictions take the laws whose parameters are determined (fitting.usable: status "ok" or
"poor"); an "undetermined" or skipped law gives a `reason` instead. A pooled law's covariance and
chi2 count a run's points (both walls, every h: one stress) as independent; the predictions widen
them by n_points / independent_points (`widening`). The B/C law they take,
`boundary.prediction_law` (`bc_prediction_law`): mu_hI_BC when determined; else its B -> 0 limit
mu_hI_BC_log when mu_hI_BC's exponent lies within two widened errors of 0 or on the lower bound of
its range, the limit's parameters are determined with widened errors and its widened chi2 exceeds
the power law's by at most 4 (the points cannot tell the power law from its limit); else none.
Whichever it takes, `prediction_law.exponent_profile` says which exponents B the points allow
(`exponent_profile`), and the predictions give V_AB over them (`form_range`): the uncertainty of
the law's form, which its parameters' interval leaves out.

Predictions, fits.json `predictions`:
  V_AB: in regime B the bulk is at rest, so each layer takes the whole jump dv = V and
    h I_b = sqrt(m / sigma_yy) V. The bulk starts to flow when the boundary friction reaches
    the bulk's critical friction mu_0 (mu_power of the bulk): h I_b* solves law(h I_b*) = mu_0
    with the law of `prediction_law`, and V_AB = h I_b* / sqrt(m / sigma_yy) per system (its
    sigma_yy). The same from each h's own law mu_power(I_b*) = mu_0: V_AB = h I_b* /
    sqrt(m / sigma_yy). Uncertainties: 68% interval of MONTE_CARLO draws of the parameters from
    their covariances (bulk and boundary fits taken as independent), with a fixed seed.
  symmetric_state_stability: the symmetric state (B) is unstable when the boundary friction
    decreases with the velocity jump. Per system and h, between consecutive velocities with B
    or C runs, the slope d mu_b / d (h I_b) of the sheared layers' points (mean of the two walls
    for B) with its error (a point's mean error over the square root of the runs, not of the
    walls: a run's two walls share one shear stress); "decreasing" when slope + 2 err < 0,
    "increasing" when slope - 2 err > 0, else "undetermined"; beside it the regimes observed at
    the two velocities.
  switch_time_C, `delta_mu_law` of each regime-C run (predict_delta_mu): the friction
    difference between the walls that the pooled B/C law of `prediction_law` gives at the two
    walls' measured velocity jumps (h I_b = sqrt(m / sigma_yy) dv), per h, beside the delta_mu
    measured over the switches.
"""
import math

import numpy as np

from . import fitting

INERTIAL_MASS = math.pi / 4   # model.md section 7: m in I = gamma_dot sqrt(m / sigma_yy)
MONTE_CARLO = 4000            # parameter draws for the V_AB intervals
SEED = 20261123               # of those draws: a report is reproducible

LAYER_LAWS = {
    "mu_power": fitting.law("power_plus", ["mu_0", "A", "B"], "mu_eff_boundary", "I_boundary"),
    "nu_linear": fitting.law("linear_minus", ["nu_max", "c"], "nu_boundary", "I_boundary"),
    "nu_ratio_linear": fitting.law("linear_minus", ["r_0", "c"], "nu_boundary / nu_bulk",
                                   "I_boundary"),
    "Z_power": fitting.law("power_minus", ["Z_0", "c", "e"], "Z_boundary", "I_boundary"),
}
POOLED = {f"mu_{x}_{g}": (fitting.law("power_plus", ["mu_0", "A", "B"], "mu_eff_boundary",
                                      "I_boundary" if x == "I" else "h * I_boundary"), x, g)
          for g in ("BC", "A") for x in ("I", "hI")}
POOLED["mu_hI_BC_log"] = (fitting.law("log_plus", ["a", "b"], "mu_eff_boundary",
                                      "h * I_boundary"), "hI", "BC")
# How many errors from 0 the power law's exponent may lie for its B -> 0 limit to stand in for
# it, and how much larger the limit's chi2 may be (one parameter fewer: about two errors)
LOG_LIMIT_ERRORS = 2.0
LOG_LIMIT_CHI2 = 4.0
# The exponents of the profile over B (0: the logarithmic limit) and its 68% threshold
PROFILE_EXPONENTS = [0.0] + [round(0.02 * k, 2) for k in range(1, 101)]
PROFILE_DELTA_CHI2 = 1.0


def h_label(h):
    """h10, h5, h2.5: the column prefix of a boundary thickness (as report._h_label)."""
    return "h" + (str(int(h)) if float(h).is_integer() else repr(float(h)))


def thicknesses(rows):
    return sorted({h for r in rows for h in r.get("_layers", [])})


def _ratio(a, ea, b, eb):
    if a is None or b is None or b == 0:
        return None, None
    q = a / b
    err = abs(q) * math.hypot((ea or 0) / a if a else 0, (eb or 0) / b) if ea and eb else None
    return q, err


LAYER_REGIMES = ("A", "B", "C")   # the regimes whose layers are points of the laws


def layer_points(rows, h):
    """The boundary-layer points of thickness h (see the module's doc): dicts with run, system,
    V, regime, side, h, I, hI, mu, nu, Z, nu_ratio (each with _err), velocity_jump."""
    label = h_label(h)
    out = []
    for r in rows:
        if r.get("steady") is not True or h not in r.get("_layers", []) \
                or r.get("regime") not in LAYER_REGIMES:
            continue
        sides = ["bottom", "top"]
        if r.get("regime") == "C" and r.get(f"{label}_sheared_layer_I") is not None:
            # the layer that carries the band in each window, whichever wall it is at
            sides = ["sheared_layer"]
        elif r.get("regime") == "C":
            # summaries without it: the wall with the larger mean jump (mixes in the windows
            # where that layer rests, if the band switched)
            jumps = {s: r.get(f"{label}_{s}_velocity_jump") for s in sides}
            if None in jumps.values():
                continue
            sides = [max(sides, key=lambda s: abs(jumps[s]))]
        for side in sides:
            c = f"{label}_{side}_"
            I = r.get(c + "I")
            if I is None or I <= 0:
                continue
            p = {"run": r["run"], "system": r.get("system"), "V": r.get("V"),
                 "regime": r.get("regime"), "side": side, "h": h, "I": I,
                 "I_err": r.get(c + "I_err"), "hI": h * I,
                 "velocity_jump": r.get(c + "velocity_jump"),
                 "averaged_time": r.get("_averaged_time")}
            for q, col in (("mu", "mu_eff"), ("nu", "nu"), ("Z", "Z")):
                p[q], p[q + "_err"] = r.get(c + col), r.get(c + col + "_err")
            p["nu_ratio"], p["nu_ratio_err"] = _ratio(
                p["nu"], p["nu_err"], r.get(f"{label}_bulk_nu"), r.get(f"{label}_bulk_nu_err"))
            out.append(p)
    return out


def _points(points, x, y):
    """fitting.fit points (x, y, err, "run:side:hK", group, averaged_time): the seeds of one
    (system, V), h, regime and layer are one point (the sheared layer of C runs, whichever wall
    it is at), weighted by averaged_time (fitting.combine)."""
    out = []
    for p in points:
        key = fitting.group_key(p)
        if key is not None:
            key += (p["h"], p["regime"], "sheared" if p["regime"] == "C" else p["side"])
        out.append((p[x], p[y], p[y + "_err"], f"{p['run']}:{p['side']}:{h_label(p['h'])}", key,
                    p.get("averaged_time")))
    return out


def fit_boundary(rows, bulk_fits):
    """fits.json `boundary` (see the module's doc). bulk_fits: the bulk laws (report.FITS),
    fitted again on each h's bulk columns."""
    out = {"thicknesses": thicknesses(rows)}
    pooled = []
    for h in out["thicknesses"]:
        pts = layer_points(rows, h)
        pooled += pts
        label = h_label(h)
        entry = {"h": h, "n_points": len(pts)}
        for name, spec in LAYER_LAWS.items():
            y = {"mu_power": "mu", "nu_linear": "nu", "nu_ratio_linear": "nu_ratio",
                 "Z_power": "Z"}[name]
            entry[name] = fitting.fit(spec, _points(pts, "I", y))
        # mu_eff of a run's two walls: one shear stress (widening); nu and Z are the walls' own
        entry["mu_power"]["independent_points"] = _independent_points(pts)
        # the B/C law in h I_b at this h alone: how far the collapse holds
        bc = [p for p in pts if p["regime"] in ("B", "C")]
        for name in ("mu_hI_BC", "mu_hI_BC_log"):
            entry[name] = _pooled_fit(name, bc)
        entry["prediction_law"] = _prediction_law(entry, bc)
        bulk = {}
        for name, spec in bulk_fits.items():
            col = {"mu_eff_bulk": "mu_eff", "nu_bulk": "nu", "Z_bulk": "Z"}[spec["y"]]
            bulk[name] = fitting.fit_columns(spec, rows, x=f"{label}_bulk_I",
                                             y=f"{label}_bulk_{col}")
        entry["bulk"] = bulk
        out[label] = entry
    groups = {"BC": [p for p in pooled if p["regime"] in ("B", "C")],
              "A": [p for p in pooled if p["regime"] == "A"]}
    all_h = {}
    for name, (_, _, g) in POOLED.items():
        all_h[name] = _pooled_fit(name, groups[g])
    collapse = {}
    for g in groups:
        fi, fh = all_h[f"mu_I_{g}"], all_h[f"mu_hI_{g}"]
        c = {"chi2_dof_I": fi["chi2_dof"], "chi2_dof_hI": fh["chi2_dof"], "collapses_in": None,
             "note": None}
        if len(out["thicknesses"]) < 2:
            c["note"] = "one boundary thickness only: nothing to collapse"
        elif not (fitting.fitted(fi) and fitting.fitted(fh)):
            c["note"] = "a fit was skipped"
        else:
            c["collapses_in"] = "h * I_boundary" if fh["chi2_dof"] < fi["chi2_dof"] \
                else "I_boundary"
        collapse[g] = c
    all_h["collapse"] = collapse
    out["all_h"] = all_h
    out["prediction_law"] = _prediction_law(all_h, groups["BC"])
    return out


def _independent_points(points):
    """How many independent mu_eff the layer points hold: one stress per (system, V) (a run
    where it has none), shared by its walls' and thicknesses' points (`widening`)."""
    return len({fitting.group_key(p) or p["run"] for p in points})


def _pooled_fit(name, points):
    """The POOLED law `name` fitted to layer points, with `independent_points`
    (_independent_points)."""
    spec, x, _ = POOLED[name]
    result = fitting.fit(spec, _points(points, x, "mu"))
    result["independent_points"] = _independent_points(points)
    return result


def _prediction_law(laws, bc_points):
    """`prediction_law` of a set of B/C laws in h I_b (all_h, or one h's entry) and the B/C
    layer points they were fitted to: the choice (bc_prediction_law) and the exponent's
    profile (exponent_profile)."""
    choice = bc_prediction_law(laws)
    choice["exponent_profile"] = exponent_profile(_points(bc_points, "hI", "mu"),
                                                  widening(laws["mu_hI_BC"]))
    return choice


def bc_prediction_law(all_h):
    """fits.json `boundary.prediction_law`: {"name", "reason"} of the pooled B/C law in h I_b
    that the predictions take (the module's doc); name None when none is determined. The
    errors and chi2 of both fits are read widened (`widening`)."""
    power, log = all_h.get("mu_hI_BC"), all_h.get("mu_hI_BC_log")
    if fitting.usable(power):
        return {"name": "mu_hI_BC", "reason": "its parameters are determined"}
    why = f"mu_hI_BC is {(power or {}).get('status', 'missing')}"
    if not fitting.fitted(power):
        return {"name": None, "reason": why + f": {(power or {}).get('reason')}"}
    why += f" ({power['reason']})"
    w = widening(power)
    b = power["parameters"]["B"]
    # the exponent on the lower bound of its range (just above 0): the fit ran into the limit
    on_bound = bool(np.isclose(b["value"], fitting.EXPONENT_BOUNDS[0][2]))
    err_b = b["err_scaled"] * math.sqrt(w) if b["err_scaled"] is not None else None
    if not on_bound and err_b is None:
        return {"name": None, "reason": why + f"; its exponent B = {b['value']:.3g} has no "
                "error: whether it is near 0 is not known"}
    if not on_bound and b["value"] > LOG_LIMIT_ERRORS * err_b:
        return {"name": None, "reason": why + f"; its exponent B = {b['value']:.3g} +- "
                f"{err_b:.3g} is more than {LOG_LIMIT_ERRORS:g} errors from 0: its B -> 0 "
                "limit does not stand in for it"}
    if not fitting.usable(log):
        return {"name": None, "reason": why + f"; its B -> 0 limit mu_hI_BC_log is "
                f"{(log or {}).get('status', 'missing')}: {(log or {}).get('reason')}"}
    wl = widening(log)
    loose = [f"{n} = {v['value']:.3g} +- {v['err_scaled'] * math.sqrt(wl):.3g}"
             for n, v in log["parameters"].items()
             if v["err_scaled"] * math.sqrt(wl) > abs(v["value"])]
    if loose:
        return {"name": None, "reason": why + "; its B -> 0 limit mu_hI_BC_log is not "
                f"determined once its points are counted once per run: {', '.join(loose)}"}
    worse = (log["chi2"] - power["chi2"]) / w
    if worse > LOG_LIMIT_CHI2:
        return {"name": None, "reason": why + f"; its B -> 0 limit mu_hI_BC_log fits worse "
                f"(chi2 {worse:.3g} higher, counted once per run, above {LOG_LIMIT_CHI2:g}): "
                "the points tell the power law from its limit"}
    where = ("lies on the lower bound of its range" if on_bound else
             f"+- {err_b:.3g} lies within {LOG_LIMIT_ERRORS:g} errors of 0")
    return {"name": "mu_hI_BC_log", "reason": (
        f"{why}; its exponent B = {b['value']:.3g} {where} and its B -> 0 limit fits as "
        f"well (chi2 {worse:+.3g}, counted once per run) with its parameters determined, so "
        "the predictions take the limit")}


def exponent_profile(points, widen):
    """fits.json `prediction_law.exponent_profile`: how far the points fix the exponent B of
    mu = mu_0 + A x^B (B = 0: its limit a + b ln x). For each B of PROFILE_EXPONENTS the two
    other parameters are fitted (linear least squares, weighted by the error bars; points as for
    fitting.fit), and chi2(B) is read widened (divided by widen, the law's n_points /
    independent_points). `allowed`: the B whose widened chi2 exceeds the smallest by at most
    PROFILE_DELTA_CHI2 (a 68% interval for one parameter), with their [c0, c1] (mu_0 and A, or a
    and b at B = 0), from which the predictions' `form_range` follows. None with fewer than 3
    points."""
    kept, _ = fitting.select(points)
    if len(kept) < 3 or len({p[0] for p in kept}) < 3:
        return None
    x, y, e = (np.array([p[i] for p in kept], float) for i in range(3))
    rows = []
    for B in PROFILE_EXPONENTS:
        f = np.log(x) if B == 0 else x ** B
        design = np.column_stack([np.ones_like(x), f]) / e[:, None]
        coef, *_ = np.linalg.lstsq(design, y / e, rcond=None)
        chi2 = float(np.sum(((y - coef[0] - coef[1] * f) / e) ** 2))
        rows.append((float(B), chi2 / widen, [float(c) for c in coef]))
    best = min(r[1] for r in rows)
    allowed = [r for r in rows if r[1] - best <= PROFILE_DELTA_CHI2]
    return {"B": [r[0] for r in rows], "chi2_widened": [r[1] for r in rows],
            "best_B": min(rows, key=lambda r: r[1])[0],
            "allowed_B": [allowed[0][0], allowed[-1][0]],
            "allowed": [{"B": r[0], "params": r[2]} for r in allowed],
            "contiguous": len(allowed) == rows.index(allowed[-1]) - rows.index(allowed[0]) + 1}


def profile_crossing(allowed, target):
    """The x > 0 at which one `allowed` entry of an exponent profile ({"B", "params"}: the law
    c0 + c1 x^B, or c0 + c1 ln x at B = 0) reaches target, or None (fitting.solve_for_x)."""
    B, (c0, c1) = allowed["B"], allowed["params"]
    law, params = ("log_plus", [c0, c1]) if B == 0 else ("power_plus", [c0, c1, B])
    return fitting.solve_for_x({"model": law}, target, params=params)


def _form_range(profile, mu_0, scale):
    """[smallest, largest] V_AB over the exponents the profile allows (None without them)."""
    values = [x / scale for x in (profile_crossing(r, mu_0)
                                  for r in (profile or {}).get("allowed", []))
              if x is not None]
    return [min(values), max(values)] if values else None


def _bc_law(boundary):
    """(name, fit) of the B/C law the predictions take, or (None, mu_hI_BC) with the reason in
    boundary["prediction_law"] (fits made before that key: mu_hI_BC). boundary: fits.json
    `boundary` (the laws under "all_h") or one h's entry (the laws in it)."""
    choice = boundary.get("prediction_law") or {"name": "mu_hI_BC"}
    name = choice["name"]
    return name, boundary.get("all_h", boundary)[name or "mu_hI_BC"]


def _interval(values):
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)])
    if len(v) < 0.5 * MONTE_CARLO:
        return None, None, len(v) / MONTE_CARLO
    lo, mid, hi = np.percentile(v, [16, 50, 84])
    return [float(lo), float(hi)], float(mid), len(v) / MONTE_CARLO


def widening(law):
    """The factor on a pooled law's covariance (and chi2) for the predictions: its points over
    its independent ones, `n_points` / `independent_points` (1 where not given). A run's layers
    (both walls, every h) share one shear stress (the momentum balance makes it uniform: a
    layer's mu_eff depends neither on h nor on the wall) at nearly one h I_b per wall, which the
    fit counts as that many independent points, so its covariance is that many times too small."""
    n, k = law.get("n_points"), law.get("independent_points")
    return max(1.0, n / k) if n and k else 1.0


def _crossing(law, mu_0_fit, scale, unavailable=None, widen=1.0):
    """(estimate, 68% interval, fraction of draws with a crossing, reason) of
    x* / scale with law(x*) = mu_0 of the bulk. unavailable: the reason when no boundary law
    is to be taken; widen: the factor on the law's covariance for its draws."""
    if unavailable:
        return None, None, None, unavailable
    for name, f in (("the boundary law", law), ("the bulk law mu_power", mu_0_fit)):
        if not fitting.usable(f):
            return None, None, None, (f"{name} is {(f or {}).get('status', 'missing')}: "
                                      f"{(f or {}).get('reason')}")
    mu_0 = mu_0_fit["parameters"]["mu_0"]["value"]
    x = fitting.solve_for_x(law, mu_0)
    if x is None:
        return None, None, None, (f"the boundary law does not reach the bulk mu_0 = "
                                  f"{mu_0:.4g} at any positive x within the float range")
    rng = np.random.default_rng(SEED)
    laws = fitting.parameter_samples(law, MONTE_CARLO, rng, widen)
    mu0s = fitting.parameter_samples(mu_0_fit, MONTE_CARLO, rng)[:, 0]
    xs = [fitting.solve_for_x(law, m, params=p) for p, m in zip(laws, mu0s)]
    interval, _, frac = _interval([v / scale if v is not None else None for v in xs])
    if interval and not interval[0] <= x / scale <= interval[1]:
        # the draws' middle two thirds miss the estimate: the Gaussian of the covariance does
        # not describe the law there (a poor or nearly degenerate fit)
        return x / scale, None, frac, None
    return x / scale, interval, frac, None


def _interval_note(v, interval, frac):
    """Why a V_AB has no interval (None when it has one or has no value)."""
    if v is None or interval is not None:
        return None
    if frac is not None and frac < 0.5:
        return f"no interval: only {frac:.0%} of the parameter draws reach mu_0"
    return ("no interval: the parameter draws do not bracket V_AB, the laws' covariances do not "
            "describe their uncertainty")


def _outside(law, x):
    """True when x lies outside the x span of the law's points (to rounding)."""
    span = law.get("x_span")
    return bool(span) and not span[0] * (1 - 1e-9) <= x <= span[1] * (1 + 1e-9)


def _bc_v_ab(laws, mu_fit, scale, none_text):
    """V_AB from the B/C law in h I_b that `laws` (fits.json `boundary`, or one h's entry)
    chooses in its prediction_law, with its interval and its range over the allowed exponents;
    none_text leads the reason when it chooses none."""
    name, law = _bc_law(laws)
    choice = laws.get("prediction_law") or {}
    v, iv, frac, why = _crossing(law, mu_fit, scale, None if name else
                                 none_text + choice["reason"], widening(law))
    profile = choice.get("exponent_profile")
    return {"V_AB": v, "interval": iv, "draws_crossing": frac, "reason": why,
            "interval_note": _interval_note(v, iv, frac), "law": name,
            "form_range": _form_range(profile, mu_fit["parameters"]["mu_0"]["value"], scale),
            "allowed_B": (profile or {}).get("allowed_B")}


def predict_v_ab(rows, bulk_fits, boundary):
    """fits.json predictions `V_AB`: per system, from the pooled B/C law in h I_b, from the B/C
    law in h I_b at each h alone (`from_hI_law_by_h`: how far the collapse holds) and from each
    h's law in I_b, beside the measured bracket (filled in by the caller)."""
    mu_fit = bulk_fits.get("mu_power")
    out = {"status": "ok", "reason": None, "method": (
        "bulk mu_0 (mu_power) = boundary law at h I_b* (B: dv = V, so V_AB = h I_b* / "
        "sqrt(m / sigma_yy)); 68% interval of parameter draws"), "systems": {}}
    if not fitting.usable(mu_fit):
        return {"status": "not available", "reason": (
            f"the bulk law mu_power (mu_0) is {(mu_fit or {}).get('status', 'missing')}: "
            f"{(mu_fit or {}).get('reason')}"), "systems": {}}
    for system in sorted({r["system"] for r in rows if r.get("system") is not None}):
        sigmas = {r.get("_sigma_yy") for r in rows if r["system"] == system} - {None}
        if len(sigmas) != 1:
            continue
        scale = math.sqrt(INERTIAL_MASS / sigmas.pop())
        entry = {"from_hI_law": _bc_v_ab(boundary, mu_fit, scale,
                                         "no B/C law in h I_b is determined: ")}
        _, law = _bc_law(boundary)
        v = entry["from_hI_law"]["V_AB"]
        entry["from_hI_law"]["extrapolated"] = _outside(law, v * scale) if v is not None \
            else None
        by_h = {}
        for h in boundary["thicknesses"]:
            law_h = boundary[h_label(h)]["mu_power"]
            v, iv, frac, why = _crossing(law_h, mu_fit, scale / h, widen=widening(law_h))
            entry[h_label(h)] = {"V_AB": v, "interval": iv, "draws_crossing": frac,
                                 "reason": why, "interval_note": _interval_note(v, iv, frac)}
            if "prediction_law" in boundary[h_label(h)]:
                by_h[h_label(h)] = _bc_v_ab(boundary[h_label(h)], mu_fit, scale,
                                            "no B/C law in h I_b at this h: ")
        entry["from_hI_law_by_h"] = by_h
        out["systems"][str(system)] = entry
    return out


def symmetric_state_stability(rows, boundary):
    """fits.json predictions `symmetric_state_stability` (see the module's doc)."""
    def mean(ps, k):
        return float(np.mean([p[k] for p in ps]))

    def runs(ps):
        # a run's two walls share one shear stress (widening): one independent point per run,
        # not per wall
        return len({p["run"] for p in ps})
    entries = []
    for h in boundary["thicknesses"]:
        pts = [p for p in layer_points(rows, h) if p["regime"] in ("B", "C")]
        for system in sorted({p["system"] for p in pts if p["system"] is not None}):
            by_v = {}
            for p in pts:
                if p["system"] == system and p["mu_err"]:
                    by_v.setdefault(p["V"], []).append(p)
            vs = sorted(by_v)
            for v0, v1 in zip(vs, vs[1:]):
                a, b = by_v[v0], by_v[v1]
                dx = mean(b, "hI") - mean(a, "hI")
                e = math.hypot(mean(a, "mu_err") / math.sqrt(runs(a)),
                               mean(b, "mu_err") / math.sqrt(runs(b)))
                if dx <= 0:
                    slope, err, trend = None, None, "undetermined"
                else:
                    slope, err = (mean(b, "mu") - mean(a, "mu")) / dx, e / dx
                    trend = ("decreasing" if slope + 2 * err < 0 else
                             "increasing" if slope - 2 * err > 0 else "undetermined")
                observed = sorted({p["regime"] for p in a + b})
                entries.append({
                    "system": system, "h": h, "V": [v0, v1], "slope": slope, "slope_err": err,
                    "trend": trend, "predicted": {"decreasing": "unstable (C)",
                                                  "increasing": "stable (B)"}.get(trend),
                    "observed": "".join(observed)})
    if not entries:
        return {"status": "not available", "reason": "no two velocities of a system with "
                "steady B or C runs", "intervals": []}
    return {"status": "ok", "reason": None, "intervals": entries}


def predict_delta_mu(row, boundary):
    """The friction difference between the walls of a regime-C run from the boundary law
    (fits.json predictions `switch_time_C`, `delta_mu_law`; docs/reports.md): per h of the
    run, the pooled B/C law the predictions take (`prediction_law`: mu_hI_BC or its B -> 0
    limit; mu_eff of the sheared layers against h I_b = sqrt(m / sigma_yy) dv, every h) at each
    wall's measured velocity jump dv (`hK_bottom_velocity_jump`, `hK_top_velocity_jump`, taken
    >= 0), delta_mu = |mu(bottom) - mu(top)|, with the 68% interval of MONTE_CARLO draws of the
    law's parameters (clipped to the bounds of its family) and of the two jumps (Gaussian, their
    errors); the logarithmic limit gives none where a layer's h I_b lies below its points (it
    has no intercept). predicted_T is filled in by the caller (transitions.switch_predictions)."""
    name, law = _bc_law(boundary)
    out = {"law": f"{name or 'mu_hI_BC'}: " + law["law"], "law_name": name,
           "law_note": law.get("note"), "status": "ok", "reason": None, "by_h": {}}
    sigma = row.get("_sigma_yy")
    if name is None:
        return dict(out, status="not available", reason="no B/C law in h I_b is determined: "
                    + boundary["prediction_law"]["reason"])
    if not fitting.usable(law):
        return dict(out, status="not available",
                    reason=f"the boundary law {name} is {law['status']}: {law['reason']}")
    if sigma is None or sigma <= 0:
        return dict(out, status="not available", reason="no positive sigma_yy (normal_stress)")
    scale = math.sqrt(INERTIAL_MASS / sigma)
    model = fitting.MODELS[law["model"]]
    lo_b, hi_b = (np.broadcast_to(b, (len(law["parameters"]),)) for b in model["bounds"])
    rng = np.random.default_rng(SEED)
    params = np.clip(fitting.parameter_samples(law, MONTE_CARLO, rng, widening(law)), lo_b, hi_b)
    span = law.get("x_span")
    for h in row.get("_layers", []):
        label = h_label(h)
        # the layers window by window when the summary has them (a band that switched walls
        # makes each wall's mean jump about V), else each wall's mean
        layers = (("sheared_layer", "resting_layer")
                  if row.get(f"{label}_sheared_layer_velocity_jump") is not None
                  and row.get(f"{label}_resting_layer_velocity_jump") is not None
                  else ("bottom", "top"))
        dv = {s: (row.get(f"{label}_{layer}_velocity_jump"),
                  row.get(f"{label}_{layer}_velocity_jump_err"))
              for s, layer in zip(("bottom", "top"), layers)}
        e = {"h": h, "layers": list(layers),
             "velocity_jump_bottom": dv["bottom"][0], "velocity_jump_top": dv["top"][0],
             "hI_bottom": None, "hI_top": None, "mu_bottom": None, "mu_top": None,
             "delta_mu": None, "interval": None, "interval_note": None,
             "extrapolated": False, "mu_negative": False, "note": None, "reason": None}
        out["by_h"][label] = e
        missing = [s for s, (v, _) in dv.items() if v is None]
        if missing:
            e["reason"] = f"no velocity jump of the {' and '.join(missing)} layer for h = {h:g}"
            continue
        x = {s: scale * max(0.0, v) for s, (v, _) in dv.items()}
        below = [f"{s} h I_b = {x[s]:.3g}" for s in x if span and x[s] < span[0] * (1 - 1e-9)]
        if law["model"] == "log_plus" and below:
            # no intercept: the logarithm falls without bound below the points
            e.update(hI_bottom=x["bottom"], hI_top=x["top"], extrapolated=True,
                     reason=f"{', '.join(below)} below the law's points (from {span[0]:.3g}): "
                     f"{name}, a logarithm, falls without bound there and gives no delta_mu")
            continue
        mu = {s: float(fitting.curve(law, x[s])) for s in x}
        draws, drawn_below = {}, np.zeros(MONTE_CARLO, bool)
        with np.errstate(all="ignore"):
            for s, (v, err) in dv.items():
                sd = fitting.finite(err)   # no usable error (None, NaN, < 0): the jump itself
                sd = sd if sd is not None and sd > 0 else 0.0
                xs = scale * np.maximum(0.0, rng.normal(v, sd, MONTE_CARLO))
                draws[s] = model["model"](xs, *params.T)
                if span:
                    drawn_below |= xs < span[0]
            interval, _, _ = _interval(np.abs(draws["bottom"] - draws["top"]))
        delta = abs(mu["bottom"] - mu["top"])
        e.update(hI_bottom=x["bottom"], hI_top=x["top"], mu_bottom=mu["bottom"],
                 mu_top=mu["top"], delta_mu=delta, interval=interval)
        if law["model"] == "log_plus" and drawn_below.mean() > 0.02:
            # those draws' delta_mu has no bound: the interval would be cut on its large side
            e.update(interval=None, interval_note=(
                f"no interval: {drawn_below.mean():.0%} of the jumps' draws fall below the "
                "law's points, where the logarithm falls without bound"))
        elif law.get("note"):
            # a parameter at its bound: the Gaussian of the covariance is no description of
            # the law's uncertainty (its draws give nonsense)
            e.update(interval=None, interval_note="no interval: the law has a parameter at the "
                     "bound of its range (law_note), its covariance does not describe it")
        elif interval and not interval[0] <= delta <= interval[1]:
            e.update(interval=None, interval_note="no interval: the parameter draws do not "
                     "bracket delta_mu, the law's covariance does not describe its uncertainty")
        notes = [f"{s} h I_b = {x[s]:.3g}" for s in x   # (rounding: a fitted point is inside)
                 if span and not span[0] * (1 - 1e-9) <= x[s] <= span[1] * (1 + 1e-9)]
        e["extrapolated"] = bool(notes)
        if notes:
            notes = [", ".join(notes) + f" outside the law's points ({span[0]:.3g} to "
                     f"{span[1]:.3g}): extrapolated"]
        e["mu_negative"] = min(mu.values()) < 0
        if e["mu_negative"]:
            notes.append("the law gives mu_eff < 0 there: the extrapolation means nothing")
        e["note"] = "; ".join(notes) or None
    return out

"""Transition velocities of each system and the predictions of docs/model.md section 8, for
`cdshear report`.

`find_transitions(rows)` (fits.json `transitions`): per system, the runs' regimes by V, seeds
combined by majority vote per V, and the brackets of V_AB and V_BC. Only a steady run classified
"A", "B" or "C" votes (`voter`): a run that is not steady has a regime from an average over a
flow still changing, and a run without a regime or with any other label (undecided,
intermittent, ...) says nothing about which side of a transition its V lies on; the runs that do
not vote are listed with the reason (`not_voting`). Then:
  V_AB in [largest V classified B or C, smallest V classified A above it];
  V_BC in [largest V classified C, smallest V classified B above it];
the estimate is the geometric mean of the bracket. A sequence whose regimes do not go C -> B -> A
as V increases is flagged "not monotonic"; a transition without a run on one side is
"unbracketed" with the side that is missing.

`predictions(rows, fits)` (fits.json `predictions`): the predictions of model.md section 8 the
summaries can give, each next to what the runs show (docs/reports.md). Anything that
cannot be computed is given with its reason.
"""
import math

from . import fitting
from .rundata import is_number

RHO = 1.0                  # model.md section 1: 2D mass density
INERTIAL_MASS = math.pi / 4  # model.md sections 1 and 7: m in I = gamma_dot sqrt(m / sigma_yy)
RANK = {"C": 0, "B": 1, "A": 2}


# ---------------------------------------------------------------------------------------------
# Transition velocities

def voter(row):
    """None when the run votes (steady, regime A, B or C), else why it does not."""
    if row.get("steady") is not True:
        return "not steady" if row.get("steady") is False else "steady state unknown"
    regime = row.get("regime")
    if regime is None:
        return "no regime"
    if regime not in RANK:
        return f"regime {regime!r} (only A, B and C vote)"
    return None


def vote(regimes):
    """(majority regime or None on a tie / no vote, {regime: count})."""
    votes = {k: regimes.count(k) for k in "ABC" if regimes.count(k)}
    if not votes:
        return None, votes
    top = max(votes.values())
    winners = [k for k, n in votes.items() if n == top]
    return (winners[0] if len(winners) == 1 else None), votes


def system_sequence(rows):
    """Per V (ascending): {"V", "regime", "votes", "runs", "not_steady", "not_voting",
    "note"}; not_voting: [{"run", "reason"}] of the runs that do not vote (`voter`)."""
    by_v = {}
    for r in rows:
        if r.get("V") is None:
            continue
        by_v.setdefault(r["V"], []).append(r)
    out = []
    for V in sorted(by_v):
        runs = by_v[V]
        not_voting = [{"run": r["run"], "reason": voter(r)} for r in runs if voter(r)]
        regime, votes = vote([r["regime"] for r in runs if voter(r) is None])
        note = None
        if not votes:
            note = "no run votes (" + ", ".join(f"{e['run']}: {e['reason']}"
                                                for e in not_voting) + ")"
        elif regime is None:
            note = "tie between seeds: " + ", ".join(f"{k} {n}" for k, n in votes.items())
        out.append({"V": V, "regime": regime, "votes": votes, "runs": [r["run"] for r in runs],
                    "not_steady": [r["run"] for r in runs if r.get("steady") is not True],
                    "not_voting": not_voting, "note": note})
    return out


def _bracket(name, lo, hi, below_text, above_text):
    out = {"bracket": [lo, hi], "estimate": None, "status": "bracketed", "note": None}
    if lo is not None and hi is not None:
        out["estimate"] = math.sqrt(lo * hi)
    elif lo is None and hi is None:
        out.update(status="unbracketed", note=f"{name}: {below_text}")
    elif lo is None:
        out.update(status="unbracketed", note=f"{name} below the smallest V run ({hi:g}): "
                                              f"{below_text}")
    else:
        out.update(status="unbracketed", note=f"{name} above the largest V run ({lo:g}): "
                                              f"{above_text}")
    return out


def brackets(sequence):
    """V_AB, V_BC and the flags of one system's sequence (system_sequence)."""
    seq = [(e["V"], e["regime"]) for e in sequence if e["regime"] is not None]
    flags = [f"V = {e['V']:g}: {e['note']}" for e in sequence if e["note"]]
    ranks = [RANK[g] for _, g in seq]
    monotonic = all(a <= b for a, b in zip(ranks, ranks[1:]))
    if not monotonic:
        flags.append("not monotonic: " + ", ".join(f"{g} at {v:g}" for v, g in seq))
    # V_AB: the last change to A (everything above the bracket is A)
    not_a = [v for v, g in seq if g != "A"]
    lo_ab = max(not_a) if not_a else None
    above = [v for v, g in seq if g == "A" and (lo_ab is None or v > lo_ab)]
    hi_ab = min(above) if above else None
    v_ab = _bracket("V_AB", lo_ab, hi_ab, "no run classified B or C",
                    "no run classified A above it")
    if not seq:
        v_ab["note"] = "V_AB: no run votes (steady, regime A, B or C)"
    # V_BC: the last C, the first B above it
    c = [v for v, g in seq if g == "C"]
    lo_bc = max(c) if c else None
    b_above = [v for v, g in seq if g == "B" and (lo_bc is None or v > lo_bc)]
    hi_bc = min(b_above) if b_above else None
    if lo_bc is None and hi_bc is None:
        v_bc = _bracket("V_BC", None, None, "no run classified B or C", "")
    else:
        v_bc = _bracket("V_BC", lo_bc, hi_bc, "no run classified C",
                        "no run classified B above the largest C")
    if lo_bc is not None and hi_bc is None:
        a_above = [v for v, g in seq if g == "A" and v > lo_bc]
        if a_above:
            v_bc["note"] += f" (C at {lo_bc:g} is followed by A at {min(a_above):g})"
    return {"monotonic": monotonic, "flags": flags, "V_AB": v_ab, "V_BC": v_bc}


def find_transitions(rows):
    """fits.json `transitions`: {"<system>": {...}} for every system of the rows."""
    out = {}
    systems = sorted({r["system"] for r in rows if r.get("system") is not None})
    for s in systems:
        seq = system_sequence([r for r in rows if r["system"] == s])
        out[str(s)] = {"system": s, "velocities": seq,
                       "sequence": " ".join(e["regime"] or "?" for e in seq),
                       "not_voting": [e for v in seq for e in v["not_voting"]],
                       **brackets(seq)}
    return out


# ---------------------------------------------------------------------------------------------
# Predictions

def switch_time(V, L_y, nu, delta_mu, sigma_yy, rho=RHO):
    """model.md section 8: T = 2 rho nu V L_y / (delta_mu sigma_yy), a block of mass
    rho nu L_x L_y taken from -V to +V by the force delta_mu sigma_yy L_x."""
    return 2 * rho * nu * V * L_y / (delta_mu * sigma_yy)


def steady_state_time(fit, I, L_y, nu, sigma_yy, rho=RHO, m=INERTIAL_MASS):
    """model.md section 8: T_SS = L_y^2 / D, D = (d mu / d gamma_dot) sigma_yy / (rho nu) with
    d mu / d gamma_dot = (d mu / d I) sqrt(m / sigma_yy) (I = gamma_dot sqrt(m / sigma_yy)).
    Returns (T_SS, D)."""
    dmu_dgd = fitting.slope(fit, I) * math.sqrt(m / sigma_yy)
    D = dmu_dgd * sigma_yy / (rho * nu)
    return L_y ** 2 / D, D


def _missing(row, cols):
    return [c for c in cols if row.get(c) is None]


def switch_predictions(rows, boundary=None):
    """One entry per regime-C run: the predicted switch time beside the measured switches, and
    (`delta_mu_law`) delta_mu and T from the boundary law at the walls' velocity jumps
    (boundary: boundary_laws.fit_boundary; without it that is "not available")."""
    out = []
    for r in rows:
        if r.get("regime") != "C":
            continue
        e = {"run": r["run"], "system": r["system"], "V": r["V"], "steady": r.get("steady"),
             "L_y": r.get("L_y"), "nu_bulk": r.get("nu_bulk"), "sigma_yy": r.get("_sigma_yy"),
             "rho": RHO, "delta_mu": None, "delta_mu_err": None, "delta_mu_source": None,
             "predicted_T": None, "reason": None}
        sw = r.get("_switches") or []
        starts = sorted(s["start_time"] for s in sw if isinstance(s, dict)
                        and s.get("start_time") is not None)
        # the switches are those of the averaged span (summary.json): the time they cover
        averaged = r.get("_averaged_time")
        observed = (averaged if is_number(averaged) and math.isfinite(averaged) and averaged > 0
                    else r.get("time_reached"))
        e.update(switch_count=len(sw), observed_time=observed,
                 switch_duration=r.get("switch_duration"),
                 switch_duration_err=r.get("switch_duration_err"),
                 switch_time=r.get("switch_time"), switch_time_err=r.get("switch_time_err"),
                 mean_interval=((starts[-1] - starts[0]) / (len(starts) - 1)
                                if len(starts) >= 2 else None),
                 time_per_switch=(observed / len(sw) if sw and observed else None))
        if not sw:
            e["measured_note"] = (f"no switch in {observed:g} time units" if observed
                                  else "no switch")
        # The walls' net friction on the plateau before each switch: by momentum balance about
        # zero on a true plateau, so a diagnostic and no prediction (the block is accelerated
        # by a friction difference that appears with the switch itself).
        e["delta_mu_plateau"] = r.get("switch_delta_mu")
        e["delta_mu_plateau_err"] = r.get("switch_delta_mu_err")
        # the delta_mu that the measured switch time implies (regime.band_switches: the T of
        # model.md section 8 at each switch's fitted rate)
        T = e["switch_time"]
        if T and T > 0 and not _missing(e, ["V", "L_y", "nu_bulk", "sigma_yy"]) \
                and e["sigma_yy"] > 0:
            e["delta_mu_implied"] = 2 * RHO * e["nu_bulk"] * e["V"] * e["L_y"] / (
                T * e["sigma_yy"])
        else:
            e["delta_mu_implied"] = None
        e["delta_mu_law"] = _delta_mu_law(r, e, boundary)
        # The prediction: the boundary law's delta_mu at the layers' jumps, at the h closest to
        # the 10 of model.md section 7 among those that give a T.
        by_h = [v for v in e["delta_mu_law"]["by_h"].values() if v.get("predicted_T")]
        missing = _missing(e, ["V", "L_y", "nu_bulk", "sigma_yy"])
        if by_h and not missing:
            best = min(by_h, key=lambda v: (abs(v["h"] - 10.0), v["h"]))
            T = best["predicted_T"]
            e.update(delta_mu=best["delta_mu"], predicted_T=T,
                     delta_mu_source=f"the boundary law "
                                     f"{e['delta_mu_law'].get('law_name') or 'mu_hI_BC'} at "
                                     f"the layers' velocity jumps, h = {best['h']:g} "
                                     "(delta_mu_law)")
        elif missing:
            e["reason"] = "not computed: missing " + ", ".join(missing)
        else:
            first = next((v["reason"] for v in e["delta_mu_law"]["by_h"].values()
                          if v.get("reason")), None)
            e["reason"] = ("not computed: no delta_mu from the boundary law ("
                           + (e["delta_mu_law"].get("reason") or first
                              or "no h gives a switch time") + ")")
        out.append(e)
    return out


def _delta_mu_law(row, e, boundary):
    """boundary_laws.predict_delta_mu of the run, with per h the switch time T of its delta_mu
    (`predicted_T`, and `predicted_T_interval` from the interval of delta_mu)."""
    from .boundary_laws import predict_delta_mu
    if boundary is None:
        return {"law": None, "law_note": None, "status": "not available",
                "reason": "needs the boundary friction law mu_eff(h I_boundary), not fitted",
                "by_h": {}}
    out = predict_delta_mu(row, boundary)
    ok = not _missing(e, ["V", "L_y", "nu_bulk", "sigma_yy"]) and e["sigma_yy"] > 0

    def T(dmu):
        return switch_time(e["V"], e["L_y"], e["nu_bulk"], dmu, e["sigma_yy"]) \
            if ok and dmu and dmu > 0 else None
    for entry in out["by_h"].values():
        entry["predicted_T"] = T(entry["delta_mu"])
        iv = entry["interval"]
        # (T falls as delta_mu grows; a lower end of 0 gives no upper end: null)
        entry["predicted_T_interval"] = [T(iv[1]), T(iv[0])] if iv else None
        if entry["delta_mu"] is not None and entry["predicted_T"] is None \
                and entry["reason"] is None:
            entry["reason"] = ("T not computed: " + ("delta_mu is 0" if ok else "missing " +
                               ", ".join(_missing(e, ["V", "L_y", "nu_bulk", "sigma_yy"]))))
    return out


def steady_state_predictions(rows, fits):
    """One entry per regime-A run: T_SS from the fitted mu_eff(I) beside transient_end_time."""
    law = next((k for k in ("mu_power", "mu_linear") if fitting.usable(fits.get(k))), None)
    out = []
    for r in rows:
        if r.get("regime") != "A":
            continue
        e = {"run": r["run"], "system": r["system"], "V": r["V"], "steady": r.get("steady"),
             "I_bulk": r.get("I_bulk"), "L_y": r.get("L_y"), "nu_bulk": r.get("nu_bulk"),
             "sigma_yy": r.get("_sigma_yy"), "law": law,
             "law_status": fits[law].get("status") if law else None, "dmu_dI": None, "D": None,
             "predicted_T_SS": None, "measured_transient_end_time": r.get("transient_end_time"),
             "reason": None}
        missing = _missing(e, ["I_bulk", "L_y", "nu_bulk", "sigma_yy"])
        if law is None:
            e["reason"] = "not computed: no mu_eff(I) law whose parameters are determined (" + \
                "; ".join(f"{k} {fitting.status_text(fits.get(k))}"
                          for k in ("mu_power", "mu_linear")) + ")"
        elif missing:
            e["reason"] = "not computed: missing " + ", ".join(missing)
        elif e["I_bulk"] <= 0 or e["sigma_yy"] <= 0 or e["nu_bulk"] <= 0:
            e["reason"] = "not computed: I_bulk, sigma_yy or nu_bulk is not positive"
        else:
            fit = fits[law]
            e["dmu_dI"] = fitting.slope(fit, e["I_bulk"])
            if e["dmu_dI"] <= 0:
                e["reason"] = (f"not computed: d mu_eff / d I = {e['dmu_dI']:.3g} <= 0 at "
                               f"I = {e['I_bulk']:.3g} (no diffusion)")
            else:
                e["predicted_T_SS"], e["D"] = steady_state_time(
                    fit, e["I_bulk"], e["L_y"], e["nu_bulk"], e["sigma_yy"])
                if law == "mu_linear" and not fits[law]["range"][0] < e["I_bulk"] < \
                        fits[law]["range"][1]:
                    e["note"] = "I_bulk outside the range of the linear law"
        if e["measured_transient_end_time"] is None:
            e["measured_note"] = "no transient_end_time (run not steady)"
        out.append(e)
    return out


def predictions(rows, fits, boundary=None, transitions=None):
    """fits.json `predictions`. boundary: boundary_laws.fit_boundary (without it, V_AB and the
    stability are "not available"); transitions: find_transitions, for the measured V_AB."""
    from .boundary_laws import predict_v_ab, symmetric_state_stability
    missing = {"status": "not available",
               "reason": "needs the boundary friction law mu_eff(I_boundary), not fitted"}
    if boundary is None:
        v_ab, stability = dict(missing), dict(missing)
    else:
        v_ab = predict_v_ab(rows, fits, boundary)
        for key, entry in v_ab["systems"].items():
            measured = (transitions or {}).get(key, {}).get("V_AB")
            entry["measured"] = ({"bracket": measured["bracket"],
                                  "estimate": measured["estimate"]} if measured else None)
        stability = symmetric_state_stability(rows, boundary)
    return {
        "constants": {"rho": RHO, "inertial_mass": INERTIAL_MASS},
        "V_AB": v_ab,
        "symmetric_state_stability": stability,
        "switch_time_C": switch_predictions(rows, boundary),
        "steady_state_time_A": steady_state_predictions(rows, fits),
    }

"""Flow regime A/B/C (SPEC 8), centre-of-mass statistics and shear-band switches.

Criteria, with r = bulk shear rate / (2 V / L_y) (bulk: see summary.choose_bulk_range) and
f = fraction of samples with |com_vx| > COM_LEVEL * V:
  A  if r > SHEAR_RATIO_A                    (the bulk is sheared);
  C  else if f > COM_FRACTION_C              (the bulk moves with one wall most of the time);
  B  otherwise                               (still bulk, com_vx fluctuating about 0).
Confidence in [0, 1] = 0.5 * margin + 0.5 * agreement. margin is how far the deciding
statistics sit from their thresholds, each scaled to [0, 1]: |r - 0.3| / 0.3, (f - 0.6) / 0.4
for C, (0.6 - f) / 0.6 for B (the smaller of the two for B and C); agreement is the fraction
of steady windows classified the same way from their own r and f.

Band switches: state +1 while com_vx > COM_LEVEL V (bulk with the top wall, band at the bottom),
-1 while com_vx < -COM_LEVEL V, 0 in between; a switch is a change between +1 and -1, the
excursions through 0 being part of it: start = first sample after the last one in the old
state, end = first sample in the new state.
"""
import numpy as np

SHEAR_RATIO_A = 0.3     # r above this: regime A
COM_LEVEL = 0.5         # |com_vx| > COM_LEVEL * V: the bulk moves with a wall
COM_FRACTION_C = 0.6    # f above this (and not A): regime C
VISIT_LEVEL = 0.9       # switches are also listed outside C if com_vx passes both +-0.9 V
HISTOGRAM_RANGE = 1.2   # com_vx histogram over [-1.2 V, 1.2 V] ...
HISTOGRAM_BINS = 24     # ... in bins of 0.1 V (values outside fall in the end bins)


def classify(r, f):
    """Regime letter from the shear-rate ratio r and the com fraction f."""
    if r > SHEAR_RATIO_A:
        return "A"
    return "C" if f > COM_FRACTION_C else "B"


def com_fraction(com_vx, velocity):
    """Fraction of finite samples with |com_vx| > COM_LEVEL * V (NaN without samples)."""
    com = np.asarray(com_vx, dtype=float)
    com = com[np.isfinite(com)]
    return float(np.mean(np.abs(com) > COM_LEVEL * velocity)) if len(com) else np.nan


def margin(regime, r, f):
    """How clearly (r, f) sits on its side of the thresholds, in [0, 1]."""
    m_r = abs(r - SHEAR_RATIO_A) / SHEAR_RATIO_A
    if regime == "A":
        m = m_r
    elif regime == "C":
        m = min(m_r, (f - COM_FRACTION_C) / (1 - COM_FRACTION_C))
    else:
        m = min(m_r, (COM_FRACTION_C - f) / COM_FRACTION_C)
    return float(np.clip(m, 0.0, 1.0)) if np.isfinite(m) else 0.0


def criterion_text(regime, r, f):
    """Why (r, f) gives `regime`, e.g. "A: r = 0.85 > 0.3"."""
    if regime == "A":
        return f"A: r = {r:.3g} > {SHEAR_RATIO_A:g}"
    side = ">" if regime == "C" else "<="
    return (f"{regime}: r = {r:.3g} <= {SHEAR_RATIO_A:g} and f = {f:.3g} {side} "
            f"{COM_FRACTION_C:g}")


def classify_run(r, f, window_r, window_f):
    """Regime, confidence and the statistics used. window_r/window_f: per steady window."""
    regime = classify(r, f)
    votes = [classify(rw, fw) for rw, fw in zip(window_r, window_f) if np.isfinite(rw)]
    agreement = float(np.mean([v == regime for v in votes])) if votes else np.nan
    confidence = 0.5 * margin(regime, r, f) + 0.5 * (agreement if votes else 0.0)
    criteria = dict(shear_rate_ratio=r, shear_rate_ratio_threshold=SHEAR_RATIO_A,
                    com_fraction=f, com_level=COM_LEVEL, com_fraction_threshold=COM_FRACTION_C,
                    window_agreement=agreement, windows_classified=len(votes),
                    window_votes={k: votes.count(k) for k in "ABC"},
                    reason=criterion_text(regime, r, f))
    return regime, float(confidence), criteria


def com_histogram(com_vx, velocity):
    """Histogram of com_vx over [-HISTOGRAM_RANGE V, HISTOGRAM_RANGE V]: (edges, counts)."""
    edges = np.linspace(-HISTOGRAM_RANGE, HISTOGRAM_RANGE, HISTOGRAM_BINS + 1) * velocity
    com = np.asarray(com_vx, dtype=float)
    com = np.clip(com[np.isfinite(com)], edges[0], edges[-1])
    return edges, np.histogram(com, bins=edges)[0]


def bimodality_coefficient(x):
    """Sarle's bimodality coefficient (g^2 + 1) / (k + 3 (n-1)^2 / ((n-2)(n-3))), g the
    skewness, k the excess kurtosis (sample-corrected): 1/3 for a Gaussian, 1 for two equal
    spikes; above 5/9 suggests bimodality."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    n = len(x)
    if n < 4 or np.std(x) == 0:
        return np.nan
    d = x - x.mean()
    m2, m3, m4 = np.mean(d ** 2), np.mean(d ** 3), np.mean(d ** 4)
    g = np.sqrt(n * (n - 1)) / (n - 2) * m3 / m2 ** 1.5
    k = (n - 1) / ((n - 2) * (n - 3)) * ((n + 1) * (m4 / m2 ** 2 - 3) + 6)
    return float((g * g + 1) / (k + 3 * (n - 1) ** 2 / ((n - 2) * (n - 3))))


def visits_both_walls(com_vx, velocity):
    """True if com_vx goes above VISIT_LEVEL V and below -VISIT_LEVEL V."""
    com = np.asarray(com_vx, dtype=float)
    level = VISIT_LEVEL * velocity
    return bool(np.nanmax(com) > level and np.nanmin(com) < -level)


def band_states(com_vx, velocity):
    """+1 above COM_LEVEL V, -1 below -COM_LEVEL V, 0 between (and for NaN)."""
    com = np.nan_to_num(np.asarray(com_vx, dtype=float))
    return np.where(com > COM_LEVEL * velocity, 1, np.where(com < -COM_LEVEL * velocity, -1, 0))


def band_switches(time, com_vx, velocity):
    """Every switch of the shear band between the walls, as dicts with start_time, end_time,
    duration, from_state, to_state and band ("bottom->top" or "top->bottom")."""
    time = np.asarray(time, dtype=float)
    states = band_states(com_vx, velocity)
    nonzero = np.flatnonzero(states)
    changes = np.flatnonzero(np.diff(states[nonzero]) != 0)
    switches = []
    for k in changes:
        old, new = nonzero[k], nonzero[k + 1]      # last sample in the old state, first in the new
        start, end = time[old + 1], time[new]
        from_state = int(states[old])
        switches.append(dict(start_time=float(start), end_time=float(end),
                             duration=float(end - start), from_state=from_state,
                             to_state=-from_state,
                             band="bottom->top" if from_state > 0 else "top->bottom"))
    return switches

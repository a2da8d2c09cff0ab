"""Flow regimes A, B, C (docs/model.md section 8) by positive criteria, per window and per run; the
block velocity's statistics; shear-band switches.

Block velocity u, the velocity of the bulk between the boundary layers:
  per sample, the series `block_vx` (mass-weighted x-velocity of the grains whose centre lies in
  the central half H/4 < y < 3H/4) when the file has it, else `com_vx` (the whole layer: its
  plateaus in regime C sit below V by the share of the sheared layer); `block_velocity_source`
  says which;
  per window, the mean of v_x(y) over the bulk stripes lo < y < hi of the window's profile (the
  bulk of summary.choose_bulk_range).

Window state (each averaged window, from its own profile and its own samples, t0 < t <= t1), with
r = bulk shear rate / (2 V / H), R^2 of the straight line fitted to v_x(y) over the bulk, and the
layers' velocity jumps dv_bottom = v_x(lo) + V, dv_top = V - v_x(hi):
  A   r > SHEAR_RATIO_A and R^2 >= LINEARITY_A (the bulk is sheared, homogeneously);
  B   r <= SHEAR_RATIO_BLOCK, each layer carries about V (|dv - V| <= JUMP_TOLERANCE V), and
      |u| <= COM_LEVEL V in at least WINDOW_SAMPLE_SHARE of the samples;
  C+  r <= SHEAR_RATIO_BLOCK, the bottom layer carries about 2V and the top one about 0 (each
      within JUMP_TOLERANCE V), u > COM_LEVEL V in at least WINDOW_SAMPLE_SHARE of the samples:
      the block moves with the top wall, the band is at the bottom (band_wall "bottom");
  C-  the mirror image (u < -COM_LEVEL V; band_wall "top");
  undecided otherwise (the window's reason says which criterion failed).

Run regime, from the window states' shares of the averaged time and the averaged samples of u:
  undecided  fewer than MIN_WINDOWS averaged windows (too short to tell);
  A          A windows >= DOMINANT_SHARE;
  B          B windows >= DOMINANT_SHARE, |u| <= COM_LEVEL V in >= SAMPLE_SHARE of the samples,
             one peak about 0 (histogram mode within COM_LEVEL V of 0, at most WALL_PEAK_SHARE
             of the samples within PLATEAU_LEVEL V of a wall's velocity; Sarle's bimodality
             coefficient is reported beside it);
  C          C+ and C- windows >= DOMINANT_SHARE, |u| > COM_LEVEL V in >= SAMPLE_SHARE of the
             samples, the plateau (below) of each side holding >= INTERMITTENT_SHARE of them
             found, and (if the band switches) the mean time on a plateau at least DWELL_RATIO
             switch durations;
  intermittent  windows in a positive state >= DOMINANT_SHARE, at least two of A, B, C with
             >= INTERMITTENT_SHARE each, the states told apart: at most GAP_SHARE of the samples
             in the gap GAP_LEVELS between rest and wall;
  undecided  otherwise, e.g. a block velocity that wanders between rest and the walls, or states
             switching faster than they can be told apart.
regime_confidence: the share of the averaged window time whose own state agrees with the run's
regime (A, B: that state; C: C+ and C-; intermittent: any positive state); NaN when undecided.

Band switches. The plateaus P+ and P- are the medians of the samples beyond +-COM_LEVEL V (none
for a side whose median lies within GAP_LEVELS[1] V of 0: the tail of a velocity fluctuating
about 0 is no plateau). Switches are found on u averaged over SMOOTHING_DISPLACEMENT / V (centred),
the time the walls take to move one mean diameter: the block velocity oscillates on its plateaus
with about that period as the grains' layers pass (system 1 at V = 0.02: sample scatter 0.11 V,
autocorrelation negative at 20 t, positive again at 45 t). The averaged u is on a plateau within
PLATEAU_LEVEL V of it; a change from one plateau to the other is a switch when the averaged u
then stays on the new plateau (its last sample there before it is back on the old one) for at
least MIN_STAY_RATIO times the change took and at least one averaging time (a change too close to
the series' end to tell is none): a brief touch of the other plateau is an excursion, like one
that turns back before it, and a change that rests at 0 (B) on the way is one switch through the
rest. A switch's start and end are those of the straight ramp from P_old to P_new, between the
two plateaus held flat, that fits the samples of u around the change best (least squares over
the change and as long again on each side): the model.md section 8 block accelerated at a
constant rate by the friction difference, measured on the samples themselves, so the plateaus'
scatter widens the error but does not shorten the duration as first and last threshold crossings
do. duration = end - start, plateau to plateau; switch_time = the T of model.md section 8, the
time from +V to -V at the fitted rate: duration 2V / |P_new - P_old| from block_vx, the duration
itself from com_vx (its plateaus sit inside +-V by the sheared layer's share, the block's at
+-V); both NaN where the fit's samples miss more than one averaging time in a row. delta_mu is
taken over the stretch of the old plateau before the ramp starts, PRE_SWITCH_TIME long or back
to the previous switch's end if that is nearer (summary.switch_friction_difference). Switches are
found over the whole series, but a run counts only those starting in its averaged span
(switches_in): the summary's switches, their statistics and the regime test's dwell criterion
are all over that span.
"""
import numpy as np

# r of a block is noise about 0: within +-0.09 over the 80-t windows of system 1's C runs (bulk
# of 6 stripes at h = 7), +-0.03 in system 2's (h = 10); a sheared bulk of system 1 at V = 2
# takes r = 0.23 to 0.35 (its layers carry 0.9 V each over 7 d), of system 2 at V = 0.8, 0.27 to
# 0.38 (the reduced campaign). Between the two thresholds a window is neither.
SHEAR_RATIO_A = 0.2       # window A: r above this (the bulk takes 20% of the mean shear rate) ...
LINEARITY_A = 0.8         # ... and R^2 of the line through v_x(y) over the bulk at least this
SHEAR_RATIO_BLOCK = 0.1   # window B or C: r at most this (a block); between 0.1 and 0.2: neither
JUMP_TOLERANCE = 0.5      # a layer carries "V" if |dv - V| <= 0.5 V; "2V", "0" alike
COM_LEVEL = 0.5           # per sample: |u| <= 0.5 V the block rests, beyond it moves with a wall
# The steady test ignores changes of |u| whose batch means stay within 0.1 V of each other: a
# fifth of COM_LEVEL, so no sample's or window's state can follow them (in regime A the block
# velocity wanders by 1 to 4% of V over thousands of time units in the validation campaign's runs).
BLOCK_SPEED_TOLERANCE = 0.1
WINDOW_SAMPLE_SHARE = 0.8  # a B or C window: at least 80% of its samples on its state's side
MIN_WINDOWS = 3           # fewer averaged windows (240 t at the default window): too short to tell
DOMINANT_SHARE = 0.7      # run A, B, C: windows in that state over at least 70% of the time
SAMPLE_SHARE = 0.8        # run B, C: at least 80% of the averaged samples on that state's side
BIMODALITY_LEVEL = 5 / 9  # Sarle's coefficient above which a sample suggests two peaks (reported)
WALL_PEAK_SHARE = 0.05    # run B: at most 5% of the samples on a wall's plateau (no second peak)
INTERMITTENT_SHARE = 0.2  # run intermittent: two regimes with at least 20% of the time each
GAP_LEVELS = (0.3, 0.7)   # the gap between rest and wall: 0.3 V < |u| < 0.7 V ...
GAP_SHARE = 0.2           # ... holding at most 20% of the samples: the states are told apart
DWELL_RATIO = 5.0         # C: mean time on a plateau at least 5 switch durations
PLATEAU_LEVEL = 0.2       # on a plateau: the averaged u within 0.2 V of it
SMOOTHING_DISPLACEMENT = 1.0  # switches found on u averaged while the walls move this far [d]
MIN_STAY_RATIO = 1.0      # a new plateau holds at least as long as the change into it took
PRE_SWITCH_TIME = 80.0    # delta_mu over this long a stretch of the old plateau before a switch
FIT_GRID = 400            # ramp ends tried over the fit's span, each end ...
FIT_REFINE = 41           # ... then about the best pair, over two of the first grid's steps
VISIT_LEVEL = 0.9         # com_vx visits both walls: beyond +0.9 V and below -0.9 V
HISTOGRAM_RANGE = 1.2     # histograms over [-1.2 V, 1.2 V] ...
HISTOGRAM_BINS = 24       # ... in bins of 0.1 V (values outside fall in the end bins)

STATES = ("A", "B", "C+", "C-", "undecided")
REGIMES = ("A", "B", "C", "intermittent", "undecided")
BAND_WALL = {"C+": "bottom", "C-": "top"}   # the wall whose layer is sheared in each C state


# ---------------------------------------------------------------------------------------------
# Block velocity per sample

def block_velocity(series):
    """(u, source): the series block_vx when present with finite values, else com_vx."""
    b = series.get("block_vx")
    if b is not None and len(b) == len(series["time"]) and np.isfinite(b).any():
        return np.asarray(b, dtype=float), "block_vx"
    return np.asarray(series["com_vx"], dtype=float), "com_vx"


def com_fraction(u, velocity):
    """Fraction of finite samples with |u| > COM_LEVEL * V (NaN without samples)."""
    u = np.asarray(u, dtype=float)
    u = u[np.isfinite(u)]
    return float(np.mean(np.abs(u) > COM_LEVEL * velocity)) if len(u) else np.nan


def sample_shares(u, velocity):
    """Shares of the finite samples: rest |u| <= COM_LEVEL V, plus u > COM_LEVEL V, minus
    u < -COM_LEVEL V, gap GAP_LEVELS[0] V < |u| < GAP_LEVELS[1] V (NaN without samples)."""
    u = np.asarray(u, dtype=float)
    u = u[np.isfinite(u)]
    if not len(u):
        return dict(rest=np.nan, plus=np.nan, minus=np.nan, gap=np.nan)
    a, level = np.abs(u), COM_LEVEL * velocity
    return dict(rest=float(np.mean(a <= level)), plus=float(np.mean(u > level)),
                minus=float(np.mean(u < -level)),
                gap=float(np.mean((a > GAP_LEVELS[0] * velocity) & (a < GAP_LEVELS[1] * velocity))))


def com_histogram(u, velocity):
    """Histogram of u over [-HISTOGRAM_RANGE V, HISTOGRAM_RANGE V]: (edges, counts)."""
    edges = np.linspace(-HISTOGRAM_RANGE, HISTOGRAM_RANGE, HISTOGRAM_BINS + 1) * velocity
    u = np.asarray(u, dtype=float)
    u = np.clip(u[np.isfinite(u)], edges[0], edges[-1])
    return edges, np.histogram(u, bins=edges)[0]


def histogram_mode(u, velocity):
    """Centre of the fullest bin of com_histogram (NaN without samples)."""
    edges, counts = com_histogram(u, velocity)
    if not counts.sum():
        return np.nan
    k = int(np.argmax(counts))
    return float(0.5 * (edges[k] + edges[k + 1]))


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
    if not np.isfinite(com).any():
        return False
    level = VISIT_LEVEL * velocity
    return bool(np.nanmax(com) > level and np.nanmin(com) < -level)


# ---------------------------------------------------------------------------------------------
# Windows

def window_profile(y, vx, lo, hi, height, velocity):
    """r, R^2, block velocity and the two layers' velocity jumps of one window's profile."""
    y, vx = np.asarray(y, dtype=float), np.asarray(vx, dtype=float)
    out = dict(shear_rate_ratio=np.nan, linearity=np.nan, block_velocity=np.nan,
               velocity_jump_bottom=np.nan, velocity_jump_top=np.nan)
    ok = np.isfinite(vx)
    bulk = ok & (y > lo) & (y < hi)
    if bulk.sum() >= 2:
        slope, icpt = np.polyfit(y[bulk], vx[bulk], 1)
        ss_tot = np.sum((vx[bulk] - vx[bulk].mean()) ** 2)
        ss_res = np.sum((vx[bulk] - slope * y[bulk] - icpt) ** 2)
        out.update(shear_rate_ratio=float(slope * height / (2 * velocity)),
                   linearity=float(1 - ss_res / ss_tot) if ss_tot > 0 else np.nan,
                   block_velocity=float(np.mean(vx[bulk])))
    if ok.sum() >= 2:
        out.update(velocity_jump_bottom=float(np.interp(lo, y[ok], vx[ok]) + velocity),
                   velocity_jump_top=float(velocity - np.interp(hi, y[ok], vx[ok])))
    return out


def _carries(dv, multiple, velocity):
    return bool(np.isfinite(dv) and abs(dv - multiple * velocity) <= JUMP_TOLERANCE * velocity)


def window_state(p, shares, velocity):
    """(state, reason) of one window from window_profile's p and sample_shares of its samples."""
    V = velocity
    r, lin = p["shear_rate_ratio"], p["linearity"]
    jb, jt = p["velocity_jump_bottom"], p["velocity_jump_top"]
    if not (np.isfinite(r) and np.isfinite(jb) and np.isfinite(jt)):
        return "undecided", "no bulk profile (fewer than 2 stripes with a velocity)"
    if r > SHEAR_RATIO_A:
        if np.isfinite(lin) and lin >= LINEARITY_A:
            return "A", f"r = {r:.3g} > {SHEAR_RATIO_A:g}, R^2 = {lin:.2f} >= {LINEARITY_A:g}"
        return "undecided", (f"r = {r:.3g} > {SHEAR_RATIO_A:g} but the bulk profile is not "
                             f"linear (R^2 = {lin:.2f} < {LINEARITY_A:g})")
    if r > SHEAR_RATIO_BLOCK:
        return "undecided", (f"r = {r:.3g} between {SHEAR_RATIO_BLOCK:g} and "
                             f"{SHEAR_RATIO_A:g}: neither sheared nor a block")
    if r < -SHEAR_RATIO_BLOCK:
        return "undecided", (f"r = {r:.3g} < -{SHEAR_RATIO_BLOCK:g}: the bulk is sheared against "
                             f"the walls' sense, not a block")
    jumps = f"jumps {jb / V:.2f} V (bottom), {jt / V:.2f} V (top)"
    if _carries(jb, 1, V) and _carries(jt, 1, V):
        state, share, side = "B", shares["rest"], f"|u| <= {COM_LEVEL:g} V"
    elif _carries(jb, 2, V) and _carries(jt, 0, V):
        state, share, side = "C+", shares["plus"], f"u > {COM_LEVEL:g} V"
    elif _carries(jt, 2, V) and _carries(jb, 0, V):
        state, share, side = "C-", shares["minus"], f"u < -{COM_LEVEL:g} V"
    else:
        return "undecided", (f"r = {r:.3g}, {jumps}: neither both layers about V (B) nor one "
                             f"about 2V and the other about 0 (C), within {JUMP_TOLERANCE:g} V")
    text = f"r = {r:.3g} <= {SHEAR_RATIO_BLOCK:g}, {jumps}"
    if not np.isfinite(share):
        return "undecided", f"{text} ({state}'s), but no sample of u in the window"
    if share < WINDOW_SAMPLE_SHARE:
        return "undecided", (f"{text} ({state}'s), but {side} in only {share:.0%} of the "
                             f"samples < {WINDOW_SAMPLE_SHARE:.0%} (the block changes state)")
    return state, f"{text}, {side} in {share:.0%} of the samples"


def window_table(windows, indices, lo, hi, time, u, velocity):
    """The state of each window of `indices`, as columns (lists, one entry per window): index,
    t_start, t_end, state, band_wall (None outside C), reason, and window_profile's and
    sample_shares' values (rest_share, plus_share, minus_share)."""
    keys = ("index", "t_start", "t_end", "state", "band_wall", "reason", "shear_rate_ratio",
            "linearity", "block_velocity", "velocity_jump_bottom", "velocity_jump_top",
            "rest_share", "plus_share", "minus_share")
    table = {k: [] for k in keys}
    y = np.asarray(windows["y"], dtype=float)
    time, u = np.asarray(time, dtype=float), np.asarray(u, dtype=float)
    for i in indices:
        t0, t1 = float(windows["t_start"][i]), float(windows["t_end"][i])
        p = window_profile(y, windows["vx"][i], lo[i], hi[i], float(windows["height"][i]),
                           velocity)
        shares = sample_shares(u[(time > t0) & (time <= t1)], velocity)
        state, reason = window_state(p, shares, velocity)
        row = dict(index=int(i), t_start=t0, t_end=t1, state=state,
                   band_wall=BAND_WALL.get(state), reason=reason, rest_share=shares["rest"],
                   plus_share=shares["plus"], minus_share=shares["minus"], **p)
        for k in keys:
            table[k].append(row[k])
    return table


def state_shares(table):
    """{state: share of the windows' time} over STATES (NaN without windows)."""
    length = np.asarray(table["t_end"], dtype=float) - np.asarray(table["t_start"], dtype=float)
    total = length.sum()
    return {s: (float(length[[x == s for x in table["state"]]].sum() / total) if total > 0
                else np.nan) for s in STATES}


# ---------------------------------------------------------------------------------------------
# Band switches

def plateau_velocities(u, velocity):
    """(P+, P-): the median of the samples beyond +COM_LEVEL V and of those beyond -COM_LEVEL V,
    NaN for a side without any or whose median lies within GAP_LEVELS[1] V of 0 (the tail of a
    velocity fluctuating about 0 is no plateau). The same for both sources: block_vx sits near
    +-V on its plateaus (less where the block slips on the resting layer), com_vx inside them by
    the sheared layer's share."""
    u = np.asarray(u, dtype=float)
    u = u[np.isfinite(u)]
    level = COM_LEVEL * velocity
    out = []
    for side in (u[u > level], -u[u < -level]):
        m = float(np.median(side)) if len(side) else np.nan
        out.append(m if m >= GAP_LEVELS[1] * velocity else np.nan)
    return out[0], -out[1]


def band_states(u, velocity, plateaus):
    """+1 within PLATEAU_LEVEL V of P+, -1 within it of P-, else 0 (a NaN plateau: never)."""
    p_plus, p_minus = plateaus
    u = np.asarray(u, dtype=float)
    level = PLATEAU_LEVEL * velocity
    with np.errstate(invalid="ignore"):
        plus = np.abs(u - p_plus) <= level
        minus = np.abs(u - p_minus) <= level
    return np.where(plus, 1, np.where(minus, -1, 0))


def running_mean(time, u, width):
    """The centred running mean of u over `width` time units (at least one sample; the finite
    samples only; fewer at the ends of the series). Samples are taken as evenly spaced."""
    u = np.asarray(u, dtype=float)
    if len(u) < 2:
        return u.copy()
    interval = float(np.median(np.diff(time)))
    # samples each side; the whole series where width / interval is beyond it (or not finite)
    span = 0.5 * width / interval + 0.5 if interval > 0 else 0.0
    half = int(np.floor(span)) if span < len(u) else len(u)
    finite = np.isfinite(u)
    total = np.concatenate([[0.0], np.cumsum(np.where(finite, u, 0.0))])
    count = np.concatenate([[0], np.cumsum(finite)])
    i = np.arange(len(u))
    lo, hi = np.maximum(i - half, 0), np.minimum(i + half + 1, len(u))
    n = count[hi] - count[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, (total[hi] - total[lo]) / n, np.nan)


def _plateau_changes(time, states, min_time):
    """(last index on the old plateau, first index on the new one) of each confirmed change of
    the averaged u from one plateau to the other (module doc): its last sample on the new
    plateau before it is back on the old one comes at least max(MIN_STAY_RATIO x the change's
    time, min_time) after its first."""
    on = np.flatnonzero(states)
    if not len(on):
        return []
    current, last_on_current, changes = int(states[on[0]]), int(on[0]), []
    k = 0
    while k < len(on):
        i = int(on[k])
        if states[i] == current:
            last_on_current = i
            k += 1
            continue
        # the averaged u reaches the other plateau at i: how long does it stay there (its last
        # sample on it before it is back on the old one)?
        back = np.flatnonzero(states[i:] == current)
        until = i + int(back[0]) if len(back) else len(states)
        stay_end = float(time[i + np.flatnonzero(states[i:until] == -current)[-1]])
        needed = max(MIN_STAY_RATIO * (float(time[i]) - float(time[last_on_current])),
                     min_time)
        if stay_end - float(time[i]) >= needed:
            changes.append((last_on_current, i))
            current, last_on_current = int(states[i]), i
            k += 1
        else:   # an excursion: skip to its return to the old plateau (or the series' end)
            if not len(back):
                break
            last_on_current = i + int(back[0])
            k = int(np.searchsorted(on, last_on_current)) + 1
    return changes


def _prefix_sums(t, u):
    """The prefix sums of 1, u, u^2, t, t u, t^2 over the samples that _ramp_residual reads."""
    return [np.concatenate([[0.0], np.cumsum(x)]) for x in (np.ones_like(t), u, u * u, t, t * u,
                                                            t * t)]


def _ramp_residual(t, c, p_old, p_new, t1, t2):
    """Sum of squares of u - ramp, the ramp at p_old up to t1, at p_new from t2 on and straight
    in between, for arrays of t1 < t2, from the samples' prefix sums c (_prefix_sums)."""
    i1, i2 = np.searchsorted(t, t1, "right"), np.searchsorted(t, t2, "right")
    n, su, suu, st, stu, stt = ((x[i2] - x[i1]) for x in c)
    # old plateau: samples before i1; new plateau: from i2 on; ramp a + b t in between
    old = c[2][i1] - 2 * p_old * c[1][i1] + p_old ** 2 * c[0][i1]
    n_new, su_new, suu_new = (x[-1] - x[i2] for x in c[:3])
    new = suu_new - 2 * p_new * su_new + p_new ** 2 * n_new
    b = (p_new - p_old) / (t2 - t1)
    a = p_old - b * t1
    ramp = suu - 2 * a * su - 2 * b * stu + a * a * n + 2 * a * b * st + b * b * stt
    return old + new + ramp


def fit_ramp(t, u, p_old, p_new):
    """(t1, t2): the straight ramp from p_old (held up to t1) to p_new (from t2) that fits the
    samples (t, u) best in least squares, t[0] <= t1 < t2 <= t[-1]: a grid of FIT_GRID ends
    over the samples' span, then one of FIT_REFINE over two of its steps about the best pair."""
    finite = np.isfinite(u)
    t, u = np.asarray(t, dtype=float)[finite], np.asarray(u, dtype=float)[finite]
    if len(t) < 2:
        raise ValueError("fit_ramp: fewer than two finite samples")
    origin = float(t[0])      # times from the first sample: no cancellation in the sums of t^2
    t = t - origin
    sums = _prefix_sums(t, u)
    lo, hi = 0.0, float(t[-1])
    best, step = None, (hi - lo) / (FIT_GRID - 1)
    for _ in range(2):
        if best is None:
            g1 = g2 = np.linspace(lo, hi, FIT_GRID)
        else:
            g1 = np.clip(np.linspace(best[0] - 2 * step, best[0] + 2 * step, FIT_REFINE), lo,
                         hi)
            g2 = np.clip(np.linspace(best[1] - 2 * step, best[1] + 2 * step, FIT_REFINE), lo,
                         hi)
        t1, t2 = (x.ravel() for x in np.meshgrid(g1, g2, indexing="ij"))
        keep = t2 > t1
        t1, t2 = t1[keep], t2[keep]
        r = _ramp_residual(t, sums, p_old, p_new, t1, t2)
        k = int(np.argmin(r))
        best = (float(t1[k]), float(t2[k]))
    return best[0] + origin, best[1] + origin


def band_switches(time, u, velocity, source="block_vx"):
    """Every switch of the shear band between the walls (module doc), as dicts: start_time and
    end_time (the fitted ramp's ends), duration, switch_time (the T of model.md section 8),
    from_state, to_state (+1: the block with the top wall), band ("bottom->top" or
    "top->bottom"), and delta_mu_start_time, delta_mu_end_time: the stretch of the old plateau
    before the ramp over which summary.switch_friction_difference takes delta_mu, between the
    plateaus (P+, P-) of plateau_velocities."""
    time, u = np.asarray(time, dtype=float), np.asarray(u, dtype=float)
    if len(time) < 2 or not velocity > 0:
        return []
    plateaus = plateau_velocities(u, velocity)
    width = SMOOTHING_DISPLACEMENT / velocity
    states = band_states(running_mean(time, u, width), velocity, plateaus)
    changes = _plateau_changes(time, states, width)
    switches = []
    previous_end = float(time[0])
    for k, (old, new) in enumerate(changes):
        from_state = int(states[old])
        p_old, p_new = plateaus[0 if from_state > 0 else 1], plateaus[1 if from_state > 0 else 0]
        # the fit's samples: the change and as long again (at least one averaging time) on
        # each side, within the neighbouring changes
        margin = max(time[new] - time[old], width)
        lo = max(time[old] - margin, time[changes[k - 1][1]] if k else time[0])
        hi = min(time[new] + margin, time[changes[k + 1][0]] if k + 1 < len(changes)
                 else time[-1])
        sel = (time >= lo) & (time <= hi) & np.isfinite(u)
        fitted = time[sel]
        if len(fitted) >= 2 and np.diff(np.concatenate([[lo], fitted, [hi]])).max() <= width:
            start, end = fit_ramp(fitted, u[sel], p_old, p_new)
            duration = end - start
            switch_time = (duration * 2 * velocity / abs(p_new - p_old)
                           if source == "block_vx" else duration)
        else:   # a gap in the samples: any ramp inside it fits, so the switch has no time
            start, end = float(time[old]), float(time[new])
            duration = switch_time = np.nan
        switches.append(dict(start_time=start, end_time=end, duration=duration,
                             switch_time=switch_time, from_state=from_state,
                             to_state=-from_state,
                             band="bottom->top" if from_state > 0 else "top->bottom",
                             delta_mu_start_time=max(start - PRE_SWITCH_TIME, previous_end),
                             delta_mu_end_time=start))
        previous_end = end
    return switches


def whole_run_switches(time, switches, height):
    """A run's band switches over its whole series (band_switches' list), as a summary keeps
    them for switch_statistics: {"time" (first to last sample), "L_y" (the mean height; NaN
    without one), "switch_times" (each switch's T, None for one across a gap in the samples),
    "starts" (each switch's start_time)}."""
    time, height = np.asarray(time, dtype=float), np.asarray(height, dtype=float)
    finite = height[np.isfinite(height)]
    return {"time": float(time[-1] - time[0]) if len(time) > 1 else 0.0,
            "L_y": float(finite.mean()) if len(finite) else np.nan,
            "switch_times": [float(w["switch_time"]) if np.isfinite(w["switch_time"]) else None
                             for w in switches],
            "starts": [float(w["start_time"]) for w in switches]}


def switches_in(switches, t0, t1):
    """The switches starting in [t0, t1], the averaged span: the ones a run's regime, its
    switch count and its switch statistics are about. Before t0 the block is still in the
    transient (model.md section 8: every average over steady state only), where it may wander
    from one wall's velocity to the other's before any band has formed."""
    return [sw for sw in switches if t0 <= sw["start_time"] <= t1]


def switch_statistics(switches, t0, t1):
    """Switches starting in [t0, t1] (switches_in): count, mean duration, and mean dwell =
    (t1 - t0 - their durations) / (count + 1), the mean time on a plateau (the durations that
    could be timed)."""
    sel = switches_in(switches, t0, t1)
    durations = [sw["duration"] for sw in sel if np.isfinite(sw["duration"])]
    dwell = (t1 - t0 - sum(durations)) / (len(sel) + 1) if t1 > t0 else np.nan
    return dict(count=len(sel), mean_duration=float(np.mean(durations)) if durations else np.nan,
                mean_dwell=float(dwell))


# ---------------------------------------------------------------------------------------------
# Run

def _shares_text(shares, n):
    return (", ".join(f"{s} {shares[s]:.0%}" for s in STATES) +
            f" of {n} window{'s' if n != 1 else ''}")


def classify_run(table, u, switches, velocity, span, source="block_vx"):
    """(regime, confidence, criteria) from the averaged windows' table (window_table), the
    averaged samples u of the block velocity, the band switches, and span = (t0, t1), the
    averaged time. See the module doc."""
    V = velocity
    n = len(table["state"])
    shares = state_shares(table)
    c_share = shares["C+"] + shares["C-"] if n else np.nan
    regime_share = dict(A=shares["A"], B=shares["B"], C=c_share)
    samples = sample_shares(u, V)
    mode, bc = histogram_mode(u, V), bimodality_coefficient(u)
    finite_u = np.asarray(u, dtype=float)[np.isfinite(u)]
    at_walls = (float(np.mean(np.abs(np.abs(finite_u) - V) <= PLATEAU_LEVEL * V))
                if len(finite_u) else np.nan)
    sw = switch_statistics(switches, *span)
    window_r = np.asarray(table["shear_rate_ratio"], dtype=float)
    r = float(np.nanmean(window_r)) if np.isfinite(window_r).any() else np.nan
    dwell_ok = (sw["count"] == 0 or (np.isfinite(sw["mean_dwell"]) and
                                     sw["mean_dwell"] >= DWELL_RATIO * sw["mean_duration"]))
    dwell_text = (f"mean time on a plateau {sw['mean_dwell']:.3g} t "
                  f"{'>=' if dwell_ok else '<'} {DWELL_RATIO:g} x the mean switch duration "
                  f"{sw['mean_duration']:.3g} t ({sw['count']} switches)") if sw["count"] \
        else "no band switch"
    rest, wall = samples["rest"], samples["plus"] + samples["minus"]
    # a side the block holds for a share of the time has its plateau, or no switch to or from
    # it could be counted: a block beyond COM_LEVEL V but not at a wall's velocity is no C
    plateaus = plateau_velocities(u, V)
    unfound = [name for name, share, p in (("+", samples["plus"], plateaus[0]),
                                           ("-", samples["minus"], plateaus[1]))
               if share >= INTERMITTENT_SHARE and not np.isfinite(p)]
    plateau_text = (f"no plateau on the {' and '.join(unfound)} side (the median of the samples "
                    f"beyond {COM_LEVEL:g} V within {GAP_LEVELS[1]:g} V of 0)" if unfound else
                    "plateaus " + " and ".join(f"{p / V:+.2f} V" for p in plateaus
                                               if np.isfinite(p)))
    su = f"|{source}|"
    window_text = _shares_text(shares, n) if n else "no window"
    # One peak about 0: the histogram's fullest bin near 0 and no second peak at a wall (at most
    # WALL_PEAK_SHARE of the samples on a wall's plateau). Sarle's coefficient is reported, not
    # used: a skewed or heavy-tailed single peak exceeds 5/9 (0.65 on system 2's B run at
    # V = 0.32, whose samples never reach a wall).
    b_peak = bool(np.isfinite(mode) and abs(mode) <= COM_LEVEL * V
                  and at_walls <= WALL_PEAK_SHARE)

    def ge(x, threshold):
        return ">=" if x >= threshold else "<"

    a_share, b_share = shares["A"], shares["B"]
    checks = {
        "A": [(n and a_share >= DOMINANT_SHARE,
               f"A windows {a_share:.0%} {ge(a_share, DOMINANT_SHARE)} {DOMINANT_SHARE:.0%}")],
        "B": [(n and b_share >= DOMINANT_SHARE,
               f"B windows {b_share:.0%} {ge(b_share, DOMINANT_SHARE)} {DOMINANT_SHARE:.0%}"),
              (rest >= SAMPLE_SHARE, f"{su} <= {COM_LEVEL:g} V in {rest:.0%} of the samples "
                                     f"{ge(rest, SAMPLE_SHARE)} {SAMPLE_SHARE:.0%}"),
              (b_peak, f"{'one' if b_peak else 'not one'} peak about 0 (histogram mode "
                       f"{mode / V:.2f} V, within {COM_LEVEL:g} V wanted; {at_walls:.0%} of the "
                       f"samples within {PLATEAU_LEVEL:g} V of a wall, at most "
                       f"{WALL_PEAK_SHARE:.0%} wanted; Sarle's bimodality coefficient "
                       f"{bc:.2f})")],
        "C": [(n and c_share >= DOMINANT_SHARE,
               f"C windows {c_share:.0%} {ge(c_share, DOMINANT_SHARE)} {DOMINANT_SHARE:.0%}"),
              (wall >= SAMPLE_SHARE, f"{su} > {COM_LEVEL:g} V in {wall:.0%} of the samples "
                                     f"{ge(wall, SAMPLE_SHARE)} {SAMPLE_SHARE:.0%}"),
              (not unfound, plateau_text),
              (dwell_ok, dwell_text)],
    }

    def met(regime):
        return all(bool(ok) for ok, _ in checks[regime])

    def text(regime, only_failed=False):
        return "; ".join(t for ok, t in checks[regime] if not (only_failed and ok))

    decided = 1 - shares["undecided"] if n else np.nan
    present = [g for g in ("A", "B", "C") if n and regime_share[g] >= INTERMITTENT_SHARE]
    gap_ok = samples["gap"] <= GAP_SHARE
    gap_text = (f"{samples['gap']:.0%} of the samples in the gap {GAP_LEVELS[0]:g} V < "
                f"{su} < {GAP_LEVELS[1]:g} V")
    intermittent = n and decided >= DOMINANT_SHARE and len(present) >= 2 and gap_ok
    if n < MIN_WINDOWS:
        regime = "undecided"
        reason = (f"undecided: too short to tell, {n} averaged window{'s' if n != 1 else ''} "
                  f"< {MIN_WINDOWS} ({window_text})")
    elif met("A"):
        regime, reason = "A", f"A: {text('A')} ({window_text}); r = {r:.3g}"
    elif met("B"):
        regime, reason = "B", f"B: {text('B')} ({window_text}); r = {r:.3g}"
    elif met("C"):
        regime = "C"
        reason = f"C: {text('C')} ({window_text}); r = {r:.3g}"
    elif intermittent:
        regime = "intermittent"
        reason = (f"intermittent: {' and '.join(present)} each over >= "
                  f"{INTERMITTENT_SHARE:.0%} of the time, windows in a state {decided:.0%} >= "
                  f"{DOMINANT_SHARE:.0%}, {gap_text} <= {GAP_SHARE:.0%} ({window_text})")
    else:
        regime = "undecided"
        why = []
        if not np.isfinite(samples["gap"]):
            why.append(f"no finite sample of {source}")
        elif not gap_ok:
            why.append(f"the block velocity wanders between rest and the walls: {gap_text} > "
                       f"{GAP_SHARE:.0%}")
        if sw["count"] and not dwell_ok:
            why.append("states switch faster than they can be told apart: " + dwell_text)
            checks["C"][-1] = (False, "its switches (above)")
        why += [f"not {g}: {text(g, only_failed=True)}" for g in ("A", "B", "C")]
        if len(present) >= 2:
            why.append(f"not intermittent: {' and '.join(present)} present but "
                       + (f"windows in a state {decided:.0%} < {DOMINANT_SHARE:.0%}"
                          if decided < DOMINANT_SHARE else "the states are not told apart"))
        reason = f"undecided: {'; '.join(why)} ({window_text}); r = {r:.3g}"
    agree = {"A": shares["A"], "B": shares["B"], "C": c_share, "intermittent": decided}
    confidence = float(agree[regime]) if regime in agree and n else np.nan
    edges, counts = com_histogram(u, V)
    u_fin = np.asarray(u, dtype=float)
    u_fin = u_fin[np.isfinite(u_fin)]
    criteria = dict(
        reason=reason, block_velocity_source=source,
        shear_rate_ratio=r, shear_rate_ratio_threshold=SHEAR_RATIO_A,
        com_fraction=com_fraction(u, V), com_level=COM_LEVEL,
        windows_classified=n, state_shares=shares, sample_shares=samples,
        block_velocity=dict(mean=float(u_fin.mean()) if len(u_fin) else np.nan,
                            std=float(u_fin.std()) if len(u_fin) else np.nan,
                            mode=mode, bimodality_coefficient=bc,
                            histogram=dict(edges=edges, counts=counts)),
        switch_count=sw["count"], mean_switch_duration=sw["mean_duration"],
        mean_dwell=sw["mean_dwell"],
        thresholds=dict(SHEAR_RATIO_A=SHEAR_RATIO_A, LINEARITY_A=LINEARITY_A,
                        SHEAR_RATIO_BLOCK=SHEAR_RATIO_BLOCK, JUMP_TOLERANCE=JUMP_TOLERANCE,
                        COM_LEVEL=COM_LEVEL, WINDOW_SAMPLE_SHARE=WINDOW_SAMPLE_SHARE,
                        MIN_WINDOWS=MIN_WINDOWS, DOMINANT_SHARE=DOMINANT_SHARE,
                        SAMPLE_SHARE=SAMPLE_SHARE, BIMODALITY_LEVEL=BIMODALITY_LEVEL,
                        WALL_PEAK_SHARE=WALL_PEAK_SHARE,
                        INTERMITTENT_SHARE=INTERMITTENT_SHARE, GAP_LEVELS=list(GAP_LEVELS),
                        GAP_SHARE=GAP_SHARE, DWELL_RATIO=DWELL_RATIO,
                        PLATEAU_LEVEL=PLATEAU_LEVEL, PRE_SWITCH_TIME=PRE_SWITCH_TIME),
        windows=table)
    return regime, confidence, criteria


def band_layers(region, band_wall):
    """The sheared and the resting boundary layer of each window with a band (band_wall
    "bottom" or "top"; None: the window is not in regime C): ({quantity: per-window array},
    {quantity: ...}) from a region group's bottom_* and top_* arrays (already restricted to the
    windows of band_wall), NaN for the windows without a band."""
    names = [k[len("bottom_"):] for k in region if k.startswith("bottom_")
             and "top_" + k[len("bottom_"):] in region]
    sheared = {q: np.full(len(band_wall), np.nan) for q in names}
    resting = {q: np.full(len(band_wall), np.nan) for q in names}
    other = {"bottom": "top", "top": "bottom"}
    for w, wall in enumerate(band_wall):
        if wall not in other:
            continue
        for q in names:
            sheared[q][w] = region[f"{wall}_{q}"][w]
            resting[q][w] = region[f"{other[wall]}_{q}"][w]
    return sheared, resting


def report_line(regime, confidence, criteria, n_switches):
    """The report's regime line."""
    source = criteria.get("block_velocity_source", "com_vx")
    if regime == "undecided":
        return f"regime {criteria['reason']}; {n_switches} band switch(es)"
    shares = criteria["state_shares"]
    n = criteria["windows_classified"]
    f = criteria["com_fraction"]
    return (f"regime {regime} ({confidence:.0%} of the window time agrees): "
            f"{_shares_text(shares, n)}; r = {criteria['shear_rate_ratio']:.3g}, "
            f"|{source}| > V/2 in {f:.0%} of samples, {n_switches} band switch(es)")

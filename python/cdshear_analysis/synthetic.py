"""Synthetic run folders (run.h5 + case.toml) following docs/run-data.md, for tests and demos.

Kinds (u: the block velocity, written as the series block_vx; com_vx = (1 - 3 / L_y) u where the
profile has the two bands of thickness 3 below, the centre-of-mass velocity of those profiles):
  "A"          linear velocity profile with 10% slip at each wall, u AR(1) noise about 0;
  "B"          shear in two boundary bands of thickness 3, still bulk, u AR(1) noise about 0
               (std 0.2 V, correlation time 10 t);
  "C"          one band; the bulk moves with one wall: u at +V or -V, switching at
               `switch_times` (default duration/4, /2, 3/4; each switch a linear ramp over
               `switch_duration`; with `switch_forces` the bottom wall's force carries the
               block's acceleration, as Newton's law for the grains says: a fast synthetic
               switch makes it large);
  "C_fast"     "C" switching every `switch_interval` (default 40 t);
  "intermittent"  the block rests (B) and moves with a wall (C) in turn, `dwell` t each:
               0, +V, 0, -V, 0, ... with ramps over `switch_duration`;
  "wander"     a B profile whose block velocity wanders: u AR(1) with std 0.5 V and correlation
               time `wander_time` (default 100 t);
  "rest"       the grains at rest and both walls sliding over them: v_x = 0 at every height
               (u noise of 0.01 V), slip V at each wall;
  "noise"      no structure: white-noise profiles and u (std 0.4 V);
  "transient"  regime A whose wall friction and height relax as exp(-t / transient_tau)
               (mu from 0.55 to 0.30, L_y from 19 to 20).
With `pre_switch_delta_mu` the walls also push the grains towards the next level with a net
tangential force pre_switch_delta_mu times the normal force (on the bottom wall) over the
`pre_switch_time` before each ramp of "C", "C_fast" and "intermittent" (a force the block does not
follow: a check of the delta_mu measurement).
`block_column=False` leaves block_vx out (a file from before the column).
Format version 2 (docs/run-data.md). Steady values: mu_wall = 0.30, L_y = 20 (nominal), bulk solid
fraction 0.80, Z = 3 (force-carrying coordination 2.55).
"""
import os

import h5py
import numpy as np
from scipy.signal import lfilter

from .profiles import regions_for_h
from .rundata import seal

MU, NU, Z, BAND = 0.30, 0.80, 3.0, 3.0


def ar1(n, phi, std, rng):
    """Stationary AR(1) noise x_t = phi x_{t-1} + e_t with standard deviation `std`."""
    e = rng.normal(0.0, std * np.sqrt(1 - phi * phi), n)
    if n:
        e[0] = rng.normal(0.0, std)
    return lfilter([1.0], [1.0, -phi], e)


BANDED = ("B", "C", "C_fast", "intermittent", "wander")   # profiles with two bands
SWITCHING = ("C", "C_fast", "intermittent")               # u from ramps between levels


def _profile(kind, y, height, velocity, block, rng):
    """v_x(y) of one window for a given mean block velocity."""
    V = velocity
    band_bottom = np.clip(1 - y / BAND, 0, 1)        # 1 at the bottom wall, 0 beyond the band
    band_top = np.clip(1 - (height - y) / BAND, 0, 1)
    if kind in ("A", "transient"):
        v = -0.9 * V + 1.8 * V * y / height + block
    elif kind in BANDED:
        v = block + (-V - block) * band_bottom + (V - block) * band_top
    elif kind == "rest":
        v = np.full_like(y, block)
    else:
        return rng.normal(0, 0.5 * V, len(y))
    return v + rng.normal(0, 0.01 * V, len(y))


def _levels(t, start, steps, ramp):
    """start, then at each (time, level) of steps a linear ramp over `ramp` to that level."""
    x, previous = np.full_like(t, float(start)), float(start)
    for ts, level in steps:
        r = np.clip((t - ts) / ramp, 0, 1)
        x = np.where(t >= ts, previous + (level - previous) * r, x)
        previous = level
    return x


def _steps(kind, duration, switch_times, switch_interval, dwell):
    """(start level, [(time, level)]) of u / V for the SWITCHING kinds."""
    if kind == "intermittent":
        times = np.arange(1, int(np.ceil(duration / dwell))) * dwell
        cycle = (1.0, 0.0, -1.0, 0.0)
        return 0.0, [(ts, cycle[k % 4]) for k, ts in enumerate(times)]
    if switch_times is not None:
        times = np.asarray(switch_times, dtype=float)
    elif kind == "C_fast":
        times = np.arange(switch_interval, duration, switch_interval)
    else:
        times = np.arange(1, 4) * duration / 4
    return 1.0, [(ts, -(-1.0) ** k) for k, ts in enumerate(times)]


def write_synthetic_run(run_dir, kind="A", duration=2000.0, velocity=0.5, time_reached=None,
                        sample_interval=0.5, window=80.0, n=511, height=20.0, length_x=20.0,
                        normal_stress=0.25, boundary_thickness=(5.0, 10.0), switch_times=None,
                        switch_duration=20.0, transient_tau=100.0, seed=1,
                        switch_forces=False, switch_interval=40.0, dwell=400.0,
                        wander_time=100.0, pre_switch_delta_mu=0.0, pre_switch_time=100.0,
                        block_column=True):
    """Write RUN_DIR/run.h5 and RUN_DIR/case.toml; returns the run.h5 path.

    time_reached < duration makes an interrupted run (attribute finished = 0)."""
    rng = np.random.default_rng(seed)
    os.makedirs(run_dir, exist_ok=True)
    V, sigma, dt, dy, m = velocity, normal_stress, 0.002, 1.0, np.pi / 4
    t_reached = duration if time_reached is None else time_reached
    n_samples = int(round(t_reached / sample_interval))
    t = sample_interval * np.arange(1, n_samples + 1)
    relax = np.exp(-t / transient_tau) if kind == "transient" else np.zeros_like(t)
    mu = MU + 0.25 * relax + ar1(n_samples, 0.9, 0.02, rng)
    height_t = height - 1.0 * relax + ar1(n_samples, 0.95, 0.05, rng)
    steps = []
    if kind in SWITCHING:
        start, steps = _steps(kind, duration, switch_times, switch_interval, dwell)
        state = _levels(t, start, steps, switch_duration)
        u = V * state + ar1(n_samples, 0.8, 0.05 * V, rng)
        # the block's acceleration, without the noise
        accel = V * np.gradient(state, t) if len(t) > 1 else np.zeros_like(t)
    elif kind == "noise":
        u = rng.normal(0, 0.4 * V, n_samples)
    elif kind == "wander":
        u = ar1(n_samples, np.exp(-sample_interval / wander_time), 0.5 * V, rng)
    else:
        u = ar1(n_samples, 0.95, {"B": 0.2, "rest": 0.01}.get(kind, 0.05) * V, rng)
    if kind not in SWITCHING or not switch_forces:
        accel = np.zeros_like(t)
    com = (1 - BAND / height) * u if kind in BANDED else u
    fy = sigma * length_x * (1 + ar1(n_samples, 0.5, 0.02, rng))
    mean_area = np.pi / 4 * (1 - 0.8 ** 3) / (3 * 0.2)
    # Newton for the grains (rho = 1): the walls' net tangential force on them, -(bottom_fx +
    # top_fx), is their mass times the block's acceleration (nonzero during a switch only)
    block_force = n * mean_area * accel
    held = np.zeros_like(t)       # the force the block does not follow, towards the next level
    level = start if kind in SWITCHING else 0.0
    for ts, new_level in steps:
        held[(t >= ts - pre_switch_time) & (t < ts)] = -np.sign(new_level - level) * \
            pre_switch_delta_mu
        level = new_level
    series = dict(
        step=np.round(t / dt).astype(np.int64), time=t, com_vx=com, height=height_t,
        solid_fraction=n * mean_area / (length_x * height_t),
        kinetic_energy=0.5 * n * 0.6 * (0.1 * V) ** 2 * (1 + 0.1 * rng.random(n_samples)),
        contacts=rng.integers(900, 1100, n_samples),
        force_carrying=rng.integers(500, 700, n_samples),
        bottom_fx=mu * fy - block_force + held * fy, bottom_fy=-fy, top_fx=-mu * fy, top_fy=fy,
        bottom_mu=mu, top_mu=mu,
        sweeps_mean=40 + 5 * rng.random(n_samples), sweeps_max=rng.integers(60, 201, n_samples),
        capped_steps=(rng.random(n_samples) < 0.001).astype(np.int64),
        residual_max=1e-6 * rng.random(n_samples), overlap_max=1e-3 * rng.random(n_samples))
    series["closed"] = (0.9 * series["contacts"]).astype(np.int64)
    if block_column:
        series["block_vx"] = u

    n_windows = int(t_reached // window)
    n_stripes = int(np.ceil(1.25 * height / dy))
    y = (np.arange(n_stripes) + 0.5) * dy
    W = dict(y=y, t_start=window * np.arange(n_windows), t_end=window * np.arange(1, n_windows + 1))
    inside = [(t > t0) & (t <= t0 + window) for t0 in W["t_start"]]
    W["samples"] = np.array([s.sum() for s in inside], dtype=np.int64)
    W["height"] = np.array([height_t[s].mean() for s in inside])
    W["com_vx"] = np.array([com[s].mean() for s in inside])
    block = np.array([u[s].mean() for s in inside])
    shape = (n_windows, n_stripes)
    nu = np.zeros(shape)
    vx, mu_prof, coord = (np.full(shape, np.nan) for _ in range(3))
    stress = np.full(shape + (2, 2), np.nan)
    for w, s in enumerate(inside):
        H = W["height"][w]
        ok = y < H
        yo = y[ok]
        nu[w, ok] = (NU - 0.1 * (np.exp(-yo / 1.5) + np.exp(-(H - yo) / 1.5))
                     + rng.normal(0, 0.005, ok.sum()))
        vx[w, ok] = _profile(kind, yo, H, V, block[w], rng)
        mu_prof[w, ok] = mu[s].mean() + rng.normal(0, 0.01, ok.sum())
        coord[w, ok] = Z + rng.normal(0, 0.05, ok.sum())
        stress[w, ok] = [[sigma, 0.0], [0.0, sigma]]
        stress[w, ok, 0, 1] = stress[w, ok, 1, 0] = -mu_prof[w, ok] * sigma
    shear_rate = np.full(shape, np.nan)
    for w in range(n_windows):
        ok = np.isfinite(vx[w])
        if ok.sum() >= 2:
            shear_rate[w, ok] = np.gradient(vx[w, ok], y[ok])
    kinetic = np.where(np.isfinite(stress), 0.0, np.nan)
    kinetic[..., 0, 0] = kinetic[..., 1, 1] = np.where(nu > 0, 0.01 * sigma * nu, np.nan)
    rotational = np.where(np.isfinite(stress), 0.0, np.nan)
    W.update(solid_fraction=nu, vx=vx, stress=stress,
             contact_stress=stress - kinetic - rotational, kinetic_stress=kinetic,
             rotational_stress=rotational, mu_eff=mu_prof, coordination=coord,
             force_carrying_coordination=0.85 * coord, shear_rate=shear_rate,
             inertial_number=np.abs(shear_rate) * np.sqrt(m / sigma))
    # The stripes counted down from the top wall: the same profiles at y = H - depth.
    depth = (np.arange(int(np.ceil(max(boundary_thickness) / dy)) + 1) + 0.5) * dy
    top_stripes = dict(depth=depth)
    for name in ("solid_fraction", "vx", "coordination", "force_carrying_coordination"):
        top_stripes[name] = np.array([_at_depth(y, W[name][w], W["height"][w], depth)
                                      for w in range(n_windows)]).reshape(n_windows, len(depth))
    top_stripes["stress"] = np.stack(
        [np.array([_at_depth(y, stress[w, :, a, b], W["height"][w], depth)
                   for w in range(n_windows)]).reshape(n_windows, len(depth))
         for a in range(2) for b in range(2)], axis=-1).reshape(n_windows, len(depth), 2, 2)
    for wall in ("bottom", "top"):
        fx, fyw = series[f"{wall}_fx"], series[f"{wall}_fy"]
        W[f"{wall}_force"] = np.array([[fx[s].mean(), fyw[s].mean()]
                                       for s in inside]).reshape(-1, 2)
        slip = V if kind == "rest" else 0.05 * V
        W[f"slip_{wall}"] = slip + rng.normal(0, 0.005 * V, n_windows)
        W[f"slip_{wall}_count"] = rng.integers(400, 600, n_windows)
    W["wall_mu"] = np.array([mu[s].mean() for s in inside])

    attrs = dict(format="cdshear-run", format_version=4, program_version="synthetic",
                 program_build="synthetic run (cdshear_analysis.synthetic)", n=n,
                 length_x=length_x, height=height, velocity=V, normal_stress=sigma, dt=dt,
                 seed=seed, solver_seed=1, duration=duration, sample_interval=sample_interval,
                 window=window, sample_steps=max(1, int(round(sample_interval / dt))),
                 window_samples=max(1, int(round(window / sample_interval))),
                 stripe_thickness=dy, stripe_span=1.25,
                 boundary_thickness=np.asarray(boundary_thickness, dtype=float),
                 force_threshold=1.0, contact_gap=0.01, inertial_mass=m,
                 time=float(t[-1]) if n_samples else 0.0,
                 step=int(series["step"][-1]) if n_samples else 0,
                 finished=int(t_reached >= duration))
    attrs["case_toml"] = (
        f"# synthetic case ({kind})\n[system]\nn = {n}\nheight = {height!r}\nseed = {seed}\n"
        f"[shear]\nvelocity = {V!r}\nnormal_stress = {sigma!r}\nduration = {duration!r}\n"
        f"[measure]\nsample_interval = {sample_interval!r}\nwindow = {window!r}\n"
        f"stripe_thickness = {dy!r}\nboundary_thickness = {list(map(float, boundary_thickness))}\n")
    path = os.path.join(run_dir, "run.h5")
    with h5py.File(path + ".tmp", "w", userblock_size=512) as f:
        f.attrs.update(attrs)
        for k, v in series.items():
            f.create_dataset(f"series/{k}", data=v)
        for k, v in W.items():
            f.create_dataset(f"windows/{k}", data=v)
        for k, v in top_stripes.items():
            f.create_dataset(f"windows/top_stripes/{k}", data=v)
        for h in boundary_thickness:
            g = f.create_group(f"windows/regions/h{h:g}")
            g.attrs["h"] = float(h)
            for k, v in regions_for_h(W, h, V, sigma, m, top_stripes).items():
                g.create_dataset(k, data=v)
        _write_snapshot(f.create_group("snapshot"), n, length_x, height, t_reached, rng)
    seal(path + ".tmp")
    os.replace(path + ".tmp", path)
    with open(os.path.join(run_dir, "case.toml"), "w") as f:
        f.write(attrs["case_toml"])
    return path


def _at_depth(y, profile, height, depth):
    """A window's profile over stripe centres y, interpolated at the heights height - depth."""
    ok = np.isfinite(profile)
    if ok.sum() < 2:
        return np.full(len(depth), np.nan)
    return np.interp(height - depth, y[ok], profile[ok])


def _write_snapshot(g, n, length_x, height, time, rng):
    """Disks on a jittered grid, contacts between near neighbours and with the walls."""
    cols = int(np.ceil(np.sqrt(n * length_x / height)))
    rows = int(np.ceil(n / cols))
    i = np.arange(n)
    x = (i % cols + 0.5 + 0.1 * rng.standard_normal(n)) * length_x / cols % length_x
    y = np.clip((i // cols + 0.5) * height / rows + 0.05 * rng.standard_normal(n),
                0.5, height - 0.5)
    r = rng.uniform(0.4, 0.5, n)
    dx = x[:, None] - x[None, :]
    dx -= length_x * np.round(dx / length_x)               # nearest periodic image
    gap = np.hypot(dx, y[:, None] - y[None, :]) - r[:, None] - r[None, :]
    a, b = np.nonzero(np.triu(gap < 0.15, 1))
    bx, by = x[a] - dx[a, b], y[b]
    bottom, top = np.flatnonzero(y - r < 0.1), np.flatnonzero(y + r > height - 0.1)
    ca = np.concatenate([a, bottom, top])
    cb = np.concatenate([b, np.full(len(bottom), n), np.full(len(top), n + 1)])
    cbx = np.concatenate([bx, x[bottom], x[top]])
    cby = np.concatenate([by, np.zeros(len(bottom)), np.full(len(top), height)])
    data = dict(x=x, y=y, radius=r, vx=rng.normal(0, 0.1, n),
                vy=rng.normal(0, 0.1, n), omega=rng.normal(0, 0.1, n),
                contact_a=ca.astype(np.int64), contact_b=cb.astype(np.int64),
                contact_ax=x[ca], contact_ay=y[ca], contact_bx=cbx, contact_by=cby,
                contact_normal_force=rng.exponential(1.0, len(ca)))
    for k, v in data.items():
        g.create_dataset(k, data=v)
    g.attrs.update(time=float(time), length_x=length_x, height=height)

"""Side by side with soft-contact DEM (LAMMPS): packing conversion and the common estimator.

`bench/peers/side_by_side.sh` shears the same packing with cdshear and with LAMMPS
(`bench/peers/lammps/in.shear`, pair style gran/hooke/history) and prints one table. This module
holds the Python half of it:

- `packing_to_lammps(packing)`: a cdshear packing (the JSON of `cdshear prepare`, docs/model.md
  section 5) as a LAMMPS data file (`atom_style sphere`, 2D) plus an include file of LAMMPS
  variables (`write_lammps_packing`). Grains keep their position and radius; each flat wall of the
  shear cell becomes a row of `n_wall` overlapping disks (type 2 bottom, type 3 top) whose tops
  are on the wall line: LAMMPS has no flat wall that is free in y under Newton's law, so
  in.shear makes each row one rigid body (fix rigid, y free, x imposed, no rotation).
- `lammps_series(path)`, `cdshear_series(run_dir)`: the global series of either code as
  arrays (time, wall forces, height, solid fraction).
- `side_by_side(...)`: the same estimator for both: means over the second half of the run,
  errors by block averaging (statistics.block_average).
- `max_overlap_from_dump(path)`: the largest overlap (grain-grain and grain-wall) over the
  snapshots of a LAMMPS dump.

Units: docs/model.md section 1 (largest diameter d = 1, 2D density 1, sigma_yy = 0.25).

LAMMPS' data-file density. With atom_style sphere, read_data sets the mass from the density
column as m = density * 4/3 pi r^3, also when `dimension 2` (checked with LAMMPS 20220106: a
disk of diameter 1 and density 1 gets m = 0.5236 = pi/6). The disks of model.md section 1 have
m = pi r^2 (2D density 1), so the column holds m / (4/3 pi r^3) = 3 / (4 r) for a grain, and
(M_w / n_wall) / (4/3 pi R_w^3) for a wall disk, so that a wall row weighs M_w = 50.
"""
import json
import math
import os
import warnings

import numpy as np

from .rundata import (MEASURED_MAGNITUDE_LIMIT, folder_case, is_number, open_regular, unique_keys,
                      what_is, write_text_atomically)
from .statistics import block_average, window_mean

GRAIN_TYPE, BOTTOM_TYPE, TOP_TYPE = 1, 2, 3
WALL_MASS = 50.0        # M_w of model.md section 4, mass of each wall
WALL_RADIUS = 0.5       # R_w: radius of the wall disks (d)
WALL_SPACING = 0.05     # largest distance between neighbouring wall disks (d)
BOX_MARGIN = 5.0        # room above and below the walls in the fixed (f) y boundary (d)


class PeerError(Exception):
    """A packing, series or dump that cannot be used: `path` and `problem`."""

    def __init__(self, path, problem):
        super().__init__(f"{path}: {problem}")
        self.path, self.problem = path, problem


def _json_integer(text):
    """A JSON integer as cdshear's reader takes it: a whole number within 64 bits stays one;
    beyond, a double (infinite past 1e308, then refused as not finite, where cdshear refuses the
    file), never a Python int that overflows float() later."""
    if len(text.lstrip("-")) <= 20:
        value = int(text)
        if -2 ** 63 <= value < 2 ** 64:
            return value
    return float(text)


def load_packing(path):
    """The packing JSON of `cdshear prepare` (format "cdshear-packing") as a dict."""
    try:
        with open_regular(path, encoding="utf-8") as f:
            packing = json.load(f, object_pairs_hook=unique_keys, parse_int=_json_integer)
    except (OSError, ValueError) as e:
        raise PeerError(path, f"cannot read packing: {e}") from e
    except RecursionError:
        raise PeerError(path, "cannot read packing: its JSON is nested too deeply") from None
    if not isinstance(packing, dict) or packing.get("format") != "cdshear-packing":
        raise PeerError(path, "not a cdshear packing (format != cdshear-packing)")
    for key in ("length_x", "height", "disks_xyr"):
        if key not in packing:
            raise PeerError(path, f"packing has no '{key}'")
    return packing


def ripple(wall_radius, spacing, grain_radius):
    """Height by which a grain of radius r sinks between two wall disks (radius R, centres s
    apart) below its height on top of one: (r + R) - sqrt((r + R)^2 - (s/2)^2), about
    s^2 / (8 (r + R)). It is the roughness of the wall as the grain feels it (d)."""
    a = grain_radius + wall_radius
    return a - math.sqrt(a * a - 0.25 * spacing * spacing)


# A disk may cross a wall by a tenth of cdshear's step.abort_overlap (0.1 d), as read_packing
# allows (src/io/packing_file.cpp). The solid fraction: at most 1, and above a floor far below
# any packing's (read_packing's is 0.1; the converter also takes small hand-made cells).
WALL_CROSSING_TOLERANCE = 0.01
SOLID_FRACTION_RANGE = (0.01, 1.0)


# As cdshear's kMaxPeriodsFromOrigin (src/core/world.hpp).
MAX_PERIODS_FROM_ORIGIN = 1e6

# The keys `cdshear prepare` writes (packing_json, src/io/packing_file.cpp), the only ones
# read_packing takes, and the version it reads.
PACKING_KEYS = frozenset((
    "format", "version", "program_version", "build", "n", "height", "length_x", "diameter_min",
    "diameter_max", "seed", "solid_fraction", "piston_stress", "preparation_time",
    "preparation_steps", "capped_steps", "displacement_warnings", "largest_overlap",
    "disks_xyr"))
PACKING_VERSION = 1


def _check_packing_keys(packing):
    """What `cdshear`'s read_packing refuses of the file's keys before the disks: a key it does
    not write, another version, and `n` that is not a whole number (511.0)."""
    for key in packing:
        if key not in PACKING_KEYS:
            raise PeerError("packing", f"{key}: unknown key (a packing holds the keys `cdshear "
                                       f"prepare` writes)")
    if "version" in packing and not (is_number(packing["version"])
                                     and packing["version"] == PACKING_VERSION):
        raise PeerError("packing", f"version is {packing['version']!r}; cdshear reads version "
                                   f"{PACKING_VERSION}")
    n = packing.get("n")
    if n is not None and not (isinstance(n, int) and not isinstance(n, bool)):
        raise PeerError("packing", f"n must be a whole number, not {n!r}")


def _largest_overlap(xyr, lx):
    """(i, j, overlap) of the two disks that overlap most, x periodic with period lx, or None
    when no two touch. The pairs within two largest radii come from a k-d tree, whose periodic
    box needs every coordinate inside it: y is shifted and given a period no pair can span."""
    from scipy.spatial import cKDTree
    x = np.mod(xyr[:, 0], lx)
    x[x >= lx] = 0.0          # mod can round up to lx itself
    y, r = xyr[:, 1] - xyr[:, 1].min(), xyr[:, 2]
    reach = 2.0 * float(r.max())
    span = float(np.nextafter(float(y.max()) + 2.0 * reach + 1.0, np.inf))
    pairs = cKDTree(np.column_stack([x, y]), boxsize=[lx, span]).query_pairs(
        reach, output_type="ndarray")
    if len(pairs) == 0:
        return None
    i, j = pairs[:, 0], pairs[:, 1]
    dx = x[i] - x[j]
    dx -= lx * np.round(dx / lx)
    overlap = r[i] + r[j] - np.hypot(dx, y[i] - y[j])
    k = int(np.argmax(overlap))
    return int(i[k]), int(j[k]), float(overlap[k])


def _check_packing_geometry(packing, xyr, lx, height):
    """What `cdshear`'s read_packing checks of the disks against the cell: the count `n`, the
    diameters within diameter_min to diameter_max, no disk crossing a wall, a solid fraction
    a preparation can give (a length_x typed 1e308 would make a wall of 1e308 disks) and the
    file's own solid_fraction; and what a shear run's build refuses: two disks overlapping."""
    if "n" in packing and not (is_number(packing["n"]) and packing["n"] == len(xyr)):
        raise PeerError("packing", f"n is {packing['n']!r}, but disks_xyr lists {len(xyr)} disks")
    bounds = [packing.get(k) for k in ("diameter_min", "diameter_max")]
    if any(b is not None for b in bounds):
        if not all(is_number(b) and math.isfinite(b) and b > 0 for b in bounds) or \
                bounds[1] < bounds[0]:
            raise PeerError("packing", f"diameter_min and diameter_max must be numbers with "
                                       f"0 < diameter_min <= diameter_max, got {bounds}")
        diameters = 2 * xyr[:, 2]
        outside = (diameters < bounds[0] * (1 - 1e-12)) | (diameters > bounds[1] * (1 + 1e-12))
        if outside.any():
            i = int(np.argmax(outside))
            raise PeerError("packing", f"disks_xyr[{i}]: diameter {diameters[i]!r} outside "
                                       f"diameter_min to diameter_max ({bounds[0]} to {bounds[1]})")
    # cdshear refuses a disk more than a million periods from x = 0 (kMaxPeriodsFromOrigin):
    # its place within the period would be lost to rounding.
    far = np.abs(xyr[:, 0]) > MAX_PERIODS_FROM_ORIGIN * lx
    if far.any():
        i = int(np.argmax(far))
        raise PeerError("packing", f"disks_xyr[{i}]: x = {xyr[i, 0]!r} is more than a million "
                                   f"periods (length_x = {lx!r}) from 0: give the disk's place "
                                   f"within the period")
    y, r = xyr[:, 1], xyr[:, 2]
    crossing = (y - r < -WALL_CROSSING_TOLERANCE) | (y + r > height + WALL_CROSSING_TOLERANCE)
    if crossing.any():
        i = int(np.argmax(crossing))
        raise PeerError("packing", f"disks_xyr[{i}] crosses a wall (y = {y[i]!r}, r = {r[i]!r}, "
                                   f"L_y = {height!r})")
    # cdshear's shear cell needs a period of three largest diameters (its build refuses less)
    if lx < 3.0 * 2.0 * float(r.max()):
        raise PeerError("packing", f"length_x {lx!r} is shorter than 3 largest diameters "
                                   f"({2.0 * float(r.max())!r}): no shear cell")
    solid_fraction = float(np.sum(np.pi * r * r)) / (lx * height)
    if not SOLID_FRACTION_RANGE[0] <= solid_fraction <= SOLID_FRACTION_RANGE[1]:
        raise PeerError("packing", f"the disks fill {solid_fraction:.3g} of length_x x height, "
                                   f"outside {SOLID_FRACTION_RANGE[0]} to "
                                   f"{SOLID_FRACTION_RANGE[1]}: a cell of another size")
    # The file's own figure is the disks' (read_packing): one that disagrees says the disks or
    # the cell were edited without it.
    given = packing.get("solid_fraction")
    if given is not None and not (is_number(given)
                                  and abs(given - solid_fraction) <= 1e-9 * solid_fraction):
        raise PeerError("packing", f"solid_fraction is {given!r}, but the disks fill "
                                   f"{solid_fraction!r} of L_x x L_y = {lx!r} x {height!r} (were "
                                   f"the disks, length_x or height edited?)")
    # Two disks overlapping more than a shear run takes of a packing (its build refuses them).
    worst = _largest_overlap(xyr, lx)
    if worst is not None and worst[2] > WALL_CROSSING_TOLERANCE:
        i, j, overlap = worst
        raise PeerError("packing", f"disks_xyr[{i}] and disks_xyr[{j}] overlap by {overlap:.6g} "
                                   f"(tolerance {WALL_CROSSING_TOLERANCE}, a shear run's at the "
                                   f"default step.abort_overlap)")


def packing_to_lammps(packing, wall_radius=WALL_RADIUS, wall_spacing=WALL_SPACING,
                      wall_mass=WALL_MASS, margin=BOX_MARGIN):
    """(data_text, variables): the LAMMPS data file and the variables of the include file.

    Geometry (model.md sections 4 and 5): the packing's bottom wall is the line y = 0, its top
    wall y = height, x periodic with period length_x. Grains: type 1, ids 1..n, centre x wrapped
    into [0, length_x). Walls: n_wall = ceil(length_x / wall_spacing) disks of radius R_w per wall,
    spaced length_x / n_wall, centres at y = -R_w (bottom, type 2) and height + R_w (top,
    type 3), so their tops are the wall lines. Box: x [0, length_x) periodic, y from
    -2 R_w - margin to height + 2 R_w + margin (fixed), z [-0.5, 0.5] (2D).
    """
    _check_packing_keys(packing)
    for key in ("length_x", "height"):
        if not is_number(packing[key]):
            raise PeerError("packing", f"{key} must be a number, got {packing[key]!r}")
    disks = packing["disks_xyr"]
    if not isinstance(disks, list) or not disks:
        raise PeerError("packing", "disks_xyr must be a non-empty list of [x, y, r]")
    for i, disk in enumerate(disks):
        if not (isinstance(disk, list) and len(disk) == 3 and all(map(is_number, disk))):
            raise PeerError("packing", f"disks_xyr[{i}] must be [x, y, r], three numbers, "
                                       f"got {disk!r}"[:200])
    lx, height = float(packing["length_x"]), float(packing["height"])
    xyr = np.asarray(disks, dtype=float)
    if not (math.isfinite(lx) and math.isfinite(height) and np.all(np.isfinite(xyr))):
        raise PeerError("packing", "length_x, height and disks_xyr must be finite")
    if not (lx > 0 and height > 0 and np.all(xyr[:, 2] > 0)):
        raise PeerError("packing", "length_x, height and every radius must be positive")
    _check_packing_geometry(packing, xyr, lx, height)
    n = len(xyr)
    n_wall = int(math.ceil(lx / wall_spacing))
    spacing = lx / n_wall
    x = np.mod(xyr[:, 0], lx)
    x[x >= lx] = 0.0          # mod can round up to lx itself
    y, r = xyr[:, 1], xyr[:, 2]
    grain_mass = math.pi * r * r                      # 2D density 1
    grain_density = grain_mass / (4.0 / 3.0 * math.pi * r ** 3)   # = 3 / (4 r), see module doc
    wall_atom_mass = wall_mass / n_wall
    wall_density = wall_atom_mass / (4.0 / 3.0 * math.pi * wall_radius ** 3)
    ylo, yhi = -2.0 * wall_radius - margin, height + 2.0 * wall_radius + margin

    lines = [f"LAMMPS data file from a cdshear packing (n = {n}, L_x = {lx!r}, "
             f"L_y = {height!r}); walls as rows of {n_wall} disks",
             "",
             f"{n + 2 * n_wall} atoms",
             "3 atom types",
             "",
             f"0.0 {lx!r} xlo xhi",
             f"{ylo!r} {yhi!r} ylo yhi",
             "-0.5 0.5 zlo zhi",
             "",
             "Atoms # sphere",
             ""]
    # atom-ID atom-type diameter density x y z
    for i in range(n):
        lines.append(f"{i + 1} {GRAIN_TYPE} {2.0 * r[i]!r} {grain_density[i]!r} "
                     f"{x[i]!r} {y[i]!r} 0.0")
    for w, (kind, yc) in enumerate(((BOTTOM_TYPE, -wall_radius),
                                    (TOP_TYPE, height + wall_radius))):
        for k in range(n_wall):
            atom_id = n + w * n_wall + k + 1
            lines.append(f"{atom_id} {kind} {2.0 * wall_radius!r} {wall_density!r} "
                         f"{(k + 0.5) * spacing!r} {yc!r} 0.0")
    data_text = "\n".join(lines) + "\n"

    variables = dict(
        n_grains=n, n_wall=n_wall, length_x=lx, height0=height, wall_radius=wall_radius,
        wall_spacing=spacing, wall_mass=wall_mass,
        grain_area=float(np.sum(grain_mass)),            # sum of pi r^2 (density 1)
        grain_mass_min=float(grain_mass.min()),          # lightest grain, for t_c and gamma_n
        wall_ripple=ripple(wall_radius, spacing, float(r.min())))
    return data_text, variables


def write_lammps_packing(packing_path, data_path, vars_path=None, **options):
    """Writes the data file and the include file (`variable NAME equal VALUE` lines read by
    in.shear); returns the variables. vars_path defaults to data_path + '.vars'."""
    packing = load_packing(packing_path)
    try:
        data_text, variables = packing_to_lammps(packing, **options)
    except PeerError as e:
        raise PeerError(packing_path, e.problem) from e
    vars_path = vars_path or data_path + ".vars"
    write_text_atomically(data_path, data_text)
    write_text_atomically(vars_path, "".join(
        [f"# written by cdshear_analysis.peers from {os.path.basename(packing_path)}\n"]
        + [f"variable {key} equal {value!r}\n" for key, value in variables.items()]))
    return variables


# ---------------------------------------------------------------------------------------------
# Series of either code and the common estimator

def lammps_series(path):
    """The series file of in.shear (fix ave/time: interval means over every step of each
    sample interval). Columns: step, time, bottom_fx, bottom_fy, top_fx, top_fy (forces of the
    grains on each wall, the applied force removed), height (distance between the walls'
    lines), solid_fraction (grain area / (L_x height)), com_vx. Returns a dict of arrays."""
    names = ("step", "time", "bottom_fx", "bottom_fy", "top_fx", "top_fy", "height",
             "solid_fraction", "com_vx")
    try:
        with open_regular(path, encoding="utf-8") as f, warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)   # "input contained no data": below
            table = np.loadtxt(f, comments="#", ndmin=2)
    except (OSError, ValueError) as e:
        raise PeerError(path, f"cannot read LAMMPS series: {e}") from e
    if table.shape[0] == 0:
        raise PeerError(path, "holds no sample (only comments, or nothing): the LAMMPS run "
                              "wrote none")
    if table.shape[1] != len(names):
        raise PeerError(path, f"expected rows of {len(names)} columns, got {table.shape[1]}")
    bad = ~np.isfinite(table) | (np.abs(np.nan_to_num(table)) > MEASURED_MAGNITUDE_LIMIT)
    if np.any(bad):
        row = int(np.argmax(bad.any(axis=1)))
        raise PeerError(path, f"row {row + 1} of the samples holds a value that is not finite "
                              f"or beyond {MEASURED_MAGNITUDE_LIMIT:g} in magnitude")
    if table.shape[0] > 1 and np.any(np.diff(table[:, 1]) <= 0):
        row = int(np.argmax(np.diff(table[:, 1]) <= 0)) + 1
        raise PeerError(path, f"time does not increase at row {row + 1} of the samples")
    return {name: table[:, k] for k, name in enumerate(names)}


def cdshear_series(run_dir):
    """/series of RUN_DIR/run.h5 (docs/run-data.md) with the same names."""
    from .rundata import load_run
    run = load_run(run_dir)
    s = run["series"]
    return {name: np.asarray(s[name], dtype=float)
            for name in ("time", "bottom_fx", "bottom_fy", "top_fx", "top_fy", "height",
                         "com_vx", "solid_fraction")}


def second_half_estimates(series, duration, name="series"):
    """mu_eff and solid fraction over the samples with time > duration / 2, same estimator for
    both codes (`estimates_after`); `name`: the file the series came from, for errors."""
    return estimates_after(series, 0.5 * duration, name)


def estimates_after(series, start_time, name="series"):
    """mu_eff, solid fraction and height over the samples with time > start_time:
      mu_eff = <|f_x^bottom| + |f_x^top|> / <|f_y^bottom| + |f_y^top|> (ratio of the time
      averaged tangential and normal wall forces), error err(a - mu b) / <b> with a, b the
      two sums per sample (first-order propagation; err = block averaging);
      solid fraction: block average of the series; height likewise.
    """
    t = series["time"]
    keep = t > start_time
    if np.count_nonzero(keep) < 16:
        raise PeerError(name, f"only {np.count_nonzero(keep)} samples after t = {start_time:g} "
                              f"(half of --duration): a run of that length?")
    a = np.abs(series["bottom_fx"][keep]) + np.abs(series["top_fx"][keep])
    b = np.abs(series["bottom_fy"][keep]) + np.abs(series["top_fy"][keep])
    if not b.mean() > 0:
        raise PeerError(name, f"no normal force on the walls after t = {start_time:g}: no "
                              f"mu_eff")
    mu = float(a.mean() / b.mean())
    mu_err = block_average(a - mu * b)["err"] / float(b.mean())
    nu = block_average(series["solid_fraction"][keep])
    h = block_average(series["height"][keep])
    return dict(mu_eff=mu, mu_eff_err=float(mu_err), solid_fraction=nu["mean"],
                solid_fraction_err=nu["err"], height=h["mean"], height_err=h["err"],
                samples=int(np.count_nonzero(keep)),
                normal_force=float(b.mean() / 2.0))


# ---------------------------------------------------------------------------------------------
# Overlaps in a LAMMPS dump

def read_dump(path):
    """Snapshots of `dump custom ... id type x y radius`: a list of (step, array[id, type, x,
    y, radius]) and the box's x length."""
    snaps, lx = [], None
    try:
        with open_regular(path, encoding="utf-8") as f:
            lines = f.read().split("\n")
    except OSError as e:
        raise PeerError(path, f"cannot read dump: {e}") from e
    i = 0
    while i < len(lines):
        if lines[i].startswith("ITEM: TIMESTEP"):
            try:
                step = int(lines[i + 1])
                count = int(lines[i + 3])
                xlo, xhi = (float(v) for v in lines[i + 5].split()[:2])
                header = lines[i + 8].split()[2:]
                want = ["id", "type", "x", "y", "radius"]
                if header != want:
                    raise PeerError(path, f"dump columns {header}, expected {want}")
                rows = np.array([lines[i + 9 + k].split() for k in range(count)], dtype=float)
            except (IndexError, ValueError):
                raise PeerError(path, f"the snapshot from line {i + 1} is cut short or not "
                                      f"numbers (ITEM: TIMESTEP, NUMBER OF ATOMS, BOX BOUNDS, "
                                      f"ATOMS id type x y radius, then one row per atom)") from None
            if count <= 0:
                raise PeerError(path, f"the snapshot from line {i + 1} holds no atoms (NUMBER OF "
                                      f"ATOMS {count})")
            if rows.shape != (count, 5) or not (np.all(np.isfinite(rows)) and xhi > xlo):
                raise PeerError(path, f"the snapshot from line {i + 1}: expected {count} rows "
                                      f"of 5 finite numbers and xhi > xlo")
            lx = xhi - xlo
            snaps.append((step, rows))
            i += 9 + count
        else:
            i += 1
    if not snaps:
        raise PeerError(path, "no snapshot in dump")
    return snaps, lx


def max_overlap(rows, lx, chunk=512):
    """Largest overlap r_i + r_j - |x_i - x_j| over the grain-grain pairs (nearest periodic
    image in x) and the grain-wall-disk pairs of one snapshot (0 when nothing overlaps).
    The pairs are taken `chunk` grains at a time, so that a snapshot of system 7 (5119 grains)
    needs arrays of chunk x 5903 numbers, not 5119 x 5119."""
    kind = rows[:, 1].astype(int)
    grains = rows[kind == GRAIN_TYPE]
    walls = rows[kind != GRAIN_TYPE]
    best = 0.0
    for first in range(0, len(grains), chunk):
        mine = grains[first:first + chunk]
        for others, same in ((grains, True), (walls, False)):
            dx = mine[:, None, 2] - others[None, :, 2]
            dx -= lx * np.round(dx / lx)
            dy = mine[:, None, 3] - others[None, :, 3]
            overlap = mine[:, None, 4] + others[None, :, 4] - np.hypot(dx, dy)
            if same:  # a grain and itself is no pair
                k = np.arange(len(mine))
                overlap[k, first + k] = -np.inf
            if overlap.size:
                best = max(best, float(overlap.max()))
    return best


def max_overlap_from_dump(path):
    """(largest overlap over all snapshots, mean of the per-snapshot largest, snapshots)."""
    snaps, lx = read_dump(path)
    per = np.array([max_overlap(rows, lx) for _, rows in snaps])
    return float(per.max()), float(per.mean()), len(per)


# ---------------------------------------------------------------------------------------------
# The table of bench/peers/side_by_side.sh

def side_by_side(cdshear_run, lammps_dir, duration, cdshear_seconds, lammps_seconds):
    """Both codes' figures as a dict: wall seconds per simulated time unit, their ratio, the
    second-half estimates (mu_eff, solid fraction, height), LAMMPS' largest overlap."""
    cd_series, cd_path = cdshear_series(cdshear_run), os.path.join(cdshear_run, "run.h5")
    series_path = os.path.join(lammps_dir, "series.txt")
    lm_series = lammps_series(series_path)
    for series, path in ((cd_series, cd_path), (lm_series, series_path)):
        _check_ends_at(series, duration, path)
    cd = second_half_estimates(cd_series, duration, cd_path)
    lm = second_half_estimates(lm_series, duration, series_path)
    cd["seconds_per_time"] = cdshear_seconds / duration
    lm["seconds_per_time"] = lammps_seconds / duration
    dump = os.path.join(lammps_dir, "dump.txt")
    from .rundata import load_run
    run = load_run(cdshear_run)
    if os.path.exists(dump):
        _check_same_cell(dump, run["attrs"], cd_path)
        lm["max_overlap"], lm["mean_max_overlap"], lm["snapshots"] = max_overlap_from_dump(dump)
    overlap = run["series"].get("overlap_max")
    if overlap is not None and len(overlap):
        cd["max_overlap"] = float(np.nanmax(overlap))
    return dict(duration=duration, cdshear=cd, lammps=lm,
                ratio=lm["seconds_per_time"] / cd["seconds_per_time"])


def _check_same_cell(dump, attrs, run_path):
    """PeerError unless the LAMMPS dump's first snapshot holds the cdshear run's number of grains
    in a box of its L_x (run.h5's attributes n and length_x, to 1e-6): two codes' figures of
    other systems would read as a comparison of codes."""
    snaps, lx = read_dump(dump)
    grains = int(np.count_nonzero(snaps[0][1][:, 1].astype(int) == GRAIN_TYPE))
    n, length_x = int(attrs["n"]), float(attrs["length_x"])
    if grains != n or not math.isclose(lx, length_x, rel_tol=1e-6):
        raise PeerError(dump, f"holds {grains} grains in a box {lx:.6g} wide where {run_path} "
                              f"has {n} in {length_x:.6g}: a run of another system")


def _check_ends_at(series, duration, name, said="--duration",
                   because="its second half and seconds per time unit would be of another run "
                           "length", samples="samples"):
    """Raises PeerError, naming the file `name`, unless the series' last sample lies within two
    sample intervals of `duration` (`said`: where that duration comes from; `because`: why it
    matters, None for a run's own record: its averages then cover another stretch of the flow
    than its namesake's)."""
    t = series["time"]
    spacing = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    if len(t) and abs(float(t[-1]) - duration) > max(2.0 * spacing, 1e-9 * duration):
        if because is None:
            because = ("cut short (the run stopped early, or the file was cut)"
                       if float(t[-1]) < duration else "longer than the run it records (another "
                       "run's file?)") + ": its averages would be of another stretch of the " \
                "flow than its namesake's"
        raise PeerError(name, f"its {samples} end at t = {float(t[-1]):g}, not at {said} "
                              f"{duration:g}: {because}")


def format_side_by_side(result):
    """The printed table (plain text, one row per figure)."""
    cd, lm = result["cdshear"], result["lammps"]

    def pm(d, key, digits):
        err = d.get(key + "_err")
        text = f"{d[key]:.{digits}f}"
        return text + (f" +- {err:.{digits}f}" if err is not None and np.isfinite(err) else "")

    def overlap(d):
        return f"{d['max_overlap']:.2e}" if "max_overlap" in d else "n/a"

    rows = [("wall s per time unit", f"{cd['seconds_per_time']:.3f}",
             f"{lm['seconds_per_time']:.3f}"),
            ("ratio LAMMPS / cdshear", "", f"{result['ratio']:.2f}"),
            ("mu_eff (wall forces)", pm(cd, "mu_eff", 4), pm(lm, "mu_eff", 4)),
            ("solid fraction", pm(cd, "solid_fraction", 4), pm(lm, "solid_fraction", 4)),
            ("L_y", pm(cd, "height", 3), pm(lm, "height", 3)),
            ("mean normal wall force", f"{cd['normal_force']:.4f}", f"{lm['normal_force']:.4f}"),
            ("max overlap (d)", overlap(cd), overlap(lm)),
            ("samples in second half", str(cd["samples"]), str(lm["samples"]))]
    width = max(len(r[0]) for r in rows)
    lines = [f"side by side over t in ({0.5 * result['duration']:g}, {result['duration']:g}] "
             "(second half), errors: block averaging",
             f"{'':{width}}  {'cdshear':>20}  {'LAMMPS':>20}"]
    lines += [f"{name:{width}}  {a:>20}  {b:>20}" for name, a, b in rows]
    if "snapshots" in lm:
        lines.append(f"(LAMMPS overlap: largest over {lm['snapshots']} snapshots; mean of the "
                     f"per-snapshot largest {lm['mean_max_overlap']:.2e}; cdshear: largest "
                     "after a step, every step)")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# LAMMPS runs beside a campaign (bench/peers/lammps_campaign.sh)

def read_vars(path):
    """The include file of `write_lammps_packing` as {name: float}."""
    out = {}
    try:
        with open_regular(path, encoding="utf-8") as f:
            for line in f:
                words = line.split()
                if len(words) == 4 and words[0] == "variable" and words[2] == "equal":
                    out[words[1]] = float(words[3])
    except (OSError, ValueError) as e:
        raise PeerError(path, f"cannot read LAMMPS variables: {e}") from e
    return out


def wall_lines(rows, wall_radius):
    """(bottom, top) wall lines of one dump snapshot: the mean height of the bottom row's disk
    centres plus R_w, of the top row's minus R_w (in.shear's height is their distance)."""
    kind = rows[:, 1].astype(int)
    bottom, top = rows[kind == BOTTOM_TYPE, 3], rows[kind == TOP_TYPE, 3]
    if not len(bottom) or not len(top):
        raise PeerError("dump", "a snapshot without both walls' disks")
    return float(bottom.mean()) + wall_radius, float(top.mean()) - wall_radius


def segment_area(radius, lower, upper):
    """Area of a disk of the given radius, centred at height 0, between the heights lower <=
    upper (arrays): A(z) = z sqrt(r^2 - z^2) + r^2 asin(z / r) + pi r^2 / 2 is the area below z,
    z clipped to [-r, r]."""
    def below(z):
        z = np.clip(z, -radius, radius)
        return (z * np.sqrt(np.maximum(radius * radius - z * z, 0.0))
                + radius * radius * np.arcsin(z / radius) + 0.5 * np.pi * radius * radius)
    return below(upper) - below(lower)


def stripe_solid_fraction(rows, lx, lower, upper):
    """Grain area fraction of one snapshot between the heights lower < upper: each grain's exact
    circular segment in the stripe over lx (upper - lower), as cdshear's stripes count it
    (src/measure/shear_measurement.hpp)."""
    grains = rows[rows[:, 1].astype(int) == GRAIN_TYPE]
    y, r = grains[:, 3], grains[:, 4]
    return float(segment_area(r, lower - y, upper - y).sum() / (lx * (upper - lower)))


def bulk_stripes(height, bulk_h, stripe_thickness):
    """(lower, upper) heights above the bottom wall line of the bulk as cdshear takes it: the
    stripes of thickness dy from the bottom wall line whose centres (k + 1/2) dy lie in bulk_h <
    y < height - bulk_h (python/cdshear_analysis/profiles.py, region_quantities), all of them
    (None where there is none)."""
    dy = stripe_thickness
    first = math.floor(bulk_h / dy - 0.5) + 1
    last = math.ceil((height - bulk_h) / dy - 0.5) - 1
    return (first * dy, (last + 1) * dy) if last >= first else None


def lammps_run_row(run_dir, start_time, bulk_h, stripe_thickness=1.0, window=80.0):
    """One LAMMPS run of bench/peers/lammps_campaign.sh (RUN_DIR/run.json, packing.data.vars,
    lammps/series.txt and lammps/dump.txt) as a runs.csv-like row averaged over t > start_time:
    mu_eff_wall, L_y and solid_fraction from the series (`estimates_after`); nu_bulk from the
    dump's snapshots as cdshear measures it (docs/model.md section 7): the snapshots in windows
    of `window` time units, [k window, (k + 1) window], each whole and after start_time; in each,
    the grain area in the bulk's stripes (`bulk_stripes` of the window's mean wall distance);
    the mean over the windows and its standard error (`nu_bulk_err`). No nu_bulk where bulk_h
    is None or fewer than two windows hold a bulk."""
    meta_path = os.path.join(run_dir, "run.json")
    try:
        with open_regular(meta_path, encoding="utf-8") as f:
            meta = json.load(f, object_pairs_hook=unique_keys)
    except (OSError, ValueError, RecursionError) as e:
        raise PeerError(meta_path, f"cannot read the run's record: {e}") from e
    if not isinstance(meta, dict):
        raise PeerError(meta_path, "the run's record is not a JSON object")
    name = os.path.basename(os.path.normpath(run_dir))
    if meta.get("run", name) != name:   # the script writes the folder's name
        raise PeerError(meta_path, f"is the record of run {meta.get('run')!r}, not of {name!r} "
                                   "(a run.json copied from another run's folder)")
    for key in ("velocity", "duration"):
        if not _positive_number(meta.get(key)):
            raise PeerError(meta_path, f"{key} = {meta.get(key)!r}: expected a number > 0 "
                                       "(lammps_campaign.sh writes the run's)")
    if meta.get("kappa") is not None and not _positive_number(meta["kappa"]):
        raise PeerError(meta_path, f"kappa = {meta['kappa']!r}: expected a number > 0 (the "
                                   "normal stiffness lammps_campaign.sh ran with)")
    variables = read_vars(os.path.join(run_dir, "packing.data.vars"))
    wall_radius, n_grains = variables.get("wall_radius"), variables.get("n_grains")
    if wall_radius is None:
        raise PeerError(os.path.join(run_dir, "packing.data.vars"), "no wall_radius")
    series_path = os.path.join(run_dir, "lammps", "series.txt")
    series = lammps_series(series_path)
    _check_ends_at(series, meta["duration"], series_path, "run.json's duration", None)
    est = estimates_after(series, start_time, series_path)
    row = {"run": name, "V": meta["velocity"], "duration": meta["duration"],
           "n": int(n_grains) if n_grains is not None and float(n_grains).is_integer() else None,
           "kappa": meta.get("kappa"), "mu_eff_wall": est["mu_eff"],
           "mu_eff_wall_err": est["mu_eff_err"], "L_y": est["height"],
           "L_y_err": est["height_err"], "solid_fraction": est["solid_fraction"],
           "solid_fraction_err": est["solid_fraction_err"]}
    if bulk_h is None:
        return row
    dump_path = os.path.join(run_dir, "lammps", "dump.txt")
    snaps, lx = read_dump(dump_path)
    # the series' times are printed to six digits: steps per time unit from its whole span,
    # and a snapshot's window from its time to within a thousandth of a time unit
    steps_per_time = ((series["step"][-1] - series["step"][0])
                      / (series["time"][-1] - series["time"][0]))
    last_time = snaps[-1][0] / steps_per_time
    _check_ends_at({"time": np.array([step / steps_per_time for step, _ in snaps])},
                   meta["duration"], dump_path, "run.json's duration", None, "snapshots")
    first_window = math.ceil(start_time / window - 1e-6)
    windows = {}
    for step, rows in snaps:
        t = step / steps_per_time
        k = math.ceil(t / window - 1e-6) - 1          # (k window, (k + 1) window]
        if k < first_window or (k + 1) * window > last_time + 1e-3:
            continue
        bottom, top = wall_lines(rows, wall_radius)
        windows.setdefault(k, []).append((bottom, top - bottom, rows))
    values = []
    for k in sorted(windows):
        snapshots = windows[k]
        stripes = bulk_stripes(float(np.mean([h for _, h, _ in snapshots])), bulk_h,
                               stripe_thickness)
        if stripes is not None:
            values.append(np.mean([stripe_solid_fraction(rows, lx, bottom + stripes[0],
                                                         bottom + stripes[1])
                                   for bottom, _, rows in snapshots]))
    if len(values) >= 2:
        row["nu_bulk"], row["nu_bulk_err"] = window_mean(np.array(values))
    return row


def lammps_campaign(lammps_folder, campaign):
    """The LAMMPS runs under lammps_folder (one folder per campaign run, named as the run) as a
    campaign.Campaign whose rows average each run as its namesake in `campaign` (a Campaign or
    a folder) is averaged: from its averaging start (summary.json's averaging_start_time, else
    the second half), with its bulk's h, its stripes' thickness and its window (case.toml's
    measure.stripe_thickness and measure.window). Runs without a finished LAMMPS run, whose own run
    is not finished, whose case.toml lacks those two, or whose LAMMPS run is of another duration
    are left out (listed in `skipped`). Raises PeerError for a LAMMPS run whose files cannot be
    read or end before or after its run.json's duration, and for runs of two stiffnesses."""
    from .campaign import Campaign, _column, load_campaign
    from .report import ReportError, read_summary, reached_text
    campaign = campaign if isinstance(campaign, Campaign) else load_campaign(campaign)
    if not os.path.isdir(lammps_folder):
        raise PeerError(lammps_folder, f"is {what_is(lammps_folder)}, not the folder of the LAMMPS "
                                       "runs" if os.path.lexists(lammps_folder) else
                        "no such folder (the OUT of bench/peers/lammps_campaign.sh)")
    rows, skipped = [], []
    for ref in campaign.rows:
        run_dir = os.path.join(lammps_folder, ref["run"])
        if not os.path.exists(os.path.join(run_dir, "run.json")):
            skipped.append((ref["run"], "no finished LAMMPS run"))
            continue
        if ref.get("finished") is False:
            reached = ref.get("time_reached")
            skipped.append((ref["run"], "the campaign's run is not finished"
                                        + (f" ({reached_text(reached, ref.get('duration'))})"
                                           if is_number(reached) else "")
                                        + ": the finished LAMMPS run's averages would cover "
                                        "other times"))
            continue
        ref_dir = os.path.join(campaign.folder, "runs", ref["run"])
        try:
            summary = read_summary(ref_dir)
        except ReportError:
            summary = None
        summary = summary if isinstance(summary, dict) else {}
        measure = (folder_case(ref_dir) or {}).get("measure", {})
        measure = measure if isinstance(measure, dict) else {}
        start = summary.get("averaging_start_time")
        if not _positive_number(start, zero=True):
            if not _positive_number(ref.get("duration")):
                skipped.append((ref["run"], "neither an averaging start nor a duration"))
                continue
            start = 0.5 * float(ref["duration"])
        dy, window = measure.get("stripe_thickness"), measure.get("window")
        if not (_positive_number(dy) and _positive_number(window)):
            skipped.append((ref["run"], "its case.toml gives no measure.stripe_thickness and "
                                        "measure.window > 0 to average the LAMMPS run as it"))
            continue
        row = lammps_run_row(run_dir, float(start), ref.get("bulk_h"), float(dy), float(window))
        if not (_positive_number(ref.get("duration"))
                and math.isclose(row["duration"], ref["duration"], rel_tol=1e-9)):
            skipped.append((ref["run"], f"LAMMPS ran {row['duration']:g} t, the campaign's run "
                                        f"{ref.get('duration')} t: their averages would cover "
                                        "other times"))
            continue
        row.update(system=ref.get("system"), seed=ref.get("seed"), regime="not classified")
        rows.append(row)
    kappas = {}
    for row in rows:
        kappas.setdefault(row.get("kappa"), row["run"])
    if len(kappas) > 1:
        made = ", ".join(f"{run}: {kappa:g}" if is_number(kappa) else f"{run}: {kappa!r}"
                         for kappa, run in kappas.items())
        raise PeerError(lammps_folder, f"its runs were made with other contact stiffnesses "
                                       f"(run.json's kappa; {made}): pooled, they would mix two "
                                       "models; run them again with one kappa")
    keys = sorted({k for r in rows for k in r})
    columns = {k: _column([r.get(k) for r in rows]) for k in keys}
    return Campaign(name=f"LAMMPS beside {campaign.name}", folder=lammps_folder, rows=rows,
                    columns=columns, skipped=skipped)


def _positive_number(value, zero=False):
    """Whether value is a finite number above 0 (at or above it with zero=True)."""
    return is_number(value) and math.isfinite(value) and (value >= 0 if zero else value > 0)

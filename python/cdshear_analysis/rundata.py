"""Reading a run folder: `load_run(RUN_DIR)` mirrors RUN_DIR/run.h5 (docs/run-data.md).

The result is a plain dict:
    run["run_dir"], run["path"]          the folder and its run.h5
    run["attrs"]                         root attributes (str, int, float, numpy arrays)
    run["case"]                          the resolved case, parsed from attrs["case_toml"]
                                         (or case.toml in the folder), {} if neither parses
    run["series"][name]                  /series datasets, length N
    run["windows"][name]                 /windows datasets, first axis W (y has length S)
    run["regions"]["h10"][name]          /windows/regions/h10 datasets, plus ["h"] (float),
                                         ordered by increasing h
    run["top_stripes"][name]             /windows/top_stripes datasets (depth has length T,
                                         the others first axis W), None in files before
                                         version 4
    run["snapshot"][name]                /snapshot datasets and attributes (`time`, `length_x`,
                                         `height` are attributes; datasets are accepted too, as
                                         plain floats), None if absent
Every problem with the folder or file raises RunDataError(path, problem).

`truncate_run(run, t)` gives the run as it stood at time t (the samples at t or before, the
windows ending by then), for averages over the first t of a longer run.

Format versions (attrs["format_version"]). Version 4 (FORMAT_VERSION) measures the top
boundary layer on stripes counted down from the top wall (/windows/top_stripes). Version 3
counts Z as the closed contacts (gap <= contact_gap), keeps the per-step count as
force_carrying_coordination, and stores the rotation's momentum flux as rotational_stress beside
a stress of contact and kinetic parts. Older files are read as version 4 would describe them
where they can be, with attrs["legacy_note"]: before version 4 the top layer's regions are as
written (stripes counted from the bottom wall, docs/measurements.md); version 2 added
rotational_stress into stress: it is taken out again, and mu_eff (profiles and regions)
recomputed; in a version-1 file, coordination (the contacts carrying force at the
sampled step) becomes force_carrying_coordination and Z is NaN (not measured).
"""
import contextlib
import errno
import json
import math
import os
import re
import signal
import stat
import tempfile
import threading
import tomllib
import zlib

import h5py
import numpy as np

from .profiles import former_regions

RUN_FILE = "run.h5"
# The files that mark a folder as a run's (what `cdshear run` writes there).
RUN_FOLDER_FILES = (RUN_FILE, "summary.json", "case.toml", "checkpoint.cbor", "final_state.json")
FORMAT_VERSION = 4
REQUIRED_ATTRS = ("n", "length_x", "height", "velocity", "normal_stress", "duration", "window",
                  "time")
REQUIRED_SERIES = ("time", "com_vx", "height", "solid_fraction",
                   "bottom_fx", "bottom_fy", "top_fx", "top_fy")
REQUIRED_WINDOWS = ("y", "t_start", "t_end", "height", "com_vx", "solid_fraction", "vx",
                    "stress", "mu_eff", "coordination", "shear_rate", "inertial_number",
                    "slip_bottom", "slip_top")

# The /windows datasets with one value per window.
WINDOW_SCALARS = ("t_start", "t_end", "height", "com_vx", "wall_mu", "slip_bottom", "slip_top",
                  "samples", "slip_bottom_count", "slip_top_count")


def open_regular(path, mode="r", **kwargs):
    """open(path, mode) for reading, refusing anything but a regular file: opening a FIFO
    waits for a writer that may never come (docs/reliability.md). The refusal is an OSError
    naming the path, which every reader here already reports as "cannot read"."""
    st = os.stat(path)
    if not stat.S_ISREG(st.st_mode):
        raise OSError(errno.EINVAL, f"not a regular file ({kind_of(st.st_mode)})",
                      os.fspath(path))
    return open(path, mode, **kwargs)


def unique_keys(pairs):
    """A JSON object as a dict, refusing a key given twice (json keeps the last silently, where
    `cdshear` refuses the file): the object_pairs_hook of every JSON reader of the analysis. The
    refusal is a ValueError, which each reports as "cannot read"."""
    out = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"the key '{key}' is given twice in one object")
        out[key] = value
    return out


def kind_of(mode):
    """A file's kind in words, from its st_mode: a file, a folder, a FIFO, a device or socket."""
    return ("a file" if stat.S_ISREG(mode) else "a folder" if stat.S_ISDIR(mode)
            else "a FIFO" if stat.S_ISFIFO(mode) else "a device or socket")


def what_is(path):
    """What stands at `path` in words (kind_of), or a link that leads nowhere or into a loop
    with the system's reason: for a place where a folder or a file was expected."""
    try:
        return kind_of(os.stat(path).st_mode)
    except OSError as e:
        return f"a link that cannot be followed ({e.strerror})"


def replace_atomically(path, write):
    """Writes `path` whole or not at all: write(tmp) fills a temporary file beside it, which then
    replaces `path` (os.replace); on any failure the temporary goes and `path` is left as it was,
    so a failed command never leaves an earlier result truncated."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp",
                               dir=folder)
    os.close(fd)
    try:
        write(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException as e:
        if os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(e, OSError) and e.filename in (None, tmp):
            raise OSError(e.errno, e.strerror or str(e), path) from e   # the file, not its tmp
        raise


def write_text_atomically(path, text):
    """`text` into `path` through replace_atomically (UTF-8)."""
    def write(tmp):
        with open(tmp, "w", encoding="utf-8", newline="") as f:
            f.write(text)
    replace_atomically(path, write)


def save_figure(fig, path, **savefig_options):
    """fig.savefig into `path` through replace_atomically (PNG)."""
    replace_atomically(path, lambda tmp: fig.savefig(tmp, format="png", **savefig_options))


def run_files_in(folder):
    """The RUN_FOLDER_FILES that `folder` holds: none for a folder that is no run's."""
    return [f for f in RUN_FOLDER_FILES if os.path.lexists(os.path.join(folder, f))]


# What a run's sittings write beside RUN_FOLDER_FILES and run_info.json: the state a stopped or
# failed sitting left (a resume reads it) and the record of each resumed sitting.
RUN_STATE_FILES = ("progress.json", "interrupted_state.json", "blowup_state.json")


def _is_packing(path):
    """True when `path` holds a cdshear packing (a JSON object of format "cdshear-packing"),
    looked for in its first and last 4 KiB: `cdshear prepare` writes its keys in order, the disks
    before "format" and only short values after it."""
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
            f.seek(max(0, os.fstat(f.fileno()).st_size - 4096))
            tail = f.read(4096)
    except OSError:
        return False
    pattern = re.compile(rb'"format"\s*:\s*"cdshear-packing"')
    return pattern.search(head) is not None or pattern.search(tail) is not None


def output_problem(path, inputs=()):
    """Why a command may not write the file `path`, or None. An existing file is replaced, as
    any output is, unless it is one of the command's `inputs` (files or folders it reads), a
    file inside an input folder, a run's own file (RUN_FOLDER_FILES, run_info.json,
    RUN_STATE_FILES or a resumed sitting's run_info_resume_*.json in a folder that run_marks_in
    calls a run's), a TOML file (a case, scene or campaign file: no command here writes one) or
    a cdshear packing: those hold what the command would lose. A folder, a FIFO or a device (the
    rename that puts a new file in place would replace it: /dev/null as root), or a file in a
    folder that does not exist or is no folder, cannot be written."""
    where = os.path.realpath(path)
    if os.path.isdir(path):
        return "is a folder, not a file"
    if os.path.lexists(where) and not os.path.isfile(where):
        return f"is {what_is(where)}, not a file: writing the output would replace it"
    folder = os.path.dirname(where)
    if not os.path.isdir(folder):
        return (f"its folder {folder} is {what_is(folder)}, not a folder"
                if os.path.lexists(folder) else f"its folder {folder} does not exist")
    for source in inputs:
        source = os.path.realpath(source)
        if where == source:
            return "is one of the command's inputs: writing it would replace what it reads"
        if os.path.isdir(source) and where.startswith(source + os.sep) and os.path.exists(where):
            return f"is a file of the input folder {source}: writing it would replace it"
    name = os.path.basename(where)
    if (name in RUN_FOLDER_FILES + ("run_info.json",) + RUN_STATE_FILES
            or RESUMED_INFO.fullmatch(name)) and (marks := run_marks_in(folder)):
        return (f"is a run's own file ({folder} holds {', '.join(marks)}): writing it would "
                f"replace it")
    if os.path.isfile(where) and name.endswith(".toml"):
        return ("is a TOML file (a case, scene or campaign file), which no output here is: "
                "writing it would replace it")
    if os.path.isfile(where) and _is_packing(where):
        return "is a cdshear packing: writing it would replace it"
    return None


RESUMED_INFO = re.compile(r"run_info_resume_[0-9]+(_[0-9]+)?\.json")


def run_info_paths(run_dir):
    """The run's solver and build records that exist, one per sitting: run_info.json (the first;
    absent when that sitting was killed, its figures then lost) and each resumed sitting's
    run_info_resume_<step>[_<k>].json, in the order of the steps they end at."""
    def step_and_k(name):
        return tuple(int(x) for x in re.findall(r"[0-9]+", name))
    try:
        names = sorted((n for n in os.listdir(run_dir) if RESUMED_INFO.fullmatch(n)),
                       key=step_and_k)
    except OSError:
        names = []
    first = os.path.join(run_dir, "run_info.json")
    return ([first] if os.path.lexists(first) else []) + [os.path.join(run_dir, n)
                                                         for n in names]


def run_marks_in(folder):
    """The files that make `folder` a run's: run.h5, or the case.toml that every run writes
    first beside its summary.json or run_info.json (a campaign keeps those three without run.h5,
    and they cannot be made again without the run)."""
    present = [f for f in (RUN_FILE, "case.toml", "summary.json", "run_info.json")
               if os.path.lexists(os.path.join(folder, f))]
    if RUN_FILE in present or ("case.toml" in present and len(present) > 1):
        return present
    return []


USER_BLOCK = 512
SEAL = re.compile(rb"cdshear-run crc32=([0-9a-f]{8}) size=([0-9]+)\n")


def _body_checksum(path):
    """CRC-32 and size of the bytes of `path` after the HDF5 user block."""
    crc, size = 0, 0
    with open(path, "rb") as f:
        f.seek(USER_BLOCK)
        while chunk := f.read(1 << 20):
            crc, size = zlib.crc32(chunk, crc), size + len(chunk)
    return crc, size


def seal(path):
    """Writes the seal of a run.h5 (created with userblock_size=512) into its user block: the
    CRC-32 and size of the rest, as cdshear does (src/io/run_data_file.cpp). A run.h5 is checked
    against it before HDF5 opens it, because the HDF5 library can crash on a damaged file."""
    crc, size = _body_checksum(path)
    with open(path, "r+b") as f:
        f.write(b"cdshear-run crc32=%08x size=%d\n" % (crc, size))


def check_seal(path):
    """Raises RunDataError unless `path` carries a seal that matches its content."""
    with open_regular(path, "rb") as f:
        m = SEAL.match(f.read(96))
    if m is None:
        raise RunDataError(path, "not a cdshear HDF5 run file: no cdshear seal (written by "
                                 "another program, or damaged: empty or truncated?)")
    crc, size = _body_checksum(path)
    if (crc, size) != (int(m.group(1), 16), int(m.group(2))):
        raise RunDataError(path, f"damaged: its content does not match the checksum it was "
                                 f"written with ({size} bytes of {int(m.group(2))}; truncated "
                                 f"or changed?)")


class RunDataError(Exception):
    """A run folder or run.h5 that cannot be analysed: `path` names the file, `problem` says why."""

    def __init__(self, path, problem):
        super().__init__(f"{path}: {problem}")
        self.path, self.problem = str(path), problem


def _scalar(value):
    """A number stored as a one-element array (or 0-d dataset) as a plain number."""
    if isinstance(value, np.ndarray) and value.size == 1 and value.dtype.kind in "biuf":
        return value.reshape(()).item()
    return value


def _plain(value):
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.dtype.kind in "SO":
        return [_plain(v) for v in value.tolist()]
    return value.item() if isinstance(value, np.generic) else value


# /windows/top_stripes: depth (T), then W x T profiles and the W x T x 2 x 2 stress.
TOP_STRIPE_DATASETS = ("depth", "solid_fraction", "vx", "coordination",
                       "force_carrying_coordination", "stress")


def _datasets(f, name, required, path):
    if name not in f or not isinstance(f[name], h5py.Group):
        raise RunDataError(path, f"missing group /{name}")
    group = f[name]
    data = {k: group[k][()] for k in group if isinstance(group[k], h5py.Dataset)}
    missing = [f"/{name}/{k}" for k in required if k not in data]
    if missing:
        raise RunDataError(path, "missing dataset" + ("s " if len(missing) > 1 else " ")
                           + ", ".join(missing))
    return data


def _check_lengths(data, keys, length, what, path, one_value=()):
    """Each of `keys` has `length` rows; those in `one_value` (or all, when True) one value
    per row."""
    for k in keys:
        if k not in data:
            continue
        if np.shape(data[k])[:1] != (length,):
            raise RunDataError(path, f"{what}/{k} has shape {np.shape(data[k])}, "
                                     f"expected first dimension {length}")
        if (one_value is True or k in one_value) and np.ndim(data[k]) != 1:
            raise RunDataError(path, f"{what}/{k} has shape {np.shape(data[k])}, "
                                     f"expected ({length},)")


# Root attributes that must be finite numbers > 0 (n also a whole number), and those that must be
# finite and >= 0: what `cdshear run` writes; anything else is not a run of this model.
POSITIVE_ATTRS = ("n", "length_x", "height", "velocity", "normal_stress", "duration", "window")
NON_NEGATIVE_ATTRS = ("time",)
# The walls' forces: finite at every sample and window (a NaN there is not an empty stripe).
WALL_FORCE_SERIES = ("bottom_fx", "bottom_fy", "top_fx", "top_fy")
WALL_FORCE_WINDOWS = ("bottom_force", "top_force")
# Per-interval counts of the series: whole numbers >= 0 where present.
COUNT_SERIES = ("step", "contacts", "force_carrying", "closed", "capped_steps", "sweeps_max")
# Read when present (older files lack some): each must then be a finite number > 0.
OPTIONAL_POSITIVE_ATTRS = ("inertial_mass", "sample_interval", "dt", "stripe_thickness")


# The case values a summary must share with its run's case.toml: (summary `case` key, TOML table,
# TOML key). The same check as the sweep's (src/app/sweep_command.cpp, summary_problem).
IDENTITY_KEYS = (("n", "system", "n"), ("height", "system", "height"),
                 ("velocity", "shear", "velocity"), ("normal_stress", "shear", "normal_stress"),
                 ("duration", "shear", "duration"),
                 ("initial_velocity", "shear", "initial_velocity"))
# Keys that summaries of an earlier cdshear do not hold: compared only where the summary has them.
IDENTITY_KEYS_RECORDED_LATER = ("initial_velocity",)


def identity_pairs(case_a, case_b):
    """(table, key, a's value, b's value) for the seed and each identity key but the duration of
    two cases as case.toml holds them (dicts of tables); a value is None where its case does not
    give it. What tells two runs apart, whatever their lengths."""
    for table, key in (("system", "seed"),) + tuple((t, k) for _, t, k in IDENTITY_KEYS
                                                    if k != "duration"):
        yield (table, key) + tuple(c[table].get(key) if isinstance(c.get(table), dict) else None
                                   for c in (case_a, case_b))


def folder_case(run_dir):
    """RUN_DIR/case.toml parsed, or None where it is missing or cannot be read."""
    try:
        with open_regular(os.path.join(run_dir, "case.toml"), encoding="utf-8") as f:
            return tomllib.loads(f.read())
    except (OSError, ValueError, RecursionError):
        return None


def end_state(run_dir):
    """(step, state hash) at the end of the run's newest sitting that says so (its run_info
    file, run_info_paths), or None where no record gives both. Runs are deterministic: two
    folders that end in the same state at the same step hold one run, copied, or run twice from
    the same packing and seeds."""
    for path in reversed(run_info_paths(run_dir)):
        try:
            with open_regular(path, encoding="utf-8") as f:
                info = json.load(f)
        except (OSError, ValueError, RecursionError):
            continue
        step = info.get("step") if isinstance(info, dict) else None
        state_hash = info.get("state_hash") if isinstance(info, dict) else None
        if isinstance(step, int) and not isinstance(step, bool) and \
                isinstance(state_hash, str) and state_hash:
            return step, state_hash
    return None


class DistinctRuns:
    """Run folders taken one at a time, each checked against those before it (each folder's
    end_state read once; `end_states`, {folder: end_state} already read, read from there): `add(d)`
    says why d cannot be pooled with them, or None."""

    def __init__(self, end_states=None):
        self._places, self._ends = {}, {}
        self._read = end_states if end_states is not None else {}

    def add(self, d):
        """Why the run folder d repeats one added before, or None (then d is kept): the same
        folder by another path or through a link, or the same run (end_state: a copy, or a run
        repeated with the same packing and seeds), which would count one realization twice."""
        where = os.path.realpath(d)
        if where in self._places:
            return f"{d} is {self._places[where]} again: each run counts once"
        self._places[where] = d
        state = self._read[d] if d in self._read else end_state(d)
        if state in self._ends:
            return (f"{d} holds the run {self._ends[state]} holds (both end at step {state[0]} "
                    f"in state {state[1]}: a copy, or the same packing and seeds run again): "
                    f"each run counts once")
        if state is not None:
            self._ends[state] = d
        return None


def repeated_folder(dirs, end_states=None):
    """Why the run folders `dirs` cannot be pooled as distinct runs, or None (DistinctRuns.add
    of each in turn; `end_states` as DistinctRuns takes it)."""
    runs = DistinctRuns(end_states)
    return next((why for why in map(runs.add, dirs) if why is not None), None)


def distinct_names(dirs):
    """A name for each of the run folders `dirs` that tells it from the others, in their order:
    the folder's own name, or, where another folder has that name too (one run's folder in two
    campaigns), the shortest ending of its path that no other folder's ending of as many parts
    is (`a/runs/s1_seed1_V1` beside `b/runs/s1_seed1_V1`); the whole path where none is."""
    parts = [os.path.abspath(d).split(os.sep) for d in dirs]
    names = []
    for k, mine in enumerate(parts):
        others = [p for j, p in enumerate(parts) if j != k]
        count = 1
        while count < len(mine) and any(p[-count:] == mine[-count:] for p in others):
            count += 1
        names.append(os.sep.join(mine[-count:]))
    return names


def is_number(value):
    """A number (int or float, numpy's included), not a boolean nor a text."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)


# No quantity a run measures comes near this magnitude; a summary value beyond it was edited by
# hand, and its squares would overflow the statistics that pool runs (1e300 ** 2 is infinite).
MEASURED_MAGNITUDE_LIMIT = 1e100


def is_measured_number(value):
    """A number (is_number) that is finite and within MEASURED_MAGNITUDE_LIMIT in magnitude:
    what a summary.json written by `analyze` holds where it holds a number (an integer too large
    for any float, which JSON can hold, is not one)."""
    try:
        return is_number(value) and math.isfinite(value) and abs(value) <= MEASURED_MAGNITUDE_LIMIT
    except OverflowError:
        return False


def _check_physics(attrs, series, windows, n_stripes, path):
    """Refuses data that are not a shear run, naming the attribute or dataset: what `cdshear run`
    cannot write (a V of 0, NaN or text, a negative height, time running backwards, no stripes,
    arrays of the wrong rank, every physical series NaN), so that no regime is ever given to
    them."""
    for k in POSITIVE_ATTRS + NON_NEGATIVE_ATTRS:
        v = attrs[k]
        if not is_number(v) or not np.isfinite(v):
            raise RunDataError(path, f"attribute {k} is {v!r}, not a finite number")
        if k in POSITIVE_ATTRS and not v > 0:
            raise RunDataError(path, f"attribute {k} is {v!r}: it must be > 0")
        if k in NON_NEGATIVE_ATTRS and v < 0:
            raise RunDataError(path, f"attribute {k} is {v!r}: it must be >= 0")
    for k in OPTIONAL_POSITIVE_ATTRS:
        v = attrs.get(k)
        if v is not None and (not is_number(v) or not np.isfinite(v) or not v > 0):
            raise RunDataError(path, f"attribute {k} is {v!r}: it must be a finite number > 0")
    finished = attrs.get("finished", 0)
    if not is_number(finished) or finished not in (0, 1):
        raise RunDataError(path, f"attribute finished is {attrs['finished']!r}: it must be 0 or 1")
    h = attrs.get("boundary_thickness")
    if h is not None:
        h = np.asarray(h)
        if h.dtype.kind not in "iuf" or h.size == 0 or not np.all(np.isfinite(h)) or np.any(h <= 0):
            raise RunDataError(path, f"attribute boundary_thickness is {h!r}: it must list "
                                     "finite thicknesses > 0")
    if float(attrs["n"]) != int(attrs["n"]):
        raise RunDataError(path, f"attribute n is {attrs['n']!r}: a number of disks is whole")
    for k, v in series.items():
        if np.ndim(v) != 1 or np.asarray(v).dtype.kind not in "biuf":
            raise RunDataError(path, f"/series/{k} is not a one-dimensional array of numbers "
                                     f"(shape {np.shape(v)}, type {np.asarray(v).dtype})")
    for k in COUNT_SERIES:
        if k in series:
            c = np.asarray(series[k], dtype=float)
            if not np.all(np.isfinite(c)) or np.any(c < 0):
                raise RunDataError(path, f"/series/{k} holds a value that is not a count "
                                         "(finite, >= 0)")
    t = np.asarray(series["time"], dtype=float)
    if not np.all(np.isfinite(t)):
        raise RunDataError(path, "/series/time holds a value that is not finite")
    if t.size > 1 and np.any(np.diff(t) <= 0):
        k = int(np.argmax(np.diff(t) <= 0)) + 1
        raise RunDataError(path, f"/series/time does not increase at row {k} "
                                 f"({t[k - 1]:g} then {t[k]:g})")
    if "step" in series and not np.all(np.isfinite(np.asarray(series["step"], dtype=float))):
        raise RunDataError(path, "/series/step holds a value that is not finite")
    physical = [k for k in REQUIRED_SERIES if k != "time"]
    if t.size > 0 and all(np.all(np.isnan(np.asarray(series[k], dtype=float))) for k in physical):
        raise RunDataError(path, "every physical series (" + ", ".join(physical) +
                                 ") is NaN: there is nothing to analyse")
    if n_stripes == 0:
        raise RunDataError(path, "/windows/y is empty: the profiles have no stripes")
    for k in ("y", "t_start", "t_end"):
        if np.ndim(windows[k]) != 1:
            raise RunDataError(path, f"/windows/{k} has shape {np.shape(windows[k])}, expected "
                                     "one dimension")
    for k in ("solid_fraction", "vx", "mu_eff", "coordination"):
        if np.ndim(windows[k]) != 2:
            raise RunDataError(path, f"/windows/{k} has shape {np.shape(windows[k])}, expected "
                                     "(windows, stripes)")
    ts, te = (np.asarray(windows[k], dtype=float) for k in ("t_start", "t_end"))
    if ts.size and (not np.all(np.isfinite(ts)) or not np.all(np.isfinite(te))
                    or np.any(te <= ts)):
        raise RunDataError(path, "/windows/t_start and t_end do not make windows of positive "
                                 "length")
    _check_magnitudes(series, "/series", path)
    _check_magnitudes(windows, "/windows", path)
    for data, group, names in ((series, "/series", WALL_FORCE_SERIES),
                               (windows, "/windows", WALL_FORCE_WINDOWS)):
        for k in (k for k in names if k in data and np.size(data[k])):
            nan = np.isnan(np.asarray(data[k], dtype=float)).reshape(len(data[k]), -1)
            if np.any(nan):
                raise RunDataError(path, f"{group}/{k} is NaN at row "
                                         f"{int(np.argmax(nan.any(axis=1)))}: cdshear writes the "
                                         "walls' forces at every sample and window")


def _check_magnitudes(datasets, group, path):
    """Refuses an infinite value, or one beyond MEASURED_MAGNITUDE_LIMIT, in any dataset of numbers
    of `group` (naming the dataset and its first such row): cdshear writes neither (an empty
    stripe's values are NaN), and the estimators that square or sum them would overflow."""
    for k, v in datasets.items():
        a = np.asarray(v)
        if a.dtype.kind != "f" or a.size == 0:
            continue
        bad = np.isinf(a) | (np.abs(np.nan_to_num(a)) > MEASURED_MAGNITUDE_LIMIT)
        if np.any(bad):
            row = int(np.argmax(bad.reshape(len(a), -1).any(axis=1))) if a.ndim else 0
            value = a.reshape(-1)[int(np.argmax(bad.reshape(-1)))]
            raise RunDataError(path, f"{group}/{k} holds {value:g} at row {row}: no measured "
                                     f"quantity comes near {MEASURED_MAGNITUDE_LIMIT:g} in "
                                     "magnitude")


def _check_structure(f, path):
    """Refuses what a damaged file's metadata can claim before anything is read: a name that is
    not text, or a dataset larger than the file could hold (cdshear and the synthetic runs write
    contiguous, uncompressed data, so a dataset's bytes lie inside the file; a compressed one may
    claim up to 1000 times its file)."""
    size = os.path.getsize(path)

    def check(name, obj):
        if not isinstance(name, str):
            raise RunDataError(path, f"an object name {name!r} is not text: damaged metadata")
        if isinstance(obj, h5py.Dataset):
            if obj.dtype.kind not in "biuf":
                raise RunDataError(path, f"/{name} holds values of type {obj.dtype}, not "
                                         "numbers: cdshear writes numbers only")
            claimed = int(np.prod(obj.shape, dtype=object)) * obj.dtype.itemsize if obj.shape \
                else obj.dtype.itemsize
            bound = size * (1000 if obj.compression else 1) + (1 << 20)
            if claimed > bound:
                raise RunDataError(path, f"/{name} claims {claimed} bytes (shape {obj.shape}), "
                                         f"more than a file of {size} bytes holds: damaged "
                                         "metadata")
    f.visititems(check)


def _read(f, run_dir, path):
    _check_structure(f, path)
    attrs = {k: _plain(v) for k, v in f.attrs.items()}
    for k, v in attrs.items():
        if k == "boundary_thickness":    # always an array (one h may be stored as a scalar)
            attrs[k] = np.atleast_1d(np.asarray(v, dtype=float)).ravel()
        else:
            attrs[k] = _scalar(v)
    missing = [k for k in REQUIRED_ATTRS if k not in attrs]
    if missing:
        raise RunDataError(path, "missing root attribute(s) " + ", ".join(missing))
    series = _datasets(f, "series", REQUIRED_SERIES, path)
    _check_lengths(series, series, len(series["time"]), "/series", path, one_value=True)
    windows = _datasets(f, "windows", REQUIRED_WINDOWS, path)
    n_windows = len(windows["t_start"])
    _check_lengths(windows, [k for k in windows if k != "y"], n_windows, "/windows", path,
                   one_value=WINDOW_SCALARS)
    n_stripes = len(windows["y"])
    for k in ("solid_fraction", "vx", "stress", "mu_eff", "coordination"):
        if windows[k].shape[1:2] != (n_stripes,):
            raise RunDataError(path, f"/windows/{k} has shape {windows[k].shape}, "
                                     f"expected ({n_windows}, {n_stripes}, ...)")
    _check_physics(attrs, series, windows, n_stripes, path)
    dt = attrs.get("dt")
    if "step" in series and isinstance(dt, (float, np.floating)) and np.isfinite(dt) and dt > 0:
        # A sample's time as its step x dt, the windows' t_start and t_end: files written before
        # cdshear wrote it so hold the summed time, which drifts from it by about 1e-11 and put
        # a sample on a window's edge into the next window. The two clocks must agree, or dt or
        # the steps are not the run's.
        clock = np.asarray(series["step"], dtype=float) * dt
        summed = np.asarray(series["time"], dtype=float)
        if clock.size and np.max(np.abs(clock - summed)) > 1e-6 * max(1.0, np.max(np.abs(summed))):
            k = int(np.argmax(np.abs(clock - summed)))
            raise RunDataError(path, f"/series/step x attribute dt ({dt:g}) gives {clock[k]:g} at "
                                     f"row {k}, where /series/time holds {summed[k]:g}: dt or "
                                     "/series/step is not the run's")
        series["time"] = clock
        step = attrs.get("step")
        if isinstance(step, (int, np.integer, float, np.floating)) and np.isfinite(step):
            attrs["time"] = float(step) * dt   # how far the file goes, on the same clock
    regions = {}
    if "regions" in f["windows"]:
        for label, group in f["windows/regions"].items():
            data = {k: group[k][()] for k in group if isinstance(group[k], h5py.Dataset)}
            _check_lengths(data, data, n_windows, f"/windows/regions/{label}", path,
                           one_value=True)
            h = group.attrs.get("h", label.lstrip("h"))
            try:
                data["h"] = float(_plain(h) if isinstance(h, (bytes, np.ndarray)) else h)
            except (TypeError, ValueError):
                raise RunDataError(path, f"/windows/regions/{label}: attribute h "
                                         f"({h!r}) is not a number")
            if not (np.isfinite(data["h"]) and data["h"] > 0):
                raise RunDataError(path, f"/windows/regions/{label}: attribute h = "
                                         f"{data['h']:g}: a layer's thickness must be > 0")
            _check_magnitudes(data, f"/windows/regions/{label}", path)
            regions[label] = data
    regions = dict(sorted(regions.items(), key=lambda item: item[1]["h"]))
    top_stripes = None
    if "top_stripes" in f["windows"] and isinstance(f["windows/top_stripes"], h5py.Group):
        group = f["windows/top_stripes"]
        top_stripes = {k: group[k][()] for k in group if isinstance(group[k], h5py.Dataset)}
        missing = [k for k in TOP_STRIPE_DATASETS if k not in top_stripes]
        if missing:
            raise RunDataError(path, "missing dataset(s) "
                               + ", ".join(f"/windows/top_stripes/{k}" for k in missing))
        _check_lengths(top_stripes, [k for k in top_stripes if k != "depth"], n_windows,
                       "/windows/top_stripes", path)
        _check_magnitudes(top_stripes, "/windows/top_stripes", path)
        for k in TOP_STRIPE_DATASETS[1:]:
            if top_stripes[k].shape[1:2] != (len(top_stripes["depth"]),):
                raise RunDataError(path, f"/windows/top_stripes/{k} has shape "
                                         f"{top_stripes[k].shape}, expected ({n_windows}, "
                                         f"{len(top_stripes['depth'])}, ...)")
    version = attrs.get("format_version", 1)
    if not isinstance(version, (int, float, np.integer, np.floating)) or not np.isfinite(version):
        raise RunDataError(path, f"format_version {version!r} is not a number")
    if version > FORMAT_VERSION:
        raise RunDataError(path, f"format version {version:g} is newer than this analysis "
                                 f"reads ({FORMAT_VERSION}): update cdshear")
    if version < 2:
        _as_version_2(windows, regions, attrs)
    if version == 2:
        _as_version_3(windows, regions, attrs)
    if version < 4:
        attrs["legacy_note"] = " ".join(filter(None, (attrs.get("legacy_note"), (
            f"format version {version:g}: the top boundary layer's stripes were counted from "
            "the bottom wall (its nu and Z less exact than the bottom layer's)"))))
    _check_window_fields(windows, n_windows, n_stripes, path)
    snapshot = None
    if "snapshot" in f:
        if not isinstance(f["snapshot"], h5py.Group):
            raise RunDataError(path, "/snapshot is not a group (the snapshot's datasets and "
                                     "attributes): the file was changed after the run wrote it")
        snapshot = {k: v[()] for k, v in f["snapshot"].items() if isinstance(v, h5py.Dataset)}
        snapshot.update({k: _plain(v) for k, v in f["snapshot"].attrs.items()})
        for k in ("time", "length_x", "height"):   # attributes, or datasets in older files
            if k in snapshot:
                snapshot[k] = _scalar(np.asarray(snapshot[k]))
    if snapshot is not None:
        _check_snapshot(snapshot, path)
    case = {}
    # run.h5's own copy first; the folder's case.toml is read only where that gives none, and one
    # that cannot be decoded (not UTF-8, not TOML, nested too deeply) gives none either.
    for source, text in (("its case_toml", lambda: attrs.get("case_toml")),
                         ("case.toml", lambda: _read_text(os.path.join(run_dir, "case.toml")))):
        try:
            value = text()
            case = tomllib.loads(value) if isinstance(value, str) else {}
        except (ValueError, RecursionError):   # UnicodeDecodeError and TOMLDecodeError included
            case = {}
        if case:
            _check_case_agrees(attrs, case, source, path)
            break
    return dict(run_dir=run_dir, path=path, attrs=attrs, case=case, series=series,
                windows=windows, regions=regions, top_stripes=top_stripes,
                snapshot=snapshot)


# Root attributes that restate a key of the run's case: (attribute, TOML table, TOML key), from
# IDENTITY_KEYS, whose summary keys are these attributes' names.
CASE_ATTRS = tuple(k for k in IDENTITY_KEYS if k[0] in ("velocity", "normal_stress"))


def _check_case_agrees(attrs, case, source, path):
    """Refuses a run.h5 whose wall velocity or pressure is not its case's (`cdshear run` writes
    both from one value): the file was changed after the run wrote it."""
    for attr, table, key in CASE_ATTRS:
        values = case.get(table)
        value = values.get(key) if isinstance(values, dict) else None
        if is_number(value) and not math.isclose(value, attrs[attr], rel_tol=1e-9):
            raise RunDataError(path, f"attribute {attr} is {attrs[attr]!r}, but {source} has "
                                     f"{table}.{key} = {value!r}: one was changed after the run")


# The /windows profiles the analysis reads (after the version conversions), by their shape
# beyond (windows, stripes): every profile, and the stress and its parts as 2 x 2 tensors.
WINDOW_PROFILES = ("solid_fraction", "vx", "mu_eff", "coordination", "force_carrying_coordination",
                   "inertial_number", "shear_rate")
WINDOW_TENSORS = ("stress", "contact_stress", "kinetic_stress", "rotational_stress")
WINDOW_WALL_FORCES = ("bottom_force", "top_force")
SNAPSHOT_DISKS = ("x", "y", "radius", "vx")
SNAPSHOT_CONTACTS = ("contact_ax", "contact_ay", "contact_bx", "contact_by",
                     "contact_normal_force")


def _check_window_fields(windows, n_windows, n_stripes, path):
    """Refuses a profile the analysis reads that is missing or of another shape, a tensor that is
    not 2 x 2 per stripe, and the walls' forces where they are not one (x, y) pair per window."""
    missing = [k for k in WINDOW_PROFILES if k not in windows]
    if missing:
        raise RunDataError(path, "missing dataset(s) "
                           + ", ".join(f"/windows/{k}" for k in missing))
    for keys, tail in ((WINDOW_PROFILES, ()), (WINDOW_TENSORS, (2, 2))):
        for k in keys:
            if k in windows and np.shape(windows[k]) != (n_windows, n_stripes) + tail:
                raise RunDataError(path, f"/windows/{k} has shape {np.shape(windows[k])}, "
                                         f"expected {(n_windows, n_stripes) + tail}")
    for k in WINDOW_WALL_FORCES:
        if k in windows and np.shape(windows[k]) != (n_windows, 2):
            raise RunDataError(path, f"/windows/{k} has shape {np.shape(windows[k])}, "
                                     f"expected {(n_windows, 2)}")


def _check_snapshot(snapshot, path):
    """A snapshot's disks (and its contacts, where it has any) as one-dimensional lists of one
    length each, its L_x and height (where given; else the run's) finite numbers > 0 and its
    time one >= 0 (a run with no sample yet has its snapshot at 0): what snapshot.png draws (its
    width in inches is scaled by 1 / L_x)."""
    for k in ("time", "length_x", "height"):
        v = snapshot.get(k)
        if v is not None and not (is_measured_number(v) and (v > 0 or k == "time" and v == 0)):
            if isinstance(v, np.ndarray):   # one value of text, or several
                shown = repr(_plain(v.item())) if v.size == 1 else f"an array of shape {v.shape}"
            else:
                shown = repr(v)
            raise RunDataError(path, f"/snapshot {k} is {shown}: it must be a finite number "
                                     f"{'>= 0' if k == 'time' else '> 0'}")
    for names in (SNAPSHOT_DISKS, SNAPSHOT_CONTACTS):
        present = [k for k in names if k in snapshot]
        if names is SNAPSHOT_CONTACTS and not present:
            continue
        missing = [k for k in names if k not in snapshot]
        if missing:
            raise RunDataError(path, "missing dataset(s) "
                               + ", ".join(f"/snapshot/{k}" for k in missing))
        lengths = {k: np.shape(snapshot[k]) for k in names}
        if any(len(shape) != 1 for shape in lengths.values()) or \
                len(set(lengths.values())) != 1:
            raise RunDataError(path, "/snapshot/" + ", ".join(names) + " must be lists of one "
                               "length: shapes " + ", ".join(f"{k} {v}"
                                                             for k, v in lengths.items()))


def _as_version_2(windows, regions, attrs):
    """A version-1 file's windows and regions in version 2's names (see the module doc)."""
    def move(data, key, new_key):
        if key in data and new_key not in data:
            data[new_key] = data[key]
            data[key] = np.full(np.shape(data[key]), np.nan)
    move(windows, "coordination", "force_carrying_coordination")
    for data in regions.values():
        for part in ("bulk", "bottom", "top"):
            move(data, f"{part}_coordination", f"{part}_force_carrying_coordination")
    attrs["legacy_note"] = ("format version 1: Z (closed contacts) was not measured; the "
                            "per-step count of force-carrying contacts is "
                            "force_carrying_coordination; the stress lacks the rotational part")


def _as_version_3(windows, regions, attrs):
    """A version-2 file's stress without the rotational flux, and the mu_eff that follow (the
    regions' stripes as that version assigned them: profiles.former_regions)."""
    if "rotational_stress" not in windows:
        return
    stress = np.asarray(windows["stress"], dtype=float) - np.asarray(
        windows["rotational_stress"], dtype=float)
    windows["stress"] = stress
    with np.errstate(invalid="ignore", divide="ignore"):
        windows["mu_eff"] = np.where(stress[..., 1, 1] > 0,
                                     np.abs(stress[..., 0, 1]) / stress[..., 1, 1], np.nan)
    vx = np.asarray(windows["vx"], dtype=float)
    for data in regions.values():
        for w, height in enumerate(np.asarray(windows["height"], dtype=float)):
            parts, _ = former_regions(windows["y"], height, data["h"], np.isfinite(vx[w]))
            for part, sel in parts.items():
                key = f"{part}_mu_eff"
                if key not in data:
                    continue
                syy, sxy = stress[w, sel, 1, 1].sum(), stress[w, sel, 0, 1].sum()
                data[key] = np.array(data[key], dtype=float)
                data[key][w] = abs(sxy) / syy if sel.any() and syy > 0 else np.nan
    attrs["legacy_note"] = ("format version 2: its stress included the rotational flux, taken "
                            "out again on reading (mu_eff recomputed)")


def _read_text(path):
    try:
        with open_regular(path, encoding="utf-8") as f:
            return f.read()
    except OSError:
        return None


def read_time_limit_seconds(path):
    """How long reading `path` may take in a `cdshear_analysis` command: CDSHEAR_READ_TIME_LIMIT
    seconds if set, else 60 s plus 0.5 s per MB (2 MB/s, far below any disk). A damaged file can
    make the HDF5 library loop without end inside C code, where no Python handler runs."""
    given = os.environ.get("CDSHEAR_READ_TIME_LIMIT")
    if given:
        try:
            return max(1, int(float(given)))
        except ValueError:
            pass
    return int(60 + 0.5 * os.path.getsize(path) / 1e6)


# Set by the command line (__main__): only a process of its own may be ended by the alarm.
LIMIT_READ_TIME = False


@contextlib.contextmanager
def _read_time_limit(path):
    """In a command-line process, ends the process by SIGALRM (its default action) when reading
    takes longer than read_time_limit_seconds: `cdshear analyze` then names the file and the
    signal (exit 2) instead of waiting for ever. Elsewhere (a notebook, a test) it does nothing."""
    use = LIMIT_READ_TIME and hasattr(signal, "alarm") and \
        threading.current_thread() is threading.main_thread()
    if use:
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.alarm(read_time_limit_seconds(path))
    try:
        yield
    finally:
        if use:
            signal.alarm(0)


def missing_run_file(run_dir):
    """Why RUN_DIR, a folder without RUN_FILE, cannot be read, in words: a run that measured
    nothing, a run folder whose RUN_FILE was not kept (a clone keeps summaries), or no run."""
    case = os.path.join(run_dir, "case.toml")
    try:   # _read_text: None for no file (or a FIFO); ValueError: TOML or UTF-8 decoding
        measured = tomllib.loads(_read_text(case) or "").get("measure", {}).get("enabled", True)
    except (ValueError, AttributeError, RecursionError):
        measured = True
    if measured is False:
        return (f"a run with measure.enabled = false: it wrote no {RUN_FILE}, so there is "
                "nothing to analyse")
    if os.path.isfile(os.path.join(run_dir, "summary.json")):
        return (f"a finished run without its {RUN_FILE} (git does not keep it: a clone holds "
                "finished runs as their summary.json)")
    if os.path.isfile(case):
        return (f"a run folder without {RUN_FILE}: the run stopped before its first checkpoint "
                "(or the file was removed)")
    return f"not a run folder (no {RUN_FILE})"


def load_run(run_dir):
    """Read RUN_DIR/run.h5 into a dict of numpy arrays and metadata (see the module doc)."""
    run_dir = os.fspath(run_dir)
    if not os.path.isdir(run_dir):
        raise RunDataError(run_dir, "no such folder" if not os.path.exists(run_dir)
                           else "not a folder (expected a run folder holding run.h5)")
    path = os.path.join(run_dir, RUN_FILE)
    if not os.path.isfile(path):
        if os.path.lexists(path):   # there, but no file: a folder, a FIFO, a link to nowhere
            try:
                problem = f"not a regular file ({kind_of(os.stat(path).st_mode)})"
            except OSError as e:
                problem = f"cannot be read: {e.strerror}"
            raise RunDataError(path, problem)
        raise RunDataError(run_dir, missing_run_file(run_dir))
    if os.path.getsize(path) == 0:
        raise RunDataError(path, "empty file")
    check_seal(path)
    try:
        with _read_time_limit(path), h5py.File(path, "r") as f:
            return _read(f, run_dir, path)
    except RunDataError:
        raise
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as e:
        detail = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise RunDataError(path, f"not a readable HDF5 run file (truncated or corrupt?): {detail}")


def truncate_run(run, time):
    """The loaded run as it stood at `time` [t]: the /series samples with time <= `time`, the
    windows (and their regions) with t_end <= `time`, attrs time and step at the last sample kept
    and finished 0 when samples were dropped. The snapshot is left as it is (the run's last).
    Analysing the result gives the averages a run stopped at `time` would give."""
    if not (is_number(time) and np.isfinite(time) and time > 0):
        raise ValueError(f"truncation time must be a number > 0, got {time!r}")
    series_time = np.asarray(run["series"]["time"], dtype=float)
    keep = series_time <= time * (1 + 1e-12)
    if keep.all():
        return run
    eps = 1e-9 * max(float(run["attrs"]["window"]), 1.0)
    keep_w = np.asarray(run["windows"]["t_end"], dtype=float) <= time + eps
    n_windows = len(keep_w)
    windows = {k: (v if k == "y" or np.ndim(v) == 0 or len(v) != n_windows else v[keep_w])
               for k, v in run["windows"].items()}
    regions = {label: {k: (v if k == "h" else v[keep_w]) for k, v in region.items()}
               for label, region in run["regions"].items()}
    top_stripes = run.get("top_stripes")
    if top_stripes is not None:
        top_stripes = {k: (v if k == "depth" else v[keep_w]) for k, v in top_stripes.items()}
    series = {k: v[keep] for k, v in run["series"].items()}
    attrs = dict(run["attrs"])
    attrs["finished"] = 0
    if keep.any():
        attrs["time"] = float(series_time[keep][-1])
        if "step" in series and len(series["step"]):
            attrs["step"] = int(series["step"][-1])
    else:
        attrs["time"] = float(time)
    return dict(run, attrs=attrs, series=series, windows=windows, regions=regions,
                top_stripes=top_stripes)

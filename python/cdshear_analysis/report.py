"""The report of a campaign (`cdshear sweep` folder): `python3 -m cdshear_analysis report DIR`.

`collect(campaign_dir)` reads DIR/campaign.toml (the campaign's name and its list of runs) and every
DIR/runs/*/summary.json (written by `cdshear analyze`). A run folder without summary.json is listed
as "not analysed", a run of campaign.toml without a folder as "not started"; both are left out. Only
summaries of this code's format and version (summary.SUMMARY_FORMAT, summary.SUMMARY_VERSION) are
pooled (`summary_state`): a stale one (an older version, no format or version, `{}`, not a JSON
object) is re-analysed from the run's run.h5 as `analyze` does (`reanalyse`, which rewrites
summary.json) or, without run.h5, left out; a summary of another format or of a newer version is
left out. Every run re-analysed or left out is listed with its reason. `fit_laws(rows)` fits the
bulk laws of docs/model.md section 8 over the steady runs in regime A of every system (fitting.py;
the seeds of one (system, V) are one point), `fit_laws_per_system(rows)` the same laws over each
system alone; `write_report(report, out_dir)` writes runs.csv, runs.md, fits.json, figures/*.png
(campaign_figures.py) and index.html, with the boundary-layer laws of boundary_laws.py and the
transition velocities and model.md section 8 predictions of transitions.py (docs/reports.md
documents every column and key), and adds to report["notes"] the lines that `cdshear
report` prints after the paths (`printed_lines`: the runs re-analysed, every bulk law's status and
every boundary or per-system law that is poor or undetermined).
"""
import csv
import html
import io
import json
import math
import os
import re
import shutil
import textwrap
import time
import tomllib

from . import fitting
from . import summary as summary_module
from .boundary_laws import fit_boundary
from .boundary_laws import h_label as _h_label
from .campaign_figures import write_figures
from .fitting import finite as _finite
from .rundata import is_measured_number
from .rundata import is_number as _is_number
from .rundata import IDENTITY_KEYS, IDENTITY_KEYS_RECORDED_LATER, identity_pairs
from .rundata import (RUN_FILE, open_regular, replace_atomically, run_files_in, run_info_paths,
                      unique_keys)
from .rundata import end_state, folder_case, what_is, write_text_atomically
from .study import averaged_time, counted
from .transitions import find_transitions, predictions

REPORT_FORMAT = "cdshear-report-fits"
REPORT_VERSION = 3
RUN_NAME = re.compile(r"^s(\d+)_seed(\d+)_V(.+)$")  # campaign_run_name() in campaign_file.cpp
# n, L_y [d] and sigma_yy of each system of model.md section 6, as `cdshear run --system K` sets
# them (apply_system_preset in src/shear/shear_case.cpp; test_report_stale compares the two).
SYSTEM_PRESETS = {1: (511, 20.0, 0.25), 2: (1023, 40.0, 0.25), 3: (1023, 40.0, 0.0625),
                  4: (3199, 50.0, 0.25), 5: (2047, 80.0, 0.25), 6: (3071, 120.0, 0.25),
                  7: (5119, 200.0, 0.25)}
SYSTEM_KEYS = (("system", "n"), ("system", "height"), ("shear", "normal_stress"))
LINEAR_RANGE = (0.03, 0.2)  # model.md section 8: linear fits of mu_eff and nu on 0.03 < I < 0.2


class ReportError(Exception):
    def __init__(self, path, problem):
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem


class FigureError(Exception):
    """A run's figure not redrawn (reanalyse): the file and why, its summary.json written."""
    def __init__(self, path, problem):
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem


# ---------------------------------------------------------------------------------------------
# Reading the runs

def _number(x):
    """float(x) for a finite number within rundata.MEASURED_MAGNITUDE_LIMIT (not a text, not
    true or false), else None."""
    return float(x) if is_measured_number(x) else None


def _text(x):
    """x if it is a text, else None (a damaged summary's number or list is no regime)."""
    return x if isinstance(x, str) else None


def _entry(summary, *keys):
    """summary[k0][k1]..., or None where a key is missing or a level is not an object."""
    entry = summary
    for k in keys:
        if not isinstance(entry, dict) or k not in entry:
            return None
        entry = entry[k]
    return entry


def _pair(summary, *keys):
    """(mean, err) of a {"mean", "err"} entry at summary[k0][k1]...; None for what is missing,
    null, not a finite number, or (err) negative."""
    entry = _entry(summary, *keys)
    if not isinstance(entry, dict):
        return None, None
    return _number(entry.get("mean")), _non_negative(entry.get("err"))


def _non_negative(x):
    """float(x) for a finite number >= 0 (an error, a standard deviation), else None."""
    x = _number(x)
    return x if x is not None and x >= 0 else None


# (column, path in summary.json) of every quantity with an error column
BULK_QUANTITIES = [
    ("L_y", ("height",)),
    ("I_bulk", ("bulk", "inertial_number")),
    ("mu_eff_wall", ("mu_eff_wall",)),
    ("mu_eff_wall_bottom", ("mu_eff_wall_bottom",)),
    ("mu_eff_wall_top", ("mu_eff_wall_top",)),
    ("mu_eff_bulk", ("bulk", "mu_eff")),
    ("nu_bulk", ("bulk", "solid_fraction")),
    ("Z_bulk", ("bulk", "coordination")),
    ("Z_force_carrying_bulk", ("bulk", "force_carrying_coordination")),
    ("shear_rate_bulk", ("bulk", "shear_rate")),
    ("slip_bottom", ("slip", "bottom")),
    ("slip_top", ("slip", "top")),
    ("com_vx", ("com_vx",)),
    ("switch_duration", ("switch_duration",)),
    ("switch_time", ("switch_time",)),
    ("switch_delta_mu", ("switch_delta_mu",)),
]
# (column, path in summary.json) of the standard deviations, without an error column
SCATTER_QUANTITIES = [
    ("com_vx_std", ("com_vx", "std")),   # the centre of mass's x-velocity: its scatter [d/t]
]
# (column suffix, key in summary["regions"][hK][part]) of each part of a region group: the
# boundary layers ("bottom", "top") and the bulk between them ("bulk", for the influence of h)
LAYER_QUANTITIES = [("I", "inertial_number"), ("mu_eff", "mu_eff"), ("nu", "solid_fraction"),
                    ("Z", "coordination"), ("velocity_jump", "velocity_jump")]
# "sheared_layer", "resting_layer": regime C's layer that carries the band and the other one,
# window by window (summary.py)
REGION_PARTS = {"bulk": LAYER_QUANTITIES[:4], "bottom": LAYER_QUANTITIES,
                "top": LAYER_QUANTITIES, "sheared_layer": LAYER_QUANTITIES,
                "resting_layer": LAYER_QUANTITIES}
HEAD_COLUMNS = ["run", "system", "seed", "V", "n", "duration", "time_reached", "finished",
                "steady", "steady_reason", "regime", "regime_confidence", "transient_end_time",
                "transient_end_strain", "band_switches", "bulk_h", "bulk_h_reference",
                "bulk_h_note"]


def _profiles(profiles):
    """{"y", "vx", "mu_eff"} lists of the steady profiles (summary.json `profiles`), or None."""
    try:
        out = {"y": [float(v) for v in profiles["y"]]}
        for k in ("vx", "mu_eff"):
            out[k] = [float(v) if v is not None else math.nan for v in profiles[k]["mean"]]
    except (KeyError, TypeError, ValueError, OverflowError):   # 10**400: no float
        return None
    return out if len(out["y"]) == len(out["vx"]) == len(out["mu_eff"]) > 0 else None


def read_json(path):
    """The parsed JSON file at path (any JSON value; a FIFO or device refused, not waited on);
    ReportError when it cannot be read or parsed."""
    try:
        with open_regular(path, encoding="utf-8") as f:
            return json.load(f, object_pairs_hook=unique_keys)
    except FileNotFoundError:
        raise ReportError(path, "missing") from None
    except OSError as e:   # the reason alone: the message names the path already
        raise ReportError(path, f"cannot read: {e.strerror or e}") from None
    except ValueError as e:
        raise ReportError(path, f"cannot read: {e}") from None
    except RecursionError:
        raise ReportError(path, "cannot read: its JSON is nested too deeply") from None


def read_summary(run_dir):
    """The parsed RUN_DIR/summary.json (any JSON value); ReportError when it cannot be read or
    parsed, saying to analyse the run where it is missing."""
    try:
        return read_json(os.path.join(run_dir, "summary.json"))
    except ReportError as e:
        if e.problem == "missing":
            raise ReportError(e.path, f"missing: the run is not analysed (`cdshear analyze "
                                      f"{run_dir}`)") from None
        raise


def summary_state(s):
    """None when the parsed summary.json s is of this code's format and version
    (summary.SUMMARY_FORMAT, summary.SUMMARY_VERSION), else (kind, reason): kind "stale" (not a
    JSON object, `{}`, no format or version, a version that is no integer or older than this
    code's: re-analyse it), "other format" or "newer" (leave it out)."""
    fmt, version = summary_module.SUMMARY_FORMAT, summary_module.SUMMARY_VERSION
    if not isinstance(s, dict):
        return "stale", f"summary.json is not a JSON object but {type(s).__name__}"
    if not s:
        return "stale", "summary.json is empty ({})"
    missing = [k for k in ("format", "version") if k not in s]
    if missing:
        return "stale", f"summary.json has no {' and no '.join(missing)} key (this code reads " \
                        f"{fmt} version {version})"
    if not isinstance(s["format"], str):
        return "stale", f"summary.json format {s['format']!r} is not a text (this code reads " \
                        f"{fmt} version {version})"
    if s["format"] != fmt:
        return "other format", f"summary.json is of format {s['format']!r}, not {fmt!r}"
    v = s["version"]
    if isinstance(v, bool) or not isinstance(v, int):
        return "stale", f"summary.json version {v!r} is not an integer (this code reads " \
                        f"version {version})"
    if v < version:
        return "stale", f"summary.json version {v} is older than this code's {version}"
    if v > version:
        return "newer", (f"summary.json version {v} is newer than this code's {version}: "
                         "report it with the cdshear_analysis that wrote it, or newer")
    return None


def case_problem(s):
    """None when the `case` of a current summary.json s holds what a report is drawn from (a
    positive, finite wall speed); else what is wrong, for a summary edited or damaged by hand."""
    case = s.get("case")
    if not isinstance(case, dict):
        return "has no `case` object"
    v = case.get("velocity")
    if not (_number(v) or 0) > 0:   # _number: None for what is no finite number
        return f"case.velocity {v!r} is not a positive number"
    return None


def _is_utf8(name):
    """Whether a name from os.listdir is UTF-8 text (Python keeps other bytes as surrogates)."""
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _shown_name(name):
    """A name from os.listdir as printable text: bytes that are not UTF-8 as \\xNN."""
    return name.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def system_values(campaign_set):
    """{system: {(table, key): value}}: the n, L_y and sigma_yy (SYSTEM_KEYS) that a campaign
    whose [set] table is `campaign_set` (a dict; {} for none) gives the runs of each system:
    the preset's, or [set]'s where it overrides one (as the sweep passes [set] on after
    --system)."""
    out = {}
    for system, preset in SYSTEM_PRESETS.items():
        values = dict(zip(SYSTEM_KEYS, preset))
        for table, key in SYSTEM_KEYS:
            given = campaign_set.get(table) if isinstance(campaign_set, dict) else None
            if isinstance(given, dict) and key in given:
                values[(table, key)] = given[key]
        out[system] = values
    return out


def _name_problem(run_dir, systems=None):
    """Why a run folder's name (s<system>_seed<seed>_V<V>, which the report reads the system and
    seed from) is not its run's, from its case.toml's seed, wall speed and, with `systems`
    (system_values of the campaign), its n, L_y and sigma_yy; or None (also where the name is
    not of that form or case.toml gives none of them)."""
    m = RUN_NAME.match(os.path.basename(os.path.normpath(run_dir)))
    case = folder_case(run_dir)
    if m is None or case is None:
        return None
    named_system = int(m.group(1))
    for (table, key), want in (systems or {}).get(named_system, {}).items():
        held = case[table].get(key) if isinstance(case.get(table), dict) else None
        if _is_number(held) and _is_number(want) and not math.isclose(held, want, rel_tol=1e-9):
            return (f"its name says system {named_system}, whose runs have {table}.{key} = "
                    f"{want!r} in this campaign, its case.toml {held!r}: a run of another "
                    f"system, renamed or copied in by hand")
    seed = case["system"].get("seed") if isinstance(case.get("system"), dict) else None
    velocity = case["shear"].get("velocity") if isinstance(case.get("shear"), dict) else None
    try:
        named_v = float(m.group(3))
    except ValueError:
        named_v = None
    if isinstance(seed, int) and seed != int(m.group(2)):
        return (f"its name says seed {m.group(2)}, its case.toml seed {seed}: a folder renamed "
                f"or copied in by hand")
    if _is_number(velocity) and named_v is not None and \
            not math.isclose(velocity, named_v, rel_tol=1e-9):
        return (f"its name says V = {m.group(3)}, its case.toml {velocity!r}: a folder renamed "
                f"or copied in by hand")
    return None


def identity_problem(run_dir, s):
    """None when the summary s belongs to RUN_DIR: the folder it names (`run_dir`) has this
    folder's name, and its case agrees with RUN_DIR/case.toml where there is one; else why not,
    for a summary.json copied from another run."""
    return _identity(run_dir, s)[0]


def _identity(run_dir, s):
    """(identity_problem's answer, extended): `extended` is True where the summary is the run's
    own from before its case.toml asked for a longer duration, the answer then saying how to
    run it on."""
    name = os.path.basename(os.path.normpath(run_dir))
    written_in = s.get("run_dir")
    # a run analysed from inside its folder recorded "." (or ".."): a name that says nothing,
    # so judged by its case alone, as one recording no run_dir
    written_name = os.path.basename(os.path.normpath(written_in)) \
        if isinstance(written_in, str) else None
    if written_name not in (None, "", ".", "..") and written_name != name:
        return f"summary.json is of another run (run_dir {written_in!r})", False
    if (case_toml := folder_case(run_dir)) is None:
        return None, False   # no case.toml to compare with (a summary kept alone, or damaged)
    case = s.get("case", {})
    for key, table, toml_key in IDENTITY_KEYS:
        values = case_toml.get(table)
        want = values.get(toml_key) if isinstance(values, dict) else None
        if key in IDENTITY_KEYS_RECORDED_LATER and key not in case:
            continue
        if want is not None and case.get(key) != want:
            had = case.get(key)
            if key == "duration" and _is_number(had) and _is_number(want) and had < want:
                # case.toml asks for a longer run than the one analysed: the run's own, extended
                return (f"summary.json is of the run before its case.toml asked for duration = "
                        f"{want!r} (the summary's {had!r}): `cdshear run --resume {run_dir}` runs "
                        f"it on to that end and analyses it"), True
            return f"summary.json is of another run ({key} = {had!r}, its case.toml " \
                   f"says {want!r})", False
    return None, False


def run_file_identity_problem(run, run_dir):
    """None when the loaded run.h5 (rundata.load_run) belongs to RUN_DIR: the case it holds
    (its case_toml) has the seed and the identity of RUN_DIR/case.toml where both give them;
    else why not, for a run.h5 copied from another run's folder (the summary's own check,
    identity_problem, cannot see it where run.h5 is analysed afresh)."""
    if (in_folder := folder_case(run_dir)) is None:
        return None
    for table, key, mine, theirs in identity_pairs(in_folder, run.get("case") or {}):
        if mine is not None and theirs is not None and mine != theirs:
            return f"{RUN_FILE} is of another run ({table}.{key} = {theirs!r}, the folder's " \
                   f"case.toml says {mine!r})"
    return None


def reanalyse(run_dir):
    """Analyse RUN_DIR/run.h5 again and rewrite RUN_DIR/summary.json, as `cdshear analyze`
    does (rundata.load_run, summary.analyze, summary.write_summary), and redraw the run's
    figures when it has some (RUN_DIR/figures, as `cdshear plot`), so that the report never
    copies figures of the old analysis; returns the summary written. Raises
    rundata.RunDataError, OSError (summary.json not written) or FigureError (summary.json
    written, a figure not)."""
    from .rundata import load_run
    run = load_run(run_dir)
    summary = summary_module.analyze(run)
    summary_module.write_summary(summary, run_dir)
    figures = os.path.join(run_dir, "figures")
    if os.path.isdir(figures):
        from .plots import plot_run
        try:
            plot_run(run, summary, figures, [])
        except OSError as e:
            raise FigureError(e.filename or figures, e.strerror or str(e)) from e
    return read_summary(run_dir)


def read_run(run_dir, s=None):
    """One row of runs.csv from RUN_DIR/summary.json (or its parsed content s): plain values,
    `X` and `X_err` pairs, and per boundary thickness h the layer quantities `hK_bottom_I`, ...
    (None where missing)."""
    path = os.path.join(run_dir, "summary.json")
    if s is None:
        s = read_summary(run_dir)
    if not isinstance(s, dict):
        raise ReportError(path, "not a JSON object")
    name = os.path.basename(os.path.normpath(run_dir))
    m = RUN_NAME.match(name)
    case = s.get("case") if isinstance(s.get("case"), dict) else {}
    switches = s.get("switches")
    row = {
        "run": name,
        "system": int(m.group(1)) if m else None,
        "seed": int(m.group(2)) if m else None,
        "V": _finite(case.get("velocity")) if case.get("velocity") is not None
        else (_finite(m.group(3)) if m else None),
        "n": case.get("n"),
        "duration": _finite(case.get("duration")),
        "time_reached": _finite(case.get("time")),
        "finished": case.get("finished"),
        "steady": bool(s["steady"]) if isinstance(s.get("steady"), bool) else None,
        "steady_reason": _text(s.get("steady_reason")),
        "regime": _text(s.get("regime")),
        "regime_confidence": _finite(s.get("regime_confidence")),
        "transient_end_time": _finite(s.get("transient_end_time")),
        "transient_end_strain": _finite(s.get("transient_end_strain")),
        "band_switches": len(switches) if isinstance(switches, list) else None,
    }
    bulk = s.get("bulk") if isinstance(s.get("bulk"), dict) else {}
    row["bulk_h"] = _finite(bulk.get("h"))
    row["bulk_h_reference"] = (bulk["h_reference"] if isinstance(bulk.get("h_reference"), bool)
                               else None)
    row["bulk_h_note"] = bulk.get("h_note") if isinstance(bulk.get("h_note"), str) else None
    for col, keys in BULK_QUANTITIES:
        row[col], row[col + "_err"] = _pair(s, *keys)
    for col, keys in SCATTER_QUANTITIES:
        row[col] = _non_negative(_entry(s, *keys))
    # for transitions.predictions (not in runs.csv): sigma_yy and the switches
    row["_sigma_yy"] = _finite(case.get("normal_stress"))
    # the rest of the case that two campaigns' namesakes must share (campaign.compare_campaigns)
    row["_height"] = _finite(case.get("height"))
    row["_initial_velocity"] = _text(case.get("initial_velocity"))
    # the time the run's averages cover, its weight among the seeds of one point of a fit
    # (fitting.combine; NaN when the summary does not say where the averaging starts)
    row["_averaged_time"] = averaged_time(s)
    row["_switches"] = switches if isinstance(switches, list) else []
    row["_profiles"] = _profiles(s.get("profiles"))
    regions = s.get("regions") if isinstance(s.get("regions"), dict) else {}
    row["_layers"] = []  # the h of each region group present, in order
    for group in regions.values():
        h = _finite(group.get("h")) if isinstance(group, dict) else None
        if h is None:
            continue
        label = _h_label(h)
        row["_layers"].append(h)
        for part, quantities in REGION_PARTS.items():
            for col, key in quantities:
                c = f"{label}_{part}_{col}"
                row[c], row[c + "_err"] = _pair(group, part, key)
    return row


def campaign_runs(campaign_toml):
    """(name, [run names], text, set) from a resolved campaign.toml: [campaign].name, the runs
    listed in its closing comment (`#   s1_seed1_V0.5  duration ...`), the whole file and its
    [set] table (the case overrides of every run; {} where it has none). A [set] value of a
    system's n, L_y or sigma_yy that no sweep would have run (not a positive number, n not
    whole) is the file's error, not every run's (the runs are judged against it)."""
    try:
        with open_regular(campaign_toml, "rb") as f:
            raw = f.read()
        data = tomllib.loads(raw.decode("utf-8"))
    except (OSError, ValueError) as e:  # tomllib.TOMLDecodeError is a ValueError
        raise ReportError(campaign_toml, f"cannot read: {e}") from None
    except RecursionError:
        raise ReportError(campaign_toml, "cannot read: nested too deeply") from None
    campaign = data.get("campaign")
    name = campaign.get("name") if isinstance(campaign, dict) else None
    name = name if isinstance(name, str) else None
    text = raw.decode("utf-8")
    runs = re.findall(r"^#\s+(s\d+_seed\d+_V\S+)\s+duration", text, re.M)
    overrides = data.get("set") if isinstance(data.get("set"), dict) else {}
    for table, key in SYSTEM_KEYS:
        given = overrides.get(table)
        if not isinstance(given, dict) or key not in given:
            continue
        value, whole = given[key], key == "n"
        if not (_is_number(value) and math.isfinite(value) and value > 0
                and (not whole or value == int(value))):
            raise ReportError(campaign_toml, f"[set.{table}] {key}: must be a positive "
                              f"{'whole number' if whole else 'number'}, not {value!r} (no sweep "
                              f"runs that: the file was edited after the sweep wrote it)")
    return name, runs, text, overrides


def _build_of(path):
    """The build that wrote one run_info file (its description, else program and version), or
    None when it cannot be read."""
    try:
        with open_regular(path, encoding="utf-8") as f:
            info = json.load(f)
        build = info.get("build")
        return (_text(build.get("description")) if isinstance(build, dict) else None) or \
            f"{info.get('program', '?')} {info.get('version', '?')}"
    except (OSError, ValueError, AttributeError, RecursionError):
        return None


def builds_of(run_dir):
    """The builds that wrote a run's run_info files, one per sitting (_build_of): a set, empty
    where none can be read."""
    return {b for b in map(_build_of, run_info_paths(run_dir)) if b is not None}


def shared_end(dir_a, dir_b, state_a=None, state_b=None):
    """How the runs of two folders relate by their ends (rundata.end_state; state_a, state_b:
    theirs where already read, else read here): "copy" where both end at one step in one state
    from the same case.toml and build (one run copied, or run again from the same packing and
    seeds), "one_flow" where they end so from other case.toml files or builds (a setting or a
    build that changes nothing there: one flow computed twice), None where their ends differ or
    either is unknown."""
    if state_a is None and (state_a := end_state(dir_a)) is None:
        return None
    if state_a != (state_b if state_b is not None else end_state(dir_b)):
        return None
    if folder_case(dir_a) == folder_case(dir_b) and builds_of(dir_a) == builds_of(dir_b):
        return "copy"
    return "one_flow"


def software(campaign_text, run_dirs):
    """What made the campaign: the sweep's version (first line of campaign.toml, "written by
    cdshear X sweep") and {version: number of runs} from each run's run_info files (run_info.json
    and the resumed sittings' run_info_resume_*.json: a run made by several builds counts under
    each)."""
    m = re.search(r"written by (\S+) (\S+) sweep", campaign_text or "")
    versions = {}
    for d in run_dirs:
        for v in sorted(builds_of(d)) or ["unknown (no readable run_info.json)"]:
            versions[v] = versions.get(v, 0) + 1
    return {"sweep": f"{m.group(1)} {m.group(2)}" if m else None, "runs": versions}


def usable_summary(run_dir, reanalysed, reanalyse_stale=True):
    """(parsed summary.json of RUN_DIR, None) when it can be pooled, re-analysing a stale one
    from run.h5 (appending (run, reason) to reanalysed; with reanalyse_stale False, a stale one
    is left out instead), or (None, why it is left out)."""
    from .rundata import RunDataError
    name = os.path.basename(os.path.normpath(run_dir))
    try:
        s = read_summary(run_dir)
        state = summary_state(s)
    except ReportError as e:   # cut short or garbled: analysed again like a stale one
        s, state = None, ("stale", f"summary.json: {e.problem}")
    if state is None and (ended := _ended_since(run_dir, s)):
        state = ("stale", ended)
    if state is None:
        damaged = case_problem(s)
        if damaged:
            return None, f"summary.json {damaged} (`cdshear analyze` the run to write it " \
                         f"again)"
        other, extended = _identity(run_dir, s)
        if extended:   # the advice is in it
            return None, other
        if other:
            return None, f"{other}: left out (`cdshear analyze` the run to write its own)"
        return s, None
    kind, why = state
    if kind == "other format":
        return None, f"{why}: left alone (`cdshear analyze` the run to replace it)"
    if kind == "newer":
        return None, why
    if not os.path.isfile(os.path.join(run_dir, RUN_FILE)):
        return None, f"{why} and there is no {RUN_FILE} to analyse it again"
    if not reanalyse_stale:
        return None, f"{why}: left out (`cdshear analyze` the run to bring it up to date)"
    try:
        s = reanalyse(run_dir)
    except RunDataError as e:
        return None, f"{why}; analysing {RUN_FILE} again failed: {e.problem}"
    except FigureError as e:
        return None, (f"{why}: analysed again, summary.json rewritten, but drawing its figures "
                      f"failed: {e.path}: {e.problem}")
    except OSError as e:
        where = e.filename or os.path.join(run_dir, "summary.json")
        return None, f"{why}; writing {where} failed: {e.strerror or e}"
    if summary_state(s) is not None:   # (analyze writes this code's version: never here)
        return None, f"{why}; analysed again, still {summary_state(s)[1]}"
    reanalysed.append((name, f"{why}: analysed again from {RUN_FILE}, summary.json rewritten"))
    return s, None


def _ended_since(run_dir, s):
    """Why summary `s` is outdated by the run's end (analysed while the run went on, the run
    finished since: progress.json), or None."""
    case = s.get("case") if isinstance(s, dict) else None
    if not isinstance(case, dict) or case.get("finished") is not False or \
            not _is_number(case.get("time")):
        return None
    p, _ = read_progress(run_dir)
    if p is None or p["state"] != "finished" or p["time"] <= case["time"]:
        return None
    return (f"summary.json is of t = {case['time']:.6g}, before the run's end at "
            f"t = {p['time']:.6g} (progress.json)")


def summary_until(run_dir, time):
    """(summary, None): the summary of RUN_DIR/run.h5 analysed as it stood at `time` [t]
    (rundata.truncate_run), as read_summary would give it, nothing written; or (None, why not):
    run data that cannot be read, or a run that has not reached `time`."""
    from .rundata import RunDataError, load_run, truncate_run
    try:
        run = load_run(run_dir)
    except RunDataError as e:
        return None, f"its run data cannot be read: {e.problem}"
    if other := run_file_identity_problem(run, run_dir):
        return None, other
    reached = float(run["attrs"]["time"])
    if reached < time * (1 - 1e-9):
        return None, f"reached t = {reached:.6g} only, before {time:g}"
    try:
        summary = summary_module.analyze(truncate_run(run, time))
    except RunDataError as e:
        return None, f"cannot be analysed as it stood at t = {time:g}: {e.problem}"
    return summary_module.jsonable(summary), None


def collect(campaign_dir, reanalyse_stale=True, until=None):
    """{"campaign": name, "campaign_dir", "rows": [...], "skipped": [(run, reason)] (the runs
    left out), "reanalysed": [(run, reason)] (stale summaries analysed again; with
    reanalyse_stale False none is, and nothing is written), "notes": [text] (about the campaign
    folder and its runs kept: unfinished ones, copies pooled), "campaign_notes": [text] (those
    about its campaign.toml alone), "listed": [run names its campaign.toml lists]}. With `until`
    (a time [t]) every run is analysed from its run.h5 as it stood then (summary_until), its
    summary.json not read nor written; a run that has not reached `until` is left out."""
    if not os.path.isdir(campaign_dir):
        raise ReportError(campaign_dir, f"is {what_is(campaign_dir)}, not a campaign folder"
                          if os.path.lexists(campaign_dir) else "no such folder")
    toml_path = os.path.join(campaign_dir, "campaign.toml")
    skipped = []
    notes = []
    if os.path.isfile(toml_path):
        name, listed, text, overrides = campaign_runs(toml_path)
        systems = system_values(overrides)
        if not name:
            notes.append("campaign.toml gives no [campaign] name, as every file a sweep writes "
                         "does (not a sweep's file, or edited): the campaign name is the "
                         "folder's, and runs it lists without a folder are not named")
    elif os.path.lexists(toml_path):
        raise ReportError(toml_path, f"is {what_is(toml_path)}, not the campaign's file")
    else:
        name, listed, text = None, [], None
        systems = None   # its [set] may have changed the systems' n or L_y: not checked
        notes.append("campaign.toml is missing: the campaign name is the folder's")
    campaign_notes = list(notes)   # about the campaign's file, not its runs
    if not name:
        # the folder's own name, also where it is given as "." or ".."
        name = os.path.basename(os.path.abspath(campaign_dir)) or os.path.abspath(campaign_dir)
    runs_dir = os.path.join(campaign_dir, "runs")
    if os.path.lexists(runs_dir) and not os.path.isdir(runs_dir):
        raise ReportError(runs_dir, f"is {what_is(runs_dir)}, not the folder of the runs")
    entries = sorted(os.listdir(runs_dir)) if os.path.isdir(runs_dir) else []
    for d in entries:   # names the report's text, tables and HTML cannot hold as they are
        if not _is_utf8(d):
            skipped.append((_shown_name(d), "its folder's name is not UTF-8 text: rename it"))
    entries = [d for d in entries if _is_utf8(d)]
    folders = [d for d in entries if os.path.isdir(os.path.join(runs_dir, d))]
    for d in entries:   # a run's place taken by a file or a link that leads nowhere
        if d not in folders and (d in listed or RUN_NAME.match(d)):
            skipped.append((d, f"not a run folder: {what_is(os.path.join(runs_dir, d))}"))
    if not folders and not listed:
        held = [f for f in ("run.h5", "case.toml") if os.path.isfile(os.path.join(campaign_dir, f))]
        if held and not os.path.isdir(runs_dir):
            raise ReportError(campaign_dir, f"is a run's folder (it holds {' and '.join(held)}), "
                                            f"not a campaign's: a report pools a campaign's runs "
                                            f"(`cdshear sweep`); one run is analysed by "
                                            f"`cdshear analyze` and plotted by `cdshear plot`")
        raise ReportError(runs_dir, "no run folders (has `cdshear sweep` run here?)")
    rows = []
    reanalysed = []
    for d in folders:
        if renamed := _name_problem(os.path.join(runs_dir, d), systems):
            skipped.append((d, renamed))
            continue
        if until is not None:
            s, why = summary_until(os.path.join(runs_dir, d), until)
            if s is None:
                skipped.append((d, why))
            else:
                rows.append(read_run(os.path.join(runs_dir, d), s))
            continue
        if not os.path.isfile(os.path.join(runs_dir, d, "summary.json")):
            skipped.append((d, _not_analysed_reason(os.path.join(runs_dir, d))))
            continue
        s, why = usable_summary(os.path.join(runs_dir, d), reanalysed, reanalyse_stale)
        if s is None:
            skipped.append((d, why))
            continue
        rows.append(read_run(os.path.join(runs_dir, d), s))
    for r in listed:
        if r not in entries:
            skipped.append((r, "not started: no run folder"))
    # (with `until` every run is cut there on purpose)
    unfinished = [r for r in rows if _unfinished(r)] if until is None else []
    if unfinished:
        notes.append("not finished, analysed over the time reached (still running or stopped; "
                     "once a run has ended the report analyses it again from run.h5): "
                     + ", ".join(f"{r['run']} ({reached_text(r['time_reached'], r['duration'])})"
                                 for r in unfinished))
    rows.sort(key=lambda r: (r["system"] if r["system"] is not None else 1 << 30,
                             r["seed"] if r["seed"] is not None else 0,
                             r["V"] if r["V"] is not None else math.inf, r["run"]))
    same = {}
    for r in rows:   # a run folder copied inside runs/ (a backup) weighs its seed twice
        if None not in (r["system"], r["seed"], r["V"]):
            same.setdefault((r["system"], r["seed"], r["V"]), []).append(r["run"])
    for (system, seed, v), names in same.items():
        if len(names) > 1:
            notes.append(f"{', '.join(names)} are the same run (system {system}, seed {seed}, "
                         f"V = {v:g}): each is pooled, so that seed weighs {len(names)} times; "
                         f"move the copies out of runs/")
    return {"campaign": name, "campaign_dir": campaign_dir, "rows": rows, "skipped": skipped,
            "reanalysed": reanalysed, "notes": notes, "campaign_notes": campaign_notes,
            "listed": list(listed),
            "campaign_toml": text,
            "software": software(text, [os.path.join(runs_dir, r["run"]) for r in rows])}


def _unfinished(row):
    """Whether a run's summary is of a run that had not reached its duration."""
    return row.get("finished") is False and row.get("time_reached") is not None


def reached_text(t, duration):
    """"t = T of D" (D left out where it is not known)."""
    return f"t = {t:.6g}" + (f" of {duration:.6g}" if duration is not None else "")


# A progress.json updated within this many seconds is of a run still going (it is rewritten
# every 2 s of wall time while the run steps: docs/shear-cell.md).
PROGRESS_FRESH_SECONDS = 60
PROGRESS_STATES = ("running", "finished", "stopped", "interrupted", "blown up")


def read_progress(run_dir):
    """(progress, None) with the checked fields of RUN_DIR/progress.json (docs/shear-cell.md):
    "state" (one of PROGRESS_STATES), "time" and "duration" [t], "age" (seconds since it was
    written; 0 for a time stamp in the future); or (None, why it cannot be used), why None
    where there is no progress.json."""
    path = os.path.join(run_dir, "progress.json")
    if not os.path.lexists(path):
        return None, None
    try:
        with open_regular(path, encoding="utf-8") as f:
            p = json.load(f)
        if not isinstance(p, dict):
            return None, "not a JSON object"
        state, t, duration, updated = (p.get(k) for k in (
            "state", "time", "duration", "updated_unix_seconds"))
        if state not in PROGRESS_STATES:
            return None, f"state is {str(state)[:40]!r}, not one of {', '.join(PROGRESS_STATES)}"
        if not all(_is_number(x) and math.isfinite(x) for x in (t, duration, updated)) or \
                t < 0 or duration <= 0:
            return None, "time, duration or updated_unix_seconds is not a valid number"
    except (OSError, ValueError, OverflowError, RecursionError) as e:
        return None, f"cannot be read: {getattr(e, 'strerror', None) or e}"
    return {"state": state, "time": float(t), "duration": float(duration),
            "age": max(0.0, time.time() - float(updated))}, None


def _not_analysed_reason(run_dir):
    """Why a run folder has no summary.json, from its progress.json where it has one (the run
    still going, stopped before its end, blown up, or ended and not analysed)."""
    fallback = "not analysed: no summary.json (`cdshear analyze` it)"
    p, why = read_progress(run_dir)
    if p is None:
        return fallback + (f"; its progress.json: {why}" if why else "")
    where = reached_text(p["time"], p["duration"])
    state = p["state"]
    if state == "finished":
        return fallback
    if state == "running" and p["age"] < PROGRESS_FRESH_SECONDS:
        return f"still running ({where}, progress.json): analysed at its end"
    if state == "blown up":
        return (f"blew up ({where}, progress.json): its log says why; resuming would repeat the "
                "same steps (remove the folder to start it again)")
    if state == "running":   # a run killed without a chance to write, or paused
        state = f"running, not updated for {p['age']:.0f} s: killed or paused"
    return (f"stopped before its end ({where}; progress.json: {state}): `cdshear sweep` or "
            "`cdshear run --resume` continues it")


def csv_columns(rows):
    cols = list(HEAD_COLUMNS)
    for col, _ in BULK_QUANTITIES:
        cols += [col, col + "_err"]
    cols += [col for col, _ in SCATTER_QUANTITIES]
    for h in sorted({h for r in rows for h in r["_layers"]}):
        for part, quantities in REGION_PARTS.items():
            for col, _ in quantities:
                c = f"{_h_label(h)}_{part}_{col}"
                cols += [c, c + "_err"]
    return cols


def _cell(v):
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ""
    return str(v)


# ---------------------------------------------------------------------------------------------
# Fits of the bulk laws (fitting.py does the fitting; boundary_laws.py the boundary layers)

# The bulk laws take the steady runs in regime A only: in B and C the bulk does not flow (it
# moves as a block, I_bulk ~ 1e-5 from noise) and sits below its yield friction, so its
# (I, mu_eff) is no point of the flow law (docs/reports.md, "Which runs each law takes").
BULK_REGIMES = ("A",)
FITS = {
    "mu_power": fitting.law("power_plus", ["mu_0", "A", "B"], "mu_eff_bulk", "I_bulk",
                            regimes=BULK_REGIMES),
    "mu_linear": fitting.law("linear_plus", ["a", "b"], "mu_eff_bulk", "I_bulk", LINEAR_RANGE,
                             BULK_REGIMES),
    "nu_linear": fitting.law("linear_minus", ["nu_max", "c"], "nu_bulk", "I_bulk",
                             LINEAR_RANGE, BULK_REGIMES),
    "Z_power": fitting.law("power_minus", ["Z_0", "c", "e"], "Z_bulk", "I_bulk",
                           regimes=BULK_REGIMES),
}


def fit_law(name, rows, x=None, y=None):
    """One law of FITS over the steady rows, with the columns x and y (default: the law's)."""
    return fitting.fit_columns(FITS[name], rows, x, y)


def bulk_rows(rows):
    """The rows whose bulk is that of model.md section 7 (h = 10): the bulk laws take no other. A
    cell too thin for h = 10 (or a run that did not measure it) says so in bulk_h_note and is
    listed in fits.json `bulk_not_reference`."""
    return [r for r in rows if r.get("bulk_h_reference") is True]


def fit_laws(rows):
    """fits.json `fits`: every law of FITS over the runs of every system (model.md section 8)
    whose bulk is at h = 10 (bulk_rows)."""
    rows = bulk_rows(rows)
    return {name: fit_law(name, rows) for name in FITS}


def fit_laws_per_system(rows):
    """fits.json `fits_per_system`: {"<system>": {law: fit}}, the laws of FITS over each
    system's runs alone (runs without a system number are in no system); a law with too few
    points of that system is skipped with its reason, as in `fits`."""
    systems = sorted({r["system"] for r in rows if r.get("system") is not None})
    return {str(s): fit_laws([r for r in rows if r.get("system") == s]) for s in systems}


# P below which system_dependence says a law depends on the system (the F test's tail).
P_DEPENDS = 0.01


def system_dependence(rows):
    """fits.json `system_dependence`: per law of FITS, whether the systems follow one law (claim
    1 of docs/validation.md: "does the law depend on the system?"). The law, fitted over the runs
    that name their system (every campaign run: then it is `fits`' law), is fitted again with an
    offset of y per system but the
    reference (fitting.fit_with_offsets: y = law(x) + delta_s, the same points), which needs one
    point per system, not a fit per system. chi2 falls by dchi2 = chi2 - chi2_offsets for ddof
    = (systems - 1) more parameters; F = (dchi2 / ddof) / (chi2_offsets / dof_offsets) compares
    that fall with the scatter left, so error bars wrong by a common factor cancel; p_F is its
    tail (F law with ddof and dof_offsets degrees of freedom): "depends on the system" below
    P_DEPENDS, "no dependence detected" otherwise. p_chi2: the tail of dchi2 (chi2 law, ddof),
    which trusts the error bars. offsets: each system's delta (y units) against the system with
    the most points (`reference`). "not tested" with its reason where the law has points of one
    system only, was not fitted, or no dof is left."""
    from scipy.stats import chi2 as chi2_law, f as f_law
    out = {}
    bulk = [r for r in bulk_rows(rows) if r.get("system") is not None]
    system_of = {r["run"]: r["system"] for r in bulk}
    for name, spec in FITS.items():
        pooled = fit_law(name, bulk)   # the same points as the fit with offsets
        systems = sorted({system_of[run] for run in pooled.get("runs") or []
                          if run in system_of})
        entry = {"systems": [str(x) for x in systems], "verdict": "not tested", "reason": None,
                 "reference": None, "offsets": None, "chi2": pooled.get("chi2"),
                 "dof": pooled.get("dof"), "chi2_offsets": None, "dof_offsets": None,
                 "F": None, "p_F": None, "p_chi2": None}
        out[name] = entry
        if not fitting.fitted(pooled):
            entry["reason"] = f"the law is {pooled['status']}: {pooled['reason']}"
            continue
        if len(systems) < 2:
            entry["reason"] = "its points are of one system"
            continue
        result = fitting.fit_with_offsets(spec, fitting.column_points(spec, bulk), system_of,
                                          pooled)
        if result is None:
            entry["reason"] = ("no degree of freedom left with an offset per system, or the fit "
                               "did not converge")
            continue
        chi2_off, dof_off, offsets, reference = result
        ddof = pooled["dof"] - dof_off
        dchi2 = max(0.0, pooled["chi2"] - chi2_off)
        entry.update(reference=reference, offsets=offsets, chi2_offsets=chi2_off,
                     dof_offsets=dof_off)
        if chi2_off <= 0:
            entry["reason"] = "the offsets fit every point exactly: nothing left to compare with"
            continue
        F = (dchi2 / ddof) / (chi2_off / dof_off)
        entry.update(F=float(F), p_F=float(f_law.sf(F, ddof, dof_off)),
                     p_chi2=float(chi2_law.sf(dchi2, ddof)))
        entry["verdict"] = ("depends on the system" if entry["p_F"] < P_DEPENDS
                            else "no dependence detected")
    return out


# ---------------------------------------------------------------------------------------------
# Output

def _fmt(v, digits=4):
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.{digits}g}"
    return html.escape(str(v))


def _pm_text(v, e):
    """v +- e as plain text, the error to two significant digits and the value to the same
    decimal place (0.4156 +- 0.0011, 1.3e-04 +- 2.0e-05 below 1e-3); "" without a value."""
    v, e = _finite(v), _finite(e)
    if v is None:
        return ""
    if e is None or e <= 0:
        return f"{v:.4g}"
    if abs(v) < 1e-3 and v != 0:
        return f"{v:.1e} +- {e:.1e}"
    digits = max(0, 1 - math.floor(math.log10(e)))
    return f"{v:.{digits}f} +- {e:.{digits}f}"


# runs.md: (header, runs.csv column) of each quantity with its error
RUNS_MD_COLUMNS = (("I_bulk", "I_bulk"), ("mu_eff bulk", "mu_eff_bulk"),
                   ("mu_eff walls", "mu_eff_wall"), ("nu bulk", "nu_bulk"), ("Z bulk", "Z_bulk"))


def runs_markdown(rows, campaign):
    """runs.md: the runs table of docs/validation.md as Markdown, made from the same rows as
    runs.csv (sorted by system, V, seed): run, regime, steady, the bulk's h where it is not
    the h = 10 of model.md section 7, the bulk and wall quantities with their errors, and the
    transient's end of steady runs (t)."""
    intro = ("Made by `cdshear report` from each run's `summary.json` (every column, with more "
             "digits: `runs.csv`). Bulk at h = 10 unless the row says otherwise; mean +- error "
             "over the steady windows, or over the last half for runs that are not steady; T_ss: "
             "the transient's end of steady runs [t].")
    out = [f"# Runs of the campaign {campaign}", "", *textwrap.wrap(intro, 100), "",
           "| run | regime | steady | " + " | ".join(h for h, _ in RUNS_MD_COLUMNS) + " | T_ss |",
           "|" + "---|" * (len(RUNS_MD_COLUMNS) + 4)]
    key = lambda r: (r.get("system") or 0, r.get("V") or 0, r.get("seed") or 0)
    for r in sorted(rows, key=key):
        name = r["run"]
        if r.get("bulk_h_reference") is not True and r.get("bulk_h") is not None:
            name += f" (bulk at h = {r['bulk_h']:g})"
        if _unfinished(r):
            name += f" (not finished: {reached_text(r['time_reached'], r['duration'])})"
        t_ss = _finite(r.get("transient_end_time")) if r.get("steady") else None
        cells = [name, r.get("regime") or "", "yes" if r.get("steady") else "no"]
        cells += [_pm_text(r.get(c), r.get(c + "_err")) for _, c in RUNS_MD_COLUMNS]
        cells.append(f"{t_ss:.0f}" if t_ss is not None else "")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def _pm(row, col):
    v, e = row.get(col), row.get(col + "_err")
    if v is None:
        return ""
    return _fmt(v) + (f" ± {_fmt(e, 2)}" if e is not None else "")


def _interval_text(e, notes):
    """A V_AB cell: the value [interval] (its notes), or the reason there is none; the long
    reasons, which repeat across systems, go to `notes` (a _Footnotes)."""
    if e["V_AB"] is None:
        return f"<small>{notes.text(e['reason'])}</small>"
    iv = e["interval"]
    fr, ab = e.get("form_range"), e.get("allowed_B")
    parts = ([f"law {e['law']}"] if e.get("law") not in (None, "mu_hI_BC") else []) + \
        (["extrapolated beyond the law's points"] if e.get("extrapolated") else []) + \
        ([f"{_fmt(fr[0], 3)} to {_fmt(fr[1], 3)} over the exponents the points allow, B "
          f"{_fmt(ab[0], 2)} to {_fmt(ab[1], 2)}"] if fr and ab else [])
    cell = [html.escape(p) for p in parts] + \
        ([notes.text(e["interval_note"])] if e.get("interval_note") else [])
    return _fmt(e["V_AB"], 3) + (f" [{_fmt(iv[0], 3)}, {_fmt(iv[1], 3)}]" if iv else "") + \
        (f" <small>({'; '.join(cell)})</small>" if cell else "")


def _by_h_text(by_h):
    """h3 0.53, h5 0.57, ... (– where an h gives none)."""
    return ", ".join(f"{h} {_fmt(e['V_AB'], 3) if e['V_AB'] is not None else '–'}"
                     for h, e in by_h.items()) or "–"


def _html_v_ab(v_ab):
    out = ["<h3>V_AB from the laws: boundary friction law = bulk mu_0</h3>"]
    if v_ab["status"] != "ok":
        return out + [f"<p>{html.escape(v_ab['status'])}: {html.escape(v_ab['reason'])}</p>"]
    systems = v_ab["systems"]
    hs = sorted({k for e in systems.values() for k in e if k.startswith("h")},
                key=lambda k: float(k[1:]))
    out.append(f"<p>{html.escape(v_ab['method'])}.</p><table><tr><th>system</th>"
               "<th>measured V_AB (bracket)</th><th>from mu(h I_b), regimes B and C, all h</th>"
               "<th>the same, each h alone</th>"
               + "".join(f"<th>from mu(I_b), {h}</th>" for h in hs) + "</tr>")
    notes = _Footnotes()
    for key, e in systems.items():
        m = e.get("measured")
        meas = "" if not m else (f"{_fmt(m['estimate'], 3) if m['estimate'] else '–'} "
                                 f"[{_fmt(m['bracket'][0]) or '–'}, "
                                 f"{_fmt(m['bracket'][1]) or '–'}]")
        out.append(f"<tr><td>{html.escape(key)}</td><td>{meas}</td>"
                   f"<td>{_interval_text(e['from_hI_law'], notes)}</td>"
                   f"<td>{_by_h_text(e.get('from_hI_law_by_h') or {})}</td>"
                   + "".join(f"<td>{_interval_text(e[h], notes)}</td>" for h in hs) + "</tr>")
    return out + ["</table>" + notes.html()]


def _html_stability(st):
    out = ["<h3>Stability of the symmetric state: d mu_boundary / d (h I_b) between "
           "velocities (B and C runs)</h3>"]
    if st["status"] != "ok":
        return out + [f"<p>{html.escape(st['status'])}: {html.escape(st['reason'])}</p>"]
    out.append("<table><tr><th>system</th><th>h</th><th>V interval</th><th>slope</th>"
               "<th>trend</th><th>predicted</th><th>regimes observed</th></tr>")
    for e in st["intervals"]:
        slope = _fmt(e["slope"], 3) + (f" ± {_fmt(e['slope_err'], 2)}" if e["slope_err"]
                                       else "")
        out.append("<tr>" + "".join(f"<td>{c}</td>" for c in [
            _fmt(e["system"]), _fmt(e["h"]), f"{_fmt(e['V'][0])} – {_fmt(e['V'][1])}", slope,
            e["trend"], e["predicted"] or "", e["observed"]]) + "</tr>")
    return out + ["</table>"]


def _html_transitions(transitions, preds):
    out = ["<h2>Transition velocities</h2><p>Regimes by V (seeds by majority vote; only the "
           "steady runs classified A, B or C vote: a run not steady, without a regime or with "
           "another label such as undecided does not); brackets [largest B or C, smallest A "
           "above] and [largest C, smallest B above]; estimate: geometric mean.</p><table><tr>"
           "<th>system</th><th>regimes by V</th><th>runs that do not vote</th><th>V_AB</th>"
           "<th>V_BC</th><th>flags</th></tr>"]

    def cell(b):
        lo, hi = b["bracket"]
        text = f"[{_fmt(lo) or '–'}, {_fmt(hi) or '–'}]"
        if b["estimate"] is not None:
            text = f"{_fmt(b['estimate'], 3)} in {text}"
        return text + (f"<br><small>{html.escape(b['note'])}</small>" if b["note"] else "")

    for key, t in transitions.items():
        seq = ", ".join(f"{_fmt(e['V'])}: {e['regime'] or '?'}" for e in t["velocities"])
        ns = "<br>".join(f"{html.escape(e['run'])} ({html.escape(e['reason'])})"
                         for e in t.get("not_voting", []))
        flags = "<br>".join(html.escape(f) for f in t["flags"])
        out.append(f"<tr><td>{html.escape(key)}</td><td style='text-align:left'>{seq}</td>"
                   f"<td style='text-align:left'>{ns or 'none'}</td><td>{cell(t['V_AB'])}</td>"
                   f"<td>{cell(t['V_BC'])}</td><td style='text-align:left'>{flags}</td></tr>")
    out.append("</table>")
    out.append("<h2>Predictions (model.md section 8) beside the runs</h2>")
    out += _html_v_ab(preds["V_AB"])
    out += _html_stability(preds["symmetric_state_stability"])
    out.append("<h3>Regime C: band switch time T = 2 rho nu V L_y / (delta_mu sigma_yy)"
               "</h3>")
    sw = preds["switch_time_C"]
    if sw:
        out.append("<table><tr><th>run</th><th>V</th><th>L_y</th><th>nu</th>"
                   "<th>delta_mu on the plateau</th><th>delta_mu (law, h nearest 10)</th>"
                   "<th>predicted T</th><th>delta_mu from the law, T from it, per h</th>"
                   "<th>switches</th><th>measured T</th><th>duration</th>"
                   "<th>mean interval</th><th>time / switch</th><th>delta_mu implied</th>"
                   "</tr>")
        notes = _Footnotes()
        for e in sw:
            law = _delta_mu_law_text(e["delta_mu_law"], notes)   # first: pred may quote it
            pred = _fmt(e["predicted_T"]) if e["predicted_T"] is not None else \
                f"<small>{notes.text(e['reason'])}</small>"
            out.append("<tr>" + "".join(f"<td>{c}</td>" for c in [
                html.escape(e["run"]), _fmt(e["V"]), _fmt(e["L_y"]), _fmt(e["nu_bulk"]),
                _fmt(e.get("delta_mu_plateau")), _fmt(e["delta_mu"]), pred, law,
                e["switch_count"], _pm(e, "switch_time"), _pm(e, "switch_duration"),
                _fmt(e["mean_interval"]),
                _fmt(e["time_per_switch"]), _fmt(e["delta_mu_implied"], 3)]) + "</tr>")
        out.append("</table>" + notes.html() + "<p>Measured T: the time from +V to -V at the "
                   "rate of the "
                   "straight ramp fitted to each switch, the run's mean (compare with the "
                   "predicted T); duration: that ramp from plateau to plateau; delta_mu on "
                   "the plateau: the walls' net friction before each switch, positive where it "
                   "pushes the block towards the new plateau, about zero by momentum balance "
                   "(a check, not a prediction); the prediction takes the boundary law's "
                   "delta_mu at the layers' jumps (h nearest 10); delta_mu implied: the "
                   "friction difference that the measured T needs. delta_mu from the law: "
                   "|mu(bottom) - mu(top)| of the boundary law of B and C in h I_b at each "
                   "wall's measured velocity jump, per h, 68% interval in brackets, and the T "
                   "of that delta_mu.</p>")
    else:
        out.append("<p>no run in regime C</p>")
    out.append("<h3>Regime A: time to steady state T_SS = L_y² / D, "
               "D = (d mu_eff / d gamma_dot) sigma_yy / (rho nu)</h3>")
    ss = preds["steady_state_time_A"]
    if ss:
        out.append("<table><tr><th>run</th><th>V</th><th>I_bulk</th><th>law</th>"
                   "<th>d mu / d I</th><th>D</th><th>predicted T_SS</th>"
                   "<th>measured transient end</th></tr>")
        notes = _Footnotes()
        for e in ss:
            pred = _fmt(e["predicted_T_SS"]) if e["predicted_T_SS"] is not None else \
                f"<small>{notes.text(e['reason'])}</small>"
            out.append("<tr>" + "".join(f"<td>{c}</td>" for c in [
                html.escape(e["run"]), _fmt(e["V"]), _fmt(e["I_bulk"]),
                _fmt(e["law"]) + (f" ({html.escape(e['law_status'])})"
                                  if e.get("law_status") not in (None, "ok") else ""),
                _fmt(e["dmu_dI"]), _fmt(e["D"]), pred,
                _fmt(e["measured_transient_end_time"])]) + "</tr>")
        out.append("</table>" + notes.html())
    else:
        out.append("<p>no run in regime A</p>")
    return out


class _Footnotes:
    """Reasons that a table's cells would repeat (the predictions' "not computed: ..."), each
    written once below the table: a cell shows "see note k" in place of the reason, and in place
    of a longer reason's part that is an earlier note (the predicted T "not computed: no
    delta_mu from the boundary law (...)" holds the reason of the law's cell of the same run)."""

    def __init__(self):
        self.reasons = []

    def text(self, reason):
        """The cell's escaped text for `reason`."""
        reason = reason or ""
        for k, known in enumerate(self.reasons, start=1):
            if known == reason:
                return f"see note {k}"
            if known and known in reason:
                head, tail = reason.split(known, 1)
                return html.escape(head) + f"see note {k}" + html.escape(tail)
        self.reasons.append(reason)
        return f"see note {len(self.reasons)}"

    def html(self):
        """The notes, one paragraph, or nothing when no cell took one."""
        if not self.reasons:
            return ""
        return "<p><small>" + "<br>".join(f"note {k}: {html.escape(r)}" for k, r in
                                          enumerate(self.reasons, start=1)) + "</small></p>"


def _delta_mu_law_text(d, notes):
    """The cell of delta_mu from the boundary law: per h, delta_mu [interval], T; the reasons
    of what is missing go to `notes` (a _Footnotes)."""
    if d["status"] != "ok":
        return f"<small>{notes.text(d['reason'])}</small>"
    out = []
    for label, e in d["by_h"].items():
        if e["delta_mu"] is None:
            out.append(f"{label}: <small>{notes.text(e['reason'])}</small>")
            continue
        iv = e["interval"]
        text = f"{label}: {_fmt(e['delta_mu'], 3)}"
        text += f" [{_fmt(iv[0], 2)}, {_fmt(iv[1], 2)}]" if iv else ""
        text += f", T = {_fmt(e['predicted_T'], 3)}" if e["predicted_T"] is not None else ""
        flags = [f for f, on in (("extrapolated", e["extrapolated"]),
                                 ("mu &lt; 0", e["mu_negative"]),
                                 ("no interval", e["interval_note"])) if on]
        out.append(text + (f" <small>({', '.join(flags)})</small>" if flags else ""))
    if d["law_note"]:
        out.append(f"<small>law: {html.escape(d['law_note'])}</small>")
    return "<br>".join(out)


STATUS_COLOURS = {"ok": "#dfd", "poor": "#fed", "undetermined": "#fdd", "skipped": "#eee"}
STATUS_TEXT = ("Status of a fit (fitting.py): <b>ok</b>, the points follow the law within their "
               "error bars; <b>poor</b>, they scatter far more than their error bars "
               f"(chi2 tail probability P(chi2 &ge; observed) &lt; {fitting.P_POOR:g}: the law "
               "does not describe them, or their error bars are too small; read the scaled "
               "errors); <b>undetermined</b>, the points do not constrain the form (a "
               "parameter's error larger than its value, an infinite covariance, or a "
               "parameter on a bound of its range): its parameters mean nothing; "
               "<b>skipped</b>, not fitted. The predictions take ok and poor laws only.")


def _fit_table(items):
    """An HTML table of fits: (name, fits.json fit) pairs, with each fit's status and reason."""
    out = ["<table><tr><th>fit</th><th>law</th><th>points</th><th>status</th>"
           "<th>parameters</th><th>chi2/dof</th></tr>"]
    for fname, f in items:
        if fitting.fitted(f):
            # with chi2/dof > 1 the scatter exceeds the error bars: the scaled error too
            scaled = f["chi2_dof"] is not None and f["chi2_dof"] > 1
            params = "<br>".join(
                f"{p} = {_fmt(v['value'])} ± {_fmt(v['err'], 2) or '?'}" +
                (f" (scaled: ± {_fmt(v['err_scaled'], 2)})"
                 if scaled and v["err_scaled"] is not None else "")
                for p, v in f["parameters"].items())
            chi = _fmt(f["chi2_dof"], 3)
            if f.get("note"):
                params += f"<br><small>{html.escape(f['note'])}</small>"
        else:
            params, chi = "", ""
        status = (f"<b>{html.escape(f['status'])}</b>"
                  + (f"<br><small>{html.escape(f['reason'])}</small>" if f.get("reason") else ""))
        points = f"{f['n_points']}" + (f" ({f['n_runs']} runs)"
                                        if f.get("n_runs", 0) > f["n_points"] else "")
        out.append(f"<tr><td>{html.escape(fname)}</td><td>{html.escape(f['law'])}</td>"
                   f"<td>{points}</td><td style='text-align:left;background:"
                   f"{STATUS_COLOURS.get(f['status'], '#fff')}'>{status}</td>"
                   f"<td style='text-align:left'>{params}</td><td>{chi}</td></tr>")
    return out + ["</table>"]


def _html_boundary(boundary):
    hs = [_h_label(h) for h in boundary["thicknesses"]]
    out = ["<h2>Boundary-layer laws</h2><p>Points: the boundary layers of the steady runs, "
           "each wall of a run in regime A or B, the sheared wall only in regime C (the other "
           "layer moves with its wall). Thicknesses h: "
           + (", ".join(f"{h:g}" for h in boundary["thicknesses"]) or "none") + ".</p>"]
    out += _fit_table([(f"{h} {name}", boundary[h][name]) for h in hs
                       for name in ("mu_power", "nu_linear", "nu_ratio_linear", "Z_power",
                                    "mu_hI_BC", "mu_hI_BC_log") if name in boundary[h]])
    all_h = boundary["all_h"]
    out.append("<h3>mu_eff against I_boundary and against h I_boundary, every h together</h3>")
    out += _fit_table([(k, v) for k, v in all_h.items() if k != "collapse"])
    choice = boundary.get("prediction_law")
    if choice:
        out.append(f"<p>The B/C law the predictions take: "
                   f"<b>{html.escape(choice['name'] or 'none')}</b> "
                   f"({html.escape(choice['reason'] or '')}).</p>")
    out.append("<ul>")
    for g, c in all_h["collapse"].items():
        verdict = (f"collapses in {html.escape(c['collapses_in'])}" if c["collapses_in"]
                   else html.escape(c["note"] or ""))
        out.append(f"<li>regime{'s B and C' if g == 'BC' else ' A'}: chi2/dof "
                   f"{_fmt(c['chi2_dof_I'], 3) or '–'} in I_boundary, "
                   f"{_fmt(c['chi2_dof_hI'], 3) or '–'} in h I_boundary: {verdict}</li>")
    out.append("</ul><h3>The bulk law measured with each h (bulk h &lt; y &lt; L_y - h)</h3>")
    out += _fit_table([(f"{h} {name}", boundary[h]["bulk"][name]) for h in hs
                       for name in boundary[h]["bulk"]])
    return out


def _html_run_figures(run_figures):
    out = ["<h2>Each run's figures</h2><p>From <code>cdshear plot</code> (copied here): "
           "snapshot with force chains, velocity profiles by shear distance, centre-of-mass "
           "velocity against strain and its histogram, solid fraction and L_y against strain, "
           "steady profiles (mu_eff, nu, Z, I).</p>"]
    if not run_figures:
        return out + ["<p>none (runs without figures/: <code>cdshear plot</code> them)</p>"]
    out.append("<table>")
    for run, names in run_figures.items():
        links = " ".join(f"<a href='runs/{html.escape(run)}/{html.escape(n)}'>"
                         f"{html.escape(n[:-4])}</a>" for n in names)
        out.append(f"<tr><td>{html.escape(run)}</td><td style='text-align:left'>{links}</td>"
                   "</tr>")
    return out + ["</table>"]


def _html(report, fits, figures, transitions=None, preds=None, boundary=None,
          run_figures=None, per_system=None, system_dependence_of=None):
    rows = report["rows"]
    name = html.escape(report["campaign"])
    shown = ["I_bulk", "mu_eff_bulk", "mu_eff_wall", "nu_bulk", "Z_bulk", "slip_bottom",
             "slip_top"]
    out = [f"<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>Campaign {name}</title>",
           "<style>body{font-family:sans-serif;max-width:80em}table{border-collapse:collapse;"
           "font-size:85%}td,th{border:1px solid #bbb;padding:2px 6px;text-align:right}"
           "img{max-width:48%}</style></head><body>",
           f"<h1>Campaign {name}</h1>",
           f"<p>{counted(len(rows), 'analysed run')} "
           f"({sum(1 for r in rows if r['steady'])} steady); "
           f"{len(report['skipped'])} left out"
           + (f"; {counted(len(report.get('reanalysed', [])), 'run')} re-analysed from run.h5 "
              "(stale summary.json)" if report.get("reanalysed") else "")
           + ". Every value: mean ± standard error. "
           "All columns: <a href='runs.csv'>runs.csv</a>; fits: "
           "<a href='fits.json'>fits.json</a>.</p>",
           "".join(f"<p>Note: {html.escape(n)}</p>" for n in report.get("notes", [])
                   if n not in report.get("printed", [])),
           "<h2>Runs</h2><table><tr>",
           "".join(f"<th>{c}</th>" for c in
                   ["run", "system", "V", "steady", "regime (conf.)", "t reached",
                    "switches"] + shown), "</tr>"]
    for r in rows:
        regime = r["regime"] or ""
        if r["regime_confidence"] is not None:
            regime += f" ({r['regime_confidence']:.2f})"
        steady = {True: "yes", False: "no", None: ""}[r["steady"]]
        cells = [html.escape(r["run"]), _fmt(r["system"]), _fmt(r["V"]),
                 steady if r["steady"] is not False else
                 f"<span title='{html.escape(r['steady_reason'] or '')}'>no</span>",
                 html.escape(regime),
                 _fmt(r["time_reached"], digits=7) + (" (not finished)" if _unfinished(r) else ""),
                 _fmt(r["band_switches"])]
        cells += [_pm(r, c) for c in shown]
        out.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    out.append("</table><h2>Fits of the bulk laws</h2><p>Over the steady runs in regime "
               f"{' or '.join(BULK_REGIMES)} whose bulk is at h = 10: in B and C the bulk moves "
               "as a block and is no point of the flow law (crosses on the figures); a cell too "
               "thin for h = 10 has no bulk as model.md section 7 defines it (plus signs; "
               "fits.json <code>bulk_not_reference</code>).</p>")
    out += _fit_table(fits.items())
    out.append("<p>Errors from the error bars (absolute); fits.json also gives them "
               "scaled by sqrt(chi2/dof) when that exceeds 1. The seeds of one (system, V) are "
               "one point: their mean weighted by the time each seed's averages cover (by "
               "1/err² only where a seed's summary does not say where its averaging starts; "
               "fits.json <code>combined</code> says which), its error the larger of the "
               "propagated one and the error of that mean from the seeds' scatter.</p>"
               f"<p><small>{STATUS_TEXT}</small></p>")
    if per_system:
        out.append("<h3>The bulk laws per system</h3><p>The same laws fitted on each "
                   "system's runs alone (the laws of model.md section 8 are the ones over all "
                   "systems, above): do the systems agree?</p>")
        out += _fit_table([(f"system {s}: {name}", f) for s, laws in per_system.items()
                           for name, f in laws.items()])
        out += _html_system_dependence(system_dependence_of or {})
    if boundary is not None:
        out += _html_boundary(boundary)
    if transitions is not None:
        out += _html_transitions(transitions, preds)
    out.append("<h2>Figures</h2>")
    for fig in figures:
        out.append(f"<img src='figures/{html.escape(fig)}' alt='{html.escape(fig)}'>")
    out += _html_run_figures(run_figures or {})
    sw = report.get("software") or {}
    out.append("<h2>Software and configuration</h2><p>Campaign resolved by "
               f"{html.escape(sw.get('sweep') or 'unknown')}; runs made by "
               + (", ".join(f"{html.escape(v)} ({counted(n, 'run')})"
                            for v, n in sw.get("runs", {}).items())
                  or "none") + "; report by cdshear_analysis (this folder's Python package).</p>")
    if report.get("campaign_toml"):
        out.append("<details><summary>The resolved campaign file (campaign.toml)</summary><pre>"
                   + html.escape(report["campaign_toml"]) + "</pre></details>")
    out.append("<h2>Runs re-analysed</h2><p>Stale summary.json (an older version than this "
               f"code's {html.escape(summary_module.SUMMARY_FORMAT)} version "
               f"{summary_module.SUMMARY_VERSION}, no format or version, empty, not a JSON "
               "object), analysed again from run.h5 as <code>cdshear analyze</code> does and "
               "rewritten (fits.json <code>reanalysed_runs</code>):</p>")
    if report.get("reanalysed"):
        out.append("<ul>" + "".join(f"<li>{html.escape(n)}: {html.escape(why)}</li>"
                                    for n, why in report["reanalysed"]) + "</ul>")
    else:
        out.append("<p>none</p>")
    out.append("<h2>Runs left out</h2><p>fits.json <code>excluded_runs</code>:</p>")
    if report["skipped"]:
        out.append("<ul>" + "".join(f"<li>{html.escape(n)}: {html.escape(why)}</li>"
                                    for n, why in report["skipped"]) + "</ul>")
    else:
        out.append("<p>none</p>")
    out.append("</body></html>\n")
    return "\n".join(out)


def copy_run_figures(report, out_dir):
    """Each run's own figures (RUN/figures/*.png, `cdshear plot`) copied to out_dir/runs/RUN/,
    so that the report folder stands alone; {run: [file names]}. A figure that cannot be read
    (a link that leads nowhere, a folder, no permission) is left out with a note in
    report["notes"]; each is tried before any is copied, so that it is found before the report
    replaces anything."""
    out, copies = {}, []
    notes = report.setdefault("notes", [])
    for r in report["rows"]:
        src = os.path.join(report["campaign_dir"], "runs", r["run"], "figures")
        names = sorted(n for n in os.listdir(src) if n.endswith(".png")) \
            if os.path.isdir(src) else []
        kept = []
        for n in names:
            source = os.path.join(src, n)
            if not os.path.isfile(source):   # not opened: a FIFO would wait
                why = f"is {what_is(source)}"
            else:
                try:
                    with open(source, "rb"):
                        why = None
                except OSError as e:
                    why = f"cannot be read ({e.strerror or e})"
            if why:
                notes.append(f"{source}: {why}: left out of the report's copies of the run's "
                             f"figures")
                continue
            kept.append(n)
            copies.append((source, os.path.join(out_dir, "runs", r["run"], n)))
        if kept:
            out[r["run"]] = kept
    for source, dst in copies:
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        replace_atomically(dst, lambda tmp, source=source: shutil.copyfile(source, tmp))
    return out


def _html_system_dependence(dependence):
    """The table of system_dependence: does each bulk law depend on the system?"""
    if not dependence:
        return []
    out = ["<p>Does each law depend on the system? The law over every system against the same "
           "law with an offset of y per system (but the one with the most points, the "
           "reference): F compares the fall in chi2 with the scatter left (error bars wrong by "
           "a common factor cancel); below p_F = "
           f"{P_DEPENDS:g} the law depends on the system (fits.json "
           "<code>system_dependence</code>).</p><table><tr><th>law</th><th>systems</th>"
           "<th>chi2 / dof</th><th>with offsets</th><th>offsets against the reference</th>"
           "<th>F</th><th>p_F</th><th>p_chi2</th><th>verdict</th></tr>"]
    for name, e in dependence.items():
        def ratio(c, d):
            return f"{c:.4g} / {d}" if c is not None and d is not None else ""
        offsets = ", ".join(f"{s}: {_fmt(o['value'], 3)} &plusmn; {_fmt(o['err'], 2)}"
                            for s, o in (e.get("offsets") or {}).items())
        verdict = e["verdict"] + (f" ({e['reason']})" if e.get("reason") else "")
        systems = ", ".join(f"{x} (reference)" if x == e.get("reference") else x
                            for x in e["systems"])
        cells = [name, systems, ratio(e["chi2"], e["dof"]),
                 ratio(e["chi2_offsets"], e["dof_offsets"]), offsets, _fmt(e["F"]),
                 _fmt(e["p_F"], 2), _fmt(e["p_chi2"], 2), html.escape(verdict)]
        out.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    out.append("</table>")
    return out


def all_fits(fits, per_system, boundary):
    """Every fit of a report as (name, fits.json fit) pairs: the bulk laws, per system, per h
    (the layers and the bulk of that h) and pooled over h."""
    out = [(name, f) for name, f in fits.items()]
    out += [(f"system {s} {name}", f) for s, laws in per_system.items()
            for name, f in laws.items()]
    for h in boundary["thicknesses"]:
        label = _h_label(h)
        out += [(f"boundary {label} {name}", f) for name, f in boundary[label].items()
                if isinstance(f, dict) and "status" in f]
        out += [(f"bulk {label} {name}", f) for name, f in boundary[label]["bulk"].items()]
    out += [(f"boundary all_h {name}", f) for name, f in boundary["all_h"].items()
            if name != "collapse"]
    return out


def status_counts(fit_items):
    """{status: number of fits} over fitting.STATUSES."""
    return {st: sum(1 for _, f in fit_items if f["status"] == st) for st in fitting.STATUSES}


def printed_lines(report, fits, per_system, boundary, dependence=None):
    """What `cdshear report` prints after the paths and the runs left out: the runs re-analysed,
    each bulk law's status and reason and, where tested, whether it depends on the system
    (system_dependence), every other fit that is poor or undetermined, and the count of each
    status."""
    lines = [f"re-analysed {name}: {why}" for name, why in report.get("reanalysed", [])]
    for name, f in fits.items():
        lines.append(f"fit {name}: {fitting.status_text(f)}")
        e = (dependence or {}).get(name)
        if e and e["p_F"] is not None:
            lines.append(f"fit {name} per system ({', '.join(e['systems'])}): {e['verdict']} "
                         f"(F = {e['F']:.3g}, p_F = {e['p_F']:.2g})")
    items = all_fits(fits, per_system, boundary)
    for name, f in items[len(fits):]:
        if f["status"] in ("poor", "undetermined"):
            lines.append(f"fit {name}: {fitting.status_text(f)}")
    choice = (boundary or {}).get("prediction_law")
    if choice:
        lines.append(f"B/C law for the predictions: {choice['name'] or 'none'} "
                     f"({choice['reason']})")
    counts = status_counts(items)
    lines.append("fits: " + ", ".join(f"{n} {st}" for st, n in counts.items())
                 + " (fits.json, index.html)")
    return lines


def check_report_folder(campaign_dir, out_dir, campaign=None):
    """Raises ReportError when out_dir is no place for a report: a run's folder (a report's
    figures/ would replace the run's own), anywhere in the campaign's runs/ (a report there
    would be read as a run), a campaign's folder, this one or another (the report copies each
    run's figures to OUT/runs/RUN/, which there are run folders), or the report of another
    campaign than `campaign` (its fits.json names it), which would be replaced unseen."""
    default = os.path.join(campaign_dir, "report")
    runs = os.path.realpath(os.path.join(campaign_dir, "runs"))
    where = os.path.realpath(out_dir)
    if where == runs or where.startswith(runs + os.sep):
        raise ReportError(out_dir, f"is inside the campaign's runs folder ({runs}), where each "
                                   f"folder is a run's; choose another -o (default: {default})")
    if found := run_files_in(out_dir):
        raise ReportError(out_dir, f"holds a run's files ({', '.join(found)}): a report would "
                                   f"write over the run's figures; choose another -o")
    out_runs = os.path.join(out_dir, "runs")
    holds_runs = os.path.isdir(out_runs) and any(
        run_files_in(os.path.join(out_runs, name)) for name in os.listdir(out_runs)
        if os.path.isdir(os.path.join(out_runs, name)))
    if holds_runs or os.path.lexists(os.path.join(out_dir, "campaign.toml")):
        raise ReportError(out_dir, "is a campaign's folder (campaign.toml or run folders in "
                                   "runs/): the report's copies of the run figures would go into "
                                   f"its run folders; choose another -o (default: {default})")
    earlier = os.path.join(out_dir, "fits.json")
    if campaign is not None and os.path.isfile(earlier):
        try:
            other = read_json(earlier)
        except ReportError:
            other = None   # not readable: no report to tell apart, replaced as any output
        other = other.get("campaign") if isinstance(other, dict) else None
        if isinstance(other, str) and other != campaign:
            raise ReportError(out_dir, f"holds the report of campaign {other!r} (its fits.json), "
                                       f"not of {campaign!r}: it would be replaced; choose "
                                       f"another -o (default: {default}) or remove it first")


def write_report(report, out_dir):
    """runs.csv, runs.md, fits.json, figures/*.png and index.html in out_dir; returns their
    paths. Adds `printed_lines` to report["notes"], which `cdshear report` prints, and keeps them
    in report["printed"] (index.html gives them in its own sections, not as notes). With no run
    to report on, or where out_dir is no place for a report (check_report_folder), raises
    ReportError and writes nothing, so that a report written before stays."""
    check_report_folder(report["campaign_dir"], out_dir, report["campaign"])
    rows = report["rows"]
    if not rows:
        raise ReportError(os.path.join(report["campaign_dir"], "runs"),
                          f"no analysed run to report on (each left out with its reason); "
                          f"{out_dir} left as it was")
    # Every text is made before any file is written, and every file is written whole or not at
    # all (replace_atomically): a failure leaves an earlier report as it was, file by file.
    table = io.StringIO()
    cols = csv_columns(rows)
    w = csv.writer(table)
    w.writerow(cols)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in cols])
    markdown = runs_markdown(rows, report["campaign"])
    fits = fit_laws(rows)
    per_system = fit_laws_per_system(rows)
    dependence = system_dependence(rows)
    transitions = find_transitions(rows)
    boundary = fit_boundary(rows, FITS)
    preds = predictions(rows, fits, boundary, transitions)
    fits_text = json.dumps(
        {"format": REPORT_FORMAT, "version": REPORT_VERSION,
         "campaign": report["campaign"], "runs_analysed": len(rows),
         "runs_steady": sum(1 for r in rows if r["steady"]),
         "summary_format": summary_module.SUMMARY_FORMAT,
         "summary_version": summary_module.SUMMARY_VERSION,
         "reanalysed_runs": [{"run": n, "reason": why}
                             for n, why in report.get("reanalysed", [])],
         "excluded_runs": [{"run": n, "reason": why} for n, why in report["skipped"]],
         "fit_status_counts": status_counts(all_fits(fits, per_system, boundary)),
         "bulk_not_reference": [{"run": r["run"], "reason": r.get("bulk_h_note")}
                                for r in rows if r.get("bulk_h_reference") is not True],
         "software": report.get("software"), "fits": fits,
         "fits_per_system": per_system, "system_dependence": dependence,
         "boundary": boundary, "transitions": transitions, "predictions": preds},
        indent=1, allow_nan=False)

    # The runs' figures first: one that cannot be read is found (and left out) before any of
    # the report's own files is replaced.
    run_figures = copy_run_figures(report, out_dir)
    fig_dir = os.path.join(out_dir, "figures")
    os.makedirs(fig_dir, exist_ok=True)
    figures = write_figures(fig_dir, rows, fits, transitions, boundary, preds)
    page = _html(report, fits, figures, transitions, preds, boundary, run_figures, per_system,
                 dependence)
    paths = []
    for name, text in (("runs.csv", table.getvalue()), ("runs.md", markdown),
                       ("fits.json", fits_text)):
        paths.append(os.path.join(out_dir, name))
        write_text_atomically(paths[-1], text)
    paths += [os.path.join(fig_dir, f) for f in figures]
    index = os.path.join(out_dir, "index.html")
    write_text_atomically(index, page)
    paths.append(index)
    report["printed"] = printed_lines(report, fits, per_system, boundary, dependence)
    notes = report.setdefault("notes", [])
    notes += [n for n in report["printed"] if n not in notes]
    return paths

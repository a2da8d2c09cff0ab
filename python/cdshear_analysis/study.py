"""Parameter studies: many runs of one case that differ in one setting, compared with a reference.

A study folder holds one run folder per setting, named `KEY=VALUE` after the `--set` it was run
with (`solver.max_sweeps=50`, `step.dt=0.002`), and one named `reference` (the tightest
settings; more folders named `reference_<anything>` are further realizations of it, for example
with another solver seed, and are combined with it). Each must have been analysed
(`summary.json`) and hold `run_info.json` (and `run_info_resume_*.json` for each resumed part;
a run whose first sitting was killed has only the latter, and its cost is that of the sittings
they record).
`collect(study_dir)` reads them into rows; `write_study(rows, study_dir)` writes `study.csv`,
`study.md` (each quantity with its error bar, whether it agrees with the reference, and the
cost) and `figures/<quantity>.png` (the quantity against each setting, reference band shaded).

Agreement: |x - x_ref| <= 2 sqrt(err^2 + err_ref^2) (two combined standard errors, both from
the blocking analysis of `cdshear analyze`). The scripts/accuracy_study.sh script runs such a
study (docs/accuracy.md).
"""
import csv
import json
import math
import os

from .rundata import (IDENTITY_KEYS, MEASURED_MAGNITUDE_LIMIT, end_state, folder_case,
                      is_measured_number, is_number, open_regular, repeated_folder,
                      run_info_paths, save_figure, unique_keys)
from .statistics import time_weighted_mean, weighted_mean

# (name in the tables, how to read value and error from summary.json)
QUANTITIES = [
    ("mu_eff_wall", lambda s: s["mu_eff_wall"]),
    ("solid_fraction", lambda s: s["solid_fraction"]),
    ("height", lambda s: s["height"]),
    ("bulk_mu_eff", lambda s: s["bulk"]["mu_eff"]),
    ("bulk_solid_fraction", lambda s: s["bulk"]["solid_fraction"]),
    ("bulk_coordination", lambda s: s["bulk"]["coordination"]),
    ("bulk_inertial_number", lambda s: s["bulk"]["inertial_number"]),
    ("slip_bottom", lambda s: s["slip"]["bottom"]),
    ("slip_top", lambda s: s["slip"]["top"]),
]


class StudyError(Exception):
    def __init__(self, path, problem):
        super().__init__(f"{path}: {problem}")
        self.path = path
        self.problem = problem


def _read_json(path):
    try:
        with open_regular(path, encoding="utf-8") as f:
            return json.load(f, object_pairs_hook=unique_keys)
    except FileNotFoundError:
        raise StudyError(path, "missing (run `cdshear analyze` on the run first)") from None
    except (OSError, ValueError) as e:
        raise StudyError(path, f"cannot read: {e}") from None
    except RecursionError:
        raise StudyError(path, "cannot read: nested too deeply") from None


def _number(text):
    try:
        return float(text)
    except ValueError:
        return None


def averaged_time(summary):
    """The time a run's averages cover, from its summary.json: the time it reached minus
    `averaging_start_time` (NaN when either is missing). A realization's weight when
    realizations are combined (`combine`), and a seed's in a campaign's fits
    (fitting.combine, through report.read_run)."""
    case = summary.get("case") if isinstance(summary.get("case"), dict) else {}
    start = _number(str(summary.get("averaging_start_time")))
    reached = _number(str(case.get("time")))
    return reached - start if start is not None and reached is not None else math.nan


def read_run(run_dir, key, value):
    """One row: the setting, each quantity's mean and error, the solver figures and the cost."""
    summary = _read_json(os.path.join(run_dir, "summary.json"))
    paths = run_info_paths(run_dir)
    if not paths:
        raise StudyError(os.path.join(run_dir, "run_info.json"),
                         "missing, and no run_info_resume_*.json either: no sitting of the run "
                         "ended (`cdshear run --resume` it)")
    parts = [(path, _read_json(path)) for path in paths]
    try:
        return _row(run_dir, key, value, summary, parts)
    # a value of another JSON type, or an integer beyond any float (OverflowError)
    except (AttributeError, TypeError, ValueError, OverflowError) as e:
        raise StudyError(run_dir, f"summary.json or a run_info file holds a value of the wrong "
                                  f"type (not what `cdshear run` and `analyze` write): {e}") \
            from None


def folder_name_problem(key, text):
    """Why a run folder's name `KEY=TEXT` names no case setting, or None: KEY must be a dotted
    key of non-empty parts (`solver.max_sweeps`), and TEXT, when it reads as a number, a finite
    one (no case key takes nan or inf)."""
    if not key or not all(part and all(c.isalnum() or c in "_-" for c in part)
                          for part in key.split(".")):
        return f"{key!r} before '=' is not a case key (such as solver.max_sweeps)"
    value = _number(text)
    if value is not None and not math.isfinite(value):
        return f"{key} = {text}: not a finite number, which no case key takes"
    return None


def _case_toml(run_dir):
    """(path, parsed case.toml of the run) or (path, None) without one; StudyError when it
    cannot be read."""
    import tomllib
    path = os.path.join(run_dir, "case.toml")
    try:
        with open_regular(path, encoding="utf-8") as f:
            return path, tomllib.loads(f.read())
    except FileNotFoundError:
        return path, None
    except (OSError, ValueError, RecursionError) as e:
        raise StudyError(path, f"cannot read: {e}") from None


def setting_problem(run_dir, key, text):
    """Why the run in the folder `KEY=TEXT` does not hold KEY = TEXT in its case.toml (a run
    copied or renamed into the wrong folder, or a KEY misspelt: `cdshear run` writes every key
    of a case), or None; None too without a case.toml."""
    try:
        path, case = _case_toml(run_dir)
    except StudyError as e:
        return f"{e.path}: {e.problem}"
    if case is None:
        return None
    table, _, name = key.rpartition(".")
    values = case.get(table) if table else case
    if not isinstance(values, dict) or name not in values:
        return (f"{path}: holds no key {key} (misspelt?): the folder's name is the `--set` its "
                f"run was made with, KEY=VALUE, KEY a key of case.toml")
    held = values[name]
    if isinstance(held, bool):
        same = text.lower() == str(held).lower()
    elif isinstance(held, (int, float)):
        wanted = _number(text)
        same = wanted is not None and math.isclose(wanted, held, rel_tol=1e-12, abs_tol=0.0)
    elif isinstance(held, str):
        same = text == held
    else:
        return None
    if same:
        return None
    return f"{path}: {key} = {held!r}, not the folder's {text}: a run of another setting"


# The case values (summary.json `case` name, the case key that sets it) every run of a study
# shares with its reference, but for the setting its folder varies: a summary's identity
# (rundata.IDENTITY_KEYS) but its duration. A run of another system, wall speed, stress or start
# state, tabulated beside the reference, would read as the setting's effect.
SHARED_CASE = tuple((name, f"{table}.{key}") for name, table, key in IDENTITY_KEYS
                    if name != "duration")


def case_difference(row, reference, varied=None, reference_name=None):
    """Why the run of `row` is not of the reference's case (the first value of SHARED_CASE in
    which they differ), or None. The setting `varied` (a case key) and values that either
    summary lacks (summaries of an earlier cdshear hold no initial_velocity) are not compared.
    `reference_name` names the reference in the reason (default: its run folder's name)."""
    for name, key in SHARED_CASE:
        held, wanted = row["case"].get(name), reference["case"].get(name)
        if key == varied or held is None or wanted is None:
            continue
        if is_number(held) and is_number(wanted):
            try:
                same = math.isclose(held, wanted, rel_tol=1e-12, abs_tol=0.0)
            except OverflowError:   # an integer beyond any float: equal only to itself
                same = held == wanted
        else:
            same = held == wanted
        if not same:
            name = reference_name or reference["run"]
            return f"{key} = {held!r} where the reference ({name}) has {wanted!r}: " \
                   f"a run of another case"
    return None


# case.toml's tables whose every key changes what a run's quantities mean: two runs analysed
# with other windows, stripes or contact gaps measure other things, whatever the solver.
_MEASURE_TABLE = "measure"


def measure_difference(run_dir, reference_dir, varied=None):
    """Why the run in run_dir was measured otherwise than the one in reference_dir (the first key
    of case.toml's [measure] that both hold with other values, but `varied`), or None; None too
    where either has no case.toml or one that cannot be read (a realization's run.h5 holds its
    own copy; a setting's row is refused for it by setting_problem)."""
    case, reference = folder_case(run_dir), folder_case(reference_dir)
    if case is None or reference is None:
        return None
    reference_path = os.path.join(reference_dir, "case.toml")
    mine, theirs = case.get(_MEASURE_TABLE), reference.get(_MEASURE_TABLE)
    if not isinstance(mine, dict) or not isinstance(theirs, dict):
        return None
    for name in sorted(set(mine) & set(theirs)):
        key = f"{_MEASURE_TABLE}.{name}"
        if key != varied and mine[name] != theirs[name]:
            return (f"{key} = {mine[name]!r} where {reference_path} has {theirs[name]!r}: "
                    f"its quantities are measured otherwise")
    return None


def _row(run_dir, key, value, summary, parts):
    for path, data in [(os.path.join(run_dir, "summary.json"), summary)] + parts:
        if not isinstance(data, dict):
            raise StudyError(path, "is not a JSON object")
    case = summary.get("case", {})
    row = {"key": key, "value": value, "run": os.path.basename(run_dir),
           "steady": summary.get("steady") is True,   # "false" (a text) is not steady
           "case": {name: case[name] for name, _ in SHARED_CASE if name in case},
           "time": float(case["time"]) if is_measured_number(case.get("time")) else math.nan}
    for name, get in QUANTITIES:
        try:
            entry = get(summary)
            mean, err = entry["mean"], entry["err"]
        except (KeyError, TypeError):
            mean = err = None
        # what `analyze` writes: a finite mean and an error >= 0 (null where it has none)
        if is_measured_number(mean) and is_measured_number(err) and err >= 0:
            row[name], row[name + "_err"] = float(mean), float(err)
        else:
            row[name] = row[name + "_err"] = math.nan
    # the scatter of the centre of mass's velocity: a finite number >= 0 (null where NaN)
    com = summary.get("com_vx") or {}
    path = os.path.join(run_dir, "summary.json")
    if not isinstance(com, dict):
        raise StudyError(path, "com_vx is not an object")
    std = com.get("std")
    if std is not None and not (is_measured_number(std) and std >= 0):
        raise StudyError(path, f"com_vx.std is {repr(std)[:40]}: it must be a finite "
                               f"number >= 0")
    row["com_vx_std"] = float(std) if std is not None else math.nan
    cost = run_cost(parts)
    row["mean_sweeps"] = cost["mean_sweeps"]
    row["capped_share"] = cost["capped_steps"] / cost["steps"] if cost["steps"] else math.nan
    row["largest_overlap"] = cost["largest_overlap"]
    covered = cost["simulated_time"]   # NaN where a record lacks dt: the summary's time then
    if not covered > 0:
        covered = float(summary.get("case", {}).get("time", math.nan))
    row["wall_s_per_time"] = cost["wall_seconds"] / covered if covered > 0 else math.nan
    row["averaged_time"] = averaged_time(summary)   # its weight in `combine`
    return row


# The solver figures of a run_info file's summary that the study's table sums; `cdshear run` writes
# each as a number >= 0 (the counts whole), with no more capped steps than steps.
_RUN_FIGURES = (("steps", True), ("capped_steps", True), ("mean_sweeps", False),
                ("wall_seconds", False), ("largest_overlap", False))


def _is_run_figure(value, whole):
    return is_measured_number(value) and value >= 0 and (not whole or float(value).is_integer())


def _check_run_figures(path, data):
    """Refuses (StudyError naming the file and key) a run_info file whose figures are not what
    `cdshear run` writes: a missing, negative, non-finite or textual value would enter the table's
    sums as a number or as zero."""
    figures = data.get("summary")
    if not isinstance(figures, dict):
        raise StudyError(path, "has no 'summary' object (not a run_info file `cdshear run` wrote)")
    for key, whole in _RUN_FIGURES:
        value = figures.get(key)
        if not _is_run_figure(value, whole):
            shown = json.dumps(value)
            shown = shown if len(shown) <= 40 else shown[:37] + "..."
            kind = "a whole number" if whole else "a number"
            raise StudyError(path, f"summary.{key} = {shown}: expected {kind} from 0 to "
                                   f"{MEASURED_MAGNITUDE_LIMIT:g} (what `cdshear run` writes)")
    if figures["capped_steps"] > figures["steps"]:
        raise StudyError(path, f"summary.capped_steps = {figures['capped_steps']} is more than "
                               f"summary.steps = {figures['steps']}")


def run_cost(parts):
    """The solver figures and the wall time of a run over its recorded sittings ((path, parsed
    run_info file) pairs, rundata.run_info_paths), each of which reports only the steps it ran;
    each record's figures checked first (_check_run_figures). Mean sweeps are weighted by steps;
    simulated_time is the sum of steps times dt (NaN where a record gives no dt)."""
    steps = capped = sweeps = wall = simulated = 0.0
    overlap = math.nan
    for path, part in parts:
        _check_run_figures(path, part)
        p = part["summary"]
        n = float(p["steps"])
        steps += n
        capped += float(p["capped_steps"])
        sweeps += n * float(p["mean_sweeps"])
        wall += float(p["wall_seconds"])
        dt = part.get("dt")
        simulated += n * float(dt) if is_number(dt) else math.nan
        o = float(p["largest_overlap"])
        overlap = o if math.isnan(overlap) else max(overlap, o)
    return {"steps": steps, "capped_steps": capped, "wall_seconds": wall,
            "simulated_time": simulated,
            "mean_sweeps": sweeps / steps if steps else math.nan, "largest_overlap": overlap}


def combine(rows):
    """One row from independent realizations of the same setting: steady only when every
    realization is; the solver figures are weighted by each realization's share. Each quantity
    is a weighted mean of the realizations' averages, its error the larger of the error the
    realizations' own error bars give it and the error of that mean from their scatter about it.
    The weights are the times the averages cover (`averaged_time`), the variance of a time
    average being inversely proportional to its length: equal weights for realizations of one
    length, whatever their error bars. Those error bars are estimates themselves (14 to 20%
    apart between ten 3000-t seeds of system 1) and correlated with the value (-0.75 to +0.61
    between a seed's bulk inertial number or slip and its error bar), so weighting by them
    (1/err^2) moved an ensemble's mean by up to one of its standard errors, one way or the
    other (docs/accuracy.md, "Effect on the averaged quantities"). Where a realization does not
    say what time it covers, the weights are 1/err^2 (statistics.weighted_mean)."""
    if len(rows) == 1:
        return rows[0]
    out = dict(rows[0])
    out["run"] = "+".join(r["run"] for r in rows)
    out["steady"] = all(r["steady"] for r in rows)
    out["realizations"] = len(rows)
    for name, _ in QUANTITIES:
        kept = [r for r in rows if math.isfinite(r[name]) and math.isfinite(r[name + "_err"]) and
                r[name + "_err"] > 0]
        out[name + "_realizations"] = len(kept)   # those whose value the mean holds
        if not kept:
            out[name] = out[name + "_err"] = math.nan
            continue
        values = [r[name] for r in kept]
        errs = [r[name + "_err"] for r in kept]
        times = [r.get("averaged_time", math.nan) for r in kept]
        if all(math.isfinite(t) and t > 0 for t in times):
            mean, err, scatter = time_weighted_mean(values, errs, times)
        else:
            mean, err, scatter = weighted_mean(values, errs)
        if len(kept) > 1:
            # Short runs underestimate their own errors; the realizations' scatter about the
            # weighted mean is a floor that does not depend on the blocking.
            err = max(err, scatter)
        out[name] = mean
        out[name + "_err"] = err
    for name in ("com_vx_std", "mean_sweeps", "capped_share", "wall_s_per_time"):
        out[name] = sum(r[name] for r in rows) / len(rows)
    out["largest_overlap"] = max(r["largest_overlap"] for r in rows)
    return out


def _is_reference(name):
    """A realization of the reference: `reference` or `reference_<anything>`."""
    return name == "reference" or name.startswith("reference_")


def _references(study_dir, skipped):
    """The rows of a study folder's realizations of the reference (`reference`,
    `reference_<anything>` with summary.json), one each, not combined; the folders without
    summary.json are named in `skipped` (a list, or None). StudyError when the folder is not
    one or holds no analysed realization."""
    if not os.path.isdir(study_dir):
        raise StudyError(study_dir, "not a folder")
    rows = []
    for name in sorted(os.listdir(study_dir)):
        path = os.path.join(study_dir, name)
        if not os.path.isdir(path) or not _is_reference(name):
            continue
        if not os.path.exists(os.path.join(path, "summary.json")):
            if skipped is not None:
                skipped.append(name)
            continue
        rows.append(read_run(path, None, None))
    if not rows:
        raise StudyError(study_dir, "no analysed `reference` run folder")
    if repeated := repeated_folder([os.path.join(study_dir, row["run"]) for row in rows]):
        raise StudyError(study_dir, f"realizations of the reference: {repeated}")
    first = os.path.join(study_dir, rows[0]["run"])
    for row in rows[1:]:
        path = os.path.join(study_dir, row["run"])
        if why := case_difference(row, rows[0]) or measure_difference(path, first):
            raise StudyError(path, why)
    return rows


def collect(study_dir, skipped=None):
    """Rows of every `KEY=VALUE` run and the `reference` run (key None) of a study folder. A run
    folder without summary.json (still running, or not analysed) is left out and named in
    `skipped` (a list, when given), so that a study can be tabulated while it runs."""
    references = _references(study_dir, skipped)
    rows = []
    for name in sorted(os.listdir(study_dir)):
        path = os.path.join(study_dir, name)
        if not os.path.isdir(path) or _is_reference(name) or "=" not in name:
            continue
        if not os.path.exists(os.path.join(path, "summary.json")):
            if skipped is not None:
                skipped.append(name)
            continue
        key, text = name.split("=", 1)
        if why := folder_name_problem(key, text):
            raise StudyError(path, why)
        if why := setting_problem(path, key, text):
            raise StudyError(path, why)
        value = _number(text)
        row = read_run(path, key, value if value is not None else text)
        if why := (case_difference(row, references[0], varied=key) or
                   measure_difference(path, os.path.join(study_dir, references[0]["run"]),
                                      varied=key)):
            raise StudyError(path, why)
        rows.append(row)
    return [combine(references)] + rows


def welch_p(values_a, values_b):
    """Two-sided p-value of Welch's t-test (unequal variances) that two sets of realizations
    have the same mean, from their values alone (scipy.stats.ttest_ind, equal_var=False): the
    chance that identical physics gives a difference at least this large. Unweighted: where the
    realizations' averages cover different times it tests their plain means, not the
    time-weighted ones of the table (`combine`), so the two columns can disagree a little. NaN
    when a set has fewer than 2 finite values or neither scatters."""
    from scipy import stats
    a = [v for v in values_a if math.isfinite(v)]
    b = [v for v in values_b if math.isfinite(v)]
    if len(a) < 2 or len(b) < 2 or (max(a) == min(a) and max(b) == min(b)):
        return math.nan
    return float(stats.ttest_ind(a, b, equal_var=False).pvalue)


def shared_realization(dirs_a, dirs_b):
    """Why a realization of dirs_b is one of dirs_a (the same folder by another path or a link,
    or a copy: the same end state, case.toml and build), or None."""
    from .report import shared_end
    places = {os.path.realpath(d): d for d in dirs_a}
    ends = {}
    for d in dirs_a:
        if (state := end_state(d)) is not None:
            ends.setdefault(state, d)
    for d in dirs_b:
        if (mine := places.get(os.path.realpath(d))) is not None:
            return f"{d} is {mine} again"
        state = end_state(d)
        if (theirs := ends.get(state)) is not None and state is not None and \
                shared_end(theirs, d, state, state) == "copy":
            return (f"{d} is a copy of {theirs} (both end at step {state[0]} in state {state[1]} "
                    f"from the same case.toml and build)")
    return None


def compare_references(dir_a, dir_b):
    """Two builds or settings, each a study folder of realizations (`reference`,
    `reference_seed2`, ...: the same case with other solver seeds), compared as in
    docs/accuracy-methods.md, "Seed ensembles": each folder's runs combined (`combine`), then for
    every quantity the two means, their errors, the difference b - a in combined errors,
    (b - a) / sqrt(err_a^2 + err_b^2), and Welch's p-value from the realizations' values
    (`welch_p`). Returns (combined row a, combined row b, lines, skipped), each line (quantity,
    a, err_a, b, err_b, difference in combined errors (NaN when both errors are 0 or missing),
    p (NaN with fewer than two realizations on a side)), skipped the run folders left out (no
    summary.json yet) as paths. A folder compared with itself, one realization in both, and
    realizations measured otherwise (case.toml's [measure]) are refused; the combined rows hold
    their realizations' times reached ("times"), which format_comparison compares."""
    if os.path.realpath(dir_a) == os.path.realpath(dir_b):
        raise StudyError(dir_b, f"is {dir_a} again: a folder compared with itself differs by "
                                f"nothing")
    skipped_a, skipped_b = [], []
    runs_a, runs_b = _references(dir_a, skipped_a), _references(dir_b, skipped_b)
    reference_a = os.path.join(dir_a, runs_a[0]["run"])
    reference_b = os.path.join(dir_b, runs_b[0]["run"])
    if why := (case_difference(runs_b[0], runs_a[0], reference_name=reference_a) or
               measure_difference(reference_b, reference_a)):
        raise StudyError(reference_b, why)
    # one run in both folders (a link, or a copy: the same end state from the same case.toml and
    # build) would be compared with itself; the same end state from another build or case is
    # two builds computing one flow, what study-compare is for
    if why := shared_realization([os.path.join(dir_a, r["run"]) for r in runs_a],
                                 [os.path.join(dir_b, r["run"]) for r in runs_b]):
        raise StudyError(dir_b, f"shares a realization with {dir_a}: {why}")
    a, b = combine(runs_a), combine(runs_b)
    a["times"], b["times"] = [r["time"] for r in runs_a], [r["time"] for r in runs_b]
    skipped = ([os.path.join(dir_a, n) for n in skipped_a] +
               [os.path.join(dir_b, n) for n in skipped_b])
    lines = []
    for name, _ in QUANTITIES:
        ea, eb = a[name + "_err"], b[name + "_err"]
        scale = math.hypot(ea, eb)
        diff = (b[name] - a[name]) / scale if scale > 0 else math.nan
        p = welch_p([r[name] for r in runs_a], [r[name] for r in runs_b])
        lines.append((name, a[name], ea, b[name], eb, diff, p))
    return a, b, lines, skipped


def counted(k, noun):
    """k and the noun, plural unless k is 1: counted(1, "run") is "1 run", counted(3, "run")
    "3 runs" (the tables of this module and report.py)."""
    return f"{k} {noun}" if k == 1 else f"{k} {noun}s"


def _part(k, n):
    """" (k of n runs)" where a combined quantity holds the values of k realizations of n (the
    others' were left out: not finite, or without an error above 0), else ""."""
    return f" ({k} of {counted(n, 'run')})" if k < n else ""


def format_comparison(dir_a, dir_b, a, b, lines, skipped=()):
    """The comparison as a Markdown table, a quantity that `agrees` finds apart (more than two
    combined errors) marked "(differs)" as in study.md, Welch's p-value of each quantity, the
    solver figures (sweeps, capped steps, wall time per time unit: means over the realizations)
    after the quantities, and how to read the p-values of several quantities at once."""
    na, nb = a.get("realizations", 1), b.get("realizations", 1)
    out = [f"| quantity | {dir_a} ({counted(na, 'run')}) | {dir_b} ({counted(nb, 'run')}) | "
           "difference / combined error | Welch p |", "|---|---|---|---|---|"]
    for name, xa, ea, xb, eb, diff, p in lines:
        if math.isnan(diff):
            text = "n/a (no error)"
        else:
            text = f"{diff:+.2f}" + (" (differs)" if agrees(b, a, name) is False else "")
        p_text = "n/a" if math.isnan(p) else f"{p:.2g}"
        cells = [f"{x:.5g} ± {e:.2g}" + _part(row.get(name + "_realizations", n), n)
                 for x, e, row, n in ((xa, ea, a, na), (xb, eb, b, nb))]
        out.append(f"| {name} | {cells[0]} | {cells[1]} | {text} | {p_text} |")
    for name, fmt in (("mean_sweeps", "{:.1f}"), ("capped_share", "{:.2%}"),
                      ("wall_s_per_time", "{:.4f}")):
        out.append(f"| {name} | {fmt.format(a[name])} | {fmt.format(b[name])} | | |")
    steady = lambda r: "all steady" if r["steady"] else "not all steady"  # noqa: E731
    out.append(f"| steady | {steady(a)} | {steady(b)} | | |")
    if any(not math.isnan(line[6]) for line in lines):
        n = len(lines)
        out.append(f"\nWelch p: the chance that identical physics gives a difference this large "
                   f"(Welch's t-test on the realizations' values). Over {n} quantities, "
                   f"identical physics puts one or more below 0.05 up to "
                   f"{1 - 0.95 ** n:.0%} of the time; below {0.05 / n:.2g} "
                   f"(0.05 / {n}, Bonferroni), at most 5% of the time.")
    out += [f"left out {path}: no summary.json yet" for path in skipped]
    times_a = [t for t in a.get("times", []) if math.isfinite(t)]
    times_b = [t for t in b.get("times", []) if math.isfinite(t)]
    if times_a and times_b and not all(
            math.isclose(x, y, rel_tol=1e-9) for x, y in ((min(times_a), min(times_b)),
                                                          (max(times_a), max(times_b)))):
        shown = lambda ts: ", ".join(f"{t:g}" for t in sorted(set(ts)))  # noqa: E731
        out.append(f"note: the realizations stand at t = {shown(times_a)} in {dir_a} and "
                   f"{shown(times_b)} in {dir_b}: their averages cover different stretches of "
                   f"the flow")
    return "\n".join(out) + "\n"


WINDOW_QUANTITIES = ("solid_fraction", "mu_eff_wall")


def _realization_series(run_dir):
    """(time, {quantity: per-sample values}) of one realization's run.h5: the solid fraction and
    the walls' friction per sample, (|bottom_fx| + |top_fx|) / (|bottom_fy| + |top_fy|)
    (summary.wall_friction_series, the steady-state signal). Its window means are what
    docs/accuracy.md compares between builds; they sit a little below the ratio of the
    time-averaged forces that `cdshear analyze` reports as mu_eff_wall (the mean of a ratio of
    fluctuating forces is biased), the same way for every build."""
    import h5py
    import numpy as np

    from .rundata import RunDataError, check_seal
    from .summary import wall_friction_series
    path = os.path.join(run_dir, "run.h5")
    if not os.path.lexists(path):
        raise StudyError(path, "missing")
    try:   # a regular file whose seal matches, before HDF5 opens it (as `analyze` checks it)
        check_seal(path)
        with h5py.File(path, "r") as f:
            series = {key: np.asarray(f["series"][key], dtype=float) for key in
                      ("time", "solid_fraction", "bottom_fx", "top_fx", "bottom_fy", "top_fy")}
    except RunDataError as e:
        raise StudyError(e.path, e.problem) from None
    except (OSError, KeyError, ValueError, TypeError) as e:
        raise StudyError(path, f"cannot read its series: {e}") from None
    uneven = [k for k, v in series.items() if v.shape != series["time"].shape]
    if series["time"].ndim != 1 or uneven:
        raise StudyError(path, "its series are not one-dimensional and of time's length: "
                               + ", ".join(uneven or ["time"]))
    return series["time"], {"solid_fraction": series["solid_fraction"],
                            "mu_eff_wall": wall_friction_series(series)}


def windowed_means(study_dir, windows, until=None):
    """How the realizations of a study folder (`reference`, `reference_<anything>` with
    summary.json, as `collect` takes them) move over time: [0, t_end] (t_end the end of the
    shortest one) cut into `windows` equal windows, and for each quantity of WINDOW_QUANTITIES
    and each window the mean over the realizations of their window means, with its error from
    their scatter, std / sqrt(k) (NaN for one realization). Shows whether a flow is still
    drifting, and whether two builds differ by a constant or by a rate (docs/accuracy.md,
    "System 1, V = 0.05"). `until`: t_end at most this (the end of another folder compared with
    this one). Returns (edges, k, {quantity: [(mean, err) per window]})."""
    import numpy as np
    if windows < 1:
        raise StudyError(study_dir, f"--windows must be at least 1, not {windows}")
    names = [n for n in sorted(os.listdir(study_dir)) if
             _is_reference(n) and os.path.exists(os.path.join(study_dir, n, "summary.json"))]
    if not names:
        raise StudyError(study_dir, "no analysed `reference` run folder")
    runs = [_realization_series(os.path.join(study_dir, n)) for n in names]
    t_end = min(float(t[-1]) if t.size else 0.0 for t, _ in runs)
    if until is not None:
        t_end = min(t_end, until)
    if t_end <= 0.0:
        raise StudyError(study_dir, "a realization has no samples")
    fewest = min(int(np.count_nonzero(t <= t_end)) for t, _ in runs)
    if windows > fewest:
        raise StudyError(study_dir, f"--windows {windows}: more windows than the "
                                    f"{fewest} samples of a realization up to t = {t_end:g}")
    edges = np.linspace(0.0, t_end, windows + 1)
    out = {}
    for quantity in WINDOW_QUANTITIES:
        per_run = []
        for time, values in runs:
            inside = [(time > lo) & (time <= hi) for lo, hi in zip(edges[:-1], edges[1:])]
            per_run.append([float(np.nanmean(values[quantity][m])) if m.any() else math.nan
                            for m in inside])
        per_run = np.array(per_run)
        k = len(runs)
        with np.errstate(invalid="ignore"):
            means = np.nanmean(per_run, axis=0)
            errs = (np.std(per_run, axis=0, ddof=1) / math.sqrt(k) if k > 1 else
                    np.full(windows, math.nan))
        out[quantity] = [(float(m), float(e)) for m, e in zip(means, errs)]
    return edges, len(runs), out


def common_windows(dir_a, dir_b, windows):
    """windowed_means of both folders over one [0, t_end], t_end the end of the shorter of the
    two (each folder's shortest realization), so that a window's row holds the same stretch of
    time in both."""
    a, b = windowed_means(dir_a, windows), windowed_means(dir_b, windows)
    end = min(a[0][-1], b[0][-1])
    if a[0][-1] > end:
        a = windowed_means(dir_a, windows, until=end)
    if b[0][-1] > end:
        b = windowed_means(dir_b, windows, until=end)
    return a, b


def format_windows(dir_a, dir_b, a, b):
    """Both folders' windowed means side by side (Markdown), each window's difference b - a in
    combined errors, and each folder's drift, last window minus first in combined errors; a and
    b cut into the same windows (common_windows)."""
    edges, ka, qa = a
    edges_b, kb, qb = b
    if list(edges) != list(edges_b):
        raise ValueError("format_windows: the two folders' windows differ (common_windows)")
    diff = lambda x, ex, y, ey: ((y - x) / math.hypot(ex, ey)  # noqa: E731
                                 if math.hypot(ex, ey) > 0 else math.nan)
    # one realization has no scatter, hence no error: said so, where "± nan" stood
    pm = lambda x, e: f"{x:.5g} ± {e:.2g}" if math.isfinite(e) else f"{x:.5g} (no error)"  # noqa
    in_errors = lambda d: f"{d:+.2f}" if math.isfinite(d) else "n/a"  # noqa: E731
    out = []
    for quantity in WINDOW_QUANTITIES:
        out += ["", f"| {quantity}, time window | {dir_a} ({counted(ka, 'run')}) | "
                f"{dir_b} ({counted(kb, 'run')}) | "
                "difference / combined error |", "|---|---|---|---|"]
        for i, ((xa, ea), (xb, eb)) in enumerate(zip(qa[quantity], qb[quantity])):
            out.append(f"| {edges[i]:.6g} to {edges[i + 1]:.6g} | {pm(xa, ea)} | "
                       f"{pm(xb, eb)} | {in_errors(diff(xa, ea, xb, eb))} |")
        for name, series in ((dir_a, qa[quantity]), (dir_b, qb[quantity])):
            if len(series) < 2:
                continue   # one window: no drift to show
            (x0, e0), (x1, e1) = series[0], series[-1]
            out.append(f"drift of {quantity} in {name}, last window - first: {x1 - x0:+.4g} "
                       f"({in_errors(diff(x0, e0, x1, e1))} combined errors)")
    if min(ka, kb) < 2:
        out += ["", "A folder of one realization has no error: its windows' scatter between "
                "realizations is what gives one."]
    return "\n".join(out) + "\n"


def agrees(row, ref, name):
    """True when the row's value is within two combined standard errors of the reference's."""
    x, e, xr, er = row[name], row[name + "_err"], ref[name], ref[name + "_err"]
    if any(math.isnan(v) for v in (x, e, xr, er)):
        return None
    return abs(x - xr) <= 2.0 * math.hypot(e, er)


def _text(value):
    """A setting as it was written: 25, not 25.0; 1e-06 stays as Python prints it."""
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return str(value)


def _sort_key(row):
    v = row["value"]
    return (0, v, "") if isinstance(v, float) else (1, 0.0, str(v))


def write_study(rows, study_dir):
    """Writes study.csv, study.md and figures/; returns their paths."""
    ref = next(r for r in rows if r["key"] is None)
    columns = ["key", "value", "run", "realizations", "steady"]
    for name, _ in QUANTITIES:
        columns += [name, name + "_err", name + "_agrees"]
    columns += ["com_vx_std", "mean_sweeps", "capped_share", "largest_overlap", "wall_s_per_time"]
    csv_path = os.path.join(study_dir, "study.csv")
    with open(csv_path, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=columns)
        w.writeheader()
        for r in rows:
            out = dict(r)
            out.setdefault("realizations", 1)
            for name, _ in QUANTITIES:
                out[name + "_agrees"] = agrees(r, ref, name)
            w.writerow({c: out.get(c) for c in columns})

    md_path = os.path.join(study_dir, "study.md")
    keys = sorted({r["key"] for r in rows if r["key"] is not None})
    shown = ["mu_eff_wall", "solid_fraction", "bulk_mu_eff", "bulk_coordination", "slip_bottom"]
    with open(md_path, "w", encoding="utf-8") as f:
        head = " | ".join(shown)
        f.write(f"| setting | steady | {head} | sweeps | capped | s per t |\n")
        f.write("|---" * (len(shown) + 5) + "|\n")
        for r in [ref] + [r for k in keys for r in sorted(
                (x for x in rows if x["key"] == k), key=_sort_key)]:
            label = f"{r['key']}={_text(r['value'])}"
            if r["key"] is None:
                n = r.get("realizations", 1)
                label = "reference" if n == 1 else f"reference ({n} runs combined)"
            cells = []
            for name in shown:
                if not math.isfinite(r[name]):   # left out (not measured, or not a number)
                    cells.append("n/a")
                    continue
                ok = agrees(r, ref, name) if r is not ref else True
                mark = "" if ok in (True, None) else " (differs)"
                part = _part(r.get(name + "_realizations", 1), r.get("realizations", 1))
                cells.append(f"{r[name]:.4f} ± {r[name + '_err']:.4f}{part}{mark}")
            steady = "yes" if r["steady"] else "no"
            f.write(f"| {label} | {steady} | " + " | ".join(cells) +
                    f" | {r['mean_sweeps']:.0f} | {100 * r['capped_share']:.0f}% |"
                    f" {r['wall_s_per_time']:.2f} |\n")

    fig_dir = os.path.join(study_dir, "figures")
    os.makedirs(fig_dir, exist_ok=True)
    figures = []
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    for name, _ in QUANTITIES:
        if not keys:
            break
        # At least 4.5 inches wide: one panel of 3.2 cut the title off on both sides.
        fig, axes = plt.subplots(1, len(keys), figsize=(max(4.5, 3.2 * len(keys)), 3.2),
                                 squeeze=False)
        for ax, key in zip(axes[0], keys):
            sel = sorted((r for r in rows if r["key"] == key and math.isfinite(r[name])),
                         key=_sort_key)
            ax.set_xlabel(key)
            ax.set_ylabel(name)
            if not sel:  # too short a run to measure it: an empty panel says so
                ax.set_title("no values", fontsize=9)
                continue
            numeric = all(isinstance(r["value"], float) for r in sel)
            xs = [r["value"] if numeric else i for i, r in enumerate(sel)]
            ax.errorbar(xs, [r[name] for r in sel], yerr=[r[name + "_err"] for r in sel],
                        fmt="o", capsize=3)
            lo, hi = ref[name] - ref[name + "_err"], ref[name] + ref[name + "_err"]
            if math.isfinite(lo) and math.isfinite(hi):
                ax.axhspan(lo, hi, color="0.85", label="reference ± err")
            if numeric and min(xs) > 0 and max(xs) / min(xs) >= 10:
                ax.set_xscale("log")
            if not numeric:
                ax.set_xticks(xs, [str(r["value"]) for r in sel], rotation=20, fontsize=7,
                              ha="right")
        fig.suptitle(f"{name} (mean ± standard error)\ngrey: reference ± its error", fontsize=9)
        fig.tight_layout()
        path = os.path.join(fig_dir, f"{name}.png")
        save_figure(fig, path, dpi=100)
        plt.close(fig)
        figures.append(path)
    return [csv_path, md_path] + figures

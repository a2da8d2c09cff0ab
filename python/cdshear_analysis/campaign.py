"""A campaign folder (`cdshear sweep`) for notebooks: `load_campaign(dir)`.

    from cdshear_analysis import load_campaign
    c = load_campaign("campaigns/validation")
    c.columns["I_bulk"], c.columns["mu_eff_bulk"]     # numpy arrays, one entry per analysed run
    c.frame()                                          # the same as a pandas DataFrame

The table is the one `cdshear report` writes to runs.csv (docs/reports.md names
every column), read from each run's summary.json. Loading never writes: a run whose summary.json
is of an older version is left out (listed in `skipped`), where `cdshear report` would analyse
it again from run.h5.
"""
import filecmp
import math
import os
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import t as student_t

from .report import RUN_NAME, collect, csv_columns, shared_end
from .rundata import end_state, folder_case, is_number


@dataclass
class Campaign:
    """The analysed runs of a campaign folder.

    name: the campaign's name (campaign.toml, or the folder's name).
    folder: the folder it was read from.
    rows: one dict per analysed run (the runs.csv columns, plus `_`-prefixed extras the report
        uses: profiles, switches, layers).
    columns: {runs.csv column: numpy array over the rows}; numbers as float (NaN where a run has
        no value), text and flags as object arrays.
    skipped: [(run, reason)] for every run left out (not started, still running, stopped, not
        analysed, stale).
    notes: the report's notes on the campaign's file (campaign.toml missing, or without a name);
        its notes on the runs (unfinished, copies in runs/) are for a report, which pools them.
    listed: the run names its campaign.toml lists (none without the file).
    """
    name: str
    folder: str
    rows: list
    columns: dict = field(default_factory=dict)
    skipped: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    listed: list = field(default_factory=list)

    def frame(self):
        """The runs table as a pandas DataFrame (pandas is optional: Debian's python3-pandas)."""
        try:
            import pandas
        except ImportError as e:
            raise ImportError("Campaign.frame() needs pandas (apt-get install python3-pandas); "
                              "Campaign.columns holds the same table as numpy arrays") from e
        return pandas.DataFrame({k: v for k, v in self.columns.items()})

    def select(self, **criteria):
        """The rows whose columns equal the given values: c.select(system=2, regime="A")."""
        return [r for r in self.rows if all(r.get(k) == v for k, v in criteria.items())]


def _column(values):
    """A float array when every value is a number or missing, else an object array."""
    if all(v is None or is_number(v) for v in values):
        return np.array([np.nan if v is None else float(v) for v in values], dtype=float)
    return np.array(values, dtype=object)


def load_campaign(folder, until=None):
    """Reads the analysed runs of a campaign folder (DIR/campaign.toml, DIR/runs/*/summary.json)
    into a Campaign. With `until` (a time [t]), each run is analysed again from its run.h5 as it
    stood at that time (report.summary_until; runs that have not reached it are left out), to
    compare campaigns over the same stretch of time. Raises report.ReportError for a folder that
    is not a campaign's."""
    report = collect(folder, reanalyse_stale=False, until=until)
    rows = report["rows"]
    columns = {c: _column([r.get(c) for r in rows]) for c in csv_columns(rows)}
    return Campaign(name=report["campaign"], folder=folder, rows=rows, columns=columns,
                    skipped=list(report["skipped"]), notes=list(report["campaign_notes"]),
                    listed=report["listed"])


# The quantities compared between two campaigns (runs.csv columns X, with their standard errors
# X_err where the runs give one: com_vx_std has none): the averages a setting could move.
COMPARED = ("mu_eff_wall", "mu_eff_bulk", "nu_bulk", "Z_bulk", "I_bulk", "L_y", "slip_bottom",
            "slip_top", "h10_bottom_mu_eff", "h10_bottom_nu", "h10_bottom_I", "com_vx",
            "com_vx_std")


# The case values besides V and n that a run and its namesake must share to be compared: the
# row's key and the summary's name for it (report.read_run).
CASE_KEYS = (("_sigma_yy", "normal_stress"), ("_height", "height"),
             ("_initial_velocity", "initial_velocity"))


def compare_campaigns(a, b, quantities=COMPARED, until=None):
    """The runs of campaign b that campaign a has too (the same run name: system, seed, V),
    compared quantity by quantity: a list of {"run", "system", "V", "time_a", "time_b" (the times
    the two analyses reached), "regime_a", "regime_b", "<q>": {"a", "b", "diff" (b - a),
    "combined_errors" ((b - a) / sqrt(err_a^2 + err_b^2), NaN where an error is missing)}}. A run
    whose two cases differ in V, the number of disks, the normal stress, the height or the
    initial velocity (the last three where both rows hold them), whose two folders are one or
    hold a copy of one run (both end in the same state, from the same case.toml and build), or
    that is a second folder of a system, seed and V already compared (a copy kept beside the run
    in both runs/; of two such folders the one b's campaign.toml lists, else one whose name reads
    as a run's, is compared), is not compared: its item holds "mismatch" (the reason) and no
    quantity; the items keep b's row order. A run
    that ends in the same state in both from other cases or builds (a setting or a build that
    changes nothing there) is compared, its item marked "one_flow". a and b are Campaign objects
    or folders; folders are read with `until` (load_campaign)."""
    a = a if isinstance(a, Campaign) else load_campaign(a, until)
    b = b if isinstance(b, Campaign) else load_campaign(b, until)
    by_name = {r["run"]: r for r in a.rows}
    out = []   # (b's row index, item)
    compared = {}   # (system, seed, V) -> the run compared for it
    # the listed folder of a seed first, so that its copies are the ones left out
    for index, rb in sorted(enumerate(b.rows), key=lambda p: _copy_rank(p[1]["run"], b.listed)):
        ra = by_name.get(rb["run"])
        if ra is None:
            continue
        item = {"run": rb["run"], "system": rb.get("system"), "V": rb.get("V"),
                "time_a": ra.get("time_reached"), "time_b": rb.get("time_reached"),
                "regime_a": ra.get("regime"), "regime_b": rb.get("regime")}
        differ = [f"{key} {ra.get(key)} in a, {rb.get(key)} in b" for key in ("V", "n")
                  if ra.get(key) != rb.get(key)]
        # compared where both summaries hold them (not a LAMMPS run's row, nor an older summary)
        differ += [f"{name} {ra[key]} in a, {rb[key]} in b" for key, name in CASE_KEYS
                   if ra.get(key) is not None and rb.get(key) is not None
                   and ra[key] != rb[key]]
        dir_a, dir_b = (os.path.join(c.folder, "runs", rb["run"]) for c in (a, b))
        if os.path.realpath(dir_a) == os.path.realpath(dir_b):
            differ.append("one run folder in both campaigns (a link)")
        elif (state := end_state(dir_a)) is not None and \
                (relation := shared_end(dir_a, dir_b, state)) is not None:
            if relation == "copy":
                differ.append(f"one run in both campaigns (both end at step {state[0]} in state "
                              f"{state[1]}, from the same case.toml and build): a copy")
            else:
                item["one_flow"] = True
        key = (rb.get("system"), rb.get("seed"), rb.get("V"))
        if not differ and None not in key:
            if key in compared:
                differ.append(f"{compared[key]} is system {key[0]}, seed {key[1]}, V = "
                              f"{key[2]:g} too and is compared: each seed pairs once (a copy "
                              f"kept in runs/)")
            else:
                compared[key] = rb["run"]
        if differ:
            item["mismatch"] = "; ".join(differ)
            out.append((index, item))
            continue
        for q in quantities:
            va, vb = ra.get(q), rb.get(q)
            ea, eb = ra.get(q + "_err"), rb.get(q + "_err")
            if va is None or vb is None:
                continue
            diff = vb - va
            err = math.hypot(ea, eb) if ea is not None and eb is not None else math.nan
            item[q] = {"a": va, "b": vb, "diff": diff,
                       "combined_errors": diff / err if err > 0 else math.nan}
        out.append((index, item))
    return [item for _, item in sorted(out, key=lambda p: p[0])]


def _copy_rank(run, listed):
    """Which of a seed's folders compare_campaigns compares first: 0 for the name campaign.toml
    lists, 1 for a name that reads as a run's (s<system>_seed<seed>_V<number>), 2 for others (a
    backup's: s1_seed1_V0.05.bak). Python's sort is stable: the rows' order stays within a rank."""
    if run in listed:
        return 0
    m = RUN_NAME.match(run)
    try:
        return 1 if m is not None and math.isfinite(float(m.group(3))) else 2
    except ValueError:
        return 2


def paired_differences(items):
    """The shared runs grouped by (system, V), each group's seeds paired: for every quantity with
    at least two pairs, {"n", "mean" (of b - a), "sd" (their standard deviation), "se" (sd /
    sqrt(n)), "t" (mean / se, Student's with n - 1 degrees of freedom; NaN where se is 0), "p"
    (its two-sided probability under no difference), "higher" (pairs with b > a)}. Pairing by
    seed takes out the scatter between packings, which in slow flows is several times one run's
    error bar (docs/accuracy.md, "Effect on the averaged quantities"). Each entry also holds
    "a" and "b": each campaign's own mean over the same pairs and its standard error (the scatter
    between packings). A list of {"system", "V", "runs", "<q>": {...}}, by system and V."""
    groups = {}
    for it in items:
        if "mismatch" not in it:
            groups.setdefault((it["system"], it["V"]), []).append(it)
    out = []
    for (system, velocity), group in sorted(groups.items(),
                                            key=lambda g: (g[0][0] or 0, g[0][1] or 0.0)):
        entry = {"system": system, "V": velocity, "runs": len(group)}
        quantities = list(dict.fromkeys(q for it in group for q, v in it.items()
                                        if isinstance(v, dict)))
        for q in quantities:
            pairs = [it[q] for it in group if isinstance(it.get(q), dict)]
            if len(pairs) < 2:
                continue
            diffs = np.array([v["diff"] for v in pairs])
            d = _mean_se_of(diffs)
            mean, se = d["mean"], d["se"]
            # no scatter at all: t is infinite unless there is no difference either
            t = mean / se if se > 0 else (math.copysign(math.inf, mean) if mean else math.nan)
            entry[q] = {"n": int(diffs.size), "mean": mean, "sd": se * math.sqrt(diffs.size),
                        "se": se, "t": t,
                        "p": float(2.0 * student_t.sf(abs(t), diffs.size - 1)),
                        "higher": int((diffs > 0).sum()),
                        "a": _mean_se_of([v["a"] for v in pairs]),
                        "b": _mean_se_of([v["b"] for v in pairs])}
        out.append(entry)
    return out


def _mean_se_of(values):
    """{"mean", "se"}: the values' mean and its standard error, std(ddof 1) / sqrt(n)."""
    values = np.asarray(values, dtype=float)
    return {"mean": float(values.mean()),
            "se": float(values.std(ddof=1) / math.sqrt(values.size))}


def format_comparison(items, name_a="a", name_b="b"):
    """The comparison as text: one block per run, one line per quantity; then, for each system
    and V with two or more seeds in both, the differences paired by seed."""
    lines = []
    for it in items:
        if "mismatch" in it:
            lines.append(f"{it['run']}: not compared: {it['mismatch']}")
            continue
        lines.append(f"{it['run']}: regime {it['regime_a']} ({name_a}) -> {it['regime_b']} "
                     f"({name_b})")
        for q, v in it.items():
            if isinstance(v, dict):
                ce = v["combined_errors"]   # NaN where a run gives no error (com_vx_std)
                lines.append(f"  {q:22s} {v['a']:.5g} -> {v['b']:.5g}  diff {v['diff']:+.3g}" +
                             ("" if math.isnan(ce) else
                              f"  ({_rounded(ce, 2):+.2f} combined errors)"))
    for g in paired_differences(items):
        shown = [(q, v) for q, v in g.items() if isinstance(v, dict)]
        if not shown:
            continue
        lines.append(f"system {g['system']}, {_velocity(g['V'])}: {g['runs']} seeds paired, b - a "
                     f"(mean +- standard error of the differences; t = mean / error and its "
                     f"two-sided p, Student's with n - 1 degrees of freedom; pairs with b > a; "
                     f"then a's and b's own means over the pairs +- their standard errors)")
        for q, v in shown:
            lines.append(f"  {q:22s} {v['mean']:+.3g} +- {v['se']:.2g}  "
                         f"t = {_rounded(v['t'], 2):+.2f}, "
                         f"p = {v['p']:.2g}  ({v['higher']} of {v['n']} higher)  "
                         f"a {_mean_se(v['a'])}, b {_mean_se(v['b'])}")
    return "\n".join(lines) if lines else "no run in both campaigns"


def _velocity(v):
    return f"V = {v:g}" if v is not None else "V unknown"


def unequal_times(items):
    """The compared runs whose two analyses reached different times [(run, time_a, time_b)]:
    averages over different stretches of a flow, to compare at a common time instead
    (compare_campaigns' `until`)."""
    return [(it["run"], it["time_a"], it["time_b"]) for it in items
            if "mismatch" not in it and not _same_time(it["time_a"], it["time_b"])]


def one_flow(items):
    """The compared runs that end in the same state in both campaigns from other cases or builds
    (compare_campaigns' "one_flow"): the two computed one flow there, a difference of zero."""
    return [it["run"] for it in items if it.get("one_flow")]


def other_packings(items, a, b):
    """The compared runs whose two cases start from packing files of other contents
    [(run, packing_a, packing_b)] (case.toml's preparation.packing, where both files are there to
    read): their differences hold the packings' scatter as well, which pairing by seed is meant
    to take out. a and b are the two Campaign objects compared."""
    out = []
    for it in items:
        if "mismatch" in it:
            continue
        paths = []
        for c in (a, b):
            preparation = (folder_case(os.path.join(c.folder, "runs", it["run"])) or {}) \
                .get("preparation")
            path = preparation.get("packing") if isinstance(preparation, dict) else None
            paths.append(path if isinstance(path, str) and os.path.isfile(path) else None)
        if None in paths or os.path.realpath(paths[0]) == os.path.realpath(paths[1]):
            continue
        try:
            same = filecmp.cmp(paths[0], paths[1], shallow=False)
        except OSError:
            continue
        if not same:
            out.append((it["run"], paths[0], paths[1]))
    return out


def compared_count(items):
    """How many of the shared runs were compared (those without a mismatch)."""
    return sum("mismatch" not in it for it in items)


def _same_time(a, b):
    return a == b or (a is not None and b is not None and math.isclose(a, b, rel_tol=1e-9))


def _mean_se(m, sign=""):
    """A mean and its standard error, both to the error's second significant digit (sign "+":
    the mean's sign always shown)."""
    if not m["se"] > 1e-9 * abs(m["mean"]):  # no scatter but round-off
        return f"{m['mean']:{sign}.4g} +- 0"
    digits = max(0, 1 - math.floor(math.log10(m["se"])))
    return f"{_rounded(m['mean'], digits):{sign}.{digits}f} +- {m['se']:.{digits}f}"


def _rounded(x, digits):
    """x rounded to `digits` decimals, a negative value that rounds to zero made +0 (so that
    a table shows 0.000, not -0.000)."""
    return round(x, digits) + 0.0 if math.isfinite(x) else x


def unpaired(items, groups=None):
    """The compared runs that no paired table holds [(run, reason)]: those of a system and V
    with no quantity that two of its runs give (a single seed, or quantities missing).
    `groups`: paired_differences(items) where the caller has it."""
    out = []
    for it, (kind, runs) in _unpaired_items(items, groups):
        if kind == "one seed":
            out.append((it["run"], f"the one run of system {it['system']}, {_velocity(it['V'])} "
                                   f"compared: no other seed to pair it with"))
        else:
            out.append((it["run"], f"no quantity that two of the {runs} runs of system "
                                   f"{it['system']}, {_velocity(it['V'])} give: nothing to pair"))
    return out


def _unpaired_items(items, groups):
    """[(item, (kind, runs))] for the compared items in no paired table: kind "one seed" for the
    only run of its system and V, "no shared quantity" where its `runs` runs give no quantity in
    common."""
    groups = paired_differences(items) if groups is None else groups
    alone = {(g["system"], g["V"]): g["runs"] for g in groups
             if not any(isinstance(v, dict) for v in g.values())}
    out = []
    for it in items:
        runs = alone.get((it["system"], it["V"])) if "mismatch" not in it else None
        if runs is not None:
            out.append((it, ("one seed" if runs == 1 else "no shared quantity", runs)))
    return out


def lone_unsteady_runs(items, groups=None):
    """The compared runs that are the one seed of their system and V and whose regime is not A in
    both campaigns [(run, regime_a, regime_b)]. Their combined errors come from the windows of one
    flow, and a flow in regime B or C (or undecided, or intermittent) stays for thousands of time
    units in one state (the block carried by one wall or the other, B or undecided windows), so
    they do not bound what two runs of one setting differ by: the shear defaults' runs of system 1
    at V = 0.065 and 0.225 from one packing, an earlier build against the current one, differ by
    up to 11 combined errors (docs/validation.md, "One run per setting does not measure the
    solver in regimes B and C"). Only seeds paired by packing measure a setting there.
    `groups`: paired_differences(items) where the caller has it."""
    return [(it["run"], it["regime_a"], it["regime_b"])
            for it, (kind, _) in _unpaired_items(items, groups)
            if kind == "one seed" and not it["regime_a"] == it["regime_b"] == "A"]


def format_paired_markdown(items, name_a="a", name_b="b"):
    """The seeds paired by system and V as Markdown tables (docs/accuracy.md's form): per
    quantity, each campaign's mean over the pairs +- its standard error, and b - a paired with
    its t. Then lists, each run with its reason: the shared runs that were not compared, those
    compared but in no table (`unpaired`), and those compared that compute one flow in both
    (compare_campaigns' "one_flow": a difference of zero)."""
    lines = []
    groups = paired_differences(items)
    for g in groups:
        shown = [(q, v) for q, v in g.items() if isinstance(v, dict)]
        if not shown:
            continue
        if lines:
            lines.append("")
        lines += [f"System {g['system']}, {_velocity(g['V'])}, {g['runs']} seeds paired:", "",
                  f"| quantity | {name_a} | {name_b} | {name_b} minus {name_a}, paired (t) |",
                  "|---|---|---|---|"]
        for q, v in shown:
            diff = _mean_se({"mean": v["mean"], "se": v["se"]}, sign="+")
            label = q if v["n"] == g["runs"] else f"{q} ({v['n']} pairs)"
            lines.append(f"| {label} | {_mean_se(v['a'])} | {_mean_se(v['b'])} | {diff} "
                         f"({_rounded(v['t'], 2):+.2f}) |")
    if not lines:
        lines.append("no system and V with two seeds in both campaigns")
    same = ("ends in the same state in both campaigns from other cases or builds: the two "
            "computed one flow there, a difference of zero")
    for title, listed in (("Not compared:", [(it["run"], it["mismatch"]) for it in items
                                             if "mismatch" in it]),
                          ("Compared, in no paired table:", unpaired(items, groups)),
                          ("One flow in both:", [(it["run"], same) for it in items
                                                 if it.get("one_flow") and "mismatch" not in it])):
        if listed:
            lines += ["", title, ""]
            lines += [f"- `{run}`: {why}" for run, why in listed]
    return "\n".join(lines)

"""Command line: `python3 -m cdshear_analysis analyze RUN_DIR [--quiet]` writes
RUN_DIR/summary.json and prints a report; `... plot RUN_DIR [-o OUT_DIR]` writes PNG figures
(default RUN_DIR/figures); `... study STUDY_DIR` tabulates and plots a parameter study (runs in
KEY=VALUE folders and a `reference` one: cdshear_analysis/study.py); `... study-compare DIR_A
DIR_B [--windows N]` compares two folders of realizations in combined errors (and, with
--windows, their solid fraction and mu_eff over time in N windows); `... report CAMPAIGN_DIR
[-o OUT_DIR]` writes a campaign's runs table, fitted laws, figures and index.html (default
CAMPAIGN_DIR/report; cdshear_analysis/report.py); `... lammps-data PACKING.json -o DATA`
writes a LAMMPS data file (and DATA.vars) of a packing, `... side-by-side ...` prints the table
of bench/peers/side_by_side.sh (cdshear_analysis/peers.py); `... series-means RUN_DIR --after T
[--key KEY ...]` prints means of run.h5 series after time T (cdshear_analysis/series_means.py);
`... series-pairs CHECK_DIR` the pairs of scripts/paired_check.sh; `... stress-balance
RUN_DIR...` the interior stress against the walls' over each run's steady windows
(cdshear_analysis/stress_balance.py); `... profile-decay RUN_DIR... --fits FITS` the decay
time of each run's velocity profile against T_SS = L_y^2 / D (cdshear_analysis/relaxation.py);
`... switch-times RUN_DIR... [--against RUN_DIR...]` the band switches over whole runs, pooled,
and two groups compared (cdshear_analysis/switch_statistics.py); `... campaign-compare DIR_A DIR_B
[--until T] [--markdown]` the runs two campaigns share, quantity by quantity, and their seeds
paired (cdshear_analysis/campaign.py; docs/reports.md, "Two campaigns compared"); `...
lammps-compare CAMPAIGN_DIR LAMMPS_DIR` the LAMMPS runs of bench/peers/lammps_campaign.sh
against their campaign's runs.
A run too short for any averaging
window is analysed (not steady, series values over the last half) and plotted without its
profile figures. Bad input:
`error: <file>: <problem>` on stderr, exit status 2."""
import argparse
import codecs
import math
import os
import sys
import warnings


def _write_json(path, data):
    """Writes `data` to the JSON file `path` (indented; NaN and infinity as null, as in
    summary.json; whole or not at all, as every output): exit status 0, or 1 with the error."""
    import json
    from .rundata import write_text_atomically
    from .summary import jsonable
    try:
        write_text_atomically(path, json.dumps(jsonable(data), indent=1, allow_nan=False) + "\n")
    except OSError as e:
        print(f"error: {path}: cannot write: {e.strerror or e}", file=sys.stderr)
        return 1
    return 0


def _escape_unencodable(error):
    """An encoding error handler for the output streams: the bytes of a file name that is not
    UTF-8 (held as surrogates) written back as they were, any other character the locale's
    encoding lacks as a backslash escape; never a UnicodeEncodeError traceback."""
    try:
        return codecs.lookup_error("surrogateescape")(error)
    except UnicodeError:
        return codecs.lookup_error("backslashreplace")(error)


codecs.register_error("cdshear_analysis.escape", _escape_unencodable)


def main(argv=None):
    # Every figure is written to a file (Agg): a backend named in the environment is of no use
    # here, and one matplotlib does not know stops its import with a traceback.
    os.environ["MPLBACKEND"] = "Agg"
    # A folder's name that is not UTF-8 printed under a locale whose stdout is strict
    # (en_US.UTF-8, where C.UTF-8 escapes surrogates already).
    for stream in (sys.stdout, sys.stderr):
        if callable(getattr(stream, "reconfigure", None)):
            stream.reconfigure(errors="cdshear_analysis.escape")
    parser = argparse.ArgumentParser(
        prog="cdshear_analysis", description="The analysis of cdshear's runs and campaigns: "
        "summaries, figures, reports, comparisons (docs/analysis.md, docs/reports.md).")
    commands = parser.add_subparsers(dest="command", required=True)
    p_analyze = commands.add_parser("analyze", help="write RUN_DIR/summary.json, print a report")
    p_analyze.add_argument("run_dir")
    p_analyze.add_argument("--quiet", action="store_true", help="print nothing on success")
    p_plot = commands.add_parser("plot", help="write PNG figures")
    p_plot.add_argument("run_dir")
    p_plot.add_argument("-o", "--out-dir", help="output folder (default RUN_DIR/figures)")
    p_study = commands.add_parser("study", help="tabulate and plot a parameter study")
    p_study.add_argument("study_dir")
    p_report = commands.add_parser("report", help="runs table, fits, figures of a campaign")
    p_report.add_argument("campaign_dir")
    p_report.add_argument("-o", "--out-dir", help="output folder (default CAMPAIGN_DIR/report)")
    p_data = commands.add_parser("lammps-data", help="a packing as a LAMMPS data file")
    p_data.add_argument("packing")
    p_data.add_argument("-o", "--output", required=True, help="data file (and OUTPUT.vars)")
    p_side = commands.add_parser("side-by-side", help="table of bench/peers/side_by_side.sh")
    p_side.add_argument("--cdshear-run", required=True, help="cdshear run folder (run.h5)")
    p_side.add_argument("--lammps-dir", required=True, help="folder with series.txt, dump.txt")
    p_side.add_argument("--duration", type=float, required=True, help="simulated time T")
    p_side.add_argument("--cdshear-seconds", type=float, required=True, help="its wall time")
    p_side.add_argument("--lammps-seconds", type=float, required=True, help="its wall time")
    p_side.add_argument("--json", help="also write the figures to this JSON file")
    p_lcompare = commands.add_parser(
        "lammps-compare", help="the LAMMPS runs of bench/peers/lammps_campaign.sh against "
        "their campaign's runs, paired by run (docs/benchmarks.md, \"Regime C beside LAMMPS\")")
    p_lcompare.add_argument("campaign", help="the campaign folder (cdshear sweep)")
    p_lcompare.add_argument("lammps_folder", help="the folder of lammps_campaign.sh's runs")
    p_ccompare = commands.add_parser(
        "campaign-compare", help="the runs two campaigns share, quantity by quantity, in "
        "combined errors, and their seeds paired (a setting's effect: docs/reports.md, \"Two "
        "campaigns compared\")")
    p_ccompare.add_argument("campaign_a")
    p_ccompare.add_argument("campaign_b")
    p_ccompare.add_argument("--until", type=float, metavar="T",
                            help="analyse every run from its run.h5 as it stood at time T, "
                            "leaving out runs that have not reached it (summary.json unused)")
    p_ccompare.add_argument("--markdown", action="store_true",
                            help="print only the seeds paired by system and V, as Markdown tables")
    p_compare = commands.add_parser(
        "study-compare", help="two folders of realizations (reference, reference_seedK) compared")
    p_compare.add_argument("dir_a")
    p_compare.add_argument("dir_b")
    p_compare.add_argument("--windows", type=int, default=0,
                           help="also the solid fraction and mu_eff over time, in this many "
                           "windows (each folder's realizations averaged per window)")
    p_balance = commands.add_parser(
        "stress-balance", help="interior stress against the walls' over the steady windows")
    p_balance.add_argument("run_dirs", nargs="+")
    p_decay = commands.add_parser(
        "profile-decay", help="each run's velocity-profile decay time against L_y^2 / D")
    p_decay.add_argument("run_dirs", nargs="+")
    p_decay.add_argument("--fits", required=True, help="a report's fits.json (its bulk law)")
    p_decay.add_argument("--json", help="also write the table to this JSON file")
    p_decay.add_argument("--plot", help="also plot each run's decay against t / T_SS")
    p_switch = commands.add_parser(
        "switch-times", help="band switches over whole runs, pooled; two groups compared")
    p_switch.add_argument("run_dirs", nargs="+")
    p_switch.add_argument("--against", nargs="+", metavar="RUN_DIR",
                          help="a second group of runs (another height): the ratios of their "
                          "switch times and rates")
    p_switch.add_argument("--json", help="also write the runs, groups and comparison here")
    p_means = commands.add_parser("series-means", help="means of run.h5 series after a time")
    p_means.add_argument("run_dir")
    p_means.add_argument("--after", type=float, required=True, help="samples with time > AFTER")
    p_means.add_argument("--before", type=float, default=float("inf"),
                         help="and time <= BEFORE (default: to the end)")
    p_means.add_argument("--key", action="append", help="series name (repeatable; default "
                         "force_carrying, sweeps_mean, capped_steps)")
    p_pairs = commands.add_parser(
        "series-pairs",
        help="series of two executables or settings resumed from the same checkpoints, "
        "compared pair by pair (scripts/paired_check.sh)")
    p_pairs.add_argument("check_dir")
    args = parser.parse_args(argv)
    # An empty folder or file argument is an unset shell variable, not "the current folder".
    for name, value in vars(args).items():
        if value == "" or (isinstance(value, list) and "" in value):
            print(f"error: {name}: is empty (an unset shell variable?)", file=sys.stderr)
            return 2
    warnings.simplefilter("ignore", RuntimeWarning)   # all-NaN slices etc. give NaN = null

    if args.command == "study":
        from .study import StudyError, collect, write_study
        try:
            skipped = []
            for path in write_study(collect(args.study_dir, skipped), args.study_dir):
                print(path)
            for name in skipped:
                print(f"left out {name}: no summary.json yet")
        except StudyError as e:
            print(f"error: {e.path}: {e.problem}", file=sys.stderr)
            return 2
        except OSError as e:   # study.csv, study.md or figures/ cannot be written
            print(f"error: {e.filename or args.study_dir}: cannot write: {e.strerror or e}",
                  file=sys.stderr)
            return 1
        return 0

    if args.command == "lammps-compare":
        from .campaign import (compare_campaigns, compared_count,
                               format_comparison as format_campaigns, load_campaign)
        from .peers import PeerError, lammps_campaign
        from .report import ReportError
        from .rundata import is_number
        try:   # both errors name a path and its problem
            campaign = load_campaign(args.campaign)
            peers = lammps_campaign(args.lammps_folder, campaign)
            items = compare_campaigns(campaign, peers)
        except (ReportError, PeerError) as e:
            print(f"error: {e.path}: {e.problem}", file=sys.stderr)
            return 2
        for run, why in campaign.skipped + peers.skipped:
            print(f"left out: {run}: {why}")
        for text in campaign.notes:
            print(f"note: {text}")
        if not items:
            print(f"error: {args.lammps_folder}: no LAMMPS run beside an analysed run of "
                  f"{args.campaign}: nothing to compare", file=sys.stderr)
            return 2
        kappas = {r.get("kappa") for r in peers.rows}   # one (lammps_campaign refuses more)
        if len(kappas) == 1 and is_number(kappa := kappas.pop()):
            print(f"the LAMMPS runs' normal stiffness: kappa = {kappa:g}")
        print(format_campaigns(items, args.campaign, "LAMMPS"))
        if not compared_count(items):
            print(f"error: {args.lammps_folder}: no LAMMPS run could be compared with its "
                  f"namesake in {args.campaign} (each is 'not compared' above)", file=sys.stderr)
            return 2
        return 0

    if args.command == "campaign-compare":
        from .campaign import compare_campaigns, format_comparison as format_campaigns
        from .campaign import (compared_count, format_paired_markdown, load_campaign,
                               lone_unsteady_runs, one_flow, other_packings, unequal_times)
        from .report import ReportError
        try:
            if args.until is not None and not (math.isfinite(args.until) and args.until > 0):
                raise ReportError("--until", f"must be a time > 0, got {args.until:g}")
            if os.path.realpath(args.campaign_a) == os.path.realpath(args.campaign_b):
                raise ReportError(args.campaign_b, f"is {args.campaign_a} again: a campaign "
                                                   "compared with itself differs by nothing")
            a = load_campaign(args.campaign_a, args.until)
            b = load_campaign(args.campaign_b, args.until)
        except ReportError as e:
            print(f"error: {e.path}: {e.problem}", file=sys.stderr)
            return 2
        for name, c in ((args.campaign_a, a), (args.campaign_b, b)):
            for run, why in c.skipped:
                print(f"left out of {name}: {run}: {why}")
            for text in c.notes:
                print(f"note on {name}: {text}")
        if args.until is not None:
            print(f"every run analysed as it stood at t = {args.until:g}")
        items = compare_campaigns(a, b)
        if not items and args.until is not None:
            early = [run for c in (a, b) for run, why in c.skipped
                     if why.startswith("reached t = ")]
            if early:
                print(f"error: --until: no run that both campaigns hold is left to compare at "
                      f"t = {args.until:g}: {len(early)} were left out above for not reaching "
                      f"it; a smaller --until may compare them", file=sys.stderr)
                return 2
        if not items:   # as `report` with no run to report on
            print(f"error: {args.campaign_b}: no analysed run that {args.campaign_a} has as "
                  f"well: nothing to compare", file=sys.stderr)
            return 2
        uneven = unequal_times(items)
        if uneven:
            run, time_a, time_b = uneven[0]
            print(f"note: {len(uneven)} of the {len(items)} shared runs stand at different times "
                  f"in the two campaigns ({run}: t = {_time(time_a)} in a, {_time(time_b)} in "
                  f"b): their averages cover different stretches of the flow; --until T "
                  f"compares them at a common time")
        if same := one_flow(items):
            print(f"note: {len(same)} of the {len(items)} shared runs end in the same state in "
                  f"both campaigns ({', '.join(same)}): the two computed one flow there, a "
                  f"difference of zero")
        packings = other_packings(items, a, b)
        if packings:
            run, packing_a, packing_b = packings[0]
            print(f"note: {len(packings)} of the {len(items)} shared runs start from other "
                  f"packings in the two campaigns ({run}: {packing_a} and {packing_b} differ): "
                  f"their paired differences hold the packings' scatter as well")
        lone = lone_unsteady_runs(items)
        if lone:
            run, regime_a, regime_b = lone[0]
            print(f"note: {len(lone)} of the compared runs are the one seed of their system and V "
                  f"and not in regime A in both campaigns ({run}: {regime_a} in a, {regime_b} in "
                  f"b): a run's combined errors come from the windows of one flow, which in "
                  f"regimes B and C stays for thousands of time units in one state, so they do "
                  f"not bound what two runs of one setting differ by (up to 11 combined errors: "
                  f"docs/validation.md); a setting is measured there by seeds paired by packing")
        if not compared_count(items):
            print(format_campaigns(items, args.campaign_a, args.campaign_b))
            print(f"error: {args.campaign_b}: none of the runs it shares with {args.campaign_a} "
                  f"could be compared (each is 'not compared' above)", file=sys.stderr)
            return 2
        if args.markdown:
            print(format_paired_markdown(items, args.campaign_a, args.campaign_b))
        else:
            print(format_campaigns(items, args.campaign_a, args.campaign_b))
        return 0

    if args.command == "study-compare":
        from .study import (StudyError, common_windows, compare_references, format_comparison,
                            format_windows)
        try:
            if args.windows < 0:   # checked before the comparison is printed
                raise StudyError("--windows", f"must be at least 1 (0: none), not {args.windows}")
            a, b, lines, skipped = compare_references(args.dir_a, args.dir_b)
            # every part made before any is printed: an error prints nothing but itself
            text = format_comparison(args.dir_a, args.dir_b, a, b, lines, skipped)
            if args.windows:
                text += format_windows(args.dir_a, args.dir_b,
                                       *common_windows(args.dir_a, args.dir_b, args.windows))
            print(text, end="")
        except StudyError as e:
            print(f"error: {e.path}: {e.problem}", file=sys.stderr)
            return 2
        return 0

    if args.command == "series-means":
        from .rundata import RunDataError, load_run
        from .series_means import SeriesError, format_series_means, series_means
        keys = args.key or ["force_carrying", "sweeps_mean", "capped_steps"]
        for option, value in (("--after", args.after), ("--before", args.before)):
            if math.isnan(value) or (option == "--after" and math.isinf(value)):
                print(f"error: {option}: must be a time, not {value:g}", file=sys.stderr)
                return 2
        try:
            print(format_series_means(series_means(load_run(args.run_dir), args.after, keys,
                                                   args.before)))
        except RunDataError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        except SeriesError as e:
            print(f"error: {os.path.join(args.run_dir, 'run.h5')}: {e.problem}", file=sys.stderr)
            return 2
        return 0

    if args.command == "stress-balance":
        from .rundata import RunDataError, load_run
        from .stress_balance import format_line, stress_balance
        for run_dir in args.run_dirs:
            try:
                balance = stress_balance(load_run(run_dir))
            except RunDataError as e:
                print(f"error: {e.path}: {e.problem}", file=sys.stderr)
                return 2
            print(format_line(run_dir, balance) if balance else
                  f"{run_dir}  no complete window: nothing to compare")
        return 0

    if args.command == "switch-times":
        from .rundata import RunDataError, end_state, output_problem, repeated_folder
        from .switch_statistics import (compare_groups, format_table, group_problem,
                                        group_statistics, run_switches)
        if args.json is not None and (why := output_problem(
                args.json, list(args.run_dirs) + list(args.against or []))):
            print(f"error: {args.json}: --json: {why}", file=sys.stderr)
            return 2
        try:
            runs = [run_switches(d) for d in args.run_dirs]
            against = [run_switches(d) for d in args.against or []]
        except RunDataError as e:
            print(f"error: {e.path}: {e.problem}", file=sys.stderr)
            return 2
        both = list(args.run_dirs) + list(args.against or [])
        ends = {d: end_state(d) for d in both}   # each run's read once for the checks below
        for problem in (group_problem(runs, args.run_dirs, ends),
                        group_problem(against, args.against or [], ends),
                        repeated_folder(both, ends)):   # a run in both groups
            if problem:
                print(f"error: {problem}", file=sys.stderr)
                return 2
        comparison = compare_groups(runs, against) if against else None
        print(format_table(runs, against, comparison))
        if args.json:
            out = {"runs": runs, "group": group_statistics(runs)}
            if against:
                out.update(against=against, against_group=group_statistics(against),
                           comparison=comparison)
            return _write_json(args.json, out)
        return 0

    if args.command == "profile-decay":
        from .relaxation import (bulk_law_problem, decay_entries, exponent_absence,
                                 format_decay_table, height_exponent)
        from .report import ReportError, identity_problem, read_json, read_summary
        from .rundata import distinct_names, output_problem, repeated_folder
        from .summary import SUMMARY_FORMAT
        summaries = []
        try:
            if repeated := repeated_folder(args.run_dirs):
                raise ReportError("run_dirs", repeated)
            # each run named by its folder's name, or by as much of its path as tells it
            # from a namesake (one run name in two campaigns)
            for run_dir, name in zip(args.run_dirs, distinct_names(args.run_dirs)):
                data = read_summary(run_dir)
                path = os.path.join(run_dir, "summary.json")
                if not isinstance(data, dict) or data.get("format") != SUMMARY_FORMAT:
                    raise ReportError(path, "not a cdshear summary")
                if other := identity_problem(run_dir, data):
                    raise ReportError(path, other)
                data["run"] = name
                summaries.append(data)
            fits = read_json(args.fits)
            fits = fits.get("fits") if isinstance(fits, dict) else None
            if not isinstance(fits, dict):
                raise ReportError(args.fits, "no `fits` table (a report's fits.json)")
            if why := bulk_law_problem(fits):
                raise ReportError(args.fits, why)
            inputs = list(args.run_dirs) + [args.fits]
            for option, out in (("--json", args.json), ("--plot", args.plot)):
                if out is not None and (why := output_problem(out, inputs)):
                    raise ReportError(out, f"{option}: {why}")
            if args.plot is not None and not args.plot.lower().endswith(".png"):
                raise ReportError(args.plot, "--plot: the figure is a PNG file: its name must "
                                             "end in .png")
            if args.json is not None and args.plot is not None and \
                    os.path.realpath(args.json) == os.path.realpath(args.plot):
                raise ReportError(args.plot, "--plot: the file --json names: one would replace "
                                             "the other")
        except ReportError as e:
            print(f"error: {e.path}: {e.problem}", file=sys.stderr)
            return 2
        entries = decay_entries(summaries, fits)
        absence = exponent_absence(entries)
        exponent = height_exponent(entries, absence)
        print(format_decay_table(entries, exponent, absence))
        if args.plot and not any(e["used"] for e in entries):
            print(f"error: {args.plot}: --plot: no run is used (each row above says why): no "
                  f"figure to draw; nothing written", file=sys.stderr)
            return 2
        if args.json and _write_json(args.json, {"runs": entries, "exponent": exponent}):
            return 1
        try:
            if args.plot:
                from .plots import plot_profile_decay
                plot_profile_decay(summaries, entries, args.plot)
                print(args.plot)
        except OSError as e:
            where = e.filename or args.plot
            print(f"error: {where}: cannot write: {e.strerror or e}", file=sys.stderr)
            return 1
        return 0

    if args.command == "series-pairs":
        from .rundata import RunDataError
        from .series_means import SeriesError, format_paired_differences, paired_differences
        try:
            print(format_paired_differences(paired_differences(args.check_dir)))
        except (RunDataError, SeriesError, OSError, ValueError) as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        return 0

    if args.command in ("lammps-data", "side-by-side"):
        from .peers import PeerError, format_side_by_side, side_by_side, write_lammps_packing
        from .rundata import RunDataError, output_problem
        try:
            if args.command == "lammps-data":
                for option, out in (("-o", args.output), ("-o (its .vars)", args.output + ".vars")):
                    if why := output_problem(out, [args.packing]):
                        raise PeerError(out, f"{option}: {why}")
                info = write_lammps_packing(args.packing, args.output)
                print(f"{args.output}: {info['n_grains']} grains, 2 walls of {info['n_wall']} "
                      f"disks, L_x = {info['length_x']:.6g}, L_y = {info['height0']:.6g}")
                return 0
            if args.json is not None and \
                    (why := output_problem(args.json, [args.cdshear_run, args.lammps_dir])):
                raise PeerError(args.json, f"--json: {why}")
            for option, value in (("--duration", args.duration),
                                  ("--cdshear-seconds", args.cdshear_seconds),
                                  ("--lammps-seconds", args.lammps_seconds)):
                if not (math.isfinite(value) and value > 0):
                    raise PeerError(option, f"must be a number > 0, got {value:g}")
            for option, value in (("--cdshear-seconds", args.cdshear_seconds),
                                  ("--lammps-seconds", args.lammps_seconds)):
                if not 1e-6 <= value <= 1e9:   # a microsecond to thirty years of wall time
                    raise PeerError(option, f"{value:g} s is no run's wall time (1e-06 to 1e+09 "
                                            f"s)")
            result = side_by_side(args.cdshear_run, args.lammps_dir, args.duration,
                                  args.cdshear_seconds, args.lammps_seconds)
        except (PeerError, RunDataError) as e:
            print(f"error: {e.path}: {e.problem}", file=sys.stderr)
            return 2
        except OSError as e:
            where = e.filename or (args.output if args.command == "lammps-data" else "")
            print(f"error: {where}: {e.strerror or e}", file=sys.stderr)
            return 1
        print(format_side_by_side(result))
        if args.json:
            return _write_json(args.json, result)
        return 0

    if args.command == "report":
        from .report import ReportError, collect, write_report

        def print_left_out(report, file):
            for name, reason in report["skipped"]:
                print(f"left out {name}: {reason}", file=file)
            for note in report.get("notes", []):
                print(f"note: {note}", file=file)

        report = None
        out_dir = args.out_dir or os.path.join(args.campaign_dir, "report")
        if os.path.lexists(out_dir) and not os.path.isdir(out_dir):
            # Refused before the campaign is read: a report goes into a folder.
            from .rundata import what_is
            print(f"error: {out_dir}: -o: is {what_is(out_dir)}, not a folder (the report "
                  "writes runs.md, runs.csv, fits.json, index.html and figures/ into it)",
                  file=sys.stderr)
            return 2
        try:
            report = collect(args.campaign_dir)
            try:
                paths = write_report(report, out_dir)
            except OSError as e:
                print(f"error: {e.filename or out_dir}: cannot write: {e.strerror or e}",
                      file=sys.stderr)
                return 1
        except ReportError as e:
            if report is not None:   # no run to report on: why each was left out
                print_left_out(report, sys.stderr)
            print(f"error: {e.path}: {e.problem}", file=sys.stderr)
            return 2
        for path in paths:
            print(path)
        print_left_out(report, sys.stdout)
        return 0

    from .rundata import RunDataError, load_run
    from .summary import analyze, format_report, write_summary
    try:
        if args.command == "plot" and args.out_dir:
            from .plots import check_figure_folder
            check_figure_folder(args.run_dir, args.out_dir)   # before the run is read
        run = load_run(args.run_dir)
        summary = analyze(run)
        if args.command == "analyze":
            try:
                path = write_summary(summary, args.run_dir)
            except OSError as e:
                print(f"error: {os.path.join(args.run_dir, 'summary.json')}: cannot write: "
                      f"{e.strerror or e}", file=sys.stderr)
                return 1
            if not args.quiet:
                print(format_report(summary, path))
        else:
            from .plots import plot_run
            out_dir = args.out_dir or os.path.join(args.run_dir, "figures")
            skipped, failed = [], []
            try:
                written = plot_run(run, summary, out_dir, skipped, failed)
            except OSError as e:   # the figure folder cannot be listed
                failed.append(e)
                written = []
            for name in written:
                print(name)
            for name, reason in skipped:
                print(f"skipped {name}: {reason}")
            for e in failed:   # a full disk, a folder in a figure's place: each figure is
                # written whole or not at all, and the others are written
                print(f"error: {e.filename or out_dir}: cannot write: {e.strerror or e}",
                      file=sys.stderr)
            if failed:
                return 1
    except RunDataError as e:
        print(f"error: {e.path}: {e.problem}", file=sys.stderr)
        return 2
    return 0


def _time(t):
    return f"{t:.6g}" if t is not None else "unknown"


if __name__ == "__main__":
    import signal
    from . import rundata
    rundata.LIMIT_READ_TIME = True  # a process of its own: a read that never ends may end it
    # A stop request (cdshear passes SIGINT, SIGTERM and SIGHUP on as SIGTERM) unwinds like
    # Ctrl-C, so replace_atomically removes its temporary; exit 130, and cdshear, which started
    # this, says so.
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    signal.signal(signal.SIGHUP, signal.default_int_handler)
    try:
        sys.exit(main())
    except KeyboardInterrupt:
        sys.exit(130)
    except BrokenPipeError:  # the reader went away (`| head`): stop quietly, as other tools do
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        sys.exit(1)

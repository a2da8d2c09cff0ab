"""Analysis of cdshear runs (docs/analysis.md): steady state, averages with errors, flow regime.

    from cdshear_analysis import load_run, analyze
    run = load_run("runs/n511_h20_V0.5_s0.25_seed1")   # dict of numpy arrays (see rundata.py)
    summary = analyze(run)                              # what summary.json holds

Command line: `python3 -m cdshear_analysis analyze|plot RUN_DIR`.
"""
from .rundata import RunDataError, load_run
from .summary import analyze, format_report, write_summary

__all__ = ["RunDataError", "load_run", "analyze", "format_report", "write_summary"]

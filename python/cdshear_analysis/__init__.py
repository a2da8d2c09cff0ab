"""Analysis of cdshear runs and campaigns (docs/analysis.md, docs/campaigns.md).

    from cdshear_analysis import load_run, load_campaign, analyze
    run = load_run("runs/n511_h20_V0.5_s0.25_seed1")   # dict of numpy arrays (see rundata.py)
    summary = analyze(run)                              # what summary.json holds
    c = load_campaign("campaigns/validation")           # the runs table (campaign.py)

Command line: `python3 -m cdshear_analysis analyze|plot|report DIR` (what `cdshear analyze`,
`plot` and `report` run).
"""
from .campaign import Campaign, load_campaign
from .rundata import RunDataError, load_run
from .summary import analyze, format_report, write_summary

__version__ = "0.1.0"  # the program's version (CMakeLists.txt project(); checked by a test)

__all__ = ["Campaign", "RunDataError", "analyze", "format_report", "load_campaign", "load_run",
           "write_summary", "__version__"]

"""A campaign folder (`cdshear sweep`) for notebooks: `load_campaign(dir)`.

    from cdshear_analysis import load_campaign
    c = load_campaign("campaigns/validation")
    c.columns["I_bulk"], c.columns["mu_eff_bulk"]     # numpy arrays, one entry per analysed run
    c.frame()                                          # the same as a pandas DataFrame

The table is the one `cdshear report` writes to runs.csv (docs/campaigns.md, "Reports", names
every column), read from each run's summary.json. Loading never writes: a run whose summary.json
is of an older version is left out (listed in `skipped`), where `cdshear report` would analyse
it again from run.h5.
"""
from dataclasses import dataclass, field

import numpy as np

from .report import collect, csv_columns


@dataclass
class Campaign:
    """The analysed runs of a campaign folder.

    name: the campaign's name (campaign.toml, or the folder's name).
    folder: the folder it was read from.
    rows: one dict per analysed run (the runs.csv columns, plus `_`-prefixed extras the report
        uses: profiles, switches, layers).
    columns: {runs.csv column: numpy array over the rows}; numbers as float (NaN where a run has
        no value), text and flags as object arrays.
    skipped: [(run, reason)] for every run left out (not started, not analysed, stale).
    """
    name: str
    folder: str
    rows: list
    columns: dict = field(default_factory=dict)
    skipped: list = field(default_factory=list)

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
    if all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))
           for v in values):
        return np.array([np.nan if v is None else float(v) for v in values], dtype=float)
    return np.array(values, dtype=object)


def load_campaign(folder):
    """Reads the analysed runs of a campaign folder (DIR/campaign.toml, DIR/runs/*/summary.json)
    into a Campaign. Raises report.ReportError for a folder that is not a campaign's."""
    report = collect(folder, reanalyse_stale=False)
    rows = report["rows"]
    columns = {c: _column([r.get(c) for r in rows]) for c in csv_columns(rows)}
    return Campaign(name=report["campaign"], folder=folder, rows=rows, columns=columns,
                    skipped=list(report["skipped"]))

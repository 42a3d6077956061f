"""A cell's life: many logs of one cell run through one online estimator,
in the order they were taken, its state carried from each to the next
(``host-sim online battery --input DIR --life-out``; docs/life.md).

``life`` returns a pandas DataFrame, one row per log, with the columns of
``LIFE_COLUMNS`` (those of the CLI's ``--life-out``): the log's counted
discharge and charge (A·h), the median R_i, R_ct and α its windows
identified (NaN where none was; ``r_i_status`` says why), the capacity
published at its end (with an OCV table), ``soh_c`` and ``soh_r`` over the
first log's, and ``error`` for a log that could not be run (a warning, and
the life goes on across it).

>>> import fracbms                                          # doctest: +SKIP
>>> df = fracbms.life("data/nasa-pcoe-b0005/discharge",
...                   start_times="start_times.csv")        # doctest: +SKIP
>>> df[["file", "discharged_ah", "r_i", "soh_r"]]           # doctest: +SKIP
"""

from __future__ import annotations

import os
import tempfile
from typing import Any, Optional, Sequence, Union

from ._fracbms import LIFE_COLUMNS, life_rows

__all__ = ["LIFE_COLUMNS", "life"]

PathLike = Union[str, "os.PathLike[str]"]


def life(
    paths: Union[PathLike, Sequence[PathLike]],
    *,
    start_times: Optional[PathLike] = None,
    out_dir: Optional[PathLike] = None,
    **options: Any,
) -> Any:
    """Runs a cell's logs through one estimator and returns one row per
    log as a pandas DataFrame (columns ``LIFE_COLUMNS``).

    ``paths``: a directory, a glob pattern, or a sequence of files.
    ``start_times``: a CSV ``file,start_time`` (ISO 8601) giving the order
    and the time between logs; without it, the date and time of each log's
    first row where every log has a column of them (``Date_Time``,
    ``TimeStamp``, ...), else name order, each taken to start an hour after
    the one before ended. ``out_dir``: where
    each log's track is written (``NAME-track.csv``; default a temporary
    directory, removed after). ``options``: ``ocv``, ``capacity_ah``,
    ``soc0``, ``window``, ``columns``, ``current_sign``, ``period_s``,
    ``steps`` (``"auto"``, ``"ignore"``, ``"count"``: where each step
    began), ``voltage_min``, ``voltage_max`` (the limits a capacity check
    runs between), as the CLI's flags.

    Raises ValueError for no files, a start-time table that does not cover
    them, or an option refused; ImportError without pandas."""
    import pandas as pd

    if out_dir is None:
        with tempfile.TemporaryDirectory(prefix="fracbms-life-") as tmp:
            rows = life_rows(paths, out_dir=tmp, start_times=start_times, **options)
    else:
        rows = life_rows(paths, out_dir=out_dir, start_times=start_times, **options)
    return pd.DataFrame(rows, columns=LIFE_COLUMNS)

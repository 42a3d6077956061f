"""Many cells' logs fitted at once: on this machine's cores, or on a Dask
cluster when one machine is not enough.

Each file is fitted exactly as ``host-sim identify battery --input FILE``
fits it, and gives one row: the columns of ``SUMMARY_COLUMNS`` (those of the
CLI's ``--summary-out``): the parameters, their 95 % intervals, the
identifiability flag and why, the rows rejected, the map's levels with
``map=True``, and ``status``/``error`` for a file that gave no fit. A row
does not depend on where or with what else it was fitted, so a cluster gives
the serial run's rows (only ``fit_s``, the wall time, differs).

How the work is cut: one task per ``files_per_task`` files (default 1: a
fit takes about a second or more, far longer than a task's overhead, and
small tasks balance best). Each task runs on one worker thread; the fits
release the GIL, so a worker's threads fit in parallel. What moves over the
network is the paths and the rows: the files themselves are read by the
workers, so every worker must see them at the same paths (a shared or
network file system, or object storage mounted there), and the OCV table
too. Each worker needs this package installed (``pip install fracbms`` with
the same version as the client; numpy, and pandas on the client).

>>> import fracbms.fleet                                  # doctest: +SKIP
>>> from dask.distributed import Client, LocalCluster     # doctest: +SKIP
>>> client = Client(LocalCluster(n_workers=2, threads_per_worker=1))  # doctest: +SKIP
>>> df = fracbms.fleet.identify_many("logs/*.csv", client,
...                                  ocv="ocv.csv", capacity_ah=5.0)  # doctest: +SKIP
>>> df[["file", "r_i", "r_i_lo", "r_i_hi", "identifiable"]]  # doctest: +SKIP
"""

from __future__ import annotations

import os
from typing import Any, Iterable, List, Optional, Sequence, Union

from ._fracbms import SUMMARY_COLUMNS, expand_inputs, identify_files

__all__ = ["SUMMARY_COLUMNS", "identify_many", "expand"]

PathLike = Union[str, "os.PathLike[str]"]


def expand(paths: Union[PathLike, Iterable[PathLike]]) -> List[str]:
    """The files ``paths`` names, as the CLI's ``--input`` names them: one
    path is a file, a directory (its .csv, .txt, .tsv and .mat files) or a
    glob pattern (sorted); a sequence is taken as it is, in order."""
    if isinstance(paths, (str, os.PathLike)):
        return list(expand_inputs(os.fspath(paths)))
    return [os.fspath(p) for p in paths]


def _fit_task(files: Sequence[str], options: dict) -> List[dict]:
    """One task: its files fitted one after another on the worker's thread."""
    return list(identify_files(list(files), jobs=1, **options))


def identify_many(
    paths: Union[PathLike, Iterable[PathLike]],
    client: Optional[Any] = None,
    *,
    files_per_task: int = 1,
    **options: Any,
):
    """Fits every file and returns a pandas DataFrame, one row per file in
    the order of ``paths`` (sorted for a directory or pattern), with the
    columns of ``SUMMARY_COLUMNS``.

    ``client``: a ``dask.distributed.Client``; without one, the files are
    fitted on this machine's cores (``jobs=`` sets how many). ``options``
    are those of :func:`fracbms.identify_files` (``ocv=`` a path,
    ``capacity_ah=``, ``model=``, ``map=``, ``columns=``, ``current_sign=``,
    …); they are checked before any file is fitted.

    A file that cannot be read or fitted is a row with ``status`` ``"error"``
    and its message; the others go on.
    """
    import pandas as pd

    files = expand(paths)
    if files_per_task < 1:
        raise ValueError(f"files_per_task={files_per_task}: must be at least 1")
    # Options refused here, once, rather than in every task.
    identify_files([], **options)
    if client is None:
        rows = list(identify_files(files, **options))
    else:
        options = {k: v for k, v in options.items() if k != "jobs"}
        if "ocv" in options and options["ocv"] is not None:
            options["ocv"] = os.fspath(options["ocv"])
        tasks = [files[k : k + files_per_task] for k in range(0, len(files), files_per_task)]
        futures = client.map(_fit_task, tasks, options=options, pure=False)
        rows = [r for part in client.gather(futures) for r in part]
    return pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))

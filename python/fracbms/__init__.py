"""fracbms: fractional-order battery cells on numpy arrays.

The Python face of fracbms (https://example.invalid/fracbms): the same
functions as the ``host-sim`` command line, on numpy arrays instead of CSV
files, so that a notebook gets what the CLI prints for the same data.

- :func:`identify_battery` fits the fractional cell model (R_i, R_ct, Q, α,
  U_oc; optionally a Butler–Volmer term and an OCV curve) to a whole record:
  ``host-sim identify battery --json``.
- :func:`predict_battery` runs an identified model (or its parameter map,
  ``identify_battery(..., map=True)``) on another record: ``host-sim
  predict battery``.
- :func:`simulate_battery` gives the terminal voltage of a cell over a
  current record, from rest.
- :class:`OnlineCell` tracks the parameters over a sliding window, sample by
  sample, as the firmware does: ``host-sim online battery``.
- :func:`online_pack` runs a series string's record (one current, every
  cell's voltage) through the pack estimator: each cell's parameters, state
  of charge and state of power and the string's: ``host-sim online pack``.
- :func:`identify_files` fits many records read from files (a directory, a
  glob pattern) on all cores, one summary row per file: ``host-sim identify
  battery --input DIR --summary-out``; :mod:`fracbms.fleet` does the same
  on a Dask cluster and returns a pandas DataFrame.
- :func:`identify_hammerstein` identifies a fractional-order Hammerstein
  system (the paper's 2S-OP-GI / KT-2S-GI, then the prediction-error
  refinement): ``host-sim identify hammerstein --json``.

Conventions, stated once: current in A, **positive when charging** (PyBaMM
and PyBOP count discharge positive: pass ``-current``); voltages in V; time
in s (uneven steps are put on a uniform grid as the CLI does); Q in F·s^(α−1); state of charge in [0, 1]; an OCV
table is a pair ``(soc, ocv_v)`` of increasing arrays.

Errors are raised as ``ValueError`` with the CLI's one-line messages; the
data are called ``record`` and rows are numbered as in the CSV file the
arrays would come from: row = index + 2 (the header is row 1). Rows with a
non-finite or implausible current or voltage are rejected and counted, as the
CLI does (``rejected`` in the result); a non-finite time is an error.

Example: simulate a cell, then identify it again.

>>> import numpy as np, fracbms
>>> t = np.arange(2000.0)
>>> i = np.where((t // 100) % 2 == 0, -2.0, 1.0)   # 2 A discharge, 1 A charge
>>> cell = dict(r_i=0.05, r_ct=0.03, q=600.0, alpha=0.8, u_oc=3.7)
>>> v = fracbms.simulate_battery(t, i, **cell)
>>> fit = fracbms.identify_battery(t, i, v)
>>> fit["model"], round(fit["r_i"], 4), round(fit["alpha"], 2), fit["rmse_v"] < 1e-4
('linear', 0.05, 0.8, True)
"""

from ._fracbms import (
    MAX_BATTERY_ROWS,
    MAX_ROWS,
    SUMMARY_COLUMNS,
    OnlineCell,
    expand_inputs,
    identify_battery,
    identify_files,
    identify_hammerstein,
    online_pack,
    predict_battery,
    simulate_battery,
)
from .life import LIFE_COLUMNS, life

__all__ = [
    "LIFE_COLUMNS",
    "MAX_BATTERY_ROWS",
    "MAX_ROWS",
    "SUMMARY_COLUMNS",
    "OnlineCell",
    "expand_inputs",
    "identify_battery",
    "identify_files",
    "identify_hammerstein",
    "life",
    "online_pack",
    "predict_battery",
    "simulate_battery",
]
__version__ = "0.1.0"

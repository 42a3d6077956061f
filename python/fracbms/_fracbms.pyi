"""Type stubs of the extension module ``fracbms._fracbms`` (re-exported by
``fracbms``). The full docstrings are the module's own (``help(fracbms.X)``)."""

import os
from typing import Any, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

ArrayLike = Union[npt.ArrayLike, Sequence[float]]
OcvTable = Tuple[ArrayLike, ArrayLike]
FloatArray = npt.NDArray[np.float64]

MAX_ROWS: int
"""Most rows identify_hammerstein takes (8192)."""

MAX_BATTERY_ROWS: int
"""Most rows identify_battery takes (262144)."""

SUMMARY_COLUMNS: list[str]
"""The keys of identify_files' rows, in the order of the CLI's --summary-out
columns (file, status, error_kind, error, samples, period_s, method, model,
r_i, r_ct, q, alpha, ..., fit_s, paper_start)."""

PathLike = Union[str, "os.PathLike[str]"]

def identify_files(
    paths: Union[PathLike, Sequence[PathLike]],
    *,
    ocv: Optional[PathLike] = None,
    capacity_ah: Optional[float] = None,
    soc0: Optional[float] = None,
    method: Literal["refined", "paper"] = "refined",
    model: Literal["auto", "linear", "butler-volmer"] = "auto",
    iterations: int = 50,
    memory: Optional[int] = None,
    map: bool = False,
    soc_bins: Optional[int] = None,
    min_rest: float = 600.0,
    map_method: Literal["levels", "joint"] = "joint",
    temperature_c: Optional[float] = None,
    columns: Optional[str] = None,
    current_sign: Literal["charge-positive", "discharge-positive"] = "charge-positive",
    period_s: Optional[float] = None,
    steps: Literal["auto", "ignore", "count"] = "auto",
    voltage_min: Optional[float] = None,
    voltage_max: Optional[float] = None,
    current_limit: Optional[float] = None,
    jobs: Optional[int] = None,
) -> list[dict[str, Any]]:
    """Fit records read from files, as ``host-sim identify battery --input
    DIR_OR_GLOB --summary-out`` does, on ``jobs`` threads (default: every
    core) without the GIL: one dict per file with the keys of
    SUMMARY_COLUMNS. ``paths``: a file, a directory, a glob pattern, or a
    sequence of files. A file that fails gives ``status="error"`` and its
    message; options are checked first (ValueError)."""

LIFE_COLUMNS: list[str]
"""The keys of life_rows' rows, in the order of the CLI's --life-out
columns (file, start_time, samples, discharged_ah, charged_ah, r_i,
r_i_status, r_ct, alpha, capacity_ah, capacity_status, soh_c, soh_r,
error, capacity_source)."""

def life_rows(
    paths: Union[PathLike, Sequence[PathLike]],
    *,
    out_dir: PathLike,
    start_times: Optional[PathLike] = None,
    ocv: Optional[PathLike] = None,
    capacity_ah: Optional[float] = None,
    soc0: Optional[float] = None,
    window: int = 256,
    columns: Optional[str] = None,
    current_sign: str = "charge-positive",
    period_s: Optional[float] = None,
    steps: Literal["auto", "ignore", "count"] = "auto",
    voltage_min: Optional[float] = None,
    voltage_max: Optional[float] = None,
) -> list[dict[str, Any]]:
    """A cell's life as `online battery --input DIR --life-out` runs it:
    one dict per log (keys LIFE_COLUMNS), each log's track written into
    out_dir. A log that cannot be run is a warning and a row whose error
    says why; no files, a start-time table that does not cover them or an
    option refused raise ValueError."""

def expand_inputs(path: PathLike) -> list[str]:
    """The files a path names as the CLI's --input does: a file, a
    directory's .csv/.txt/.tsv/.mat files, or a glob pattern's matches,
    sorted."""

def identify_battery(
    time_s: ArrayLike,
    current_a: ArrayLike,
    voltage_v: ArrayLike,
    *,
    ocv: Optional[OcvTable] = None,
    capacity_ah: Optional[float] = None,
    soc0: Optional[float] = None,
    method: Literal["refined", "paper"] = "refined",
    model: Literal["auto", "linear", "butler-volmer"] = "auto",
    iterations: int = 50,
    memory: Optional[int] = None,
    map: bool = False,
    soc_bins: Optional[int] = None,
    min_rest: float = 600.0,
    map_method: Literal["levels", "joint"] = "joint",
    observed: Optional[ArrayLike] = None,
) -> dict[str, Any]:
    """Identify a battery cell from a whole record: the keys of
    ``host-sim identify battery --json`` (r_i, r_ct, q, alpha, u_oc, model,
    bv_a_v, bv_i0_a, ocv_offset_v, soc0, soc_end, rmse_v, confidence,
    identifiable, rejected, ...) plus ``model_v`` (numpy array). Current
    positive when charging; ``observed`` (0/1 per row) marks rows whose
    voltage was not measured, counted in no fit. Raises ValueError with the
    CLI's message."""

def simulate_battery(
    time_s: ArrayLike,
    current_a: ArrayLike,
    *,
    r_i: float,
    r_ct: float,
    q: float,
    alpha: float,
    u_oc: Optional[float] = None,
    bv_a_v: float = 0.0,
    bv_i0_a: float = 1.0,
    ocv: Optional[OcvTable] = None,
    capacity_ah: Optional[float] = None,
    soc0: Optional[float] = None,
    ocv_offset_v: float = 0.0,
) -> FloatArray:
    """The terminal voltage (V) of a cell over a current record (A, positive
    when charging), from rest: ``host-sim simulate battery`` without noise."""

def online_pack(
    current_a: ArrayLike,
    cells_v: npt.ArrayLike,
    h: float = 1.0,
    window: Literal[64, 128, 256, 512, 1024] = 256,
    memory: Optional[int] = None,
    *,
    iterations_per_sample: int = 1,
    updates_per_period: Optional[int] = None,
    flag_ratio: float = 0.3,
    precision: Literal["f64", "f32"] = "f64",
    start: Literal["from-data", "at-rest"] = "from-data",
    tail: bool = False,
    ocv: Optional[OcvTable] = None,
    capacity_ah: Optional[float] = None,
    soc0: Optional[float] = None,
    horizons: Sequence[float] = (10.0, 30.0),
    voltage_min: Optional[float] = None,
    voltage_max: Optional[float] = None,
    current_limit: Optional[float] = None,
    pulse_current_a: Optional[float] = None,
    sop_carry_s: Optional[float] = None,
    sop_confidence: Optional[float] = None,
    pulse_correction: bool = True,
    soc: Literal["observer", "coulomb"] = "observer",
    soc_rest_s: Optional[float] = None,
    soc_bias_sigma_a: Optional[float] = None,
    soc_rest_load_sigma_a: Optional[float] = None,
    soc_voltage_sigma_v: Optional[float] = None,
    capacity_min_span: Optional[float] = None,
    t0: float = 0.0,
    state_in: Optional[bytes] = None,
    return_state: bool = False,
    slow_memory_s: Optional[float] = None,
    slow_memory_soc: Optional[float] = None,
) -> Union[dict[str, Any], tuple[dict[str, Any], bytes]]:
    """A series string's record (``current_a`` one per sample, ``cells_v``
    shape ``(samples, cells)``) through the pack estimator: the columns of
    ``host-sim online pack --out``, one row per sample and cell (cell 1
    first): numbers as float arrays (NaN where empty), ``cell`` int,
    ``rejected``/``flagged`` bool, statuses as lists of str. With ``ocv``
    and ``capacity_ah``, each cell's SOC and state of power
    (``sop_discharge_a_{H}s``…) and the string's (``pack_sop_*``,
    ``pack_pulse_v_*``: the weakest cell's currents, the sum of the pulse
    voltages). ``state_in`` (a snapshot's bytes, the CLI's ``--state-in``)
    starts every cell from it and adds ``restoration``; a rejected one
    raises ``ValueError``. ``return_state=True`` returns ``(track,
    snapshot)``, the CLI's ``--state-out`` bytes. ``t0`` is the first
    sample's time (s), the snapshot's clock. ``slow_memory_s`` is the
    CLI's ``--slow-memory-s``: the published ``r_ct``, ``q`` and ``alpha``
    the mean of what the windows identified, forgetting over that many
    seconds (default: each window's own), and ``slow_memory_soc`` over that
    much state of charge (``--slow-memory-soc``, default 0.02).
    ``capacity_min_span`` is ``--capacity-min-span``: the SOC two rests
    linked by the count must read apart before a cell's capacity is
    identified (default 0.3)."""

class OnlineCell:
    """The online estimator of one cell (``host-sim online battery``): a
    sliding window refitted after every sample, as the firmware runs it."""

    def __init__(
        self,
        window: Literal[64, 128, 256, 512, 1024] = 256,
        memory: int = 64,
        h: float = 1.0,
        ocv: Optional[OcvTable] = None,
        capacity_ah: Optional[float] = None,
        *,
        soc0: Optional[float] = None,
        method: Literal["refined", "paper"] = "refined",
        model: Literal["auto", "linear", "butler-volmer"] = "auto",
        precision: Literal["f64", "f32"] = "f64",
        start: Literal["from-data", "at-rest"] = "from-data",
        iterations_per_sample: int = 1,
        tail: bool = False,
        prior: Optional[Union[str, os.PathLike[str], dict[str, Any]]] = None,
        map: Optional[Union[str, os.PathLike[str], dict[str, Any]]] = None,
        prior_factor: float = 2.0,
        prior_alpha_sigma: float = 0.1,
        prior_noise_mv: float = 100.0,
        horizons: Sequence[float] = (10.0, 30.0),
        voltage_min: Optional[float] = None,
        voltage_max: Optional[float] = None,
        current_limit: Optional[float] = None,
        pulse_current_a: Optional[float] = None,
        soc: Literal["observer", "coulomb"] = "observer",
        soc_rest_s: Optional[float] = None,
        soc_bias_sigma_a: Optional[float] = None,
        soc_rest_load_sigma_a: Optional[float] = None,
        soc_voltage_sigma_v: Optional[float] = None,
        sop_carry_s: Optional[float] = None,
        sop_confidence: Optional[float] = None,
        pulse_correction: bool = True,
        slow_memory_s: Optional[float] = None,
        slow_memory_soc: Optional[float] = None,
        capacity_min_span: Optional[float] = None,
        voltage_timing: Literal["end", "mean", "start"] = "end",
    ) -> None:
        """``horizons`` (s), ``voltage_min``/``voltage_max`` (V; default the OCV
        table's range), ``current_limit`` (A) and ``pulse_current_a`` (A, +
        charging; default a 1C discharge) give the state-of-power columns
        (``sop_carry_s``: how long, s, they may be carried from the last fit
        through a rest; default as far as the window reaches; ``sop_confidence``:
        how many standard deviations of the pulse voltage the currents keep
        inside the limits, default 2; ``pulse_correction``: the pulse voltage
        corrected by the last pulse of its current, default yes)
        ``sop_discharge_a_{H}s``, ``sop_charge_a_{H}s``, ``pulse_v_{H}s``,
        ``sop_basis``, ``sop_uncertainty_v``, ``sop_uncertainty_v_{H}s`` and
        ``pulse_ratio_{H}s``, as ``host-sim online battery``'s flags
        (``pulse_correction=False`` its ``--no-pulse-correction``). With an OCV table, ``soc`` is
        the observer's (``soc="observer"``: the count corrected at each rest
        of ``soc_rest_s``, default 600 s, with ``current_bias_a`` (its prior
        spread ``soc_bias_sigma_a``, default C/50; 0: none; each rest's mean
        current reads it, give or take ``soc_rest_load_sigma_a``, default
        C/1000; a rested voltage read as the OCV give or take
        ``soc_voltage_sigma_v``, default 0.005 V),
        ``capacity_ah``, ``capacity_sigma_ah``, ``soc_sigma``,
        ``soc_ocv_weight``; ``capacity_status`` ``identified`` once two rests
        linked by the count read SOCs ``capacity_min_span`` apart, default
        0.3, and the spread is within 2 %) or the count
        (``soc="coulomb"``); ``soc_coulomb`` is always the count.
        ``slow_memory_s`` (s; ``--slow-memory-s``): the published ``r_ct``,
        ``q`` and ``alpha`` the mean of what the windows identified,
        forgetting over that many seconds (default: each window's own), and
        ``slow_memory_soc`` over that much state of charge
        (``--slow-memory-soc``, default 0.02). ``voltage_timing``: where
        in the period whose mean current a sample holds its voltage was
        taken, as the check of the state of power against the next pulse
        places it: ``"end"`` (default) a gauge or a simulation, ``"mean"`` a
        log put on a coarser period than its rows (as ``host-sim online
        battery`` reads it where it merges rows), ``"start"`` a log's
        instants whose current holds exactly through each period."""
    def push(
        self, current_a: float, voltage_v: float, temperature_c: Optional[float] = None
    ) -> Optional[dict[str, Any]]:
        """Feed one sample; the estimate and ``status`` after it (None while
        the window is filling). Never raises on data: a bad sample is
        rejected (``rejected``) and the last good estimate kept.
        ``temperature_c`` picks a map prior's temperature."""
    def run(
        self,
        current_a: ArrayLike,
        voltage_v: ArrayLike,
        temperature_c: Optional[ArrayLike] = None,
    ) -> dict[str, np.ndarray]:
        """Feed a whole record; the columns of ``host-sim online battery
        --out`` as numpy arrays (NaN where the CSV is empty), plus
        ``rejected``. ``temperature_c`` (one per sample) picks a map prior's
        temperature."""
    def resume_after_gap(self, rested: bool) -> None:
        """The record resumes after a gap of unknown charge: the window
        restarts and, when ``rested``, the state of charge is read again
        from the next rested voltages through the OCV table and the
        restarted window is fitted from rest until it slides."""
    def save_state(self, saved_at_s: Optional[float] = None) -> bytes:
        """The snapshot of what the cell has learned (docs/persistence.md):
        the bytes of ``host-sim online battery --state-out`` and of the C
        ABI's ``fracbms_cell_snapshot_save``. ``saved_at_s``: the caller's
        clock (s), judged for the age at a restore."""
    def restore_state(self, snapshot: bytes, now_s: Optional[float] = None) -> None:
        """Restore from ``save_state``'s bytes before the first sample:
        parameters published as ``restored`` until a window identifies
        them, the SOC read again when the first rested voltage contradicts
        it. Raises ValueError (the cell stays clean) for a corrupt, stale,
        foreign or implausible snapshot."""
    @property
    def restoration(self) -> str:
        """``"clean"``, ``"restored"`` or ``"soc_reread"``."""
    @property
    def samples(self) -> int:
        """Samples offered so far."""
    @property
    def rejected(self) -> int:
        """Samples rejected (and substituted) so far."""
    @property
    def published(self) -> dict[str, Any]:
        """What has been published so far: ``samples``, ``state_of_power``
        and per parameter (``r_i``, ``r_ct``, ``q``, ``alpha``) the samples
        of every status, as ``online battery`` says after its track."""
    @property
    def window(self) -> int:
        """The window length L."""
    @property
    def memory(self) -> int:
        """The short memory M."""
    @property
    def h(self) -> float:
        """The sample period (s)."""

def identify_hammerstein(
    u: ArrayLike,
    y: ArrayLike,
    *,
    na: int,
    nb: int,
    nc: int,
    basis: str = "poly:2",
    algorithm: Literal["op", "kt"] = "op",
    method: Literal["refined", "paper"] = "refined",
    memory: Optional[int] = None,
    iterations: int = 100,
    refine_iterations: int = 400,
    alpha0: float = 0.45,
) -> dict[str, Any]:
    """Identify a fractional-order Hammerstein system: the keys of
    ``host-sim identify hammerstein --json`` (a, b, c, gamma, alpha,
    theta_products, cost, paper_cost, refine_*, history, ...)."""


def predict_battery(
    time_s: ArrayLike,
    current_a: ArrayLike,
    voltage_v: ArrayLike,
    *,
    model: dict[str, Any],
    ocv: Optional[OcvTable] = None,
    capacity_ah: Optional[float] = None,
    soc0: Optional[float] = None,
    temperature_c: Optional[float] = None,
) -> dict[str, Any]:
    """Run the model of identify_battery (its dict, or its ``map``) on
    another record: ``host-sim predict battery``'s errors (``in_table``:
    inside the OCV table; ``map``: what a map used) plus ``model_v`` and
    ``observed`` (0/1: the samples the RMSE is taken over); a map over
    temperature is taken at ``temperature_c`` (Arrhenius between)."""
    ...

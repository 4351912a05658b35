"""vibrobar: vibro-impact (impact-damped) boring bars in Python.

The exact event-driven solver, sweeps, design maps and the analyses of the ``vibrobar`` command
line, with NumPy results identical to the command line's, bit for bit. Units are SI throughout
and every name carries its unit (``gap_m``, ``dt_s``, ``rms_damped_m``).

    >>> import vibrobar
    >>> sc = vibrobar.Scenario.paper(gap_m=1e-4, friction="coulomb")
    >>> r = vibrobar.run(sc)
    >>> r.rms_m, r.impacts
    >>> s = vibrobar.sweep(sc, ratios=[0.98, 1.0, 1.02])
    >>> import pandas; pandas.DataFrame(s)

Every function takes a :class:`Scenario` (default: the paper's) and keyword overrides of it
(``solver="rk4"``, ``duration_s=0.5``, ...). Long calls release the GIL, run in parallel on the
library's thread pool, report to ``progress`` (a callable ``progress(done, total)``, or ``True``
for a progress bar: tqdm when installed) and stop on Ctrl-C with ``KeyboardInterrupt``.
"""

from __future__ import annotations

import os as _os
import sys as _sys
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as _np

from . import _vibrobar
from ._vibrobar import DEFAULT_SOLVER, Scenario, __version__, solver_names

__all__ = [
    "Scenario",
    "Table",
    "SweepResult",
    "MapResult",
    "RunResult",
    "run",
    "sweep",
    "map",
    "design_map",
    "regime",
    "poincare",
    "bifurcation",
    "lyapunov",
    "lyapunov_spectrum",
    "orbit",
    "continuation",
    "continuation2",
    "ensemble",
    "lobes",
    "fit_modes",
    "ModalFit",
    "width_diagram",
    "time_domain_lobes",
    "lobe_design",
    "read_frf",
    "write_uff58",
    "frf",
    "two_plane",
    "two_plane_run",
    "TwoPlaneRun",
    "TwoPlaneTable",
    "submit",
    "solver_names",
    "DEFAULT_SOLVER",
    "__version__",
]

ArrayLike = Union[Sequence[float], _np.ndarray, float]
Progress = Union[None, bool, Callable[[int, int], Any]]

# Units of the columns of every table (xarray attributes; the names carry them too).
UNITS = {
    "ratio": "1 (Ω/ω₁)",
    "gap_mm": "mm",
    "gap_m": "m",
    "rms_solid_m": "m",
    "rms_damped_m": "m",
    "mean_rms_m": "m",
    "std_rms_m": "m",
    "min_rms_m": "m",
    "max_rms_m": "m",
    "reduction_pct": "%",
    "impacts": "1",
    "impacts_per_cycle": "1/cycle",
    "friction_force_n": "N",
    "restitution": "1",
    "mass_ratio": "1",
    "t_s": "s",
    "u_m": "m",
    "du_m_s": "m/s",
    "v_m": "m",
    "dv_m_s": "m/s",
    "w_m": "m",
    "dw_m_s": "m/s",
    "spindle_rpm": "rpm",
    "b_lim_m": "m",
    "b_lim_ball_stuck_m": "m",
    "b_lim_solid_m": "m",
    "chatter_frequency_hz": "Hz",
    "chatter_frequency_ball_stuck_hz": "Hz",
    "chatter_frequency_solid_hz": "Hz",
    "ball_mass_kg": "kg",
    "position_m": "m",
    "worst_width_m": "m",
    "worst_rpm": "rpm",
    "mean_width_m": "m",
    "solid_worst_width_m": "m",
    "solid_worst_rpm": "rpm",
    "solid_mean_width_m": "m",
    "axial_gap_m": "m",
    "hole_angle_deg": "°",
    "hole_diameter_m": "m",
    "radial_clearance_m": "m",
    "member": "1",
}


class Table(dict):
    """A table as a mapping column name → 1-d NumPy array (``pandas.DataFrame(table)`` works).

    Column names are the command line's CSV columns; :meth:`to_csv` gives the CSV text the
    command line writes for the same rows, character for character.
    """

    _dims: tuple = ()

    def __init__(self, columns: Mapping[str, Any], csv: Optional[str] = None):
        super().__init__(
            (k, v if isinstance(v, _np.ndarray) else _np.asarray(v, dtype=str))
            for k, v in columns.items()
        )
        self._csv = csv

    def __len__(self) -> int:  # number of columns, as a dict
        return super().__len__()

    @property
    def rows(self) -> int:
        """Number of rows."""
        return len(next(iter(self.values()))) if self else 0

    def to_csv(self) -> str:
        """The CSV text of the command line's file for these rows (header first)."""
        if self._csv is None:
            raise ValueError("this table has no CSV form")
        return self._csv

    def to_pandas(self):
        """A ``pandas.DataFrame`` (needs pandas)."""
        import pandas

        return pandas.DataFrame(self)

    def to_xarray(self):
        """An ``xarray.Dataset`` on the grid's dimensions, units in each variable's attributes.

        Needs xarray. Points missing from the grid are NaN (numbers) or "" (text).
        """
        import xarray

        dims = [d for d in self._dims if d in self]
        if not dims:
            raise ValueError("this table has no grid dimensions")
        coords = {d: _np.unique(self[d]) for d in dims}
        index = tuple(_np.searchsorted(coords[d], self[d]) for d in dims)
        shape = tuple(len(coords[d]) for d in dims)
        data = {}
        for name, col in self.items():
            if name in dims:
                continue
            if col.dtype.kind in "fiu":
                a = _np.full(shape, _np.nan)
            else:
                a = _np.full(shape, "", dtype=object)
            a[index] = col
            data[name] = (dims, a, {"units": UNITS[name]} if name in UNITS else {})
        ds = xarray.Dataset(data, coords=coords)
        for d in dims:
            ds[d].attrs["units"] = UNITS.get(d, "")
        return ds


class SweepResult(Table):
    """Rows of a sweep (gap-major), columns as ``vibrobar sweep``'s CSV; xarray dims ratio × gap_mm."""

    _dims = ("gap_mm", "ratio")


class MapResult(Table):
    """Rows of a design map in grid order, columns as ``vibrobar map``'s CSV."""

    _dims = ("ratio", "gap_mm", "friction_force_n", "restitution", "mass_ratio")


class TwoPlaneTable(Table):
    """Rows of a sweep, an ensemble or a design map of a scenario with ``[two_plane]``, columns
    as the command line's CSV of the same command; xarray dims: the grid's axes (and ``member``
    for an ensemble)."""

    def __init__(self, columns: Mapping[str, Any], csv: Optional[str], dims: tuple):
        super().__init__(columns, csv)
        self._dims = dims


class RunResult:
    """One run: the history (``t_s``, ``u_m``, ``du_m_s``, ``v_m``, ``dv_m_s``, ``w_m``,
    ``dw_m_s`` as arrays, also in :attr:`history`), the impacts and the statistics.

    Attributes:
        history: Table of the sampled states (the CLI's history columns; ``w_m`` is the ball
            relative to the cavity centre).
        impact_table: Table with ``t_s`` (s), ``wall`` (+1 / −1), ``dw_before_m_s`` and
            ``dw_after_m_s`` (relative velocity ẇ before and after, m/s), ``energy_loss_j`` (J).
        rms_m: RMS of the bar displacement u over the RMS window (the last ``rms_fraction``), m.
        impacts: impacts over the whole run.
        impacts_in_window: impacts in the RMS window.
        impacts_per_cycle: impacts per forcing cycle in the RMS window.
        max_penetration_m: largest ``|w| − l_g`` (0 when the ball stayed inside), m.
        energy: energy books of the whole run, J: ``work_input_j``, ``viscous_loss_j``,
            ``impact_loss_j``, ``friction_work_j``, ``delta_mechanical_j``, ``residual_j``.
        solver: the solver's name.
    """

    def __init__(self, d: dict):
        self.history = Table(d["history"])
        self.impact_table = Table(d["impact_table"])
        self.impact_table_truncated: bool = d["impact_table_truncated"]
        self.rms_m: float = d["rms_m"]
        self.impacts: int = d["impacts"]
        self.impacts_in_window: int = d["impacts_in_window"]
        self.impacts_per_cycle: float = d["impacts_per_cycle"]
        self.max_penetration_m: float = d["max_penetration_m"]
        self.energy: dict = d.get("energy", {})
        self.solver: str = d["solver"]

    def __getattr__(self, name: str):
        history = self.__dict__.get("history")
        if history is not None and name in history:
            return history[name]
        raise AttributeError(name)

    def __repr__(self) -> str:
        return (
            f"RunResult(rms_m={self.rms_m:.6e}, impacts={self.impacts}, "
            f"max_penetration_m={self.max_penetration_m:.3e}, samples={self.history.rows}, "
            f"solver={self.solver!r})"
        )


# ---------------------------------------------------------------------------------------------


def _scenario(scenario: Optional[Scenario], overrides: dict) -> Scenario:
    if scenario is None:
        scenario = Scenario.paper()
    elif not isinstance(scenario, Scenario):
        raise TypeError(
            f"scenario must be a vibrobar.Scenario, got {type(scenario).__name__} "
            "(make one with Scenario.paper(), Scenario.paper_beam() or Scenario.from_toml(path))"
        )
    return scenario.replace(**overrides) if overrides else scenario


def _array(name: str, x: Any, required: bool = True) -> Optional[_np.ndarray]:
    """A 1-d float64 array argument; a scalar is one value."""
    if x is None:
        if required:
            raise TypeError(f"{name} is required")
        return None
    if isinstance(x, (str, bytes)):
        raise TypeError(f"{name} must be a number or a 1-d array of numbers, got {x!r}")
    try:
        a = _np.asarray(x, dtype=_np.float64)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{name} must be a number or a 1-d array of numbers: {e}") from None
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise ValueError(f"{name} must be 1-d, got an array of shape {a.shape}")
    return _np.ascontiguousarray(a)


def _number(name: str, x: Any, optional: bool = True) -> Optional[float]:
    if x is None and optional:
        return None
    if isinstance(x, bool) or not isinstance(x, (int, float, _np.integer, _np.floating)):
        raise TypeError(f"{name} must be a number, got {type(x).__name__}")
    return float(x)


def _threads(threads: Any) -> Optional[int]:
    if threads is None:
        return None
    if isinstance(threads, bool) or not isinstance(threads, (int, _np.integer)):
        raise TypeError(f"threads must be an int, got {type(threads).__name__}")
    if threads < 1:
        raise ValueError(f"threads = {threads} is outside the allowed range [1, ∞)")
    return int(threads)


def _progress(progress: Progress, label: str):
    """The callback for ``progress``: a callable as given, ``True`` a bar (tqdm if installed)."""
    if progress is None or progress is False:
        return None, lambda: None
    if callable(progress):
        return progress, lambda: None
    if progress is not True:
        raise TypeError("progress must be None, True or a callable progress(done, total)")
    try:
        from tqdm.auto import tqdm
    except ImportError:
        tqdm = None
    if tqdm is not None:
        bar = tqdm(desc=label, total=None, unit="run")

        def cb(done, total):
            bar.total = total
            bar.n = done
            bar.refresh()

        return cb, bar.close

    def cb(done, total):
        print(f"\r{label}: {done}/{total}", end="", file=_sys.stderr, flush=True)

    return cb, lambda: print(file=_sys.stderr)


class TwoPlaneRun:
    """One run of the bar that bends in two planes (``vibrobar run`` on a scenario with
    ``[two_plane]``).

    Attributes:
        history: Table of the sampled states: ``t_s``; the bar in the cross-section's x (radial)
            and y (tangential), ``u_x_m``, ``u_y_m``, ``du_x_m_s``, ``du_y_m_s``, and along the
            force, ``u_force_m``; the ball relative to the cavity along and across the hole,
            ``w_along_m``, ``w_across_m``, ``dw_along_m_s``, ``dw_across_m_s``; its spin
            ``spin_rad_s``. ``history.to_csv()`` is the command line's file.
        rms_along_force_m, rms_radial_m, rms_tangential_m, rms_total_m: RMS over the window, m.
        solid_rms_m: RMS along the force of the bar without its ball, m; reduction_pct: the
            reduction against it, %.
        walls: per wall (``axial_plus``, ``axial_minus``, ``across_plus``, ``across_minus``) its
            ``impacts`` and the window fractions the ball rests on it ``rolling``, ``sliding``,
            ``stuck``.
        flight_fraction: window fraction the ball touches no wall; events: all events.
        max_penetration_m: largest depth beyond a wall (0 when the ball stayed inside), m.
        energy: the energy book, J: ``forcing_work_j``, ``viscous_loss_j``, ``impact_loss_j``,
            ``sliding_loss_j``, ``rolling_loss_j``, ``delta_mechanical_j``, ``residual_j``.
        solver: ``"exact"`` or ``"reference"``; member: which member of the ensemble ran.
    """

    def __init__(self, d: dict):
        self.history = Table(d["history"], csv=d["history_csv"])
        for k in (
            "rms_along_force_m",
            "rms_radial_m",
            "rms_tangential_m",
            "rms_total_m",
            "solid_rms_m",
            "reduction_pct",
            "walls",
            "flight_fraction",
            "events",
            "max_penetration_m",
            "energy",
            "solver",
            "member",
        ):
            setattr(self, k, d[k])

    def __repr__(self) -> str:
        return (
            f"TwoPlaneRun(rms_along_force_m={self.rms_along_force_m:.6e}, "
            f"reduction_pct={self.reduction_pct:.2f}, solver={self.solver!r}, "
            f"member={self.member}, samples={self.history.rows})"
        )


def two_plane_run(
    scenario: Scenario, *, member: int = 0, sample_every: int = 10, **overrides
) -> TwoPlaneRun:
    """One run of a scenario with ``[two_plane]`` (``vibrobar run`` on it): one member of its
    ensemble of starts on its solver, the history and the summary.

    Args:
        scenario: a scenario with a ``[two_plane]`` section (``Scenario.from_toml``).
        member: which member of the scenario's ensemble of starts, in ``[0, members)``: 0 is the
            bar at rest with the ball resting where gravity presses it; the others are drawn as
            ``vibrobar sweep`` and ``vibrobar ensemble`` draw them.
        sample_every: keep one history row every this many steps of ``dt_s``, ≥ 1.
        **overrides: scenario keyword overrides (``gap_m=1e-4``, ``frequency_ratio=1.0``, ...).

    Returns:
        TwoPlaneRun.
    """
    sc = _scenario(scenario, overrides)
    for name, x in (("member", member), ("sample_every", sample_every)):
        if isinstance(x, bool) or not isinstance(x, (int, _np.integer)):
            raise TypeError(f"{name} must be an int, got {type(x).__name__}")
    if member < 0:
        raise ValueError(f"member = {member} is outside the allowed range [0, members)")
    if sample_every < 1:
        raise ValueError(f"sample_every = {sample_every} is outside the allowed range [1, ∞) steps")
    return TwoPlaneRun(_vibrobar.two_plane_run(sc, int(member), int(sample_every)))


def _two_plane_refuse(function: str, given: Mapping[str, Any], why: str) -> None:
    """Refuse, for a scenario with ``[two_plane]``, the arguments of the one-plane model."""
    for name, x in given.items():
        if x is not None:
            raise ValueError(f"{name}: {why} (vibrobar.{function} of a scenario with [two_plane])")


def _two_plane_refuse_one(function: str, given: Mapping[str, Any], why: str) -> None:
    """Refuse, for a scenario without ``[two_plane]``, the arguments of the two-plane model."""
    for name, x in given.items():
        if x is not None:
            raise ValueError(
                f"{name}: {why}; this scenario has no [two_plane] section (vibrobar.{function})"
            )


def _two_plane_start(start: str, branch: Any) -> None:
    """A [two_plane] orbit starts from the run a member settles on."""
    if start not in ("auto", "settled") or branch is not None:
        raise ValueError(
            f"start = {start!r}, branch = {branch!r}: a [two_plane] orbit starts from the run a "
            "member settles on (start = 'auto' or 'settled', no branch); the analytic symmetric "
            "orbit is the one-plane model's"
        )


def _two_plane_table(kind, sc, ratios, gaps_m, cb, close, threads, members=None, seed=None,
                     hole_angles_deg=None, hole_diameters_m=None, dims=()):
    for name, x in (("members", members), ("seed", seed)):
        if x is None:
            continue
        if isinstance(x, bool) or not isinstance(x, (int, _np.integer)):
            raise TypeError(f"{name} must be an int, got {type(x).__name__}")
        if x < 0:
            raise ValueError(f"{name} = {x} is outside the allowed range [0, ∞)")
    try:
        cols, csv = _vibrobar.two_plane_table(
            sc,
            kind,
            _array("ratios", ratios, False),
            _array("gaps_m", gaps_m, False),
            _array("hole_angles_deg", hole_angles_deg, False),
            _array("hole_diameters_m", hole_diameters_m, False),
            None if members is None else int(members),
            None if seed is None else int(seed),
            cb,
            _threads(threads),
        )
    finally:
        close()
    return TwoPlaneTable(cols, csv, dims)


def _member(member: Any) -> int:
    if isinstance(member, bool) or not isinstance(member, (int, _np.integer)):
        raise TypeError(f"member must be an int, got {type(member).__name__}")
    if member < 0:
        raise ValueError(f"member = {member} is outside the allowed range [0, members)")
    return int(member)


def run(scenario: Optional[Scenario] = None, *, sample_every: int = 10, **overrides) -> RunResult:
    """One run of the scenario (``vibrobar run``): its gap, frequency ratio, initial state,
    solver, duration and step.

    Args:
        scenario: the scenario (default: the paper's).
        sample_every: keep one history row every this many time steps (every ``sample_every·dt_s``
            seconds), ≥ 1.
        **overrides: scenario keyword overrides (``gap_m=1e-4``, ``frequency_ratio=1.0``,
            ``solver="rk4"``, ...).

    Returns:
        RunResult: the history arrays, the impact table, ``rms_m`` (m), ``impacts``,
        ``max_penetration_m`` (m) and the energy books (J).
    """
    sc = _scenario(scenario, overrides)
    if isinstance(sample_every, bool) or not isinstance(sample_every, (int, _np.integer)):
        raise TypeError(f"sample_every must be an int, got {type(sample_every).__name__}")
    if sample_every < 1:
        raise ValueError(f"sample_every = {sample_every} is outside the allowed range [1, ∞) steps")
    return RunResult(_vibrobar.run(sc, int(sample_every)))


def sweep(
    scenario: Optional[Scenario] = None,
    ratios: Optional[ArrayLike] = None,
    gaps_m: Optional[ArrayLike] = None,
    *,
    freqs_hz: Optional[ArrayLike] = None,
    progress: Progress = None,
    threads: Optional[int] = None,
    **overrides,
) -> SweepResult:
    """RMS of the damped and of the solid bar over frequency ratios × gaps (``vibrobar sweep``).

    Args:
        scenario: the scenario (default: the paper's).
        ratios: forcing frequency ratios Ω/ω₁ (> 0), each bar at its own ω₁; default (without
            ``freqs_hz``): the scenario's ``[sweep]`` range.
        gaps_m: total clearances in m (> 0); default: the scenario's ``[sweep] gaps_m``.
        freqs_hz: absolute forcing frequencies in Hz (in (0, 1e7]) instead of ``ratios``
            (``sweep --freqs-hz``): the damped and the solid bar both run at the same Ω; the
            ``ratio`` column is then Ω/ω₁ of the damped bar. ``start + step * np.arange(n)``
            gives the CLI's ``START:STOP:STEP`` values.
        progress: ``progress(done, total)`` callable over the runs, or True for a progress bar.
        threads: worker threads (default: all cores, or ``RAYON_NUM_THREADS``).
        **overrides: scenario keyword overrides (``solver="rk4"``, ``friction="coulomb"``, ...).

    Returns:
        SweepResult: columns ``ratio``, ``gap_mm`` (mm), ``friction``, ``solver``,
        ``rms_solid_m`` (m), ``rms_damped_m`` (m), ``reduction_pct`` (%), ``impacts``; rows
        gap-major, as the CLI's CSV.

        For a scenario with ``[two_plane]``: a TwoPlaneTable, one row per (gap, ratio), each
        point an ensemble of the scenario's starts, with the columns of ``vibrobar sweep`` on
        it (``axial_gap_m``, ``ratio``, ``solver``, ``members``, the RMS along the force and its
        reduction as mean, standard error and range, the one-plane model's from the same
        starts, ``solid_rms_m``, the RMS per direction, impacts and flight). ``freqs_hz`` does
        not apply there: ratios refer to the bar's lower principal frequency or first mode.
    """
    _one_frequency_axis(ratios, freqs_hz, required=False)
    sc = _scenario(scenario, overrides)
    if sc.is_two_plane:
        _two_plane_refuse("sweep", {"freqs_hz": freqs_hz}, "give frequency ratios (ratios)")
        cb, close = _progress(progress, "sweep")
        return _two_plane_table("sweep", sc, ratios, gaps_m, cb, close, threads,
                                dims=("axial_gap_m", "ratio"))
    cb, close = _progress(progress, "sweep")
    try:
        cols, csv = _vibrobar.sweep(
            sc,
            _array("ratios", ratios, False),
            _array("gaps_m", gaps_m, False),
            cb,
            _threads(threads),
            _array("freqs_hz", freqs_hz, False),
        )
    finally:
        close()
    return SweepResult(cols, csv)


def map(
    scenario: Optional[Scenario] = None,
    ratios: ArrayLike = None,
    gaps_m: ArrayLike = None,
    *,
    freqs_hz: Optional[ArrayLike] = None,
    friction_forces_n: Optional[ArrayLike] = None,
    restitutions: Optional[ArrayLike] = None,
    mass_ratios: Optional[ArrayLike] = None,
    hole_angles_deg: Optional[ArrayLike] = None,
    hole_diameters_m: Optional[ArrayLike] = None,
    progress: Progress = None,
    threads: Optional[int] = None,
    client: Any = None,
    shards: Optional[int] = None,
    **overrides,
) -> MapResult:
    """A design map (``vibrobar map``): every combination of the axes given.

    Args:
        scenario: the scenario (default: the paper's).
        ratios: forcing frequency ratios Ω/ω₁ (> 0), each bar at its own ω₁.
        gaps_m: total clearances in m (> 0).
        freqs_hz: absolute forcing frequencies in Hz (in (0, 1e7]) instead of ``ratios``
            (``map --freqs-hz``): the damped and the solid bar both run at the same Ω; the
            ``ratio`` column is then Ω/ω₁ of the damped bar. Give exactly one of ``ratios`` and
            ``freqs_hz``.
        friction_forces_n: optional axis, friction force levels in N (≥ 0).
        restitutions: optional axis, coefficients of restitution in [0, 1].
        mass_ratios: optional axis, ball mass over bar mass (> 0).
        progress: ``progress(done, total)`` callable over the runs, or True for a progress bar.
        threads: worker threads (default: all cores; on a Dask cluster, per task).
        client: a ``dask.distributed.Client``: run the map as ``shards`` Dask tasks (round-robin
            over the ratios) and merge them; the result is the same, bit for bit. Progress then
            counts ratios as shards finish; Ctrl-C cancels the tasks. :func:`submit` gives the
            future instead.
        shards: number of Dask tasks (default: 4 per worker; at most one per ratio).
        **overrides: scenario keyword overrides.

        hole_angles_deg, hole_diameters_m: axes of a scenario with ``[two_plane]`` only: hole
            directions (degrees from the radial direction, in [−360, 360]) and hole diameters
            (m); default: the scenario's hole.

    Returns:
        MapResult: columns ``ratio``, ``gap_mm`` (mm), the optional axes, ``rms_solid_m`` (m),
        ``rms_damped_m`` (m), ``reduction_pct`` (%), ``impacts_per_cycle``, ``regime``.

        For a scenario with ``[two_plane]``: a TwoPlaneTable, one row per cell (hole diameter,
        hole angle, gap, then ratio fastest), each an ensemble of the scenario's starts, with
        the columns of ``vibrobar map`` on it (``ratio``, ``axial_gap_m``, ``hole_angle_deg``,
        ``hole_diameter_m``, ``radial_clearance_m``, ``solver``, ``members``, the reduction
        along the force as mean, standard error and range, the one-plane model's, the RMS,
        impacts on the plugs and on the hole's wall, flight). ``freqs_hz``,
        ``friction_forces_n``, ``restitutions``, ``mass_ratios`` and ``client`` do not apply
        there.
    """
    _one_frequency_axis(ratios, freqs_hz, required=True)
    sc = _scenario(scenario, overrides)
    if sc.is_two_plane:
        _two_plane_refuse("map", {
            "freqs_hz": freqs_hz,
            "friction_forces_n": friction_forces_n,
            "restitutions": restitutions,
            "mass_ratios": mass_ratios,
            "client": client,
            "shards": shards,
        }, "not an axis or option of the two-plane map")
        cb, close = _progress(progress, "map")
        return _two_plane_table(
            "map", sc, ratios, gaps_m, cb, close, threads,
            hole_angles_deg=hole_angles_deg, hole_diameters_m=hole_diameters_m,
            dims=("ratio", "axial_gap_m", "hole_angle_deg", "hole_diameter_m"),
        )
    _two_plane_refuse_one("map", {"hole_angles_deg": hole_angles_deg,
                              "hole_diameters_m": hole_diameters_m},
                      "an axis of a scenario with [two_plane] only")
    cb, close = _progress(progress, "map")
    if client is not None:
        try:
            return _on_dask(client, "map", sc, ratios, shards, cb, gaps_m=gaps_m,
                            friction_forces_n=friction_forces_n, restitutions=restitutions,
                            mass_ratios=mass_ratios, threads=threads, freqs_hz=freqs_hz)
        finally:
            close()
    try:
        cols, csv = _vibrobar.design_map(
            sc,
            _array("ratios", ratios, False),
            _array("gaps_m", gaps_m),
            _array("friction_forces_n", friction_forces_n, False),
            _array("restitutions", restitutions, False),
            _array("mass_ratios", mass_ratios, False),
            cb,
            _threads(threads),
            _array("freqs_hz", freqs_hz, False),
        )
    finally:
        close()
    return MapResult(cols, csv)


design_map = map


def regime(
    scenario: Optional[Scenario] = None,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    **overrides,
) -> dict:
    """The steady-state impact regime at one point (solid and damped runs).

    Args:
        ratio: Ω/ω₁ (default: the scenario's). gap_m: clearance in m (default: the scenario's).

    Returns:
        dict: ``regime`` (e.g. ``"none"`` without impacts, ``"chaotic"``; the names of ``vibrobar map``), ``ratio``, ``gap_m`` (m),
        ``rms_solid_m``, ``rms_damped_m`` (m), ``reduction_pct`` (%), ``impacts_per_cycle``.
    """
    sc = _scenario(scenario, overrides)
    return _vibrobar.regime(sc, _number("ratio", ratio), _number("gap_m", gap_m))


def poincare(
    scenario: Optional[Scenario] = None,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    *,
    phase_deg: float = 0.0,
    transient_s: Optional[float] = None,
    member: Optional[int] = None,
    **overrides,
) -> Table:
    """Stroboscopic Poincaré section: the state once per forcing period at phase ``phase_deg``.

    Args:
        ratio: Ω/ω₁; gap_m: clearance in m (defaults: the scenario's).
        phase_deg: forcing phase of the section in degrees.
        transient_s: discarded time in s (default: the part before the RMS window).
        member: for a scenario with ``[two_plane]``, which member of its ensemble of starts runs
            (default 0: the ball resting where gravity presses it); ``gap_m`` is the axial gap.

    Returns:
        Table: ``t_s`` (s), ``u_m`` (m), ``du_m_s`` (m/s), ``w_m`` (m), ``dw_m_s`` (m/s).
        For a scenario with ``[two_plane]``: the columns of :func:`two_plane_run`'s history
        (``vibrobar poincare`` on it).
    """
    sc = _scenario(scenario, overrides)
    if sc.is_two_plane:
        return Table(
            _vibrobar.two_plane_poincare(
                sc,
                _number("ratio", ratio),
                _number("gap_m", gap_m),
                _member(0 if member is None else member),
                _number("phase_deg", phase_deg, False),
                _number("transient_s", transient_s),
            )
        )
    _two_plane_refuse_one("poincare", {"member": member}, "a member of a two-plane ensemble")
    return Table(
        _vibrobar.poincare(
            sc,
            _number("ratio", ratio),
            _number("gap_m", gap_m),
            _number("phase_deg", phase_deg, False),
            _number("transient_s", transient_s),
        )
    )


def bifurcation(
    scenario: Optional[Scenario] = None,
    param: str = "ratio",
    values: ArrayLike = None,
    *,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    phase_deg: float = 0.0,
    transient_s: Optional[float] = None,
    progress: Progress = None,
    **overrides,
):
    """A bifurcation diagram: stroboscopic points of u while ``param`` takes ``values``.

    Args:
        param: ``"ratio"`` (Ω/ω₁) or ``"gap_m"`` (m).
        values: the parameter's values (> 0).
        ratio, gap_m: the other parameter's fixed value (default: the scenario's).
        phase_deg: forcing phase of the section in degrees.
        transient_s: discarded time in s (default: the part before the RMS window).

    Returns:
        (points, impacts): two Tables; points has ``param``, ``t_s`` (s), ``u_m`` (m),
        ``du_m_s`` (m/s); impacts has ``param``, ``t_s`` (s), ``wall`` (±1), ``dw_m_s`` (m/s).
    """
    sc = _scenario(scenario, overrides)
    if not isinstance(param, str):
        raise TypeError(f"param must be a str, got {type(param).__name__}")
    cb, close = _progress(progress, "bifurcation")
    try:
        pts, imp = _vibrobar.bifurcation_diagram(
            sc,
            param,
            _array("values", values),
            _number("ratio", ratio),
            _number("gap_m", gap_m),
            _number("phase_deg", phase_deg, False),
            _number("transient_s", transient_s),
            cb,
        )
    finally:
        close()
    return Table(pts), Table(imp)


def orbit(
    scenario: Optional[Scenario] = None,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    *,
    period: int = 1,
    start: str = "auto",
    branch: Optional[int] = None,
    settle_s: Optional[float] = None,
    member: Optional[int] = None,
    **overrides,
) -> dict:
    """A periodic orbit of ``period`` forcing cycles (Newton on the stroboscopic map), like
    ``vibrobar orbit``.

    Args:
        period: forcing cycles per orbit, in [1, 64].
        start: ``"auto"`` (the analytic symmetric orbit when one exists, else a settled run),
            ``"symmetric"`` (orbit number ``branch``) or ``"settled"`` (a run over ``settle_s``).
            On an N-mode bar (``[beam]``, ``[[modes]]``) the start is a settled run (``"auto"``
            or ``"settled"``), the Jacobian the modal variational flow, and the result also has
            ``modes`` and the modal state (``state["q_m"]``, ``state["dq_m_s"]``).

        member: for a scenario with ``[two_plane]``, which member of its ensemble of starts
            settles (default 0; ``gap_m`` is the axial gap). The orbit is then the one that
            member's run settles on over ``settle_s``, where the planes decouple (frictionless
            walls, the bar's principal axes along and across the hole); ``start`` must be
            ``"auto"`` or ``"settled"``.

    Returns:
        dict: ``rms_m``, ``impacts_per_period``, ``period``, ``multipliers`` (list of
        ``(re, im)``, largest first), ``max_abs_multiplier``, ``stable``, ``event_sequence``,
        ``state`` (at the section), ``confined``, ``max_penetration_m``, ``residual``.

        For a scenario with ``[two_plane]`` (``vibrobar orbit`` on it): ``stable``,
        ``multipliers`` and ``max_abs_multiplier`` of both planes (the spin's neutral
        ``spin_multiplier`` 1 apart), ``impacts_per_period``, ``impacts_per_wall``,
        ``rms_along_force_m``, ``rms_radial_m``, ``rms_tangential_m``, ``rms_total_m`` over the
        orbit, ``solid_rms_m``, ``reduction_pct``, ``flight_fraction``, ``return_gap`` (how
        closely a two-plane run repeats the orbit), ``state`` and ``planes`` (each plane's
        orbit, ``"along_hole"`` and ``"across_hole"``, with the keys above).
    """
    sc = _scenario(scenario, overrides)
    if isinstance(period, bool) or not isinstance(period, (int, _np.integer)):
        raise TypeError(f"period must be an int, got {period!r}")
    if not 1 <= int(period) <= 64:
        raise ValueError(f"period = {period} is outside the allowed range [1, 64] forcing cycles")
    if sc.is_two_plane:
        _two_plane_start(start, branch)
        return _vibrobar.two_plane_orbit(
            sc,
            _number("ratio", ratio),
            _number("gap_m", gap_m),
            _member(0 if member is None else member),
            int(period),
            _number("settle_s", settle_s),
        )
    _two_plane_refuse_one("orbit", {"member": member}, "a member of a two-plane ensemble")
    return _vibrobar.orbit(
        sc,
        _number("ratio", ratio),
        _number("gap_m", gap_m),
        int(period),
        start,
        branch,
        _number("settle_s", settle_s),
    )


def continuation(
    scenario: Optional[Scenario] = None,
    param: str = "gap_m",
    from_: float = 0.06e-3,
    to: float = 0.12e-3,
    *,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    period: int = 1,
    start: str = "auto",
    max_points: int = 2000,
    switch_branches: bool = True,
    member: Optional[int] = None,
    settle_s: Optional[float] = None,
    **overrides,
) -> Table:
    """Pseudo-arclength continuation of a periodic orbit in ``param`` (``"ratio"``,
    ``"gap_m"``, ``"friction_force_n"``, ``"restitution"``, and ``"cavity_position_m"`` on a
    ``[beam]``; SI values) from ``from_`` to ``to``, like ``vibrobar continue``; with
    ``switch_branches`` (lumped and N-mode bars) the period-2k branch from each period
    doubling follows the main branch (its rows have ``period`` 2k).

    Returns:
        Table: ``param``, ``rms_m``, ``max_abs_multiplier``, ``stable``,
        ``impacts_per_period``, ``period``, ``event`` (the CSV's columns; ``to_csv()`` its text
        with ``param`` in SI units).

        For a scenario with ``[two_plane]``, where the planes decouple (``vibrobar continue`` on
        it): each plane's orbit, from the one member ``member`` (default 0) settles on over
        ``settle_s``, followed in ``"ratio"`` or ``"restitution"`` (both planes) or ``"gap_m"``
        (the axial gap: the plane along the hole); the same columns after a ``plane`` column
        (``"along_hole"``, ``"across_hole"``). The two-plane orbit at a value is the pair of
        the planes' orbits there, stable where both are.
    """
    sc = _scenario(scenario, overrides)
    if isinstance(period, bool) or not isinstance(period, (int, _np.integer)):
        raise TypeError(f"period must be an int, got {period!r}")
    if not 1 <= int(period) <= 64:
        raise ValueError(f"period = {period} is outside the allowed range [1, 64] forcing cycles")
    if sc.is_two_plane:
        _two_plane_start(start, None)
        cols, csv = _vibrobar.two_plane_continuation(
            sc,
            param,
            _number("from_", from_, False),
            _number("to", to, False),
            _number("ratio", ratio),
            _number("gap_m", gap_m),
            _member(0 if member is None else member),
            int(period),
            _number("settle_s", settle_s),
            int(max_points),
            bool(switch_branches),
        )
        return Table(cols, csv)
    _two_plane_refuse_one("continuation", {"member": member, "settle_s": settle_s},
                          "an argument of a scenario with [two_plane]")
    cols, csv = _vibrobar.continuation(
        sc,
        param,
        _number("from_", from_, False),
        _number("to", to, False),
        _number("ratio", ratio),
        _number("gap_m", gap_m),
        int(period),
        start,
        int(max_points),
        bool(switch_branches),
    )
    return Table(cols, csv)


def continuation2(
    scenario: Optional[Scenario] = None,
    kind: str = "torus",
    ratio: float = 1.0,
    gap_m: float = 0.09489e-3,
    *,
    ratios: tuple[float, float] = (0.95, 1.05),
    gaps_m: tuple[float, float] = (5e-6, 1e-3),
    period: int = 1,
    max_points: int = 400,
    **overrides,
) -> Table:
    """Two-parameter continuation in (ratio, gap) of a ``kind`` point (``"fold"``,
    ``"period-doubling"``, ``"torus"``, ``"branch-point"``, ``"grazing"``) of a periodic orbit,
    from the point (``ratio``, ``gap_m``) (e.g. one :func:`continuation` located), within
    ``ratios`` × ``gaps_m``, like ``vibrobar continue2``.

    Returns:
        Table: ``ratio``, ``gap_mm``, ``kind``, ``rms_m``, ``max_abs_multiplier``,
        ``on_boundary``, ``test_function``, ``residual``, ``impacts_per_period``, ``event`` (the
        CSV's columns; ``to_csv()`` its text).
    """
    sc = _scenario(scenario, overrides)
    if isinstance(period, bool) or not isinstance(period, (int, _np.integer)):
        raise TypeError(f"period must be an int, got {period!r}")
    if not 1 <= int(period) <= 64:
        raise ValueError(f"period = {period} is outside the allowed range [1, 64] forcing cycles")
    cols, csv = _vibrobar.continuation2(
        sc,
        kind,
        _number("ratio", ratio, False),
        _number("gap_m", gap_m, False),
        (_number("ratios", ratios[0], False), _number("ratios", ratios[1], False)),
        (_number("gaps_m", gaps_m[0], False), _number("gaps_m", gaps_m[1], False)),
        int(period),
        int(max_points),
    )
    return Table(cols, csv)


def lyapunov(
    scenario: Optional[Scenario] = None,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    *,
    transient_s: Optional[float] = None,
    periods: float = 5.0,
    d0: float = 1e-9,
    member: Optional[int] = None,
    **overrides,
) -> dict:
    """The largest Lyapunov exponent at one point (two trajectories, renormalised).

    Args:
        transient_s: discarded time in s (default: the part before the RMS window).
        periods: forcing periods per renormalisation interval (> 0).
        d0: initial separation in the energy-scaled state space (> 0).
        member: for a scenario with ``[two_plane]``, which member of its ensemble of starts runs
            (default 0); ``gap_m`` is the axial gap.

    Returns:
        dict: ``exponent_per_s`` (1/s), ``std_error_per_s`` (1/s), ``intervals``,
        ``interval_s`` (s), ``blocks``, ``clamped``, ``d0``; for a scenario with
        ``[two_plane]`` also ``member`` and ``solver`` (``clamped`` then counts projections of
        the perturbed ball back into the hole).
    """
    sc = _scenario(scenario, overrides)
    if sc.is_two_plane:
        return _vibrobar.two_plane_lyapunov(
            sc,
            _number("ratio", ratio),
            _number("gap_m", gap_m),
            _member(0 if member is None else member),
            _number("transient_s", transient_s),
            _number("periods", periods, False),
            _number("d0", d0, False),
        )
    _two_plane_refuse_one("lyapunov", {"member": member}, "a member of a two-plane ensemble")
    return _vibrobar.lyapunov(
        sc,
        _number("ratio", ratio),
        _number("gap_m", gap_m),
        _number("transient_s", transient_s),
        _number("periods", periods, False),
        _number("d0", d0, False),
    )


def lyapunov_spectrum(
    scenario: Optional[Scenario] = None,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    *,
    transient_s: Optional[float] = None,
    blocks: int = 10,
    member: Optional[int] = None,
    **overrides,
) -> dict:
    """Every Lyapunov exponent at one point, by QR of the variational flow with saltation
    matrices at the events (lumped or N-mode bar, ``solver="exact"``, restitution law).

    Args:
        transient_s: discarded time in s (default: the part before the RMS window); the
            exponents are averaged over the rest of the run.
        blocks: blocks of the window for the standard errors (≥ 2).

    Returns:
        dict: ``exponents_per_s`` (four, or 2N + 2 on an N-mode bar, 1/s; ``None`` is −∞: a
        direction removed by stick or wall contact), ``std_error_per_s``, ``collapsed``,
        ``sum_per_s``, ``impacts_per_s``, ``duration_s``, ``blocks``, ``chatter_limits``,
        ``grazing``, ``compliant_contacts`` and ``approach_memory_per_s`` (the ``hertz`` law's
        contacts, and the part of the sum that is the law's memory of the approach speed; 0 under
        the restitution law), ``volume_identity_per_s`` (without friction: −C/M, or −Σcₙ/mₙ on an
        N-mode bar, + 2 ln(e) × ``impacts_per_s``; ``None`` with friction). With nothing
        collapsed, ``sum_per_s`` equals it (under ``hertz``: the trace average plus
        ``approach_memory_per_s``; the restitution identity in the stiff limit).

        For a scenario with ``[two_plane]`` (``member`` picks the start, default 0), where the
        planes decouple: ``along_hole`` and ``across_hole``, each plane's ``exponents_per_s``,
        ``std_error_per_s``, ``collapsed``, ``sum_per_s``, ``impacts_per_s``, ``duration_s``,
        and ``spin_exponent_per_s`` (0: nothing acts on the spin on frictionless walls).
    """
    sc = _scenario(scenario, overrides)
    if isinstance(blocks, bool) or not isinstance(blocks, int) or blocks < 2:
        raise ValueError(f"blocks = {blocks!r} is outside the allowed range [2, 1000000] (an integer)")
    if sc.is_two_plane:
        return _vibrobar.two_plane_lyapunov_spectrum(
            sc,
            _number("ratio", ratio),
            _number("gap_m", gap_m),
            _member(0 if member is None else member),
            _number("transient_s", transient_s),
            blocks,
        )
    _two_plane_refuse_one("lyapunov_spectrum", {"member": member},
                          "a member of a two-plane ensemble")
    return _vibrobar.lyapunov_spectrum(
        sc,
        _number("ratio", ratio),
        _number("gap_m", gap_m),
        _number("transient_s", transient_s),
        blocks,
    )


def lobes(
    scenario: Optional[Scenario] = None,
    rpm_start: float = None,
    rpm_stop: float = None,
    rpm_step: float = None,
    *,
    measured_frf: Any = None,
    **overrides,
) -> Table:
    """Exact linear stability lobes of regenerative chatter (``vibrobar lobes``).

    The scenario needs a ``[cutting]`` section (its coefficient and direction factors set the
    boundary); its bar is the lumped ``[bar]``, a ``[beam]`` or ``[[modes]]``. The speeds are
    ``rpm_start:rpm_stop:rpm_step`` (stop included), as ``--rpm`` expands them, each in
    [1, 200000] rpm.

    Returns:
        Table: the rows of the command's CSV: ``spindle_rpm``, ``b_lim_m`` and
        ``chatter_frequency_hz`` (ball free), ``b_lim_ball_stuck_m``,
        ``chatter_frequency_ball_stuck_hz``, ``b_lim_solid_m``, ``chatter_frequency_solid_hz``,
        ``lobe``, ``lobe_ball_stuck``, ``lobe_solid``; :meth:`Table.to_csv` is the CLI's file.

    With ``measured_frf`` (``vibrobar lobes --frf``): the lobes straight from a measured FRF at
    the tool tip instead of the scenario's structure, with no modal fit: the receptance is
    interpolated between the measured lines by a natural cubic spline. Only the scenario's
    ``[cutting]`` is used, and the FRF must be measured in the direction its direction factors
    assume. ``measured_frf`` is a file path (read as :func:`read_frf` reads it) or the dict
    :func:`read_frf` returns (``freqs_hz``, complex ``values``, ``kind``). The rows are then
    ``spindle_rpm``, ``b_lim_m``, ``chatter_frequency_hz``, ``lobe``, as in the command's CSV.
    """
    sc = _scenario(scenario, overrides)
    if measured_frf is not None:
        if isinstance(measured_frf, (str, _os.PathLike)):
            measured_frf = read_frf(measured_frf)
        if not isinstance(measured_frf, dict):
            raise TypeError(
                "measured_frf must be a file path or the dict read_frf returns, got "
                f"{type(measured_frf).__name__}"
            )
        missing = [k for k in ("freqs_hz", "values", "kind") if k not in measured_frf]
        if missing:
            raise ValueError(f"measured_frf lacks {', '.join(missing)} (the keys read_frf returns)")
        if not measured_frf.get("driving_point", True):
            raise ValueError(
                "measured_frf is a cross FRF (response and reference at different points); "
                "lobes need the driving-point FRF at the tool tip"
            )
        f = _array("measured_frf['freqs_hz']", measured_frf["freqs_hz"])
        h = _np.asarray(measured_frf["values"], dtype=_np.complex128)
        cols, csv = _vibrobar.lobes_frf(
            sc,
            f,
            _np.ascontiguousarray(h.real),
            _np.ascontiguousarray(h.imag),
            str(measured_frf["kind"]),
            _number("rpm_start", rpm_start, False),
            _number("rpm_stop", rpm_stop, False),
            _number("rpm_step", rpm_step, False),
        )
        return Table(cols, csv)
    cols, csv = _vibrobar.lobes(
        sc,
        _number("rpm_start", rpm_start, False),
        _number("rpm_stop", rpm_stop, False),
        _number("rpm_step", rpm_step, False),
    )
    return Table(cols, csv)

class ModalFit:
    """Modes fitted to a measured FRF (:func:`fit_modes`).

    Attributes:
        modes: a :class:`Table` with one row per mode: ``frequency_hz`` (undamped, Hz),
            ``damping_ratio``, ``modal_mass_kg`` (shape 1 at the tip), ``modal_stiffness_n_per_m``,
            ``shape_cavity`` (from the cross FRF; NaN without one), ``pole_re``, ``pole_im``
            (rad/s), ``residue_re``, ``residue_im`` (receptance form, m/(N·s)),
            ``residue_phase_deg`` (−90° for a lightly damped receptance mode), ``frac``, ``mpc``
            and ``order`` (the model order the pole was taken at).
        chart: a :class:`Table` of the stabilisation chart: ``order``, ``frequency_hz``,
            ``damping_ratio``, ``pole_re``, ``pole_im``, ``stable``.
        upper_residual_m_per_n: the upper residual (modes above the band), m/N.
        lower_residual_per_kg: the lower residual ``L`` of ``−L/ω²`` (modes below the band), 1/kg.
        fit_error: relative error of the fitted driving-point FRF over the band.
        fit_error_cross: the same for the cross FRF (None without one).
        refine_iterations: Levenberg–Marquardt iterations of the refinement.
    """

    def __init__(self, d: dict):
        chart = d.pop("chart")
        keys = ("upper_residual_m_per_n", "lower_residual_per_kg", "fit_error", "fit_error_cross",
                "refine_iterations")
        scalars = {k: d.pop(k) for k in keys}
        self.modes = Table(d)
        self.chart = Table(chart)
        self.upper_residual_m_per_n: float = scalars["upper_residual_m_per_n"]
        self.lower_residual_per_kg: float = scalars["lower_residual_per_kg"]
        self.fit_error: float = scalars["fit_error"]
        self.fit_error_cross: Optional[float] = scalars["fit_error_cross"]
        self.refine_iterations: int = scalars["refine_iterations"]

    def __repr__(self) -> str:
        f = ", ".join(f"{x:.6g}" for x in self.modes["frequency_hz"])
        return f"ModalFit(frequency_hz=[{f}], fit_error={self.fit_error:.3e})"


def fit_modes(
    freqs_hz: ArrayLike,
    frf: ArrayLike,
    *,
    form: str = "receptance",
    cross: Optional[ArrayLike] = None,
    weights: Optional[ArrayLike] = None,
    band_hz: Optional[Sequence[float]] = None,
    max_order: int = 40,
    min_stable_orders: int = 4,
    poles_hz: Optional[ArrayLike] = None,
    upper_residual: bool = True,
    lower_residual: bool = False,
    refine: bool = True,
) -> ModalFit:
    """Modes of a bar from its measured driving-point FRF at the tool tip (``vibrobar fit-modes``).

    Poles by least-squares complex frequency (LSCF) over model orders 2, 4, …, ``max_order``
    with a stabilisation chart (stable: frequency within 1 % and damping within 5 % of the
    lower order's pole, damping positive), residues by LSFD, then poles and residues refined
    together by nonlinear least squares. The FRF is fitted in its own form.

    The modes describe the bar **without the ball**: tap it with the ball removed, or locked
    with its mass subtracted.

    Args:
        freqs_hz: the lines, Hz, strictly increasing and positive.
        frf: complex values at those lines, SI units of ``form``.
        form: ``"receptance"`` (m/N), ``"mobility"`` ((m/s)/N) or ``"accelerance"`` ((m/s²)/N).
        cross: the cross FRF between the cavity and the tip (same lines and form); gives
            ``shape_cavity``.
        weights: per-line weights in [0, 1] (e.g. the coherence); 0 drops a line.
        band_hz: ``(low, high)`` band within the lines; default: the whole record.
        max_order: highest LSCF model order (even).
        min_stable_orders: orders at which a pole must be stable to count as a mode.
        poles_hz: take the stable poles nearest these frequencies (within 5 %) instead.
        upper_residual, lower_residual: fit the residual terms of the modes above / below the
            band.
        refine: refine poles and residues by nonlinear least squares.
    """
    f = _array("freqs_hz", freqs_hz)
    h = _np.asarray(frf, dtype=_np.complex128)
    if h.ndim != 1:
        raise ValueError(f"frf must be 1-d, got an array of shape {h.shape}")
    c = None
    if cross is not None:
        c = _np.asarray(cross, dtype=_np.complex128)
        if c.ndim != 1:
            raise ValueError(f"cross must be 1-d, got an array of shape {c.shape}")
    if not isinstance(form, str):
        raise TypeError(f"form must be a str, got {type(form).__name__}")
    if band_hz is not None:
        if len(band_hz) != 2:
            raise ValueError(f"band_hz must be (low, high) in Hz, got {band_hz!r}")
        band_hz = (float(band_hz[0]), float(band_hz[1]))
    for name, v in (("max_order", max_order), ("min_stable_orders", min_stable_orders)):
        if isinstance(v, bool) or not isinstance(v, (int, _np.integer)):
            raise TypeError(f"{name} must be an int, got {type(v).__name__}")
        if v < 1:
            raise ValueError(f"{name} = {v} is outside the allowed range [1, ∞)")
    p = None if poles_hz is None else [float(x) for x in _array("poles_hz", poles_hz)]
    d = _vibrobar.fit_modes(
        f,
        _np.ascontiguousarray(h.real),
        _np.ascontiguousarray(h.imag),
        form,
        None if c is None else _np.ascontiguousarray(c.real),
        None if c is None else _np.ascontiguousarray(c.imag),
        _array("weights", weights, False),
        band_hz,
        int(max_order),
        int(min_stable_orders),
        p,
        bool(upper_residual),
        bool(lower_residual),
        bool(refine),
    )
    return ModalFit(d)



def frf(
    scenario: Optional[Scenario] = None,
    band_hz: Optional[Sequence[float]] = None,
    *,
    frequencies_hz: Optional[ArrayLike] = None,
    curves: Sequence[str] = ("solid", "ball_free", "ball_stuck"),
    from_point: str = "force",
    to_point: str = "response",
    force_n: Optional[float] = None,
    settle_s: Optional[float] = None,
    measure_periods: int = 50,
    tap_force_n: float = 100.0,
    tap_duration_s: float = 1e-4,
    taps: int = 5,
    sample_rate_hz: Optional[float] = None,
    record_s: Optional[float] = None,
    progress: Progress = None,
    **overrides,
) -> Table:
    """Frequency response functions of the scenario's bar (``vibrobar frf``), over absolute
    frequencies in Hz.

    Curves (``curves``, any of):

    * ``solid``: the solid reference bar's receptance (linear);
    * ``ball_free``: the damped bar with the ball never touching a wall (the bar alone);
    * ``ball_stuck``: the damped bar with the ball stuck at the cavity, its mass added there;
    * ``stepped_sine``: the nonlinear damped bar forced at ``force_n`` (default: the scenario's
      forcing amplitude), run ``settle_s`` (default: until the slowest mode's free decay has
      fallen by 1e12), then the first harmonic of the response over ``measure_periods`` forcing
      periods, with its RMS and impacts per cycle;
    * ``tap``: a simulated tap test, ``taps`` half-sine hammer pulses of peak ``tap_force_n`` and
      duration ``tap_duration_s`` at the force point, the free decay recorded at
      ``sample_rate_hz`` over ``record_s``; H1 = S_fx/S_ff and the coherence. Each tap starts
      with the ball at rest at its own place in the gap. With a ball that impacts, H1 depends on
      the tap force: it describes the bar at that force only.

    The linear curves take any ``from_point``/``to_point`` (``"force"``, ``"cavity"``,
    ``"response"``); the stepped sine and the tap test force the force point and read the
    response point or the cavity. A ``[cutting]`` section is not applied.

    Args:
        scenario: the scenario (default: the paper's).
        band_hz: ``(start, stop, step)`` in Hz, stop included, as ``--band-hz``; or give
            ``frequencies_hz`` (each in (0, 1e7] Hz, at most 100000 lines).
        progress: ``progress(done, total)`` callable over the simulated runs, or True for a bar.
        **overrides: scenario keyword overrides (``gap_m=1e-4``, ``friction="coulomb"``, ...).

    Returns:
        Table: ``frequency_hz``, then per curve ``{curve}_re_m_per_n``, ``{curve}_im_m_per_n``,
        ``{curve}_mag_m_per_n``, ``{curve}_phase_deg`` and ``stepped_sine_rms_m``,
        ``stepped_sine_impacts_per_cycle``, ``tap_coherence``; :meth:`Table.to_csv` is the
        CLI's file.
    """
    sc = _scenario(scenario, overrides)
    if isinstance(curves, str):
        curves = [curves]
    band = None
    if band_hz is not None:
        band = tuple(band_hz)
        if len(band) != 3:
            raise ValueError(f"band_hz must be (start, stop, step) in Hz, got {band_hz!r}")
        band = tuple(_number("band_hz", x, False) for x in band)
    for name, x in [("measure_periods", measure_periods), ("taps", taps)]:
        if isinstance(x, bool) or not isinstance(x, (int, _np.integer)):
            raise TypeError(f"{name} must be an int, got {type(x).__name__}")
    if measure_periods < 1:
        raise ValueError(f"measure periods (measure_periods) = {measure_periods} is outside the allowed range [1, 100000]")
    if taps < 1:
        raise ValueError(f"taps = {taps} is outside the allowed range [1, 1000]")
    cb, close = _progress(progress, "frf")
    try:
        cols, csv = _vibrobar.frf(
            sc,
            band,
            _array("frequencies_hz", frequencies_hz, False),
            [str(c) for c in curves],
            str(from_point),
            str(to_point),
            _number("force_n", force_n),
            _number("settle_s", settle_s),
            int(min(measure_periods, 2**32 - 1)),
            _number("tap_force_n", tap_force_n, False),
            _number("tap_duration_s", tap_duration_s, False),
            int(taps),
            _number("sample_rate_hz", sample_rate_hz),
            _number("record_s", record_s),
            cb,
        )
    finally:
        close()
    return Table(cols, csv)


def ensemble(
    scenario: Optional[Scenario] = None,
    ratios: ArrayLike = None,
    gaps_m: ArrayLike = None,
    *,
    members: Optional[int] = None,
    seed: Optional[int] = None,
    u_m: Optional[float] = None,
    du_m_s: Optional[float] = None,
    dw_m_s: Optional[float] = None,
    progress: Progress = None,
    threads: Optional[int] = None,
    client: Any = None,
    shards: Optional[int] = None,
    **overrides,
) -> MapResult:
    """Ensembles of random initial states at each (ratio, gap): RMS statistics and regimes
    (``vibrobar ensemble``).

    Args:
        ratios: Ω/ω₁ values; gaps_m: clearances in m.
        members: initial states per point (≥ 1; default 16, or the ``[two_plane]`` section's);
            seed: random seed (default 1, or the section's).
        u_m, du_m_s, dw_m_s: half-ranges of the uniform initial u (m), u̇ and ẇ (m/s); the ball
            starts anywhere in the cavity (defaults 5e-5 m, 0.2 m/s, 0.2 m/s; one-plane model
            only).
        threads: worker threads of a scenario with ``[two_plane]`` (default: all cores).
        client, shards: run on a Dask cluster, as for :func:`map` (same result, bit for bit).

    Returns:
        Table: ``ratio``, ``gap_mm`` (mm), ``members``, ``mean_rms_m``, ``std_rms_m``,
        ``min_rms_m``, ``max_rms_m`` (m), ``regimes`` (counts per regime).

        For a scenario with ``[two_plane]``: a TwoPlaneTable with one row per member (gap-major,
        then ratio, then member), the columns of ``vibrobar ensemble`` on it: the member's start
        along and across the hole, its RMS along the force and reduction beside the one-plane
        model's from the same start and the bar without its ball, the RMS per direction,
        impacts per wall (``impacts_plug_plus``, ``impacts_plug_minus``, ``impacts_wall_plus``,
        ``impacts_wall_minus``) and ``flight_fraction``. Its members start with the bar at rest
        and the ball where the section's ensemble puts it (``start_speed_m_s``), so ``u_m``,
        ``du_m_s`` and ``dw_m_s`` do not apply.
    """
    sc = _scenario(scenario, overrides)
    if sc.is_two_plane:
        _two_plane_refuse("ensemble", {
            "u_m": u_m, "du_m_s": du_m_s, "dw_m_s": dw_m_s, "client": client, "shards": shards,
        }, "the members start where the [two_plane] ensemble puts them; set start_speed_m_s there")
        cb, close = _progress(progress, "ensemble")
        return _two_plane_table("ensemble", sc, _array("ratios", ratios),
                                _array("gaps_m", gaps_m), cb, close, threads,
                                members=members, seed=seed,
                                dims=("axial_gap_m", "ratio", "member"))
    _two_plane_refuse_one("ensemble", {"threads": threads}, "the one-plane ensemble runs on all cores (set RAYON_NUM_THREADS)")
    members = 16 if members is None else members
    seed = 1 if seed is None else seed
    u_m = 5e-5 if u_m is None else u_m
    du_m_s = 0.2 if du_m_s is None else du_m_s
    dw_m_s = 0.2 if dw_m_s is None else dw_m_s
    for name, x in (("members", members), ("seed", seed)):
        if isinstance(x, bool) or not isinstance(x, (int, _np.integer)):
            raise TypeError(f"{name} must be an int, got {type(x).__name__}")
        if x < 0:
            raise ValueError(f"{name} = {x} is outside the allowed range [0, ∞)")
    cb, close = _progress(progress, "ensemble")
    if client is not None:
        try:
            return _on_dask(client, "ensemble", sc, ratios, shards, cb, gaps_m=gaps_m,
                            members=members, seed=seed, u_m=u_m, du_m_s=du_m_s, dw_m_s=dw_m_s)
        finally:
            close()
    try:
        cols, csv = _vibrobar.ensemble(
            sc,
            _array("ratios", ratios),
            _array("gaps_m", gaps_m),
            int(members),
            int(seed),
            _number("u_m", u_m, False),
            _number("du_m_s", du_m_s, False),
            _number("dw_m_s", dw_m_s, False),
            cb,
        )
    finally:
        close()
    t = MapResult(cols, csv)
    return t


def width_diagram(
    scenario: Optional[Scenario] = None,
    spindle_rpm: float = None,
    widths_m: ArrayLike = None,
    *,
    progress: Progress = None,
    **overrides,
) -> Table:
    """Width–amplitude diagram of a ``[cutting]`` scenario at one spindle speed
    (``vibrobar width-diagram``): for each width, from the small and the large disturbance of
    ``[time_domain]``, for the solid and the damped bar, the settled vibration.

    Returns:
        Table: ``width_m``, ``disturbance`` (small/large), ``bar`` (solid/damped),
        ``peak_to_peak_m``, ``out_of_cut_fraction``, ``impacts_per_rev``, ``regime``,
        ``static_deflection_m``, ``growth_per_rev``, ``acceptable``, ``spindle_rpm``.
    """
    sc = _scenario(scenario, overrides)
    cb, close = _progress(progress, "width-diagram")
    try:
        cols, csv = _vibrobar.width_diagram(
            sc, _number("spindle_rpm", spindle_rpm, False), _array("widths_m", widths_m), cb
        )
    finally:
        close()
    return Table(cols, csv)


def time_domain_lobes(
    scenario: Optional[Scenario] = None,
    spindle_rpm: ArrayLike = None,
    *,
    progress: Progress = None,
    **overrides,
) -> Table:
    """Time-domain lobes of a ``[cutting]`` scenario (``vibrobar lobes
    --time-domain``): per spindle speed the largest acceptable width of the solid and the damped
    bar from the small and the large disturbance.

    Returns:
        Table: ``spindle_rpm``, ``b_lim_m``, ``b_lim_solid_m``, ``b_solid_small_m``,
        ``b_solid_large_m``, ``b_damped_small_m``, ``b_damped_large_m`` (m),
        ``event_limit_runs``, ``non_monotonic``, ``capped``, ``runs``.
    """
    sc = _scenario(scenario, overrides)
    cb, close = _progress(progress, "time-domain lobes")
    try:
        cols, csv = _vibrobar.time_domain_lobes(sc, _array("spindle_rpm", spindle_rpm), cb)
    finally:
        close()
    return Table(cols, csv)


def lobe_design(
    scenario: Optional[Scenario] = None,
    spindle_rpm: ArrayLike = None,
    gaps_m: ArrayLike = None,
    *,
    ball_masses_kg: ArrayLike = None,
    positions_m: ArrayLike = None,
    progress: Progress = None,
    **overrides,
) -> Table:
    """Design by time-domain lobes of a ``[cutting]`` scenario (``vibrobar
    lobe-design``): each gap × ball mass (``ball_masses_kg``, lumped bar) or gap × cavity
    position from the clamp (``positions_m``, a ``[beam]``) scored by its worst-case acceptable
    width over the spindle speeds from the large disturbance, beside the solid bar's. Give
    exactly one of ``ball_masses_kg`` and ``positions_m``.

    Returns:
        Table: one row per design (gap outer): ``gap_m``, ``ball_mass_kg`` or ``position_m``,
        ``worst_width_m``, ``worst_rpm``, ``mean_width_m``, ``solid_worst_width_m``,
        ``solid_worst_rpm``, ``solid_mean_width_m``, ``worst_gain``, ``mean_gain``,
        ``event_limit_runs``, ``non_monotonic``, ``capped``, ``runs``, ``worst_regime`` (the
        damped run's at the worst case) and, where it is ``chaotic``, ``spread_min_width_m``,
        ``spread_mean_width_m``, ``spread_max_width_m`` (the worst speed's width over seeded
        perturbations of the disturbance; empty otherwise). The optimum is the row with the
        largest ``worst_width_m`` (ties: larger mean, then earlier row).
    """
    sc = _scenario(scenario, overrides)
    cb, close = _progress(progress, "lobe-design")
    masses = None if ball_masses_kg is None else _array("ball_masses_kg", ball_masses_kg)
    positions = None if positions_m is None else _array("positions_m", positions_m)
    try:
        cols, csv = _vibrobar.lobe_design(
            sc,
            _array("spindle_rpm", spindle_rpm),
            _array("gaps_m", gaps_m),
            masses,
            positions,
            cb,
        )
    finally:
        close()
    return Table(cols, csv)


def two_plane(
    *,
    bar_mass_kg: float = 0.644,
    bar_stiffness_n_per_m: Any = 9.22e6,
    bar_damping_ratio: Any = 0.01,
    bar_principal_axis_deg: float = 0.0,
    ball_mass_kg: float = 0.026,
    ball_radius_m: float = 0.0075,
    ball_restitution: float = 0.5,
    ball_friction_static: float = 0.0,
    ball_friction_kinetic: float = 0.0,
    ball_rolling_friction_m: float = 0.0,
    hole_angle_deg: float = 0.0,
    hole_axial_gap_m: float = 1e-3,
    hole_diameter_m: float = 0.0151,
    forcing_amplitude_n: float = 15.0,
    forcing_frequency_ratio: float = 1.0,
    forcing_angle_deg: float = 63.4,
    gravity_m_s2: float = 9.80665,
    gravity_angle_deg: float = 90.0,
    members: int = 8,
    seed: int = 1,
    start_speed_m_s: float = 0.01,
    duration_s: float = 2.0,
    dt_s: float = 1e-6,
    rms_fraction: float = 0.8,
    solver: str = "auto",
    threads: Optional[int] = None,
    progress: Progress = None,
) -> Table:
    """The bar that bends in two planes, with the ball in a hole across it, at one design point
    (``vibrobar two-plane`` runs grids of these).

    Angles are in the bar's cross-section plane, in degrees from the radial direction towards
    the tangential one. A force with tangential/radial ratio ``F_t/F_r`` points at
    ``atan(F_t/F_r)`` (63.4° for 2). Gravity defaults to 90°, along the tangential force.

    Args:
        bar_mass_kg: the lumped bar's mass, the same in both planes.
        bar_stiffness_n_per_m, bar_damping_ratio: a number (a round bar) or a pair, one per
            principal axis; bar_principal_axis_deg: the first principal axis' angle. A frequency
            ratio refers to the lower principal frequency.
        ball_mass_kg, ball_radius_m, ball_restitution: the ball (restitution on every wall).
        ball_friction_static, ball_friction_kinetic: friction on the hole's walls, 0 ≤ μ_k ≤ μ_s < 1;
            ball_rolling_friction_m: rolling resistance η (a length).
        hole_angle_deg: the hole's direction; hole_axial_gap_m: total clearance along it (the
            ball moves ±gap/2); hole_diameter_m: across it the ball moves ±(d_hole − 2r)/2.
        forcing_amplitude_n, forcing_frequency_ratio, forcing_angle_deg: the harmonic force.
        gravity_m_s2, gravity_angle_deg: gravity on the ball (0 allowed).
        members, seed, start_speed_m_s: the ensemble of starts: member 0 rests on the wall gravity
            presses it onto, centred along the hole; the others at seeded places along the hole
            with speeds up to ``start_speed_m_s`` along it and across it (away from the wall it
            rests on).
        duration_s, dt_s, rms_fraction: each run (the reference solver's RK4 step; RMS over
            the last fraction).
        solver: ``"exact"`` (the event-driven solver; it needs frictionless walls and the bar's
            principal axes along and across the hole, where the planes decouple),
            ``"reference"`` (RK4 at ``dt_s`` with every event located inside its step; any
            walls), or ``"auto"``: exact where it applies, the reference elsewhere.

    Returns:
        Table, one row per member: ``w_along_start_m``, ``dw_along_start_m_s``,
        ``dw_across_start_m_s`` (the start),
        ``rms_along_force_m``, ``rms_radial_m``, ``rms_tangential_m``, ``rms_total_m`` (m),
        ``impacts_axial_plus``, ``impacts_axial_minus``, ``impacts_across_plus``,
        ``impacts_across_minus``, ``flight_fraction``, ``one_plane_rms_m`` (the one-plane model
        from the same start: the slot along the hole, the whole force along it, Coulomb friction
        when the walls have friction), ``solid_rms_m`` (the bar without its ball) and
        ``solver`` (which solver ran).
    """
    if solver not in ("auto", "exact", "reference"):
        raise ValueError(
            f"solver = {solver!r} is not one of the allowed values: 'auto', 'exact', 'reference'"
        )
    def pair(name, x):
        if isinstance(x, (int, float, _np.integer, _np.floating)) and not isinstance(x, bool):
            return (float(x), float(x))
        try:
            a, b = x
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be a number or a pair of numbers, got {x!r}") from None
        return (_number(name, a, False), _number(name, b, False))

    for name, x in (("members", members), ("seed", seed)):
        if isinstance(x, bool) or not isinstance(x, (int, _np.integer)):
            raise TypeError(f"{name} must be an int, got {type(x).__name__}")
        if x < 0:
            raise ValueError(f"{name} = {x} is outside the allowed range [0, ∞)")
    numbers = {
        k: _number(k, v, False)
        for k, v in (
            ("bar_mass_kg", bar_mass_kg),
            ("bar_principal_axis_deg", bar_principal_axis_deg),
            ("ball_mass_kg", ball_mass_kg),
            ("ball_radius_m", ball_radius_m),
            ("ball_restitution", ball_restitution),
            ("ball_friction_static", ball_friction_static),
            ("ball_friction_kinetic", ball_friction_kinetic),
            ("ball_rolling_friction_m", ball_rolling_friction_m),
            ("hole_angle_deg", hole_angle_deg),
            ("hole_axial_gap_m", hole_axial_gap_m),
            ("hole_diameter_m", hole_diameter_m),
            ("forcing_amplitude_n", forcing_amplitude_n),
            ("forcing_frequency_ratio", forcing_frequency_ratio),
            ("forcing_angle_deg", forcing_angle_deg),
            ("gravity_m_s2", gravity_m_s2),
            ("gravity_angle_deg", gravity_angle_deg),
            ("start_speed_m_s", start_speed_m_s),
            ("duration_s", duration_s),
            ("dt_s", dt_s),
            ("rms_fraction", rms_fraction),
        )
    }
    cb, close = _progress(progress, "two_plane")
    try:
        cols = _vibrobar.two_plane(
            numbers["bar_mass_kg"],
            pair("bar_stiffness_n_per_m", bar_stiffness_n_per_m),
            pair("bar_damping_ratio", bar_damping_ratio),
            numbers["bar_principal_axis_deg"],
            numbers["ball_mass_kg"],
            numbers["ball_radius_m"],
            numbers["ball_restitution"],
            numbers["ball_friction_static"],
            numbers["ball_friction_kinetic"],
            numbers["ball_rolling_friction_m"],
            numbers["hole_angle_deg"],
            numbers["hole_axial_gap_m"],
            numbers["hole_diameter_m"],
            numbers["forcing_amplitude_n"],
            numbers["forcing_frequency_ratio"],
            numbers["forcing_angle_deg"],
            numbers["gravity_m_s2"],
            numbers["gravity_angle_deg"],
            int(members),
            int(seed),
            numbers["start_speed_m_s"],
            numbers["duration_s"],
            numbers["dt_s"],
            numbers["rms_fraction"],
            solver,
            _threads(threads),
            cb,
        )
    finally:
        close()
    return Table(cols)


def _one_frequency_axis(ratios, freqs_hz, required: bool) -> None:
    """``ratios`` or ``freqs_hz``, not both (and, when ``required``, one of them)."""
    if ratios is not None and freqs_hz is not None:
        raise ValueError(
            "ratios and freqs_hz given together (allowed: one of them: ratios Ω/ω₁ > 0, "
            "or freqs_hz in (0, 1e7] Hz)"
        )
    if required and ratios is None and freqs_hz is None:
        raise TypeError(
            "ratios is required, or freqs_hz instead (allowed: one of them: ratios Ω/ω₁ > 0, "
            "or freqs_hz in (0, 1e7] Hz)"
        )


def _on_dask(client, fn, sc, ratios, shards, cb, **kwargs):
    from . import _dask

    if kwargs.get("freqs_hz") is None:
        kwargs.pop("freqs_hz", None)
        _array("ratios", ratios)
    else:
        _array("freqs_hz", kwargs["freqs_hz"])
    return _dask.run(client, fn, sc, ratios, shards, cb, **kwargs)


def submit(client, fn: str, scenario: Optional[Scenario] = None, ratios: ArrayLike = None, *,
           shards: Optional[int] = None, **kwargs):
    """Submit ``vibrobar.<fn>`` (``"map"`` or ``"ensemble"``) to a Dask cluster as shard tasks
    and a merge task, and return the merge's ``distributed.Future`` at once: its ``result()`` is
    what ``vibrobar.<fn>(scenario, ratios, **kwargs)`` returns, bit for bit; ``cancel()`` stops
    the shards not yet started. ``kwargs`` are the function's own (``gaps_m=…``, ``members=…``,
    scenario overrides go into ``scenario``)."""
    from . import _dask

    if fn not in ("map", "ensemble"):
        raise ValueError(f"fn = {fn!r}: only 'map' and 'ensemble' run on Dask")
    if fn == "map":
        _one_frequency_axis(ratios, kwargs.get("freqs_hz"), required=True)
    if kwargs.get("freqs_hz") is None:
        kwargs.pop("freqs_hz", None)
        _array("ratios", ratios)
    else:
        _array("freqs_hz", kwargs["freqs_hz"])
    return _dask.submit(client, fn, scenario, ratios, shards, **kwargs)


def read_frf(
    path: Any,
    *,
    units: Optional[str] = None,
    frf_type: Optional[str] = None,
    columns: Optional[str] = None,
    record: Optional[int] = None,
    conjugate: bool = False,
    negate: bool = False,
    accelerometer_mass_kg: Optional[float] = None,
    cross: bool = False,
) -> dict:
    """Read a measured FRF, as ``vibrobar lobes --frf`` does.

    ``path`` is a universal file (dataset 58 ASCII or 58b binary, with dataset 164 units) or
    plain columns (CSV or blank separated: frequency in Hz, then re/im or magnitude/phase,
    optionally a coherence). ``units`` gives the units of plain columns (m/N, mm/N, µm/N,
    in/lbf, (m/s)/N, (m/s²)/N, g/N); ``frf_type`` the kind where the file does not say
    (receptance, mobility, accelerance); ``columns`` the layout of plain columns without a
    header (re-im, mag-deg, mag-rad); ``record`` the FRF record of a universal file with several
    response/reference pairs (1-based). ``conjugate``/``negate`` fix an FRF under the
    e^{−iωt} convention or with a reversed hammer; ``accelerometer_mass_kg`` cancels the
    sensor's mass; ``cross`` marks plain columns as a cross FRF (no passivity check).

    Returns a dict: ``freqs_hz`` (Hz), ``values`` (complex, SI units of ``kind``), ``kind``,
    ``coherence`` (or None), ``driving_point``, ``units_note`` (where the units came from),
    ``notes`` and ``format`` (uff58, uff58b or columns). Bad files raise ``ValueError`` naming
    the file, the dataset, the record and the line.
    """
    return _vibrobar.read_frf(
        str(path),
        units,
        frf_type,
        columns,
        record,
        conjugate,
        negate,
        accelerometer_mass_kg,
        cross,
    )


def write_uff58(
    path: Any,
    freqs_hz: ArrayLike,
    values: Any,
    *,
    kind: str = "receptance",
    coherence: Optional[ArrayLike] = None,
    binary: bool = True,
    driving_point: bool = True,
    description: str = "vibrobar FRF",
) -> None:
    """Write an FRF as a universal file: dataset 164 (SI), the FRF as dataset 58b
    (``binary=True``: little-endian doubles, read back bit for bit) or ASCII 58 (values to 12
    significant digits), and its coherence if given.

    ``freqs_hz`` must increase; ``values`` are complex, in SI units of ``kind`` (m/N for a
    receptance, (m/s)/N mobility, (m/s²)/N accelerance). Evenly spaced lines whose start and
    step have at most 6 significant digits are stored as start and step; others line by line
    (in ASCII with 6 significant digits).
    """
    f = _np.ascontiguousarray(freqs_hz, dtype=_np.float64)
    v = _np.ascontiguousarray(values, dtype=_np.complex128)
    c = None if coherence is None else _np.ascontiguousarray(coherence, dtype=_np.float64)
    _vibrobar.write_uff58(str(path), f, v, kind, c, binary, driving_point, description)

"""Type stubs of the ``vibrobar`` package (units are SI; names carry them)."""

from typing import Any, Callable, Dict, Mapping, Optional, Sequence, Tuple, Union
import numpy as np
import numpy.typing as npt

from ._vibrobar import DEFAULT_SOLVER as DEFAULT_SOLVER
from ._vibrobar import Scenario as Scenario
from ._vibrobar import __version__ as __version__
from ._vibrobar import solver_names as solver_names

ArrayLike = Union[Sequence[float], npt.NDArray[np.float64], float]
Progress = Union[None, bool, Callable[[int, int], Any]]
UNITS: dict[str, str]

class Table(dict[str, np.ndarray]):
    """Column name → 1-d NumPy array; the CLI's CSV column names."""
    def __init__(self, columns: Mapping[str, Any], csv: Optional[str] = None) -> None: ...
    @property
    def rows(self) -> int: ...
    def to_csv(self) -> str: ...
    def to_pandas(self) -> Any: ...
    def to_xarray(self) -> Any: ...

class SweepResult(Table): ...
class MapResult(Table): ...

class TwoPlaneRun:
    history: Table
    rms_along_force_m: float
    rms_radial_m: float
    rms_tangential_m: float
    rms_total_m: float
    solid_rms_m: float
    reduction_pct: float
    walls: Dict[str, Dict[str, float]]
    flight_fraction: float
    events: int
    max_penetration_m: float
    energy: Dict[str, float]
    solver: str
    member: int
    def __init__(self, d: dict) -> None: ...

def two_plane_run(
    scenario: Scenario, *, member: int = 0, sample_every: int = 10, **overrides: Any
) -> TwoPlaneRun: ...

class RunResult:
    history: Table
    impact_table: Table
    impact_table_truncated: bool
    rms_m: float
    impacts: int
    impacts_in_window: int
    impacts_per_cycle: float
    max_penetration_m: float
    energy: dict[str, float]
    solver: str
    t_s: npt.NDArray[np.float64]
    u_m: npt.NDArray[np.float64]
    du_m_s: npt.NDArray[np.float64]
    v_m: npt.NDArray[np.float64]
    dv_m_s: npt.NDArray[np.float64]
    w_m: npt.NDArray[np.float64]
    dw_m_s: npt.NDArray[np.float64]

def run(scenario: Optional[Scenario] = None, *, sample_every: int = 10, **overrides: Any) -> RunResult: ...
def sweep(
    scenario: Optional[Scenario] = None,
    ratios: Optional[ArrayLike] = None,
    gaps_m: Optional[ArrayLike] = None,
    *,
    freqs_hz: Optional[ArrayLike] = None,
    progress: Progress = None,
    threads: Optional[int] = None,
    **overrides: Any,
) -> SweepResult: ...
def map(
    scenario: Optional[Scenario] = None,
    ratios: Optional[ArrayLike] = None,
    gaps_m: ArrayLike = ...,
    *,
    freqs_hz: Optional[ArrayLike] = None,
    friction_forces_n: Optional[ArrayLike] = None,
    restitutions: Optional[ArrayLike] = None,
    mass_ratios: Optional[ArrayLike] = None,
    progress: Progress = None,
    threads: Optional[int] = None,
    client: Any = None,
    shards: Optional[int] = None,
    **overrides: Any,
) -> MapResult: ...
design_map = map
def regime(
    scenario: Optional[Scenario] = None,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    **overrides: Any,
) -> dict[str, Any]: ...
def poincare(
    scenario: Optional[Scenario] = None,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    *,
    phase_deg: float = 0.0,
    transient_s: Optional[float] = None,
    **overrides: Any,
) -> Table: ...
def bifurcation(
    scenario: Optional[Scenario] = None,
    param: str = "ratio",
    values: ArrayLike = ...,
    *,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    phase_deg: float = 0.0,
    transient_s: Optional[float] = None,
    progress: Progress = None,
    **overrides: Any,
) -> tuple[Table, Table]: ...
def orbit(
    scenario: Optional[Scenario] = None,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    *,
    period: int = 1,
    start: str = "auto",
    branch: Optional[int] = None,
    settle_s: Optional[float] = None,
    **overrides: Any,
) -> dict[str, Any]: ...
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
    **overrides: Any,
) -> Table: ...
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
    **overrides: Any,
) -> Table: ...
def lyapunov(
    scenario: Optional[Scenario] = None,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    *,
    transient_s: Optional[float] = None,
    periods: float = 5.0,
    d0: float = 1e-9,
    **overrides: Any,
) -> dict[str, Any]: ...
class ModalFit:
    modes: Table
    chart: Table
    upper_residual_m_per_n: float
    lower_residual_per_kg: float
    fit_error: float
    fit_error_cross: Optional[float]
    refine_iterations: int
    def __init__(self, d: dict[str, Any]) -> None: ...

def fit_modes(
    freqs_hz: ArrayLike,
    frf: ArrayLike,
    *,
    form: str = ...,
    cross: Optional[ArrayLike] = ...,
    weights: Optional[ArrayLike] = ...,
    band_hz: Optional[Sequence[float]] = ...,
    max_order: int = ...,
    min_stable_orders: int = ...,
    poles_hz: Optional[ArrayLike] = ...,
    upper_residual: bool = ...,
    lower_residual: bool = ...,
    refine: bool = ...,
) -> ModalFit: ...
def lobes(
    scenario: Optional[Scenario] = None,
    rpm_start: float = ...,
    rpm_stop: float = ...,
    rpm_step: float = ...,
    *,
    measured_frf: Any = None,
    **overrides: Any,
) -> Table: ...
def frf(
    scenario: Optional[Scenario] = None,
    band_hz: Optional[Sequence[float]] = None,
    *,
    frequencies_hz: Optional[ArrayLike] = None,
    curves: Sequence[str] = ...,
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
    **overrides: Any,
) -> Table: ...
def ensemble(
    scenario: Optional[Scenario] = None,
    ratios: ArrayLike = ...,
    gaps_m: ArrayLike = ...,
    *,
    members: int = 16,
    seed: int = 1,
    u_m: float = 5e-5,
    du_m_s: float = 0.2,
    dw_m_s: float = 0.2,
    progress: Progress = None,
    client: Any = None,
    shards: Optional[int] = None,
    **overrides: Any,
) -> MapResult: ...
def submit(
    client: Any,
    fn: str,
    scenario: Optional[Scenario] = None,
    ratios: ArrayLike = ...,
    *,
    shards: Optional[int] = None,
    **kwargs: Any,
) -> Any: ...
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
) -> dict[str, Any]: ...
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
) -> None: ...

def two_plane(
    *,
    bar_mass_kg: float = 0.644,
    bar_stiffness_n_per_m: Union[float, Tuple[float, float]] = 9.22e6,
    bar_damping_ratio: Union[float, Tuple[float, float]] = 0.01,
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
) -> Table: ...

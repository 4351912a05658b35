"""Type stubs of the native module (crates/vibrobar-py). Use the package ``vibrobar``."""

from typing import Any, Callable, Dict, Optional, Tuple, Union
import os
import numpy as np
import numpy.typing as npt

__version__: str
DEFAULT_SOLVER: str

_Override = Union[float, int, str, bool, list, dict, None]
_Progress = Optional[Callable[[int, int], Any]]

class Scenario:
    """A simulation scenario in SI units (the TOML scenario file's sections): immutable."""

    @staticmethod
    def paper(**overrides: _Override) -> "Scenario":
        """The paper's lumped bar, with keyword overrides (``gap_m=1e-4``, ``friction="coulomb"``)."""
    @staticmethod
    def paper_beam(**overrides: _Override) -> "Scenario":
        """The paper's bar as an Euler–Bernoulli beam (``[beam]``), with overrides (``modes=3``)."""
    @staticmethod
    def from_toml(path: Union[str, os.PathLike[str]], **overrides: _Override) -> "Scenario":
        """Read a scenario file (TOML, SI units), with keyword overrides."""
    @staticmethod
    def from_toml_str(text: str, **overrides: _Override) -> "Scenario":
        """Parse scenario TOML text, with keyword overrides."""
    def replace(self, **overrides: _Override) -> "Scenario":
        """A copy with keyword overrides."""
    def to_toml(self) -> str:
        """The scenario as TOML text (reads back as the same scenario)."""
    def to_dict(self) -> dict[str, Any]:
        """Section → field → value."""
    @property
    def solver(self) -> str:
        """Solver name (``[run] solver``)."""
    @property
    def gap_m(self) -> float:
        """Total clearance of the ball, m."""
    @property
    def frequency_ratio(self) -> float:
        """Ω/ω₁ of the bar with the cavity."""
    @property
    def is_beam(self) -> bool:
        """True for a ``[beam]`` scenario."""
    def __eq__(self, other: object) -> bool: ...

def solver_names() -> list[str]:
    """Names of the solvers."""

def run(scenario: Scenario, sample_every: int = 10) -> dict[str, Any]: ...
def sweep(
    scenario: Scenario,
    ratios: Optional[npt.NDArray[np.float64]] = None,
    gaps_m: Optional[npt.NDArray[np.float64]] = None,
    progress: _Progress = None,
    threads: Optional[int] = None,
    freqs_hz: Optional[npt.NDArray[np.float64]] = None,
) -> tuple[dict[str, Any], str]: ...
def design_map(
    scenario: Scenario,
    ratios: Optional[npt.NDArray[np.float64]],
    gaps_m: npt.NDArray[np.float64],
    friction_forces_n: Optional[npt.NDArray[np.float64]] = None,
    restitutions: Optional[npt.NDArray[np.float64]] = None,
    mass_ratios: Optional[npt.NDArray[np.float64]] = None,
    progress: _Progress = None,
    threads: Optional[int] = None,
    freqs_hz: Optional[npt.NDArray[np.float64]] = None,
) -> tuple[dict[str, Any], str]: ...
def regime(scenario: Scenario, ratio: Optional[float] = None, gap_m: Optional[float] = None) -> dict[str, Any]: ...
def poincare(
    scenario: Scenario,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    phase_deg: float = 0.0,
    transient_s: Optional[float] = None,
) -> dict[str, Any]: ...
def orbit(
    scenario: Scenario,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    period: int = 1,
    start: str = "auto",
    branch: Optional[int] = None,
    settle_s: Optional[float] = None,
) -> dict[str, Any]: ...
def continuation(
    scenario: Scenario,
    param: str,
    from_: float,
    to: float,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    period: int = 1,
    start: str = "auto",
    max_points: int = 2000,
    switch_branches: bool = True,
) -> tuple[dict[str, Any], str]: ...
def continuation2(
    scenario: Scenario,
    kind: str,
    ratio: float,
    gap_m: float,
    ratios: tuple[float, float] = (0.95, 1.05),
    gaps_m: tuple[float, float] = (5e-6, 1e-3),
    period: int = 1,
    max_points: int = 400,
) -> tuple[dict[str, Any], str]: ...
def lyapunov(
    scenario: Scenario,
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    transient_s: Optional[float] = None,
    periods: float = 5.0,
    d0: float = 1e-9,
) -> dict[str, Any]: ...
def bifurcation_diagram(
    scenario: Scenario,
    param: str,
    values_: npt.NDArray[np.float64],
    ratio: Optional[float] = None,
    gap_m: Optional[float] = None,
    phase_deg: float = 0.0,
    transient_s: Optional[float] = None,
    progress: _Progress = None,
) -> tuple[dict[str, Any], dict[str, Any]]: ...
def lobes(
    scenario: Scenario, rpm_start: float, rpm_stop: float, rpm_step: float
) -> tuple[dict[str, Any], str]: ...
def lobes_frf(
    scenario: Scenario,
    freqs_hz: npt.NDArray[np.float64],
    frf_re: npt.NDArray[np.float64],
    frf_im: npt.NDArray[np.float64],
    kind: str,
    rpm_start: float,
    rpm_stop: float,
    rpm_step: float,
) -> tuple[dict[str, Any], str]: ...
def fit_modes(
    freqs_hz: npt.NDArray[np.float64],
    frf_re: npt.NDArray[np.float64],
    frf_im: npt.NDArray[np.float64],
    form: str,
    cross_re: Optional[npt.NDArray[np.float64]] = None,
    cross_im: Optional[npt.NDArray[np.float64]] = None,
    weights: Optional[npt.NDArray[np.float64]] = None,
    band_hz: Optional[tuple[float, float]] = None,
    max_order: int = 40,
    min_stable_orders: int = 4,
    poles_hz: Optional[list[float]] = None,
    upper_residual: bool = True,
    lower_residual: bool = False,
    refine: bool = True,
) -> dict[str, Any]: ...
def frf(
    scenario: Scenario,
    band_hz: Optional[tuple[float, float, float]] = None,
    frequencies_hz: Optional[npt.NDArray[np.float64]] = None,
    curves: Optional[list[str]] = None,
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
    progress: _Progress = None,
) -> tuple[dict[str, Any], str]: ...
def ensemble(
    scenario: Scenario,
    ratios: npt.NDArray[np.float64],
    gaps_m: npt.NDArray[np.float64],
    members: int = 16,
    seed: int = 1,
    u_m: float = 5e-5,
    du_m_s: float = 0.2,
    dw_m_s: float = 0.2,
    progress: _Progress = None,
) -> tuple[dict[str, Any], str]: ...
def lobe_design(
    scenario: Scenario,
    spindle_rpm: npt.NDArray[np.float64],
    gaps_m: npt.NDArray[np.float64],
    ball_masses_kg: Optional[npt.NDArray[np.float64]] = None,
    positions_m: Optional[npt.NDArray[np.float64]] = None,
    progress: _Progress = None,
) -> tuple[dict[str, Any], str]: ...
def _busy(seconds: float, panic: bool = False) -> float: ...
def read_frf(
    path: str,
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
    path: str,
    freqs_hz: npt.NDArray[np.float64],
    values: npt.NDArray[np.complex128],
    kind: str = "receptance",
    coherence: Optional[npt.NDArray[np.float64]] = None,
    binary: bool = True,
    driving_point: bool = True,
    description: str = "vibrobar FRF",
) -> None: ...

def two_plane(
    bar_mass_kg: float,
    bar_stiffness_n_per_m: Tuple[float, float],
    bar_damping_ratio: Tuple[float, float],
    bar_principal_axis_deg: float,
    ball_mass_kg: float,
    ball_radius_m: float,
    ball_restitution: float,
    ball_friction_static: float,
    ball_friction_kinetic: float,
    ball_rolling_friction_m: float,
    hole_angle_deg: float,
    hole_axial_gap_m: float,
    hole_diameter_m: float,
    forcing_amplitude_n: float,
    forcing_frequency_ratio: float,
    forcing_angle_deg: float,
    gravity_m_s2: float,
    gravity_angle_deg: float,
    members: int,
    seed: int,
    start_speed_m_s: float,
    duration_s: float,
    dt_s: float,
    rms_fraction: float,
    solver: str,
    threads: Optional[int],
    progress: Optional[Callable[[int, int], None]],
) -> Dict[str, npt.NDArray[Any]]: ...

def two_plane_run(scenario: Scenario, member: int = 0, sample_every: int = 10) -> Dict[str, Any]: ...

"""Type stubs of the compiled module visguide._visguide (re-exported by visguide.mser,
visguide.lwpr, visguide.fd and visguide.tracking)."""

import os
from typing import Any, Iterable, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, "os.PathLike[str]"]
_Floats = npt.ArrayLike
_Estimate = Tuple[float, float, Optional[float]]

# --- visguide.mser ---------------------------------------------------------------------------

class Region:
    """One maximally stable extremal region (coordinates: pixel centres, x right, y down)."""

    @property
    def polarity(self) -> str: ...  # "dark" or "bright"
    @property
    def level(self) -> int: ...
    @property
    def seed(self) -> Tuple[int, int]: ...
    @property
    def area(self) -> int: ...
    @property
    def variation(self) -> float: ...
    @property
    def bbox(self) -> Tuple[int, int, int, int]: ...
    @property
    def centroid(self) -> Tuple[float, float]: ...
    @property
    def moments(self) -> Tuple[int, int, int, int, int, int]: ...
    @property
    def ellipse(self) -> Tuple[float, float, float, float, float]: ...
    @property
    def pixels(self) -> Optional[npt.NDArray[np.int32]]: ...
    @property
    def contour(self) -> Optional[npt.NDArray[np.int32]]: ...
    def ellipse_scaled(self, k: float) -> Tuple[float, float, float, float, float]: ...

def detect(
    image: npt.NDArray[np.uint8],
    *,
    preset: str = "opencv",
    pixels: bool = False,
    contours: bool = False,
    opencv_compatible: bool = False,
    delta: int = ...,
    min_area: int = ...,
    max_area: Optional[int] = ...,
    max_variation: float = ...,
    min_diversity: float = ...,
    polarities: str = ...,
    variation: str = ...,
) -> list[Region]: ...
def preset(name: str) -> dict[str, Any]: ...

# --- visguide.lwpr ---------------------------------------------------------------------------

class LWPR:
    """Locally Weighted Projection Regression with the reference Python module's vocabulary."""

    def __init__(self, n_in: Union[int, _Path], n_out: Optional[int] = None) -> None: ...
    def update(self, x: _Floats, y: _Floats) -> npt.NDArray[np.float64]: ...
    def update_batch(self, x: _Floats, y: _Floats) -> npt.NDArray[np.float64]: ...
    def predict(self, x: _Floats, cutoff: float = 0.0) -> npt.NDArray[np.float64]: ...
    def predict_batch(self, x: _Floats, cutoff: float = 0.0) -> npt.NDArray[np.float64]: ...
    def predict_conf(
        self, x: _Floats, cutoff: float = 0.0
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def predict_J(
        self, x: _Floats, cutoff: float = 0.0
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def rf_center(self, dim: int, n: int) -> npt.NDArray[np.float64]: ...
    def rf_D(self, dim: int, n: int) -> npt.NDArray[np.float64]: ...
    def save(self, path: _Path) -> None: ...
    @classmethod
    def load(cls, path: _Path) -> "LWPR": ...
    def write_XML(self, filename: _Path) -> None: ...
    @classmethod
    def read_XML(cls, filename: _Path) -> "LWPR": ...
    def to_xml(self) -> str: ...
    @classmethod
    def from_xml(cls, text: str) -> "LWPR": ...
    def to_bytes(self) -> bytes: ...
    @classmethod
    def from_bytes(cls, data: bytes) -> "LWPR": ...
    def __eq__(self, other: object) -> bool: ...
    @property
    def nIn(self) -> int: ...
    @property
    def nOut(self) -> int: ...
    @property
    def n_data(self) -> int: ...
    @property
    def num_rfs(self) -> list[int]: ...
    @property
    def n_pruned(self) -> list[int]: ...
    @property
    def mean_x(self) -> npt.NDArray[np.float64]: ...
    @property
    def var_x(self) -> npt.NDArray[np.float64]: ...
    @property
    def init_M(self) -> npt.NDArray[np.float64]: ...
    init_D: Any  # (n_in, n_in) array; set with any array-like
    init_alpha: Any
    norm_in: Any
    norm_out: Any
    kernel: str  # "Gaussian" | "BiSquare"
    prune_rule: str  # "published" | "reference_c"
    arithmetic: str  # "fast" | "reference"
    w_gen: float
    w_prune: float
    init_lambda: float
    final_lambda: float
    tau_lambda: float
    init_S2: float
    add_threshold: float
    penalty: float
    meta_rate: float
    diag_only: bool
    update_D: bool
    meta: bool

# --- visguide.fd -----------------------------------------------------------------------------

class Descriptors:
    def __len__(self) -> int: ...
    @property
    def sources(self) -> npt.NDArray[np.uintp]: ...
    @property
    def sampling(self) -> str: ...
    @property
    def rejected(self) -> list[Tuple[int, str]]: ...
    @property
    def fd(self) -> npt.NDArray[np.complex128]: ...
    @property
    def magnitudes(self) -> npt.NDArray[np.float64]: ...
    @property
    def afd0(self) -> npt.NDArray[np.float64]: ...
    @property
    def afd1(self) -> npt.NDArray[np.complex128]: ...
    def select(self, indices: Sequence[int]) -> "Descriptors": ...
    def min_errors(self, method: str = "fd_corr") -> npt.NDArray[np.float64]: ...

def describe(
    contours: Sequence[_Floats],
    *,
    sampling: str = "affine",
    samples: int = 256,
    coefficients: int = 51,
    smoothing: float = 1.0,
    dense_samples: int = 2048,
) -> Descriptors: ...
def match(
    a: Descriptors, b: Descriptors, *, method: str = "fd_corr", ratio: Optional[float] = 0.5
) -> dict[str, npt.NDArray[Any]]: ...
def match_images(
    image1: Union[npt.NDArray[np.uint8], _Path],
    image2: Union[npt.NDArray[np.uint8], _Path],
    *,
    preset: str = "larsson2009",
    sampling: str = "affine",
    method: str = "fd_corr",
    ratio: float = 0.5,
    preselection: Optional[float] = None,
    homography: bool = True,
    ransac_threshold: float = 3.0,
    ransac_iterations: int = 5000,
    ransac_confidence: float = 0.999,
    ransac_seed: int = 0,
    **params: Any,
) -> dict[str, Any]: ...

# --- visguide.tracking -----------------------------------------------------------------------

class _Tracker:
    def reset(self, start: Tuple[float, float]) -> None: ...
    def step(self, detections: _Floats) -> _Estimate: ...
    def step_on_grid(self, detections: _Floats) -> Tuple[float, float, Optional[float], int]: ...
    def run(self, start: Tuple[float, float], frames: Iterable[_Floats]) -> npt.NDArray[np.float64]: ...
    def estimate(self) -> _Estimate: ...
    def to_json(self) -> str: ...
    def save(self, path: _Path) -> None: ...
    def __eq__(self, other: object) -> bool: ...

class CBT(_Tracker):
    @staticmethod
    def learn(
        sequences: Iterable[Iterable[Tuple[_Floats, _Floats]]],
        width: float,
        height: float,
        spacing: float = 10.0,
        *,
        self_learning: bool = False,
        # The fields of cbt_tracker::CbtConfig (test_tracking.py checks these against
        # CBT.default_config(), which the crate's defaults fill):
        order: str = "second",  # "first" | "second"
        layout: str = "separable",  # "separable" | "sparse_joint" | "stationary"
        clutter: str = "model",  # "model" | "subtract" | "uniform"
        observation_fallback: str = "identity",  # "identity" | "uniform"
        system_fallback: str = "first_order",  # "first_order" | "constant_velocity"
        prior_weight: float = 1.0,
        fallback_sigma: float = 1.0,
        observation_floor: float = 1e-3,
        mixing: float = 1e-3,
        prune: float = 0.01,
        online_weight: float = 1.0,
        runner_ups: int = 3,
        obs_radius: int = 10,
        support: float = 1e-2,
        decode_radius: int = 4,
        smoothing: str = "fixed",  # "fixed" | "held_out"
        start: str = "marginal",  # "marginal" | "learned" | "pooled"
        # "channels" | "interpolated" | "aligned" | "selected" | "fitted"
        displacements: str = "channels",
        observation_smoothing: str = "counted",  # "counted" | "held_out"
        velocity: str = "factored",  # "factored" | "per_position"
    ) -> "CBT": ...
    @staticmethod
    def default_config() -> dict[str, Any]: ...
    @staticmethod
    def stationary_config() -> dict[str, Any]: ...
    @property
    def config(self) -> dict[str, Any]: ...
    def learn_online(self, truths: _Floats, detections: _Floats) -> None: ...
    @classmethod
    def from_json(cls, text: str) -> "CBT": ...
    @classmethod
    def load(cls, path: _Path) -> "CBT": ...
    @property
    def posterior(self) -> npt.NDArray[np.float64]: ...

class Kalman(_Tracker):
    def __init__(
        self, accel_sigma: float, meas_sigma: float, init_vel_sigma: float, gate: float = 9.21
    ) -> None: ...
    @classmethod
    def from_json(cls, text: str) -> "Kalman": ...
    @classmethod
    def load(cls, path: _Path) -> "Kalman": ...
    @property
    def x(self) -> list[float]: ...
    @property
    def P(self) -> npt.NDArray[np.float64]: ...

class ParticleFilter(_Tracker):
    def __init__(
        self,
        accel_sigma: float,
        meas_sigma: float,
        p_detect: float,
        clutter_density: float,
        init_vel_sigma: float,
        n: int = 1000,
        seed: int = 0,
    ) -> None: ...
    @classmethod
    def from_json(cls, text: str) -> "ParticleFilter": ...
    @classmethod
    def load(cls, path: _Path) -> "ParticleFilter": ...
    def __len__(self) -> int: ...

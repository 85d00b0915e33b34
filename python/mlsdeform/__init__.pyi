from typing import Literal, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Array = npt.ArrayLike
_Transform = Literal["rigid", "similarity", "affine"]
_Method = Literal["axis_angle", "horn_quaternion", "horn_matrix", "kanatani", "svd"]

class _Targets(TypedDict):
    points: np.ndarray
    segments: Tuple[np.ndarray, np.ndarray]

class Deformer:
    def __init__(
        self,
        vertices: _Array,
        *,
        points: Optional[_Array] = ...,
        segments: Optional[Tuple[_Array, _Array]] = ...,
        transform: _Transform = ...,
        exponent: float = ...,
        method: _Method = ...,
        segment_weight: Literal["paper_constant", "exact_integral"] = ...,
        threads: int = ...,
        weight_storage: Literal["automatic", "precomputed", "on_the_fly", "precomputed_weights"] = ...,
        backend: Literal["simd", "scalar"] = ...,
        precompute_budget_bytes: int = ...,
        dtype: Optional[npt.DTypeLike] = ...,
        faces: Optional[_Array] = ...,
        arap_iterations: int = ...,
        centroids: Literal["mls", "rbf"] = ...,
        region: Optional[_Array] = ...,
        arap_acceleration: Literal["none", "anderson"] = ...,
        arap_warm_start: bool = ...,
        affine_frames: bool = ...,
    ) -> None: ...
    def deform(
        self,
        *,
        points: Optional[_Array] = ...,
        segments: Optional[Tuple[_Array, _Array]] = ...,
        out: Optional[np.ndarray] = ...,
        quaternions: Optional[np.ndarray] = ...,
        rotations: Optional[np.ndarray] = ...,
        scales: Optional[np.ndarray] = ...,
        linear: Optional[np.ndarray] = ...,
    ) -> np.ndarray: ...
    def set_point_target(self, i: int, target: _Array) -> None: ...
    def set_segment_target(self, i: int, a: _Array, b: _Array) -> None: ...
    def transform_handles(
        self,
        *,
        points: Optional[_Array] = ...,
        segments: Optional[_Array] = ...,
        rotation: Optional[_Array] = ...,
        translation: Optional[_Array] = ...,
        pivot: Optional[_Array] = ...,
    ) -> None: ...
    @property
    def targets(self) -> _Targets: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def point_count(self) -> int: ...
    @property
    def segment_count(self) -> int: ...
    @property
    def dtype(self) -> np.dtype: ...
    @property
    def memory_bytes(self) -> int: ...
    @property
    def uses_precomputed_weights(self) -> bool: ...

def fit_rotations(
    H: _Array, *, method: _Method = ..., threads: int = ..., out: Optional[np.ndarray] = ...
) -> np.ndarray: ...
def fit_rotation(H: _Array, *, method: _Method = ...) -> np.ndarray: ...
def fit_points(
    P: _Array,
    Q: _Array,
    w: Optional[_Array] = ...,
    *,
    transform: Literal["rigid", "similarity"] = ...,
    method: _Method = ...,
) -> Union[Tuple[np.ndarray, np.ndarray], Tuple[np.ndarray, np.ndarray, float]]: ...
def rotate_splats(
    quaternions: _Array,
    scales: Optional[_Array] = ...,
    *,
    rotations: Optional[np.ndarray] = ...,
    log_scales: Optional[np.ndarray] = ...,
    sh_rest: Optional[np.ndarray] = ...,
    threads: int = ...,
) -> None: ...
def transform_splats_affine(
    linear: _Array,
    *,
    rotations: Optional[np.ndarray] = ...,
    log_scales: Optional[np.ndarray] = ...,
    sh_rest: Optional[np.ndarray] = ...,
    threads: int = ...,
) -> None: ...
def active_isa() -> str: ...
def supported_isas() -> Sequence[str]: ...
def set_isa(isa: Literal["scalar", "sse4_2", "avx2", "avx512", "neon"]) -> None: ...
def transform_normals(linear: _Array, normals: _Array, *, out: Optional[np.ndarray] = ...) -> np.ndarray: ...
def transform_tangents(linear: _Array, tangents: _Array, *, out: Optional[np.ndarray] = ...) -> np.ndarray: ...

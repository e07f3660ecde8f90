# Hand-kept stub of the compiled module native/python/module.cpp.
from typing import Literal, Required, TypedDict, overload

import numpy as np
import numpy.typing as npt

__version__: str

class MotionKitError(ValueError): ...

def build_info() -> dict[str, str]: ...
def data_address(array: npt.NDArray[np.float64]) -> int: ...
def keyframe_co(
    frames: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    co: npt.NDArray[np.float32],
) -> None: ...

# Rotation interpolation (native/python/bind_rotation_interpolation.cpp).
@overload
def interpolate_rotations(
    times: npt.NDArray[np.float64],
    quats: npt.NDArray[np.float64],
    eval_times: npt.NDArray[np.float64],
    kind: str = "squad",
    *,
    tension: npt.ArrayLike | None = None,
    continuity: npt.ArrayLike | None = None,
    bias: npt.ArrayLike | None = None,
    euler_order: str = "XYZ",
    angular_velocity: Literal[False] = False,
) -> npt.NDArray[np.float64]: ...
@overload
def interpolate_rotations(
    times: npt.NDArray[np.float64],
    quats: npt.NDArray[np.float64],
    eval_times: npt.NDArray[np.float64],
    kind: str = "squad",
    *,
    tension: npt.ArrayLike | None = None,
    continuity: npt.ArrayLike | None = None,
    bias: npt.ArrayLike | None = None,
    euler_order: str = "XYZ",
    angular_velocity: Literal[True],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
@overload
def slerp(q0: npt.ArrayLike, q1: npt.ArrayLike, u: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
@overload
def slerp(q0: npt.ArrayLike, q1: npt.ArrayLike, u: float) -> npt.NDArray[np.float64]: ...

# Key reduction (native/python/bind_key_reduction.cpp).
def reduce_keys(
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    tolerance: float,
    mode: str = "absolute",
    euler_order: str = "XYZ",
    stride: int = 1,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
# Keyframe interpolation (native/python/bind_interpolation.cpp). kind is one of
# "stepped", "linear", "polynomial", "natural", "clamped", "periodic",
# "not-a-knot", "hermite", "catmull-rom", "centripetal", "chordal",
# "kochanek-bartels", "monotone". times, values and eval_times must be float64
# and C-contiguous (no silent copies); the optional arrays are converted.
def interpolate(
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    eval_times: npt.NDArray[np.float64],
    kind: str = "natural",
    *,
    slopes: npt.ArrayLike | None = None,
    end_slopes: npt.ArrayLike | None = None,
    tension: npt.ArrayLike | None = None,
    continuity: npt.ArrayLike | None = None,
    bias: npt.ArrayLike | None = None,
    derivative: bool = False,
) -> npt.NDArray[np.float64] | tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def hermite_form(
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    kind: str = "natural",
    *,
    slopes: npt.ArrayLike | None = None,
    end_slopes: npt.ArrayLike | None = None,
    tension: npt.ArrayLike | None = None,
    continuity: npt.ArrayLike | None = None,
    bias: npt.ArrayLike | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def interpolate_curves(
    offsets: npt.NDArray[np.integer],
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    eval_times: npt.NDArray[np.float64],
    kind: str = "natural",
    *,
    slopes: npt.ArrayLike | None = None,
    end_slopes: npt.ArrayLike | None = None,
    tension: npt.ArrayLike | None = None,
    continuity: npt.ArrayLike | None = None,
    bias: npt.ArrayLike | None = None,
    derivative: bool = False,
) -> npt.NDArray[np.float64] | tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

class Skeleton:
    """Joints depth-first, end sites included (read_bvh, parse_bvh or Skeleton(...))."""

    def __len__(self) -> int: ...

def forward_kinematics(
    skeleton: Skeleton,
    values: npt.NDArray[np.float64],
    positions: npt.NDArray[np.float64],
    orientations: npt.NDArray[np.float64],
    threads: int = 0,
) -> None:
    """Whole-clip FK in place; threads=0 shares the frames among all cores, 1 stays on this thread."""

# Rigs and retargeting (native/python/bind_retarget.cpp).
class Rig:
    def __init__(
        self,
        names: list[str],
        parents: list[int],
        rest_rotations: npt.NDArray[np.float64],
        rest_heads: npt.NDArray[np.float64],
        lengths: npt.NDArray[np.float64],
    ) -> None: ...
    @property
    def size(self) -> int: ...
    @property
    def names(self) -> list[str]: ...
    def find(self, name: str) -> int: ...

def armature_pose(
    rig: Rig,
    basis_rotations: npt.NDArray[np.float64],
    basis_locations: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def retarget(
    source: Rig,
    target: Rig,
    source_rotations: npt.NDArray[np.float64],
    source_root_heads: npt.NDArray[np.float64],
    bone_map: list[int],
    *,
    source_match: npt.NDArray[np.float64],
    source_match_root: npt.ArrayLike,
    target_match_basis: npt.NDArray[np.float64],
    target_match_location: npt.ArrayLike,
    source_root: int,
    target_root: int,
    space: npt.ArrayLike = ...,
    scale: float = 1.0,
    unit_scale: float = 1.0,
    vertical_offset: float = 0.0,
    root_motion: Literal["scaled", "in_place", "offset", "none"] = "scaled",
    ground_bones: list[int] = ...,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

# Full-body inverse kinematics (native/python/bind_ik.cpp).
class IkEffector(TypedDict, total=False):
    name: str
    bone: Required[int]
    weight: float
    position: bool
    orientation: bool
    pin: bool

class IkResult(TypedDict):
    rotations: npt.NDArray[np.float64]
    root_locations: npt.NDArray[np.float64]
    scales: npt.NDArray[np.float64]
    errors: npt.NDArray[np.float64]
    iterations: npt.NDArray[np.int32]

def ik_solve(
    rig: Rig,
    input_rotations: npt.NDArray[np.float64],
    input_locations: npt.NDArray[np.float64],
    target_positions: npt.NDArray[np.float64],
    target_orientations: npt.NDArray[np.float64],
    effectors: list[IkEffector],
    *,
    limit_min: npt.NDArray[np.float64] | None = None,
    limit_max: npt.NDArray[np.float64] | None = None,
    locked: npt.NDArray[np.bool_] | None = None,
    stiffness: npt.NDArray[np.float64] | None = None,
    excluded: npt.NDArray[np.bool_] | None = None,
    stretch: npt.NDArray[np.float64] | None = None,
    scale_range: npt.NDArray[np.float64] | None = None,
    method: Literal["dls", "pinv", "transpose", "ccd"] = "dls",
    max_iterations: int = 64,
    tolerance: float = 1e-5,
    max_step: float = 0.3,
    damping: float = 0.0,
    regularization: float = 1e-4,
    reference: Literal["previous", "input"] = "previous",
    orientation_scale: float = 0.0,
    root_translation: bool = False,
    root_rotation: bool = False,
    warm_start: bool = True,
    threads: int = 0,
    size: float = 0.0,
) -> IkResult:
    """Whole-clip full-body IK; see native/include/motionkit/ik.hpp. Bones the solver does not move keep their input."""

# Foot contacts (native/python/bind_contacts.cpp).
def foot_targets(
    points: npt.NDArray[np.float64],
    contacts: npt.NDArray[np.bool_],
    blend_frames: int,
    rigid_pairs: list[tuple[int, int]] = [],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

# Hand-kept stub of the compiled module native/python/module.cpp (tests/python/test_native_stub.py checks it).
# Inputs are float64 C-contiguous arrays taken without a copy; every output is an array the function returns.
from typing import Literal, overload

import numpy as np
import numpy.typing as npt

__version__: str

class MotionKitError(ValueError): ...

def build_info() -> dict[str, str]: ...
def keyframe_co(
    frames: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
) -> npt.NDArray[np.float32]: ...

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

# Key reduction (native/python/bind_key_reduction.cpp).
def reduce_keys(
    times: npt.NDArray[np.float64],
    values: npt.NDArray[np.float64],
    tolerance: float,
    mode: str = "absolute",
    euler_order: str = "XYZ",
    stride: int = 1,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def reduce_keys_world(
    rig: Rig,
    times: npt.NDArray[np.float64],
    channels: npt.NDArray[np.float64],
    rotation_modes: npt.NDArray[np.int32],
    group_ranges: npt.NDArray[np.int32],
    distance: float,
    axis_length: float,
    stride: int = 1,
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float64], npt.NDArray[np.float64], float]: ...
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
class Skeleton:
    """Joints depth-first, end sites included (read_bvh, parse_bvh or Skeleton(...))."""

    def __init__(
        self,
        names: list[str],
        parents: list[int],
        offsets: npt.NDArray[np.float64],
        end_sites: list[bool],
        channels: list[list[str]],
    ) -> None: ...
    def __len__(self) -> int: ...
    @property
    def names(self) -> list[str]: ...
    @property
    def parents(self) -> list[int]: ...
    @property
    def offsets(self) -> npt.NDArray[np.float64]: ...
    @property
    def end_sites(self) -> list[bool]: ...
    @property
    def channels(self) -> list[list[str]]: ...
    @property
    def channel_count(self) -> int: ...
    @property
    def first_channels(self) -> list[int]: ...
    def find(self, name: str) -> int: ...

# Rigs (native/python/bind_rig.cpp) and retargeting (native/python/bind_retarget.cpp).
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
    up: npt.ArrayLike = ...,
    source_floor: float = 0.0,
    target_floor: float = 0.0,
    source_aims: npt.NDArray[np.float64] | None = None,
    target_aims: npt.NDArray[np.float64] | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

# Mirroring a clip across a plane (native/python/bind_mirror.cpp).
def mirror(
    source: Rig,
    target: Rig,
    basis_rotations: npt.NDArray[np.float64],
    basis_locations: npt.NDArray[np.float64],
    partners: list[int],
    kept: list[int],
    *,
    normal: npt.ArrayLike = ...,
    point: npt.ArrayLike = ...,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

# Full-body inverse kinematics (native/python/bind_ik.cpp).
class IkEffector:
    """One effector of ik_solve: its bone's tail reaches a target, or with pin holds where the input has it."""

    def __init__(
        self,
        bone: int,
        *,
        name: str = "",
        weight: float = 1.0,
        position: bool = True,
        orientation: bool = False,
        pin: bool = False,
    ) -> None: ...
    bone: int
    name: str
    weight: float
    position: bool
    orientation: bool
    pin: bool

class IkResult:
    """What ik_solve returns (read-only arrays)."""

    @property
    def rotations(self) -> npt.NDArray[np.float64]: ...
    @property
    def root_locations(self) -> npt.NDArray[np.float64]: ...
    @property
    def scales(self) -> npt.NDArray[np.float64]: ...
    @property
    def errors(self) -> npt.NDArray[np.float64]: ...
    @property
    def iterations(self) -> npt.NDArray[np.int32]: ...

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
    soft: npt.NDArray[np.bool_] | None = None,
    stage: npt.NDArray[np.int32] | None = None,
    mass: npt.NDArray[np.float64] | None = None,
    method: Literal["dls", "pinv", "transpose", "ccd"] = "dls",
    max_iterations: int = 64,
    tolerance: float = 0.0,
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
    priorities: bool = True,
    balance: bool = False,
    up: tuple[float, float, float] = (0.0, 0.0, 1.0),
    balance_margin: float = 0.0,
) -> IkResult:
    """Whole-clip full-body IK; see native/include/motionkit/ik.hpp. Bones the solver does not move keep their input."""

# Foot contacts (native/python/bind_contacts.cpp).
def foot_targets(
    points: npt.NDArray[np.float64],
    contacts: npt.NDArray[np.bool_],
    blend_frames: int,
    rigid_pairs: list[tuple[int, int]] = [],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

# BVH (native/python/bind_bvh.cpp); Skeleton above.
class Motion:
    """The channel values of a BVH clip and its frame time."""

    def __init__(self, values: npt.NDArray[np.float64], frame_time: float) -> None: ...
    @property
    def values(self) -> npt.NDArray[np.float64]: ...
    @property
    def frames(self) -> int: ...
    @property
    def frame_time(self) -> float: ...

def read_bvh(path: str) -> tuple[Skeleton, Motion]: ...
def write_bvh(path: str, skeleton: Skeleton, motion: Motion) -> None: ...
def bvh_to_pose(
    skeleton: Skeleton,
    values: npt.NDArray[np.float64],
    bone_rest: npt.NDArray[np.float64],
    conversion: npt.ArrayLike,
    scale: float,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def pose_to_bvh(
    skeleton: Skeleton,
    rotations: npt.NDArray[np.float64],
    locations: npt.NDArray[np.float64],
    bone_rest: npt.NDArray[np.float64],
    conversion: npt.ArrayLike,
    scale: float,
) -> npt.NDArray[np.float64]: ...

# Euler angles (native/python/bind_rotation.cpp).
def euler_to_quaternion(angles: npt.NDArray[np.float64], order: str) -> npt.NDArray[np.float64]: ...
def quaternion_to_euler(
    quaternions: npt.NDArray[np.float64],
    order: str,
    continuous: bool = True,
    previous: npt.NDArray[np.float64] = ...,
    threads: int = 0,
) -> npt.NDArray[np.float64]: ...

# F-curve evaluation (native/python/bind_fcurve.cpp).
def evaluate_fcurves(
    co: npt.NDArray[np.float64],
    handle_left: npt.NDArray[np.float64],
    handle_right: npt.NDArray[np.float64],
    interpolation: npt.NDArray[np.int32],
    key_offsets: npt.NDArray[np.int32],
    linear_extrapolation: npt.NDArray[np.int32],
    times: npt.NDArray[np.float64],
) -> npt.NDArray[np.float64]: ...

# Filters (native/python/bind_filters.cpp). kind is one of "butterworth",
# "gaussian", "median", "one_euro"; each reads only its own keywords.
def filter_channels(
    values: npt.NDArray[np.float64],
    kind: str,
    fps: float,
    *,
    cutoff: float = 7.0,
    order: int = 4,
    sigma: float = 1.0,
    size: int = 5,
    min_cutoff: float = 1.0,
    beta: float = 0.0,
    d_cutoff: float = 1.0,
) -> npt.NDArray[np.float64]: ...
def filter_rotations(
    quaternions: npt.NDArray[np.float64],
    kind: str,
    fps: float,
    *,
    cutoff: float = 7.0,
    order: int = 4,
    sigma: float = 1.0,
    size: int = 5,
    min_cutoff: float = 1.0,
    beta: float = 0.0,
    d_cutoff: float = 1.0,
) -> npt.NDArray[np.float64]: ...

# Functions only the tests use (native/python: the _testing submodule), written as a namespace so that
# this one stub holds the module.
class _testing:
    @staticmethod
    def data_address(array: npt.NDArray[np.float64]) -> int: ...
    @staticmethod
    def parse_bvh(text: str, source: str = "<string>") -> tuple[Skeleton, Motion]: ...
    @staticmethod
    def format_bvh(skeleton: Skeleton, motion: Motion) -> str: ...
    @staticmethod
    def blender_euler_mode(order: str) -> str: ...
    @staticmethod
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
    @overload
    @staticmethod
    def slerp(q0: npt.ArrayLike, q1: npt.ArrayLike, u: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    @overload
    @staticmethod
    def slerp(q0: npt.ArrayLike, q1: npt.ArrayLike, u: float) -> npt.NDArray[np.float64]: ...

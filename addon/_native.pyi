# Hand-kept stub of the compiled module native/python/module.cpp (tests/python/test_native_stub.py checks it).
# Inputs are float64 C-contiguous arrays taken without a copy; every output is an array the function returns.
from typing import Literal, TypedDict, Unpack, overload

import numpy as np
import numpy.typing as npt

# The arrays the module takes (without a copy) and returns, and optional inputs it converts.
F64 = npt.NDArray[np.float64]
I32 = npt.NDArray[np.int32]
Bools = npt.NDArray[np.bool_]
ArrayIn = npt.ArrayLike | None

__version__: str

class MotionKitError(ValueError): ...

def build_info() -> dict[str, str]: ...
def keyframe_co(frames: F64, values: F64) -> npt.NDArray[np.float32]: ...

# Rotation interpolation (native/python/bind_rotation_interpolation.cpp).
@overload
def interpolate_rotations(times: F64, quats: F64, eval_times: F64, kind: str = "squad", *, tension: ArrayIn = None,
    continuity: ArrayIn = None, bias: ArrayIn = None, euler_order: str = "XYZ",
    angular_velocity: Literal[False] = False) -> F64: ...
@overload
def interpolate_rotations(times: F64, quats: F64, eval_times: F64, kind: str = "squad", *, tension: ArrayIn = None,
    continuity: ArrayIn = None, bias: ArrayIn = None, euler_order: str = "XYZ", angular_velocity: Literal[True]
) -> tuple[F64, F64]: ...

# Key reduction (native/python/bind_key_reduction.cpp).
def reduce_keys(times: F64, values: F64, tolerance: float, mode: str = "absolute", euler_order: str = "XYZ",
    stride: int = 1) -> tuple[npt.NDArray[np.int64], F64, F64]: ...
def reduce_keys_world(rig: Rig, times: F64, channels: F64, rotation_modes: I32, group_ranges: I32, distance: float,
    axis_length: float, stride: int = 1) -> tuple[Bools, F64, F64, float]: ...
# Keyframe interpolation (native/python/bind_interpolation.cpp). kind is one of
# "stepped", "linear", "polynomial", "natural", "clamped", "periodic",
# "not-a-knot", "hermite", "catmull-rom", "centripetal", "chordal",
# "kochanek-bartels", "monotone". times, values and eval_times must be float64
# and C-contiguous (no silent copies); the optional arrays are converted.
def interpolate(times: F64, values: F64, eval_times: F64, kind: str = "natural", *, slopes: ArrayIn = None,
    end_slopes: ArrayIn = None, tension: ArrayIn = None, continuity: ArrayIn = None, bias: ArrayIn = None,
    derivative: bool = False) -> F64 | tuple[F64, F64]: ...
def hermite_form(times: F64, values: F64, kind: str = "natural", *, slopes: ArrayIn = None,
    end_slopes: ArrayIn = None, tension: ArrayIn = None, continuity: ArrayIn = None, bias: ArrayIn = None
) -> tuple[F64, F64]: ...
class Skeleton:
    """Joints depth-first, end sites included (read_bvh, parse_bvh or Skeleton(...))."""

    def __init__(self, names: list[str], parents: list[int], offsets: F64, end_sites: list[bool],
        channels: list[list[str]]) -> None: ...
    def __len__(self) -> int: ...
    @property
    def names(self) -> list[str]: ...
    @property
    def parents(self) -> list[int]: ...
    @property
    def offsets(self) -> F64: ...
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
    def __init__(self, names: list[str], parents: list[int], rest_rotations: F64, rest_heads: F64, lengths: F64
    ) -> None: ...
    @property
    def size(self) -> int: ...
    @property
    def names(self) -> list[str]: ...
    def find(self, name: str) -> int: ...

def armature_pose(rig: Rig, basis_rotations: F64, basis_locations: F64) -> tuple[F64, F64]: ...
class RetargetResult:
    @property
    def rotations(self) -> F64: ...
    @property
    def root_locations(self) -> F64: ...
    @property
    def kept_posture(self) -> list[int]: ...

class RetargetOptions:
    root_motion: Literal["scaled", "in_place", "offset", "none"]
    scale: float
    unit_scale: float
    vertical_offset: float
    scale_horizontal: float
    space: npt.ArrayLike
    up: npt.ArrayLike
    source_floor: float
    target_floor: float
    posture_bones: list[int]
    posture_always: list[int]
    helper_bones: list[int]
    threads: int
    def __init__(self) -> None: ...

def retarget(source: Rig, target: Rig, source_rotations: F64, source_root_heads: F64, bone_map: list[int], *,
    source_match: F64, source_match_root: npt.ArrayLike, target_match_basis: F64,
    target_match_location: npt.ArrayLike, source_root: int, target_root: int, options: RetargetOptions = ...,
    source_aims: F64 | None = None, target_aims: F64 | None = None) -> RetargetResult: ...

# Mirroring a clip across a plane (native/python/bind_mirror.cpp).
def mirror(source: Rig, target: Rig, basis_rotations: F64, basis_locations: F64, partners: list[int],
    kept: list[int], *, normal: npt.ArrayLike = ..., point: npt.ArrayLike = ...) -> tuple[F64, F64]: ...

# The body's signed-distance field (native/python/bind_body.cpp).
def body_field(vertices: F64, triangles: I32, vertex_bone: list[int], *,
    origin: npt.ArrayLike, spacing: float, dims: list[int]) -> tuple[F64, I32]: ...
def body_sample(distance: F64, owner: I32, *, dims: list[int], origin: npt.ArrayLike, spacing: float,
    carriers: list[int], carrier_rest: F64, carrier_heads: F64, carrier_cells: I32, orientations: F64,
    heads: F64, points: F64, gradient: bool = False) -> tuple[F64, F64 | None]: ...
class BodyArmResult:
    """What body_arm returns, by name."""
    least: F64
    hand: F64
    gap: F64
def body_arm(distance: F64, owner: I32, *, dims: list[int], origin: npt.ArrayLike, spacing: float,
    carriers: list[int], carrier_rest: F64, carrier_heads: F64, carrier_cells: I32, orientations: F64, heads: F64,
    arm: list[int],
    point_bones: list[int], point_local: F64, on_hand: list[int], frames: list[int], wanted: F64, touch: list[int],
    turns: F64, goals: F64 | None = None, contacts: F64 | None = None, touch_distance: float = 0.0,
    iterations: int = 6, turn_weight: float = 0.05, max_step: float = 0.25, smoothness: float = 0.0,
    threads: int = 0) -> BodyArmResult: ...

# Full-body inverse kinematics (native/python/bind_ik.cpp).
class IkEffector:
    """One effector of ik_solve: its bone's tail reaches a target, or with pin holds where the input has it."""

    def __init__(self, bone: int, *, name: str = "", weight: float = 1.0, position: bool = True,
        orientation: bool = False, pin: bool = False) -> None: ...
    bone: int
    name: str
    weight: float
    position: bool
    orientation: bool
    pin: bool

class IkResult:
    """What ik_solve returns (read-only arrays)."""

    @property
    def rotations(self) -> F64: ...
    @property
    def root_locations(self) -> F64: ...
    @property
    def scales(self) -> F64: ...
    @property
    def errors(self) -> F64: ...
    @property
    def iterations(self) -> I32: ...

class _IkJointsFields(TypedDict, total=False):
    limit_min: F64 | None
    limit_max: F64 | None
    locked: Bools | None
    stiffness: F64 | None
    excluded: Bools | None
    stretch: F64 | None
    scale_range: F64 | None
    soft: Bools | None
    stage: I32 | None
    mass: F64 | None

class IkJoints:
    """ik_solve's per-bone tables, each optional (b bones): limit_min, limit_max float64 (b, 3) radians,
    locked bool (b, 3), stiffness float64 (b, 3), excluded bool (b,), stretch float64 (b,), scale_range
    float64 (b, 2), soft bool (b, 3), stage int32 (b,), mass float64 (b,). Float and bool tables are taken as
    they are (C order, that dtype); shapes are checked against the rig by ik_solve."""

    def __init__(self, **kwargs: Unpack[_IkJointsFields]) -> None: ...
    limit_min: F64 | None
    limit_max: F64 | None
    locked: Bools | None
    stiffness: F64 | None
    excluded: Bools | None
    stretch: F64 | None
    scale_range: F64 | None
    soft: Bools | None
    stage: I32 | None
    mass: F64 | None

class _IkOptionsFields(TypedDict, total=False):
    method: Literal["dls", "pinv", "transpose", "ccd"]
    max_iterations: int
    tolerance: float
    max_step: float
    damping: float
    regularization: float
    reference: Literal["previous", "input"]
    orientation_scale: float
    root_translation: bool
    root_rotation: bool
    warm_start: bool
    threads: int
    size: float
    priorities: bool
    balance: bool
    up: npt.ArrayLike
    balance_margin: float

class IkOptions:
    """ik_solve's options; IkOptions(**fields) sets the named ones. Defaults: method "dls", max_iterations 64,
    tolerance 0.0, max_step 0.3, damping 0.0, regularization 1e-4, reference "previous", orientation_scale 0.0,
    root_translation False, root_rotation False, warm_start True, threads 0, size 0.0, priorities True,
    balance False, up (0, 0, 1), balance_margin 0.0. An unknown method or reference raises MotionKitError."""

    def __init__(self, **kwargs: Unpack[_IkOptionsFields]) -> None: ...
    method: Literal["dls", "pinv", "transpose", "ccd"]
    max_iterations: int
    tolerance: float
    max_step: float
    damping: float
    regularization: float
    reference: Literal["previous", "input"]
    orientation_scale: float
    root_translation: bool
    root_rotation: bool
    warm_start: bool
    threads: int
    size: float
    priorities: bool
    balance: bool
    up: npt.ArrayLike
    balance_margin: float

def ik_solve(rig: Rig, input_rotations: F64, input_locations: F64, target_positions: F64, target_orientations: F64,
    effectors: list[IkEffector], *, joints: IkJoints | None = None, options: IkOptions | None = None) -> IkResult:
    """Whole-clip full-body IK; see native/include/motionkit/ik.hpp. Bones the solver does not move keep their input."""

# Foot contacts (native/python/bind_contacts.cpp).
def foot_targets(points: F64, contacts: Bools, blend_frames: int, rigid_pairs: list[tuple[int, int]] = []
) -> tuple[F64, F64]: ...

# BVH (native/python/bind_bvh.cpp); Skeleton above.
class Motion:
    """The channel values of a BVH clip and its frame time."""

    def __init__(self, values: F64, frame_time: float) -> None: ...
    @property
    def values(self) -> F64: ...
    @property
    def frames(self) -> int: ...
    @property
    def frame_time(self) -> float: ...

def read_bvh(path: str) -> tuple[Skeleton, Motion]: ...
def write_bvh(path: str, skeleton: Skeleton, motion: Motion) -> None: ...
def bvh_to_pose(skeleton: Skeleton, values: F64, bone_rest: F64, conversion: npt.ArrayLike, scale: float
) -> tuple[F64, F64]: ...
def pose_to_bvh(skeleton: Skeleton, rotations: F64, locations: F64, bone_rest: F64, conversion: npt.ArrayLike,
    scale: float) -> F64: ...

# Euler angles (native/python/bind_rotation.cpp).
def euler_to_quaternion(angles: F64, order: str) -> F64: ...
def quaternion_to_euler(quaternions: F64, order: str, continuous: bool = True, previous: F64 = ...,
    threads: int = 0) -> F64: ...
def quaternion_channels(quaternions: F64, previous: F64 = ..., threads: int = 0, out: F64 | None = None) -> F64: ...

# F-curve evaluation (native/python/bind_fcurve.cpp).
def evaluate_fcurves(co: F64, handle_left: F64, handle_right: F64, interpolation: I32, key_offsets: I32,
    linear_extrapolation: I32, times: F64) -> F64: ...

# Filters (native/python/bind_filters.cpp). kind is one of "butterworth",
# "gaussian", "median", "one_euro"; each reads only its own keywords.
def filter_channels(values: F64, kind: str, fps: float, *, cutoff: float = 7.0, order: int = 4, sigma: float = 1.0,
    size: int = 5, min_cutoff: float = 1.0, beta: float = 0.0, d_cutoff: float = 1.0) -> F64: ...
def filter_rotations(quaternions: F64, kind: str, fps: float, *, cutoff: float = 7.0, order: int = 4,
    sigma: float = 1.0, size: int = 5, min_cutoff: float = 1.0, beta: float = 0.0, d_cutoff: float = 1.0
) -> F64: ...

# Functions only the tests use (native/python: the _testing submodule), written as a namespace so that
# this one stub holds the module.
class _testing:
    @staticmethod
    def data_address(array: F64) -> int: ...
    @staticmethod
    def parse_bvh(text: str, source: str = "<string>") -> tuple[Skeleton, Motion]: ...
    @staticmethod
    def format_bvh(skeleton: Skeleton, motion: Motion) -> str: ...
    @staticmethod
    def blender_euler_mode(order: str) -> str: ...
    @staticmethod
    def interpolate_curves(offsets: npt.NDArray[np.integer], times: F64, values: F64, eval_times: F64,
        kind: str = "natural", *, slopes: ArrayIn = None, end_slopes: ArrayIn = None, tension: ArrayIn = None,
        continuity: ArrayIn = None, bias: ArrayIn = None, derivative: bool = False) -> F64 | tuple[F64, F64]: ...
    @overload
    @staticmethod
    def slerp(q0: npt.ArrayLike, q1: npt.ArrayLike, u: F64) -> F64: ...
    @overload
    @staticmethod
    def slerp(q0: npt.ArrayLike, q1: npt.ArrayLike, u: float) -> F64: ...

# Hand-kept stub of the compiled module native/python/module.cpp.
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

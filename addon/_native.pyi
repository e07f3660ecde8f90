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

"""The loaded native core (or why it is missing), shared by every module of the add-on. The compiled
module and its build_info.json sit at the package's top (motionkit/_native*.so), one level above core/."""
import contextlib
import os
import re

from . import native_loader

status = native_loader.load(__package__.rpartition(".")[0], os.path.dirname(os.path.dirname(__file__)))


def native():
    """The native core module; raises RuntimeError with the reason when it is not usable."""
    if not status.ok:
        raise RuntimeError(status.message)
    return status.module


@contextlib.contextmanager
def blender_frames(frames):
    """Native errors raised inside name Blender's frames: the core counts rows of the clip it was given
    ("frame index i"), the user knows the timeline, so i becomes frames[i] ("frame 12")."""
    try:
        yield
    except ValueError as error:
        message = str(error)

        def frame(match):
            i = int(match.group(1))
            return f"frame {float(frames[i]):g}" if 0 <= i < len(frames) else match.group(0)

        named = re.sub(r"frame index (\d+)", frame, message)
        if named == message:
            raise
        raise ValueError(named) from None

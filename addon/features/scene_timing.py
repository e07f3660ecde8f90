"""The scene's frame rate and range from a clip, so that a 60 fps capture keyed into a 24 fps scene plays at
the speed it was captured at and is not cut at the scene's end frame."""
import math

from ..blender import animdata
from ..core import frame_rates


def from_clip(scene, action) -> tuple[float, int, int]:
    """Sets the scene's rate to the action's recorded one (animdata.frame_rate: as captured, else the scene's
    own) as Blender keeps it, and its range to the action's keys; returns (fps, start, end)."""
    rate = animdata.frame_rate(action)
    scene.render.fps, scene.render.fps_base = frame_rates.scene_rate(1.0 / rate)
    first, last = action.frame_range
    scene.frame_start, scene.frame_end = math.floor(first), math.ceil(last)
    return scene.render.fps / scene.render.fps_base, scene.frame_start, scene.frame_end

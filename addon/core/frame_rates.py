"""Frame rates as Blender keeps them (an integer fps and a float fps_base, the rate being fps / fps_base),
from a BVH file's frame time, which files print to a few digits (0.016667 s for 60 fps, 0.033333 s for
30 fps, 0.041708 s for 23.976 fps). No bpy here."""
from __future__ import annotations

# Rates people capture and animate at, as (fps, fps_base): whole ones, and NTSC's n * 1000 / 1001.
_NTSC = tuple((n, 1.001) for n in (24, 30, 48, 60, 120, 240))


def scene_rate(frame_time: float, digits_error: float = 1e-4) -> tuple[int, float]:
    """(fps, fps_base) for a clip of frame_time seconds a frame: the nearest whole rate (fps_base 1) or NTSC
    rate when the frame time is within digits_error of it, relatively (what a file's printed digits leave
    out: 0.016667 is 60 fps to 2e-5), else the rate itself (fps rounded, fps_base making it exact)."""
    if not (frame_time > 0 and frame_time == frame_time and frame_time != float("inf")):
        raise ValueError(f"a frame time must be a positive number of seconds, not {frame_time!r}")
    rate = 1.0 / frame_time
    whole = max(1, round(rate))
    candidates = [(whole, 1.0)] + [c for c in _NTSC if abs(c[0] / c[1] - rate) < 1.0]
    fps, base = min(candidates, key=lambda c: abs(c[0] / c[1] - rate))
    if abs(fps / base - rate) <= digits_error * rate:
        return fps, base
    return whole, whole / rate

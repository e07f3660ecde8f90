"""Resample and reduce keys in Blender: motionkit.resample and motionkit.reduce_keys.

Location, scale and other scalar channels are interpolated per channel group
(a location is one 3-D curve); rotations are interpolated on the quaternion
sphere whatever the rotation mode, and come back in the owner's own mode with
continuous angles. Keys are read and written in bulk (motionkit.animdata),
everything is computed and checked before the first F-curve changes, so an
error leaves the action as it was.
"""
from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from . import world_reduction
from ..blender import animdata, channel_groups
from ..core import native_state, resample_plan, rotation_channels, worker_thread
from ..core.resample_plan import ChannelGroup

POLYNOMIAL_MAX_KEYS = 64
# Slopes of sphere curves for exact output come from one-sided second-order
# differences this far apart (in frames): truncation ~1e-6 x the third
# derivative, round-off ~1e-13.
_SLOPE_STEP = 1e-3
_TANGENT_STEP = 1e-4  # frames; truncation ~1e-8 x the third derivative, round-off ~1e-12
_SMOOTH_ROTATIONS = {"squad", "catmull-rom", "euler-catmull-rom", "axis-angle-catmull-rom"}


@dataclass
class KeyWrite:
    """One group's new keys, computed and checked, waiting to be written. in_place: the channels' curves
    keep their keys (at frames) and take the new values (animdata.set_key_values)."""
    channels: list
    frames: np.ndarray
    values: np.ndarray
    interpolation: str
    handles: animdata.Handles | None
    in_place: bool = False


def target_action(target, verb: str = "resample"):
    """(object, action) from an object or an action that some object plays; verb names the work in errors."""
    if isinstance(target, bpy.types.Action):
        for obj in bpy.data.objects:
            if animdata.assigned_action(obj) == target:
                return obj, target
        raise ValueError(f"action '{target.name}' is not assigned to any object: pass the object instead")
    if not isinstance(target, bpy.types.Object):
        raise TypeError(f"expected an Object or an Action, got {type(target).__name__}")
    action = animdata.assigned_action(target)
    if action is None:
        raise ValueError(f"'{target.name}' has no action to {verb}")
    return target, action


def _stepped(group: ChannelGroup) -> bool:
    """A scalar curve whose keys all hold (CONSTANT), such as a 0/1 foot contact: it stays stepped, never
    a spline that overshoots between its values."""
    return group.kind == 'scalar' and animdata.holds_every_key(next(iter(group.curves.values())))


def _key_range(fcurve) -> tuple[float, float]:
    points = fcurve.keyframe_points
    return points[0].co[0], points[-1].co[0]


def _scalar_options(kind: str, count: int, tcb) -> dict:
    if kind == "polynomial" and count > POLYNOMIAL_MAX_KEYS:
        raise ValueError(f"polynomial interpolation through {count} keys would only show Runge's phenomenon "
                         f"(at most {POLYNOMIAL_MAX_KEYS} keys); choose another interpolant")
    if kind == "kochanek-bartels":
        return {name: np.full(count, value) for name, value in zip(("tension", "continuity", "bias"), tcb)}
    return {}


def _resample_vector(native, label, times, values, grid, kind, output, tcb) -> tuple:
    if kind == "periodic" and not np.allclose(values[0], values[-1], rtol=0, atol=1e-6):
        raise ValueError(f"{label}: a periodic spline needs equal first and last keys")
    options = _scalar_options(kind, times.size, tcb)
    times, values, grid = (np.ascontiguousarray(a, dtype=np.float64) for a in (times, values, grid))
    try:
        new = native.interpolate(times, values, grid, kind=kind, **options)
        if output == 'DENSE' or kind in resample_plan.NOT_CUBIC or grid.size < 2:
            return new, 'LINEAR', None
        if kind in resample_plan.BLENDER_INTERPOLATION:
            return new, resample_plan.BLENDER_INTERPOLATION[kind], None
        if kind == "periodic":  # rounding must not break the equal-ends rule
            new[-1] = new[0]
        slopes_in, slopes_out = native.hermite_form(grid, new, kind=kind, **_scalar_options(kind, grid.size, tcb))
    except native.MotionKitError as ex:
        raise ValueError(f"{label}: {ex}") from None
    return new, 'BEZIER', (slopes_in, slopes_out)


def _resample_rotation(native, group, times, values, grid, kind, output, tcb) -> tuple:
    mode = group.mode
    quats = rotation_channels.to_quaternions(native, mode, values, group.data_path, times)
    order = rotation_channels.euler_order(mode)[0] if mode in rotation_channels.EULER_MODES else "XYZ"
    options = {"euler_order": order}
    if kind == "kochanek-bartels":
        options.update({name: np.full(times.size, value)
                        for name, value in zip(("tension", "continuity", "bias"), tcb)})
    exact = output == 'EXACT' and grid.size >= 2
    smooth = kind in _SMOOTH_ROTATIONS or (kind == "kochanek-bartels" and tcb[1] == 0.0)
    if exact and smooth:
        return _smooth_rotation_keys(native, group, times, quats, values, grid, kind, options)
    if exact:
        # Five samples per key, in time order, so that continuity runs through them.
        offsets = _SLOPE_STEP * np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
        eval_times = (grid[:, None] + offsets[None, :]).ravel()
    else:
        eval_times = grid
    times, quats, eval_times = (np.ascontiguousarray(a, dtype=np.float64) for a in (times, quats, eval_times))
    try:
        q = native.interpolate_rotations(times, quats, eval_times, kind=kind, **options)
    except native.MotionKitError as ex:
        raise ValueError(f"{group.data_path}: {ex}") from None
    channels = rotation_channels.from_quaternions(native, mode, q, previous=values[0])
    if not exact:
        return channels, 'LINEAR', None
    samples = channels.reshape(grid.size, 5, -1)
    new = samples[:, 2]
    h = _SLOPE_STEP
    slopes_in = (3.0 * new - 4.0 * samples[:, 1] + samples[:, 0]) / (2.0 * h)
    slopes_out = (-3.0 * new + 4.0 * samples[:, 3] - samples[:, 4]) / (2.0 * h)
    # Outside the keys the rotation holds, so the outer slopes of the end keys
    # are zero; the segments need the inner ones.
    slopes_in[0], slopes_out[-1] = slopes_out[0], slopes_in[-1]
    if kind in _SMOOTH_ROTATIONS or (kind == "kochanek-bartels" and tcb[1] == 0.0):
        slopes_in = slopes_out = 0.5 * (slopes_in + slopes_out)
    return new, 'BEZIER', (slopes_in, slopes_out)


def _smooth_rotation_keys(native, group, times, quats, values, grid, kind, options) -> tuple:
    """Keys and slopes of a C1 sphere curve from one evaluation with its angular velocity.

    Each key's channels are also taken a hair before and after along the curve's
    own tangent (exp(+-eps w / 2) q), so the slope of every channel, in any
    rotation mode, is a central difference along the exact tangent direction.
    """
    # The last key takes the velocity from inside, not that of the held end.
    at_end = grid[-1] >= times[-1] - 1e-9
    eval_times = np.append(grid, times[-1] - 1e-6) if at_end else grid
    times, quats, eval_times = (np.ascontiguousarray(a, dtype=np.float64) for a in (times, quats, eval_times))
    try:
        q, omega = native.interpolate_rotations(times, quats, eval_times, kind=kind, angular_velocity=True,
                                                **options)
    except native.MotionKitError as ex:
        raise ValueError(f"{group.data_path}: {ex}") from None
    if at_end:
        q, omega[-2] = q[:-1], omega[-1]
        omega = omega[:-1]
    if group.mode == 'QUATERNION':
        # dq/dt = (0, w) q / 2 exactly, kept with the hemisphere the keys take.
        q = rotation_channels.sign_continuous(q, quats[0])
        slopes = 0.5 * rotation_channels.multiply(np.hstack([np.zeros((len(omega), 1)), omega]), q)
        return q, 'BEZIER', (slopes, slopes)
    rows = np.stack([_turn(q, omega, -_TANGENT_STEP), q, _turn(q, omega, _TANGENT_STEP)], axis=1)
    channels = rotation_channels.from_quaternions(native, group.mode, rows.reshape(-1, 4), previous=values[0])
    channels = channels.reshape(grid.size, 3, -1)
    slopes = (channels[:, 2] - channels[:, 0]) / (2.0 * _TANGENT_STEP)
    return np.ascontiguousarray(channels[:, 1]), 'BEZIER', (slopes, slopes)


def _turn(q, omega, dt):
    """exp(dt w / 2) q: q carried dt along the world angular velocity w."""
    angle = np.linalg.norm(omega, axis=1, keepdims=True) * dt
    axis = np.divide(omega, np.linalg.norm(omega, axis=1, keepdims=True), out=np.zeros_like(omega),
                     where=angle != 0)
    return rotation_channels.multiply(np.hstack([np.cos(0.5 * angle), np.sin(0.5 * angle) * axis]), q)


def _handles(frames, values, slopes) -> animdata.Handles:
    slopes_in, slopes_out = slopes
    return animdata.Handles(*resample_plan.bezier_handles(frames, values, slopes_in, slopes_out))


def target_actions(targets, verb: str = "resample") -> list:
    """[(object, action)] from one object or action, or a list of them, each once."""
    items = targets if isinstance(targets, (list, tuple, set)) else [targets]
    pairs = []
    for item in items:
        pair = target_action(item, verb)
        if all(pair[0] != seen[0] for seen in pairs):
            pairs.append(pair)
    if not pairs:
        raise ValueError("nothing to work on: no object or action given")
    return pairs


def bones_of(bones, obj):
    return bones.get(obj.name) if isinstance(bones, dict) else bones


def resample(targets, step: float | None = None, fps: float | None = None, *, rotation: str = "squad",
             scalar: str = "catmull-rom", output: str = 'EXACT', change_scene_rate: bool = False,
             bones=None, tension: float = 0.0, continuity: float = 0.0, bias: float = 0.0,
             scene=None, progress=None) -> list:
    """Put the keys of the targets' actions on a new frame step or frame rate.

    targets: an object, an action that an object plays, or a list of them.
    step: a key every `step` frames; fps: keys at a new frame rate, with the
    scene's rate and frame range changed to it (change_scene_rate) or kept
    (keys then fall every scene_fps / fps frames). scalar / rotation: the
    interpolants (motionkit.resample_plan lists them). output 'EXACT' writes
    Bezier handles so that Blender draws the chosen curve between the keys
    (rotations: per channel, matching the sphere curve's value and slope at
    every key); 'DENSE' writes linear keys. bones: pose bone names to resample,
    or {object name: names} (default: every curve of each action). tension,
    continuity, bias: Kochanek-Bartels parameters for every key.
    progress(done, total): called per channel group. Returns the actions.
    Everything is computed and checked before anything changes: a ValueError
    leaves every action and the scene as they were.
    """
    native = native_state.native()
    pairs = target_actions(targets)
    scene = scene or bpy.context.scene
    valid_scalar = [item[0] for item in resample_plan.SCALAR_INTERPOLANTS]
    valid_rotation = [item[0] for item in resample_plan.ROTATION_INTERPOLANTS]
    if scalar not in valid_scalar:
        raise ValueError(f"unknown scalar interpolant {scalar!r}; expected one of {valid_scalar}")
    if rotation not in valid_rotation:
        raise ValueError(f"unknown rotation interpolant {rotation!r}; expected one of {valid_rotation}")
    if output not in ('EXACT', 'DENSE'):
        raise ValueError(f"unknown output {output!r}; expected 'EXACT' or 'DENSE'")
    if not all(np.isfinite([tension, continuity, bias])):
        raise ValueError("tension, continuity and bias must be finite")
    scene_fps = scene.render.fps / scene.render.fps_base
    timing = resample_plan.plan_timing(scene_fps, float(scene.frame_start), step, fps, change_scene_rate)
    tcb = (tension, continuity, bias)

    work = []
    for obj, action in pairs:
        groups = channel_groups.read(obj, action, bones_of(bones, obj))
        if not groups:
            raise ValueError(f"'{obj.name}' has no keys to resample" + (" on the selected bones" if bones else ""))
        check_keys_finite(obj, [fc for group in groups for fc in group.curves.values()], "resample")
        work.append((obj, action, groups))
    ends = [_key_range(fcurve) for *_, groups in work for group in groups for fcurve in group.curves.values()]
    first, last = min(e[0] for e in ends), max(e[1] for e in ends)
    grid = resample_plan.key_grid(float(timing.map(first)), float(timing.map(last)), timing.step)

    # The groups are independent and their work is native (GIL released) and
    # numpy, so they run on all cores while this thread reads the next group's
    # keys; everything that touches bpy stays on this thread.
    total = sum(len(groups) for *_, groups in work)
    planned, done = [], 0
    with worker_thread.pool() as pool:
        for obj, action, groups in work:
            futures = []
            for group in groups:
                channels, times, values = channel_groups.keys(obj, action, group)
                kind = "stepped" if _stepped(group) else scalar
                futures.append(pool.submit(_resample_group, native, channels, group, timing.map(times),
                                           values, grid, kind, rotation, output, tcb))
            writes = []
            for future in futures:
                if progress is not None:
                    progress(done, total)
                done += 1
                writes.append(future.result())
            check_finite(obj, writes)
            planned.append((obj, action, writes))
    write_planned(planned)
    if timing.scene_fps is not None:
        _set_scene_rate(scene, timing)
        # The actions' frames now count the new rate's frames: a capture's recorded rate (animdata.FRAME_RATE,
        # which contacts and root smoothing turn seconds into frames with) follows.
        for _, action, _ in planned:
            if action.get(animdata.FRAME_RATE) is not None:
                action[animdata.FRAME_RATE] = float(timing.scene_fps)
    return [action for _, action, _ in planned]


def _resample_group(native, channels, group, times, values, grid, scalar, rotation, output, tcb) -> KeyWrite:
    if times.size == 1:
        return KeyWrite(channels, times, np.ascontiguousarray(values.T), 'LINEAR', None)
    own_grid = resample_plan.segment_grid(grid, float(times[0]), float(times[-1]))
    if group.kind == 'rotation':
        new, interpolation, slopes = _resample_rotation(native, group, times, values, own_grid,
                                                        rotation, output, tcb)
    else:
        new, interpolation, slopes = _resample_vector(native, group.label(), times, values, own_grid,
                                                      scalar, output, tcb)
    values_t = np.ascontiguousarray(new.T)
    handles = _handles(own_grid, values_t, (slopes[0].T, slopes[1].T)) if slopes is not None else None
    return KeyWrite(channels, own_grid, values_t, interpolation, handles)


def check_keys_finite(obj, fcurves, label: str) -> None:
    """A ValueError naming the curve and frame of the first key of fcurves that is not a finite number (or,
    failing that, the first key with such a handle): work on such keys would spread NaN through every curve
    it computes."""
    bad = animdata.first_non_finite(fcurves)
    if bad is not None:
        where = (f"at frame {bad.frame:g}" if np.isfinite(bad.frame)
                 else f"(key {bad.index}, whose frame is not a number)")
        raise ValueError(f"{label}: '{obj.name}' {bad.fcurve.data_path}[{bad.fcurve.array_index}] has a non-finite "
                         f"{bad.what} {where}; nothing was changed")


def check_finite(obj, writes) -> None:
    for write in writes:
        arrays = [write.values] + ([write.handles.left_values, write.handles.right_values]
                                   if write.handles is not None else [])
        for array in arrays:
            if np.isfinite(array).all():
                continue  # the usual case, without argwhere's index array
            bad = np.argwhere(~np.isfinite(array))
            if bad.size:
                channel, key = bad[0]
                raise ValueError(f"{obj.name}: {write.channels[channel]} would get a non-finite value at "
                                 f"frame {write.frames[key]:g}; nothing was changed")


def _set_scene_rate(scene, timing) -> None:
    fps = timing.scene_fps
    scene.render.fps = max(1, int(round(fps)))
    scene.render.fps_base = scene.render.fps / fps
    start, end = timing.map([scene.frame_start, scene.frame_end])
    scene.frame_end = max(int(round(start)), int(round(end)))


def reduce_keys(targets, tolerance: float = 1e-3, rotation_tolerance: float = np.radians(0.1), *,
                samples_per_frame: int = 4, bones=None, progress=None, space: str = 'CHANNELS',
                distance: float = 1e-3, axis_length: float = 0.1) -> tuple[int, int]:
    """Replace each channel group's keys by the fewest Bezier keys that stay within tolerance.

    targets, bones: as for resample. space 'CHANNELS': tolerance for
    location, scale and scalar channels, in their own units;
    rotation_tolerance: radians, on the whole rotation (not per channel;
    axis-angle channels: per channel). space 'WORLD' (armatures): the pose
    bones' keys are reduced together so that every joint (head, and the tail
    of a bone without children) and the points axis_length along each bone's
    three axes stay within distance of where they were (scene units, through
    the object's scale; errors accumulating down the hierarchy included);
    their other curves take the per-channel tolerances (world_reduction). The
    current curves are sampled samples_per_frame times per frame; the
    reduced curve stays within its bound at every sample, and its keys stay
    on whole frames where the original ones were. Returns (keys before, keys
    after). A ValueError leaves every action as it was.
    """
    native = native_state.native()
    pairs = target_actions(targets, "reduce")
    if space not in ('CHANNELS', 'WORLD'):
        raise ValueError(f"reduce_keys: space must be 'CHANNELS' or 'WORLD', got {space!r}")
    if not (np.isfinite(tolerance) and tolerance > 0 and np.isfinite(rotation_tolerance)
            and rotation_tolerance > 0):
        raise ValueError("reduce_keys: tolerances must be positive")
    if space == 'WORLD':
        world_reduction.check_settings(distance, axis_length)
    if not (isinstance(samples_per_frame, int) and 1 <= samples_per_frame <= 64):
        raise ValueError("reduce_keys: samples_per_frame must be an integer from 1 to 64")
    work = []
    for obj, action in pairs:
        groups = channel_groups.read(obj, action, bones_of(bones, obj))
        if not groups:
            raise ValueError(f"'{obj.name}' has no keys to reduce")
        check_keys_finite(obj, [fc for group in groups for fc in group.curves.values()], "reduce_keys")
        for group in groups:
            for fcurve in group.curves.values():
                if len(fcurve.modifiers):
                    raise ValueError(f"{fcurve.data_path}[{fcurve.array_index}] has F-curve modifiers: "
                                     "apply or remove them before reducing its keys")
        work.append((obj, action, groups))
    world = {}
    if space == 'WORLD':
        for obj, action, groups in work:
            for key, keys in world_reduction.plan(native, obj, action, groups, distance, axis_length,
                                                  samples_per_frame).items():
                world[(obj.name, *key)] = keys

    def compute(obj, action, group):
        planned_keys = world.get((obj.name, group.owner, group.prop))
        if planned_keys is None:
            return _reduce_group(native, obj, action, group, tolerance, rotation_tolerance, samples_per_frame)
        channels, frames, values, slopes_in, slopes_out = planned_keys
        return KeyWrite(channels, frames, values, 'BEZIER', _handles(frames, values, (slopes_in, slopes_out)))

    planned, before, after = plan_group_writes(work, compute, progress)
    write_planned(planned)
    return before, after


def plan_group_writes(work, compute, progress) -> tuple[list, int, int]:
    """Each group's new keys, computed and checked before anything is written: work [(object, action,
    groups)], compute(object, action, group) -> KeyWrite, progress(done, total) or None. Returns
    ([(object, action, writes)], keys before, keys after)."""
    total = sum(len(groups) for _, _, groups in work)
    planned, before, after, done = [], 0, 0, 0
    for obj, action, groups in work:
        writes = []
        for group in groups:
            if progress is not None:
                progress(done, total)
            done += 1
            before += sum(len(fcurve.keyframe_points) for fcurve in group.curves.values())
            writes.append(compute(obj, action, group))
            after += writes[-1].values.size
        check_finite(obj, writes)
        planned.append((obj, action, writes))
    return planned, before, after


def write_planned(planned) -> None:
    """Writes what plan_group_writes computed, in bulk."""
    for obj, action, writes in planned:
        for write in writes:
            if write.in_place:
                animdata.set_key_values(obj, action, write.channels, write.values, frames=write.frames)
            else:
                animdata.write_keys(obj, action, write.channels, write.frames, write.values, write.interpolation,
                                    write.handles)


def _reduce_group(native, obj, action, group, tolerance, rotation_tolerance, samples_per_frame) -> KeyWrite:
    channels, static = channel_groups.channels(obj, group)
    reads = [animdata.read_keys(fcurve)[0] for fcurve in group.curves.values()]
    first = min(float(f[0]) for f in reads)
    last = max(float(f[-1]) for f in reads)
    times = resample_plan.samples_between(first, last, samples_per_frame)
    if last - times[-1] > 1e-9:
        times = np.append(times, last)
    values = channel_groups.sample(obj, action, channels, static, times)
    kind, order, tol = "absolute", "XYZ", tolerance
    columns = np.arange(values.shape[1])
    if group.kind == 'rotation':
        tol = rotation_tolerance
        if group.mode == 'QUATERNION':
            kind = "quaternion"
        elif group.mode in rotation_channels.EULER_MODES:
            # The native Euler mode takes the angles in its order's letter order.
            kind = "euler"
            order, axes = rotation_channels.euler_order(group.mode)
            columns = np.asarray(axes)
    try:
        indices, slopes_in, slopes_out = native.reduce_keys(
            times, np.ascontiguousarray(values[:, columns]), tol, mode=kind, euler_order=order,
            stride=samples_per_frame)
    except native.MotionKitError as ex:
        raise ValueError(f"{group.label()}: {ex}") from None
    inverse = np.argsort(columns)
    slopes_in, slopes_out = slopes_in[:, inverse], slopes_out[:, inverse]
    frames = times[indices]
    values_t = np.ascontiguousarray(values[indices].T)
    handles = _handles(frames, values_t, (slopes_in.T, slopes_out.T))
    return KeyWrite(channels, frames, values_t, 'BEZIER', handles)

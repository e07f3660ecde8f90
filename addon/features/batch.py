"""A library of motion files retargeted onto one target in one Blender: every take of every file, a bad file
reported and the rest done, a quality row per clip (features/clip_report), and what each import brought
taken away again so that memory stays flat over thousands of files.

motionkit.batch.retarget_library(["clips/"], target, out_dir="out", export="fbx")
"""
from __future__ import annotations

import contextlib
import math
import os
import time
from dataclasses import dataclass, field

import bpy

from ..blender import animdata, imports
from ..core import batch_inputs, batch_report, channel_carry
from . import bvh, clip_report, retargeting

EXPORTS = ("bvh", "fbx", "glb", "gltf")
# What a file may do wrong that fails its clip and not the batch: MotionKit's and Blender's own errors.
_CLIP_ERRORS = (ValueError, RuntimeError, TypeError, KeyError, IndexError, AttributeError, OSError,
                UnicodeDecodeError, ArithmeticError)


@dataclass
class BatchResult:
    """Every clip's report row (batch_report.COLUMNS), and the actions made, in the files' order."""
    rows: list = field(default_factory=list)
    actions: list = field(default_factory=list)

    @property
    def failed(self) -> int:
        return sum(row["status"] == "failed" for row in self.rows)


def _load_takes(path: str) -> tuple[object, list, dict | None]:
    """(source armature, [(take name or None, action)], what the import added or None for a BVH)."""
    if os.path.splitext(path)[1].lower() in imports.FORMATS:
        obj, added = imports.import_animated_armature(path)
        return obj, imports.takes(obj, added), added
    obj, action = bvh.load(path)
    return obj, [(None, action)], None


def _output_path(out_dir: str | None, export: str | None, name: str) -> str | None:
    if not (out_dir and export):
        return None
    safe = "".join(c if c.isalnum() or c in "-_.@" else "_" for c in name)
    return os.path.join(out_dir, f"{safe}.{export}")


def _retarget_take(path, stem, take, action, count, source, target, out_dir, export, overwrite, keep,
                   options) -> tuple:
    """(report row, new action or None) of one take. options: retarget()'s keywords, as check_options takes
    them."""
    name = batch_inputs.clip_name(path, take, count, stem)
    row = batch_report.new_row(path, take if count > 1 else "", name)
    started = time.perf_counter()
    output = _output_path(out_dir, export, name)
    if output and os.path.exists(output) and not overwrite:
        row.update(status="skipped", reason=f"{output} exists (overwrite replaces it)")
        return row, None
    made = None
    try:
        animdata.assign(source, action)
        fields, rest = retargeting.split_options(options)
        retargeted = retargeting.retarget_clip(source, target, options=fields, **rest, action_name=name)
        # The pairs and kept bones as the retarget decided them, on the target as it found it (after it, root
        # motion onto the object has moved it).
        pairs, kept = list(retargeted.pairs), list(retargeted.kept_bones)
        made = retargeted.action
        made.use_fake_user = True
        # What the body stage did (the arms kept out of the target's body, or why not), as the button says.
        row["body"] = retargeted.body.message() if retargeted.body is not None else ""
        # The scale, properties and shape keys the target had no place for (RetargetOptions.channels).
        row["channels_left_out"] = channel_carry.summary(retargeted.channels_left_out)
        row.update(clip_report.row_figures(source, target, pairs, kept))
        if output:
            export_clip(target, output, export)
            row["output"] = output
        if not keep:
            bpy.data.actions.remove(made)
            made = None
    except _CLIP_ERRORS as error:
        if made is not None:
            bpy.data.actions.remove(made)
            made = None
        row.update(status="failed", reason=_reason(path, take if count > 1 else "", error))
    row["seconds"] = round(time.perf_counter() - started, 3)
    return row, made


def _reason(path: str, take: str, error: BaseException) -> str:
    """What went wrong, naming the file (and take) where MotionKit's message does not already."""
    message = str(error) if isinstance(error, ValueError) else f"{type(error).__name__}: {error}"
    where = f"{path} | {take}" if take else path
    return message if path in message else f"{where}: {message}"


def retarget_file(path: str, target, *, out_dir=None, export=None, overwrite=False, stem=None, keep=True,
                  **options) -> BatchResult:
    """Every take of one file onto target; everything the file brought is removed again, whatever happens.
    stem: the file's name for its clips (batch_inputs.stems), by default its own stem; keep: False removes
    each new action once it is written out (a pipeline that wants the files only)."""
    with _selection_kept():
        result = _retarget_takes(path, target, out_dir, export, overwrite, stem, keep, options)
    return result


def _retarget_takes(path, target, out_dir, export, overwrite, stem, keep, options) -> BatchResult:
    """retarget_file's work, the view layer's selection aside."""
    result, named = BatchResult(), []
    before = imports.snapshot()
    try:
        try:
            source, takes, _ = _load_takes(path)
        except _CLIP_ERRORS as error:
            result.rows.append(batch_report.new_row(path, "", batch_inputs.clip_name(path, stem=stem),
                                                    status="failed", reason=_reason(path, "", error)))
            return result
        if not takes:
            result.rows.append(batch_report.new_row(path, "", batch_inputs.clip_name(path, stem=stem), status="failed",
                                                    reason=f"{path}: the armature has no take that moves its bones"))
        for take, action in takes:
            row, made = _retarget_take(path, stem, take, action, len(takes), source, target, out_dir, export,
                                       overwrite, keep, options)
            result.rows.append(row)
            if made is not None:
                result.actions.append(made)
                named.append(row)
    finally:
        kept = set(result.actions)
        added = imports.added_since(before)
        added["actions"] = [a for a in added["actions"] if a not in kept]
        imports.remove(added)
    for action, row in zip(result.actions, named):  # the source's own action held the name until now
        action.name = row["action"]
        row["action"] = action.name  # what Blender made of it, were the name another action's
    return result


def retarget_library(inputs, target, *, pattern: str = "*", recursive: bool = True, out_dir: str | None = None,
                     export: str | None = None, overwrite: bool = False, report_dir: str | None = None,
                     keep: bool = True, progress=None, **options) -> BatchResult:
    """Retarget every take of every motion file that inputs name (files, folders) onto target.

    One action per take, named '<file>' or '<file>|<take>', kept with a fake user. A file or take that
    fails is a 'failed' row with its reason and leaves nothing behind; the others are done. export: 'bvh',
    'fbx', 'glb' or 'gltf' writes each clip into out_dir, an existing file kept unless overwrite.
    report_dir: where report.json and report.csv go. keep=False: the actions are written out, not kept.
    progress(done, total, path) is called before each file.
    options: retargeting.retarget's.
    """
    check_arguments(target, export, out_dir, keep, options)
    files = batch_inputs.collect(inputs, pattern, recursive)
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
    result, stems = BatchResult(), batch_inputs.stems(files)
    for done, path in enumerate(files):
        if progress is not None:
            progress(done, len(files), path)
        one = retarget_file(path, target, out_dir=out_dir, export=export, overwrite=overwrite, stem=stems[path],
                            keep=keep, **options)
        result.rows += one.rows
        result.actions += one.actions
    if progress is not None:
        progress(len(files), len(files), "")
    if report_dir:
        batch_report.write(result.rows, report_dir)
    return result


def check_arguments(target, export, out_dir, keep, options) -> None:
    """What would fail every clip of a batch, refused before any file is read: a ValueError naming the
    argument (the target, export, out_dir, keep, a retarget option)."""
    if not (isinstance(target, bpy.types.Object) and target.type == 'ARMATURE'):
        raise ValueError(f"target: {getattr(target, 'name', target)!r} is not an armature object")
    if export is not None and export not in EXPORTS:
        raise ValueError(f"unknown export {export!r}; expected one of {EXPORTS}")
    if export and not out_dir:
        raise ValueError("export needs out_dir, the folder the clips are written into")
    if not keep and not export:
        raise ValueError("keep=False without export would leave nothing of the clips")
    if "action_name" in options:
        raise ValueError("action_name: a batch names each action after its clip")
    retargeting.check_options(**options)
    fields = retargeting.split_options(options)[0]
    if fields.into != "new":  # every clip would write into, and be named as, the target's own action
        raise ValueError(f"into={fields.into!r}: a batch makes a new action of each clip (into='new'); the "
                         f"bones it does not write keep the target's own keys in each")
    retargeting.check_root_bone(target, fields)


def retarget_files(paths, target, **options) -> list:
    """Every file's takes onto target, one action each (retarget_file), and the actions in the order of
    paths; for scripts that want a bad file to stop them: a file that fails raises ValueError naming it,
    and the files before it keep their actions."""
    actions = []
    for path in paths:
        one = retarget_file(os.fspath(path), target, **options)
        failed = [row for row in one.rows if row["status"] == "failed"]
        if failed:
            raise ValueError(failed[0]["reason"])
        actions += one.actions
    return actions


def export_clip(target, path: str, kind: str) -> None:
    """The target's action alone, over its own frames, written by MotionKit's BVH writer or Blender's
    exporters. Alone: no NLA track under it, and no other action of the file (Blender 3.4's glTF exporter
    otherwise takes in every armature action of the file when one armature is exported and merges them into
    one animation); its frames: the action's range, not the scene's. The scene is as it was afterwards."""
    action = animdata.assigned_action(target)
    if action is None:
        raise ValueError(f"export_clip: '{target.name}' plays no action to export")
    first, last = math.floor(action.frame_range[0]), math.ceil(action.frame_range[1])
    with _clip_alone(target, first, last):
        if kind == "bvh":
            bvh.save(target, path, frame_range=(first, last))
        elif kind == "fbx":
            # Every frame keyed (no simplify), so that the file plays Blender's evaluation, not a curve fit of it.
            bpy.ops.export_scene.fbx(filepath=path, use_selection=True, object_types={'ARMATURE'},
                                     add_leaf_bones=False, bake_anim_use_all_actions=False,
                                     bake_anim_use_nla_strips=False, bake_anim_simplify_factor=0.0)
        else:
            bpy.ops.export_scene.gltf(**_gltf_options(path, kind, action.name))


@contextlib.contextmanager
def _selection_kept():
    """The view layer's selected and active objects as they were, afterwards (an importer selects what it
    brings and nothing else); those removed meanwhile left out, known by address, never touched."""
    layer = bpy.context.view_layer
    layer.update()  # objects linked or removed since (an import, its clean-up) listed as they are (4.x syncs lazily)
    selected = {o.as_pointer() for o in layer.objects if o.select_get()}
    active = layer.objects.active.as_pointer() if layer.objects.active is not None else None
    try:
        yield
    finally:
        layer.update()
        for obj in layer.objects:
            obj.select_set(obj.as_pointer() in selected)
        layer.objects.active = next((o for o in layer.objects if o.as_pointer() == active), None)


_POSE_CHANNELS = {"location": (0.0, 0.0, 0.0), "rotation_quaternion": (1.0, 0.0, 0.0, 0.0),
                  "rotation_euler": (0.0, 0.0, 0.0), "rotation_axis_angle": (0.0, 0.0, 1.0, 0.0),
                  "scale": (1.0, 1.0, 1.0)}


@contextlib.contextmanager
def _clip_alone(target, first: int, last: int):
    """The target alone selected and active, its NLA off, every pose channel at rest where the action keys
    none (the clip keys no scale: what an earlier action left there is no part of it), the scene's range
    the clip's; all put back after."""
    scene, layer, anim = bpy.context.scene, bpy.context.view_layer, target.animation_data
    kept = (scene.frame_start, scene.frame_end, scene.frame_current, anim.use_nla)
    pose = [(b, {k: tuple(getattr(b, k)) for k in _POSE_CHANNELS}) for b in target.pose.bones]
    with _selection_kept():
        try:
            for obj in layer.objects:
                obj.select_set(obj == target)
            layer.objects.active = target
            anim.use_nla = False
            for bone, _ in pose:
                for key, rest in _POSE_CHANNELS.items():
                    setattr(bone, key, rest)
            scene.frame_start, scene.frame_end = first, last
            yield
        finally:
            anim.use_nla = kept[3]
            for bone, values in pose:
                for key, value in values.items():
                    setattr(bone, key, value)
            scene.frame_start, scene.frame_end = kept[0], kept[1]
            scene.frame_set(kept[2])


def _gltf_options(path: str, kind: str, name: str) -> dict:
    """Only the active action, as one animation named after it, in whichever words this Blender's glTF
    exporter has: 3.4's export_anim_single_armature (on by default) would add every other armature action."""
    known = bpy.ops.export_scene.gltf.get_rna_type().properties.keys()
    options = {"filepath": path, "use_selection": True, "export_format": 'GLB' if kind == "glb" else 'GLTF_SEPARATE'}
    wanted = {"export_animation_mode": 'ACTIVE_ACTIONS', "export_nla_strips": False,
              "export_anim_single_armature": False, "export_frame_range": True,
              "export_nla_strips_merged_animation_name": name}
    options.update({key: value for key, value in wanted.items() if key in known})
    return options

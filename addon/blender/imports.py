"""Motion files read through Blender's own importers (FBX, glTF), leaving nothing behind on failure, and an
imported armature taken away again.

Blender's importers are operators that add whatever the file holds (meshes,
materials, images, several armatures, one action per take); MotionKit keeps
the animated armature and can take back everything an import added.
"""
from __future__ import annotations

import os

import bpy

from . import animdata

FORMATS = {".fbx": "fbx", ".glb": "gltf", ".gltf": "gltf"}
_DATA = ("objects", "meshes", "armatures", "actions", "materials", "images", "textures", "cameras", "lights",
         "collections", "node_groups", "curves")


def snapshot() -> dict[str, set]:
    return {kind: set(getattr(bpy.data, kind)[:]) for kind in _DATA}


def added_since(before: dict[str, set]) -> dict[str, list]:
    return {kind: [item for item in getattr(bpy.data, kind) if item not in before[kind]] for kind in _DATA}


def remove(added: dict[str, list]) -> None:
    """Removes what an import added, objects first (their data may then be removed too)."""
    for kind in _DATA:
        collection = getattr(bpy.data, kind)
        for item in added.get(kind, []):
            try:
                collection.remove(item)
            except ReferenceError:  # already gone with something removed before it
                pass


def remove_armature(obj, action=None) -> None:
    """Removes an armature object, its armature, and its action (action, else the one it plays) once nothing
    else uses that."""
    action = action if action is not None else animdata.assigned_action(obj)
    armature = obj.data
    bpy.data.objects.remove(obj)
    bpy.data.armatures.remove(armature)
    if action is not None and action.users == 0:
        bpy.data.actions.remove(action)


def _run_importer(path: str, kind: str) -> None:
    if kind == "fbx":
        if not hasattr(bpy.ops.import_scene, "fbx"):
            _enable("io_scene_fbx")
        bpy.ops.import_scene.fbx(filepath=path)
    else:
        if not hasattr(bpy.ops.import_scene, "gltf"):
            _enable("io_scene_gltf2")
        bpy.ops.import_scene.gltf(filepath=path)


def _enable(module: str) -> None:
    import addon_utils
    addon_utils.enable(module, default_set=True)


def import_animated_armature(path) -> tuple[bpy.types.Object, dict[str, list]]:
    """Imports an FBX or glTF file with Blender's importer: (its animated armature, everything added).

    ValueError names the file when it cannot be read, holds no armature, or
    its armatures have no animation; the scene is then as it was.
    """
    path = os.fspath(path)
    kind = FORMATS.get(os.path.splitext(path)[1].lower())
    if kind is None:
        raise ValueError(f"{path}: not a file Blender's importers read here (expected {', '.join(FORMATS)})")
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file")
    before = snapshot()
    try:
        _run_importer(path, kind)
    except (RuntimeError, ValueError, TypeError, KeyError, IndexError, AttributeError, UnicodeDecodeError) as error:
        remove(added_since(before))
        detail = str(error).strip().splitlines()
        raise ValueError(f"{path}: Blender's {kind.upper()} importer could not read it"
                         f"{': ' + detail[-1] if detail else ''}") from None
    added = added_since(before)
    armatures = [o for o in added["objects"] if o.type == 'ARMATURE']
    animated = [o for o in armatures if animdata.assigned_action(o) is not None]
    if not animated:
        remove(added)
        what = "no armature" if not armatures else "an armature with no animation"
        raise ValueError(f"{path}: the file holds {what}; MotionKit needs an animated armature to retarget from")
    return animated[0], added


def _take_name(obj, action) -> str:
    """The name a file gave a take: glTF's animation (the NLA track the importer put it on), FBX's stack
    (the action's name after the importer's 'object|')."""
    anim = obj.animation_data
    for track in (anim.nla_tracks if anim is not None else ()):
        if any(strip.action == action for strip in track.strips):
            return track.name
    return action.name[len(obj.name) + 1:] if action.name.startswith(obj.name + "|") else action.name


def takes(obj, added: dict[str, list]) -> list[tuple[str, bpy.types.Action]]:
    """(take name, action) for every action an import added that animates obj's bones, the one the
    importer assigned first, the others as the file ordered them."""
    assigned = animdata.assigned_action(obj)
    found = [a for a in added["actions"]
             if any(c.data_path.startswith("pose.bones[") for c in animdata.fcurves(a, obj))]
    found.sort(key=lambda a: a != assigned)
    return [(_take_name(obj, a), a) for a in found]

"""The source a retarget reads from a file: a BVH through MotionKit's reader (sized by bvh_scale), FBX and
glTF through Blender's own importers, and what becomes of the import once the target is keyed."""
from __future__ import annotations

import os
from dataclasses import dataclass

import bpy
import numpy as np

from . import bvh
from ..blender import imports, pose_channels
from ..blender.imports import remove_armature
from ..core.retarget_options import is_number

# What a file's imported armature (the source retarget() imports) becomes once the retarget is done.
IMPORTED_SOURCES = (
    ("keep", "Keep", "Leave the imported armature in the scene, scaled as asked"),
    ("hide", "Hide", "Keep the imported armature (and anything imported with it), hidden in the viewport and "
                     "in renders"),
    ("remove", "Remove", "Remove what was imported, its action included, once the target is keyed"),
)


def imported_source_option(imported_source, bvh_source) -> str:
    if imported_source is not None and bvh_source is not None and imported_source != bvh_source:
        raise ValueError("imported_source and its older name bvh_source say different things; give one")
    chosen = imported_source or bvh_source or "keep"
    if chosen not in [b[0] for b in IMPORTED_SOURCES]:
        raise ValueError(f"unknown imported_source (bvh_source) {chosen!r}; expected one of {[b[0] for b in IMPORTED_SOURCES]}")
    return chosen


@dataclass
class Imported:
    """A source armature retarget() imported from a file, and what the import added."""
    obj: bpy.types.Object
    added: dict | None = None  # Blender's importers: everything they added (imports.remove)

    def remove(self) -> None:
        if self.added is None:
            remove_armature(self.obj)
        else:
            imports.remove(self.added)

    def finish(self, what: str) -> None:
        """What becomes of the import once the target is keyed: IMPORTED_SOURCES."""
        if what == "remove":
            self.remove()
            return
        if what == "hide":
            shown = [self.obj] + ([o for o in self.added["objects"] if o != self.obj] if self.added else [])
            for obj in shown:
                obj.hide_set(True)
                obj.hide_render = True


def check_bvh_scale(bvh_scale) -> None:
    if not (bvh_scale == "auto" or (is_number(bvh_scale) and np.isfinite(bvh_scale) and bvh_scale > 0)):
        raise ValueError(f"bvh_scale must be 'auto' or a positive number, not {bvh_scale!r}")


def import_source(path, target, bvh_scale) -> Imported:
    """A file path's armature: BVH through MotionKit's reader, FBX and glTF through Blender's importers."""
    path = os.fspath(path)
    if os.path.splitext(path)[1].lower() in imports.FORMATS:
        obj, added = imports.import_animated_armature(path)
        return Imported(obj, added)
    check_bvh_scale(bvh_scale)
    obj, _ = bvh.load(path, scale=1.0 if bvh_scale == "auto" else float(bvh_scale))
    if bvh_scale == "auto":
        try:
            stand_as_tall_as(obj, target)
        except BaseException:
            remove_armature(obj)
            raise
    return Imported(obj)


def stand_as_tall_as(obj, other) -> None:
    """Scale obj (uniformly, as an object) so that its rest pose stands as tall as other's."""
    def height(o):
        world = np.array(o.matrix_world)
        z = (pose_channels.rest_points(o.data) @ world[:3, :3].T + world[:3, 3])[:, 2]
        return float(np.ptp(z))

    mine, theirs = height(obj), height(other)
    if mine > 0 and theirs > 0:
        obj.scale = obj.scale * (theirs / mine)
        bpy.context.view_layer.update()

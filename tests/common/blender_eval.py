"""What Blender itself shows, for tests and benches to judge by: a Graph Editor context for Blender's own
operators, and points of a posed armature as Blender evaluates them (frame_set, pose_bone.matrix)."""
from __future__ import annotations

import bpy
import numpy as np


class GraphEditor:
    """A context override with a Graph Editor showing every curve (the largest area of the window's screen
    switched to one); the area's type is restored on leaving."""

    def __enter__(self):
        window = bpy.context.window_manager.windows[0]
        self.area = max(window.screen.areas, key=lambda area: area.width * area.height)
        self.kept_type = self.area.type
        self.area.type = 'GRAPH_EDITOR'
        self.space = self.area.spaces.active
        self.kept_only_selected = self.space.dopesheet.show_only_selected
        self.space.dopesheet.show_only_selected = False
        region = next(r for r in self.area.regions if r.type == 'WINDOW')
        return dict(window=window, screen=window.screen, area=self.area, region=region, space_data=self.space)

    def __exit__(self, *exc):
        self.space.dopesheet.show_only_selected = self.kept_only_selected
        self.area.type = self.kept_type


def world_scale(obj) -> float:
    """The object's largest scale factor: armature-space distances times it are world distances (at most)."""
    return float(np.linalg.svd(np.array(obj.matrix_world)[:3, :3], compute_uv=False)[0])


def world_points(obj, frames, axis):
    """(frames, bones, 5, 3) in world units: each pose bone's head, the points axis along its x, y and z
    (pose_bone.matrix, so its scale too), and its tail (the head again for a bone with children), as
    Blender evaluates them; armature space scaled by the object's largest scale factor. A frame with a
    fraction is evaluated between frames (frame_set's subframe), where the curves interpolate."""
    scene = bpy.context.scene
    scale = world_scale(obj)
    out = np.empty((len(frames), len(obj.pose.bones), 5, 3))
    for i, frame in enumerate(frames):
        whole = int(np.floor(frame))
        scene.frame_set(whole, subframe=float(frame) - whole)
        for b, pose_bone in enumerate(obj.pose.bones):
            matrix = np.array(pose_bone.matrix, dtype=np.float64)
            head = matrix[:3, 3]
            out[i, b, 0] = head
            out[i, b, 1:4] = head + axis * matrix[:3, :3].T
            out[i, b, 4] = np.array(pose_bone.tail) if not pose_bone.children else head
    return out * scale

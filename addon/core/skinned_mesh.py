"""A character's skin as plain data: the meshes its armature deforms, joined, at rest in the armature's
space (no bpy; blender/body_reads reads it from Blender's meshes, tests build it from arrays)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(eq=False)
class SkinnedMesh:
    """vertices (V, 3) rest positions in the armature's space and units; triangles (T, 3) int32 vertex
    indices; bone (V,) int, per vertex the rig bone whose vertex group weighs it most (-1 for none);
    weight (V,) that weight; source: what it was read from (the mesh objects' names), for messages."""
    vertices: np.ndarray
    triangles: np.ndarray
    bone: np.ndarray
    weight: np.ndarray
    source: str = ""

    def __post_init__(self):
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float64)
        self.triangles = np.ascontiguousarray(self.triangles, dtype=np.int32)
        self.bone = np.asarray(self.bone, dtype=np.int64)
        self.weight = np.asarray(self.weight, dtype=np.float64)
        count = len(self.vertices)
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3:
            raise ValueError(f"mesh '{self.source}': vertices must be (V, 3), not {self.vertices.shape}")
        if self.triangles.ndim != 2 or self.triangles.shape[1] != 3:
            raise ValueError(f"mesh '{self.source}': triangles must be (T, 3), not {self.triangles.shape}")
        if self.bone.shape != (count,) or self.weight.shape != (count,):
            raise ValueError(f"mesh '{self.source}': one bone and one weight per vertex")
        bad = np.flatnonzero((self.triangles < 0) | (self.triangles >= count))
        if len(bad):
            raise ValueError(f"mesh '{self.source}': triangle {bad[0] // 3} names vertex "
                             f"{self.triangles.ravel()[bad[0]]} of {count}")
        if not np.all(np.isfinite(self.vertices)):
            raise ValueError(f"mesh '{self.source}': vertex {np.flatnonzero(~np.isfinite(self.vertices).all(1))[0]} "
                             f"is not finite")

    @classmethod
    def from_weights(cls, vertices, triangles, weights, bones, source: str = "") -> "SkinnedMesh":
        """From dense skin weights (V, K) over the rig bones `bones` (K,): each vertex's heaviest."""
        weights = np.asarray(weights, dtype=np.float64)
        heaviest = np.argmax(weights, axis=1) if weights.size else np.zeros(len(weights), dtype=np.int64)
        weight = weights[np.arange(len(weights)), heaviest] if weights.size else np.zeros(len(weights))
        bone = np.where(weight > 0.0, np.asarray(bones, dtype=np.int64)[heaviest], -1) if weights.size else \
            np.full(len(weights), -1)
        return cls(vertices, triangles, bone, weight, source)

    @staticmethod
    def join(meshes: list["SkinnedMesh"]) -> "SkinnedMesh":
        """Several meshes as one (their triangles renumbered)."""
        offsets = np.cumsum([0] + [len(m.vertices) for m in meshes])
        return SkinnedMesh(np.vstack([m.vertices for m in meshes]),
                           np.vstack([m.triangles + o for m, o in zip(meshes, offsets)]),
                           np.concatenate([m.bone for m in meshes]), np.concatenate([m.weight for m in meshes]),
                           ", ".join(m.source for m in meshes))

"""The volume a character's body takes, from its skinned mesh (core.skinned_mesh): which of its bones
carry the body (the trunk, the head, the thighs) and which the forearms and hands, and the body's signed
distance where its bones have moved it (numpy and native, no bpy).

The body is a signed-distance field of the whole skin on a grid in the armature's rest space
(_native.body_field), each cell naming the bone that carries the skin nearest it. A point posed on a frame
is taken back to rest through each body bone's motion and read where that bone (or a bone next to it)
carries the cell: each part of the body moves rigidly with its bone (where two parts bend apart, a
point between them is outside both; where they bend together, inside either). Why a field: against the winding
number of the five Mixamo meshes of ../shared/data/bodies (points within about 3 cm of the skin), one
capsule per bone put 56-70 % of them on the right side on Big Vegas (a belly is no cylinder), convex pieces
56-79 %, the field 92-99 %, and all but 0-2 % beyond one cell of the skin (docs/body.md); a read costs one
trilinear lookup per body bone, the field 0.2-0.45 s to build for these characters at 128 cells a height.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import bone_mapping, native_state
from .rig_data import RigData
from .skinned_mesh import SkinnedMesh

BODY_PARTS = ("trunk", "head", "thigh")  # the closed body a hand is kept out of
ARM_PARTS = ("forearm", "hand")          # what is kept out of it
# Cells per height of the body: a cell of 1.4 cm on a 1.8 m character, finer than the decimated meshes'
# 1.4-4 cm edges, and 0.2-0.45 s to build natively for a decimated Mixamo character.
CELLS_PER_HEIGHT = 128
# The grid reaches this far (in the body's heights) beyond the body's skin: room for the clearance a hand
# keeps (a few cm) and for a distance's gradient there; farther, a point is simply outside.
MARGIN = 1.0 / 16.0

_LABEL_PART = {"shoulder": "upper_arm", "upper_arm": "upper_arm", "forearm": "forearm", "hand": "hand",
               "thigh": "thigh", "shin": "leg", "foot": "leg", "toe": "leg"}


def parts(rig: RigData, body: bone_mapping.Body) -> tuple:
    """Per bone, the part of the body it carries: "trunk" (the hips, spine and neck and what hangs from
    them that no limb does: a belly, a breast), "head" (and its hair, jaw, ears), "thigh", "leg" (shin
    and foot), "upper_arm" (with the shoulder), "forearm", "hand" (with the fingers), or "other" (above
    the hips). A bone takes the part of the nearest labelled bone at or above it; a twist bone its limb's."""
    labelled = {body.hips: "trunk", **{n: "trunk" for n in body.spine + body.neck}, body.head: "head"}
    labelled.update({name: _LABEL_PART[key.split(".")[0]] for key, name in body.limbs.items()})
    labelled.update({n: "hand" for chain in body.fingers.values() for n in chain})
    labelled.update({n: "hand" for n in body.metacarpals.values()})
    labelled.update({n: _LABEL_PART[key.split(".")[0]] for n, key in body.twists.items()})
    labelled.pop(None, None)
    out = []
    for b, name in enumerate(rig.names):
        line = [b] + rig.ancestors(b)
        found = next((labelled[rig.names[a]] for a in line if rig.names[a] in labelled), "other")
        out.append(found)
    return tuple(out)


@dataclass(eq=False)
class Body:
    """A character's body as a field (see the module): part per bone (parts()), the grid (origin, its
    first cell's centre; spacing; distance and owner (nx, ny, nz): the signed distance to the skin and the
    bone carrying the skin nearest), carriers: the body bones (BODY_PARTS) that carry cells, height: the
    body's extent along up (what CELLS_PER_HEIGHT divides)."""
    rig: RigData
    mesh: SkinnedMesh
    part: tuple
    origin: np.ndarray
    spacing: float
    distance: np.ndarray
    owner: np.ndarray
    carriers: np.ndarray
    height: float

    @classmethod
    def of(cls, rig: RigData, mesh: SkinnedMesh, body: bone_mapping.Body | None = None,
           cells_per_height: int = CELLS_PER_HEIGHT) -> "Body":
        """The field of mesh's skin over the body bones' vertices; a ValueError naming the mesh where no
        vertex is carried by a body bone."""
        labels = parts(rig, rig.body if body is None else body)
        carried = on_body(labels, mesh)
        if not carried.any():
            raise ValueError(f"mesh '{mesh.source}': no vertex is weighted to the trunk, head or thighs of "
                             f"'{rig.name}'")
        heights = mesh.vertices @ rig.up
        height = float(np.ptp(heights))
        spacing = height / cells_per_height
        low = mesh.vertices[carried].min(axis=0) - MARGIN * height
        high = mesh.vertices[carried].max(axis=0) + MARGIN * height
        dims = [int(d) for d in np.ceil((high - low) / spacing).astype(int) + 1]
        distance, owner = native_state.native().body_field(
            mesh.vertices, mesh.triangles, [int(b) for b in mesh.bone], origin=low, spacing=spacing, dims=dims)
        owner = owner.reshape(dims)
        carriers = np.array([b for b in np.unique(owner) if b >= 0 and labels[b] in BODY_PARTS], dtype=np.int64)
        return cls(rig, mesh, labels, low, spacing, distance.reshape(dims), owner, carriers, height)

    @classmethod
    def cached(cls, rig: RigData, mesh: SkinnedMesh) -> "Body":
        """Body.of, kept for the same rig rest and mesh (the last few): a batch retargeting a library onto one
        character builds its field once."""
        key = _fingerprint(rig, mesh)
        found = _CACHE.pop(key, None)
        if found is None:
            found = cls.of(rig, mesh)
        _CACHE[key] = found
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        return found

    def at_rest(self, points) -> tuple[np.ndarray, np.ndarray]:
        """(distance, owner) at points (..., 3) of the rest space: the field's trilinear distance and the
        nearest cell's bone; +inf and -1 off the grid."""
        points = np.asarray(points, dtype=np.float64)
        x = (points - self.origin) / self.spacing
        dims = np.array(self.distance.shape)
        inside = np.all((x >= 0) & (x <= dims - 1), axis=-1)
        x = np.clip(x, 0, dims - 1 - 1e-9)
        i0 = np.floor(x).astype(np.int64)
        f = x - i0
        out = np.zeros(points.shape[:-1])
        for corner in range(8):
            o = np.array([(corner >> 2) & 1, (corner >> 1) & 1, corner & 1])
            idx = np.minimum(i0 + o, dims - 1)
            out += np.prod(np.where(o, f, 1.0 - f), axis=-1) * self.distance[idx[..., 0], idx[..., 1], idx[..., 2]]
        near = np.rint(x).astype(np.int64)
        owner = self.owner[near[..., 0], near[..., 1], near[..., 2]]
        return np.where(inside, out, np.inf), np.where(inside, owner, -1)

    def posed(self, points, orientations, heads) -> np.ndarray:
        """(frames, N) the body's signed distance at points (frames, N, 3) of the armature's space, the rig
        posed with orientations (frames, 4B) and heads (frames, 3B) (an armature pose): each point taken
        back to rest through every carrier's motion and read where that carrier carries the cell; the
        nearest of those, +inf where none does. A carrier reads its own cells only: read through a bone
        it does not carry, a turned head's place at rest would stand on the neck as a head not turned."""
        return self.posed_with_gradient(points, orientations, heads, gradient=False)[0]

    def posed_with_gradient(self, points, orientations, heads, gradient: bool = True):
        """posed()'s distance and, with gradient, its gradient (frames, N, 3) in the armature's space (zero
        where no carrier reads a point); natively (_native.body_sample)."""
        points = np.asarray(points, dtype=np.float64)
        frames, count = points.shape[0], points.shape[1]
        read, slope = native_state.native().body_sample(
            **self.field_arguments(), orientations=np.ascontiguousarray(orientations, dtype=np.float64),
            heads=np.ascontiguousarray(heads, dtype=np.float64),
            points=np.ascontiguousarray(points.reshape(frames, 3 * count)), gradient=gradient)
        return read, (slope.reshape(frames, count, 3) if gradient else None)

    def field_arguments(self) -> dict:
        """The field and its carriers as the native reads take them (_native.body_sample, body_arm)."""
        rig = self.rig
        return dict(distance=self._flat_distance, owner=self._flat_owner, dims=[int(d) for d in self.distance.shape],
                    origin=self.origin, spacing=self.spacing, carriers=[int(b) for b in self.carriers],
                    carrier_rest=np.ascontiguousarray(rig.unit_rest[self.carriers]),
                    carrier_heads=np.ascontiguousarray(rig.heads[self.carriers]), carrier_cells=self._carrier_cells)

    @cached_property
    def _carrier_cells(self) -> np.ndarray:
        """(K, 6) int32: per carrier the first and last cell (i, j, k) of the box around the cells it owns, so
        that the native reads pass over a carrier whose box a point misses without touching the grid."""
        out = np.zeros((len(self.carriers), 6), dtype=np.int32)
        for row, bone in enumerate(self.carriers):
            owned = np.argwhere(self.owner == bone)
            out[row] = np.concatenate([owned.min(axis=0), owned.max(axis=0)])
        return out

    @cached_property
    def _flat_distance(self) -> np.ndarray:
        return np.ascontiguousarray(self.distance.ravel(), dtype=np.float64)

    @cached_property
    def _flat_owner(self) -> np.ndarray:
        return np.ascontiguousarray(self.owner.ravel(), dtype=np.int32)


def skins_body(rig: RigData, mesh: SkinnedMesh) -> bool:
    """Whether any of mesh's vertices is weighted most to the rig's trunk, head or thighs (a face or a prop
    alone is no body)."""
    return bool(on_body(parts(rig, rig.body), mesh).any())


def on_body(labels, mesh: SkinnedMesh) -> np.ndarray:
    """(V,) whether each of mesh's vertices is weighted most to a body bone (BODY_PARTS) of labels (parts())."""
    return np.isin(mesh.bone, [b for b, part in enumerate(labels) if part in BODY_PARTS])


_CACHE: dict = {}
_CACHE_SIZE = 4


def _fingerprint(rig: RigData, mesh: SkinnedMesh) -> str:
    """What a body is built from, hashed: the rig's names and rest, the mesh's vertices, triangles and bones."""
    digest = hashlib.blake2b(digest_size=16)
    digest.update("\0".join(rig.names).encode())
    for array in (rig.rest, rig.heads, mesh.vertices, mesh.triangles, mesh.bone):
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()

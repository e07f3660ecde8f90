"""Writes the rest skeletons of the real characters in ../shared/data/pairs as JSON rig fixtures.

Run once in Blender 3.4 (the importers users have):
    blender --background --factory-startup --python tests/python/data/rigs/dump_rigs.py
Each fixture holds what core.bone_mapping sees of the imported armature (blender.pose_channels.
armature_mapping_rig): bone names depth first, parent indices, rest heads and tails in armature space,
plus the armature object's world matrix, which the mapping does not read.
"""
import json
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', '..', '..'))

HERE = os.path.dirname(os.path.abspath(__file__))
PAIRS = os.path.join(HERE, "..", "..", "..", "..", "..", "shared", "data", "pairs")
SOURCES = {
    "Aj": ("san/Aj/Running.bvh", "bvh"),
    "Kaya": ("san/Kaya/Running.bvh", "bvh"),
    "girl1": ("fbx/girl1/Happy Walk Backward.fbx", "fbx"),
    "girl2": ("fbx/girl2/Happy Walk Backward.fbx", "fbx"),
}


class Skeleton:
    """A BVH hierarchy as MotionKit's native reader gives it: joints and end sites, parents first."""

    def __init__(self, path):
        self.names, self.parents, self.offsets, self.end_sites = [], [], [], []
        stack, pending = [], None
        with open(path, encoding="utf-8") as f:
            for line in f:
                words = line.split()
                if not words or words[0] == "MOTION":
                    if words:
                        break
                    continue
                if words[0] in ("ROOT", "JOINT") or words[:2] == ["End", "Site"]:
                    end = words[0] == "End"
                    pending = (stack[-1][0] + "_end" if end else words[1], end)
                elif words[0] == "{":
                    self.names.append(pending[0])
                    self.end_sites.append(pending[1])
                    self.parents.append(stack[-1][1] if stack else -1)
                    stack.append((pending[0], len(self.names) - 1))
                elif words[0] == "}":
                    stack.pop()
                elif words[0] == "OFFSET":
                    self.offsets.append([float(v) for v in words[1:4]])
        self.offsets = np.array(self.offsets)


class CompactSkeleton(Skeleton):
    """A hierarchy written one joint a line (san/*.txt): two spaces of indent a level, the name and its offset;
    "End x y z" for an end site; "#" lines are notes."""

    def __init__(self, path):
        self.names, self.parents, self.offsets, self.end_sites = [], [], [], []
        stack = []
        with open(path, encoding="utf-8") as f:
            for line in f:
                if not line.strip() or line.startswith("#"):
                    continue
                depth = (len(line) - len(line.lstrip(" "))) // 2
                name, *offset = line.split()
                del stack[depth:]
                end = name == "End"
                self.names.append(self.names[stack[-1]] + "_end" if end else name)
                self.parents.append(stack[-1] if stack else -1)
                self.end_sites.append(end)
                self.offsets.append([float(v) for v in offset])
                stack.append(len(self.names) - 1)
        self.offsets = np.array(self.offsets)


def bvh_rig(path, skeleton=None):
    """MotionKit's own importer's bones (features/bvh.py: Blender 3.4's import_anim.bvh fails on Python 3.11)."""
    from addon.features import bvh
    skeleton = skeleton or Skeleton(path)
    heads, tails = bvh._rest_bones(skeleton, bvh.ImportOptions())
    joints = [i for i, end in enumerate(skeleton.end_sites) if not end]
    index = {j: k for k, j in enumerate(joints)}
    return {"importer": "MotionKit's BVH importer (features/bvh.py) with its defaults",
            "matrix_world": [[1.0 if r == c else 0.0 for c in range(4)] for r in range(4)],
            "names": [skeleton.names[j] for j in joints],
            "parents": [index.get(skeleton.parents[j], -1) for j in joints],
            "heads": [[round(float(v), 6) for v in heads[j]] for j in joints],
            "tails": [[round(float(v), 6) for v in tails[j]] for j in joints]}


def fbx_rig(path):
    from addon.blender.pose_channels import depth_first  # the order core.bone_mapping reads an armature in
    bpy.ops.import_scene.fbx(filepath=path)
    arm = next(o for o in bpy.context.scene.objects if o.type == 'ARMATURE')
    bones = depth_first(arm.data)
    index = {b.name: i for i, b in enumerate(bones)}
    return {"importer": f"Blender {bpy.app.version_string} import_scene.fbx with its defaults",
            "matrix_world": [[round(v, 9) for v in row] for row in arm.matrix_world],
            "names": [b.name for b in bones],
            "parents": [index[b.parent.name] if b.parent else -1 for b in bones],
            "heads": [[round(v, 6) for v in b.head_local] for b in bones],
            "tails": [[round(v, 6) for v in b.tail_local] for b in bones]}


def dump(name, relative, kind):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    path = os.path.normpath(os.path.join(PAIRS, relative))
    if kind == "bvh":
        data = bvh_rig(path)
    else:
        data = fbx_rig(path)
    data = {
        "character": name, "from": f"../shared/data/pairs/{relative}",
        **data}
    with open(os.path.join(HERE, f"{name}.json"), "w", encoding="utf-8") as f:
        json.dump(data, f, indent=0)
        f.write("\n")
    print(name, len(data["names"]), "bones")


for key, (rel, kind) in SOURCES.items():
    dump(key, rel, kind)
# The other characters of the SAN test set, from their hierarchies in san/*.txt.
for file in sorted(os.listdir(os.path.join(HERE, "san"))):
    source = os.path.join(HERE, "san", file)
    with open(source, encoding="utf-8") as f:
        note = f.readline().lstrip("# ").strip()
    data = {"character": file[:-4], "from": note, **bvh_rig(source, CompactSkeleton(source))}
    with open(os.path.join(HERE, file[:-4] + ".json"), "w", encoding="utf-8") as f:
        json.dump(data, f, indent=0)
        f.write("\n")
    print(file[:-4], len(data["names"]), "bones")
sys.exit(0)

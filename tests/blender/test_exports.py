"""The batch's exports played by clients that are not MotionKit: each GLB and glTF by three.js under node
(GLTFLoader + AnimationMixer, checked first by Khronos' glTF validator), each FBX and BVH re-imported by
Blender's own importers; every joint where Blender's evaluation of the target puts it (frame_set, then each
pose bone's head through matrix_world), on every frame of the clip.

The scene holds what a user's has and an exporter may wrongly take in: the target's own earlier action
(kept with a fake user), an NLA track on the target, and the source's action while the batch runs.
"""
import json
import os
import shutil
import subprocess

import bpy
import numpy as np
import pytest
from mathutils import Matrix

import conftest
import mixamo_pairs
from test_batch import target, ybot_blend  # noqa: F401  (fixtures)
from test_production_files import fbx_dir  # noqa: F401  (a fixture)

JS = os.path.join(conftest.ROOT, "tools", "js")
# glTF is +Y up, -Z forward out of Blender's exporter: Blender's (x, y, z) is glTF's (x, -z, y).
GLTF_TO_BLENDER = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


# Worst joint distance over the clip, as a fraction of the target's height (1e-4 at most for any export).
# glTF: float32 translations and quaternions; a joint 10-20 bones from the root moves by the sum of its
# chain's roundings (2^-24 each, times a lever under the height): measured 4.9e-7 (3.4), 6.2e-7 (4.3, 5.2).
# FBX: float32 key values read back into Blender's float32 matrices, the same order: measured 5.8e-7 (3.4),
# 6.3e-7 (4.3, 5.2). BVH: the file holds full doubles, but Blender's importer turns each Euler triple into
# a matrix and back into the bone's Euler in float32, ill-conditioned near gimbal lock (the worst, a right
# finger on frame 44, hangs on a forearm bent 89 degrees about its ZXY Euler's middle axis): measured
# 4.4e-6 (3.4), 5.0e-6 (4.3, 5.2). Each bound about 10x its measure.
JOINT_BOUND = {"glb": 6e-6, "gltf": 6e-6, "fbx": 6e-6, "bvh": 5e-5}


@pytest.fixture(scope="session")
def node_js():
    """node, with tools/js's packages (three, gltf-validator) installed by `npm ci --prefix tools/js`
    (tools/install_deps.sh): required under CI, a visible skip elsewhere."""
    node = shutil.which("node")
    missing = [] if node else ["node"]
    missing += [f"tools/js/node_modules/{name}" for name in ("three", "gltf-validator")
                if not os.path.isfile(os.path.join(JS, "node_modules", name, "package.json"))]
    if missing:
        message = f"{', '.join(missing)} missing (tools/install_deps.sh installs them)"
        if os.environ.get("CI") == "true":
            pytest.fail(message + ", and CI=true requires them")
        pytest.skip(message)
    return node


def _node(node, script, *args) -> dict:
    done = subprocess.run([node, os.path.join(JS, script), *map(str, args)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, f"{script} {args[0]}: {done.stderr}"
    return json.loads(done.stdout)


def _import_bvh(path):
    """Blender's own BVH importer (3.4's given the open() it needs: mixamo_pairs.import_bvh), in the
    file's units: bvh.save writes Blender units (metres)."""
    scale, mixamo_pairs.BVH_SCALE = mixamo_pairs.BVH_SCALE, 1.0
    try:
        return mixamo_pairs.import_bvh(path)
    finally:
        mixamo_pairs.BVH_SCALE = scale


def _height(obj) -> float:
    """The armature's height at rest in the world: the span of its bones' heads and tails along Z."""
    world = obj.matrix_world
    z = [(world @ p).z for b in obj.data.bones for p in (b.head_local, b.tail_local)]
    return max(z) - min(z)


def _blender_joints(obj, frames) -> dict:
    """{bone: (frames, 3)} world heads as Blender evaluates obj on each frame."""
    heads = {b.name: [] for b in obj.pose.bones}
    for frame in frames:
        bpy.context.scene.frame_set(frame)
        world = obj.matrix_world
        for pose_bone in obj.pose.bones:
            heads[pose_bone.name].append(tuple(world @ pose_bone.head))
    return {name: np.array(points) for name, points in heads.items()}


def _user_scene(target):
    """The target as a user's scene has it before a batch: its own action (fake user) playing, and an NLA
    track under it with another action; both key every bone away from the clip, its scale too, which the
    retargeted clip leaves unkeyed (an NLA track evaluated under it would show through there)."""
    anim = target.animation_data_create()
    made = []
    for name in ("own", "layer"):
        action = bpy.data.actions.new(f"{target.name}_{name}")
        anim.action = action
        for i, pose_bone in enumerate(target.pose.bones):
            pose_bone.rotation_mode = 'QUATERNION'
            pose_bone.rotation_quaternion = (0.9, 0.3 if name == "own" else 0.0, 0.0, 0.3 if i % 2 else -0.3)
            pose_bone.location = (0.0, 0.1, 0.0)
            pose_bone.scale = (1.2, 0.9, 1.1)
            for frame in (1, 200):
                for path in ("rotation_quaternion", "location", "scale"):
                    pose_bone.keyframe_insert(path, frame=frame)
        action.use_fake_user = True
        made.append(action)
    anim.action = None
    anim.nla_tracks.new().strips.new("layer", 1, made[1])
    anim.action = made[0]
    for obj in bpy.context.view_layer.objects:  # as a user leaves it: the character selected and active
        obj.select_set(obj == target)
    bpy.context.view_layer.objects.active = target
    return made


def _state(target):
    scene, anim = bpy.context.scene, target.animation_data
    bpy.context.view_layer.update()  # the objects the batch imported and removed again no longer listed
    return dict(frames=(scene.frame_start, scene.frame_end, scene.frame_current),
                selected=sorted(o.name for o in bpy.context.view_layer.objects if o.select_get()),
                active=getattr(bpy.context.view_layer.objects.active, "name", None),
                use_nla=anim.use_nla, tracks=[(t.name, t.mute, t.is_solo, [s.action.name for s in t.strips])
                                               for t in anim.nla_tracks],
                fake_users=sorted(a.name for a in bpy.data.actions if a.use_fake_user))


@pytest.fixture()
def clip(mk, fbx_dir, target, tmp_path):  # noqa: F811
    """Mixamo's punch (66 frames at 30 fps), to go onto Y Bot in a user's scene that plays 250 frames."""
    _user_scene(target)
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 250
    return os.path.join(fbx_dir, "ybot@punch.fbx")


def _gltf_joints(node, path, action, frames, fps) -> dict:
    """{node name: (frames, 3)} world positions in Blender's axes as three.js plays the file, once Khronos'
    validator has found no error in it. Blender's glTF exporter writes frame f at time f / fps (no slide to
    zero); the file must hold the clip alone: one animation, named after it, over its frames only."""
    report = _node(node, "validate_gltf.mjs", path)
    assert report["issues"]["numErrors"] == 0, report["issues"]["messages"]
    played = _node(node, "play_gltf.mjs", path, *[f / fps for f in frames])
    animation, = played["animations"]
    assert animation["name"] == action.name, animation
    # float32 times: frame 66 at 30 fps is 2.2 s to 1.2e-7 s.
    assert np.allclose([animation["start"], animation["end"]], [frames[0] / fps, frames[-1] / fps],
                       rtol=0, atol=1e-6), animation
    positions = np.array(played["positions"]) @ GLTF_TO_BLENDER.T
    return {name: positions[:, i] for i, name in enumerate(played["nodes"])}


def _reimported_joints(path, kind, frames) -> dict:
    """{bone: (frames, 3)} as Blender evaluates what its own FBX or BVH importer makes of the file; the
    file's frames must be the clip's. FBX: written at f / fps and read back at f (anim_offset 0); BVH:
    its first frame read at frame 1."""
    before = set(bpy.data.objects)
    if kind == "fbx":
        bpy.ops.import_scene.fbx(filepath=path, anim_offset=0.0)
        imported, = [o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE']
        at = list(frames)
    else:
        imported = _import_bvh(path)
        at = [f - frames[0] + 1 for f in frames]
    keyed = tuple(round(v, 3) for v in imported.animation_data.action.frame_range)
    assert keyed == (at[0], at[-1]), f"{path}: keys over frames {keyed}, the clip's are {(at[0], at[-1])}"
    return _blender_joints(imported, at)


@pytest.mark.parametrize("kind", ["glb", "gltf", "fbx", "bvh"])
def test_an_export_plays_the_retargeted_clip_alone(mk, node_js, target, clip, tmp_path, kind):  # noqa: F811
    """The batch's export of one clip, played by another client, puts every joint of the target where
    Blender does on every frame; the scene around it is as it was."""
    out = tmp_path / "out"
    before = _state(target)
    result = mk.batch.retarget_library([clip], target, out_dir=str(out), export=kind)
    row, = result.rows
    assert row["status"] == "ok", row
    assert _state(target) == {**before, "fake_users": sorted(before["fake_users"] + [row["action"]])}
    action = result.actions[0]
    assert mk.animdata.assigned_action(target) == action
    first, last = (int(round(v)) for v in action.frame_range)
    frames = list(range(first, last + 1))
    fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    # The clip alone, as the export holds it: no NLA under it, and the channels it keys none of (scale) at
    # rest, not where the user's own action left them.
    target.animation_data.use_nla = False
    for pose_bone in target.pose.bones:
        pose_bone.matrix_basis = Matrix.Identity(4)
    expected = _blender_joints(target, frames)
    height = _height(target)
    if kind in ("glb", "gltf"):
        got = _gltf_joints(node_js, row["output"], action, frames, fps)
    else:
        got = _reimported_joints(row["output"], kind, frames)
    assert set(expected) <= set(got), sorted(set(expected) - set(got))
    names = sorted(expected)
    errors = np.array([np.linalg.norm(got[n] - expected[n], axis=1) for n in names]) / height
    worst = np.unravel_index(errors.argmax(), errors.shape)
    print(f"\n{kind}: Blender {bpy.app.version_string}: joints median {np.median(errors):.3e}, worst "
          f"{errors.max():.3e} of the height {height:.4f} ({names[worst[0]]}, frame {frames[worst[1]]}; "
          f"{len(frames)} frames)")
    assert errors.max() < JOINT_BOUND[kind], (names[worst[0]], frames[worst[1]])


def test_a_target_that_plays_no_action_is_refused_by_name(mk, target, tmp_path):  # noqa: F811
    """export_clip on an armature with no action: a ValueError naming it, no file, the scene as it was."""
    target.animation_data_create().action = None  # Y Bot's file brings a take of its own
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, 250
    before = _state(target)
    path = tmp_path / "nothing.glb"
    with pytest.raises(ValueError, match=f"'{target.name}' plays no action"):
        mk.batch.export_clip(target, str(path), "glb")
    assert not path.exists() and _state(target) == before

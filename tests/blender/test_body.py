"""The body stage through motionkit.retarget in Blender, judged by Blender's Armature modifier: the target's
forearms and hands stay out of its own body (the winding number of its trunk, head and thighs about the
evaluated vertices, tests/common/body_metrics), and nothing else moves."""
import os

import numpy as np
import pytest

import body_metrics as bm
import mixamo_pairs as mp

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED = os.path.join(os.path.dirname(ROOT), "shared")
DANCE = os.path.join(SHARED, "data", "bodies", "clips", "{}", "Macarena Dance.bvh")


@pytest.fixture()
def bodies_dir(shared_dir):
    if not os.path.isdir(os.path.join(SHARED, "data", "bodies")):
        pytest.fail("../shared/data/bodies is missing")
    return SHARED


def _pose_columns(obj, frames):
    """(frames, bones x 4) every pose bone's matrix_basis rotation as Blender evaluates each frame."""
    import bpy
    out = []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        out.append(np.concatenate([np.array(pb.matrix_basis.to_quaternion()) for pb in obj.pose.bones]))
    return np.array(out)


def test_a_slim_dancer_s_macarena_onto_a_cartoon_mouse_keeps_the_arms_out_of_its_body(mk, bodies_dir):
    """Sporty Granny's Macarena Dance (the hands to the other arm, the head and the hips) onto Mousey (a large
    head, short arms): with the mesh the arms go into the body no more than the source's own on its own mesh
    (every sixth frame: 12.1 % of the arm's vertices, 70 % of the frames deeper than 1 cm: the dance
    touches, and Mixamo's hands sink in), where without it far more (57.6 %, 95 %; with it 2.7 %, 25 %);
    every bone but the arms' is as without the stage."""
    source = mp.import_bvh(DANCE.format("Sporty_Granny"))
    own = mp.import_bvh(DANCE.format("Mousey"))
    frames = np.arange(1, 700, 35)  # 20 frames: the winding numbers of Mousey's 2,300 arm vertices are slow
    plain, body = mp.rest_copy(own, "plain"), mp.rest_copy(own, "body")
    mk.retarget(source, plain, body="off")
    skinned = bm.Skinned.of(body, bodies_dir, "Mousey")
    mk.retarget(source, body)
    plain_skin = bm.Skinned.of(plain, bodies_dir, "Mousey")
    src = bm.measure(bm.Skinned.of(source, bodies_dir, "Sporty_Granny"), frames)
    without, with_body = bm.measure(plain_skin, frames), bm.measure(skinned, frames)
    print(f"inside: source {src.inside.mean():.4f}, without {without.inside.mean():.4f}, "
          f"with {with_body.inside.mean():.4f}; frames > 1 cm: {np.mean(src.deepest > bm.DEEP):.3f}, "
          f"{np.mean(without.deepest > bm.DEEP):.3f}, {np.mean(with_body.deepest > bm.DEEP):.3f}")
    assert without.inside.mean() > src.inside.mean()  # the problem is there to solve
    assert with_body.inside.mean() <= src.inside.mean()
    assert np.mean(with_body.deepest > bm.DEEP) <= np.mean(src.deepest > bm.DEEP)
    arms = {n for n in (b.name for b in body.data.bones)
            if any(n.endswith(":" + j) for j in ("LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm",
                                                   "RightHand"))}
    keep = [k for k, pb in enumerate(body.pose.bones) if pb.name not in arms and not pb.parent or
            pb.name not in arms and not any(p.name in arms for p in pb.parent_recursive)]
    columns = np.concatenate([np.arange(4 * k, 4 * k + 4) for k in keep])
    a, b = _pose_columns(plain, frames), _pose_columns(body, frames)
    # The same keys through Blender's float32 F-curves.
    np.testing.assert_allclose(b[:, columns], a[:, columns], atol=1e-6)


def _arm_poses(obj, frames):
    """(frames, arm bones x 4) the arms' pose rotations as Blender evaluates each frame."""
    columns = [k for k, pb in enumerate(obj.pose.bones) if pb.name.split(":")[-1] in ARM_BONES]
    poses = _pose_columns(obj, frames)
    return poses[:, np.concatenate([np.arange(4 * k, 4 * k + 4) for k in columns])]


ARM_BONES = ("LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm", "RightHand")


def test_the_preview_plays_the_arms_kept_out_and_strength_and_off_change_it(mk, bodies_dir):
    """The Retarget panel's live preview onto Mousey with his mesh plays what motionkit.retarget keys (the
    arms kept out of his body); Strength 0 and Body off play the bones-only retarget, which Blender's
    evaluated mesh shows deeper in the body."""
    import importlib
    import bpy
    ui_preview = importlib.import_module(mk.__name__ + ".ui.preview")
    source = mp.import_bvh(DANCE.format("Sporty_Granny"))
    own = mp.import_bvh(DANCE.format("Mousey"))
    target = mp.rest_copy(own, "previewed")
    skinned = bm.Skinned.of(target, bodies_dir, "Mousey")
    frames = np.array([1, 141, 281, 421])
    keyed = mk.retarget(source, target)
    retargeted = _arm_poses(target, frames)
    off = mk.retarget(source, target, body="off")
    bones_only, bones_only_in = _arm_poses(target, frames), bm.measure(skinned, frames).inside.mean()
    target.animation_data.action = None
    bpy.data.actions.remove(keyed)
    bpy.data.actions.remove(off)
    settings = bpy.context.scene.motionkit_retarget
    settings.source_kind, settings.source, settings.target = 'ARMATURE', source, target
    settings.set_bone_map(mk.retargeting.auto_map(source, target))
    settings.scene_from_clip = False
    try:
        assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'} and settings.preview.message == ""
        # The same keys through Blender's float32 F-curves.
        np.testing.assert_allclose(_arm_poses(target, frames), retargeted, atol=1e-6)
        previewed_in = bm.measure(skinned, frames).inside.mean()
        assert previewed_in < 0.5 * bones_only_in
        for prop, value in (("body_strength", 0.0), ("body", "off")):
            setattr(settings, prop, value)
            ui_preview._tick()  # the timer's look at the settings, called here: no event loop
            np.testing.assert_allclose(_arm_poses(target, frames), bones_only, atol=1e-6)
            settings.property_unset(prop)
        assert bpy.ops.motionkit.retarget_preview_cancel() == {'FINISHED'}
    finally:
        ui_preview.stop(settings)
        settings.pairs.clear()  # the scene's panel as the next tests expect it
        for prop in ("scene_from_clip", "source_kind", "source", "target", "body", "body_strength"):
            settings.property_unset(prop)


def test_a_library_onto_a_character_keeps_its_arms_out_and_its_report_says_so(mk, bodies_dir, tmp_path):
    """motionkit.batch.retarget_library onto Mousey with his mesh keeps his arms out of his body (under half
    the arm vertices inside that a bones-only retarget leaves, by Blender's evaluated mesh), and its
    report's body column says what the stage did; onto the same character without a mesh, that there was
    none."""
    own = mp.import_bvh(DANCE.format("Mousey"))
    target, bare = mp.rest_copy(own, "library"), mp.rest_copy(own, "bare")
    skinned = bm.Skinned.of(target, bodies_dir, "Mousey")
    frames = np.array([1, 141, 281, 421])
    done = mk.batch.retarget_library([DANCE.format("Sporty_Granny")], target, report_dir=str(tmp_path))
    row = done.rows[0]
    assert row["status"] == "ok" and row["body"].startswith("Arms kept out of the body of ")
    assert " on " in row["body"] and "frames" in row["body"]
    target.animation_data.action = done.actions[0]
    batch_in = bm.measure(skinned, frames).inside.mean()
    with_mesh = _arm_poses(target, frames)
    source = mp.import_bvh(DANCE.format("Sporty_Granny"))
    off = mk.retarget(source, target, body="off")
    assert bm.measure(skinned, frames).inside.mean() > 2.0 * batch_in
    assert np.abs(_arm_poses(target, frames) - with_mesh).max() > 1e-2  # the batch's arms were moved
    target.animation_data.action = off
    alone = mk.batch.retarget_library([DANCE.format("Sporty_Granny")], bare)
    assert alone.rows[0]["body"] == ("The target deforms no mesh: its arms were not kept out of its body")
    with open(tmp_path / "report.csv", encoding="utf-8") as f:
        assert "body" in f.readline().split(",")

"""The retarget's live preview: the target plays the retarget from an action of the
preview's own, remade as the panel's settings change, the user's actions untouched; Cancel leaves the scene
as it was, Apply keys the retarget as the Retarget button does. Judged by Blender's evaluation."""
import importlib

import bpy
import numpy as np
import pytest

import characters
import generate


@pytest.fixture()
def panel(mk, walk60):
    """The Retarget panel set up as a user has it: walk60 onto the sample character that walks its own walk."""
    source, _ = mk.bvh.load(walk60)
    target = generate.build_armature(characters.MIXAMO_T)
    generate.add_walk(target, characters.MIXAMO_T, mk.animdata)
    settings = bpy.context.scene.motionkit_retarget
    settings.source_kind, settings.source, settings.target = 'ARMATURE', source, target
    settings.set_bone_map(mk.retargeting.auto_map(source, target))
    settings.scene_from_clip = False
    yield settings
    ui_preview = importlib.import_module(mk.__name__ + ".ui.preview")
    ui_preview.stop(settings)
    for prop in ("parts", "into", "blend", "influence", "root_motion", "scene_from_clip"):  # for the next tests
        settings.property_unset(prop)


def _keys(mk, obj, action):
    out = {}
    for fc in mk.animdata.fcurves(action, obj):
        co = np.empty(2 * len(fc.keyframe_points), dtype=np.float32)
        fc.keyframe_points.foreach_get("co", co)
        out[(fc.data_path, fc.array_index)] = co.tobytes()
    return out


def _pose(obj, frames):
    """(frames, bones, 4, 4) every bone's armature-space matrix, as Blender evaluates it."""
    out = []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        out.append([np.array(b.matrix) for b in obj.pose.bones])
    return np.array(out)


def test_preview_plays_the_retarget_and_cancel_puts_everything_back(mk, panel):
    ui_preview = importlib.import_module(mk.__name__ + ".ui.preview")
    target, walk = panel.target, panel.target.animation_data.action
    actions, keys, frame = set(bpy.data.actions), _keys(mk, target, walk), bpy.context.scene.frame_current
    frames = [1, 40, 90]
    walking = _pose(target, frames)
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'}
    shown = panel.preview.action
    assert target.animation_data.action == shown and shown not in actions and _keys(mk, target, walk) == keys
    shown_pointer = shown.as_pointer()
    previewed = _pose(target, frames)
    # The preview's pose is the retarget's: the same plan keyed into a copy by the public call.
    copy = target.copy()
    copy.data = target.data.copy()
    copy.animation_data_clear()
    bpy.context.scene.collection.objects.link(copy)
    made = mk.retarget(panel.source, copy, panel.bone_map(), options=panel.retarget_options())
    assert np.abs(_pose(copy, frames) - previewed).max() < 1e-6  # float32 matrices, the same keys
    bpy.data.objects.remove(copy)
    bpy.data.actions.remove(made)
    # A change of an option remakes it (the timer's look at the settings, called here: no event loop).
    panel.root_motion = "in_place"
    ui_preview._tick()
    assert panel.preview.action.as_pointer() != shown_pointer  # the first preview removed, a new one made
    assert np.abs(_pose(target, frames) - previewed).max() > 1e-3
    assert bpy.ops.motionkit.retarget_preview_cancel() == {'FINISHED'}
    assert target.animation_data.action == walk and set(bpy.data.actions) == actions
    assert _keys(mk, target, walk) == keys and np.array_equal(_pose(target, frames), walking)
    bpy.context.scene.frame_set(frame)


def test_apply_keys_what_was_previewed(mk, panel):
    target, walk = panel.target, panel.target.animation_data.action
    frames = [1, 60]
    panel.parts = "arms"
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'}
    previewed = _pose(target, frames)
    assert not bpy.ops.motionkit.retarget.poll()  # Retarget waits for Apply or Cancel
    assert bpy.ops.motionkit.retarget_preview_apply() == {'FINISHED'}
    applied = target.animation_data.action
    assert applied not in (walk, None) and not panel.preview.on and walk.use_fake_user
    assert "MotionKit Preview" not in bpy.data.actions
    assert np.abs(_pose(target, frames) - previewed).max() < 1e-6


def test_a_preview_that_fails_says_why_and_keeps_the_last(mk, panel):
    ui_preview = importlib.import_module(mk.__name__ + ".ui.preview")
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'}
    shown = panel.preview.action
    panel.pairs[0].target = "no such bone"
    ui_preview._tick()
    assert "no such bone" in panel.preview.message and panel.target.animation_data.action == shown


def test_cancel_puts_back_a_target_without_an_action_and_its_object(mk, panel):
    """A target that plays nothing keeps no keys to put its pose back: Cancel does, and the object's own
    transform after a preview that keyed the object (root motion onto the object)."""
    target = panel.target
    target.animation_data.action = None
    for bone in target.pose.bones:  # a pose the animator left, not the rest
        bone.rotation_quaternion = (0.9, 0.1, 0.3, -0.2)
    target.location = (0.4, -0.3, 0.0)
    bpy.context.view_layer.update()
    frames = [1, 30]
    before, matrix = _pose(target, frames), target.matrix_world.copy()
    panel.root_motion_onto = "object"
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'} and panel.preview.message == ""
    assert np.abs(_pose(target, frames) - before).max() > 1e-3
    assert bpy.ops.motionkit.retarget_preview_cancel() == {'FINISHED'}
    assert target.animation_data.action is None
    assert np.array_equal(_pose(target, frames), before) and target.matrix_world == matrix
    panel.property_unset("root_motion_onto")


def test_a_retarget_into_an_nla_track_is_previewed_blended(mk, panel):
    """The arms into an NLA track that adds at half influence over the target's own walk: the preview plays
    the blend, as Blender plays the track that Apply then makes (its evaluation, both); not the arms
    replaced as a new action would show them; Cancel removes the preview's tracks, the walk plays again."""
    target, walk = panel.target, panel.target.animation_data.action
    frames = [1, 40, 90]
    walking = _pose(target, frames)
    panel.parts = "arms"
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'}
    replaced = _pose(target, frames)
    assert bpy.ops.motionkit.retarget_preview_cancel() == {'FINISHED'}
    panel.into, panel.blend, panel.influence = "nla", "add", 0.5
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'} and panel.preview.message == ""
    blended = _pose(target, frames)
    assert np.abs(blended - replaced).max() > 1e-2 and np.abs(blended - walking).max() > 1e-2
    assert bpy.ops.motionkit.retarget_preview_cancel() == {'FINISHED'}
    anim = target.animation_data
    assert anim.action == walk and len(anim.nla_tracks) == 0 and "MotionKit Preview" not in bpy.data.actions
    assert np.array_equal(_pose(target, frames), walking)
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'}
    assert bpy.ops.motionkit.retarget_preview_apply() == {'FINISHED'}
    assert [t.name for t in anim.nla_tracks if t.name.startswith("MotionKit Preview")] == []
    assert np.abs(_pose(target, frames) - blended).max() < 1e-6  # float32 matrices of the same keys

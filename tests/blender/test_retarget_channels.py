"""Every channel: bone scale (squash and stretch), custom properties and ARKit-named
shape keys carried by name, with a map for names that differ, judged by Blender's evaluation of the source
and of the target on every frame of the clip. No real file has them all: the source is the sample Mixamo
character walking (blend_samples), given Bezier keys every few frames on its spine's and arm's scale, a
property of its spine bone and of its object, and the shape keys of a face mesh it deforms; the target, the
sample Rigify character, has some of them: one shape key and one property missing, one property named
differently (mapped)."""
import importlib

import bpy
import numpy as np
import pytest

import characters
import generate

SOURCE, TARGET = characters.MIXAMO_T, characters.RIGIFY_A
SRC, TGT = SOURCE.canonical, TARGET.canonical
SHAPES = ("jawOpen", "eyeBlinkLeft", "mouthSmileLeft", "tongueOut")  # ARKit names; the target lacks tongueOut
SCALED = ("spine.1", "upper_arm.L")

# Each carried value is the source's F-curve evaluated on the frame, stored as a float32 key on that frame
# and played back as it is (a key on every frame): what Blender evaluates on the source (float32 arithmetic
# through a Bezier segment) and what it plays on the target can differ by the float32 rounding of the
# evaluation, a few units of the last place of a float32 of the value's size (2^-23 relative, 2^-23 absolute
# below 1: the keys' Bezier segments span values of about 1). Measured at most 1.5 units (3.4, 4.3, 5.2);
# four allowed, below which a float32 rounding cannot hide a wrong value (every value scaled by 1 + 4 units
# measures 5.35 and fails).
FLOAT32_UNITS = 4


def _bezier(animdata, id_data, action, paths_values, frames):
    """Bezier keys (Blender's automatic handles) on frames for each (data path, index): values (frames,)."""
    channels = [c for c, _ in paths_values]
    animdata.write_keys(id_data, action, channels, frames, np.array([v for _, v in paths_values]),
                        interpolation='BEZIER')


def _face(name, armature, shapes, x=0.0):
    """A mesh deformed by armature (an Armature modifier, parented to it) with a Basis and shapes."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(x, 0, 1.6), (x + 0.1, 0, 1.6), (x, 0, 1.7)], [], [(0, 1, 2)])
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    obj.parent = armature
    obj.modifiers.new("Armature", 'ARMATURE').object = armature
    obj.shape_key_add(name="Basis")
    for shape in shapes:
        obj.shape_key_add(name=shape, from_mix=False)
    return obj


@pytest.fixture()
def rigs(mk, animdata):
    """(source, target, source face, target faces): the source's extra channels keyed, the target's places."""
    source = generate.build_armature(SOURCE)
    generate.add_walk(source, SOURCE, animdata)
    action = source.animation_data.action
    frames = animdata.read_keys(animdata.fcurves(action, source)[0])[0].astype(np.float64)
    sparse = frames[::5]
    t = (sparse - sparse[0]) / (sparse[-1] - sparse[0])
    wave = np.sin(2 * np.pi * 2 * t)
    keyed = []
    for k, canonical in enumerate(SCALED):  # squash and stretch: volume kept
        path = f'pose.bones["{SRC[canonical]}"].scale'
        stretch = 1.0 + (0.25 - 0.1 * k) * wave
        keyed += [((path, 0), 1 / np.sqrt(stretch)), ((path, 1), stretch), ((path, 2), 1 / np.sqrt(stretch))]
    # A unit scale as Blender's FBX importer keys it (1 - 6e-8): nothing to carry into a new action.
    keyed += [((f'pose.bones["{SRC["head"]}"].scale', i), np.full(len(sparse), 1 - 2.0 ** -24)) for i in range(3)]
    spine, arm, foot = SRC["spine.1"], SRC["upper_arm.L"], SRC["foot.L"]
    for bone, prop in ((spine, "squash"), (arm, "ik_fk"), (foot, "motionkit_contact_heel")):
        source.pose.bones[bone][prop] = 0.0
    for prop in ("blink", "mood", "smile"):
        source[prop] = 0.0
    keyed += [((f'pose.bones["{spine}"]["squash"]', 0), 0.5 + 0.4 * wave),
              ((f'pose.bones["{arm}"]["ik_fk"]', 0), t),
              ((f'pose.bones["{foot}"]["motionkit_contact_heel"]', 0), (wave > 0).astype(float)),
              (('["blink"]', 0), 0.5 - 0.5 * np.cos(6 * np.pi * t)), (('["mood"]', 0), 3 * t),
              (('["smile"]', 0), -2.0 + 4.0 * t * t)]
    _bezier(animdata, source, action, keyed, sparse)
    face = _face("SourceFace", source, SHAPES)
    key = face.data.shape_keys
    face_action = animdata.new_action("SourceFace")
    _bezier(animdata, key, face_action, [((f'key_blocks["{s}"].value', 0), 0.5 + 0.45 * np.sin(
        2 * np.pi * (j + 1) * t + j)) for j, s in enumerate(SHAPES)], sparse)
    animdata.assign(key, face_action)

    target = generate.build_armature(TARGET, x=2.0)
    target.pose.bones[TGT["spine.1"]]["squash"] = 0.0
    target.pose.bones[TGT["foot.L"]]["motionkit_contact_heel"] = 0.25
    target["blink"] = 0.0
    target["grin"] = 0.0  # the source's "smile", mapped; no "mood", no "ik_fk"
    # The source animates no cheekPuff: the target's own keys of it stay.
    faces = (_face("TargetFace", target, SHAPES[:3] + ("cheekPuff",), x=2.0),
             _face("TargetTeeth", target, ("jawOpen",), x=2.0))
    return source, target, face, faces


def _bone_map():
    return [(SRC[c], TGT[c]) for c in SRC if c in TGT]


def _evaluated(obj, face_objects, frames, bones, props, shapes):
    """(frames, values) of each bone's scale, each (bone or "", property) and each (mesh, shape) as Blender
    evaluates them on each frame."""
    out = []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        row = [v for b in bones for v in obj.pose.bones[b].scale]
        row += [float(obj.pose.bones[b][p] if b else obj[p]) for b, p in props]
        row += [float(face_objects[m].data.shape_keys.key_blocks[s].value) for m, s in shapes]
        out.append(row)
    return np.array(out)


def _frames(animdata, obj):
    return animdata.read_keys(animdata.fcurves(obj.animation_data.action, obj)[0])[0].astype(np.float64)


def _judge(animdata, source, target, face, faces, frames):
    """The worst difference between the target's evaluated channels and the source's, every frame."""
    expected = _evaluated(source, {"face": face}, frames, [SRC[c] for c in SCALED],
                          [(SRC["spine.1"], "squash"), ("", "blink"), ("", "smile")],
                          [("face", s) for s in SHAPES[:3]] + [("face", "jawOpen")])
    got = _evaluated(target, {"face": faces[0], "teeth": faces[1]}, frames, [TGT[c] for c in SCALED],
                     [(TGT["spine.1"], "squash"), ("", "blink"), ("", "grin")],
                     [("face", s) for s in SHAPES[:3]] + [("teeth", "jawOpen")])
    assert np.ptp(expected, axis=0).min() > 0.1  # every channel moves: a channel left at rest would show
    return _units(got, expected)


def _units(got, expected):
    """The worst difference in units of the last place of a float32 of the value's size (at least 1)."""
    return float((np.abs(got - expected) / (2.0 ** -23 * np.maximum(1.0, np.abs(expected)))).max())


def test_scale_properties_and_shape_keys_are_carried_by_name_and_map(mk, animdata, rigs):
    source, target, face, faces = rigs
    frames = _frames(animdata, source)
    made = mk.retargeting.retarget_clip(source, target, _bone_map(), plant_feet=False, channel_map={"smile": "grin"})
    action = made.action
    assert target.animation_data.action == action
    worst = _judge(animdata, source, target, face, faces, frames)
    print(f"\nscale, properties and shape keys on {len(frames)} frames: worst {worst:.2f} float32 units from "
          f"the source's")
    assert worst <= FLOAT32_UNITS
    _check_left_out(made, animdata, target, action, faces)


def _check_left_out(made, animdata, target, action, faces):
    """What the target lacks is not written, and the report names it; MotionKit's contacts are not carried."""
    left = {(item.kind, item.name) for item in made.channels_left_out}
    assert left == {("property", '["mood"]'), ("property", f'{SRC["upper_arm.L"]}["ik_fk"]'),
                    ("shape_key", "tongueOut")}
    paths = {fc.data_path for fc in animdata.fcurves(action, target)}
    assert not {p for p in paths if "mood" in p or "ik_fk" in p or "motionkit_contact" in p}
    assert f'pose.bones["{TGT["head"]}"].scale' not in paths  # a unit scale carries nothing
    assert "mood" not in target.keys() and "ik_fk" not in target.pose.bones[TGT["upper_arm.L"]].keys()
    assert target.pose.bones[TGT["foot.L"]]["motionkit_contact_heel"] == 0.25
    for mesh in faces:
        key = mesh.data.shape_keys
        written = {fc.data_path for fc in animdata.fcurves(key.animation_data.action, key)}
        assert written == {f'key_blocks["{s}"].value' for s in SHAPES[:3] if s in key.key_blocks}


def test_into_current_keeps_the_targets_other_keys_and_none_carries_nothing(mk, animdata, rigs):
    """into='current': the target Key's own curves not carried keep every key; channels=() writes none."""
    source, target, face, faces = rigs
    frames = _frames(animdata, source)
    key = faces[0].data.shape_keys
    own = animdata.new_action("TargetFace own")
    outside = np.array([frames[0] - 20, frames[0] - 10, frames[-1] + 10])
    _bezier(animdata, key, own, [(('key_blocks["eyeBlinkLeft"].value', 0), np.array([0.1, 0.9, 0.3])),
                                 (('key_blocks["mouthSmileLeft"].value', 0), np.array([0.2, 0.4, 0.6])),
                                 (('key_blocks["cheekPuff"].value', 0), np.array([0.0, 0.7, 0.1]))], outside)
    puff = animdata.read_keys(animdata.find_fcurve(own, key, 'key_blocks["cheekPuff"].value'))
    animdata.assign(key, own)
    walk = mk.retarget(source, target, _bone_map(), plant_feet=False, channels=())
    assert all(fc.data_path.endswith(("rotation_quaternion", "rotation_euler", "location"))
               for fc in animdata.fcurves(walk, target))
    assert key.animation_data.action == own and faces[1].data.shape_keys.animation_data is None
    smile = animdata.read_keys(animdata.find_fcurve(own, key, 'key_blocks["mouthSmileLeft"].value'))
    head = f'pose.bones["{TGT["head"]}"].scale'  # the target's own scale keys: the source's unit scale replaces them
    animdata.write_keys(target, walk, [(head, i) for i in range(3)], frames[[0, -1]], np.full((3, 2), 1.5))
    mk.retarget(source, target, _bone_map(), plant_feet=False, into="current", channel_map={"smile": "grin"},
                channels=("shape_keys", "scale"))
    bpy.context.scene.frame_set(int(frames[len(frames) // 2]))
    assert tuple(target.pose.bones[TGT["head"]].scale) == (1 - 2.0 ** -24,) * 3
    assert key.animation_data.action == own
    blink = animdata.read_keys(animdata.find_fcurve(own, key, 'key_blocks["eyeBlinkLeft"].value'))
    assert blink[0][:2].tolist() == outside[:2].tolist() and blink[0][-1] == outside[-1]  # kept about the clip
    assert len(blink[0]) == len(frames) + 3
    kept = animdata.read_keys(animdata.find_fcurve(own, key, 'key_blocks["mouthSmileLeft"].value'))
    assert len(kept[0]) == len(frames) + 3 and kept[1][:2].tolist() == smile[1][:2].tolist()
    worst = _judge_shapes(source, face, faces, frames)
    print(f"\nshape keys merged into the target's own: worst {worst:.2f} float32 units from the source's")
    assert worst <= FLOAT32_UNITS
    # A part of the body into a new action: each Key's a copy of its own, the shapes not carried kept.
    mk.retarget(source, target, _bone_map(), plant_feet=False, parts="arms", channels=("shape_keys",))
    copy = key.animation_data.action
    assert copy != own and own.use_fake_user
    kept = animdata.read_keys(animdata.find_fcurve(copy, key, 'key_blocks["cheekPuff"].value'))
    assert all(np.array_equal(a, b) for a, b in zip(kept, puff))
    blink = animdata.read_keys(animdata.find_fcurve(copy, key, 'key_blocks["eyeBlinkLeft"].value'))
    assert blink[0].tolist() == frames.tolist()  # a carried shape's curve is the clip's, whole
    assert _judge_shapes(source, face, faces, frames) <= FLOAT32_UNITS
    # overwrite: into the Key's own action, as into the armature's.
    mk.retarget(source, target, _bone_map(), plant_feet=False, overwrite=True, channels=("shape_keys",))
    assert key.animation_data.action == copy and _judge_shapes(source, face, faces, frames) <= FLOAT32_UNITS


def _judge_shapes(source, face, faces, frames):
    got, expected = [], []
    for frame in frames:
        bpy.context.scene.frame_set(int(frame))
        expected.append([face.data.shape_keys.key_blocks[s].value for s in SHAPES[:3]])
        got.append([faces[0].data.shape_keys.key_blocks[s].value for s in SHAPES[:3]])
    return _units(np.array(got), np.array(expected))


@pytest.mark.parametrize("bad,message", [
    (dict(channels=("scale", "rotation")), r"unknown channel 'rotation'"),
    (dict(channels="shape_keys"), r"channels must be a list of"),
    (dict(channel_map={"smile": ""}), r"channel_map: 'smile': '' is not a pair"),
])
def test_a_bad_option_changes_nothing(mk, animdata, rigs, bad, message):
    source, target, _, faces = rigs
    actions = set(bpy.data.actions)
    with pytest.raises(ValueError, match=message):
        mk.retarget(source, target, _bone_map(), plant_feet=False, **bad)
    assert set(bpy.data.actions) == actions
    assert target.animation_data is None or target.animation_data.action is None
    assert all(m.data.shape_keys.animation_data is None for m in faces)


def test_nla_track_and_a_part_of_the_body(mk, animdata, rigs):
    """into='nla': the shapes' keys on a track of each target Key, played as the source's; parts='arms': the
    arm's scale carried, the spine's scale and property not (the spine is not written), the faces still."""
    source, target, face, faces = rigs
    frames = _frames(animdata, source)
    mk.retarget(source, target, _bone_map(), plant_feet=False, into="nla", channel_map={"smile": "grin"})
    for mesh in faces:
        anim = mesh.data.shape_keys.animation_data
        assert anim.action is None and len(anim.nla_tracks) == 1
        if animdata.LAYERED:  # the Key's own slot in the new action
            strip = anim.nla_tracks[0].strips[0]
            assert strip.action_slot is not None and strip.action_slot.target_id_type == 'KEY'
    worst = _judge(animdata, source, target, face, faces, frames)
    print(f"\nonto NLA tracks: worst {worst:.2f} float32 units from the source's")
    assert worst <= FLOAT32_UNITS

    again = generate.build_armature(TARGET, x=4.0)
    again.pose.bones[TGT["spine.1"]]["squash"] = 0.0
    made = mk.retargeting.retarget_clip(source, again, _bone_map(), plant_feet=False, parts="arms")
    action = made.action
    paths = {fc.data_path for fc in animdata.fcurves(action, again)}
    arm, spine = (f'pose.bones["{TGT[c]}"]' for c in SCALED[::-1])
    assert f"{arm}.scale" in paths and f"{spine}.scale" not in paths and f'{spine}["squash"]' not in paths
    left = {item.name: item.reason for item in made.channels_left_out}
    assert set(left) == {'["mood"]', '["smile"]', '["blink"]', f'{SRC["upper_arm.L"]}["ik_fk"]', *SHAPES}
    assert left["jawOpen"] == f"the target '{again.name}' has no mesh with shape keys"


def test_the_operator_tells_which_channels_were_not_carried(mk, animdata, rigs, capfd):
    """The panel has no channel map: the source's "smile" is not carried either, and the report says so."""
    source, target, _, _ = rigs
    settings = bpy.context.scene.motionkit_retarget
    settings.source_kind, settings.source, settings.target = 'ARMATURE', source, target
    settings.set_bone_map(_bone_map())
    plant_feet, settings.plant_feet = settings.plant_feet, False
    try:
        assert bpy.ops.motionkit.retarget() == {'FINISHED'}
    finally:
        settings.plant_feet, settings.source, settings.target = plant_feet, None, None
        settings.pairs.clear()
    said = capfd.readouterr()
    said = said.out + said.err
    assert "4 channels not carried" in said, said
    for name in ('["mood"]', '["smile"] (the target', f'{SRC["upper_arm.L"]}["ik_fk"]', "tongueOut (no mesh"):
        assert name in said


def test_a_control_rig_target_takes_the_objects_channels_and_reports_the_bones(mk, animdata, shared_dir,
                                                                                 tmp_path):
    """Its controls are keyed, and none takes a deform bone's scale or property yet: nothing of them is
    written, and each is reported. The object's own properties and the faces' shape keys are no control's:
    they are carried as onto any armature, judged by Blender's evaluation. The hand-made control rig of
    test_control_rigs, on walk60's skeleton."""
    import json
    from test_control_rigs import _hand_made_rig

    walk, action = mk.bvh.load(f"{shared_dir}/data/bvh/walk60.bvh")
    target, data = _hand_made_rig(walk)
    bone = walk.data.bones[1].name
    frames = _frames(animdata, walk)[::10]
    animdata.write_keys(walk, action, [(f'pose.bones["{bone}"].scale', i) for i in range(3)], frames,
                        np.tile(1.0 + 0.2 * np.sin(frames), (3, 1)))
    walk["mood"] = target["mood"] = 0.0
    walk.update_tag()  # Blender's evaluated copy of walk, made before, takes the new property only so
    t = (frames - frames[0]) / (frames[-1] - frames[0])
    _bezier(animdata, walk, action, [(('["mood"]', 0), 3 * t)], frames)
    face, faces = _face("SourceFace", walk, SHAPES[:1]), (_face("TargetFace", target, SHAPES[:1]),)
    face_action = animdata.new_action("SourceFace")
    _bezier(animdata, face.data.shape_keys, face_action, [((f'key_blocks["{SHAPES[0]}"].value', 0),
                                                          0.5 + 0.45 * np.sin(2 * np.pi * t))], frames)
    animdata.assign(face.data.shape_keys, face_action)
    map_file = tmp_path / "handmade.json"
    map_file.write_text(json.dumps(data), encoding="utf-8")
    retargeted = mk.retargeting.retarget_clip(walk, target, control_map=str(map_file), plant_feet=False,
                                              floor_fit="hips")
    assert not [fc for fc in animdata.fcurves(retargeted.action, target) if fc.data_path.endswith(".scale")]
    left = retargeted.channels_left_out
    assert [(item.kind, item.name) for item in left] == [("scale", f'pose.bones["{bone}"].scale[{i}]')
                                                        for i in range(3)]
    assert all(item.reason.startswith("the target is a control rig") for item in left)
    played = frames[::2]
    expected = _evaluated(walk, {"face": face}, played, [], [("", "mood")], [("face", SHAPES[0])])
    got = _evaluated(target, {"face": faces[0]}, played, [], [("", "mood")], [("face", SHAPES[0])])
    assert np.ptp(expected, axis=0).min() > 0.1
    assert _units(got, expected) <= FLOAT32_UNITS


@pytest.fixture()
def panel(rigs):
    """The Retarget panel set to the rigs, feet not planted (the walk's feet are not what is judged); put back
    afterwards for the next tests."""
    source, target, _, _ = rigs
    settings = bpy.context.scene.motionkit_retarget
    settings.source_kind, settings.source, settings.target = 'ARMATURE', source, target
    settings.set_bone_map(_bone_map())
    settings.plant_feet, settings.scene_from_clip = False, False
    yield settings
    for prop in ("plant_feet", "scene_from_clip", "channels", "source", "target"):
        settings.property_unset(prop)
    settings.pairs.clear()
    settings.channel_pairs.clear()


def _name_pair(settings, source_name, target_name):
    assert bpy.ops.motionkit.channel_map_add() == {'FINISHED'}
    pair = settings.channel_pairs[settings.active_channel_pair]
    pair.source, pair.target = source_name, target_name


def test_the_panels_channel_map_reaches_the_preview_and_the_retarget(mk, animdata, rigs, panel):
    """A name pair added in the panel's channel map (smile -> grin, and an empty row just added) carries the
    source's "smile" onto the target's "grin", in the live preview (with the scale and the shape keys, each
    target mesh's Key playing a preview action of its own; Cancel leaves every Key as it was) and in the keys
    Retarget writes."""
    source, target, face, faces = rigs
    frames = _frames(animdata, source)
    _name_pair(panel, "smile", "grin")
    _name_pair(panel, "", "")
    actions = set(bpy.data.actions)
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'} and panel.preview.message == ""
    previewed = _judge(animdata, source, target, face, faces, frames)
    assert bpy.ops.motionkit.retarget_preview_cancel() == {'FINISHED'}
    assert set(bpy.data.actions) == actions and all(m.data.shape_keys.animation_data is None for m in faces)
    assert bpy.ops.motionkit.retarget() == {'FINISHED'}
    worst = _judge(animdata, source, target, face, faces, frames)
    print(f"\nthe panel's channel map: worst {previewed:.2f} float32 units previewed, {worst:.2f} keyed")
    assert previewed <= FLOAT32_UNITS and worst <= FLOAT32_UNITS
    made = mk.retargeting.retarget_clip(source, target, _bone_map(), None, panel.retarget_options())
    assert '["smile"]' not in {item.name for item in made.channels_left_out}  # mapped: not said left out


def test_the_channel_map_buttons_say_why_they_wait_and_a_half_row_changes_nothing(mk, rigs, panel, capfd):
    """Without Properties or Shape Keys carried the map's buttons are greyed, saying why; a row with one
    name stops Retarget before anything is written, naming the row, and the preview says the same."""
    source, target, _, _ = rigs
    _name_pair(panel, "smile", "grin")
    assert bpy.ops.motionkit.channel_map_remove.poll()
    panel.channels = {"scale"}
    assert not bpy.ops.motionkit.channel_map_add.poll() and not bpy.ops.motionkit.channel_map_remove.poll()
    assert panel.retarget_options().channel_map is None  # the hidden map renames nothing
    panel.property_unset("channels")
    _name_pair(panel, "mood", "")
    actions = set(bpy.data.actions)
    with pytest.raises(RuntimeError, match=r"Channel map, row 2: give both a source and a target name"):
        bpy.ops.motionkit.retarget()
    assert set(bpy.data.actions) == actions and target.animation_data is None
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'}
    assert panel.preview.message.startswith("Channel map, row 2")
    assert bpy.ops.motionkit.retarget_preview_cancel() == {'FINISHED'}
    panel.channel_pairs[1].target = "mood_target"
    panel.channel_pairs[1].source = "smile"
    with pytest.raises(RuntimeError, match=r"row 2: 'smile' is mapped twice"):
        bpy.ops.motionkit.retarget()
    assert set(bpy.data.actions) == actions


def test_the_preview_plays_shape_keys_over_a_keys_own_action_and_cancel_gives_it_back(mk, animdata, rigs, panel):
    """The target's face plays its own action (cheekPuff, which the source lacks, and eyeBlinkLeft): a preview
    of the arms plays a copy of it with the carried shapes replaced, its cheekPuff as it was; Cancel gives the
    Key its own action back, every key as it was; nothing of the preview is left."""
    source, target, face, faces = rigs
    frames = _frames(animdata, source)
    key = faces[0].data.shape_keys
    own = animdata.new_action("TargetFace own")
    _bezier(animdata, key, own, [(('key_blocks["cheekPuff"].value', 0), np.array([0.0, 0.7, 0.1])),
                                 (('key_blocks["eyeBlinkLeft"].value', 0), np.array([0.1, 0.9, 0.3]))],
            frames[[0, len(frames) // 2, -1]])
    animdata.assign(key, own)
    kept = {fc.data_path: animdata.read_keys(fc) for fc in animdata.fcurves(own, key)}
    puff = [(bpy.context.scene.frame_set(int(f)), key.key_blocks["cheekPuff"].value)[1] for f in frames]
    actions = set(bpy.data.actions)
    panel.parts = "arms"
    try:
        assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'} and panel.preview.message == ""
        shown = key.animation_data.action
        assert shown not in actions and own.users == 1  # the Key's own action kept: the preview holds it
        worst = _judge_shapes(source, face, faces, frames)
        puffed = [(bpy.context.scene.frame_set(int(f)), key.key_blocks["cheekPuff"].value)[1] for f in frames]
        assert bpy.ops.motionkit.retarget_preview_cancel() == {'FINISHED'}
    finally:
        panel.property_unset("parts")
    print(f"\nshape keys previewed over the Key's own action: worst {worst:.2f} float32 units")
    assert worst <= FLOAT32_UNITS and puffed == puff
    assert key.animation_data.action == own and set(bpy.data.actions) == actions
    assert all(np.array_equal(a, b) for fc in animdata.fcurves(own, key) for a, b in zip(animdata.read_keys(fc),
                                                                                       kept[fc.data_path]))
    # A file saved mid-preview and opened again keeps no Held: the Key's own action is found on its preview.
    ui_preview = importlib.import_module(mk.__name__ + ".ui.preview")
    assert bpy.ops.motionkit.retarget_preview() == {'FINISHED'} and key.animation_data.action != own
    ui_preview._SHOWN["held"] = None
    ui_preview.stop(panel)
    assert key.animation_data.action == own and set(bpy.data.actions) == actions

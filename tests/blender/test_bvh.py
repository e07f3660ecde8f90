"""BVH import and export in Blender, against a numpy FK reference (tests/common/bvh_reference.py),
Blender's own evaluation and (on 4.3 and 5.2) Blender's own BVH importer."""
import os

import bpy
import bvh_cases
import bvh_reference
import numpy as np
import pytest
import shared_data
from bpy_extras.io_utils import axis_conversion

import conftest

CASES = bvh_cases.cases()
BUILTIN = bpy.app.version >= (4, 2, 0)  # 3.4's bundled importer cannot open files under Python 3.11
needs_builtin = pytest.mark.skipif(not BUILTIN, reason="Blender 3.4's own BVH importer is broken "
                                                       "under Python 3.11 (open(..., 'rU'))")


def write_case(tmp_path, name, text):
    path = tmp_path / f"{name}.bvh"
    path.write_bytes(text.encode())
    return str(path)


def shared_files(shared_dir):
    return shared_data.bvh_files(os.path.join(shared_dir, "data", "bvh"))


def reference_world(native, path, axis_forward='-Z', axis_up='Y', scale=1.0):
    """World joint positions (frames, joints, 3) from the FK reference, in Blender's frame."""
    skeleton, motion = native.read_bvh(path)
    positions, _ = bvh_reference.forward_kinematics(skeleton, motion.values)
    conv = np.array(axis_conversion(from_forward=axis_forward, from_up=axis_up)) * scale
    return skeleton, positions @ conv.T


def height(world):
    return float(np.ptp(world[0, :, 2])) or 1.0


def blender_heads(obj, names, frames, frame_start=1):
    """World heads of the named bones on each frame, as Blender's depsgraph poses them."""
    out = np.empty((len(frames), len(names), 3))
    matrix = np.array(obj.matrix_world)
    for f, frame in enumerate(frames):
        bpy.context.scene.frame_set(frame_start + frame)
        for j, name in enumerate(names):
            head = np.append(obj.pose.bones[name].head, 1.0)
            out[f, j] = (matrix @ head)[:3]
    return out


def check_import_against_fk(mk, native, path, **options):
    obj, action = mk.bvh.load(path, mk.bvh.ImportOptions(**options))
    skeleton, world = reference_world(native, path, options.get("axis_forward", '-Z'),
                                   options.get("axis_up", 'Y'), options.get("scale", 1.0))
    joints = [j for j, end in enumerate(skeleton.end_sites) if not end]
    names = [skeleton.names[j] for j in joints]
    frames = range(world.shape[0])
    got = blender_heads(obj, names, frames)
    tolerance = 1e-5 * height(world)
    np.testing.assert_allclose(got, world[:, joints], atol=tolerance, err_msg=path)
    # End sites are where their bones' tails are.
    ends = [j for j, end in enumerate(skeleton.end_sites) if end]
    parents = skeleton.parents
    for f in (0, world.shape[0] - 1):
        bpy.context.scene.frame_set(1 + f)
        for j in ends:
            bone = skeleton.names[parents[j]]
            tail = np.array(obj.matrix_world @ obj.pose.bones[bone].tail)
            np.testing.assert_allclose(tail, world[f, j], atol=tolerance)
    return obj, action


@pytest.mark.parametrize("name, text", CASES, ids=[c[0] for c in CASES])
def test_import_poses_every_layout_as_native_fk(mk, native, tmp_path, name, text):
    check_import_against_fk(mk, native, write_case(tmp_path, name, text))


def test_import_of_the_real_files_matches_native_fk(mk, native, shared_dir):
    for path in shared_files(shared_dir):
        conftest.clear_scene()
        check_import_against_fk(mk, native, path)


@pytest.mark.parametrize("mode", ['NATIVE', 'XYZ', 'ZXY'])
def test_euler_import_is_exact_and_continuous(mk, native, shared_dir, mode):
    path = os.path.join(shared_dir, "data", "bvh", "walk60.bvh")
    obj, action = check_import_against_fk(mk, native, path, rotation_mode=mode)
    curves = [fc for fc in mk.animdata.fcurves(action, obj) if fc.data_path.endswith("rotation_euler")]
    assert curves
    steps = {fc.data_path + f"[{fc.array_index}]": float(np.max(np.abs(np.diff(mk.animdata.read_keys(fc)[1]))))
             for fc in curves}
    print(f"\n{mode}: largest step of an Euler channel between frames {max(steps.values()):.4f} rad")
    # A branch flip moves a channel by about pi or 2 pi; walk60's joints turn by far less a frame.
    assert max(steps.values()) < 0.5, max(steps, key=steps.get)


def test_options_scale_axes_and_frames(mk, native, tmp_path):
    path = write_case(tmp_path, *CASES[0])
    check_import_against_fk(mk, native, path, scale=2.0, axis_forward='Y', axis_up='Z')
    conftest.clear_scene()
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 24, 1.0
    obj, action = mk.bvh.load(path, frame_start=10, update_scene_fps=True, update_scene_duration=True)
    assert tuple(action.frame_range) == (10.0, 33.0)
    assert scene.render.fps == 30 and scene.frame_end >= 33


def test_bones_have_sensible_tails_and_rolls(mk, shared_dir):
    obj, _ = mk.bvh.load(os.path.join(shared_dir, "data", "bvh", "walk60.bvh"))
    bones = obj.data.bones
    # The root points up the spine, not down a leg; the chest up the neck.
    assert bones["RootJoint"].tail_local.z > bones["RootJoint"].head_local.z + 0.05
    assert bones["RootJoint"].tail_local == bones["pelvis_lowerback"].head_local
    assert bones["lowerback_torso"].tail_local == bones["torso_head"].head_local
    # End sites set the tails of the limbs.
    assert (bones["lWrist"].tail_local - bones["lWrist"].head_local).length == pytest.approx(0.116380, abs=1e-5)
    assert all(b.length > 1e-3 for b in bones)


def builtin_import(path):
    before = set(bpy.data.objects)
    assert bpy.ops.import_anim.bvh(filepath=path) == {'FINISHED'}
    (obj,) = [o for o in bpy.data.objects if o not in before and o.type == 'ARMATURE']
    return obj


@needs_builtin
def test_import_equals_blenders_own_importer(mk, native, tmp_path, shared_dir):
    paths = shared_files(shared_dir) + [write_case(tmp_path, n, t) for n, t in CASES
                                        if bvh_cases.comparable_with_blender(n)]
    for path in paths:
        conftest.clear_scene()
        ours, _ = mk.bvh.load(path)
        theirs = builtin_import(path)
        names = [b.name for b in ours.data.bones]
        skeleton, world = reference_world(native, path)
        frames = range(world.shape[0])
        np.testing.assert_allclose(blender_heads(ours, names, frames),
                                   blender_heads(theirs, names, frames),
                                   atol=1e-5 * height(world), err_msg=path)


def export_and_compare(mk, source, path, importer):
    """Exports source, imports the file with importer, compares world heads on every frame."""
    scene = bpy.context.scene
    action = mk.animdata.assigned_action(source)
    start, end = (int(round(x)) for x in action.frame_range)
    mk.bvh.save(source, path, frame_range=(start, end))
    names = [b.name for b in source.data.bones]
    frames = range(end - start + 1)
    want = blender_heads(source, names, frames, frame_start=start)
    scene.frame_set(start)
    copy = importer(path)
    got = blender_heads(copy, names, frames, frame_start=1)
    span = np.ptp(want.reshape(-1, 3), axis=0).max()
    np.testing.assert_allclose(got, want, atol=1e-5 * span)


def test_export_then_import_gives_the_same_motion(mk, shared_dir, tmp_path):
    source, _ = mk.bvh.load(os.path.join(shared_dir, "data", "bvh", "walk60.bvh"))
    export_and_compare(mk, source, str(tmp_path / "out.bvh"), lambda p: mk.bvh.load(p)[0])


@needs_builtin
def test_export_reads_back_in_blenders_own_importer(mk, shared_dir, tmp_path):
    source, _ = mk.bvh.load(os.path.join(shared_dir, "data", "bvh", "walk60.bvh"))
    export_and_compare(mk, source, str(tmp_path / "out.bvh"), builtin_import)


def test_export_of_a_rolled_rig_not_from_bvh(mk, animdata, tmp_path):
    """A sample character (A-pose, ±90° rolls, Euler-free quaternion keys) round-trips."""
    import characters
    import generate
    spec = characters.UNREAL_A
    obj = generate.build_armature(spec, x=0.7)
    generate.add_walk(obj, spec, animdata)
    export_and_compare(mk, obj, str(tmp_path / "unreal.bvh"), lambda p: mk.bvh.load(p)[0])
    if BUILTIN:
        conftest.clear_scene()
        obj = generate.build_armature(spec, x=0.7)
        generate.add_walk(obj, spec, animdata)
        export_and_compare(mk, obj, str(tmp_path / "unreal2.bvh"), builtin_import)


BROKEN = [
    ("truncated", lambda t: t[: len(t) // 3]),
    ("unknown_channel", lambda t: t.replace("Yrotation", "Wrotation", 1)),
    ("bad_number", lambda t: t.replace("MOTION", "MOTION", 1).rsplit("\n", 3)[0] + "\n1 2 x\n"),
    ("nan", lambda t: t[: t.rindex("\n", 0, len(t) - 1)] + "\n" + " ".join(["nan"] * 18) + "\n"),
    ("unbalanced", lambda t: t.replace("}", "", 1)),
]


@pytest.mark.parametrize("name, corrupt", BROKEN, ids=[b[0] for b in BROKEN])
def test_a_broken_file_is_reported_and_changes_nothing(mk, tmp_path, name, corrupt):
    path = write_case(tmp_path, name, corrupt(CASES[0][1]))
    before = (set(bpy.data.objects), set(bpy.data.armatures), set(bpy.data.actions),
              bpy.context.scene.render.fps)
    with pytest.raises(ValueError, match=rf"{name}\.bvh:\d+:\d+: "):
        mk.bvh.load(path)
    # Headless, Blender raises an operator's error report as RuntimeError.
    with pytest.raises(RuntimeError, match=rf"{name}\.bvh:\d+:\d+: "):
        bpy.ops.motionkit.import_bvh(filepath=path, update_scene_fps=True)
    after = (set(bpy.data.objects), set(bpy.data.armatures), set(bpy.data.actions),
             bpy.context.scene.render.fps)
    assert after == before


def test_operators_import_and_export(mk, shared_dir, tmp_path):
    path = os.path.join(shared_dir, "data", "bvh", "run_forward.bvh")
    assert bpy.ops.motionkit.import_bvh(filepath=path) == {'FINISHED'}
    obj = bpy.context.view_layer.objects.active
    assert obj.type == 'ARMATURE' and obj.name == "run_forward"
    out = str(tmp_path / "run.bvh")
    assert bpy.ops.motionkit.export_bvh(filepath=out, frame_start=1, frame_end=45) == {'FINISHED'}
    with open(out) as f:
        assert "Frames: 45" in f.read()


def test_native_fcurve_sampling_equals_fcurve_evaluate(mk, animdata):
    """Bezier (auto, vector, free, overlong handles), linear and constant keys, both extrapolations."""
    obj = bpy.data.objects.new("Empty", None)
    bpy.context.scene.collection.objects.link(obj)
    action = animdata.new_action("Curves")
    rng = np.random.default_rng(4)
    frames = np.cumsum(rng.uniform(0.5, 6.0, 30))
    values = rng.normal(size=(6, 30))
    curves = animdata.write_keys(obj, action, [(f'["c{i}"]', 0) for i in range(6)], frames, values,
                                 interpolation='BEZIER')
    kinds = ['AUTO_CLAMPED', 'AUTO', 'VECTOR', 'FREE', 'ALIGNED', 'FREE']
    for i, fc in enumerate(curves):
        for k, key in enumerate(fc.keyframe_points):
            key.handle_left_type = key.handle_right_type = kinds[i]
            if kinds[i] in ('FREE', 'ALIGNED'):
                reach = rng.uniform(0.2, 3.0 if i == 5 else 1.0) * 4.0  # curve 5: overlong handles
                key.handle_left = (key.co.x - reach, key.co.y + rng.normal())
                key.handle_right = (key.co.x + reach, key.co.y + rng.normal())
            if i == 4 and k % 3 == 0:
                key.interpolation = 'LINEAR'
            if i == 4 and k % 3 == 1:
                key.interpolation = 'CONSTANT'
        fc.extrapolation = 'LINEAR' if i % 2 else 'CONSTANT'
        fc.update()
    # fcurve.evaluate takes its time as float32: compare at times it can represent.
    times = np.sort(rng.uniform(frames[0] - 10, frames[-1] + 10, 3000)).astype(np.float32).astype(np.float64)
    got, found = animdata.sample(action, obj, [(f'["c{i}"]', 0) for i in range(6)], times)
    assert found.all()
    want = np.array([[fc.evaluate(t) for t in times] for fc in curves])
    for i in range(len(curves)):
        # Blender computes in float32; we in float64.
        bad = np.flatnonzero(~np.isclose(got[i], want[i], rtol=1e-5, atol=1e-5))
        assert not bad.size, (kinds[i], curves[i].extrapolation, times[bad[:5]], got[i, bad[:5]],
                              want[i, bad[:5]], frames[:3], frames[-1])


def test_no_file_chosen_and_folders_are_named_and_change_nothing(mk, tmp_path):
    """Import with no file picked (the file browser then passes its folder, ending in a separator) says so,
    instead of reading the folder as a file; a folder path is refused by name."""
    before = (set(bpy.data.objects), set(bpy.data.actions))
    for path, message in (("", r"^no BVH file was chosen$"),
                          (str(tmp_path) + os.sep, r"no BVH file was chosen \(only the folder .*\)"),
                          (str(tmp_path), r"is a folder, not a BVH file")):
        with pytest.raises(ValueError, match=message):
            mk.bvh.load(path)
        with pytest.raises(RuntimeError, match=message.lstrip("^").rstrip("$")):
            bpy.ops.motionkit.import_bvh(filepath=path)
    assert (set(bpy.data.objects), set(bpy.data.actions)) == before


@pytest.mark.parametrize("frame_time, fps, fps_base", [(0.016667, 60, 1.0), (0.033333, 30, 1.0),
                                                        (0.041708, 24, 1.001)])
def test_the_files_frame_rate_is_the_one_it_meant(mk, tmp_path, frame_time, fps, fps_base):
    """'Use File's Frame Rate' on a file that prints 0.016667 s gives the scene exactly 60 fps (fps_base 1),
    not 59.9988."""
    text = CASES[0][1]
    lines = text.splitlines()
    lines = [f"Frame Time: {frame_time}" if line.startswith("Frame Time:") else line for line in lines]
    path = write_case(tmp_path, "rate", "\n".join(lines) + "\n")
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 24, 1.0
    mk.bvh.load(path, update_scene_fps=True)
    assert (scene.render.fps, scene.render.fps_base) == (fps, pytest.approx(fps_base, abs=1e-6))


def test_imported_bones_are_selected_so_their_curves_show(mk, shared_dir):
    """The Graph Editor shows only selected bones' curves by default (Only Show Selected): a fresh import
    selects its bones, as Blender's importer does."""
    obj, action = mk.bvh.load(os.path.join(shared_dir, "data", "bvh", "walk60.bvh"))
    selected = mk.pose_channels.selected(obj)
    assert len(selected) == 20 and all(selected)


def _scene_state():
    """What a refused import or export must leave as it was: the datablocks and the scene's timing."""
    scene = bpy.context.scene
    return (set(bpy.data.objects), set(bpy.data.actions), set(bpy.data.armatures),
            (scene.render.fps, scene.render.fps_base, scene.frame_start, scene.frame_end))


@pytest.mark.parametrize("options, message", [(dict(scale=0.0), r"scale must be a positive number, got 0\.0"),
                                              (dict(scale=-1.0), r"scale must be a positive number, got -1\.0"),
                                              (dict(scale=float("nan")), r"scale must be a positive number, got nan"),
                                              (dict(rotation_mode="XZ"), r"unknown rotation_mode 'XZ'")])
def test_a_bad_import_option_is_named_and_changes_nothing(mk, tmp_path, options, message):
    path = write_case(tmp_path, "good", CASES[0][1])
    before = _scene_state()
    with pytest.raises(ValueError, match=rf"^bvh\.load: .*good\.bvh.*: {message}"):
        mk.bvh.load(path, update_scene_fps=True, update_scene_duration=True, **options)
    assert _scene_state() == before


def _keyed_rig(mk, tmp_path):
    obj, action = mk.bvh.load(write_case(tmp_path, "good", CASES[0][1]))
    return obj, action


@pytest.mark.parametrize("case", ["not an armature", "no bones", "scale 0", "scale nan", "rotation order",
                                  "non-uniform scale"])
def test_a_bad_export_is_named_writes_nothing_and_changes_nothing(mk, tmp_path, case):
    obj, _ = _keyed_rig(mk, tmp_path)
    options, message = {}, None
    if case == "not an armature":
        obj, message = bpy.data.objects.new("Prop", None), r"^bvh\.save: 'Prop' is not an armature object"
    elif case == "no bones":
        obj = bpy.data.objects.new("Bare", bpy.data.armatures.new("Bare"))
        message = r"^bvh\.save: armature 'Bare' has no bones"
    elif case.startswith("scale"):
        options["scale"] = 0.0 if case == "scale 0" else float("nan")
        message = r"^bvh\.save: scale must be a positive number, got (0\.0|nan)"
    elif case == "rotation order":
        options["rotation_order"], message = "XYZW", r"^bvh\.save: unknown rotation order 'XYZW'"
    else:
        obj.scale = (1.0, 2.0, 1.0)
        bpy.context.view_layer.update()
        message = rf"^bvh\.save: '{obj.name}' has a non-uniform scale"
    before = _scene_state()
    path = tmp_path / "out.bvh"
    with pytest.raises(ValueError, match=message):
        mk.bvh.save(obj, str(path), **options)
    assert not path.exists() and _scene_state() == before


def test_a_nan_key_is_named_on_export_and_writes_nothing(mk, animdata, tmp_path):
    """A NaN in the source action (a broken script's key) is refused with its bone, channel and frame,
    rather than written into the file as 'nan'."""
    obj, action = _keyed_rig(mk, tmp_path)
    curve = next(fc for fc in animdata.fcurves(action, obj) if ".rotation_quaternion" in fc.data_path)
    bone = curve.data_path.split('"')[1]
    curve.keyframe_points[2].co.y = float("nan")
    frame = curve.keyframe_points[2].co.x
    path = tmp_path / "out.bvh"
    with pytest.raises(ValueError, match=rf"^bvh\.save: '{obj.name}' pose\.bones\[\"{bone}\"\]\.rotation_quaternion"
                                         rf"\[{curve.array_index}\] has a non-finite key at frame {frame:g}"):
        mk.bvh.save(obj, str(path))
    assert not path.exists()

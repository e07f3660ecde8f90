"""Whole motion libraries: a folder of BVH, FBX and glTF files (real Mixamo clips, files this test writes with
Blender's own exporters, a corrupt one and a non-humanoid) retargeted in one call; every good take gives its
action and its report row, every bad file a reason and nothing left behind; the report's figures agree with
Blender's own evaluation (frame_set, pose_bone.matrix, matrix_world).
"""
import csv
import json
import os
import shutil
import subprocess
import sys

import bpy
import numpy as np
import pytest
from mathutils import Vector

import conftest
from test_production_files import fbx_dir, import_fbx  # noqa: F401  (fbx_dir is a fixture)

SNAKE_BVH = """HIERARCHY
ROOT Base
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Middle
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Tip
    {
      OFFSET 0 10 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 10 0
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.033333
0 0 0 0 0 0 0 0 0 0 0 0
0 0 0 10 0 0 10 0 0 10 0 0
0 0 0 20 0 0 20 0 0 20 0 0
"""


def _export_takes(mk, fbx_dir, folder):
    """A two-take FBX (punch and kick on one armature, as NLA strips) and a one-take GLB, by Blender's own
    exporters; everything imported for them removed again."""
    punch = import_fbx(os.path.join(fbx_dir, "ybot@punch.fbx"))
    kick = import_fbx(os.path.join(fbx_dir, "ybot@kick.fbx"))
    anim = punch.animation_data
    for name, action in (("Punch", anim.action), ("Kick", kick.animation_data.action)):
        action.name = name
        anim.nla_tracks.new().strips.new(name, 1, action)
    anim.action = None
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj == punch)
    bpy.context.view_layer.objects.active = punch
    bpy.ops.export_scene.fbx(filepath=os.path.join(folder, "fight.fbx"), use_selection=True,
                             object_types={'ARMATURE'}, bake_anim_use_all_actions=False,
                             bake_anim_use_nla_strips=True, add_leaf_bones=False)
    for track in list(anim.nla_tracks):
        anim.nla_tracks.remove(track)
    anim.action = bpy.data.actions["Kick"]
    mk.batch.export_clip(punch, os.path.join(folder, "kick_gltf.glb"), "glb")
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for collection in (bpy.data.armatures, bpy.data.meshes, bpy.data.actions, bpy.data.materials):
        for item in list(collection):
            collection.remove(item)


@pytest.fixture()
def library(mk, fbx_dir, shared_dir, tmp_path):  # noqa: F811
    folder = tmp_path / "clips"
    (folder / "bvh").mkdir(parents=True)
    for name in ("walk60.bvh", "run_forward.bvh"):
        shutil.copy(os.path.join(shared_dir, "data", "bvh", name), folder / "bvh" / name)
    shutil.copy(os.path.join(fbx_dir, "ybot@punch.fbx"), folder / "punch.fbx")
    _export_takes(mk, fbx_dir, str(folder))
    (folder / "bvh" / "cut_short.bvh").write_text(SNAKE_BVH[:200])
    (folder / "garbage.fbx").write_bytes(b"Kaydara FBX Binary  \x00\x1a\x00" + bytes(range(256)) * 4)
    (folder / "snake.bvh").write_text(SNAKE_BVH)
    return folder


@pytest.fixture()
def target(fbx_dir):  # noqa: F811
    return import_fbx(os.path.join(fbx_dir, "ybot.fbx"))


GOOD = {"walk60", "run_forward", "punch", "fight|Punch", "fight|Kick", "kick_gltf"}
BAD = {"cut_short", "garbage", "snake"}


def _datablocks():
    return {kind: set(getattr(bpy.data, kind)) for kind in ("objects", "armatures", "meshes", "actions",
                                                            "materials", "images", "collections")}


def test_a_library_is_retargeted_past_its_bad_files_with_a_row_for_every_clip(mk, library, target, tmp_path):
    from motionkit.core import batch_report
    before = _datablocks()
    report_dir = tmp_path / "report"
    seen = []
    result = mk.batch.retarget_library([library], target, report_dir=str(report_dir),
                                       progress=lambda done, total, path: seen.append((done, total)))
    rows = {row["action"]: row for row in result.rows}
    print("\n" + batch_report.table(result.rows))
    assert set(rows) == GOOD | BAD, sorted(rows)
    assert {name for name, row in rows.items() if row["status"] == "ok"} == GOOD, \
        {name: row["reason"] for name, row in rows.items()}
    assert result.failed == len(BAD)
    for name in BAD:
        assert os.path.basename(rows[name]["file"]).startswith(name) and rows[name]["file"] in rows[name]["reason"]
    assert sorted(a.name for a in result.actions) == sorted(GOOD)
    assert all(a.use_fake_user and a.name in bpy.data.actions for a in result.actions)
    after = _datablocks()
    assert after["actions"] - before["actions"] == set(result.actions)
    for kind in ("objects", "armatures", "meshes", "materials", "images", "collections"):
        assert after[kind] == before[kind], (kind, after[kind] - before[kind])
    assert seen[0] == (0, 8) and seen[-1] == (8, 8)
    for name in GOOD:
        row = rows[name]
        # Feet held where they land (plant_feet) turn away from the source's: the report is there to show it.
        assert row["frames"] > 1 and row["bones_mapped"] >= 20 and row["direction_worst_deg"] < 30.0, row
    assert rows["punch"]["fingers_mapped"] == 30 and rows["walk60"]["fingers_mapped"] == 0
    assert rows["walk60"]["sliding_worst_mm"] is not None
    report = json.loads((report_dir / "report.json").read_text())
    assert report["failed"] == len(BAD) and [r["action"] for r in report["clips"]] == [r["action"] for r in result.rows]
    with open(report_dir / "report.csv", newline="") as f:
        table = list(csv.DictReader(f))
    assert [r["action"] for r in table] == [r["action"] for r in result.rows]
    assert float(table[[r["action"] for r in table].index("walk60")]["frames"]) == rows["walk60"]["frames"]


def test_each_clip_is_written_out_and_an_existing_file_is_kept_unless_asked(mk, library, target, tmp_path):
    out = tmp_path / "out"
    files = [library / "bvh" / "walk60.bvh", library / "fight.fbx"]
    result = mk.batch.retarget_library(files, target, out_dir=str(out), export="bvh")
    assert sorted(os.listdir(out)) == ["fight_Kick.bvh", "fight_Punch.bvh", "walk60.bvh"]
    again = mk.batch.retarget_library(files, target, out_dir=str(out), export="bvh")
    assert [row["status"] for row in again.rows] == ["skipped"] * 3 and again.actions == []
    forced = mk.batch.retarget_library(files[:1], target, out_dir=str(out), export="fbx", overwrite=True)
    assert forced.rows[0]["status"] == "ok" and os.path.isfile(out / "walk60.fbx")
    assert len(result.actions) == 3


def _reference_quality(mk, source, target, pairs, stance):
    """The figures, from Blender's evaluation: frame_set, pose_bone.matrix and head, matrix_world."""
    from motionkit.core import clip_quality
    action = mk.animdata.assigned_action(target)
    start, end = (int(round(v)) for v in action.frame_range)
    aims = mk.retargeting.pointing(source, target, pairs)
    feet = mk.contacts.find_feet(target)
    joints = [(f.foot, f.toe) for f in feet]  # the ankle is the foot's head, the ball the toe's
    dirs, rots, points = {"s": [], "t": []}, {"s": [], "t": []}, []
    for frame in range(start, end + 1):
        bpy.context.scene.frame_set(frame)
        for key, obj, names, side_aims in (("s", source, [a for a, _ in pairs], aims[0]),
                                           ("t", target, [t for _, t in pairs], aims[1])):
            world = obj.matrix_world.to_quaternion()
            matrices = [world @ obj.pose.bones[n].matrix.to_quaternion() for n in names]
            dirs[key].append([tuple(m @ Vector(side_aims[n])) for m, n in zip(matrices, names)])
            rots[key].append([tuple(m.normalized()) for m in matrices])
        world = target.matrix_world
        points.append([tuple(world @ target.pose.bones[b].head) for ankle, ball in joints for b in (ankle, ball)])
    rest = np.array([tuple(target.matrix_world @ target.data.bones[b].head_local) for ankle, ball in joints
                     for b in (ankle, ball)])
    up = np.array([0.0, 0.0, 1.0])
    source_dirs, target_dirs = np.array(dirs["s"]), np.array(dirs["t"])
    turn = clip_quality.best_turn_about(up, source_dirs, target_dirs)
    bones = clip_quality.BoneMotion(mk.rotation_channels.rotate(turn, source_dirs), target_dirs,
                                    np.array(rots["s"]), np.array(rots["t"]), [t for _, t in pairs])
    return clip_quality.measure(clip_quality.FeetMotion(np.array(points), rest, stance, up, ((0, 1), (2, 3))),
                                 bones)


@pytest.mark.parametrize("clip", ["walk60.bvh", "punch.fbx"])
def test_the_reports_figures_are_blenders_evaluation(mk, library, target, clip):
    from motionkit.features import clip_report
    path = str(library / ("bvh" if clip.endswith(".bvh") else "") / clip)
    source = mk.bvh.load(path)[0] if clip.endswith(".bvh") else import_fbx(path)
    pairs = mk.retargeting.auto_map(source, target)
    mk.retarget(source, target, bone_map=pairs)
    measured = clip_report.measure(source, target, pairs)
    stance = clip_report.source_stance(source, target)
    reference = _reference_quality(mk, source, target, pairs, stance)
    for key, value in reference.as_dict().items():
        if isinstance(value, float):
            assert getattr(measured, key) == pytest.approx(value, abs=0.01), key
        else:
            assert getattr(measured, key) == value, key
    print(f"\n{clip}: {measured.as_dict()}")


def _keys(action, obj, animdata):
    """{(data path, index): keyframe points (n, 2)} of an action's curves for obj."""
    out = {}
    for curve in animdata.fcurves(action, obj):
        co = np.empty(2 * len(curve.keyframe_points))
        curve.keyframe_points.foreach_get("co", co)
        out[(curve.data_path, curve.array_index)] = co.reshape(-1, 2)
    return out


def _same_actions(mk, one, other, target):
    assert [r["status"] for r in one.rows] == [r["status"] for r in other.rows]
    assert len(one.actions) == len(other.actions) > 0
    for a, b in zip(one.actions, other.actions):
        keys_a, keys_b = _keys(a, target, mk.animdata), _keys(b, target, mk.animdata)
        assert keys_a.keys() == keys_b.keys() and keys_a, (a.name, b.name)
        for channel, co in keys_a.items():
            assert np.allclose(co, keys_b[channel], atol=1e-9), (a.name, channel)
        assert a.use_fake_user and b.use_fake_user


def _some_files(library):
    return [library / "bvh" / "walk60.bvh", library / "punch.fbx", library / "fight.fbx",
            library / "bvh" / "cut_short.bvh", library / "kick_gltf.glb"]


def test_two_worker_blenders_give_the_same_actions_and_rows_as_one(mk, library, target):
    files = _some_files(library)
    alone = mk.batch.retarget_library(files, target)
    shared = mk.batch_workers.run_parallel(files, target, workers=2)
    assert [(r["file"], r["take"]) for r in shared.rows] == [(r["file"], r["take"]) for r in alone.rows]
    _same_actions(mk, alone, shared, target)
    for a, b in zip(alone.rows, shared.rows):
        assert a["sliding_worst_mm"] == b["sliding_worst_mm"] and a["direction_worst_deg"] == b["direction_worst_deg"]


@pytest.fixture()
def dask_scheduler():
    """A Dask LocalCluster of two worker processes, in a Python of its own, for as long as the test runs."""
    script = ("from distributed import LocalCluster\n"
              "import sys, time\n"
              "cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)\n"
              "print(cluster.scheduler_address, flush=True)\n"
              "sys.stdin.read()\n")
    process = subprocess.Popen([sys.executable, "-c", script], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                               text=True)
    try:
        address = process.stdout.readline().strip()
        assert address.startswith("tcp://"), f"the LocalCluster did not start: {address!r}"
        yield address
    finally:
        process.stdin.close()
        process.wait(timeout=60)


def test_a_dask_cluster_gives_the_same_actions_and_rows_as_one_blender(mk, library, target, dask_scheduler):
    files = _some_files(library)
    alone = mk.batch.retarget_library(files, target)
    on_dask = mk.batch_workers.run_parallel(files, target, scheduler=dask_scheduler)
    assert [(r["file"], r["take"], r["status"]) for r in on_dask.rows] == \
        [(r["file"], r["take"], r["status"]) for r in alone.rows]
    _same_actions(mk, alone, on_dask, target)


def test_the_command_line_retargets_a_folder_and_exits_with_the_number_that_failed(mk, library, target, tmp_path):
    """The README's command, in a Blender of its own with the add-on installed as a user installs it."""
    blend = str(tmp_path / "character.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    env = conftest.fresh_blender_env(tmp_path)
    install = ("import sys, bpy; sys.path.insert(0, %r); import install_addon; "
               "install_addon.install(%r); bpy.ops.wm.save_userpref()") % (os.path.join(conftest.ROOT, "tools"),
                                                                           os.environ["MOTIONKIT_ZIP"])
    subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", "--python-expr", install], env=env,
                   check=True, capture_output=True, timeout=300)
    out = tmp_path / "out"
    command = [bpy.app.binary_path, "-b", blend, "--python-expr", "import motionkit.cli as c; c.main()", "--",
               "retarget", "--target", target.name, "--out", str(out), "--export", "bvh", "--save",
               str(tmp_path / "done.blend"), str(library)]
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == len(BAD), done.stdout[-3000:] + done.stderr[-3000:]
    assert "[1/8]" in done.stdout and f"{len(GOOD) + len(BAD)} clips, {len(GOOD)} done, {len(BAD)} failed" in done.stdout
    rows = json.loads((out / "report.json").read_text())["clips"]
    assert {r["action"] for r in rows if r["status"] == "ok"} == GOOD
    assert len([n for n in os.listdir(out) if n.endswith(".bvh")]) == len(GOOD)
    with bpy.data.libraries.load(str(tmp_path / "done.blend")) as (saved, _):
        assert GOOD <= set(saved.actions)


def test_the_library_operator_fills_the_report_list(mk, library, target):
    """The sidebar's Library panel: the operator retargets the folder, its rows sorted worst first."""
    bpy.context.scene.motionkit_retarget.target = target
    settings = bpy.context.scene.motionkit_batch
    settings.folder = str(library / "bvh")
    actions = set(bpy.data.actions)
    assert bpy.ops.motionkit.retarget_library() == {'FINISHED'}
    rows = {row.action: row for row in settings.rows}
    assert set(rows) == {"walk60", "run_forward", "cut_short"}
    assert rows["cut_short"].status == "failed" and "cut_short.bvh" in rows["cut_short"].reason
    assert rows["walk60"].frames == 182 and rows["walk60"].sliding_worst_mm >= 0.0
    assert {a.name for a in set(bpy.data.actions) - actions} == {"walk60", "run_forward"}

"""MotionKit's headless demo (run inside Blender; `make demo` runs it).

Installs the built add-on from its zip, builds the sample characters, plays
the procedural walk on the Mixamo-style one, retargets the capture onto the
sample characters and onto a Rigify rig's controls, and writes out/demo.blend
and a rendered out/demo.png (Cycles on the CPU: no GPU or display needed).

    tools/with_blender.sh 3.4 -b --factory-startup --python demo/demo.py -- \\
        --zip dist/motionkit-0.1.0-linux-x64-py311.zip --out out
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

import bpy
import mathutils
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [os.path.join(ROOT, "tools"), os.path.join(ROOT, "blend_samples")]

import characters  # noqa: E402
import generate  # noqa: E402
import install_addon  # noqa: E402
import rigify_rig  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import body_figure  # noqa: E402
import cleanup_figures  # noqa: E402
import contacts_plot  # noqa: E402
import filters_plot  # noqa: E402
import feet_fingers  # noqa: E402
import ik_reach  # noqa: E402
import interpolant_plot  # noqa: E402
import mixamo_figure  # noqa: E402

SHOW_FRAME = 22  # mid-stride: left leg forward, right arm forward


def add_label(text: str, location, camera, size=0.085):
    curve = bpy.data.curves.new("Label", 'FONT')
    curve.body, curve.size, curve.align_x = text, size, 'CENTER'
    obj = bpy.data.objects.new("Label", curve)
    obj.location = location
    # Text faces -Y once stood up; turn it about Z to face the camera.
    dx, dy = camera.location.x - location[0], camera.location.y - location[1]
    obj.rotation_euler = (math.radians(90), 0.0, math.atan2(dx, -dy))
    bpy.context.scene.collection.objects.link(obj)
    material = bpy.data.materials.new("LabelInk")
    material.diffuse_color = (0.05, 0.05, 0.05, 1.0)
    curve.materials.append(material)
    return obj


def stage(scene) -> bpy.types.Object:
    """Ground, light, sky and a camera that frames both rows of characters."""
    ground = bpy.data.meshes.new("Ground")
    s = 12.0
    ground.from_pydata([(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], [], [(0, 1, 2, 3)])
    ground_obj = bpy.data.objects.new("Ground", ground)
    scene.collection.objects.link(ground_obj)
    floor = bpy.data.materials.new("Floor")
    floor.diffuse_color = (0.62, 0.62, 0.60, 1.0)
    if floor.node_tree is None:
        floor.use_nodes = True
    bsdf = next(n for n in floor.node_tree.nodes if n.type == 'BSDF_PRINCIPLED')
    bsdf.inputs["Base Color"].default_value = (0.62, 0.62, 0.60, 1.0)
    ground.materials.append(floor)

    sun = bpy.data.lights.new("Sun", 'SUN')
    sun.energy, sun.angle = 3.5, math.radians(8)
    sun_obj = bpy.data.objects.new("Sun", sun)
    sun_obj.rotation_euler = (math.radians(50), math.radians(10), math.radians(35))
    scene.collection.objects.link(sun_obj)

    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    if world.node_tree is None:
        world.use_nodes = True
    background = next(n for n in world.node_tree.nodes if n.type == 'BACKGROUND')
    background.inputs["Color"].default_value = (0.55, 0.62, 0.72, 1.0)
    background.inputs["Strength"].default_value = 0.9

    cam = bpy.data.cameras.new("Camera")
    cam.lens = 38
    cam_obj = bpy.data.objects.new("Camera", cam)
    cam_obj.location = (0.0, -9.0, 4.2)
    target = mathutils.Vector((0.0, 1.2, 0.6))
    # Cameras look down their -Z with +Y up.
    cam_obj.rotation_euler = (target - cam_obj.location).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    return cam_obj


def render(scene, path: str, samples: int) -> None:
    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    scene.cycles.samples = samples
    if hasattr(scene.cycles, "use_denoising"):
        scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 960, 540
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'PNG'
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def resample_inputs(motionkit, obj, action, seconds: float = 2.0) -> dict:
    """The first seconds of the clip's bounciest root location channel and liveliest bone rotation."""
    animdata = motionkit.animdata
    curves = list(animdata.fcurves(action, obj))
    root = obj.pose.bones[0].name
    locations = [f for f in curves if f.data_path == f'pose.bones["{root}"].location']
    keys = [animdata.read_keys(f) for f in locations]
    count = int(seconds * 60) + 1

    def wiggle(i):  # what is left once the steady drift is taken out: the bounce of a walk
        values = keys[i][1][:count].astype(np.float64)
        steps = np.arange(values.size)
        return float(np.std(values - np.polyval(np.polyfit(steps, values, 1), steps)))

    index = max(range(len(keys)), key=wiggle)
    frames, values = (k.astype(np.float64)[:count] for k in keys[index])
    best, quats = None, None
    for bone in obj.pose.bones[1:]:
        rows = [animdata.find_fcurve(action, obj, f'pose.bones["{bone.name}"].rotation_quaternion', k)
                for k in range(4)]
        if any(r is None for r in rows):
            continue
        q = np.stack([animdata.read_keys(r)[1][:count] for r in rows], axis=1).astype(np.float64)
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        spread = float(np.ptp(np.abs(q @ q[0])))
        if best is None or spread > best[0]:
            best, quats = (spread, bone.name), q
    return {"scalar": (frames, values, f"{root} location[{index}]"),
            "rotation": (frames[:len(quats)], quats, best[1]),
            "channel": (f'pose.bones["{root}"].location', index)}


def resampled_curve(motionkit, obj, action, before) -> dict:
    """The resampled channel as Blender now has it: its keys, and fcurve.evaluate between them."""
    path, index = before["channel"]
    fcurve = motionkit.animdata.find_fcurve(action, obj, path, index)
    frames, values = (k.astype(np.float64) for k in motionkit.animdata.read_keys(fcurve))
    old_frames, old_values, _ = before["scalar"]
    seconds = (old_frames[-1] - old_frames[0]) / 60.0
    new = frames <= 1.0 + seconds * 24.0 + 1e-6
    dense = np.linspace(1.0, 1.0 + seconds * 24.0, 1500)
    return {"old_times": (old_frames - 1.0) / 60.0, "old_values": old_values,
            "new_times": (frames[new] - 1.0) / 24.0, "new_values": values[new],
            "curve_times": (dense - 1.0) / 24.0, "curve_values": np.array([fcurve.evaluate(t) for t in dense]),
            "label": f"{path}[{index}]"}


FRONT, BACK = 0.0, 3.4  # the rows' distances from the camera side
SOURCE_FPS = 60


def character(spec, x: float, y: float):
    obj = generate.build_armature(spec, x=x)
    obj.location.y = y
    generate.build_body(spec, obj)
    return obj


def retarget_row(motionkit, source, y: float, placements, labels: dict, source_label: str) -> list:
    """Sample characters placed at (spec, x) on row y, each retargeted from source (auto-mapped)."""
    targets = []
    for spec, x in placements:
        obj = character(spec, x, y)
        started = time.perf_counter()
        motionkit.retarget(source, obj)
        print(f"demo: retargeted {source.name} onto {obj.name} in {time.perf_counter() - started:.3f} s")
        labels[obj] = f"{spec.name} ({spec.rest_pose}-pose)\n<- {source_label}"
        targets.append(obj)
    return targets


def contacts_figure(motionkit, source, target, path: str) -> None:
    """out/contacts.png: the target's left ankle with and without planted feet (the target keeps the planted
    retarget it already has)."""
    retargeting, pose_channels, animdata = motionkit.retargeting, motionkit.pose_channels, motionkit.animdata
    planted_action = animdata.assigned_action(target)
    plan = retargeting.plan(source, target)  # the same as the row's, for its contacts and feet
    names = [b.name for b in pose_channels.depth_first(target.data)]
    ankle = names.index(plan.feet[0].foot)

    def track(action):
        _, heads = pose_channels.armature_motion(target, action, plan.frames)
        return heads[:, 3 * ankle:3 * ankle + 3]

    plain_action = retargeting.apply(retargeting.plan(source, target, plant_feet=False))
    plain = track(plain_action)
    animdata.assign(target, planted_action)
    bpy.data.actions.remove(plain_action)
    contacts_plot.plot(path, plan.frames, plan.frame_rate, plan.contacts[:, 0], plain, track(planted_action),
                       f"walk60.bvh onto {target.name}: left ankle")
    print(f"demo: wrote {path}")


def filters_figure(motionkit, mocap: str, path: str, bone: str = "lKnee", degrees: float = 1.5,
                   cutoff: float = 6.0) -> None:
    """out/filters.png: walk60 with noise on every bone's rotation, filtered by a Butterworth low-pass on the
    sphere; on an armature of its own, removed afterwards."""
    animdata = motionkit.animdata
    obj, action = motionkit.bvh.load(mocap, name="walk60 noisy")
    frames = animdata.read_keys(animdata.fcurves(action, obj)[0])[0].astype(np.float64)

    def rotation(name):
        """(frames, 4): as Blender evaluates the bone's curves at the capture's frames (a filter writes
        its keys at the action's own rate)."""
        channels = [(f'pose.bones["{name}"].rotation_quaternion', k) for k in range(4)]
        return animdata.sample(action, obj, channels, frames)[0].T

    rng = np.random.default_rng(2)
    captured = rotation(bone)
    for name in obj.pose.bones.keys():
        if animdata.find_fcurve(action, obj, f'pose.bones["{name}"].rotation_quaternion', 0) is None:
            continue
        q = rotation(name)
        noisy = filters_plot.multiply(q, filters_plot.noise(rng, len(q), degrees))
        animdata.write_keys(obj, action, [(f'pose.bones["{name}"].rotation_quaternion', k, name) for k in range(4)],
                            frames, noisy.T)
    noisy = rotation(bone)
    motionkit.filter(obj, "butterworth", cutoff=cutoff, order=4)
    filtered = rotation(bone)
    fps = animdata.frame_rate(action)
    armature = obj.data
    bpy.data.objects.remove(obj)
    bpy.data.armatures.remove(armature)
    bpy.data.actions.remove(action)
    filters_plot.plot(path, frames, fps, captured, noisy, filtered,
                      f"walk60.bvh, {bone} with {degrees:g}° of noise on every rotation: "
                      f"Butterworth {cutoff:g} Hz, order 4, on the sphere")
    print(f"demo: wrote {path}")


def raise_hand(motionkit, obj, labels: dict):
    """Full-body IK over the retargeted walk: both feet pinned where the walk puts them, the left
    hand up to a ball above the head; the hips are free to move."""
    from motionkit.ik import Effector
    spec = characters.UNREAL_A
    bones = spec.canonical
    ball = bpy.data.meshes.new("Goal")
    goal = bpy.data.objects.new("Goal", ball)
    bpy.context.scene.collection.objects.link(goal)
    generate_sphere(ball, 0.06)
    material = bpy.data.materials.new("GoalRed")
    material.diffuse_color = (0.85, 0.1, 0.1, 1.0)
    ball.materials.append(material)
    # The ball rides above the left shoulder as the hips go (posed natively from the walk's keys).
    action = motionkit.animdata.assigned_action(obj)
    start, end = (int(v) for v in action.frame_range)
    frames = np.arange(start, end + 1, dtype=np.float64)
    rig, order = motionkit.pose_channels.native_rig(obj.data)
    _, heads = motionkit.pose_channels.armature_motion(obj, action, frames, rig, order)
    hips = order.index(obj.data.bones[bones["hips"]])
    path = heads[:, 3 * hips:3 * hips + 3] + np.array(obj.matrix_world.translation) + (0.3, -0.1, 0.0)
    path[:, 2] = 2.05
    goal_path = motionkit.animdata.new_action("GoalPath")
    motionkit.animdata.write_keys(goal, goal_path, [("location", k) for k in range(3)], frames, path.T)
    motionkit.animdata.assign(goal, goal_path)
    started = time.perf_counter()
    result = motionkit.ik.solve(obj, [Effector(bones["foot.L"], pin=True, orientation=True),
                                      Effector(bones["foot.R"], pin=True, orientation=True),
                                      Effector(bones["hand.L"], target=goal)], frame_range=(start, end))
    print(f"demo: IK on {obj.name}, {end - start + 1} frames in {time.perf_counter() - started:.3f} s, "
          f"largest hand error {1000 * result.errors[:, 2].max():.2f} mm, feet {1000 * result.errors[:, :2].max():.2f} mm")
    labels[obj] += "\n+ IK: feet pinned, hand raised"
    return goal


def rigify_character(motionkit, source, x: float, y: float, labels: dict, source_label: str):
    """A rig generated by Rigify (the add-on that ships with Blender) from its human metarig, the capture
    retargeted onto its controls: legs in IK with planted feet, arms in FK. Its DEF bones get a body."""
    before = set(bpy.data.objects)
    rig, metarig = rigify_rig.generate()
    bpy.data.objects.remove(metarig)
    for obj in set(bpy.data.objects) - before - {rig}:  # Rigify's widget shapes: never rendered
        obj.hide_render = True
    rig.name = "RigifyRig"
    rig.location = (x, y, 0.0)
    # The body's deform bones (not the face's, fingers' or breasts'), the head as a ball.
    thick = {"spine": (0.11, 0.09), "spine.004": (0.05, 0.045), "spine.005": (0.05, 0.045),
             "spine.006": (0.1, 0.1), "shoulder": (0.045, 0.04), "upper_arm": (0.045, 0.04),
             "forearm": (0.04, 0.03), "hand": (0.035, 0.03), "thigh": (0.07, 0.055), "shin": (0.05, 0.04),
             "foot": (0.04, 0.035), "toe": (0.035, 0.03)}
    radii = {}
    for bone in rig.data.bones:
        name = bone.name[4:]
        part = name if name in thick else name.split(".")[0]
        if bone.use_deform and bone.name.startswith("DEF-") and part in thick:
            radii[bone.name] = thick[part] if part != "spine" or name == "spine" else (0.1, 0.09)
    generate.skin_bones(rig, radii, (0.55, 0.4, 0.75, 1.0), "Rigify")
    started = time.perf_counter()
    motionkit.retarget(source, rig, controls="auto")
    print(f"demo: retargeted {source.name} onto the Rigify rig's controls in {time.perf_counter() - started:.3f} s")
    labels[rig] = f"Rigify rig (controls:\nlegs IK, arms FK)\n<- {source_label}"
    return rig


def generate_sphere(mesh, radius: float) -> None:
    rings, segments = 8, 12
    verts = [(0.0, 0.0, radius)]
    for r in range(1, rings):
        polar = math.pi * r / rings
        verts += [(radius * math.sin(polar) * math.cos(2 * math.pi * k / segments),
                   radius * math.sin(polar) * math.sin(2 * math.pi * k / segments), radius * math.cos(polar))
                  for k in range(segments)]
    verts.append((0.0, 0.0, -radius))
    faces = [(0, 1 + (k + 1) % segments, 1 + k) for k in range(segments)]
    for r in range(rings - 2):
        a, b = 1 + r * segments, 1 + (r + 1) * segments
        faces += [(a + k, a + (k + 1) % segments, b + (k + 1) % segments, b + k) for k in range(segments)]
    last, base = len(verts) - 1, 1 + (rings - 2) * segments
    faces += [(last, base + k, base + (k + 1) % segments) for k in range(segments)]
    mesh.from_pydata(verts, [], faces)
    for polygon in mesh.polygons:
        polygon.use_smooth = True


def place_labels(labels: dict, camera) -> None:
    """Each label at its character's feet, where the shown frame has it."""
    for obj, text in labels.items():
        bones = obj.pose.bones
        root = obj.matrix_world @ (bones["torso"] if "torso" in bones else bones[0]).head  # Rigify: the torso
        add_label(text, (root.x + 0.45, root.y - 0.25, 0.2), camera)


def main() -> None:
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog="demo.py")
    parser.add_argument("--zip", required=True, help="the MotionKit zip to install and use")
    parser.add_argument("--out", default=os.path.join(ROOT, "out"), help="output folder")
    parser.add_argument("--samples", type=int, default=48, help="Cycles samples per pixel")
    args = parser.parse_args(argv)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)

    start = time.perf_counter()
    install_addon.install(args.zip)
    import motionkit
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    # First, on an empty scene (it evaluates 909 frames, each frame_set as fast as the scene is light; its
    # objects are removed after): Mixamo's own retargets (../shared/data/pairs), Kaya under Aj's clip,
    # MotionKit beside Mixamo's answer.
    pairs = os.path.join(os.path.dirname(ROOT), "shared", "data", "pairs")
    why_not = mixamo_figure.available(pairs)
    if why_not is None:
        mixamo_figure.figure(motionkit, os.path.join(os.path.dirname(ROOT), "shared"),
                             os.path.join(out, "mixamo_pairs.png"))
        print(f"demo: wrote {os.path.join(out, 'mixamo_pairs.png')}")
    else:
        print(f"demo: {why_not}, so mixamo_pairs.png is left out")
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = SOURCE_FPS, 1.0
    camera = stage(scene)
    animated, labels = [], {}

    # Front row: the procedural walk on the T-pose Mixamo-style character,
    # retargeted onto the A-pose Rigify- and Unreal-style ones.
    source = character(characters.MIXAMO_T, -1.6, FRONT)
    generate.add_walk(source, characters.MIXAMO_T, motionkit.animdata, fps=SOURCE_FPS)
    labels[source] = "MixamoT (T-pose)\nsource: procedural walk"
    animated += [source] + retarget_row(motionkit, source, FRONT,
                                        ((characters.RIGIFY_A, 0.0), (characters.UNREAL_A, 1.6)),
                                        labels, "MixamoT")

    animated.append(raise_hand(motionkit, animated[-1], labels))  # the goal is resampled with the rest

    mocap = os.path.join(os.path.dirname(ROOT), "shared", "data", "bvh", "walk60.bvh")
    before = None
    if os.path.isfile(mocap):
        # Back row: real motion capture through MotionKit's importer, and the
        # three characters retargeted from it.
        # The scene takes the capture's rate and range, as a user importing it would have it.
        walker, action = motionkit.bvh.load(mocap, update_scene_fps=True, update_scene_duration=True)
        walker.location = (-3.3, BACK, 0.0)
        generate.skin_bones(walker, {b.name: (0.045, 0.035) for b in walker.data.bones},
                            (0.85, 0.75, 0.25, 1.0), "walk60")
        labels[walker] = "walk60.bvh\nsource: motion capture"
        row = retarget_row(motionkit, walker, BACK, tuple(zip(characters.CHARACTERS, (-1.1, 1.1, 3.3))),
                           labels, "walk60.bvh")
        animated += [walker] + row
        animated.append(rigify_character(motionkit, walker, 3.25, FRONT + 0.9, labels, "walk60.bvh"))
        contacts_figure(motionkit, walker, row[-1], os.path.join(out, "contacts.png"))
        filters_figure(motionkit, mocap, os.path.join(out, "filters.png"))
        cleanup_figures.reduction_figure(motionkit, mocap, os.path.join(out, "reduction.png"))
        before = resample_inputs(motionkit, walker, action)
    else:
        print(f"demo: {mocap} is absent, so the motion-capture row is left out")

    # Everything from 60 to 24 fps in one call, Kochanek-Bartels rotations.
    motionkit.resample(animated, fps=24.0, change_scene_rate=True, rotation="kochanek-bartels",
                       scalar="catmull-rom")
    if before is not None:
        plot = os.path.join(out, "interpolants.png")
        interpolant_plot.plot(motionkit.native(), plot, before["scalar"], before["rotation"],
                              resampled_curve(motionkit, walker, action, before))
        print(f"demo: wrote {plot}")
    if before is not None:
        motionkit.scene_timing.from_clip(scene, action)  # the capture's range at its new rate: 1-73 at 24 fps
    else:
        scene.frame_start, scene.frame_end = 1, 73
    scene.frame_set(SHOW_FRAME)
    place_labels(labels, camera)
    blend = os.path.join(out, "demo.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    png = os.path.join(out, "demo.png")
    render(scene, png, args.samples)
    # Last, as it replaces the scene's characters (demo.blend is saved): the same reach before and after
    # the IK's priorities and natural defaults, side by side.
    reach = os.path.join(out, "ik_reach.png")
    ik_reach.figure(motionkit, add_label, render, reach, args.samples)
    # Real Mixamo files (Blender's FBX importer): feet on the floor and fists, before and after.
    fbx = os.path.join(os.path.dirname(ROOT), "shared", "data", "fbx")
    if os.path.isfile(mocap) and os.path.isfile(os.path.join(fbx, "ybot.fbx")):
        feet_fingers.figure(motionkit, mocap, fbx, os.path.join(out, "feet_fingers.png"))
        print(f"demo: wrote {os.path.join(out, 'feet_fingers.png')}")
        # Last, as it replaces the scene's objects too: a Mixamo clip and its mirror image, rendered.
        cleanup_figures.mirror_figure(motionkit, add_label, render, fbx, os.path.join(out, "mirror.png"),
                                      args.samples)
    else:
        print(f"demo: {fbx} is absent, so feet_fingers.png is left out")
    # Last, as it replaces the scene's objects too: arms kept out of a cartoon body, with the meshes.
    shared = os.path.join(os.path.dirname(ROOT), "shared")
    why_not = body_figure.available(shared)
    if why_not is None:
        body_figure.figure(motionkit, add_label, render, shared, os.path.join(out, "body.png"), args.samples)
        print(f"demo: wrote {os.path.join(out, 'body.png')}")
    else:
        print(f"demo: {why_not}, so body.png is left out")
    print(f"demo: wrote {blend}, {png} and {reach} in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()

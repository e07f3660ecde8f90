"""out/mixamo_pairs.png: a Mixamo character keeps her own posture under another's clip, MotionKit beside
Mixamo's own answer.

Mixamo retargets every animation onto every character itself, so the same clip downloaded on two of its
characters is an answer no one here wrote (../shared/data/pairs, README there). Aj's clip is retargeted
by MotionKit's defaults (motionkit.retarget(source, target)) onto a rest copy of Kaya; Kaya's own clip of
the same animation is Mixamo's. Both are imported with Blender's own BVH importer and every joint is
Blender's evaluation (frame_set, pose bone heads through matrix_world); the plain rotation copy (each
joint's local rotation by name, the root's path times the hip heights' ratio) is san_protocol's numpy.
Shown: the 22 main body joints of the SAN protocol as stick figures on five frames of one stride, a side
view, her lower foot close up against the floor and a front view, the views turned with Mixamo's hips on
each frame (she turns on the catwalk); under each frame its mean distance to Mixamo's joints in % of Kaya's
height (all joints, and the pose alone: the joints relative to the hips), MotionKit's hips' offset from
Mixamo's and the lower toe joint's height; in the title the clip's means, the pose alone split between
the upper body and the legs, and the toes' mean height (every figure measured, none assumed).
"""
from __future__ import annotations

import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "common"))

import mixamo_pairs as mp  # noqa: E402
import san_protocol as sp  # noqa: E402

SOURCE, TARGET = "Aj", "Kaya"
TRUNK = ("Hips", "Spine", "Spine1", "Spine2", "Neck", "Head")
LIMBS = tuple((side, ("Spine2",) + tuple(side + p for p in ("Shoulder", "Arm", "ForeArm", "Hand")))
              for side in sp.SIDES) + \
    tuple((side, ("Hips",) + tuple(side + p for p in ("UpLeg", "Leg", "Foot", "ToeBase"))) for side in sp.SIDES)
MIXAMO, MOTIONKIT, COPY = "#222222", "#e66101", "#1b9e77"


def available(pairs_dir: str) -> str | None:
    """Why the figure cannot be made here (None when it can): under CI=true a missing input is an error."""
    missing = [p for p in (os.path.join(pairs_dir, "san", c) for c in (SOURCE, TARGET)) if not os.path.isdir(p)]
    if not missing:
        return None
    if os.environ.get("CI") == "true":
        raise RuntimeError(f"{missing[0]} is missing, and CI=true requires it for mixamo_pairs.png")
    return f"{missing[0]} is absent"


def _clip_joints(motionkit, shared: str, clip: str, frames) -> dict:
    """Kaya's body joints (frames, 22, 3) in Blender's world, metres: Mixamo's own clip, MotionKit's
    retarget of Aj's clip onto her rest, and the plain copy; and her height (SAN's, metres)."""
    src = sp.read_bvh(mp.san_path(shared, SOURCE, clip))
    tgt = sp.read_bvh(mp.san_path(shared, TARGET, clip))
    mixamo = mp.import_bvh(mp.san_path(shared, TARGET, clip))
    reference = mp.joints_world(mixamo, sp.BODY_JOINTS, frames)
    target = mp.rest_copy(mixamo, f"{TARGET} rest")
    source = mp.import_bvh(mp.san_path(shared, SOURCE, clip))
    motionkit.retarget(source, target)
    ours = mp.joints_world(target, sp.BODY_JOINTS, frames)
    plain = mp.bvh_to_blender(sp.plain_copy(src, tgt)[np.asarray(frames) - 1][:, sp.body_indices(tgt.names)])
    mp.remove(mixamo, target, source)
    return {"Mixamo": reference, "MotionKit": ours, "copy": plain,
            "height": mp.BVH_SCALE * sp.height(tgt.names, tgt.parents, tgt.offsets)}


def _draw(ax, joints, view, origin, color, width, style="-", alpha=1.0):
    """One stick figure: the trunk, then each limb from where it hangs; the right side paler."""
    index = {n: i for i, n in enumerate(sp.BODY_JOINTS)}
    for side, chain in (("", TRUNK),) + LIMBS:
        p = (joints[[index[n] for n in chain]] - origin) @ view
        fade = 0.45 if side == "Right" else 1.0
        ax.plot(p[:, 0], p[:, 1], style, color=color, lw=width, alpha=alpha * fade,
                solid_capstyle="round")
    head = (joints[index["Head"]] - origin) @ view
    ax.plot(head[0], head[1], "o", color=color, ms=width * 2.2, alpha=alpha)


# One stride of her straight walk: her left foot's height repeats every 70 frames, and she walks
# straight from frame 40 to 330 (then turns, walks back, turns again).
CLIP, SHOWN = "Catwalk Walk", (141, 155, 169, 183, 197)


def _view(reference, side: bool) -> np.ndarray:
    """(3, 2): world to the panel's (across, up), facing with Mixamo's hips on that frame (she walks
    and turns): the side view has her forward to the right, the front view is as one facing her sees
    her (her left on the right)."""
    index = {n: i for i, n in enumerate(sp.BODY_JOINTS)}
    left = reference[index["LeftUpLeg"]] - reference[index["RightUpLeg"]]
    left[2] = 0.0
    left /= np.linalg.norm(left)
    up = np.array([0.0, 0.0, 1.0])
    return np.stack([np.cross(left, up) if side else left, up], axis=1)


def _panel(ax, joints, frame, side: bool, center: str, xlim, ylim) -> None:
    """The three figures on one frame, across centred on Mixamo's joint center, heights as they are (the
    floor is the file's y = 0, dashed)."""
    reference = joints["Mixamo"][frame]
    origin = reference[sp.BODY_JOINTS.index(center)].copy()
    origin[2] = 0.0
    view = _view(reference, side)
    ax.axhline(0.0, color="#888888", lw=1.0, ls="--", zorder=0)
    _draw(ax, joints["copy"][frame], view, origin, COPY, 1.2, "-", 0.9)
    _draw(ax, reference, view, origin, MIXAMO, 3.2)
    _draw(ax, joints["MotionKit"][frame], view, origin, MOTIONKIT, 2.0)
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    ax.set_aspect("equal")
    ax.tick_params(labelsize=7)


def _lower_toe(joints) -> tuple[str, np.ndarray]:
    """Per frame: the lower of the two toe joints' heights (frames,), and the name of Mixamo's lower one
    on each frame."""
    toes = [sp.BODY_JOINTS.index(n) for n in ("LeftToeBase", "RightToeBase")]
    return joints[:, toes, 2].min(axis=1), np.array(["LeftToeBase", "RightToeBase"])[
        joints[:, toes, 2].argmin(axis=1)]


def _frame_label(joints, k: int, height: float) -> str:
    """What is measured on frame k: each way's mean distance to Mixamo's joints (all; pose alone) and the
    lower toe joint's height above the floor."""
    lines = []
    for method, name in (("MotionKit", "MotionKit"), ("copy", "plain copy")):
        e = sp.errors(joints[method][k:k + 1], joints["Mixamo"][k:k + 1], height)
        lines.append(f"{name} {e['all']:.1f} %, pose {e['pose']:.1f} %")
    off = 100 * (joints["MotionKit"][k, 0] - joints["Mixamo"][k, 0])
    side, front = _view(joints["Mixamo"][k], True), _view(joints["Mixamo"][k], False)
    lines.append(f"MotionKit's hips from Mixamo's (cm):\n{off @ side[:, 0]:+.1f} ahead, "
                 f"{off @ front[:, 0]:+.1f} to her left, {off[2]:+.1f} up")
    toe = {m: round(100 * _lower_toe(joints[m])[0][k], 1) + 0.0 for m in ("Mixamo", "MotionKit", "copy")}
    lines.append(f"lower toe joint above the floor (cm):\nMixamo {toe['Mixamo']:.1f}, "
                 f"MotionKit {toe['MotionKit']:.1f}, copy {toe['copy']:.1f}")
    return "\n".join(lines)


def _summary(joints, height: float) -> str:
    """The clip's means, where the pose alone differs (upper body, hips to hands, against the legs) and
    how high the feet stand."""
    m = sp.errors(joints["MotionKit"], joints["Mixamo"], height)
    c = sp.errors(joints["copy"], joints["Mixamo"], height)
    per_joint = sp.joint_pose_errors(joints["MotionKit"], joints["Mixamo"], height)
    upper = per_joint[:sp.BODY_JOINTS.index("LeftUpLeg")]
    toe = {k: 100 * float(_lower_toe(joints[k])[0].mean()) for k in ("Mixamo", "MotionKit", "copy")}
    return (f"Mean over the clip, distance to Mixamo's joints in % of her height: MotionKit {m['all']:.1f} % all "
            f"joints, {m['pose']:.1f} % pose alone (relative to the hips); plain rotation copy {c['all']:.1f} %, "
            f"{c['pose']:.1f} % (her height {100 * height:.1f} cm)\n"
            f"MotionKit's pose alone: trunk, head and arms at most {upper.max():.2f} %, "
            f"knees {np.mean(per_joint[[sp.BODY_JOINTS.index(s + 'Leg') for s in sp.SIDES]]):.1f} %, "
            f"ankles {np.mean(per_joint[[sp.BODY_JOINTS.index(s + 'Foot') for s in sp.SIDES]]):.1f} %\n"
            f"The lower toe joint above the floor, mean: Mixamo {toe['Mixamo']:.1f} cm, MotionKit "
            f"{toe['MotionKit']:.1f}, copy {toe['copy']:.1f}")


def figure(motionkit, shared: str, path: str, clip: str = CLIP, shown=SHOWN, every: int = 1) -> None:
    """Write the figure to path: the shown frames of clip, the means over every every-th frame."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    started = time.perf_counter()
    last = sp.read_bvh(mp.san_path(shared, TARGET, clip)).values.shape[0]
    frames = np.array(sorted(set(range(1, last + 1, every)) | set(shown)))
    joints = _clip_joints(motionkit, shared, clip, frames)
    height = joints["height"]
    picks = [int(np.searchsorted(frames, f)) for f in shown]
    top = max(float(joints[m][picks][..., 2].max()) for m in ("Mixamo", "MotionKit", "copy")) + 0.08
    fig, axes = plt.subplots(3, len(shown), figsize=(2.5 * len(shown), 10.9), sharey="row",
                             gridspec_kw={"height_ratios": [top / 1.1, 0.2 / 0.44, top / 1.1]},
                             constrained_layout=True)
    _, lower = _lower_toe(joints["Mixamo"])
    for column, k in enumerate(picks):
        _panel(axes[0, column], joints, k, True, "Hips", (-0.55, 0.55), (-0.05, top))
        _panel(axes[1, column], joints, k, True, lower[k], (-0.22, 0.22), (-0.04, 0.16))
        _panel(axes[2, column], joints, k, False, "Hips", (-0.55, 0.55), (-0.05, top))
        axes[0, column].set_title(f"frame {frames[k]}", fontsize=10)
        axes[2, column].set_xlabel(_frame_label(joints, k, height), fontsize=8)
    axes[0, 0].set_ylabel("side view (she faces right)\nheight (m)", fontsize=9)
    axes[1, 0].set_ylabel("her lower foot,\nclose up (m)", fontsize=9)
    axes[2, 0].set_ylabel("front view (facing her)\nheight (m)", fontsize=9)
    handles = [plt.Line2D([], [], color=c, lw=w) for c, w in ((MIXAMO, 3.2), (MOTIONKIT, 2.0), (COPY, 1.2))]
    fig.legend(handles, ["Mixamo's own clip on Kaya", "MotionKit's default retarget onto her rest",
                         "plain rotation copy"], loc="lower center", ncol=3, fontsize=9, frameon=False,
               bbox_to_anchor=(0.5, -0.025))
    fig.suptitle(f"Aj's \"{clip}\" on Kaya (Mixamo's BVH files, 60 fps), one stride: MotionKit against Mixamo's "
                 f"own retarget; her right side paler, the floor dashed\n{_summary(joints, height)}", fontsize=9.5)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    print(f"demo: {clip}, Aj onto Kaya against Mixamo's own ({len(frames)} frames): "
          + _summary(joints, height).replace("\n", "; ") + f"; in {time.perf_counter() - started:.1f} s")

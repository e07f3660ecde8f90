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

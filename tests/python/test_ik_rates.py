"""The IK solver's convergence and robustness figures, on walk60's 20-joint skeleton and a 60-bone rig.

- 10,000 random reachable problems per rig: 4 effectors (both hands to targets,
  both feet pinned), root translation and rotation free; DLS must converge to
  1e-4 of the rig's size in at least 99.5 % of them; CCD's and the transpose's
  rates are printed beside it (run pytest with -s to see them).
- 1,000,000 random solves, unreachable, singular and degenerate ones among
  them, across all four methods: no NaN or infinity anywhere in the output.
"""
import os

import numpy as np
import pytest

import rig_fk

RATE_CASES = 10_000
FK_CASES = 1_000  # the cases whose errors the test's own forward kinematics (scipy) checks


def rest_rotation(direction):
    """The shortest turn of +Y onto direction, as w x y z."""
    d = direction / np.linalg.norm(direction)
    y = np.array([0.0, 1.0, 0.0])
    c = float(y @ d)
    if c < -1 + 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])
    axis = np.cross(y, d)
    q = np.array([1.0 + c, *axis])
    return q / np.linalg.norm(q)


def make_rig(native, names, parents, heads, tails):
    """A Rig and what the tests need of it: (rig, arrays, parents, size), arrays the rig as rig_fk takes it
    (parents, rest, heads, lengths)."""
    heads, tails = np.asarray(heads, float), np.asarray(tails, float)
    rest = np.array([rest_rotation(t - h) for h, t in zip(heads, tails)])
    lengths = np.linalg.norm(tails - heads, axis=1)
    size = float(np.linalg.norm(np.ptp(np.vstack([heads, tails]), axis=0)))
    arrays = (list(parents), rest, heads, lengths)
    return native.Rig(list(names), list(parents), rest, heads, lengths), arrays, list(parents), size


def walk60_rig(native, path):
    """walk60's joints as bones (head at the joint, tail at its first child or end site), Z up."""
    skeleton, _ = native.read_bvh(path)
    offsets, parents = np.array(skeleton.offsets), list(skeleton.parents)
    heads = np.zeros_like(offsets)
    for i, p in enumerate(parents):
        heads[i] = offsets[i] if p < 0 else heads[p] + offsets[i]
    heads = heads[:, [0, 2, 1]] * np.array([1.0, -1.0, 1.0])  # Y up -> Z up
    joints = [i for i, end in enumerate(skeleton.end_sites) if not end]
    index = {j: k for k, j in enumerate(joints)}
    tails = []
    for j in joints:
        kids = [i for i, p in enumerate(parents) if p == j]
        tail = heads[kids[0]] if kids else heads[j] + [0.0, 0.0, 0.05]
        tails.append(tail if np.linalg.norm(tail - heads[j]) > 1e-6 else heads[j] + [0.0, 0.0, 0.05])
    names = [skeleton.names[j] for j in joints]
    built = make_rig(native, names, [index.get(parents[j], -1) for j in joints], heads[joints], tails)
    return built + ([names.index("lWrist"), names.index("rWrist")],
                    [names.index("lToeJoint"), names.index("rToeJoint")])


def sixty_bone_rig(native):
    """Hips, 6 spine, 2 neck, head, 2 arms of 4 with 4 three-bone fingers each, 2 legs of 4, a tail."""
    names, parents, heads, tails = [], [], [], []

    def add(name, parent, head, tail):
        names.append(name)
        parents.append(-1 if parent is None else names.index(parent))
        heads.append(np.asarray(head, float))
        tails.append(np.asarray(tail, float))
        return name

    add("hips", None, (0, 0, 1.0), (0, 0, 1.1))
    parent, z = "hips", 1.1
    for i in range(6):
        parent = add(f"spine{i}", parent, (0, 0, z), (0, 0, z + 0.08))
        z += 0.08
    chest = parent
    parent = add("neck0", chest, (0, 0, z), (0, 0, z + 0.05))
    parent = add("neck1", parent, (0, 0, z + 0.05), (0, 0, z + 0.1))
    add("head", parent, (0, 0, z + 0.1), (0, 0, z + 0.3))
    hands, feet = [], []
    for side, s in (("L", 1.0), ("R", -1.0)):
        x = np.array([s, 0.0, 0.0])
        parent, head = chest, np.array([0.03 * s, 0.0, z - 0.04])
        for k, length in enumerate((0.15, 0.28, 0.26, 0.08)):
            parent = add(f"arm{side}{k}", parent, head, head + length * x)
            head = head + length * x
        hands.append(len(names) - 1)
        for f in range(4):
            p, h = f"arm{side}3", head + [0.0, 0.02 * (f - 1.5), 0.0]
            for k in range(3):
                p = add(f"finger{side}{f}{k}", p, h, h + 0.03 * x)
                h = h + 0.03 * x
        parent, head = "hips", np.array([0.1 * s, 0.0, 1.0])
        for k, (d, length) in enumerate(((np.array([0.0, 0.0, -1.0]), 0.45), (np.array([0.0, 0.0, -1.0]), 0.45),
                                         (np.array([0.0, -0.8, -0.6]), 0.1), (np.array([0.0, -1.0, 0.0]), 0.05))):
            parent = add(f"leg{side}{k}", parent, head, head + length * d)
            head = head + length * d
        feet.append(len(names) - 1)
    parent, head = "hips", np.array([0.0, 0.05, 1.0])
    while len(names) < 60:
        parent = add(f"tail{len(names)}", parent, head, head + [0.0, 0.05, -0.01])
        head = head + [0.0, 0.05, -0.01]
    return make_rig(native, names, parents, heads, tails) + (hands, feet)


def random_rotations(rng, count, spread):
    v = rng.normal(scale=spread, size=(count, 3))
    angle = np.linalg.norm(v, axis=1, keepdims=True)
    return np.hstack([np.cos(angle / 2), np.sin(angle / 2) * v / np.maximum(angle, 1e-12)])


def tails_of(arrays, rotations, root_locations, bones):
    """The chosen bones' tails (frames, 3 x len(bones)) by the test's own forward kinematics (scipy,
    tests/common/rig_fk.py), which shares no code with the solver."""
    _, _, tails = rig_fk.pose(*arrays, rotations, root_locations)
    return tails[:, bones].reshape(len(rotations), -1)


def problems(native, built, count, seed):
    """Input poses A (random) and hand targets from B: A with everything but the legs moved, so the feet
    stay and pinning them while reaching the hands has a solution (B)."""
    _, arrays, parents, _, hands, feet = built
    bones = len(parents)
    rng = np.random.default_rng(seed)
    a = random_rotations(rng, count * bones, 0.35).reshape(count, 4 * bones)
    locations = rng.normal(scale=0.05, size=(count, 3))
    legs = set()
    for bone in feet:
        while bone > 0:
            legs.add(bone)
            bone = parents[bone]
    b = a.copy()
    for bone in range(1, bones):
        if bone not in legs:
            b[:, 4 * bone:4 * bone + 4] = random_rotations(rng, count, 0.35)
    hand_targets = tails_of(arrays, b, locations, hands)
    return a, locations, np.ascontiguousarray(np.hstack([hand_targets, np.zeros((count, 6))]))


def solve(native, built, a, locations, targets, method, **options):
    rig, _, _, _, hands, feet = built
    effectors = ([native.IkEffector(h, name=f"hand {i}") for i, h in enumerate(hands)] +
                 [native.IkEffector(f, name=f"foot {i}", pin=True) for i, f in enumerate(feet)])
    return native.ik_solve(rig, a, locations, targets, np.zeros((len(a), 0)), effectors,
                           options=native.IkOptions(method=method, root_translation=True, root_rotation=True,
                                                    warm_start=False, **options))


def fk_errors(native, built, a, locations, targets, out):
    """Each effector's distance from its goal, from the test's own forward kinematics of the returned pose
    (not the solver's error output, nor the native armature pose): hands from their targets, pinned feet
    from where the input pose has them."""
    _, arrays, _, _, hands, feet = built
    count = len(a)
    rotations, root_locations = out.rotations[:count], out.root_locations[:count]  # out may hold more cases
    solved_hands = tails_of(arrays, rotations, root_locations, hands).reshape(count, -1, 3)
    solved_feet = tails_of(arrays, rotations, root_locations, feet).reshape(count, -1, 3)
    pinned = tails_of(arrays, a, locations, feet).reshape(count, -1, 3)
    goals = targets[:, :3 * len(hands)].reshape(count, -1, 3)
    return np.hstack([np.linalg.norm(solved_hands - goals, axis=2), np.linalg.norm(solved_feet - pinned, axis=2)])


@pytest.fixture(scope="module")
def rigs(native, shared_files):
    walk = next(f for f in shared_files if os.path.basename(f) == "walk60.bvh")
    return {"walk60": walk60_rig(native, walk), "60-bone": sixty_bone_rig(native)}


@pytest.mark.parametrize("name", ["walk60", "60-bone"])
def test_dls_converges_on_random_reachable_problems(native, rigs, name):
    built = rigs[name]
    size = built[3]
    a, locations, targets = problems(native, built, RATE_CASES, seed=3)
    rates = {}
    for method in ("dls", "ccd", "transpose"):
        out = solve(native, built, a, locations, targets, method)
        # The solver's own error output against the test's forward kinematics (scipy, sharing no code with
        # the solver) of the returned pose, on the first FK_CASES: the rate counts errors proven so.
        checked = fk_errors(native, built, a[:FK_CASES], locations[:FK_CASES], targets[:FK_CASES], out)
        np.testing.assert_allclose(out.errors[:FK_CASES], checked, rtol=0, atol=1e-9 * size)
        rates[method] = float(np.mean(np.all(out.errors < 1e-4 * size, axis=1)))
    print(f"\n{name}: {RATE_CASES:,} problems (2 hands, 2 pinned feet, hips free), converged to 1e-4 of the "
          "size: " + ", ".join(f"{m} {100 * r:.2f} %" for m, r in rates.items()))
    assert rates["dls"] >= 0.995


def test_a_million_random_solves_give_no_nan(native, rigs):
    """Random targets anywhere (unreachable ones too), straight and degenerate starts, coincident targets:
    25,000 per method here (every kind of start and target, 30 s), the million (250,000 per method, minutes)
    in the long tier (`make test-long` sets MOTIONKIT_LONG=1)."""
    built = rigs["walk60"]
    rig, _, parents, size, hands, feet = built
    rng = np.random.default_rng(11)
    count = 250_000 if os.environ.get("MOTIONKIT_LONG") == "1" else 25_000
    bones = len(parents)
    for k, method in enumerate(("dls", "pinv", "ccd", "transpose")):
        a = random_rotations(rng, count * bones, 0.5).reshape(count, 4 * bones)
        a[: count // 4] = np.tile([1.0, 0.0, 0.0, 0.0], bones)  # the straight rest pose: singular chains
        targets = rng.normal(scale=2.0 * size, size=(count, 12))  # mostly out of reach
        targets[count // 2: 5 * count // 8, 3:6] = targets[count // 2: 5 * count // 8, 0:3]  # coincident
        targets[5 * count // 8: 3 * count // 4] = 0.0  # all at the origin
        out = solve(native, built, a, np.zeros((1, 3)), np.ascontiguousarray(targets), method, max_iterations=8)
        for key in ("rotations", "root_locations", "scales", "errors"):
            value = getattr(out, key)
            assert np.all(np.isfinite(value)), (method, key)

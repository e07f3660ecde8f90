"""core/body_clearance: an arm driven into Big Vegas' belly brought back out, judged by the winding number
of the mesh skinned independently (linear blend skinning on rig_fk's posing, tests/common), not by the
field the stage reads; what else it must leave alone, to the doubles' rounding."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import bodies
import rig_fk
from core import body as body_module
from core import body_clearance

FPS = 30.0
FRAMES = 60


@pytest.fixture(scope="module")
def vegas(shared_bodies):
    return bodies.load(shared_bodies, "Big_Vegas")


def _quaternions(rotvecs):
    return np.roll(Rotation.from_rotvec(rotvecs).as_quat(), 1, axis=-1)


def _into_the_belly(rig, still: int = 0, reach: float = 1.0):
    """FRAMES frames (and still frames at rest before and after): the left arm swung down and its forearm
    across into the belly and back (a sine), the right arm still; found once by hand, 7 cm deep at the
    middle frame (reach: the share of that swing; 0.87 stops the hand 5 cm off the belly)."""
    rotations = np.tile([1.0, 0.0, 0.0, 0.0], (FRAMES + 2 * still, len(rig)))
    rise = reach * np.concatenate([np.zeros(still), np.sin(np.linspace(0.0, np.pi, FRAMES)), np.zeros(still)])[:, None]
    for name, rotvec in (("LeftArm", [-0.785, -0.156, 0.941]), ("LeftForeArm", [1.792, -1.511, 1.817])):
        b = rig.index("mixamorig:" + name)
        rotations[:, 4 * b:4 * b + 4] = _quaternions(rise * np.array(rotvec))
    return rotations


def _skinned(rig, mesh, rotations):
    """(frames, V, 3) the mesh deformed by each vertex's heaviest bone (rig_fk posing)."""
    orientations, heads, _ = rig_fk.pose(rig.parents, rig.unit_rest, rig.heads, rig.lengths, rotations)
    out = np.empty((len(rotations), len(mesh.vertices), 3))
    for b in np.unique(mesh.bone):
        on = mesh.bone == b
        local = Rotation.from_quat(np.roll(rig.unit_rest[b], -1)).inv().apply(mesh.vertices[on] - rig.heads[b])
        for f in range(len(rotations)):
            out[f, on] = orientations[b][f].apply(local) + heads[f, b]
    return out, orientations


def _arm_inside(rig, mesh, world):
    """(frames,) the share of the left forearm's and hand's vertices inside the trunk, head and thighs."""
    labels = body_module.parts(rig, rig.body)
    on_body = np.array([b >= 0 and labels[b] in body_module.BODY_PARTS for b in mesh.bone])
    triangles = mesh.triangles[on_body[mesh.triangles].all(axis=1)]
    arm = np.isin(mesh.bone, [rig.index("mixamorig:LeftForeArm"), rig.index("mixamorig:LeftHand")])
    return np.array([np.mean(bodies.winding_numbers(w[arm], w, triangles) > 0.5) for w in world])


def test_an_arm_in_the_belly_comes_out_and_its_hand_keeps_its_direction(vegas, core_native):
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    before = _into_the_belly(rig)
    after = before.copy()
    cleared = body_clearance.clear(body, after, np.zeros((FRAMES, 3 * len(rig))), FPS)
    every = slice(None, None, 3)  # every third frame: the winding number is the test's slow part
    world_before, _ = _skinned(rig, mesh, before[every])
    world_after, orientations = _skinned(rig, mesh, after[every])
    inside_before, inside_after = _arm_inside(rig, mesh, world_before), _arm_inside(rig, mesh, world_after)
    assert inside_before.max() > 0.2 and cleared.went_in["L"].sum() > 5 and not cleared.went_in["R"].any()
    # Out: the field keeps half a cell, more than its sqrt(3)/2-cell error beside a cell's corner at worst.
    assert inside_after.max() <= 0.01
    hand = rig.index("mixamorig:LeftHand")
    fk_before = rig_fk.pose(rig.parents, rig.unit_rest, rig.heads, rig.lengths, before[every])[0]
    turn = (orientations[hand] * fk_before[hand].inv()).magnitude()
    assert turn.max() < 1e-9  # the hand's world orientation kept
    changed = [rig.names[b] for b in range(len(rig))
               if not np.allclose(after[:, 4 * b:4 * b + 4], before[:, 4 * b:4 * b + 4], atol=1e-15)]
    assert changed == ["mixamorig:LeftArm", "mixamorig:LeftForeArm", "mixamorig:LeftHand"]


def test_the_arm_leaves_and_meets_the_body_without_a_pop(vegas, core_native):
    """The frames around those that go in ease into the turn: on every frame the change of the upper arm and
    the forearm is no more than the motion's own (up to 3.8 and 10.6 degrees a frame here) plus 2 degrees,
    and the frames far from the body are left exactly."""
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    before = _into_the_belly(rig, still=60)
    after = before.copy()
    cleared = body_clearance.clear(body, after, np.zeros((len(before), 3 * len(rig))), FPS)
    fk = lambda r: rig_fk.pose(rig.parents, rig.unit_rest, rig.heads, rig.lengths, r)[0]  # noqa: E731
    own, moved = fk(before), fk(after)
    for name in ("LeftArm", "LeftForeArm"):
        b = rig.index("mixamorig:" + name)
        step = lambda g: np.degrees((g[1:] * g[:-1].inv()).magnitude())  # noqa: E731
        # Frame by frame, not only at the clip's fastest.
        assert np.all(step(moved[b]) <= step(own[b]) + 2.0)
    # The ease reaches as far as the largest turn asks (EASE_RATE), and no farther.
    turned = np.any(cleared.turns["L"] != 0.0, axis=1)
    assert (~turned).sum() > 40
    np.testing.assert_array_equal(after[~turned], before[~turned])


def test_nothing_moves_where_no_arm_goes_in(vegas, core_native):
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    rest = np.tile([1.0, 0.0, 0.0, 0.0], (FRAMES, len(rig)))
    after = rest.copy()
    cleared = body_clearance.clear(body, after, np.zeros((FRAMES, 3 * len(rig))), FPS)
    assert not any(w.any() for w in cleared.went_in.values())
    np.testing.assert_array_equal(after, rest)


def test_strength_scales_the_turn_and_a_side_left_out_is_left(vegas, core_native):
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    before = _into_the_belly(rig)
    full, half, none = before.copy(), before.copy(), before.copy()
    a = body_clearance.clear(body, full, np.zeros((FRAMES, 3 * len(rig))), FPS)
    b = body_clearance.clear(body, half, np.zeros((FRAMES, 3 * len(rig))), FPS, strength=0.5)
    body_clearance.clear(body, none, np.zeros((FRAMES, 3 * len(rig))), FPS, sides=("R",))
    np.testing.assert_allclose(b.turns["L"], 0.5 * a.turns["L"], atol=1e-12)
    np.testing.assert_array_equal(none, before)


def _body_skin(rig, mesh):
    """(the trunk, head and thighs' triangles, the left hand's vertices (bools), a function of a posed mesh's
    vertices giving its body skin sampled six a triangle's side: tests/python/test_body.py's way)."""
    from test_body import _surface_samples
    from core.skinned_mesh import SkinnedMesh
    labels = body_module.parts(rig, rig.body)
    on_body = np.array([b >= 0 and labels[b] in body_module.BODY_PARTS for b in mesh.bone])
    triangles = mesh.triangles[on_body[mesh.triangles].all(axis=1)]
    hand = mesh.bone == rig.index("mixamorig:LeftHand")
    return triangles, hand, lambda w: _surface_samples(SkinnedMesh(w, triangles, mesh.bone, mesh.weight))


def _hand_gap(rig, mesh, world):
    """(frames,) the left hand's vertices' nearest distance to the trunk, head and thighs (0 inside)."""
    triangles, hand, skin = _body_skin(rig, mesh)
    out = []
    for w in world:
        if np.any(bodies.winding_numbers(w[hand], w, triangles) > 0.5):
            out.append(0.0)
            continue
        surface = skin(w)
        out.append(min(np.sqrt(((surface - p) ** 2).sum(axis=1).min()) for p in w[hand][::4]))
    return np.array(out)


@pytest.mark.parametrize("reach", [0.87, 0.3], ids=["5 cm off", "beyond the field"])
def test_a_hand_the_source_touches_its_body_with_comes_onto_the_target_s(vegas, core_native, reach):
    """The arm swung to stop the hand 5 cm off the belly, or farther than the field reaches (a third of the
    swing: more than MARGIN beyond the skin, where its gradient pulls nothing); asked to touch on the middle
    ten frames (the source's touches) with no place, the hand comes onto the belly there the nearest way:
    within two cells of the skin (a cell the field's reading, half a cell kept, the sample's sixth of an
    edge), against the mesh skinned independently, the arm kept out."""
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    before = _into_the_belly(rig, reach=reach)
    after = before.copy()
    touches = {"L": np.zeros(FRAMES, dtype=bool)}
    touches["L"][25:35] = True
    cleared = body_clearance.clear(body, after, np.zeros((FRAMES, 3 * len(rig))), FPS, touches=touches)
    middle = slice(25, 35, 3)
    gap_before = _hand_gap(rig, mesh, _skinned(rig, mesh, before[middle])[0])
    gap_after = _hand_gap(rig, mesh, _skinned(rig, mesh, after[middle])[0])
    assert gap_before.min() > (0.04 if reach > 0.5 else body_module.MARGIN * body.height)
    assert cleared.went_in["L"][25:35].all()
    assert gap_after.max() < 2.0 * body.spacing
    assert _arm_inside(rig, mesh, _skinned(rig, mesh, after[middle])[0]).max() <= 0.01


def test_a_clearance_beyond_the_field_s_reach_asks_only_what_it_can_measure(vegas, core_native):
    """A source whose arm is far from its body everywhere (its clearance +inf, off its own field) asks the
    target's arm out as far as the target's field reaches, never a turn that is not finite."""
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    before = _into_the_belly(rig)
    after = before.copy()
    body_clearance.clear(body, after, np.zeros((FRAMES, 3 * len(rig))), FPS, clearance={"L": np.full(FRAMES, np.inf)})
    assert np.all(np.isfinite(after))
    changed = np.any(after != before, axis=1)
    assert changed.sum() > 10


def _touch_patch(rig, mesh, world):
    """(frames, 3) where the left hand touches the body on each frame of the mesh skinned independently: the
    centre of the trunk, head and thighs' skin (sampled six a triangle's side) within a centimetre more than
    the nearest of the hand's vertices is of it (a patch: the nearest single point jumps about a flat hand)."""
    _, hand, skin = _body_skin(rig, mesh)
    out = []
    for w in world:
        surface = skin(w)
        gaps = np.linalg.norm(surface[:, None, :] - w[hand][None, ::2, :], axis=2).min(axis=1)
        out.append(surface[gaps <= gaps.min() + 0.01].mean(axis=0))
    return np.array(out)


def _source_touching(rig, body, core_native):
    """(rotations, locations, touching(), touch_places()) of a source whose left hand is on the belly: the
    swing stopped 0.7-1.4 cm off it on its middle eight frames."""
    source, locations = _into_the_belly(rig, reach=0.92), np.zeros((FRAMES, 3 * len(rig)))
    orientations, heads = core_native.armature_pose(rig.native, source, locations)
    touches = body_clearance.touching(body, orientations, heads)
    return source, locations, touches, body_clearance.touch_places(body, orientations, heads, touches)


def _hand_turned_as(rig, rotations, like, core_native):
    """rotations with the left hand's channel set so that the hand lies in the armature as it does in like (a
    retarget's hand: the source's orientation), by the rig's own posing (parent * rest offset * channel)."""
    from core import rotation_channels as rc
    b = rig.index("mixamorig:LeftHand")
    p = rig.parents[b]
    zeros = np.zeros((len(rotations), 3 * len(rig)))
    wanted = core_native.armature_pose(rig.native, like, zeros)[0][:, 4 * b:4 * b + 4]
    parent = core_native.armature_pose(rig.native, rotations, zeros)[0][:, 4 * p:4 * p + 4]
    offset = rc.multiply(rc.conjugate(rig.unit_rest[b])[None], rig.unit_rest[p][None])
    out = rotations.copy()
    out[:, 4 * b:4 * b + 4] = rc.multiply(np.broadcast_to(offset, wanted.shape), rc.multiply(rc.conjugate(parent), wanted))
    return out


def test_a_hand_the_source_touches_its_body_with_comes_onto_the_target_s_at_the_same_place(vegas, core_native):
    """The source's hand on the belly (the swing stopped 0.7-1.4 cm off it on its middle eight frames, touching
    by touching()); the target the same character with the arm only half-way there, its hand turned as the
    source's (as a retarget leaves it): asked to touch at the source's places (touch_places), its hand comes
    onto the belly where the source's touches it, by the mesh skinned independently (the centre of the skin it
    touches within 2 cells of the source's: half a cell kept off the skin, the field's sqrt(3)/2 cell and the
    patch's sixth of an edge; measured 0.1-0.4 cm, cells of 1.6 cm), its arm kept out; where the nearest way
    takes it (no places), more than 5 cm from there (7.6-9.6)."""
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    source, locations, touches, places = _source_touching(rig, body, core_native)
    middle = slice(26, 34, 2)
    assert touches["L"][26:34].all() and not touches["R"].any()
    assert {rig.names[b] for b in places["L"].bone[touches["L"]]} <= {"mixamorig:Spine", "mixamorig:Spine1",
                                                                      "mixamorig:Spine2", "mixamorig:Hips"}
    touched = _touch_patch(rig, mesh, _skinned(rig, mesh, source[middle])[0])
    gaps = {}
    for kind, given in (("place", places), ("nearest", None)):
        after = _hand_turned_as(rig, _into_the_belly(rig, reach=0.5), source, core_native)
        body_clearance.clear(body, after, locations, FPS, touches=touches, places=given)
        world = _skinned(rig, mesh, after[middle])[0]
        gaps[kind] = np.linalg.norm(_touch_patch(rig, mesh, world) - touched, axis=1)
        assert _arm_inside(rig, mesh, world).max() <= 0.01
    assert gaps["place"].max() < 2.0 * body.spacing
    assert gaps["nearest"].min() > 0.05


def test_a_place_the_hand_cannot_reach_from_outside_the_body_is_touched_the_nearest_way(vegas, core_native):
    """The source's touch place moved to the far side of the target's body (its offset from the spine bone
    turned to the back, where the belly is in front): reaching it would take the arm through the body (driven
    there it goes 66-77 % inside). The clearance comes first: the arm stays out (at most 1 % inside, as the
    other tests) and the hand, 5 cm off the belly before, touches the nearest way (within two cells of the
    skin, as the nearest-way test: measured 1.1-2.3 cm, cells of 1.6 cm)."""
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    source, locations, touches, places = _source_touching(rig, body, core_native)
    place = places["L"]
    behind = place.offset * np.array([1.0, -1.0, 1.0])  # the front is +Y here: the belly's vertices reach it
    assert np.nanmin(behind[:, 1]) < -0.2  # 20 cm behind the spine bone's head at least
    after = _into_the_belly(rig, reach=0.87)
    body_clearance.clear(body, after, locations, FPS, touches=touches,
                         places={"L": body_clearance.Place(place.bone, behind, place.hand, place.reach)})
    world = _skinned(rig, mesh, after[26:34:2])[0]
    assert _arm_inside(rig, mesh, world).max() <= 0.01
    assert _hand_gap(rig, mesh, world).max() < 2.0 * body.spacing


def test_between_two_runs_of_frames_that_go_in_the_turn_passes_from_one_to_the_other_without_a_pop():
    """Two runs of frames solved 50 frames apart, their turns a radian apart (the elbow's the same): every frame
    between them changes by no more than 2 degrees (the line between them: 1.15 degrees a frame), where taking
    the nearer run's turn would jump by half their difference halfway (the ease still near one there)."""
    frames = np.r_[np.arange(10), np.arange(60, 70)]
    solved = np.zeros((20, 6))
    solved[:10, 0], solved[10:, 1] = 0.7071, 0.7071
    turns = body_clearance._spread_turns(frames, solved, 70, FPS)
    step = np.degrees(np.maximum(np.linalg.norm(np.diff(turns[:, :3], axis=0), axis=1),
                                 np.linalg.norm(np.diff(turns[:, 3:], axis=0), axis=1)))
    assert step.max() <= 2.0
    np.testing.assert_allclose(turns[frames[[4, 15]], :2], [[0.7071, 0.0], [0.0, 0.7071]], atol=1e-3)


def test_a_touching_point_off_the_target_s_hand_is_taken_to_its_own_skin_nearest_there(vegas, core_native):
    """The source's touches as the same-place test has them (the hand turned as the source's), but the source's
    touching point three times as far from its wrist (a hand of another shape: a cartoon glove's, 9 cm off
    this hand's palm): the target's hand touches with its own skin point nearest there, so it comes onto the
    belly, within two cells of the skin by the mesh skinned independently (measured 0.7-1.2 cm); brought there
    itself, the point in space would hold the palm 9 cm off it."""
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    source, locations, touches, places = _source_touching(rig, body, core_native)
    place = places["L"]
    assert np.nanmin(np.linalg.norm(place.hand, axis=1)) > 0.04
    after = _hand_turned_as(rig, _into_the_belly(rig, reach=0.5), source, core_native)
    body_clearance.clear(body, after, locations, FPS, touches=touches,
                         places={"L": body_clearance.Place(place.bone, place.offset, 3.0 * place.hand, place.reach)})
    assert _hand_gap(rig, mesh, _skinned(rig, mesh, after[26:34:2])[0]).max() < 2.0 * body.spacing



def test_a_turn_that_jumps_is_spread_at_the_turn_rate_and_the_frames_away_from_it_are_left():
    """A shoulder's turn that jumps by a radian from one frame to the next (a goal switching places) comes out
    changing by no more than TURN_RATE allows a frame (1.0e-9 for the comparison's rounding), as a ramp about
    the jump: the frames half a second away keep their turns to the bit; a turn changing slower (the elbow's,
    a line) is left, to the rounding of its neighbours' mean."""
    turns = np.zeros((120, 6))
    turns[60:, 0], turns[:, 4] = 1.0, np.linspace(0.0, 0.3, 120)
    limited = body_clearance._limited(turns, FPS)
    step = np.linalg.norm(np.diff(limited.reshape(120, 2, 3), axis=0), axis=2)
    assert step.max() <= np.radians(body_clearance.TURN_RATE) / FPS + 1e-9
    assert np.array_equal(limited[:45], turns[:45]) and np.array_equal(limited[75:], turns[75:])
    np.testing.assert_allclose(limited[:, 3:], turns[:, 3:], rtol=0, atol=1e-14)  # a line's average: itself
    assert 0.3 < limited[59, 0] < 0.5 and 0.5 < limited[60, 0] < 0.7


def test_a_touching_place_that_jumps_or_is_missing_is_joined_into_one_path(vegas, core_native):
    """Goals on touching frames that switch every other frame between two places 10 cm apart, and are missing
    on some (no place the arm reaches): on every touching frame the goal is one, half a cell off the skin (by
    the field), moving less from frame to frame than the switching (a Gaussian of SPREAD over it), and the
    frames not touching have none."""
    rig, mesh = vegas
    body = body_module.Body.of(rig, mesh)
    source, locations, touches, places = _source_touching(rig, body, core_native)
    orientations, heads = core_native.armature_pose(rig.native, source, locations)
    arm = [a for a in body_clearance.arms(body) if a.side == "L"][0]
    goals, contacts = body_clearance._goals(body, arm, places["L"], orientations, heads, FPS)
    on = np.flatnonzero(touches["L"])
    jumping = goals.copy()
    jumping[on[1::2]] += [0.0, 0.0, 0.1]
    jumping[on[2:4]] = np.nan
    joined, held = body_clearance._joined(body, arm, jumping, contacts, touches["L"], orientations, heads, FPS)
    assert np.all(np.isfinite(joined[on])) and np.all(np.isnan(np.delete(joined, on, axis=0)))
    distance = body.posed(joined[on][:, None, :], orientations[on], heads[on])[:, 0]
    np.testing.assert_allclose(distance, 0.5 * body.spacing, atol=0.1 * body.spacing)
    moved = np.linalg.norm(np.diff(joined[on], axis=0), axis=1)
    assert moved.max() < 0.5 * np.linalg.norm(np.diff(jumping[on[4:]], axis=0), axis=1).min()
    assert np.all(np.isfinite(held[on]))

"""set_key_values leaves Auto handles to Blender: the keys it leaves are, bit for bit, those Blender's own
fcurve.update() makes of the same values (the reference: every key's value set through RNA, then update()),
whether it updates them through update() or, given the keys' frames, through handles_recalc() (4.x)."""
import bpy
import numpy as np
import pytest


def _keys(fcurve) -> dict:
    points = fcurve.keyframe_points
    out = {}
    for prop in ("co", "handle_left", "handle_right"):
        out[prop] = np.empty(2 * len(points), dtype=np.float32)
        points.foreach_get(prop, out[prop])
    return out


@pytest.mark.parametrize("handles", ["AUTO", "AUTO_CLAMPED", "FREE"])
@pytest.mark.parametrize("smoothing", ["NONE", "CONT_ACCEL"])
def test_new_values_leave_the_keys_updates_makes(animdata, handles, smoothing):
    obj = bpy.data.objects.new("Keys", None)
    bpy.context.scene.collection.objects.link(obj)
    action = animdata.new_action("Keys")
    rng = np.random.default_rng(36)
    n = 500
    frames = np.cumsum(rng.uniform(0.3, 2.0, n))
    start = np.cumsum(rng.normal(size=n))
    ways = ("rna", "update", "handles_recalc")
    curves = animdata.write_keys(obj, action, [("location", k) for k in range(len(ways))], frames,
                                 np.tile(start, (len(ways), 1)), interpolation='BEZIER')
    for fcurve in curves:
        fcurve.auto_smoothing = smoothing
        for point in fcurve.keyframe_points:
            point.handle_left_type = point.handle_right_type = handles
        fcurve.update()
    new = 3.0 * rng.normal(size=n)
    for point, value in zip(curves[0].keyframe_points, new):  # Blender's own way, key by key
        point.co.y = value
    curves[0].update()
    animdata.set_key_values(obj, action, [("location", 1)], new[None])
    animdata.set_key_values(obj, action, [("location", 2)], new[None], frames=frames)
    expected = _keys(curves[0])
    for way, fcurve in zip(ways[1:], curves[1:]):
        got = _keys(fcurve)
        for prop in expected:
            if handles == "FREE" and prop != "co":
                continue  # RNA's co leaves Free handles behind; set_key_values moves them with the key
            np.testing.assert_array_equal(got[prop], expected[prop], err_msg=f"{way}: {prop}")

"""The native squad (resample's default rotation interpolant) against Shoemake's published formula,
computed in the test (tests/common/squad_reference.py), not against the native code's own figures."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import squad_reference
from rotations import quaternion_angles

# Both sides are float64 compositions of about thirty quaternion products, logs and exps of angles under
# a half turn, each exact to a unit or two of 2.2e-16 relative, and the logs lose nothing near zero
# (arctan2 of the vector part against w): the curves agree to ~30 * 2.2e-16 rad at worst; measured 1.2e-15
# rad (x86-64, these 9 cases). The bound is about ten times that.
TOLERANCE = 1e-14


def _keys(n, seed, spread):
    """n keys, each turned from the last by a random turn of about `spread` radians, with random signs
    (q and -q, the same rotation) and scales (the native code normalises its keys)."""
    rng = np.random.default_rng(seed)
    turns = Rotation.from_rotvec(rng.normal(scale=spread, size=(n, 3)))
    rotations = [Rotation.random(random_state=seed)]
    for turn in turns[1:]:
        rotations.append(rotations[-1] * turn)
    q = np.roll(Rotation.concatenate(rotations).as_quat(), 1, axis=-1)
    return np.ascontiguousarray(q * rng.choice([-1.0, 1.0], size=(n, 1)) * rng.uniform(0.5, 2.0, size=(n, 1)))


@pytest.mark.parametrize("spread", [0.05, 0.5, 1.2])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_squad_is_shoemakes_formula(native, seed, spread):
    """At 2,000 times over 12 equally spaced keys (steps of 0.5 frames from frame 3.25, the keys included),
    small to large turns between keys (spread 1.2: steps of about 2 rad, where the slerps' signs matter)."""
    times = 3.25 + 0.5 * np.arange(12)
    keys = _keys(12, seed, spread)
    at = np.concatenate([np.linspace(times[0], times[-1], 2000), times])
    ours = native.interpolate_rotations(times, keys, at, "squad")
    theirs = squad_reference.squad(times, keys, at)
    worst = quaternion_angles(ours, theirs).max()
    print(f"\nseed {seed}, spread {spread}: squad against Shoemake's formula, worst {worst:.3g} rad")
    assert worst < TOLERANCE


def test_the_reference_is_not_slerp(native):
    """The formula's inner quadrangle matters: the reference parts from plain slerp by far more than the
    tolerance, so an interpolant that dropped the s_i would fail the test above."""
    times = 0.5 * np.arange(12)
    keys = _keys(12, 1, 0.5)
    at = np.linspace(times[0], times[-1], 2000)
    apart = quaternion_angles(native.interpolate_rotations(times, keys, at, "slerp"),
                              squad_reference.squad(times, keys, at)).max()
    assert apart > 1e3 * TOLERANCE

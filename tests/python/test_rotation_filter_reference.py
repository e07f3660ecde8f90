"""filter_rotations' Butterworth and Gaussian against their algorithm written out with scipy: Rotation's
logarithm and exponential (closed forms) and scipy's sosfiltfilt and gaussian_filter1d on the tangents.
The native filter maps small angles by power series; this holds those maps to the closed forms, on
motion that takes the series (slow turns, small noise) and motion that does not (fast turns, large noise)."""
import numpy as np
import pytest
from rotations import quaternion_angles
from scipy import ndimage, signal
from scipy.spatial.transform import Rotation

CORRECTIONS, CONVERGED = 3, 1e-12  # FilterRotationsJob::kCorrections and kConverged


def wxyz(rotation):
    return rotation.as_quat()[..., [3, 0, 1, 2]]


def butterworth(order, cutoff, fps):
    sos = signal.butter(order, cutoff, fs=fps, output="sos")
    taps = 2 * len(sos) + 1  # sosfiltfilt's default padding; every section here is of second order
    return lambda x: signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=min(3 * taps, len(x) - 1))


def gaussian(sigma):
    return lambda x: ndimage.gaussian_filter1d(x, sigma, axis=0, mode="reflect")


def on_the_sphere(rotations, scalar):
    """Lee and Shin's filter as filter_rotations documents it: a reference integrated from the filtered
    angular velocities, then moved by the filtered deviation of the input from it, three times (fewer once
    the largest move is below CONVERGED radians)."""
    steps = scalar((rotations[:-1].inv() * rotations[1:]).as_rotvec())
    reference = [rotations[0]]
    for step in steps:
        reference.append(reference[-1] * Rotation.from_rotvec(step))
    reference = Rotation.concatenate(reference)
    for _ in range(CORRECTIONS):
        moves = scalar((reference.inv() * rotations).as_rotvec())
        reference = reference * Rotation.from_rotvec(moves)
        if np.linalg.norm(moves, axis=1).max() < CONVERGED:
            break
    return reference


def bones(frames, fps):
    """Three bones: a slow turn with 2 degrees of noise (every angle the filter maps is small), a fast spin
    (0.4 rad a frame) and 15 degrees of noise on a slow turn (angles above the series' range)."""
    rng = np.random.default_rng(36)
    t = np.arange(frames)[:, None] / fps
    slow = Rotation.from_rotvec(0.6 * np.sin(2 * np.pi * np.array([0.3, 0.5, 0.7]) * t + rng.uniform(0, 6, 3)))

    def noise(degrees):
        return Rotation.from_rotvec(rng.normal(0.0, np.radians(degrees) / np.sqrt(3), (frames, 3)))

    spin = Rotation.from_rotvec(12.0 * t * np.array([0.0, 0.6, 0.8])) * slow
    return [slow * noise(2.0), spin * noise(2.0), slow * noise(15.0)]


@pytest.mark.parametrize("kind, scalar, options", [
    ("butterworth", butterworth(4, 7.0, 30.0), dict(cutoff=7.0, order=4)),
    ("gaussian", gaussian(2.0), dict(sigma=2.0)),
])
def test_rotation_filter_is_its_algorithm_in_closed_forms(native, kind, scalar, options):
    fps, frames = 30.0, 300
    observed = bones(frames, fps)
    got = native.filter_rotations(np.ascontiguousarray(np.hstack([wxyz(r) for r in observed])), kind, fps,
                                  **options)
    for b, rotations in enumerate(observed):
        error = quaternion_angles(got[:, 4 * b:4 * b + 4], wxyz(on_the_sphere(rotations, scalar))).max()
        print(f"{kind}, bone {b}: {error:.2e} rad from the closed forms")
        # Both sides round at double precision through four filter passes of unit gain: measured at most
        # 8.1e-16 rad (Debian 12's numpy and scipy; the series and the closed forms alike), so ten times
        # that. A wrong series coefficient (atan's 1/5 as 1/6) gives 2.5e-9 rad, 1/w scaled by 1 + 1e-9
        # 1.3e-11 rad.
        assert error < 8e-15

"""Native errors name Blender's frames, not rows of the clip the core was given."""
import numpy as np
import pytest
from core import native_state


def test_frame_indices_become_blender_frames():
    frames = np.arange(11.0, 51.0)
    with pytest.raises(ValueError, match=r"^effector 'hand' target is not finite at frame 13 \(and frame 50\)$"):
        with native_state.blender_frames(frames):
            raise ValueError("effector 'hand' target is not finite at frame index 2 (and frame index 39)")


def test_other_errors_pass_unchanged():
    frames = np.array([1.0, 2.0])
    error = ValueError("no frame here")
    with pytest.raises(ValueError) as raised:
        with native_state.blender_frames(frames):
            raise error
    assert raised.value is error
    with pytest.raises(ValueError, match="at frame index 7$"):  # out of the clip: left as the core said it
        with native_state.blender_frames(frames):
            raise ValueError("at frame index 7")
    with pytest.raises(KeyError):
        with native_state.blender_frames(frames):
            raise KeyError("frame index 1")


def test_the_real_core_error_reads_in_frames(native):
    """ik_solve's own message for a non-finite target, through the helper: the frame of the timeline."""
    rig = native.Rig(["a", "b"], [-1, 0], np.tile([1.0, 0, 0, 0], (2, 1)), np.array([[0, 0, 0], [0, 1.0, 0]]),
                     np.array([1.0, 1.0]))
    count = 4
    targets = np.zeros((count, 3))
    targets[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"frame 103\b") as raised:
        with native_state.blender_frames(np.arange(101.0, 101.0 + count)):
            native.ik_solve(rig, np.tile([1.0, 0, 0, 0, 1.0, 0, 0, 0], (count, 1)), np.zeros((count, 3)), targets,
                            np.zeros((count, 0)), [native.IkEffector(1, name="tip")])
    assert "frame index" not in str(raised.value)

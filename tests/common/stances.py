"""Where a foot stands, by the tests' own rule (not the product's contact detector): its lowest point near
the lowest it comes in the clip and its ankle slow. Shared by the tests that measure slides and floors on
stance frames, so that a contact the detector misses, or one it makes up, shows."""
import numpy as np


def stance(low, ankles, leg, fps, height=0.04, speed=0.5):
    """(frames, k) bool: a foot (or point) stands where its lowest point low (frames, k) is within height
    legs above the lowest it comes in the clip (a Mixamo foot's ball is 10 cm above its sole: 4 % of the
    leg) and its ankle (frames, k, 3) moves slower than speed legs a second (central differences)."""
    low = np.asarray(low, dtype=np.float64)
    ankles = np.asarray(ankles, dtype=np.float64)
    pace = np.zeros(low.shape)
    pace[1:-1] = np.linalg.norm(ankles[2:] - ankles[:-2], axis=-1) * fps / 2
    pace[0], pace[-1] = pace[1], pace[-2]
    return (low - low.min(axis=0) < height * leg) & (pace < speed * leg)


def runs(mask, shortest=1):
    """[(column, first row, last row)] of each run of True in mask (frames, k) at least shortest rows long."""
    out = []
    for k in range(mask.shape[1]):
        on = np.flatnonzero(mask[:, k])
        if not on.size:
            continue
        for run in np.split(on, np.flatnonzero(np.diff(on) > 1) + 1):
            if run.size >= shortest:
                out.append((k, int(run[0]), int(run[-1])))
    return out


def slides(points, mask, shortest=1):
    """[(column, first, last, slide)]: per run of mask, how far points (frames, k, 3) stray across the floor
    (X and Y) from where they stand on the run's first frame."""
    return [(k, a, b, float(np.linalg.norm(points[a:b + 1, k, :2] - points[a, k, :2], axis=1).max()))
            for k, a, b in runs(mask, shortest)]

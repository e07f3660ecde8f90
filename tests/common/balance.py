"""The balance the IK keeps, measured independently of the solver: the centre of mass of bones at their
midpoints and how far it lies inside the support polygon of the feet, in the plane the native solver uses
(Eigen's unitOrthogonal of up). No Blender, no MotionKit."""
import numpy as np


def centre_of_mass(heads: np.ndarray, tails: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """The centre of mass of bones at their midpoints: heads, tails (..., B, 3), mass (B,)."""
    return np.einsum("...bk,b->...k", 0.5 * (heads + tails), mass) / mass.sum()


def support_polygon(points: np.ndarray, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """The convex hull (counter-clockwise about up) of points (N, 3) projected along up, in the
    plane's coordinates (side, ahead) that the native solver uses: side = up's unit orthogonal."""
    up = np.asarray(up, float) / np.linalg.norm(up)
    side, ahead = plane_axes(up)
    p = np.stack([points @ side, points @ ahead], axis=1)
    order = np.lexsort((p[:, 1], p[:, 0]))
    p = p[order]

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    hull = []
    for sweep in (p, p[::-1]):
        start = len(hull)
        for q in sweep:
            while len(hull) >= start + 2 and cross(hull[-2], hull[-1], q) <= 0:
                hull.pop()
            hull.append(q)
        hull.pop()
    return np.array(hull)


def plane_axes(up) -> tuple[np.ndarray, np.ndarray]:
    """Eigen's unitOrthogonal of up (as the solver), and up x it."""
    up = np.asarray(up, float)
    if abs(up[0]) > abs(up[2]) or abs(up[1]) > abs(up[2]):
        side = np.array([-up[1], up[0], 0.0])
    else:
        side = np.array([0.0, -up[2], up[1]])
    side /= np.linalg.norm(side)
    return side, np.cross(up, side)


def inside_distance(polygon: np.ndarray, point2) -> float:
    """How far a 2-D point lies inside a counter-clockwise convex polygon (negative: outside)."""
    best = np.inf
    for i in range(len(polygon)):
        a, b = polygon[i], polygon[(i + 1) % len(polygon)]
        d = b - a
        normal = np.array([-d[1], d[0]]) / np.linalg.norm(d)
        best = min(best, float(np.dot(normal, np.asarray(point2) - a)))
    return best

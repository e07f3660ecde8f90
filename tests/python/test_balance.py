"""The balance reference the IK tests measure with (tests/common/balance.py), against scipy and by hand."""
import balance
import numpy as np
import pytest
from scipy.spatial import ConvexHull


def test_support_polygon_and_inside_distance_against_scipy():
    rng = np.random.default_rng(4)
    for _ in range(50):
        points = np.c_[rng.normal(size=(8, 2)), rng.normal(size=8)]
        polygon = balance.support_polygon(points)
        side, ahead = balance.plane_axes([0.0, 0.0, 1.0])
        flat = np.stack([points @ side, points @ ahead], axis=1)
        hull = ConvexHull(flat)
        assert len(polygon) == len(hull.vertices)
        assert ConvexHull(polygon).volume == pytest.approx(hull.volume, rel=1e-12)
        p = rng.normal(size=2)
        # scipy's facets: normal . x + offset <= 0 inside; the distance inside is -max of those.
        expected = -np.max(hull.equations[:, :2] @ p + hull.equations[:, 2])
        assert balance.inside_distance(polygon, p) == pytest.approx(expected, abs=1e-12)


def test_centre_of_mass():
    heads = np.array([[0.0, 0, 0], [0, 0, 1]])
    tails = np.array([[0.0, 0, 1], [0, 0, 3]])
    assert balance.centre_of_mass(heads, tails, np.array([1.0, 3.0])) == pytest.approx([0, 0, 1.625])

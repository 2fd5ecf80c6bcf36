"""Condyle spheres fitted to a femoral surface (knee.preset = 'fit')."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import require_knee_data

from fecheck.errors import FecheckError
from fecheck.model.condyles import fitted_knee
from fecheck.scene import validate
from geometry.icosphere import icosphere
from geometry.mesh import TriMesh

CONDYLES = {"medial": ((-22.0, 3.0, 26.0), 27.0), "lateral": ((21.0, 1.0, 25.0), 25.0)}


def _femur() -> TriMesh:
    """The lower halves of two condyle spheres (a right knee), outward normals, one mesh."""
    parts = []
    for centre, radius in CONDYLES.values():
        ball = icosphere(radius, 5, centre, method="trimesh", cache=False)
        low = ball.face_centroids[:, 2] < centre[2]
        used, inverse = np.unique(ball.faces[low], return_inverse=True)
        parts.append(TriMesh(ball.points[used], inverse.reshape(-1, 3)))
    offset = parts[0].n_points
    return TriMesh(np.vstack([p.points for p in parts]),
                   np.vstack([parts[0].faces, parts[1].faces + offset]))


def test_fit_recovers_the_condyle_spheres_and_their_lowest_points():
    knee = fitted_knee(_femur(), "right")
    for c, (centre, radius) in CONDYLES.items():
        # face centroids sit inside the sphere by the faces' sagitta (~0.005 mm here)
        np.testing.assert_allclose(knee.condyle_center[c], centre, atol=0.02)
        assert knee.radius_mm(c) == pytest.approx(radius, abs=0.02)
        lowest = knee.condyle_center[c] - (0.0, 0.0, knee.radius_mm(c))
        np.testing.assert_allclose(knee.contact_point[c], lowest, atol=1e-12)


def test_a_left_knee_takes_the_condyles_the_other_way_round():
    knee = fitted_knee(_femur(), "left")
    assert knee.radius_mm("lateral") == pytest.approx(CONDYLES["medial"][1], abs=0.02)


def test_fit_reproduces_the_data_sets_own_sphere_fits():
    from fecheck.scene import lenhart

    require_knee_data()
    knee = fitted_knee(lenhart.mesh("femur_cartilage"), "right")
    fits = lenhart.read_fits()["fits"]
    for c in ("medial", "lateral"):
        ref = fits[f"femoral_condyle_{c}_sphere"]
        np.testing.assert_allclose(knee.condyle_center[c], ref["centre_mm"], atol=1e-3)
        assert knee.radius_mm(c) == pytest.approx(ref["radius_mm"], abs=1e-3)


@pytest.mark.parametrize("model, extra", [
    ({"kind": "femur-tibia"}, {}),
    ({"kind": "sphere-tibia"}, {"ligaments": {"model": "spring"}})])
def test_fit_is_refused_where_the_model_needs_more_than_spheres(model, extra):
    with pytest.raises(FecheckError, match="knee.preset = 'fit' fits the condyle spheres"):
        validate({"model": model, "knee": {"preset": "fit"}, **extra})


def test_too_few_condyle_faces_name_the_fix():
    flat = icosphere(25.0, 2, (0.0, 40.0, 0.0), method="trimesh", cache=False)  # trochlea
    with pytest.raises(FecheckError, match="look like the medial condyle.*knee.landmarks"):
        fitted_knee(flat, "right")

"""Building blocks of the perception pipeline on synthetic point sets with known answers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mycobot_planning.perception.cloud_processing import (
    PLANE_RSD_RADIUS, _smallest_eigen, as_point_array, crop_mask, estimate_features, voxel_downsample,
)
from mycobot_planning.perception.clustering import euclidean_clusters
from mycobot_planning.perception.errors import CloudFormatError
from mycobot_planning.perception.plane_segmentation import fit_plane_ransac
from mycobot_planning.perception.primitive_fitting import (
    PlaneFrame, _wrap_quarter, fit_circle_geometric, ransac_circle, ransac_line, rotation_from_z,
)


def cylinder_surface(radius: float, height: float, arc: float, n: int, noise: float, rng) -> np.ndarray:
    """Points on the visible arc (centred on -y) of an upright cylinder at the origin."""
    ang = rng.uniform(-math.pi / 2 - arc / 2, -math.pi / 2 + arc / 2, n)
    r = radius + rng.normal(0, noise, n)
    return np.column_stack([r * np.cos(ang), r * np.sin(ang), rng.uniform(0, height, n)])


def test_as_point_array_drops_non_finite_transforms_and_crops():
    pts = np.array([[0, 0, 0], [np.nan, 0, 0], [1, np.inf, 0], [2, 2, 2]], dtype=np.float32)
    out, cols = as_point_array(pts, np.full((4, 3), 7))
    assert out.dtype == np.float64 and out.tolist() == [[0, 0, 0], [2, 2, 2]] and cols.tolist() == [[7] * 3] * 2
    T = np.eye(4)
    T[:3, 3] = (1, 0, 0)
    out, _ = as_point_array(pts, transform=T, crop=((0.5, -1, -1), (1.5, 1, 1)))
    assert out.tolist() == [[1, 0, 0]]
    organised = np.zeros((2, 3, 3))
    assert as_point_array(organised)[0].shape == (6, 3)


@pytest.mark.parametrize("bad, message", [
    (np.zeros((0, 3)), "empty"),
    (np.full((5, 3), np.nan), "no finite point"),
    (np.zeros((5, 2)), r"shape \(N, 3\) or \(H, W, 3\)"),
    (np.array([["a", "b", "c"]]), "real numbers"),
    ([[1, 2, 3], [4, 5]], "not an array|real numbers"),
    (np.zeros((3, 3), dtype=complex), "real numbers"),
])
def test_as_point_array_rejects_garbage(bad, message):
    with pytest.raises(CloudFormatError, match=message):
        as_point_array(bad)


def test_colour_shape_mismatch_is_an_error():
    with pytest.raises(CloudFormatError, match="one \\(r, g, b\\) per point"):
        as_point_array(np.zeros((4, 3)), np.zeros((3, 3)))


def test_voxel_downsample_averages_per_cell():
    pts = np.array([[0.001, 0.001, 0.001], [0.003, 0.003, 0.003], [0.012, 0.0, 0.0]])
    grid = voxel_downsample(pts, 0.01, np.array([[0, 0, 0], [100, 100, 100], [50, 50, 50]], dtype=np.uint8))
    order = np.argsort(grid.points[:, 0])
    np.testing.assert_allclose(grid.points[order], [[0.002, 0.002, 0.002], [0.012, 0, 0]])
    assert grid.counts[order].tolist() == [2, 1]
    assert grid.colors[order].tolist() == [[50, 50, 50], [50, 50, 50]]
    np.testing.assert_allclose(grid.points[grid.inverse][:2], [[0.002] * 3] * 2)
    assert voxel_downsample(pts, 0.0).points is pts


def test_crop_mask_with_infinite_bounds():
    pts = np.array([[0, 0, -100.0], [0, 0, 100.0], [2, 0, 0]])
    assert crop_mask(pts, (-1, -1, -np.inf), (1, 1, np.inf)).tolist() == [True, True, False]


def test_closed_form_eigen_matches_lapack():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(500, 3, 3))
    cov = A @ A.transpose(0, 2, 1)
    evals, normal = _smallest_eigen(cov)
    ref_vals, ref_vecs = np.linalg.eigh(cov)
    np.testing.assert_allclose(evals, ref_vals, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(np.abs(np.einsum("nd,nd->n", normal, ref_vecs[:, :, 0])), 1.0, atol=1e-9)


def test_features_on_a_plane_and_a_cylinder():
    rng = np.random.default_rng(0)
    plane = np.column_stack([rng.uniform(0, 0.1, 3000), rng.uniform(0, 0.1, 3000), rng.normal(0, 1e-5, 3000)])
    f = estimate_features(plane, 30, 0.02, 10, 0.01)
    inner = np.all((plane[:, :2] > 0.02) & (plane[:, :2] < 0.08), axis=1)
    assert np.all(np.abs(f.normals[inner, 2]) > 0.999)
    assert np.median(f.curvature[inner]) < 1e-3
    assert np.median(f.rsd_radius[inner]) > 0.1  # flat: a large radius
    cyl = cylinder_surface(0.02, 0.1, math.pi, 4000, 1e-5, rng)
    fc = estimate_features(cyl, 30, 0.02, 10, 0.01)
    radial = cyl[:, :2] / np.linalg.norm(cyl[:, :2], axis=1, keepdims=True)
    assert np.median(np.abs(np.einsum("nd,nd->n", fc.normals[:, :2], radial))) > 0.99
    assert np.median(fc.curvature) > 5 * np.median(f.curvature[inner])
    assert np.median(fc.rsd_radius) == pytest.approx(0.02, abs=0.006)
    assert fc.rsd_radius.max() <= PLANE_RSD_RADIUS


def test_isolated_points_have_no_features():
    rng = np.random.default_rng(1)
    pts = np.vstack([rng.uniform(0, 0.05, (500, 3)) * [1, 1, 0], [[1.0, 1.0, 1.0]]])
    f = estimate_features(pts, 30, 0.02, 10, 0.01)
    assert not f.valid[-1] and f.valid[:-1].mean() > 0.95


def test_euclidean_clusters_split_at_the_tolerance():
    rng = np.random.default_rng(2)
    a = rng.uniform(0, 0.05, (800, 3))
    b = rng.uniform(0, 0.05, (600, 3)) + [0.07, 0, 0]  # gap of 2 cm
    c = rng.uniform(0, 0.002, (5, 3)) + [0.5, 0.5, 0.5]
    pts = np.vstack([a, b, c])
    clusters = euclidean_clusters(pts, 0.01, min_size=10)
    assert [len(k) for k in clusters] == [800, 600]
    assert set(clusters[0]) == set(range(800))
    assert len(euclidean_clusters(pts, 0.03, min_size=10)) == 1
    assert euclidean_clusters(pts, 0.01, min_size=10, max_size=700)[0].size == 600


def test_ransac_line_and_circle_find_the_models():
    rng = np.random.default_rng(4)
    t = rng.uniform(-0.05, 0.05, 400)
    theta = 0.3
    line = np.column_stack([t * math.cos(theta), t * math.sin(theta)]) + [0.2, 0.1]
    line += rng.normal(0, 3e-4, line.shape)
    pts = np.vstack([line, rng.uniform(0.1, 0.3, (100, 2))])
    normal, rho = ransac_line(pts, 1e-3, 1000, rng)
    assert abs(abs(normal @ [math.cos(theta), math.sin(theta)])) < 0.01
    assert abs(normal @ [0.2, 0.1] - rho) < 1e-3
    arc = cylinder_surface(0.03, 0.0, 2.5, 400, 3e-4, rng)[:, :2] + [0.4, 0.2]
    centre, radius = ransac_circle(np.vstack([arc, rng.uniform(0.3, 0.5, (100, 2))]), 1e-3, 1000, rng, 0.005, 0.2)
    assert np.linalg.norm(centre - [0.4, 0.2]) < 3e-3 and abs(radius - 0.03) < 3e-3
    c, r = fit_circle_geometric(arc, centre, radius)
    assert np.linalg.norm(c - [0.4, 0.2]) < 5e-4 and abs(r - 0.03) < 5e-4


def test_geometric_circle_fit_is_unbiased_on_a_half_arc():
    rng = np.random.default_rng(5)
    arc = cylinder_surface(0.0125, 0.0, math.pi, 2000, 1e-3, rng)[:, :2]
    c, r = fit_circle_geometric(arc, np.array([0.0, 0.005]), 0.02)
    assert abs(r - 0.0125) < 3e-4 and np.linalg.norm(c) < 3e-4


def test_plane_ransac_and_frames():
    rng = np.random.default_rng(6)
    n = np.array([0.02, -0.01, 1.0])
    n /= np.linalg.norm(n)
    xy = rng.uniform(-0.5, 0.5, (3000, 2))
    z = -(n[0] * xy[:, 0] + n[1] * xy[:, 1] + 0.01) / n[2]
    pts = np.vstack([np.column_stack([xy, z + rng.normal(0, 1e-3, 3000)]), rng.uniform(-0.5, 0.5, (500, 3))])
    normal, offset, inliers = fit_plane_ransac(pts, 0.005, 1000, rng)
    assert normal[2] > 0 and np.degrees(np.arccos(normal @ n)) < 0.3 and abs(offset - 0.01 / 1.0) < 2e-3
    assert inliers[:3000].mean() > 0.98
    R = rotation_from_z(normal)
    np.testing.assert_allclose(R @ [0, 0, 1], normal, atol=1e-12)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    frame = PlaneFrame.from_plane(normal, offset, np.array([0.1, 0.2, 0.3]))
    assert abs(normal @ frame.origin + offset) < 1e-12
    local = frame.to_plane(pts[:10])
    np.testing.assert_allclose(frame.to_world(local), pts[:10], atol=1e-12)
    T = frame.pose(0.0, 0.0, 0.05, yaw=0.3)
    np.testing.assert_allclose(T[:3, 2], normal, atol=1e-12)


def test_box_yaw_is_folded_into_a_quarter_turn():
    assert _wrap_quarter(math.radians(50)) == pytest.approx(math.radians(-40))
    assert _wrap_quarter(math.radians(-45)) == pytest.approx(math.radians(45))
    assert _wrap_quarter(math.radians(135)) == pytest.approx(math.radians(45))
    np.testing.assert_allclose(_wrap_quarter(np.radians([10.0, 100.0, -80.0])), np.radians([10.0, 10.0, 10.0]))

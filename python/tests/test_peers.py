"""Where a peer implements the same geometry, it agrees with fishcam: kornia's
Kannala-Brandt projection and its inverse (kornia 0.9) against fishcam's
kannala-brandt camera, to 1e-6 px."""

import os

import fishcam
import numpy as np
import pytest
import torch

if os.environ.get("FISHCAM_REQUIRE_PEERS") != "1":
    pytest.importorskip("kornia")
from conftest import DATA
from kornia.geometry.camera import distort_points_kannala_brandt, undistort_points_kannala_brandt  # noqa: E402


@pytest.fixture(scope="module")
def kb():
    camera = fishcam.Camera.read(os.path.join(DATA, "kannala_brandt.yaml"))
    assert camera.model == "kannala-brandt"
    f, k1, k2, k3, k4 = camera.parameters
    (ax, ay), (cx, cy) = camera.pixel_scale, camera.principal_point
    params = torch.tensor([f * ax, f * ay, cx, cy, k1, k2, k3, k4], dtype=torch.float64)
    return camera, params


def rays_in_front(n, max_theta_deg, seed=0):
    rng = np.random.default_rng(seed)
    theta = np.radians(rng.uniform(0, max_theta_deg, n))
    phi = rng.uniform(0, 2 * np.pi, n)
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], 1)


def test_kornia_projects_as_fishcam_does(kb):
    camera, params = kb
    points = rays_in_front(2000, 89.0) * np.random.default_rng(1).uniform(0.5, 20, (2000, 1))
    pixels, ok = camera.project(points)
    assert ok.all()
    plane = torch.from_numpy(points[:, :2] / points[:, 2:])
    theirs = distort_points_kannala_brandt(plane, params).numpy()
    assert np.max(np.abs(theirs - pixels)) <= 1e-6


def test_kornias_inverse_agrees_within_its_convergence(kb):
    camera, params = kb
    rays = rays_in_front(500, 75.0, seed=2)
    pixels, _ = camera.project(rays)
    plane = undistort_points_kannala_brandt(torch.from_numpy(pixels), params).numpy()
    back = np.concatenate([plane, np.ones((len(plane), 1))], 1)
    back /= np.linalg.norm(back, axis=1, keepdims=True)
    ours, ok = camera.unproject(pixels)
    assert ok.all()
    reprojected, _ = camera.project(back)  # kornia's ray, in pixels through fishcam
    assert np.max(np.abs(reprojected - pixels)) <= 1e-6
    assert np.max(np.linalg.norm(ours - rays, axis=1)) <= 1e-12

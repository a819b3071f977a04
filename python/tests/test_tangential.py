"""Cameras with tangential terms from Python: real files against numpy's Mei formula
and cv2.projectPoints, unprojection that reprojects, pickling and keys that carry the
terms, and conversion to a radial model with its non-radial part."""

import json
import pickle
from pathlib import Path

import fishcam
import numpy as np
import pytest
from conftest import SHARED

EXTERNAL = SHARED / "data" / "external"
needs_shared = pytest.mark.skipif(not (EXTERNAL / "README.md").exists(), reason="no ../shared/data/external")


def rays(n, theta_max_deg, seed):
    rng = np.random.default_rng(seed)
    z = rng.uniform(np.cos(np.radians(theta_max_deg)), 1, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    s = np.sqrt(1 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def mei(points, fx, fy, cx, cy, xi, k1, k2, p1, p2):
    """Mei & Rives 2007 (camodocal MEI), written from the paper."""
    s = points / np.linalg.norm(points, axis=1, keepdims=True)
    mx, my = s[:, 0] / (s[:, 2] + xi), s[:, 1] / (s[:, 2] + xi)
    r2 = mx * mx + my * my
    g = 1 + k1 * r2 + k2 * r2 * r2
    dx = 2 * p1 * mx * my + p2 * (r2 + 2 * mx * mx)
    dy = p1 * (r2 + 2 * my * my) + 2 * p2 * mx * my
    return np.stack([fx * (mx * g + dx) + cx, fy * (my * g + dy) + cy], axis=1)


@pytest.fixture(scope="module")
def mei_camera(tmp_path_factory):
    """The T265 fisheye's MEI calibration (vinsfusion_t265_fisheye1_MEI.yaml) as fishcam JSON."""
    path = tmp_path_factory.mktemp("tangential") / "mei.json"
    path.write_text(
        json.dumps(
            {
                "fishcam_camera": 1,
                "width": 848,
                "height": 800,
                "principal_point": [426.05865129, 400.00487828],
                "pixel_scale": [1.0, 841.73955011 / 840.35417863],
                "model": "mei",
                "parameters": [840.35417863, 2.00109674298, 0.26251514, -0.85422959],
                "tangential": {"p1": 0.00501238, "p2": 0.00039633},
            }
        )
    )
    return fishcam.Camera.read(str(path))


MEI_ARGS = (
    840.35417863,
    841.73955011,
    426.05865129,
    400.00487828,
    2.00109674298,
    0.26251514,
    -0.85422959,
    0.00501238,
    0.00039633,
)


def test_a_mei_camera_with_tangential_terms_projects_as_the_paper_says(mei_camera):
    assert not mei_camera.radial
    assert mei_camera.tangential == {"p1": 0.00501238, "p2": 0.00039633, "s1": 0.0, "s2": 0.0, "s3": 0.0, "s4": 0.0}
    points = rays(20000, mei_camera.domain.theta_max_deg, 1) * np.linspace(0.5, 20, 20000)[:, None]
    pixels, ok = mei_camera.project(points)
    assert ok.all()
    assert np.abs(pixels - mei(points, *MEI_ARGS)).max() < 1e-7
    back, ok = mei_camera.unproject(pixels)
    assert ok.all()
    again, _ = mei_camera.project(back)
    assert np.abs(again - pixels).max() < 1e-6
    assert np.abs(back - points / np.linalg.norm(points, axis=1, keepdims=True)).max() < 1e-9


def test_pickles_and_keys_carry_the_tangential_terms(mei_camera, tmp_path):
    copy = pickle.loads(pickle.dumps(mei_camera))
    assert copy == mei_camera and copy.tangential == mei_camera.tangential
    assert mei_camera.distortion == copy.distortion == "tangential"
    # The pickle holds the part's one serialisation (name, configuration, values) and the
    # skew; a pickle of an earlier fishcam (the six terms in field 11) still loads.
    state = mei_camera.__getstate__()
    assert state[10] == ("tangential", "", [mei_camera.tangential[n] for n in ("p1", "p2", "s1", "s2", "s3", "s4")])
    assert state[11] == (0.0, 0.0)
    earlier = fishcam.Camera.__new__(fishcam.Camera)
    earlier.__setstate__((*state[:10], tuple(state[10][2])))
    assert earlier == mei_camera
    radial_json = json.loads(mei_camera.to_json())
    del radial_json["tangential"]
    path = tmp_path / "radial.json"
    path.write_text(json.dumps(radial_json))
    radial = fishcam.Camera.read(str(path))
    assert radial.radial and radial.distortion == "none"
    assert radial != mei_camera
    assert radial.parameters_key(False) != mei_camera.parameters_key(False)
    assert json.loads(mei_camera.info_json())["tangential"]["p1"] == 0.00501238
    assert json.loads(radial.info_json())["tangential"] is None


def test_conversion_to_a_radial_model_reports_the_non_radial_part(mei_camera):
    small = mei_camera.resized(212, 200)
    conversion = fishcam.convert(small, "kannala-brandt")
    assert conversion.center_and_aspect_fitted
    rms, worst = conversion.non_radial_px
    assert 0 < rms <= worst
    assert conversion.camera.radial
    errors = fishcam.reprojection_error_map(small, conversion.camera)
    assert errors.shape == (200, 212) and errors.dtype == np.float32
    every_other = errors[::2, ::2]
    assert np.sqrt(np.nanmean(every_other.astype(np.float64) ** 2)) == pytest.approx(conversion.report.rms_px, abs=1e-5)
    assert (
        fishcam.convert(
            fishcam.Camera.read(str(Path(__file__).resolve().parents[2] / "data" / "kannala_brandt.yaml")),
            "equidistant",
        ).non_radial_px
        is None
    )


@needs_shared
def test_real_radial_tangential_files_agree_with_cv2_project_points():
    cv2 = pytest.importorskip("cv2")
    camera = fishcam.Camera.read(str(EXTERNAL / "openvins_euroc_mav_kalibr_imucam_chain.yaml"), camera="cam0")
    assert camera.model == "opencv" and camera.tangential["p1"] == 0.00019359
    points = rays(5000, 70, 2)
    K = np.array([[458.654, 0, 367.215], [0, 457.296, 248.375], [0, 0, 1]])
    expected, _ = cv2.projectPoints(
        points, np.zeros(3), np.zeros(3), K, np.array([-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05])
    )
    pixels, ok = camera.project(points)
    assert ok.all()
    assert np.abs(pixels - expected[:, 0]).max() < 1e-7


@needs_shared
def test_real_mei_file_agrees_with_the_paper():
    camera = fishcam.Camera.read(str(EXTERNAL / "vinsfusion_t265_fisheye1_MEI.yaml"))
    points = rays(5000, camera.domain.theta_max_deg, 3)
    pixels, ok = camera.project(points)
    assert ok.all()
    assert np.abs(pixels - mei(points, *MEI_ARGS)).max() < 1e-7


def spline_camera_json():
    """A stereographic camera with mrcal's spline on its plane (LENSMODEL_SPLINED_STEREOGRAPHIC)."""
    values = []
    for y in range(6):
        for x in range(8):
            values += [0.004 * np.cos(0.7 * x + 0.3 * y) + 0.001 * x, 0.003 * np.sin(0.5 * x - 0.9 * y) - 0.0015 * y]
    return {
        "fishcam_camera": 1,
        "width": 640,
        "height": 483,
        "principal_point": [321.5, 240.0],
        "pixel_scale": [1.0, 1.0045],
        "model": "stereographic",
        "parameters": [165.0],
        "mrcal_lens": {
            "lensmodel": "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=150",
            "values": [float(v) for v in values],
        },
    }


def test_a_splined_camera_is_mrcals_projection(tmp_path):
    path = tmp_path / "spline.json"
    path.write_text(json.dumps(spline_camera_json()))
    camera = fishcam.Camera.read(str(path))
    assert not camera.radial and camera.model == "stereographic"
    lensmodel, values = camera.mrcal_lens
    assert lensmodel.startswith("LENSMODEL_SPLINED_STEREOGRAPHIC") and len(values) == 96
    assert json.loads(camera.info_json())["mrcal_lens"]["values"] == 96
    copy = pickle.loads(pickle.dumps(camera))
    assert copy == camera and copy.mrcal_lens == camera.mrcal_lens and copy.distortion == "mrcal_lens"
    assert camera.__getstate__()[10] == ("mrcal_lens", lensmodel, values)
    # Files written before CAHVOR and LONLAT/LATLON were read call it "spline".
    old = dict(spline_camera_json())
    old["spline"] = old.pop("mrcal_lens")
    old_path = tmp_path / "old.json"
    old_path.write_text(json.dumps(old))
    assert fishcam.Camera.read(str(old_path)) == camera
    both = dict(spline_camera_json(), spline=old["spline"])
    old_path.write_text(json.dumps(both))
    with pytest.raises(fishcam.Error, match="one plane distortion"):
        fishcam.Camera.read(str(old_path))
    plain = dict(spline_camera_json())
    del plain["mrcal_lens"]
    plain_path = tmp_path / "plain.json"
    plain_path.write_text(json.dumps(plain))
    assert fishcam.Camera.read(str(plain_path)).parameters_key(False) != camera.parameters_key(False)
    points = rays(5000, 60, 4)
    pixels, ok = camera.project(points)
    assert ok.all()
    back, ok = camera.unproject(pixels)
    assert ok.all() and np.abs(back - points).max() < 1e-9
    mrcal = pytest.importorskip("mrcal")
    intrinsics = np.array([165.0, 165.0 * 1.0045, 321.5, 240.0] + list(values))
    expected = mrcal.project(points, lensmodel, intrinsics)
    assert np.abs(pixels - expected).max() < 1e-9
    camera.write(str(tmp_path / "spline.cameramodel"))
    back = fishcam.Camera.read(str(tmp_path / "spline.cameramodel"))
    assert back.mrcal_lens == camera.mrcal_lens
    assert np.abs(back.project(points)[0] - pixels).max() < 1e-9
    with pytest.raises(fishcam.Error, match="not stereographic"):
        camera.write(str(tmp_path / "spline.yaml"), format="opencv")
    # The augmentation evaluates the spline in its float kernel and takes the grid path;
    # the identity keeps every pixel of the image.
    warp = fishcam.ViewpointWarp(camera)
    assert warp.float_kernel and warp.grid_spacing > 0
    image = (np.arange(camera.width * camera.height) % 251).astype(np.uint8).reshape(camera.height, camera.width)
    out = warp(image=image, change=fishcam.ViewpointChange(), return_valid=True)
    assert out["valid"].all() and np.array_equal(out["image"], image)


MRCAL_LENSES = [  # (lensmodel, values, base model, fx, image, whether warps take the float kernel)
    ("LENSMODEL_CAHVOR", [0.03, -0.02, 0.01, -0.05, 0.01], "pinhole", 420.0, (1280, 966), True),
    (
        "LENSMODEL_CAHVORE_linearity=0.50",
        [0.03, -0.02, 0.01, -0.05, 0.01, 1.2, 0.5, -0.3],
        "stereographic",
        420.0,
        (1280, 966),
        True,
    ),
    ("LENSMODEL_LONLAT", [], "stereographic", 450.0, (1280, 966), True),  # the image inside the poles
    # The image reaches 81.5 deg of latitude at its sides, next to the pole, where the
    # chart is singular: no table of its offsets holds 1e-4 px (docs/augmentation.md).
    ("LENSMODEL_LATLON", [], "stereographic", 450.0, (1280, 966), False),
]


@pytest.mark.parametrize("lensmodel, values, base, fx, size, kernel", MRCAL_LENSES, ids=[m[0] for m in MRCAL_LENSES])
def test_mrcal_lenses_are_mrcals_projection(tmp_path, lensmodel, values, base, fx, size, kernel):
    """CAHVOR on a pinhole plane, CAHVORE, LONLAT and LATLON on a stereographic one,
    read from .cameramodel files and compared with mrcal's own Python (mrcal.project)."""
    intrinsics = [fx, fx * 1.004, size[0] / 2 - 3.5, size[1] / 2 + 2.0] + values
    path = tmp_path / "lens.cameramodel"
    path.write_text(repr({"lensmodel": lensmodel, "intrinsics": intrinsics, "imagersize": list(size)}))
    camera = fishcam.Camera.read(str(path))
    assert camera.model == base and not camera.radial
    assert camera.mrcal_lens == (lensmodel, values)
    info = json.loads(camera.info_json())
    assert info["mrcal_lens"] == {"lensmodel": lensmodel, "base_model": base, "values": len(values)}
    theta_max = info["theta_max_deg"]
    if lensmodel in ("LENSMODEL_LONLAT", "LENSMODEL_LATLON"):  # singular at the poles, 90 deg off the axis
        assert 89.9 < theta_max <= 90
    points = rays(4000, min(0.999 * theta_max, 85), 7) * np.linspace(0.5, 7, 4000)[:, None]
    pixels, ok = camera.project(points)
    assert ok.all()
    back, ok = camera.unproject(pixels)
    assert ok.all() and np.abs(camera.project(back)[0] - pixels).max() < 1e-7
    mrcal = pytest.importorskip("mrcal")
    expected = mrcal.project(points, lensmodel, np.array(intrinsics))
    # mrcal's CAHVOR is not scale-invariant to rounding (the same ray at different lengths
    # projects up to 1.3e-8 px apart at 80 deg): ours is one of those lengths.
    assert np.abs(pixels - expected).max() < (5e-8 if lensmodel.startswith("LENSMODEL_CAHVOR") else 1e-9)
    assert np.abs(back - points / np.linalg.norm(points, axis=1, keepdims=True)).max() < 1e-9
    # mrcal .cameramodel and fishcam JSON hold it; other formats refuse it in one line.
    for name in ("again.cameramodel", "again.json"):
        camera.write(str(tmp_path / name))
        again = fishcam.Camera.read(str(tmp_path / name))
        assert again.model == base and again.mrcal_lens == camera.mrcal_lens
        assert np.abs(again.project(points)[0] - pixels).max() < 1e-9
    refusal = (
        "mrcal_lens: the opencv format cannot hold mrcal's " + lensmodel if base == "pinhole" else "not stereographic"
    )
    with pytest.raises(fishcam.Error, match=refusal):
        camera.write(str(tmp_path / "lens.yaml"), format="opencv")
    # Augmentation: the float kernel from a table of mrcal's offsets, within 1e-3 px of
    # the exact maps where both have a source in the image; else the exact path.
    small = camera.resized(320, 242)
    warp = fishcam.ViewpointWarp(small)
    assert warp.float_kernel == kernel
    if kernel:
        change = fishcam.ViewpointChange(rotation_deg=np.array([12.0, -8.0, 20.0]))
        fast_x, fast_y, fast_valid = warp.maps(change)
        exact_x, exact_y, exact_valid = warp.maps(change, exact=True)
        both = fast_valid & exact_valid
        assert both.sum() > 30000 and (fast_valid != exact_valid).sum() <= 20
        assert np.hypot(fast_x - exact_x, fast_y - exact_y)[both].max() < 1e-3
    else:
        assert warp.grid_spacing == 0
    image = (np.arange(small.width * small.height) % 251).astype(np.uint8).reshape(small.height, small.width)
    out = warp(image=image, change=fishcam.ViewpointChange(), return_valid=True)
    assert out["valid"].all() and np.array_equal(out["image"], image)


def ocam_cam2world(pixels, pol, xc, yc, c, d, e):
    """OCamCalib's cam2world (ocam_functions.c), written from the toolbox: pixels as
    (column, row) in, rays in fishcam's frame out (OCamCalib's x runs along rows and
    its camera looks along -z: fishcam's (X, Y, Z) = (y, x, -z))."""
    row, column = pixels[:, 1] - xc, pixels[:, 0] - yc
    inv_det = 1 / (c - d * e)
    xp = inv_det * (row - d * column)
    yp = inv_det * (-e * row + c * column)
    z = np.polynomial.polynomial.polyval(np.hypot(xp, yp), pol)
    rays = np.stack([yp, xp, -z], axis=1)
    return rays / np.linalg.norm(rays, axis=1, keepdims=True)


@needs_shared
def test_the_real_ocamcalib_file_is_cam2world(tmp_path):
    camera = fishcam.Camera.read(str(EXTERNAL / "ocamcalib_calib_results.txt"))
    assert camera.model == "ocam" and not camera.radial
    assert camera.skew == (0.013102, pytest.approx(-0.014257 / 0.996974, abs=1e-15))
    u, v = np.meshgrid(np.arange(0, camera.width, 7.0), np.arange(0, camera.height, 7.0))
    pixels = np.stack([u.ravel(), v.ravel()], axis=1)
    rays, ok = camera.unproject(pixels)
    assert ok.all()
    expected = ocam_cam2world(
        pixels,
        [-7.463674e02, 0.0, 8.872435e-04, -1.024379e-06, 9.406640e-10],
        630.102940,
        958.314910,
        0.996974,
        -0.014257,
        0.013102,
    )
    assert np.abs(rays - expected).max() < 1e-13
    again, ok = camera.project(rays)
    assert ok.all() and np.abs(again - pixels).max() < 1e-9
    # A skewed camera pickles (its skew the state's last field) and keys on its skew.
    copy = pickle.loads(pickle.dumps(camera))
    assert copy == camera and copy.skew == camera.skew
    unskewed_json = json.loads(camera.to_json())
    assert unskewed_json["skew"] == {"xy": 0.013102, "yx": camera.skew[1]}
    del unskewed_json["skew"]
    path = tmp_path / "unskewed.json"
    path.write_text(json.dumps(unskewed_json))
    unskewed = fishcam.Camera.read(str(path))
    assert unskewed.radial and unskewed.skew == (0.0, 0.0)
    assert unskewed.parameters_key(False) != camera.parameters_key(False)
    assert json.loads(camera.info_json())["skew"]["xy"] == 0.013102
    # Converted to a radial model: the skew is part of what no radial model represents.
    conversion = fishcam.convert(camera.resized(480, 302), "polynomial:4")
    assert conversion.center_and_aspect_fitted and conversion.camera.radial
    assert 0 < conversion.non_radial_px[0] <= conversion.report.rms_px

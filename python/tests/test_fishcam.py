"""The Python package against the C++ CLI, and its contract: exact equality with
`fishcam map` / `fishcam augment`, zero copy, seeding, pickling, bad input."""

import json
import os
import pickle
import subprocess

import fishcam
import numpy as np
import pytest
from conftest import BINARY, DATA
from fishcam.transforms import RandomViewpoint

BUNDLED = [
    "woodscape_front.json",
    "stereographic.cameramodel",
    "pinhole.cameramodel",
    "kannala_brandt.yaml",
    "equidistant.json",
]


def data(name):
    return os.path.join(DATA, name)


@pytest.fixture(scope="module")
def cam():
    return fishcam.Camera.read(data("woodscape_front.json"))


def run_cli(*args):
    if not BINARY:
        pytest.skip("FISHCAM_BINARY not set (run through CTest)")
    result = subprocess.run([BINARY, *map(str, args)], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return result.stdout


def read_npy(path):
    return np.load(path)


def test_version_and_error_type():
    assert fishcam.__version__.count(".") == 2
    assert issubclass(fishcam.Error, ValueError)


def test_info_has_the_cli_fields(cam, tmp_path):
    info = json.loads(cam.info_json())
    cli = json.loads(run_cli("info", data("woodscape_front.json"), "--json"))
    for key in cli:
        if key not in ("format", "camera"):  # what the file said, not the camera
            assert info[key] == cli[key], key
    # The same values, typed.
    assert cam.domain.theta_max_deg == cli["theta_max_deg"] and cam.domain.closed == cli["theta_max_closed"]
    assert cam.domain.limited_by == cli["theta_max_limited_by"] and cam.domain.rho_max_px == cli["rho_max_px"]
    fov = cam.field_of_view_deg
    assert [fov.horizontal, fov.vertical, fov.diagonal] == [
        cli["fov_deg"][k] for k in ("horizontal", "vertical", "diagonal")
    ]
    assert list(cam.principal_point) == [cli["cx"], cli["cy"]] and cam.parameters == cli["parameters"]


@pytest.mark.parametrize("name", BUNDLED)
def test_project_unproject_agree_with_the_cli(name):
    camera = fishcam.Camera.read(data(name))
    rng = np.random.default_rng(1)
    points = rng.normal(size=(200, 3))
    points[:5] = [[0, 0, 1], [0, 0, -1], [0, 0, 0], [np.nan, 1, 1], [1e300, 1e300, 1]]
    px, ok = camera.project(points)
    text = "\n".join(" ".join(repr(float(v)) for v in p) for p in points) + "\n"
    result = (
        subprocess.run([BINARY, "project", data(name)], input=text, capture_output=True, text=True)
        if BINARY
        else pytest.skip("no CLI")
    )
    cli = np.array([[float(v) for v in line.split()] for line in result.stdout.split("\n") if line.strip()])
    np.testing.assert_array_equal(np.isnan(cli[:, 0]), ~ok)
    np.testing.assert_array_equal(px[ok], cli[ok])  # %.17g: bit for bit
    assert np.all(np.isnan(px[~ok]))
    rays, ok2 = camera.unproject(px[ok])
    assert ok2.all()
    scaled = points[ok] / np.abs(points[ok]).max(axis=1, keepdims=True)  # no overflow at 1e300
    expected = scaled / np.linalg.norm(scaled, axis=1, keepdims=True)
    np.testing.assert_allclose(rays, expected, atol=1e-9)
    # theta_from_rho: NaN outside the domain, and inverse of rho.
    theta = camera.theta_from_rho(np.array([0.0, 50.0, -1.0, np.nan, 1e12]))
    assert theta[0] == 0 and theta[1] > 0
    assert np.all(np.isnan(theta[2:4]))


def test_theta_from_rho_keeps_the_shape(cam):
    rho = np.linspace(0, 500, 12).reshape(3, 4)
    theta = cam.theta_from_rho(rho)
    assert theta.shape == (3, 4)
    px, _ = cam.project(np.stack([np.sin(theta.ravel()), 0 * theta.ravel(), np.cos(theta.ravel())], axis=1))
    np.testing.assert_allclose(px[:, 0] - cam.principal_point[0], rho.ravel(), atol=1e-9)


def test_random_change_equals_the_cli(cam, tmp_path):
    for seed in [0, 7, 2**63 + 5, 2**64 - 1]:
        change = fishcam.random_change("train", seed)
        cli = json.loads(
            run_cli(
                "augment",
                data("woodscape_front.json"),
                "--image",
                make_image(tmp_path, cam),
                "--out-image",
                tmp_path / f"o{seed}.png",
                "--preset",
                "train",
                "--seed",
                seed,
                "--json",
            )
        )
        assert list(change.rotation_deg) == cli["rotation_deg"]
        assert list(change.translation) == cli["translation"]


def make_image(tmp_path, cam):
    import cv2

    path = tmp_path / "image.png"
    if not path.exists():
        rng = np.random.default_rng(0)
        cv2.imwrite(str(path), rng.integers(0, 256, size=(cam.height, cam.width, 3), dtype=np.uint8))
        labels = (np.arange(cam.width)[None, :] // 37 + np.arange(cam.height)[:, None] // 23) % 10
        cv2.imwrite(str(tmp_path / "labels.png"), labels.astype(np.uint8))
    return path


@pytest.mark.parametrize("depth", fishcam.DEPTH_PRIORS)
def test_maps_are_bit_identical_to_fishcam_map(cam, tmp_path, depth):
    change = fishcam.ViewpointChange(rotation_deg=(10, -20, 5), translation=(0.1, 0, 0.2))
    map_x, map_y, valid = fishcam.ViewpointWarp(cam).maps(change, depth=depth)
    run_cli(
        "map",
        data("woodscape_front.json"),
        "--rotate",
        "10,-20,5",
        "--translate",
        "0.1,0,0.2",
        "--depth",
        depth,
        "--out",
        tmp_path / "m.npy",
    )
    cli = read_npy(tmp_path / "m.npy")
    assert cli.shape == (cam.height, cam.width, 2)
    np.testing.assert_array_equal(map_x, cli[..., 0])
    np.testing.assert_array_equal(map_y, cli[..., 1])
    assert valid.dtype == bool and 0.5 < valid.mean() < 1


def test_augmented_images_and_labels_are_byte_identical_to_fishcam_augment(cam, tmp_path):
    import cv2

    image_path = make_image(tmp_path, cam)
    image = cv2.imread(str(image_path), cv2.IMREAD_UNCHANGED)
    labels = cv2.imread(str(tmp_path / "labels.png"), cv2.IMREAD_UNCHANGED)
    warp = fishcam.ViewpointWarp(cam)
    for seed in [1, 2]:
        run_cli(
            "augment",
            data("woodscape_front.json"),
            "--image",
            image_path,
            "--label",
            tmp_path / "labels.png",
            "--out-image",
            tmp_path / f"a{seed}.png",
            "--out-label",
            tmp_path / f"l{seed}.png",
            "--preset",
            "train",
            "--seed",
            seed,
            "--label-fill",
            255,
        )
        out = warp(image=image, labels=labels, change=fishcam.random_change("train", seed), label_fill=255)
        np.testing.assert_array_equal(out["image"], cv2.imread(str(tmp_path / f"a{seed}.png"), cv2.IMREAD_UNCHANGED))
        np.testing.assert_array_equal(out["labels"], cv2.imread(str(tmp_path / f"l{seed}.png"), cv2.IMREAD_UNCHANGED))
        # The transform with the same seed gives the same bytes.
        t = RandomViewpoint(cam, preset="train", fill_mask=255)
        o = t(image=image, mask=labels, seed=seed)
        np.testing.assert_array_equal(o["image"], out["image"])
        np.testing.assert_array_equal(o["mask"], out["labels"])
        assert o["change"]["seed"] == seed
        json.dumps(o["change"])


def test_image_types_channels_and_fill(cam):
    warp = fishcam.ViewpointWarp(cam)
    change = fishcam.random_change("large", 3)
    _, _, valid = warp.maps(change)
    for dtype in [np.uint8, np.uint16, np.float32]:
        for shape in [
            (cam.height, cam.width),
            (cam.height, cam.width, 1),
            (cam.height, cam.width, 3),
            (cam.height, cam.width, 4),
        ]:
            image = np.full(shape, 7, dtype=dtype)
            out = warp.warp(image=image, change=change, fill=42, return_valid=True)
            assert out["image"].dtype == dtype and out["image"].shape == shape
            assert np.all(out["image"][out["valid"]] == 7)
            assert np.all(out["image"][~out["valid"]] == 42)
            np.testing.assert_array_equal(out["valid"], valid)


def test_inputs_are_not_copied_when_contiguous(cam, monkeypatch):
    # project reads the caller's buffer: writing into it from another view shows up.
    points = np.ascontiguousarray(np.random.default_rng(2).normal(size=(10, 3)))
    points[:, 2] = np.abs(points[:, 2]) + 1
    px, _ = cam.project(points)
    # A non-contiguous view (every other row) gives the same results as its copy.
    strided = np.random.default_rng(3).normal(size=(20, 3))[::2]
    strided[:, 2] = 1
    assert not strided.flags.c_contiguous
    np.testing.assert_array_equal(cam.project(strided)[0], cam.project(np.ascontiguousarray(strided))[0])
    # Images: a Fortran-ordered or sliced image is copied, never read with wrong strides.
    warp = fishcam.ViewpointWarp(cam)
    rng = np.random.default_rng(4)
    image = rng.integers(0, 256, size=(cam.height, cam.width * 2, 3), dtype=np.uint8)
    view = image[:, ::2]
    change = fishcam.random_change("small", 1)
    np.testing.assert_array_equal(
        warp.warp(image=view, change=change)["image"],
        warp.warp(image=np.ascontiguousarray(view), change=change)["image"],
    )
    # Inputs need not be writeable (np.asarray of a PIL image, np.load(mmap_mode='r')).
    frozen = np.ascontiguousarray(view)
    labels = rng.integers(0, 10, size=(cam.height, cam.width), dtype=np.uint8)
    expected = warp.warp(image=frozen, labels=labels, change=change)
    frozen.setflags(write=False), labels.setflags(write=False)
    out = warp.warp(image=frozen, labels=labels, change=change)
    np.testing.assert_array_equal(out["image"], expected["image"])
    np.testing.assert_array_equal(out["labels"], expected["labels"])


def test_zero_copy_is_measured_by_the_data_pointer(cam):
    """The bindings compute on the caller's memory when it is C-contiguous (the same
    code path as project/unproject/warp: rows_of and as_mat), and on a copy otherwise."""
    address = fishcam._fishcam._input_address

    def pointer(a):
        return a.__array_interface__["data"][0]

    points = np.zeros((7, 3))
    assert address(points, "points3") == pointer(points)
    pixels = np.zeros((7, 2))
    assert address(pixels, "points2") == pointer(pixels)
    for dtype in [np.uint8, np.uint16, np.float32]:
        image = np.zeros((cam.height, cam.width, 3), dtype)
        assert address(image, "image") == pointer(image)
    labels = np.zeros((cam.height, cam.width), np.uint8)
    assert address(labels, "labels") == pointer(labels)
    # Not contiguous or not float64: a copy (a different address), never strided reads.
    strided = np.zeros((7, 6))[:, ::2]
    assert address(strided, "points3") != pointer(strided)
    sliced = np.zeros((cam.height, 2 * cam.width, 3), np.uint8)[:, ::2]
    assert address(sliced, "image") != pointer(sliced)
    as_float32 = np.zeros((7, 3), np.float32)
    assert address(as_float32, "points3") != pointer(as_float32)


def test_resized_follows_the_pixel_centre_convention(cam):
    small = cam.resized(640, 483)
    assert (small.width, small.height) == (640, 483)
    np.testing.assert_allclose(
        small.principal_point, (np.array(cam.principal_point) + 0.5) * 0.5 - 0.5, rtol=0, atol=1e-12
    )
    rays = np.random.default_rng(5).normal(size=(50, 3))
    rays[:, 2] = np.abs(rays[:, 2])
    big_px, ok = cam.project(rays)
    small_px, ok2 = small.project(rays)
    np.testing.assert_array_equal(ok, ok2)
    np.testing.assert_allclose((big_px[ok] + 0.5) * 0.5 - 0.5, small_px[ok], atol=1e-9)


def test_convert_matches_the_cli(cam, tmp_path):
    conversion = fishcam.convert(cam, to="kannala-brandt")
    kb, report = conversion
    cli = json.loads(
        run_cli(
            "convert", data("woodscape_front.json"), "--to", "kannala-brandt", "--out", tmp_path / "kb.json", "--json"
        )
    )
    assert kb.parameters == cli["parameters"] and conversion.camera == kb
    assert isinstance(report, fishcam.FitReport) and report.rms_px == cli["rms_px"]
    assert report.p99_px == cli["p99_px"] and report.samples_below_90 == cli["below_90_deg"]["samples"]
    assert [b.rms_px for b in report.by_angle] == [b["rms_px"] for b in cli["by_angle"]]
    assert json.loads(conversion.to_json()) == {k: v for k, v in cli.items() if k in json.loads(conversion.to_json())}
    assert 90 < conversion.widest_theta_deg <= cam.domain.theta_max_deg
    assert kb.model == "kannala-brandt"
    assert kb == fishcam.Camera.read(str(tmp_path / "kb.json"))
    eq, paper = fishcam.convert(cam, to="equidistant", method="paper")
    # Eq. 13: f = (W / 2) / (half the horizontal field of view).
    half_fov = np.radians(cam.field_of_view_deg.horizontal / 2)
    assert eq.parameters[0] == pytest.approx(cam.width / 2 / half_fov, rel=1e-12)


def test_write_refuses_to_replace_unless_overwrite(cam, tmp_path):
    path = tmp_path / "c.json"
    cam.write(str(path))
    with pytest.raises(fishcam.Error, match="already exists"):
        cam.write(str(path))
    cam.write(str(path), overwrite=True)
    assert fishcam.Camera.read(str(path)) == cam
    for fmt in ["woodscape", "fishcam"]:
        cam.write(str(tmp_path / f"c.{fmt}"), format=fmt)
        assert fishcam.Camera.read(str(tmp_path / f"c.{fmt}"), format=fmt).principal_point[0] == cam.principal_point[0]
    with pytest.raises(fishcam.Error, match="extension"):
        cam.write(str(tmp_path / "c.dat"))


def test_warp_is_callable_and_needs_a_change(cam):
    warp = fishcam.ViewpointWarp(cam)
    image = np.full((cam.height, cam.width), 5, np.uint8)
    change = fishcam.random_change("small", 2)
    np.testing.assert_array_equal(
        warp(image=image, change=change)["image"], warp.warp(image=image, change=change)["image"]
    )
    with pytest.raises(fishcam.Error, match="change"):
        warp(image=image)


def test_pickling_round_trips(cam):
    assert pickle.loads(pickle.dumps(cam)) == cam
    warp = fishcam.ViewpointWarp(cam)
    change = fishcam.random_change("medium", 9)
    again = pickle.loads(pickle.dumps(warp))
    np.testing.assert_array_equal(again.maps(change)[0], warp.maps(change)[0])
    c = pickle.loads(pickle.dumps(change))
    assert list(c.rotation_deg) == list(change.rotation_deg)
    t = pickle.loads(pickle.dumps(RandomViewpoint(cam, preset="small")))
    assert t.camera == cam and t.preset == "small"


@pytest.mark.parametrize("protocol", range(pickle.HIGHEST_PROTOCOL + 1))
def test_pickling_works_at_every_protocol(cam, protocol):
    # Protocols 0 and 1 aborted the interpreter ("no registered base types").
    assert pickle.loads(pickle.dumps(cam, protocol)) == cam
    warp = pickle.loads(pickle.dumps(fishcam.ViewpointWarp(cam), protocol))
    assert warp.source == cam
    change = fishcam.random_change("medium", 9)
    assert list(pickle.loads(pickle.dumps(change, protocol)).rotation_deg) == list(change.rotation_deg)
    t = pickle.loads(pickle.dumps(RandomViewpoint(cam, preset="small"), protocol))
    assert t.camera == cam and t.preset == "small"


def test_objects_made_without_init_raise_instead_of_crashing(cam):
    # cls.__new__(cls) alone: to_json segfaulted, width read uninitialised memory.
    for cls, use in [
        (fishcam.Camera, lambda o: o.to_json()),
        (fishcam.Camera, lambda o: o.width),
        (fishcam.Camera, lambda o: o.domain),
        (fishcam.ViewpointWarp, lambda o: o.source),
        (fishcam.ViewpointChange, lambda o: o.rotation_deg),
    ]:
        with pytest.raises(fishcam.Error, match="made without __init__"):
            use(cls.__new__(cls))


def test_setstate_validates_its_input(cam):
    for cls, state in [
        (fishcam.Camera, (1, 2)),
        (fishcam.Camera, "{not json"),
        (fishcam.Camera, 5),
        (fishcam.ViewpointChange, (1,)),
        (fishcam.ViewpointChange, ("a", "b")),
        (fishcam.ViewpointWarp, ("x",)),
        (fishcam.ViewpointWarp, (1, 2)),
    ]:
        obj = cls.__new__(cls)
        with pytest.raises(fishcam.Error):
            obj.__setstate__(state)


def test_bad_input_raises_fishcam_error(cam):
    warp = fishcam.ViewpointWarp(cam)
    change = fishcam.random_change("small", 1)
    cases = [
        lambda: cam.project(np.zeros((3, 2))),
        lambda: cam.project(np.zeros(3)),
        lambda: cam.unproject(np.zeros((2, 3))),
        lambda: warp.warp(image=np.zeros((10, 10), np.uint8), change=change),
        lambda: warp.warp(image=np.zeros((cam.height, cam.width), np.int32), change=change),
        lambda: warp.warp(image=np.zeros((cam.height, cam.width, 5), np.uint8), change=change),
        lambda: warp.warp(labels=np.zeros((cam.height, cam.width), np.float32), change=change),
        lambda: warp.warp(labels=np.zeros((cam.height, cam.width), np.uint8), change=change, label_fill=256),
        lambda: warp.maps(change, depth="sideways"),
        lambda: warp.maps(change, kind="fancy"),
        lambda: fishcam.ViewpointChange(rotation_deg=(np.nan, 0, 0)),
        lambda: fishcam.ViewpointChange(translation=(0, np.inf, 0)),
        lambda: fishcam.random_change("huge", 1),
        lambda: fishcam.random_change("train", -1),
        lambda: fishcam.random_change("train", 2**64),
        lambda: fishcam.random_change("train", 1.5),
        lambda: fishcam.convert(cam, to="fancy-model"),
        lambda: fishcam.convert(cam, to="equidistant", method="guess"),
        lambda: fishcam.convert(cam, to="equidistant", max_angle=float("nan")),
        lambda: fishcam.Camera.read(data("woodscape_front.json"), camera="rear"),
        lambda: fishcam.Camera.read(data("woodscape_front.json"), image_size=(640, 480)),
        lambda: fishcam.Camera.read(data("woodscape_front.json"), format="mrcal"),
        lambda: fishcam.Camera.read(data("woodscape_front.json"), format="kodak"),
        lambda: fishcam.set_num_threads(0),
        lambda: RandomViewpoint(cam, preset="huge"),
        lambda: RandomViewpoint(cam, depth="sideways"),
        lambda: RandomViewpoint(cam)(image=np.zeros((5, 5, 3), np.uint8)),
        lambda: RandomViewpoint()(image=np.zeros((5, 5, 3), np.uint8)),
    ]
    for i, case in enumerate(cases):
        with pytest.raises(fishcam.Error):
            case()
            pytest.fail(f"case {i} did not raise")
    # The messages are one line and name the argument.
    with pytest.raises(fishcam.Error, match=r"^points: expected shape \(N, 3\)"):
        cam.project(np.zeros((3, 2)))
    with pytest.raises(fishcam.Error, match="image: is 10x10 but the camera is 1280x966"):
        warp.warp(image=np.zeros((10, 10), np.uint8), change=change)


def test_num_threads_are_opencvs(cam):
    import cv2

    before = fishcam.get_num_threads()
    fishcam.set_num_threads(1)
    assert fishcam.get_num_threads() == 1
    if cv2.__file__.startswith("/usr/lib/python3/"):  # Debian's cv2: the OpenCV fishcam links, one pool
        assert cv2.getNumThreads() == 1, "one OpenCV in the process: the pool is shared with cv2 (as documented)"
    fishcam.set_num_threads(max(before, 1))


def test_camera_read_options(cam):
    assert fishcam.Camera.read(data("woodscape_front.json"), camera=0) == cam
    assert fishcam.Camera.read(data("woodscape_front.json"), image_size=(1280, 966)) == cam
    assert fishcam.Camera.read(data("woodscape_front.json"), format="woodscape") == cam


@pytest.mark.parametrize(
    "model,fmt,ext",
    [
        ("double-sphere", "basalt", "json"),
        ("extended-unified", "kalibr", "yaml"),
        ("unified", "kalibr", "yaml"),
        ("mei", "camodocal", "yaml"),
        ("kannala-brandt", "colmap", "txt"),
        ("kannala-brandt", "ros", "yaml"),
        ("kannala-brandt", "orbslam3", "yaml"),
    ],
)
def test_every_model_and_format_reaches_python(cam, tmp_path, model, fmt, ext):
    fitted, report = fishcam.convert(cam, model)
    assert fitted.model == model and report.rms_px < 1.0
    path = tmp_path / f"c.{ext}"
    fitted.write(str(path), format=fmt)
    back = fishcam.Camera.read(str(path), format=fmt)
    rays, ok = cam.unproject(np.array([[640.0, 480.0], [300.0, 200.0], [1000.0, 800.0]]))
    assert ok.all()
    (a, a_ok), (b, b_ok) = back.project(rays), fitted.project(rays)
    assert a_ok.all() and b_ok.all()
    np.testing.assert_allclose(a, b, atol=1e-9)
    assert back.model == model


def test_cameras_of_a_multi_camera_file(cam, tmp_path):
    fitted, _ = fishcam.convert(cam, "kannala-brandt")
    fitted.write(str(tmp_path / "a.yaml"), format="kalibr")
    text = (tmp_path / "a.yaml").read_text()
    (tmp_path / "chain.yaml").write_text(text + text.replace("cam0:", "cam1:"))
    assert fishcam.Camera.read(str(tmp_path / "chain.yaml"), camera="cam1") == fishcam.Camera.read(
        str(tmp_path / "chain.yaml")
    )
    with pytest.raises(fishcam.Error, match="no camera 'cam9'"):
        fishcam.Camera.read(str(tmp_path / "chain.yaml"), camera="cam9")


def test_sampling_exact_and_grid_equal_the_cli(cam, tmp_path):
    import cv2

    image_path = make_image(tmp_path, cam)
    image = cv2.imread(str(image_path), cv2.IMREAD_UNCHANGED)
    warp = fishcam.ViewpointWarp(cam)
    assert warp.grid_spacing == 4 and 0 < warp.grid_error_px <= 1 / 32
    change = fishcam.random_change("train", 5)
    for sampling in ("grid", "exact"):
        run_cli(
            "augment",
            data("woodscape_front.json"),
            "--image",
            image_path,
            "--out-image",
            tmp_path / f"{sampling}.png",
            "--preset",
            "train",
            "--seed",
            5,
            "--sampling",
            sampling,
        )
        out = warp(image=image, change=change, sampling=sampling)
        np.testing.assert_array_equal(out["image"], cv2.imread(str(tmp_path / f"{sampling}.png"), cv2.IMREAD_UNCHANGED))
    grid = warp(image=image, change=change)["image"].astype(float)
    exact = warp(image=image, change=change, sampling="exact")["image"].astype(float)
    assert 0 < np.abs(grid - exact).mean() < 1  # within 1/32 px of each other on a random-noise image
    with pytest.raises(fishcam.Error, match="sampling"):
        warp(image=image, change=change, sampling="nearest")
    with pytest.raises(fishcam.Error, match="sampling"):
        RandomViewpoint(cam, sampling="nearest")


def test_arguments_of_the_wrong_type_are_one_line_fishcam_errors(cam):
    """pybind11's multi-line TypeErrors become fishcam.Error naming the call."""
    warp = fishcam.ViewpointWarp(cam)
    change = fishcam.random_change("small", 1)
    cases = [
        (lambda: fishcam.Camera.read(None), "Camera.read: arguments of the wrong type or range (NoneType)"),
        (lambda: cam.resized(1.5, 5), "Camera.resized"),
        (lambda: warp.warp(image=[[1]], change=change), "ViewpointWarp.warp"),
        (lambda: fishcam.derive_seed(-1, "a", 0), "derive_seed: arguments of the wrong type or range (int, str, int)"),
        (lambda: cam.theta_from_rho("a"), "Camera.theta_from_rho"),
        (lambda: fishcam.metrics.ConfusionMatrix(3, ignore="x"), "ConfusionMatrix"),
        (lambda: fishcam.ViewpointWarp(None), "ViewpointWarp: arguments"),
        (lambda: fishcam.convert(cam, "equidistant", max_angle="x"), "convert: arguments"),
        (lambda: fishcam.compare(cam, ["equidistant"], samples="x"), "samples: expected an integer"),
        (lambda: fishcam.transforms.RandomViewpoint(cam, p="x"), "p: expected a number"),
        (lambda: fishcam.transforms.RandomViewpoint(cam, fill="x"), "fill: expected a number"),
        (
            lambda: fishcam.transforms.RandomViewpoint(cam, max_rotation_deg="x", max_translation=0.1),
            "max_rotation_deg: expected a number",
        ),
        (lambda: fishcam.transforms.RandomViewpoint(cam, fill_mask="x"), "fill_mask: expected an integer"),
        (lambda: fishcam.transforms.RandomAffine(fill_mask=1.5), "fill_mask: expected an integer"),
    ]
    for call, message in cases:
        with pytest.raises(fishcam.Error) as error:
            call()
        assert message in str(error.value) and "\n" not in str(error.value), str(error.value)


def test_the_package_holds_the_extension_objects_themselves():
    """Errors become fishcam.Error inside the extension (python/src/errors.cpp): the
    package wraps nothing, so what it exports is what the stubs describe."""
    assert fishcam.derive_seed is fishcam._fishcam.derive_seed
    assert type(fishcam.derive_seed).__name__ == "builtin_function_or_method"
    for cls in (fishcam.Camera, fishcam.ViewpointWarp, fishcam.ViewpointChange, fishcam._fishcam.AffineChange):
        assert cls is getattr(fishcam._fishcam, cls.__name__)
        for name, member in vars(cls).items():
            function = member.__func__ if isinstance(member, staticmethod) else member
            assert not hasattr(function, "__wrapped__"), f"{cls.__name__}.{name} is wrapped"
    with pytest.raises(fishcam.Error, match=r"^Camera: has no constructor; make one with fishcam.Camera.read"):
        fishcam.Camera()
    with pytest.raises(fishcam.Error, match=r"^Camera.width: an object made without __init__"):
        _ = fishcam.Camera.__new__(fishcam.Camera).width


def test_parameters_key_is_exact_and_cheap(cam):
    """The warp cache's key: equal exactly when the cameras are; the pose counts only
    with with_pose (a warp depends on intrinsics and size)."""
    same = fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json"))
    assert cam.parameters_key() == same.parameters_key() and cam == same and hash(cam) == hash(same)
    assert cam.parameters_key() != cam.resized(640, 483).parameters_key()
    text = json.loads(cam.to_json())
    text["principal_point"][0] += 1e-9
    nudged = fishcam.Camera.from_json(json.dumps(text))
    assert nudged.parameters_key(with_pose=False) != cam.parameters_key(with_pose=False) and nudged != cam
    text = json.loads(cam.to_json())
    text["pose"]["translation"][0] += 0.5
    moved = fishcam.Camera.from_json(json.dumps(text))
    assert moved.parameters_key(with_pose=False) == cam.parameters_key(with_pose=False)
    assert moved.parameters_key() != cam.parameters_key() and moved != cam
    # One warp for cameras that differ only in their pose.
    transform = RandomViewpoint(preset="small")
    transform(image=np.zeros((cam.height, cam.width), np.uint8), camera=cam, seed=1)
    transform(image=np.zeros((cam.height, cam.width), np.uint8), camera=moved, seed=2)
    assert len(transform._warps._warps) == 1


def test_the_package_under_test_is_the_installed_one():
    """The README's test command tests what `pip install .` installed (CTest says so),
    and the wheel's version is the library's."""
    import tomllib

    if os.environ.get("FISHCAM_EXPECT_INSTALLED") == "1":
        assert "site-packages" in fishcam.__file__, fishcam.__file__
    with open(os.path.join(os.path.dirname(__file__), "..", "..", "pyproject.toml"), "rb") as f:
        assert tomllib.load(f)["project"]["version"] == fishcam.__version__

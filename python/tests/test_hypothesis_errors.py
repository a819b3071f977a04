"""Property tests (Hypothesis) of the public API's error paths (issue 40, round 3).

Whatever the arguments' types and values (wrong types, odd dtypes such as bfloat16
and float16, arrays and tensors of 0 to 5 dimensions, NaN and infinities, integers
past 64 bits, negative sizes), a call either succeeds or raises ``fishcam.Error``
(a ValueError) with a one-line message: never TypeError, OverflowError, IndexError,
RuntimeError or SystemError, never a crash. Beside that, the properties behind the
round's bugs: an integer image's fill is a value of its dtype or refused, and a box
costs a bounded number of mapped points however large it is.

The examples are derandomized (the same ones every run; set
FISHCAM_HYPOTHESIS_SEARCH=1 to search afresh, FISHCAM_HYPOTHESIS_SCALE=N for N
times as many) and kept few: the file runs in well under a minute on two cores.
"""

import math
import os
import warnings

import fishcam
import fishcam.torch as ft
import fishcam.transforms as fx
import numpy as np
import pytest
import torch
from conftest import DATA
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from torchvision import tv_tensors

CAMERA_FILE = os.path.join(DATA, "woodscape_front.json")
W, H = 40, 30
CAMERA = fishcam.Camera.read(CAMERA_FILE).resized(W, H)
WARP = fishcam.ViewpointWarp(CAMERA)
CHANGE = fishcam.random_change("large", 3)


def properties(examples: int = 60) -> settings:
    return settings(
        max_examples=examples * int(os.environ.get("FISHCAM_HYPOTHESIS_SCALE", "1")),
        deadline=None,
        database=None,
        derandomize=not os.environ.get("FISHCAM_HYPOTHESIS_SEARCH"),
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
    )


def one_line_or_success(call, *args, **kwargs):
    """call(*args, **kwargs)'s result, or None when it raised fishcam.Error with a
    one-line message; any other exception fails the property."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numpy's casts (ComplexWarning, ...) may warn
            return call(*args, **kwargs)
    except fishcam.Error as error:
        message = str(error)
        assert message.strip(), "an empty message"
        assert "\n" not in message, f"a multi-line message: {message!r}"
        return None
    except Exception as error:  # noqa: BLE001 - the property is that nothing else is raised
        raise AssertionError(f"{type(error).__name__} instead of fishcam.Error: {str(error)[:500]}") from error


# --- strategies --------------------------------------------------------------------

HUGE_INTS = st.sampled_from(
    [2**31, 2**32, 2**63 - 1, 2**63, 2**64, 2**64 + 1, -(2**31) - 1, -(2**63) - 1, 10**400, -(10**400)]
)
INTS = st.one_of(st.integers(-3, 70), st.integers(), HUGE_INTS)
FLOATS = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0.5, -0.0, 1e-300, 1e300]))
NUMPY_SCALARS = st.builds(
    lambda value, kind: kind(value),
    st.integers(0, 100),
    st.sampled_from([np.int8, np.uint8, np.int64, np.uint64, np.float16, np.float32, np.float64, np.bool_]),
)
NUMBERS = st.one_of(INTS, FLOATS, st.booleans(), NUMPY_SCALARS, st.complex_numbers(max_magnitude=10))
# Strings of a few characters (st.text would cache Unicode tables in ./.hypothesis).
TEXTS = st.one_of(
    st.lists(st.sampled_from(list("ab.j/\\ \n\x00\udc80é")), max_size=6).map("".join),
    st.sampled_from(["", ".", "\x00", "a\udc80", "a\nb", "train", "map", "grid"]),
)

NUMPY_DTYPES = [
    np.bool_,
    np.int8,
    np.uint8,
    np.int16,
    np.uint16,
    np.int32,
    np.uint32,
    np.int64,
    np.uint64,
    np.float16,
    np.float32,
    np.float64,
    np.complex64,
    object,
]
TORCH_DTYPES = [
    torch.bool,
    torch.uint8,
    torch.int8,
    torch.int16,
    torch.int32,
    torch.int64,
    torch.float16,
    torch.bfloat16,
    torch.float32,
    torch.float64,
    torch.complex64,
] + [getattr(torch, name) for name in ("uint16", "uint32") if hasattr(torch, name)]
VALUES = [0, 1, -1, 7, 255, 65535, 2**31, 2**63, float("nan"), float("inf"), float("-inf"), 1e300, 0.5]
# Shapes near what the calls take (so the draws get past the first check), and any.
IMAGE_SHAPES = [
    (H, W),
    (H, W, 1),
    (H, W, 3),
    (H, W, 4),
    (H, W, 5),
    (H, W, 0),
    (3, H, W),
    (1, H, W),
    (2, 3, H, W),
    (1, 1, 3, H, W),
    (W, H),
    (H, 1),
    (0, 0),
    (0, H, W),
    (5, H, W),
]
POINT_SHAPES = [(5, 2), (5, 3), (5, 4), (0, 2), (0, 3), (0, 4), (2,), (3,), (), (1, 1, 2), (2, 5)]
SHAPES = st.one_of(st.sampled_from(IMAGE_SHAPES + POINT_SHAPES), st.lists(st.integers(0, 4), max_size=5).map(tuple))


def full(make, shape, value, dtype, zeros):
    """make(shape, value, dtype), or zeros(shape, dtype) where the value does not fit."""
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            return make(shape, value, dtype=dtype)
    except (OverflowError, ValueError, TypeError, RuntimeError):
        return zeros(shape, dtype=dtype)


@st.composite
def arrays(draw, shapes=SHAPES):
    shape = draw(shapes)
    array = full(np.full, shape, draw(st.sampled_from(VALUES)), draw(st.sampled_from(NUMPY_DTYPES)), np.zeros)
    if array.ndim >= 1 and array.shape[-1] > 1 and draw(st.booleans()):
        array = array[..., ::2]  # not contiguous
    return array


@st.composite
def tensors(draw, shapes=SHAPES, dtypes=st.sampled_from(TORCH_DTYPES)):  # noqa: B008 (a strategy, built once)
    return full(torch.full, draw(shapes), draw(st.sampled_from(VALUES)), draw(dtypes), torch.zeros)


JUNK = st.one_of(
    st.none(),
    NUMBERS,
    TEXTS,
    st.binary(max_size=3),
    st.lists(NUMBERS, max_size=4),
    st.tuples(NUMBERS, NUMBERS),
    st.dictionaries(TEXTS, NUMBERS, max_size=2),
    arrays(),
    tensors(),
    st.just(object()),
    st.just(CAMERA),
    st.just(CHANGE),
)


def either(plausible, junk=JUNK):
    """Mostly plausible values, sometimes anything."""
    return st.one_of(plausible, plausible, junk)


POINTS2 = either(st.one_of(arrays(st.sampled_from(POINT_SHAPES)), st.lists(st.lists(NUMBERS, max_size=3), max_size=3)))
POINTS3 = POINTS2
SIDES = either(st.one_of(st.integers(-3, 100), HUGE_INTS))
SEEDS = either(st.one_of(st.integers(0, 2**64 - 1), INTS))
CHANGES = either(st.just(CHANGE))
IMAGES = either(arrays(st.sampled_from(IMAGE_SHAPES)))


def optional_kwargs(draw, **strategies):
    """A random subset of the keyword arguments, each drawn from its strategy."""
    return {name: draw(strategy) for name, strategy in strategies.items() if draw(st.booleans())}


# --- fishcam.Camera -------------------------------------------------------------------

CAMERA_CALLS = {
    "resized": lambda d: CAMERA.resized(d.draw(SIDES), d.draw(SIDES)),
    "project": lambda d: CAMERA.project(d.draw(POINTS3)),
    "unproject": lambda d: CAMERA.unproject(d.draw(POINTS2)),
    "theta_from_rho": lambda d: CAMERA.theta_from_rho(d.draw(either(arrays()))),
    "observed": lambda d: CAMERA.observed(d.draw(POINTS3)),
    "limited_to_observed": lambda d: CAMERA.limited_to_observed(d.draw(either(FLOATS))),
    "parameters_key": lambda d: CAMERA.parameters_key(d.draw(either(st.booleans()))),
    "augmented": lambda d: CAMERA.augmented(d.draw(CHANGES)),
    "projection_uncertainty": lambda d: CAMERA.projection_uncertainty(d.draw(POINTS2), d.draw(either(FLOATS))),
    "read": lambda d: fishcam.Camera.read(
        d.draw(either(st.sampled_from([CAMERA_FILE, DATA, "missing.json"]))),
        **optional_kwargs(
            d.draw,
            camera=either(INTS),
            image_size=either(st.tuples(SIDES, SIDES)),
            format=either(st.sampled_from(["woodscape", "x\ny"])),
            distortion_model=either(st.just("fisheye")),
        ),
    ),
    "from_json": lambda d: fishcam.Camera.from_json(
        d.draw(either(st.sampled_from([CAMERA.to_json(), CAMERA.to_json()[:-9], "{", "[]", "null", '{"model": 5}'])))
    ),
    "constructor": lambda d: fishcam.Camera(*d.draw(st.lists(JUNK, max_size=2))),
    "equality": lambda d: (CAMERA == d.draw(JUNK), CAMERA != d.draw(JUNK), hash(CAMERA)),
}


@properties(100)
@given(st.sampled_from(sorted(CAMERA_CALLS)), st.data())
def test_camera(call, data):
    one_line_or_success(CAMERA_CALLS[call], data)


# --- ViewpointChange, ViewpointWarp ---------------------------------------------------

VECTORS = either(st.one_of(st.lists(NUMBERS, min_size=3, max_size=3), arrays(st.sampled_from([(3,), (2,), (3, 1)]))))
DEPTHS = either(st.sampled_from(["source-sphere", "target-sphere", "infinity", "map"]))
WARP_KWARGS = dict(
    labels=IMAGES,
    depth=DEPTHS,
    fill=either(NUMBERS),
    label_fill=either(INTS),
    return_valid=either(st.booleans()),
    sampling=either(st.sampled_from(["grid", "exact"])),
    depth_map=IMAGES,
    depth_values=either(st.sampled_from(["range", "z"])),
)


def unpickled(cls, state):
    """What unpickling ``state`` (a state fishcam never pickled) makes of ``cls``."""
    made = cls.__new__(cls)
    made.__setstate__(state)
    return made


def warp_calls():
    return {
        "ViewpointChange": lambda d: fishcam.ViewpointChange(
            **optional_kwargs(d.draw, rotation_deg=VECTORS, translation=VECTORS)
        ),
        "AffineChange": lambda d: fishcam._fishcam.AffineChange(
            **optional_kwargs(d.draw, rotation_deg=either(FLOATS), translation=VECTORS, scale=either(FLOATS))
        ),
        "ViewpointWarp": lambda d: fishcam.ViewpointWarp(
            d.draw(either(st.just(CAMERA))),
            **optional_kwargs(
                d.draw, target=either(st.sampled_from([CAMERA, CAMERA.resized(20, 15), CAMERA.resized(2**15, 2**15)]))
            ),
        ),
        "maps": lambda d: WARP.maps(
            d.draw(CHANGES),
            **optional_kwargs(
                d.draw,
                depth=DEPTHS,
                kind=either(st.sampled_from(["geometric", "sampling"])),
                exact=either(st.booleans()),
                grid=either(st.booleans()),
            ),
        ),
        "sampling_grid": lambda d: WARP.sampling_grid(d.draw(CHANGES), **optional_kwargs(d.draw, depth=DEPTHS)),
        "forward": lambda d: WARP.forward(
            d.draw(POINTS2),
            d.draw(CHANGES),
            **optional_kwargs(d.draw, depth=DEPTHS, depth_map=IMAGES, depth_values=WARP_KWARGS["depth_values"]),
        ),
        "warp": lambda d: WARP.warp(
            image=d.draw(IMAGES), change=d.draw(CHANGES), **optional_kwargs(d.draw, **WARP_KWARGS)
        ),
        "__call__": lambda d: WARP(
            image=d.draw(IMAGES), change=d.draw(CHANGES), **optional_kwargs(d.draw, **WARP_KWARGS)
        ),
        "warp_depth": lambda d: WARP.warp_depth(
            d.draw(IMAGES),
            d.draw(CHANGES),
            **optional_kwargs(d.draw, depth=DEPTHS, values=WARP_KWARGS["depth_values"], fill=either(NUMBERS)),
        ),
        "setstate": lambda d: unpickled(
            d.draw(
                st.sampled_from(
                    [fishcam.ViewpointWarp, fishcam.ViewpointChange, fishcam.Camera, fishcam._fishcam.AffineChange]
                )
            ),
            d.draw(st.one_of(JUNK, st.tuples(JUNK, JUNK), st.tuples(JUNK, JUNK, JUNK))),
        ),
    }


WARP_CALLS = warp_calls()


@properties(100)
@given(st.sampled_from(sorted(WARP_CALLS)), st.data())
def test_viewpoint_change_and_warp(call, data):
    one_line_or_success(WARP_CALLS[call], data)


# --- seeds and changes ----------------------------------------------------------------

PRESETS = either(st.sampled_from(["small", "medium", "large", "train", "huge"]))
SEED_CALLS = {
    "random_change": lambda d: fishcam.random_change(d.draw(PRESETS), d.draw(SEEDS)),
    "random_change_in": lambda d: fishcam.random_change_in(
        d.draw(either(FLOATS)), d.draw(either(FLOATS)), d.draw(SEEDS)
    ),
    "derive_seed": lambda d: fishcam.derive_seed(d.draw(SEEDS), d.draw(either(TEXTS)), d.draw(SEEDS)),
    "change_for": lambda d: fx.RandomViewpoint(CAMERA).change_for(d.draw(SEEDS)),
    "affine_change_for": lambda d: fx.RandomAffine().change_for(d.draw(SEEDS)),
    "sample_seed": lambda d: ft.sample_seed(d.draw(SEEDS)).__enter__(),
}


@properties(80)
@given(st.sampled_from(sorted(SEED_CALLS)), st.data())
def test_seeds_and_changes(call, data):
    one_line_or_success(SEED_CALLS[call], data)


# --- fishcam.transforms ---------------------------------------------------------------


def viewpoint_kwargs(draw):
    return optional_kwargs(
        draw,
        camera=either(st.just(CAMERA)),
        preset=PRESETS,
        max_rotation_deg=either(FLOATS),
        max_translation=either(FLOATS),
        depth=DEPTHS,
        p=either(FLOATS),
        fill=either(st.one_of(NUMBERS, st.dictionaries(st.sampled_from(["image", "mask", "others"]), NUMBERS))),
        fill_mask=either(INTS),
        rng=either(st.just(np.random.default_rng(0))),
        sampling=either(st.sampled_from(["grid", "exact"])),
        depth_values=WARP_KWARGS["depth_values"],
    )


def affine_kwargs(draw):
    return optional_kwargs(
        draw,
        preset=PRESETS,
        max_rotation_deg=either(FLOATS),
        max_translation=either(FLOATS),
        scale_range=either(st.tuples(FLOATS, FLOATS)),
        p=either(FLOATS),
        fill=either(NUMBERS),
        fill_mask=either(INTS),
        rng=either(st.just(np.random.default_rng(0))),
    )


def target_kwargs(draw):
    return optional_kwargs(
        draw,
        image=IMAGES,
        mask=IMAGES,
        seed=SEEDS,
        camera=either(st.just(CAMERA)),
        keypoints=POINTS2,
        boxes=POINTS2,
        polygons=either(st.lists(POINTS2, max_size=2)),
        images=either(st.lists(IMAGES, max_size=2)),
        depth_map=IMAGES,
    )


@properties(100)
@given(st.data())
def test_numpy_transform_constructors(data):
    one_line_or_success(lambda: fx.RandomViewpoint(**viewpoint_kwargs(data.draw)))
    one_line_or_success(lambda: fx.RandomAffine(**affine_kwargs(data.draw)))


@properties(100)
@given(st.sampled_from(["viewpoint", "viewpoint-map", "affine"]), st.data())
def test_numpy_transform_calls(kind, data):
    transform = {
        "viewpoint": fx.RandomViewpoint(CAMERA, preset="large"),
        "viewpoint-map": fx.RandomViewpoint(CAMERA, preset="large", depth="map"),
        "affine": fx.RandomAffine(),
    }[kind]
    one_line_or_success(lambda: transform(**target_kwargs(data.draw)))
    if kind == "affine":
        one_line_or_success(lambda: transform.draw(data.draw(either(st.tuples(SIDES, SIDES))), data.draw(SEEDS)))


# --- fishcam.torch --------------------------------------------------------------------

TENSOR_SHAPES = st.one_of(st.sampled_from(IMAGE_SHAPES), SHAPES)


@st.composite
def samples(draw):
    """A sample of odd tensors: plain, tv_tensors.Image, Mask, DepthMap; in a tuple or dict."""
    kinds = draw(
        st.lists(
            st.sampled_from(["plain", "image", "mask", "depth", "boxes", "keypoints", "polygon", "camera"]),
            min_size=1,
            max_size=3,
        )
    )
    out = []
    for kind in kinds:
        if kind == "camera":
            out.append(CAMERA)
            continue
        if kind in ("boxes", "keypoints", "polygon"):
            values = draw(
                tensors(
                    st.sampled_from([(2, 4), (0, 4), (2, 2), (3, 2), (1, 2)]),
                    st.sampled_from([torch.float32, torch.float64, torch.int64, torch.float16, torch.bfloat16]),
                )
            )
            if kind == "boxes" and values.shape[-1] == 4:
                out.append(tv_tensors.BoundingBoxes(values, format="XYXY", canvas_size=(H, W)))
            elif kind == "keypoints" and values.shape[-1] == 2:
                out.append(tv_tensors.KeyPoints(values, canvas_size=(H, W)))
            elif kind == "polygon" and values.shape[-1] == 2:
                out.append(ft.Polygon(values))
            continue
        tensor = draw(tensors(TENSOR_SHAPES))
        if tensor.ndim >= 2 or kind in ("plain", "mask"):
            wrap = {"plain": lambda t: t, "image": tv_tensors.Image, "mask": tv_tensors.Mask, "depth": ft.DepthMap}
            out.append(wrap[kind](tensor))
    return {f"x{i}": x for i, x in enumerate(out)} if draw(st.booleans()) else tuple(out)


def torch_transform(kind, fill, fill_mask, min_visibility):
    if kind == "affine":
        return ft.RandomAffine(preset="large", fill=fill, fill_mask=fill_mask, min_visibility=min_visibility)
    return ft.RandomViewpoint(
        CAMERA,
        preset="large",
        fill=fill,
        fill_mask=fill_mask,
        min_visibility=min_visibility,
        depth="map" if kind == "viewpoint-map" else "source-sphere",
    )


@properties(100)
@given(st.sampled_from(["viewpoint", "viewpoint-map", "affine"]), samples(), st.data())
def test_torch_transforms_on_odd_tensors(kind, sample, data):
    transform = one_line_or_success(
        torch_transform, kind, data.draw(either(NUMBERS)), data.draw(either(INTS)), data.draw(either(FLOATS))
    )
    if transform is not None:
        one_line_or_success(transform, sample)


@properties(50)
@given(tensors(st.sampled_from([(2, 3, H, W), (1, 1, H, W), (2, H, W), (0, 3, H, W)])), st.data())
def test_warp_batch(images, data):
    batch = images.shape[0] if images.ndim == 4 else 1
    masks = data.draw(either(tensors(st.sampled_from([(batch, H, W), (batch, H, W, 1)]))))
    one_line_or_success(
        ft.warp_batch,
        images,
        data.draw(either(st.just(CAMERA))),
        data.draw(either(st.just([CHANGE] * batch))),
        masks=masks,
        fill=data.draw(either(NUMBERS)),
        fill_mask=data.draw(either(INTS)),
    )


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A WoodScape-layout folder of two samples."""
    import cv2

    root = tmp_path_factory.mktemp("woodscape")
    for sub in ["rgb_images", "semantic_annotations/gtLabels", "calibration"]:
        (root / sub).mkdir(parents=True)
    for name in ["a", "b"]:
        cv2.imwrite(str(root / "rgb_images" / f"{name}.png"), np.zeros((H, W, 3), np.uint8))
        cv2.imwrite(str(root / "semantic_annotations/gtLabels" / f"{name}.png"), np.zeros((H, W), np.uint8))
        CAMERA.write(str(root / "calibration" / f"{name}.json"), format="woodscape")
    return ft.WoodScapeDataset(root, transform=ft.RandomViewpoint(preset="small"), seed=1)


TORCH_CALLS = {
    "Polygon": lambda d, _: ft.Polygon(d.draw(either(tensors()))),
    "DepthMap": lambda d, _: ft.DepthMap(d.draw(either(tensors()))),
    "EpochSampler": lambda d, _: ft.EpochSampler(range(3), d.draw(either(INTS))).set_epoch(d.draw(either(INTS))),
    "set_epoch": lambda d, dataset: dataset.set_epoch(d.draw(either(INTS))),
    "item": lambda d, dataset: dataset[
        d.draw(either(st.one_of(st.integers(-2, 1), st.tuples(INTS, st.integers(-2, 1)), st.tuples(INTS, INTS, INTS))))
    ],
    "min_visibility": lambda d, _: ft.RandomViewpoint(min_visibility=d.draw(either(FLOATS))),
}


@properties(60)
@given(st.sampled_from(sorted(TORCH_CALLS)), st.data())
def test_torch_objects(dataset, call, data):
    try:
        one_line_or_success(TORCH_CALLS[call], data, dataset)
    except AssertionError as error:  # an index out of range is the sequence protocol's IndexError
        if not (call == "item" and isinstance(error.__cause__, IndexError) and "out of range" in str(error)):
            raise


# --- the round's bugs as properties -----------------------------------------------------


def holds(dtype, value):
    """Whether images of ``dtype`` hold ``value`` exactly (float: within its range)."""
    if isinstance(value, float) and not np.isfinite(value):
        return False
    if dtype.kind == "f":
        return abs(value) <= float(np.finfo(dtype).max)
    info = np.iinfo(dtype)
    return (isinstance(value, int) or float(value).is_integer()) and info.min <= value <= info.max


NO_SOURCE = WARP.maps(CHANGE)[2] == 0  # where the "large" change of seed 3 has no source
assert NO_SOURCE.any()


@properties(80)
@given(
    st.sampled_from([np.uint8, np.uint16, np.float32]),
    st.one_of(INTS, FLOATS),
    st.sampled_from(["numpy", "torch", "albumentations"]),
)
def test_image_fill_is_a_value_of_the_dtype_or_refused(dtype, fill, adapter):
    """The no-source pixels hold exactly ``fill`` (never a wrapped or saturated value);
    a fill the image's dtype cannot hold is refused."""
    image = np.full((H, W, 3), 9, dtype)
    if adapter == "numpy":
        transform = one_line_or_success(fx.RandomViewpoint, CAMERA, preset="large", fill=fill)
        out = transform and one_line_or_success(lambda: transform(image=image, seed=3)["image"])
    elif adapter == "torch":
        transform = one_line_or_success(ft.RandomViewpoint, CAMERA, preset="large", fill=fill)
        with ft.sample_seed(3):
            out = transform and one_line_or_success(
                lambda: transform(tv_tensors.Image(torch.from_numpy(image).permute(2, 0, 1))).permute(1, 2, 0).numpy()
            )
    else:
        import albumentations as A
        import fishcam.albumentations as fa

        transform = one_line_or_success(fa.RandomViewpoint, CAMERA, preset="large", fill=fill)
        pipeline = transform and A.Compose([transform], seed=0)
        out = pipeline and one_line_or_success(lambda: pipeline(image=image)["image"])
        if out is not None:  # the pipeline's own seed: compare against its change's validity
            valid = WARP.maps(fishcam.random_change("large", transform.params["seed"]))[2]
            assert (out[valid == 0] == np.array(fill, dtype)).all()
            return
    representable = holds(np.dtype(dtype), fill)
    if out is None:
        assert not representable, f"fill {fill!r} refused for {np.dtype(dtype)} images"
        return
    nan = isinstance(fill, float) and math.isnan(fill)
    assert representable or (nan and np.dtype(dtype).kind == "f"), f"fill {fill!r} taken for {dtype}"
    expected = out[NO_SOURCE]
    if nan:
        assert np.isnan(expected).all()
    else:
        assert (expected == np.array(fill, dtype)).all(), f"fill {fill!r} became {np.unique(expected)}"


COORDINATES = st.one_of(st.floats(-1e12, 1e12), st.sampled_from([-np.inf, np.inf, -1e300, 1e300, 0.0, W / 2]))


@properties(60)
@given(
    st.lists(st.tuples(COORDINATES, COORDINATES, COORDINATES, COORDINATES), min_size=1, max_size=4),
    st.sampled_from([None, 1, 3, 6]),
)
def test_boxes_cost_a_bounded_number_of_points(corners, seed):
    """However large a box, its outline costs at most BOX_MAX_POINTS mapped points, and
    the result is finite; a box holding the whole image keeps the content in view."""
    boxes = np.array([[min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)] for x0, y0, x1, y1 in corners])
    transform = fx.RandomViewpoint(CAMERA, preset="large")
    change = transform.draw(seed=seed or 0) if seed else transform.draw(seed=0)
    if seed is None:
        change = fx.RandomViewpoint(CAMERA, preset="large", p=0).draw(seed=0)  # the identity
    counted = []
    forward = change._forward
    change._forward = lambda points: (counted.append(len(points)), forward(points))[1]
    out, visibility = change.boxes(boxes)
    assert sum(counted) <= fx.BOX_MAX_POINTS * len(boxes)
    assert np.isfinite(out).all() and np.isfinite(visibility).all()
    assert ((out >= 0) & (out <= [W, H, W, H])).all() and ((visibility >= 0) & (visibility <= 1)).all()
    unclipped, _ = change.boxes(boxes, clip=False)
    assert np.isfinite(unclipped).all()
    valid = WARP.maps(fishcam.random_change("large", seed) if seed else fishcam.ViewpointChange())[2] != 0
    ys, xs = np.nonzero(valid)
    for box, result in zip(boxes, out):
        if box[0] <= 0 and box[1] <= 0 and box[2] >= W and box[3] >= H and len(xs):
            # Every output pixel with a source shows the box's content: inside its box (1 px slack).
            assert result[0] <= xs.min() + 1 and result[1] <= ys.min() + 1, (box, result)
            assert result[2] >= xs.max() and result[3] >= ys.max(), (box, result)

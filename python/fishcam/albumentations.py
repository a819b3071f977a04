"""fishcam's transforms as albumentations transforms (albumentations >= 2.0; imported
only when it is installed).

    import albumentations as A
    import fishcam.albumentations as fa
    pipeline = A.Compose([fa.RandomViewpoint(camera, preset="train"), A.ColorJitter()],
                         bbox_params=A.BboxParams(format="pascal_voc", label_fields=["labels"]),
                         keypoint_params=A.KeypointParams(format="xy"),
                         additional_targets={"image2": "image", "instances": "mask"}, seed=0)
    out = pipeline(image=image, mask=mask, bboxes=boxes, labels=labels, keypoints=points,
                   depth=depth_map, camera=camera)

One change per call for every target: ``image``/``images`` (HxW or HxWxC uint8,
uint16, float32; bilinear), ``mask``/``masks`` (any integer or bool dtype, kept;
nearest; where there is no source, ``mask`` (semantic labels) gets ``fill_mask``,
or ``fill["mask"]``, while ``masks`` (albumentations' instance masks) and bool masks
get 0 / False whatever it says), ``bboxes`` (the tight box of the densely
transformed outline; albumentations then clips and applies ``min_visibility``),
``keypoints`` (mapped exactly; the angle and scale columns are kept as they are;
hidden points become NaN, so ``remove_invisible`` drops them with those that left
the view), and the
targets albumentations has no type for: ``depth`` (HxW float32 depth map, sampled
without blending, values re-expressed in the moved camera), ``polygons`` (a list of
(K, 2) vertex arrays, edges subdivided to follow the curved image within 0.5 px),
``camera`` (a fishcam.Camera: the camera of the images, returned augmented). The
seed of the change is drawn from the transform's generator, which ``A.Compose(seed=)``
seeds; ``A.ReplayCompose`` replays it.

albumentations' own geometric transforms pass ``camera`` through unchanged: after
them it no longer describes the images. ``HorizontalFlip``, ``VerticalFlip``,
``Resize``, ``RandomCrop``, ``CenterCrop`` and ``Crop`` here are albumentations' own
that also give ``camera`` the image it now describes (``Camera.mirrored``,
``Camera.resized``, ``Camera.cropped``; a padded crop's padding included).
"""

import json
import typing

import numpy as np
import numpy.typing as npt

try:
    import albumentations as _albumentations
    from albumentations.core.transforms_interface import DualTransform as _DualTransform
except ImportError as error:  # pragma: no cover - the message is the point
    raise ImportError(
        f"fishcam.albumentations needs albumentations >= 2.0: pip install albumentations ({error})"
    ) from None

from . import Camera, Error
from . import transforms as _transforms
from .transforms import options as _options
from .transforms.checks import _camera_matches
from .transforms.options import AffineOptions, Unpack, ViewpointOptions

__all__ = [
    "RandomViewpoint",
    "RandomAffine",
    "HorizontalFlip",
    "VerticalFlip",
    "Resize",
    "RandomCrop",
    "CenterCrop",
    "Crop",
]

if int(_albumentations.__version__.split(".")[0]) < 2:  # pragma: no cover
    raise ImportError(f"fishcam.albumentations needs albumentations >= 2.0, found {_albumentations.__version__}")


Array = npt.NDArray[typing.Any]
Params = dict[str, typing.Any]


def _check_camera(camera: object) -> Camera:
    """The ``camera`` target, or fishcam.Error unless it is a fishcam.Camera."""
    if not isinstance(camera, Camera):
        raise Error(f"camera: expected a fishcam.Camera, got {type(camera).__name__}")
    return camera


class _Call:
    """What one call of a transform computed before albumentations applies it target by
    target: its SampleChange, and the image and mask warped together (one pass, the
    maps computed once), each kept with the very input it belongs to."""

    def __init__(self, seed: int, camera: object, depth: object, change: _transforms.SampleChange) -> None:
        self.seed, self.camera, self.depth, self.change = seed, camera, depth, change
        self.fused: dict[str, tuple[Array, Array]] = {}


class _FishcamDualTransform(_DualTransform):
    """The albumentations side: the seed in get_params (from the transform's
    generator), the camera and size from the data, one SampleChange per call for every
    target, the image and mask warped in one pass."""

    def __init__(self, p: float) -> None:
        super().__init__(p=p)
        # Made in get_params_dependent_on_data, found by the call's seed, camera and
        # depth (params carry only those, so ReplayCompose stores and replays numbers;
        # a replay, whose params are copies, draws again: the same change).
        self._call: typing.Optional[_Call] = None

    @property
    def targets(self) -> dict[str, typing.Callable[..., typing.Any]]:
        return {
            **super().targets,
            "depth": self.apply_to_depth,
            "polygons": self.apply_to_polygons,
            "camera": self.apply_to_camera,
        }

    def get_params(self) -> Params:
        return {"seed": int(self.random_generator.integers(0, 2**64, dtype=np.uint64))}

    def get_params_dependent_on_data(self, params: Params, data: Params) -> Params:
        camera = data.get("camera")
        if camera is not None:
            _check_camera(camera)
        # The depth target, for depth="map" (the scene points of the whole sample).
        dependent = {"source_camera": camera, "source_depth": data.get("depth")}
        self._call = None
        call = _Call(params["seed"], camera, dependent["source_depth"], self._change({**params, **dependent}))
        image, mask = data.get("image"), data.get("mask")
        if isinstance(image, np.ndarray) and isinstance(mask, np.ndarray) and mask.ndim == 2:
            out_image, out_mask = call.change.image_and_mask(image, mask)
            call.fused = {"image": (image, out_image), "mask": (mask, out_mask)}
        self._call = call
        return dependent

    def _sample_change(self, params: Params) -> _transforms.SampleChange:
        """This call's SampleChange (made once), or one drawn from params (a replay)."""
        call = self._call
        if (
            call is not None
            and call.seed == params["seed"]
            and call.camera is params.get("source_camera")
            and call.depth is params.get("source_depth")
        ):
            return call.change
        return self._change(params)

    def _fused(self, key: str, array: Array, params: Params) -> typing.Optional[Array]:
        """The output warped with the other raster target, if ``array`` is the input it was made from."""
        call = self._call
        if call is None or call.seed != params["seed"] or key not in call.fused or call.fused[key][0] is not array:
            return None
        return call.fused.pop(key)[1]

    def _change(self, params: Params) -> _transforms.SampleChange:
        raise NotImplementedError

    def apply(self, img: Array, **params: typing.Any) -> Array:
        fused = self._fused("image", img, params)
        return fused if fused is not None else self._sample_change(params).image(img)

    def _mask(self, mask: Array, params: Params, instance: bool) -> Array:
        if mask.ndim == 3:  # albumentations' multi-channel mask: each channel a plane
            return np.stack(
                [self._mask(np.ascontiguousarray(mask[..., c]), params, instance) for c in range(mask.shape[2])],
                axis=-1,
            )
        return self._sample_change(params).mask(mask, instance=instance)

    def apply_to_mask(self, mask: Array, **params: typing.Any) -> Array:
        fused = self._fused("mask", mask, params)
        return fused if fused is not None else self._mask(mask, params, instance=False)  # semantic: fill_mask

    def apply_to_masks(self, masks: Array, **params: typing.Any) -> Array:
        # albumentations' instance masks: 0 / False where there is no source, whatever fill_mask says.
        return self._sample_change(params).instance_masks(np.asarray(masks)) if len(masks) else masks

    def apply_to_images(self, images: Array, **params: typing.Any) -> Array:
        return np.stack([self.apply(x, **params) for x in images])

    def apply_to_bboxes(self, bboxes: Array, **params: typing.Any) -> Array:
        if len(bboxes) == 0:
            return bboxes
        height, width = params["shape"][:2]
        scale = np.array([width, height, width, height], dtype=np.float64)
        boxes, _ = self._sample_change(params).boxes(bboxes[:, :4].astype(np.float64) * scale, clip=False)
        out = bboxes.copy()
        out[:, :4] = boxes / scale
        return out

    def apply_to_keypoints(self, keypoints: Array, **params: typing.Any) -> Array:
        if len(keypoints) == 0:
            return keypoints
        mapped, visible = self._sample_change(params).points(keypoints[:, :2].astype(np.float64))
        height, width = params["shape"][:2]
        inside = (
            (mapped[:, 0] >= -0.5)
            & (mapped[:, 0] < width - 0.5)
            & (mapped[:, 1] >= -0.5)
            & (mapped[:, 1] < height - 0.5)
        )
        mapped[inside & ~visible] = np.nan  # hidden, not merely outside
        out = keypoints.copy()
        out[:, :2] = mapped
        return out

    def apply_to_depth(self, depth: Array, **params: typing.Any) -> Array:
        return self._sample_change(params).depth_map(depth, "depth")

    def apply_to_polygons(self, polygons: typing.Sequence[Array], **params: typing.Any) -> list[Array]:
        change = self._sample_change(params)
        return [change.polygon(p, f"polygons[{i}]") for i, p in enumerate(polygons)]

    def apply_to_camera(self, value: Camera, **params: typing.Any) -> Camera:
        return self._sample_change(params).camera(value)


_CAMERA = (
    "the fishcam.Camera of the images, or its fishcam JSON object (what A.to_dict writes), "
    "or None: then every call passes camera=."
)


def _init_args(defaults: typing.Mapping[str, typing.Any]) -> tuple[str, ...]:
    """The options A.to_dict writes (p is albumentations' own, written by it)."""
    return tuple(name for name in defaults if name != "p")


def _keep(transform: _FishcamDualTransform, options: typing.Mapping[str, typing.Any]) -> None:
    """The options as given, as attributes (what get_transform_init_args reads)."""
    for name in _init_args(options):
        setattr(transform, name, options[name])


class RandomViewpoint(_FishcamDualTransform):
    __doc__ = _options.docstring(
        """fishcam.transforms.RandomViewpoint as an albumentations transform (see the
        module). The camera comes from the constructor or from ``camera=`` in the call;
        ``p`` is albumentations' (its generator decides). ``mask`` is a semantic mask
        (``fill_mask`` where there is no source); ``masks`` and bool masks get 0 / False.
        ``A.to_dict`` writes a constructor camera as its fishcam JSON object
        (``Camera.to_json``), which the constructor (and so ``A.from_dict``) takes back.
        """,
        {"camera": _CAMERA},
        _options.VIEWPOINT_TEXTS,
    )

    @_options.takes_options(ViewpointOptions, _options.VIEWPOINT_DEFAULTS)
    def __init__(
        self, camera: typing.Union[Camera, dict[str, typing.Any], None] = None, **options: Unpack[ViewpointOptions]
    ) -> None:
        given = _options.resolved(options, _options.VIEWPOINT_DEFAULTS, "RandomViewpoint")
        super().__init__(given["p"])
        if isinstance(camera, dict):  # what get_transform_init_args (A.to_dict) writes
            try:
                camera = Camera.from_json(json.dumps(camera))
            except (TypeError, ValueError) as error:
                raise Error(f"camera: not a fishcam JSON camera ({error})") from None
        elif camera is not None and not isinstance(camera, Camera):
            raise Error(f"camera: expected a fishcam.Camera or its fishcam JSON object, got {type(camera).__name__}")
        options.pop("p", None)  # albumentations' (above)
        self._viewpoint = _transforms.RandomViewpoint(camera, **options)
        self.camera = camera
        _keep(self, given)

    def get_transform_init_args_names(self) -> tuple[str, ...]:
        return ("camera", *_init_args(_options.VIEWPOINT_DEFAULTS))

    def get_transform_init_args(self) -> dict[str, typing.Any]:
        """The constructor's arguments for A.to_dict: the camera as its fishcam JSON object."""
        args = typing.cast(dict[str, typing.Any], super().get_transform_init_args())
        if isinstance(args.get("camera"), Camera):
            args["camera"] = json.loads(args["camera"].to_json())
        return args

    def _change(self, params: Params) -> _transforms.SampleChange:
        camera = params.get("source_camera") or self.camera
        if camera is None:
            raise Error("camera: none given (pass one to the constructor or camera= in the call)")
        height, width = params["shape"][:2]
        if (camera.width, camera.height) != (width, height):
            raise Error(f"image: is {width}x{height} but the camera is {camera.width}x{camera.height}")
        return self._viewpoint.draw(camera, params["seed"], params.get("source_depth"))


class RandomAffine(_FishcamDualTransform):
    __doc__ = _options.docstring(
        """fishcam.transforms.RandomAffine (the paper's affine baseline) as an
        albumentations transform; depth maps keep their values, a camera is passed on;
        ``p`` is albumentations', the fills as RandomViewpoint's.
        """,
        _options.AFFINE_TEXTS,
    )

    @_options.takes_options(AffineOptions, _options.AFFINE_DEFAULTS)
    def __init__(self, **options: Unpack[AffineOptions]) -> None:
        given = _options.resolved(options, _options.AFFINE_DEFAULTS, "RandomAffine")
        super().__init__(given["p"])
        options.pop("p", None)  # albumentations' (above)
        self._affine = _transforms.RandomAffine(**options)
        _keep(self, given)

    def get_transform_init_args_names(self) -> tuple[str, ...]:
        return _init_args(_options.AFFINE_DEFAULTS)

    def _change(self, params: Params) -> _transforms.SampleChange:
        height, width = params["shape"][:2]
        return self._affine.draw((width, height), params["seed"])


class _KeepsCamera:
    """The ``camera`` target for one of albumentations' geometric transforms: the
    camera, checked against the sample's size, made to describe the output images."""

    @property
    def targets(self) -> dict[str, typing.Callable[..., typing.Any]]:
        return {**super().targets, "camera": self._camera_target}  # type: ignore[misc]

    def _camera_target(self, value: object, **params: typing.Any) -> Camera:
        camera = _check_camera(value)
        height, width = params["shape"][:2]
        _camera_matches(camera, (int(width), int(height)))
        return self.apply_to_camera(camera, **params)

    def apply_to_camera(self, camera: Camera, **params: typing.Any) -> Camera:
        """The camera of the transformed images (each transform's own)."""
        raise NotImplementedError


class HorizontalFlip(_KeepsCamera, _albumentations.HorizontalFlip):
    """albumentations' ``HorizontalFlip``; ``camera`` mirrored with the images
    (``Camera.mirrored(horizontal=True)``: c'x = width - 1 - cx, a'x = -a_x)."""

    def apply_to_camera(self, camera: Camera, **params: typing.Any) -> Camera:
        """The camera of the flipped images."""
        return camera.mirrored(horizontal=True, vertical=False)


class VerticalFlip(_KeepsCamera, _albumentations.VerticalFlip):
    """albumentations' ``VerticalFlip``; ``camera`` mirrored upside down with the images."""

    def apply_to_camera(self, camera: Camera, **params: typing.Any) -> Camera:
        """The camera of the flipped images."""
        return camera.mirrored(horizontal=False, vertical=True)


class Resize(_KeepsCamera, _albumentations.Resize):
    """albumentations' ``Resize``; ``camera`` resized with the images (``Camera.resized``:
    c' = (c + 0.5) s - 0.5, a' = a s, as pixel centres map)."""

    def apply_to_camera(self, camera: Camera, **params: typing.Any) -> Camera:
        """The camera of the resized images."""
        return camera.resized(int(self.width), int(self.height))


class _CropsCamera(_KeepsCamera):
    def apply_to_camera(self, camera: Camera, **params: typing.Any) -> Camera:
        """The camera of the cropped images."""
        # The crop's window in the (padded, when pad_if_needed pads) image.
        x_min, y_min, x_max, y_max = (int(v) for v in params["crop_coords"])
        pad = params.get("pad_params") or {}
        return camera.cropped(
            x_min - int(pad.get("pad_left", 0)), y_min - int(pad.get("pad_top", 0)), x_max - x_min, y_max - y_min
        )


class RandomCrop(_CropsCamera, _albumentations.RandomCrop):
    """albumentations' ``RandomCrop`` (``pad_if_needed`` included); ``camera`` cropped to the
    same window (``Camera.cropped``: c' = c - (left, top), the padding counted)."""


class CenterCrop(_CropsCamera, _albumentations.CenterCrop):
    """albumentations' ``CenterCrop`` (``pad_if_needed`` included); ``camera`` cropped to the
    same window."""


class Crop(_CropsCamera, _albumentations.Crop):
    """albumentations' ``Crop`` (``pad_if_needed`` included); ``camera`` cropped to the same
    window."""

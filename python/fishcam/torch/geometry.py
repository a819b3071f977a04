"""torchvision's geometric transforms that keep the sample's camera true: Resize,
RandomCrop, CenterCrop, RandomHorizontalFlip and RandomVerticalFlip do to images,
masks, boxes and keypoints what torchvision's do, and give a fishcam.Camera in the
sample the image it now describes (Camera.resized, Camera.cropped, Camera.mirrored),
so the camera still projects scene points onto the transformed image. torchvision's
own geometric transforms pass a camera through unchanged."""

import typing

import torch
from torchvision.transforms import v2

from .. import Camera, Error
from ..transforms.checks import _camera_matches as _checked
from .targets import Params


class Resize(v2.Resize):
    """torchvision's ``v2.Resize`` that keeps the sample's camera true: images, masks,
    boxes and keypoints as ``v2.Resize`` resizes them, and a fishcam.Camera in the
    sample resized to the same size (``Camera.resized``: the same lens, c' = (c + 0.5)
    s - 0.5, a' = a s; pixel centres map as torchvision's resize maps them), so the
    camera still projects scene points onto the resized image. torchvision's own
    geometric transforms (flips, crops, rotations, perspective, ``v2.Resize``) pass a
    camera through unchanged: after them it no longer describes the image."""

    _transformed_types = (*v2.Resize._transformed_types, Camera)

    def make_params(self, flat_inputs: list[typing.Any]) -> Params:
        params: Params = super().make_params(flat_inputs)
        height, width = v2.query_size(flat_inputs)
        probe = v2.functional.resize(
            torch.zeros((1, height, width), dtype=torch.uint8), self.size, max_size=self.max_size, antialias=False
        )
        return {**params, "size": (width, height), "camera_size": (int(probe.shape[-1]), int(probe.shape[-2]))}

    def transform(self, inpt: typing.Any, params: Params) -> typing.Any:
        if isinstance(inpt, Camera):
            _checked(inpt, params["size"])
            return inpt.resized(*params["camera_size"])
        return super().transform(inpt, params)


class RandomCrop(v2.RandomCrop):
    """torchvision's ``v2.RandomCrop`` (padding, pad_if_needed and fill as its own) that
    keeps the sample's camera true: a fishcam.Camera in the sample is cropped with the
    images (``Camera.cropped``: the principal point moved by the padding and the crop's
    corner, the lens unchanged)."""

    _transformed_types = (*v2.RandomCrop._transformed_types, Camera)

    def make_params(self, flat_inputs: list[typing.Any]) -> Params:
        params: Params = super().make_params(flat_inputs)
        height, width = v2.query_size(flat_inputs)
        pad_left, pad_top = params["padding"][0], params["padding"][1]
        window = (params["left"] - pad_left, params["top"] - pad_top, params["width"], params["height"])
        return {**params, "size": (width, height), "window": window}

    def transform(self, inpt: typing.Any, params: Params) -> typing.Any:
        if isinstance(inpt, Camera):
            _checked(inpt, params["size"])
            return inpt.cropped(*params["window"])
        return super().transform(inpt, params)


class CenterCrop(v2.CenterCrop):
    """torchvision's ``v2.CenterCrop`` that keeps the sample's camera true (as
    RandomCrop): the window where ``v2.functional.center_crop`` puts it, padding
    included, measured on the sample's size."""

    _transformed_types = (*v2.CenterCrop._transformed_types, Camera)

    def __init__(self, size: typing.Union[int, typing.Sequence[int]]) -> None:
        super().__init__(size)
        self._windows: dict[tuple[int, int], tuple[int, int, int, int]] = {}  # by the sample's (width, height)

    def make_params(self, flat_inputs: list[typing.Any]) -> Params:
        params: Params = super().make_params(flat_inputs)
        height, width = v2.query_size(flat_inputs)
        window = self._windows.get((width, height))
        if window is None:
            window = self._windows[(width, height)] = self._window(width, height)
        return {**params, "size": (width, height), "window": window}

    def _window(self, width: int, height: int) -> tuple[int, int, int, int]:
        # Where center_crop puts the window: found on a probe of the sample's size whose
        # pixels hold their own coordinates (0: padding), whatever rule torchvision uses.
        rows = torch.arange(1, height + 1, dtype=torch.int32).view(1, height, 1).expand(1, height, width)
        cols = torch.arange(1, width + 1, dtype=torch.int32).view(1, 1, width).expand(1, height, width)
        probe = v2.functional.center_crop(torch.cat([rows, cols]), self.size)
        crop_height, crop_width = int(probe.shape[-2]), int(probe.shape[-1])
        inside = torch.nonzero(probe[0] > 0)
        if len(inside) == 0:
            raise Error(f"CenterCrop: the {crop_width}x{crop_height} window misses the {width}x{height} image")
        y, x = (int(v) for v in inside[0])
        return (int(probe[1, y, x]) - 1 - x, int(probe[0, y, x]) - 1 - y, crop_width, crop_height)

    def transform(self, inpt: typing.Any, params: Params) -> typing.Any:
        if isinstance(inpt, Camera):
            _checked(inpt, params["size"])
            return inpt.cropped(*params["window"])
        return super().transform(inpt, params)


class _MirrorsCamera:
    """A flip's camera: mirrored as the images are (Camera.mirrored), when they are."""

    _mirrors = (False, False)  # (horizontal, vertical)

    def make_params(self, flat_inputs: list[typing.Any]) -> Params:
        height, width = v2.query_size(flat_inputs)
        return {**super().make_params(flat_inputs), "size": (width, height)}  # type: ignore[misc]

    def transform(self, inpt: typing.Any, params: Params) -> typing.Any:
        if isinstance(inpt, Camera):
            _checked(inpt, params["size"])
            return inpt.mirrored(*self._mirrors)
        return super().transform(inpt, params)  # type: ignore[misc]


class RandomHorizontalFlip(_MirrorsCamera, v2.RandomHorizontalFlip):
    """torchvision's ``v2.RandomHorizontalFlip`` that keeps the sample's camera true: when
    the images are flipped left-right, a fishcam.Camera in the sample is mirrored with
    them (``Camera.mirrored(horizontal=True)``: c'x = width - 1 - cx, a'x = -a_x, the
    lens and pose unchanged), so it projects every scene point where the flipped image
    shows it, and a RandomViewpoint after the flip warps with the flipped camera."""

    _transformed_types = (*v2.RandomHorizontalFlip._transformed_types, Camera)
    _mirrors = (True, False)


class RandomVerticalFlip(_MirrorsCamera, v2.RandomVerticalFlip):
    """torchvision's ``v2.RandomVerticalFlip`` that keeps the sample's camera true, as
    RandomHorizontalFlip does (``Camera.mirrored(horizontal=False, vertical=True)``)."""

    _transformed_types = (*v2.RandomVerticalFlip._transformed_types, Camera)
    _mirrors = (False, True)

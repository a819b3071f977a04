"""RandomViewpoint, RandomAffine and Resize as torchvision.transforms.v2 transforms:
one change per call for every target of the sample."""

import typing

import numpy as np
import PIL.Image
import torch
from torchvision import tv_tensors
from torchvision.transforms import v2

from .. import Camera, Error, derive_seed
from .. import transforms as _transforms
from ..transforms import options as _options
from ..transforms.checks import _choice, _number
from ..transforms.options import AffineOptions, Unpack, ViewpointOptions
from . import functional
from .seeding import _sample_records, _sample_seed, torch_seed
from .targets import (
    _MASK_DTYPES,
    DepthMap,
    Params,
    _cpu,
    _image_to_numpy,
    _instance_mask_ids,
    _masks_under_instance_keys,
    _numpy,
    _numpy_to_image,
    _size_of,
    _split_fill,
    _wrapped_like,
    is_instance_mask,
)


class _FishcamTransform(v2.Transform):
    """The v2 side of fishcam's transforms: one SampleChange per call (make_params),
    applied to every input it knows by type (transform)."""

    _transformed_types = (torch.Tensor, Camera)

    def __init__(self, min_visibility: float, boxes: str = "outline") -> None:
        super().__init__()
        if not 0 <= _number(min_visibility, "min_visibility") <= 1:
            raise Error(f"min_visibility: must be in [0, 1], got {min_visibility}")
        self.min_visibility = float(min_visibility)
        self.boxes = _choice(boxes, BOX_MODES, "boxes")

    def _seed(self) -> int:
        """The sample's seed (sample_seed) for the first fishcam transform of the
        sample, seeds derived from it for any later one; else one from torch's generator."""
        seed = _sample_seed.get()
        if seed is None:
            return torch_seed()
        records = _sample_records.get()
        made = len(records) if records is not None else 0
        return seed if made == 0 else derive_seed(seed, "fishcam-transform", made)

    def check_inputs(self, flat_inputs: list[typing.Any]) -> None:
        for x in flat_inputs:
            # Passed through by torchvision, an image or mask in these forms would silently
            # keep its geometry while the rest of the sample moves.
            if isinstance(x, np.ndarray) and x.ndim >= 2:
                raise Error(
                    f"a numpy array {x.shape} in a torchvision pipeline: convert it (torch.from_numpy, "
                    "tv_tensors.Image / Mask), or use fishcam.transforms for numpy samples"
                )
            if isinstance(x, PIL.Image.Image):
                raise Error("PIL images: convert them first (v2.PILToTensor() or v2.ToImage() before this transform)")

    def _draw(self, flat_inputs: list[typing.Any]) -> _transforms.SampleChange:
        raise NotImplementedError

    def forward(self, *inputs: typing.Any) -> typing.Any:
        # The structure is flattened before make_params sees it: the masks under a
        # "masks" key (instance masks) are found here, by id, for the call.
        token = _instance_mask_ids.set(frozenset(_masks_under_instance_keys(inputs)))
        try:
            return super().forward(*inputs)
        finally:
            _instance_mask_ids.reset(token)

    def make_params(self, flat_inputs: list[typing.Any]) -> Params:
        sample_change = self._draw(flat_inputs)
        records = _sample_records.get()
        if records is not None:
            records.append(sample_change.record)
        instance_ids = _instance_mask_ids.get()
        return {
            "change": sample_change,
            "instance_masks": self._paired_masks(flat_inputs, instance_ids) if self.boxes == "from_masks" else None,
            "instance_ids": instance_ids,
            "done": self._image_and_mask(flat_inputs, sample_change, instance_ids),
        }

    @staticmethod
    def _paired_masks(
        flat_inputs: list[typing.Any], instance_ids: typing.AbstractSet[int]
    ) -> typing.Optional[torch.Tensor]:
        """boxes="from_masks": the NxHxW instance masks paired by index with the
        sample's N boxes, as torchvision's detection targets pair them -- those under
        the key "masks" (a {"boxes", "labels", "masks"} target), else the one set of
        instance masks in the sample; a count that differs, or a choice that would be a
        guess, is refused. A sample without boxes has nothing to pair (None)."""
        boxes = [x for x in flat_inputs if isinstance(x, tv_tensors.BoundingBoxes)]
        if not boxes:
            return None
        if len(boxes) != 1:
            raise Error(f'boxes="from_masks": expected one BoundingBoxes in the sample, got {len(boxes)}')
        masks = [
            x
            for x in flat_inputs
            if isinstance(x, tv_tensors.Mask) and x.ndim == 3 and is_instance_mask(x, id(x) in instance_ids)
        ]
        targets = [m for m in masks if id(m) in instance_ids]
        chosen = targets if len(targets) == 1 else masks
        if len(chosen) != 1:
            raise Error(
                f'boxes="from_masks": expected the instance masks under "masks" or one NxHxW instance Mask in the '
                f"sample, got {len(masks)} instance masks"
            )
        if boxes[0].shape[0] != chosen[0].shape[0]:
            raise Error(
                f'boxes="from_masks": {boxes[0].shape[0]} boxes but {chosen[0].shape[0]} instance masks (box i is '
                "mask i's: the counts must match)"
            )
        return typing.cast(torch.Tensor, chosen[0])

    @staticmethod
    def _image_and_mask(
        flat_inputs: list[typing.Any],
        change: _transforms.SampleChange,
        instance_ids: typing.AbstractSet[int] = frozenset(),
    ) -> dict[int, torch.Tensor]:
        """The sample's first image and first HxW mask resampled in one pass (the maps
        computed once for both), keyed by the inputs' ids for transform()."""
        images = [
            x
            for x in flat_inputs
            if isinstance(x, torch.Tensor)
            and x.ndim == 3
            and (isinstance(x, tv_tensors.Image) or not isinstance(x, tv_tensors.TVTensor))
        ]
        masks = [x for x in flat_inputs if isinstance(x, tv_tensors.Mask) and x.ndim == 2]
        if not images or not masks:
            return {}
        image, mask = images[0], masks[0]
        out_image, out_mask = change.image_and_mask(
            _image_to_numpy(image, "image"),
            _numpy(mask, "mask", _MASK_DTYPES),
            instance=is_instance_mask(mask, id(mask) in instance_ids),
        )
        return {
            id(image): _numpy_to_image(out_image, image),
            id(mask): _wrapped_like(torch.from_numpy(out_mask), mask),
        }

    def transform(self, inpt: typing.Any, params: Params) -> typing.Any:
        done = params["done"].get(id(inpt))
        if done is not None:
            return done
        instance = None
        if isinstance(inpt, tv_tensors.Mask):
            instance = is_instance_mask(inpt, id(inpt) in params.get("instance_ids", ()))
        options = functional.ChangeOptions(instance, self.min_visibility, params["instance_masks"])
        return functional.apply_change(inpt, params["change"], options)


# How BoundingBoxes follow the change: "outline" -- each box from its own outline,
# densely transformed (amodal boxes stay amodal; the default) -- or "from_masks" --
# the tight box of the instance mask of the same index.
BOX_MODES = ("outline", "from_masks")

# The extras of the torch transforms, beside the options they share with the numpy
# and albumentations ones.
_EXTRA_TEXTS = {
    "min_visibility": "boxes seen less than this share of their area collapse to zero size, which "
    "v2.SanitizeBoundingBoxes drops (the same share in both box modes: of the box's transformed outline).",
    "boxes": '"outline" (the default: each box from its own densely transformed outline) or "from_masks": '
    "box i becomes the tight box of instance mask i (the sample's one NxHxW instance Mask, N = the number "
    "of boxes, else fishcam.Error), as torchvision pairs detection targets (or its fishcam.BoxMode).",
}

_Options = typing.TypeVar("_Options", ViewpointOptions, AffineOptions)


def _numpy_fill(options: _Options) -> _Options:
    """The options as the numpy transform takes them: a fill dict keyed by
    tv_tensors.Image and tv_tensors.Mask becomes the two numbers (numbers go as
    they are, checked by the numpy transform)."""
    fill = options.get("fill")
    if isinstance(fill, typing.Mapping):
        options["fill"], options["fill_mask"] = _split_fill(fill, options.get("fill_mask", 0))
    return options


class RandomViewpoint(_FishcamTransform):
    __doc__ = _options.docstring(
        """The paper's viewpoint change as a torchvision v2 transform: one random change
        per call for everything in the sample (any structure v2 takes; the same structure
        back). The camera comes from the constructor or from a fishcam.Camera in the
        sample (which comes back as the augmented camera: its pose moved by the change).
        Without a seeded dataset, the seed comes from torch's generator.

        Targets: ``tv_tensors.Image`` or plain image tensors (CxHxW or a batch BxCxHxW
        sharing the camera; uint8, uint16, float32; bilinear), ``tv_tensors.Mask`` (HxW
        class ids or NxHxW instance masks, any integer or bool dtype, kept; nearest),
        ``tv_tensors.BoundingBoxes`` (each box from its own densely transformed outline,
        so amodal and loose boxes keep their meaning, or the tight box of its instance
        mask: ``boxes``; clipped; boxes seen less than ``min_visibility`` collapse to
        zero size), ``tv_tensors.KeyPoints`` (mapped exactly; points that leave the view
        keep their coordinates outside the canvas, NaN where they have no image),
        ``fishcam.torch.DepthMap``, ``fishcam.torch.Polygon``.

        Where the moved camera has no source, semantic masks (HxW or 1xHxW, integer
        dtype) get ``fill_mask``; instance masks get 0 (False), so no-source pixels join
        no instance and the boxes taken from the masks stay tight: bool masks, NxHxW
        masks with N >= 2, and the masks under the key "masks" of a dict (a detection
        target ``{"boxes", "labels", "masks"}``; ``is_instance_mask``).
        """,
        {"camera": "the fishcam.Camera of the images, or None: then the sample must hold one."},
        _options.VIEWPOINT_TEXTS,
        _EXTRA_TEXTS,
    )

    @_options.takes_options(ViewpointOptions, _options.VIEWPOINT_DEFAULTS)
    def __init__(
        self,
        camera: typing.Optional[Camera] = None,
        *,
        min_visibility: float = 0.0,
        boxes: str = "outline",
        **options: Unpack[ViewpointOptions],
    ) -> None:
        _options.checked(options, _options.VIEWPOINT_DEFAULTS, "RandomViewpoint")
        super().__init__(min_visibility, boxes)
        self.numpy_transform = _transforms.RandomViewpoint(camera, **_numpy_fill(options))

    def _draw(self, flat_inputs: list[typing.Any]) -> _transforms.SampleChange:
        cameras = [x for x in flat_inputs if isinstance(x, Camera)]
        if len(cameras) > 1 and any(c != cameras[0] for c in cameras[1:]):
            raise Error("camera: the sample holds several different cameras; one change needs one camera")
        camera = cameras[0] if cameras else self.numpy_transform.camera
        if camera is None:
            raise Error("camera: none given (pass one to the constructor or put a fishcam.Camera in the sample)")
        depth_map = None
        if self.numpy_transform.depth == "map":  # the sample's DepthMap places the scene points
            maps = [x for x in flat_inputs if isinstance(x, DepthMap)]
            if len(maps) != 1:
                raise Error(f"depth='map' needs exactly one fishcam.torch.DepthMap in the sample, got {len(maps)}")
            tensor = _cpu(maps[0], "depth map")
            plane = tensor.reshape(tensor.shape[-2:]) if tensor.ndim == 3 and tensor.shape[0] == 1 else tensor
            depth_map = _numpy(plane, "depth map", "HxW or 1xHxW float32")
        return self.numpy_transform.draw(camera, self._seed(), depth_map)

    def extra_repr(self) -> str:
        return (
            repr(self.numpy_transform)[len("RandomViewpoint(") : -1]
            + f", min_visibility={self.min_visibility}, boxes={self.boxes!r}"
        )


class RandomAffine(_FishcamTransform):
    __doc__ = _options.docstring(
        """The paper's affine baseline (fishcam.transforms.RandomAffine) as a torchvision
        v2 transform, with the targets of RandomViewpoint (depth maps keep their values;
        a camera in the sample is passed on unchanged: the baseline has no camera model)
        and its fills (instance masks get 0 / False).
        """,
        _options.AFFINE_TEXTS,
        _EXTRA_TEXTS,
    )

    @_options.takes_options(AffineOptions, _options.AFFINE_DEFAULTS)
    def __init__(
        self, *, min_visibility: float = 0.0, boxes: str = "outline", **options: Unpack[AffineOptions]
    ) -> None:
        _options.checked(options, _options.AFFINE_DEFAULTS, "RandomAffine")
        super().__init__(min_visibility, boxes)
        self.numpy_transform = _transforms.RandomAffine(**_numpy_fill(options))

    def _draw(self, flat_inputs: list[typing.Any]) -> _transforms.SampleChange:
        return self.numpy_transform.draw(_size_of(flat_inputs), self._seed())

    def extra_repr(self) -> str:
        return (
            repr(self.numpy_transform)[len("RandomAffine(") : -1]
            + f", min_visibility={self.min_visibility}, boxes={self.boxes!r}"
        )

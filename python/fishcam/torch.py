"""fishcam for PyTorch: the viewpoint change (and the affine baseline) as
torchvision.transforms.v2 transforms, a WoodScape dataset that hands whole samples
to its transform, an epoch-carrying sampler, and the DataLoader worker set-up.

    from torchvision.transforms import v2
    transform = v2.Compose([fishcam.torch.RandomViewpoint(preset="train"),   # camera from the sample
                            v2.ColorJitter(0.2, 0.2), v2.ToDtype(torch.float32, scale=True)])
    dataset = fishcam.torch.WoodScapeDataset(root, transform=transform, seed=5)
    loader = torch.utils.data.DataLoader(dataset, batch_size=8, num_workers=2,
                                         sampler=fishcam.torch.EpochSampler(torch.utils.data.RandomSampler(dataset)),
                                         worker_init_fn=fishcam.torch.worker_init_fn,
                                         persistent_workers=True,  # workers keep their warps
                                         collate_fn=fishcam.torch.collate,
                                         generator=torch.Generator().manual_seed(0))

Seeding: without a dataset seed, each sample's change comes from torch's generator
(two 32-bit draws, since torch.randint cannot draw 64 bits), which the DataLoader
seeds per worker from its own generator: workers differ, and the same generator
seed reproduces a run. With ``WoodScapeDataset(seed=S)``, sample ``i`` of epoch
``e`` gets ``derive_seed(S, f"epoch{e}", i)`` whatever the workers and processes:
the epoch travels with the index from ``EpochSampler``, which runs in the main
process and counts the epochs itself; torch's generator is seeded with that seed
for the call, so the other random transforms of the pipeline follow it too. A
seeded dataset indexed by a bare index raises instead of repeating one epoch's
changes: always inside a DataLoader worker (a worker's copy of the dataset never
sees ``set_epoch`` from the main process), and in the main process until
``set_epoch`` is called.
"""

import contextlib
import contextvars
import json
import operator
import os
import typing

import numpy as np
import PIL.Image
import torch

try:
    from torchvision import tv_tensors
    from torchvision.transforms import v2
except ImportError as error:  # pragma: no cover - the message is the point
    raise ImportError(
        "fishcam.torch needs torchvision >= 0.23 (transforms.v2 and tv_tensors.KeyPoints): "
        f"pip install torchvision ({error})"
    ) from None
if not hasattr(tv_tensors, "KeyPoints"):  # pragma: no cover
    raise ImportError("fishcam.torch needs torchvision >= 0.23 (tv_tensors.KeyPoints); pip install -U torchvision")

from . import Camera, Error, ViewpointChange, _check_seed, _shown, derive_seed, set_num_threads
from . import transforms as _transforms

__all__ = [
    "RandomViewpoint",
    "RandomAffine",
    "Resize",
    "DepthMap",
    "Polygon",
    "WoodScapeDataset",
    "EpochSampler",
    "WarpedBatch",
    "warp_batch",
    "collate",
    "sample_seed",
    "record_changes",
    "worker_init_fn",
    "torch_seed",
    "is_instance_mask",
]


Sample = typing.Any  # anything torchvision.transforms.v2 takes: a tensor, a tuple, a dict, ...
Params = dict[str, typing.Any]


def _cv2() -> typing.Any:
    import cv2  # python3-opencv: only the dataset needs it

    return cv2


def torch_seed() -> int:
    """One 64-bit seed from torch's (per-worker) generator."""
    hi, lo = torch.randint(0, 2**32, (2,), dtype=torch.int64).tolist()
    return int((hi << 32) | lo)


def worker_init_fn(worker_id: int) -> None:
    """For DataLoader workers: one fishcam thread each (the workers are the parallelism)."""
    del worker_id
    set_num_threads(1)


def _tensor_of(
    cls: type[tv_tensors.TVTensor],
    data: typing.Any,
    dtype: typing.Optional[torch.dtype],
    device: typing.Optional[torch.device],
    requires_grad: typing.Optional[bool],
) -> torch.Tensor:
    """torch's tensor of ``data`` for a fishcam tv_tensor, or fishcam.Error naming the class."""
    try:
        return typing.cast(torch.Tensor, cls._to_tensor(data, dtype=dtype, device=device, requires_grad=requires_grad))
    except (TypeError, ValueError, RuntimeError, OverflowError) as error:
        raise Error(
            f"{cls.__name__}: not a tensor of numbers ({type(data).__name__}): "
            f"{str(error).splitlines()[0] if str(error) else type(error).__name__}"
        ) from None


class DepthMap(tv_tensors.TVTensor):
    """A depth map (HxW or 1xHxW float32): the range along each pixel's ray, or its
    z (the transform's ``depth_values``). fishcam's transforms sample it without
    blending and re-express its values in the moved camera; torchvision's own
    transforms do not know it and pass it through unchanged (a flip or crop after
    fishcam's transform would leave it behind)."""

    @classmethod
    def _wrap(cls, tensor: torch.Tensor) -> "DepthMap":
        return tensor.as_subclass(cls)

    def __new__(
        cls,
        data: typing.Any,
        *,
        dtype: typing.Optional[torch.dtype] = None,
        device: typing.Optional[torch.device] = None,
        requires_grad: typing.Optional[bool] = None,
    ) -> "DepthMap":
        return cls._wrap(_tensor_of(cls, data, dtype, device, requires_grad))


class Polygon(tv_tensors.TVTensor):
    """One closed polygon, (K, 2) float pixels x, y (pixel centres at integers), e.g.
    a WoodScape instance outline. fishcam's transforms map its vertices and subdivide
    its edges so that they follow the curved image within 0.5 px (K changes); put
    several in a list. torchvision's own transforms pass it through."""

    @classmethod
    def _wrap(cls, tensor: torch.Tensor) -> "Polygon":
        return tensor.as_subclass(cls)

    def __new__(
        cls,
        data: typing.Any,
        *,
        dtype: typing.Optional[torch.dtype] = None,
        device: typing.Optional[torch.device] = None,
        requires_grad: typing.Optional[bool] = None,
    ) -> "Polygon":
        tensor = _tensor_of(cls, data, dtype, device, requires_grad)
        if tensor.ndim != 2 or tensor.shape[-1] != 2:
            raise Error(f"Polygon: expected shape (K, 2), got {tuple(tensor.shape)}")
        return cls._wrap(tensor)


# The seed a seeded dataset gives the transforms of one sample, and the records of
# the changes they made (WoodScapeDataset reads them back into the item).
_sample_seed: "contextvars.ContextVar[typing.Optional[int]]" = contextvars.ContextVar(
    "fishcam_sample_seed", default=None
)
_sample_records: "contextvars.ContextVar[typing.Optional[list[_transforms.Record]]]" = contextvars.ContextVar(
    "fishcam_sample_records", default=None
)


@contextlib.contextmanager
def record_changes() -> typing.Iterator[list[_transforms.Record]]:
    """Within the block, fishcam's transforms append the record of each change they
    make (the manifest's dict: method, seed, rotation, translation, depth) to the
    list this yields."""
    records: list[_transforms.Record] = []
    token = _sample_records.set(records)
    try:
        yield records
    finally:
        _sample_records.reset(token)


@contextlib.contextmanager
def sample_seed(seed: int) -> typing.Iterator[list[_transforms.Record]]:
    """Within the block, fishcam's transforms use ``seed`` (one 64-bit integer) instead
    of drawing one, and torch's generator is seeded with it (restored afterwards), so
    every random transform of a pipeline is reproducible per sample. Yields the list
    of change records, as record_changes."""
    seed = _check_seed(seed)
    token = _sample_seed.set(seed)
    try:
        with record_changes() as records, torch.random.fork_rng(devices=[]):
            torch.default_generator.manual_seed(seed)  # the CPU's: torch.manual_seed also queues every device's
            yield records
    finally:
        _sample_seed.reset(token)


def _cpu(tensor: torch.Tensor, what: str) -> torch.Tensor:
    if tensor.device.type != "cpu":
        raise Error(f"{what}: fishcam runs on the CPU; got a tensor on {tensor.device} (move it with .cpu())")
    return tensor.detach()


def _numpy(tensor: torch.Tensor, what: str, expected: str) -> _transforms.Array:
    """A CPU tensor as numpy (a view), or fishcam.Error naming ``expected`` for a
    dtype numpy has not (bfloat16, complex32, float8, quantized...)."""
    tensor = _cpu(tensor, what).resolve_conj().resolve_neg()
    try:
        array: _transforms.Array = tensor.numpy()
    except (TypeError, RuntimeError):
        raise Error(f"{what}: expected {expected}, got dtype {tensor.dtype}") from None
    return array


_IMAGE_DTYPES = "dtype uint8, uint16 or float32 (float64 is taken as float32)"
_MASK_DTYPES = "an integer or bool dtype"


def _image_to_numpy(tensor: torch.Tensor, what: str) -> _transforms.Array:
    """CHW (or HW) tensor -> HWC numpy (a view; the warp copies if it must), refusing
    what the warp cannot take with the layout in the message."""
    tensor = _cpu(tensor, what)
    if tensor.ndim not in (2, 3):
        raise Error(f"{what}: expected CxHxW or HxW, got shape {tuple(tensor.shape)}")
    if tensor.dtype == torch.float64:
        tensor = tensor.float()
    array = _numpy(tensor, what, _IMAGE_DTYPES)
    return np.moveaxis(array, 0, -1) if array.ndim == 3 else array


def _numpy_to_image(array: _transforms.Array, like: torch.Tensor) -> torch.Tensor:
    # CHW as a view of the HWC result (as the dataset's own images are): no copy.
    out = torch.from_numpy(array)
    out = out.permute(2, 0, 1) if out.ndim == 3 else out
    out = out.to(like.dtype) if out.dtype != like.dtype else out
    return tv_tensors.wrap(out, like=like) if isinstance(like, tv_tensors.TVTensor) else out


# The fill by target: a number (the images') or a dict keyed by tv_tensors.Image and/or tv_tensors.Mask.
Fill = _transforms.Fill

# The key under which a detection target ({"boxes", "labels", "masks"}, Mask R-CNN's)
# holds its instance masks; and the ids of the masks found under it in the sample
# being transformed (set by _FishcamTransform.forward for its make_params).
_INSTANCE_MASKS_KEY = "masks"
_instance_mask_ids: "contextvars.ContextVar[frozenset[int]]" = contextvars.ContextVar(
    "fishcam_instance_mask_ids", default=frozenset()
)


def _split_fill(fill: object, fill_mask: object) -> tuple[typing.Any, int]:
    """(the images' fill, the semantic masks' fill) of a torch transform's arguments."""
    return _transforms._split_fill(fill, fill_mask, tv_tensors.Image, tv_tensors.Mask)


def _masks_under_instance_keys(
    structure: typing.Any, inside: bool = False, found: typing.Optional[set[int]] = None
) -> set[int]:
    """The ids of the tv_tensors.Mask leaves of ``structure`` held under the key
    "masks" of a dict, at any depth (the sample's own or a target's)."""
    found = set() if found is None else found
    if isinstance(structure, tv_tensors.Mask):
        if inside:
            found.add(id(structure))
    elif isinstance(structure, typing.Mapping):
        for key, value in structure.items():
            _masks_under_instance_keys(value, inside or key == _INSTANCE_MASKS_KEY, found)
    elif isinstance(structure, (list, tuple)):
        for value in structure:
            _masks_under_instance_keys(value, inside, found)
    return found


def is_instance_mask(mask: torch.Tensor, under_masks_key: bool = False) -> bool:
    """Whether fishcam's torch transforms take ``mask`` for instance masks (0 / False
    where there is no source, whatever ``fill_mask`` says) rather than a semantic
    label map (``fill_mask``): a bool mask, an NxHxW mask with N >= 2, or any mask
    under the key "masks" of a dict in the sample (``under_masks_key``: a detection
    target, ``{"boxes", "labels", "masks"}``). HxW and 1xHxW masks of an integer
    dtype elsewhere are semantic."""
    return under_masks_key or mask.dtype == torch.bool or (mask.ndim == 3 and mask.shape[0] >= 2)


def _size_of(flat_inputs: list[typing.Any]) -> tuple[int, int]:
    """(width, height) of the sample's images, masks or depth maps (or plain tensors
    of 2 or more dimensions, taken for images), else of its boxes or keypoints."""
    for x in flat_inputs:
        if isinstance(x, (tv_tensors.Image, tv_tensors.Mask, DepthMap)) or (
            isinstance(x, torch.Tensor) and not isinstance(x, tv_tensors.TVTensor)
        ):
            if x.ndim < 2:
                if isinstance(x, tv_tensors.TVTensor):
                    raise Error(f"{type(x).__name__}: expected 2 or more dimensions, got shape {tuple(x.shape)}")
                continue  # a plain scalar or vector (a label, an id): not an image
            return int(x.shape[-1]), int(x.shape[-2])
        if isinstance(x, (tv_tensors.BoundingBoxes, tv_tensors.KeyPoints)):
            return int(x.canvas_size[1]), int(x.canvas_size[0])
    raise Error("nothing to size the change by: the sample has no image, mask, depth map, boxes or keypoints")


class _FishcamTransform(v2.Transform):
    """The v2 side of fishcam's transforms: one SampleChange per call (make_params),
    applied to every input it knows by type (transform)."""

    _transformed_types = (torch.Tensor, Camera)

    def __init__(self, min_visibility: float, boxes: str = "outline") -> None:
        super().__init__()
        if not 0 <= _transforms._number(min_visibility, "min_visibility") <= 1:
            raise Error(f"min_visibility: must be in [0, 1], got {min_visibility}")
        self.min_visibility = float(min_visibility)
        self.boxes = _transforms._choice(boxes, BOX_MODES, "boxes")

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
            id(mask): tv_tensors.wrap(torch.from_numpy(out_mask), like=mask),
        }

    def transform(self, inpt: typing.Any, params: Params) -> typing.Any:
        done = params["done"].get(id(inpt))
        if done is not None:
            return done
        change = params["change"]
        if isinstance(inpt, Camera):
            return change.camera(inpt)
        if isinstance(inpt, tv_tensors.BoundingBoxes):
            return self._boxes(inpt, change, params["instance_masks"])
        if isinstance(inpt, tv_tensors.KeyPoints):
            points = _cpu(inpt, "keypoints").reshape(-1, 2).double().numpy()
            mapped, visible = change.points(points)
            out = torch.from_numpy(mapped).to(inpt.dtype).reshape(inpt.shape)
            return tv_tensors.wrap(out, like=inpt)
        if isinstance(inpt, Polygon):
            mapped = change.polygon(_cpu(inpt, "polygon").double().numpy())
            return tv_tensors.wrap(torch.from_numpy(mapped).to(inpt.dtype), like=inpt)
        if isinstance(inpt, DepthMap):
            tensor = _cpu(inpt, "depth map")
            flat = tensor.reshape(tensor.shape[-2:]) if tensor.ndim == 3 and tensor.shape[0] == 1 else tensor
            if flat.ndim != 2 or flat.dtype != torch.float32:
                raise Error(f"depth map: expected HxW or 1xHxW float32, got {tuple(tensor.shape)} {tensor.dtype}")
            out = torch.from_numpy(change.depth_map(flat.numpy())).reshape(tensor.shape)
            return tv_tensors.wrap(out, like=inpt)
        if isinstance(inpt, tv_tensors.Mask):
            instance = is_instance_mask(inpt, id(inpt) in params.get("instance_ids", ()))
            return tv_tensors.wrap(self._masks(inpt, change, instance), like=inpt)
        if isinstance(inpt, tv_tensors.TVTensor) and not isinstance(inpt, (tv_tensors.Image, tv_tensors.Video)):
            raise Error(f"{type(inpt).__name__}: not a target fishcam's transforms know")
        return self._images(inpt, change)

    @staticmethod
    def _masks(mask: torch.Tensor, change: _transforms.SampleChange, instance: bool) -> torch.Tensor:
        """HxW or NxHxW masks resampled (each plane on its own); where there is no
        source, 0 (False) for instance masks, else the semantic masks' fill."""
        tensor = _cpu(mask, "mask")
        if tensor.ndim == 2:
            return torch.from_numpy(change.mask(_numpy(tensor, "mask", _MASK_DTYPES), instance=instance))
        if tensor.ndim == 3:  # instance masks (N, H, W), or a 1xHxW label map: each plane on its own
            planes = [
                change.mask(_numpy(plane, f"mask[{i}]", _MASK_DTYPES), f"mask[{i}]", instance)
                for i, plane in enumerate(tensor)
            ]
            return torch.from_numpy(np.stack(planes)) if planes else tensor.clone()
        raise Error(f"mask: expected HxW or NxHxW, got shape {tuple(tensor.shape)}")

    @staticmethod
    def _images(image: torch.Tensor, change: _transforms.SampleChange) -> torch.Tensor:
        if image.ndim == 4:  # a batch of images sharing the camera
            return torch.stack([_FishcamTransform._images(x, change) for x in image])
        array = _image_to_numpy(image, "image")
        return _numpy_to_image(change.image(array), image)

    def _boxes(
        self,
        boxes: tv_tensors.BoundingBoxes,
        change: _transforms.SampleChange,
        instance_masks: typing.Optional[torch.Tensor],
    ) -> tv_tensors.BoundingBoxes:
        fmt = boxes.format
        if "ROTATED" in str(fmt).upper() or "XYXYXYXY" in str(fmt).upper():
            raise Error(f"boxes: rotated boxes ({fmt}) are not supported; use keypoints for their corners")
        xyxy = v2.functional.convert_bounding_box_format(
            boxes.as_subclass(torch.Tensor), old_format=fmt, new_format=tv_tensors.BoundingBoxFormat.XYXY
        )
        # Each box's own outline, densely transformed: its place and, in both modes, its
        # visibility (the share of the transformed box inside the image).
        mapped, seen = change.boxes(_cpu(xyxy, "boxes").double().numpy())
        out, visibility = torch.from_numpy(mapped), torch.from_numpy(seen)
        if instance_masks is not None:  # from_masks: the tight box of mask i (no-source pixels: in none)
            warped = self._masks(instance_masks, change, instance=True)
            out = torch.zeros((len(warped), 4), dtype=torch.float64)
            for i, plane in enumerate(warped):
                ys, xs = torch.nonzero(plane, as_tuple=True)
                if len(xs):
                    out[i] = torch.tensor([xs.min(), ys.min(), xs.max() + 1, ys.max() + 1], dtype=torch.float64)
                else:
                    visibility[i] = 0  # the instance left the image
        # Boxes seen too little collapse to nothing: v2.SanitizeBoundingBoxes drops them.
        out[visibility < self.min_visibility] = 0
        out = v2.functional.convert_bounding_box_format(
            out.to(boxes.dtype), old_format=tv_tensors.BoundingBoxFormat.XYXY, new_format=fmt
        )
        return tv_tensors.wrap(out, like=boxes)


# How BoundingBoxes follow the change: "outline" -- each box from its own outline,
# densely transformed (amodal boxes stay amodal; the default) -- or "from_masks" --
# the tight box of the instance mask of the same index.
BOX_MODES = ("outline", "from_masks")


class RandomViewpoint(_FishcamTransform):
    """The paper's viewpoint change as a torchvision v2 transform: one random change
    per call for everything in the sample (any structure v2 takes; the same structure
    back). The camera comes from the constructor or from a fishcam.Camera in the
    sample (which comes back as the augmented camera: its pose moved by the change).

    Targets: ``tv_tensors.Image`` or plain image tensors (CxHxW or a batch BxCxHxW
    sharing the camera; uint8, uint16, float32; bilinear), ``tv_tensors.Mask`` (HxW
    class ids or NxHxW instance masks, any integer or bool dtype, kept; nearest;
    no-source pixels as ``fill`` below),
    ``tv_tensors.BoundingBoxes`` (each box from its own densely transformed outline,
    so amodal and loose boxes keep their meaning; with ``boxes="from_masks"`` the
    tight box of the transformed instance mask of the same index instead; clipped;
    boxes seen less than ``min_visibility`` collapse to zero size, which
    ``v2.SanitizeBoundingBoxes`` drops), ``tv_tensors.KeyPoints`` (mapped
    exactly; points that leave the view keep their coordinates outside the canvas,
    NaN where they have no image), ``fishcam.torch.DepthMap``, ``fishcam.torch.Polygon``.
    Without a seeded dataset, the seed comes from torch's generator.

    Fill, where the moved camera has no source, per target type as torchvision's
    ``fill``: a number is the images' value; a dict, ``{tv_tensors.Image: 0,
    tv_tensors.Mask: 255}``, gives the images' and the semantic masks' (either may
    be left out; other keys, torchvision's "others" included, are refused).
    Semantic masks (HxW or 1xHxW, integer dtype) get ``fill_mask`` (or
    ``fill[tv_tensors.Mask]``; an integer in 0..65535 that fits the mask's dtype;
    given both ways, they must agree), e.g. the loss's ``ignore_index``. Instance
    masks get 0 (False) whatever either says, so no-source pixels join no instance
    and the boxes taken from the masks stay tight: bool masks, NxHxW masks with
    N >= 2, and the masks under the key "masks" of a dict (a detection target
    ``{"boxes", "labels", "masks"}``; ``is_instance_mask``).

    Args:
        camera: the fishcam.Camera of the images, or None: then the sample must hold one.
        preset: "small", "medium", "large" or "train" (the paper's ranges); None, or
            max_rotation_deg and max_translation given, draws uniformly per axis in
            [-max, max] instead.
        max_rotation_deg, max_translation: the ranges without a preset (degrees; units
            of the depth prior: the unit sphere's, or the depth map's).
        depth: where a pixel's scene point is assumed to be when the camera moves:
            "source-sphere" (default), "target-sphere", "infinity" (rotation only
            matters), or "map" (the sample's fishcam.torch.DepthMap; exact).
        p: probability of applying a change (else the identity, still recorded).
        fill, fill_mask: the no-source values per target type (above).
        sampling: "grid" (maps interpolated from grid nodes, within 1/32 px of the
            per-pixel map) or "exact".
        depth_values: what a DepthMap holds, "range" (along the ray) or "z".
        min_visibility: boxes seen less than this share of their area collapse to
            zero size (the same share in both box modes: of the box's transformed outline).
        boxes: "outline" (default) or "from_masks": box i becomes the tight box of
            instance mask i (the sample's one NxHxW instance Mask, N = the number of
            boxes, else fishcam.Error), as torchvision pairs detection targets.
    """

    def __init__(
        self,
        camera: typing.Optional[Camera] = None,
        preset: typing.Optional[str] = "train",
        max_rotation_deg: typing.Optional[float] = None,
        max_translation: typing.Optional[float] = None,
        depth: str = "source-sphere",
        p: float = 1.0,
        fill: Fill = 0,
        fill_mask: int = 0,
        sampling: str = "grid",
        depth_values: str = "range",
        min_visibility: float = 0.0,
        boxes: str = "outline",
    ) -> None:
        super().__init__(min_visibility, boxes)
        if isinstance(fill, typing.Mapping):  # numbers go as they are (checked by the numpy transform)
            fill, fill_mask = _split_fill(fill, fill_mask)
        self.numpy_transform = _transforms.RandomViewpoint(
            camera,
            preset=preset,
            max_rotation_deg=max_rotation_deg,
            max_translation=max_translation,
            depth=depth,
            p=p,
            fill=fill,
            fill_mask=fill_mask,
            sampling=sampling,
            depth_values=depth_values,
        )

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
    """The paper's affine baseline (fishcam.transforms.RandomAffine) as a torchvision
    v2 transform, with the targets of RandomViewpoint (depth maps keep their values;
    a camera in the sample is passed on unchanged: the baseline has no camera model)
    and its ``fill`` and ``fill_mask`` (instance masks get 0 / False), ``min_visibility``
    and ``boxes`` ("outline" or "from_masks", as RandomViewpoint's)."""

    def __init__(
        self,
        preset: typing.Optional[str] = "train",
        max_rotation_deg: typing.Optional[float] = None,
        max_translation: typing.Optional[float] = None,
        scale_range: typing.Optional[tuple[float, float]] = None,
        p: float = 1.0,
        fill: Fill = 0,
        fill_mask: int = 0,
        min_visibility: float = 0.0,
        boxes: str = "outline",
    ) -> None:
        super().__init__(min_visibility, boxes)
        if isinstance(fill, typing.Mapping):  # numbers go as they are (checked by the numpy transform)
            fill, fill_mask = _split_fill(fill, fill_mask)
        self.numpy_transform = _transforms.RandomAffine(
            preset=preset,
            max_rotation_deg=max_rotation_deg,
            max_translation=max_translation,
            scale_range=scale_range,
            p=p,
            fill=fill,
            fill_mask=fill_mask,
        )

    def _draw(self, flat_inputs: list[typing.Any]) -> _transforms.SampleChange:
        return self.numpy_transform.draw(_size_of(flat_inputs), self._seed())

    def extra_repr(self) -> str:
        return (
            repr(self.numpy_transform)[len("RandomAffine(") : -1]
            + f", min_visibility={self.min_visibility}, boxes={self.boxes!r}"
        )


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
            if (inpt.width, inpt.height) != params["size"]:
                raise Error(
                    f"camera: {inpt.width}x{inpt.height} but the images are {params['size'][0]}x{params['size'][1]} "
                    "(a transform before this one changed them without the camera)"
                )
            return inpt.resized(*params["camera_size"])
        return super().transform(inpt, params)


class WarpedBatch(typing.NamedTuple):
    """warp_batch's result: images (B, C, H, W), masks (B, H, W) or None, valid (B, H, W) bool."""

    images: torch.Tensor
    masks: typing.Optional[torch.Tensor]
    valid: torch.Tensor


_batch_warps = _transforms._WarpCache()


def warp_batch(
    images: torch.Tensor,
    cameras: typing.Union[Camera, typing.Sequence[Camera]],
    changes: typing.Sequence[ViewpointChange],
    masks: typing.Optional[torch.Tensor] = None,
    depth: str = "source-sphere",
    fill: Fill = 0.0,
    fill_mask: int = 0,
) -> WarpedBatch:
    """Viewpoint changes for a batch of tensors on any device.

    The maps come from fishcam on the CPU (the grid path, geometric: within 1/32 px
    of the per-pixel map), one per sample; the sampling is
    ``torch.nn.functional.grid_sample`` on the tensors' device (CPU or CUDA):
    bilinear for images, nearest for masks, in one call for the batch.

    Args:
        images: (B, C, H, W) tensor, uint8, uint16 or floating point, on any device.
        cameras: one fishcam.Camera for the batch, or a sequence of B (one per sample).
        changes: a sequence of B fishcam.ViewpointChange (e.g. ``fishcam.random_change``).
        masks: None or (B, H, W) integer or bool tensor on the images' device (nearest; dtype kept):
            one semantic label map per sample, or one bool mask per sample.
        depth: the depth prior ("source-sphere", "target-sphere", "infinity").
        fill: where the moved camera has no source: the images' value (a number: for
            integer images one of their dtype's values, for floating point ones any
            within its range, NaN too), or ``{tv_tensors.Image: ..., tv_tensors.Mask: ...}``
            as RandomViewpoint's.
        fill_mask: the masks' value there (or ``fill[tv_tensors.Mask]``): an integer
            the masks' dtype holds (within +-2^24); bool masks get False whatever it says.

    Returns:
        WarpedBatch(images, masks, valid): the images and masks in their dtypes and on
        their device; valid (B, H, W) bool, where the output has a source.
    """
    if not isinstance(images, torch.Tensor) or images.ndim != 4:
        raise Error(f"images: expected a (B, C, H, W) tensor, got {getattr(images, 'shape', type(images).__name__)}")
    if images.dtype == torch.bool or images.is_complex():
        raise Error(f"images: expected an integer or floating point tensor, got {images.dtype}")
    image_fill: typing.Any = fill  # a number (NaN included, for float images)
    if isinstance(fill, typing.Mapping):
        image_fill, fill_mask = _transforms._split_fill(
            fill, fill_mask, tv_tensors.Image, tv_tensors.Mask, finite=False, label_range=None
        )
    image_fill = _transforms._number(image_fill, "fill")
    fill_mask = _transforms._integer(fill_mask, "fill_mask")
    if images.is_floating_point():
        if np.isfinite(image_fill) and abs(image_fill) > torch.finfo(images.dtype).max:
            raise Error(f"images: the no-source fill {image_fill} is past the range of dtype {images.dtype}")
    else:
        info = torch.iinfo(images.dtype)
        if not (image_fill.is_integer() and info.min <= image_fill <= info.max):
            raise Error(
                f"images: the no-source fill {image_fill} is not a value of dtype {images.dtype} "
                f"(integers {info.min}..{info.max})"
            )
    batch, _, height, width = images.shape
    cameras = (
        [cameras] * batch
        if isinstance(cameras, Camera)
        else _transforms._sequence(cameras, "cameras", "a fishcam.Camera or a sequence of them")
    )
    changes = _transforms._sequence(changes, "changes", "a sequence of fishcam.ViewpointChange")
    if len(cameras) != batch or len(changes) != batch:
        raise Error(f"cameras, changes: expected one per image ({batch}), got {len(cameras)} and {len(changes)}")
    if masks is not None and (not isinstance(masks, torch.Tensor) or tuple(masks.shape) != (batch, height, width)):
        raise Error(
            f"masks: expected a ({batch}, {height}, {width}) tensor, got "
            f"{getattr(masks, 'shape', type(masks).__name__)}"
        )
    if masks is not None and masks.device != images.device:
        raise Error(f"masks: on {masks.device} but the images are on {images.device}")
    grids = torch.empty((batch, height, width, 2), dtype=torch.float32)
    valid = torch.empty((batch, height, width), dtype=torch.bool)
    for i, (camera, change) in enumerate(zip(cameras, changes)):
        if not isinstance(camera, Camera):
            raise Error(f"cameras[{i}]: expected a fishcam.Camera, got {type(camera).__name__}")
        if not isinstance(change, ViewpointChange):
            raise Error(f"changes[{i}]: expected a fishcam.ViewpointChange, got {type(change).__name__}")
        if (camera.width, camera.height) != (width, height):
            raise Error(f"images: are {width}x{height} but cameras[{i}] is {camera.width}x{camera.height}")
        grid, ok = _batch_warps.get(camera).sampling_grid(change, depth)
        grids[i] = torch.from_numpy(grid)
        valid[i] = torch.from_numpy(ok)
    device = images.device
    grids, valid = grids.to(device), valid.to(device)
    floating = images if images.is_floating_point() else images.float()
    sampled = torch.nn.functional.grid_sample(
        floating, grids.to(floating.dtype), mode="bilinear", padding_mode="border", align_corners=True
    )
    sampled = torch.where(
        valid[:, None], sampled, torch.as_tensor(float(image_fill), dtype=sampled.dtype, device=device)
    )
    if not images.is_floating_point():
        info = torch.iinfo(images.dtype)
        sampled = sampled.round_().clamp_(info.min, info.max)
    out_masks = None
    if masks is not None:
        if masks.is_floating_point() or masks.is_complex():
            raise Error(f"masks: expected an integer or bool tensor, got {masks.dtype}")
        # float32 holds integers exactly up to 2^24: labels and instance ids.
        if masks.numel() and (int(masks.min()) < 0 or int(masks.max()) >= 2**24):
            raise Error("masks: values outside 0..2^24 cannot be sampled exactly")
        if masks.dtype == torch.bool:
            fill_mask = 0  # a bool mask is an instance's: no source, not in it
        else:
            info = torch.iinfo(masks.dtype)
            low, high = max(info.min, -(2**24)), min(info.max, 2**24)
            if not low <= fill_mask <= high:
                raise Error(f"fill_mask: {fill_mask} does not fit the masks' dtype {masks.dtype} ({low}..{high})")
        picked = torch.nn.functional.grid_sample(
            masks[:, None].float(), grids, mode="nearest", padding_mode="border", align_corners=True
        )[:, 0]
        out_masks = torch.where(valid, picked, torch.as_tensor(float(fill_mask), device=device)).to(masks.dtype)
    return WarpedBatch(sampled.to(images.dtype), out_masks, valid)


def collate(batch: typing.Sequence[typing.Any]) -> typing.Any:
    """torch's default collate, but fishcam.Camera objects (and other non-tensors the
    default cannot stack: names, change records) are gathered into lists."""
    if isinstance(batch[0], dict):
        return {key: collate([item[key] for item in batch]) for key in batch[0]}
    if isinstance(batch[0], (Camera, str)) or not isinstance(batch[0], (torch.Tensor, np.ndarray, int, float)):
        return list(batch)
    return torch.utils.data.default_collate(list(batch))


class EpochSampler(torch.utils.data.Sampler[tuple[int, int]]):
    """Yields ``(epoch, index)`` for every index of ``sampler``, one epoch per pass.

    The DataLoader iterates its sampler in the main process, so the epoch reaches
    ``WoodScapeDataset(seed=...)`` in every worker, persistent or not. Each
    ``iter()`` starts the next epoch (0, 1, 2, ... from ``start_epoch``);
    ``set_epoch(e)`` makes the next pass epoch ``e`` (resuming a training run).
    A sampler with ``set_epoch`` (``DistributedSampler``) is told each epoch too,
    so its shuffle changes with it.

    Args:
        sampler: any sampler or iterable of dataset indices with ``len()``
            (``SequentialSampler``, ``RandomSampler``, ``DistributedSampler``, a list).
        start_epoch: the first pass's epoch.
    """

    def __init__(self, sampler: typing.Iterable[int], start_epoch: int = 0) -> None:
        if isinstance(start_epoch, bool) or not isinstance(start_epoch, int) or start_epoch < 0:
            raise Error(f"EpochSampler: start_epoch must be a non-negative integer, got {_shown(start_epoch)}")
        self.sampler = sampler
        self.next_epoch = start_epoch

    def set_epoch(self, epoch: int) -> None:
        """Makes the next pass epoch ``epoch``."""
        if isinstance(epoch, bool) or not isinstance(epoch, int) or epoch < 0:
            raise Error(f"EpochSampler.set_epoch: expected a non-negative integer, got {_shown(epoch)}")
        self.next_epoch = epoch

    def __len__(self) -> int:
        return len(typing.cast(typing.Sized, self.sampler))

    def __iter__(self) -> typing.Iterator[tuple[int, int]]:
        epoch = self.next_epoch
        self.next_epoch = epoch + 1
        if hasattr(self.sampler, "set_epoch"):
            self.sampler.set_epoch(epoch)
        for index in self.sampler:
            yield (epoch, int(index))


def _index(value: object, what: str) -> int:
    """An integer index (int, numpy or 0-dimensional torch integer), or fishcam.Error."""
    if isinstance(value, (bool, np.bool_)):
        raise Error(f"{what}: expected an integer, got {type(value).__name__}")
    try:
        return operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise Error(f"{what}: expected an integer, got {type(value).__name__}") from None


class WoodScapeDataset(torch.utils.data.Dataset[Sample]):
    """Samples of a WoodScape-layout folder: ``rgb_images/NAME.png``,
    ``semantic_annotations/gtLabels/NAME.png`` and ``calibration/NAME.json`` (one
    calibration per image, as WoodScape has). One image a name: ``NAME.png`` beside
    ``NAME.jpg`` is refused (fishcam.Error naming both).

    Each item is a dict: ``image`` (``tv_tensors.Image``, 3xHxW uint8), ``mask``
    (``tv_tensors.Mask``, HxW ``mask_dtype``, int64 by default: what cross-entropy
    takes; None keeps the PNG's uint8/uint16), ``camera`` (the fishcam.Camera of the
    image), ``name``; the whole dict goes through ``transform`` (the mask still as
    decoded, which is cheaper to resample; a v2 transform or
    ``v2.Compose``; fishcam's transforms take the camera from it and put the
    augmented camera back), and ``changes`` is added: the records of the changes
    fishcam's transforms made, as a JSON list (seeds are 64-bit, past torch's int64;
    ``json.loads`` gives the dicts back). Batch with ``collate_fn=fishcam.torch.collate``
    (cameras are gathered into lists). Cameras are read once per distinct calibration
    file content; the transforms keep one warp per calibration.

    With ``seed``, sample ``index`` in epoch ``e`` is transformed under
    ``sample_seed(derive_seed(seed, f"epoch{e}", index))``: the same change whatever
    the workers. The epoch comes with the key: ``dataset[(e, index)]``, as
    ``EpochSampler`` yields them; a bare ``dataset[index]`` uses ``set_epoch``'s
    epoch, in the main process only, and only once ``set_epoch`` has been called
    (raises otherwise: every epoch would repeat epoch 0's changes; and in a
    DataLoader worker, whose copy never sees ``set_epoch``).
    """

    def __init__(
        self,
        root: typing.Union[str, "os.PathLike[str]"],
        transform: typing.Optional[typing.Callable[[Sample], Sample]] = None,
        seed: typing.Optional[int] = None,
        mask_dtype: typing.Optional[torch.dtype] = torch.int64,
    ) -> None:
        self.root = os.fspath(root)
        self.transform = transform
        self.mask_dtype = mask_dtype
        self.seed = None if seed is None else _check_seed(seed)
        self.epoch: typing.Optional[int] = None  # set_epoch's; None: bare indices of a seeded dataset refused
        images = os.path.join(self.root, "rgb_images")
        if not os.path.isdir(images):
            raise Error(f"{images}: missing (expected the WoodScape layout)")
        # One image a name: NAME.png beside NAME.jpg would be one sample twice (or two
        # images under one calibration and label image).
        self._files: dict[str, str] = {}
        for f in sorted(os.listdir(images)):
            name, extension = os.path.splitext(f)
            if extension.lower() not in (".png", ".jpg", ".jpeg"):
                continue
            if name in self._files:
                raise Error(f"{images}: two images of sample {name!r}, {self._files[name]!r} and {f!r}: keep one")
            self._files[name] = f
        self.names = sorted(self._files)
        if not self.names:
            raise Error(f"{images}: no images")
        self._cameras: dict[bytes, Camera] = {}

    def set_epoch(self, epoch: int) -> None:
        """The epoch of bare-index items in this process (DataLoader workers: use EpochSampler)."""
        self.epoch = _index(epoch, "WoodScapeDataset.set_epoch")

    def _epoch_and_index(self, key: typing.Union[int, tuple[int, int]]) -> tuple[typing.Optional[int], int]:
        if isinstance(key, tuple):
            if len(key) != 2:
                raise Error(f"WoodScapeDataset: expected an index or (epoch, index), got {_shown(key)}")
            epoch, index = (_index(k, "WoodScapeDataset: (epoch, index)") for k in key)
        else:
            epoch, index = None, _index(key, "WoodScapeDataset: index")
            if self.seed is not None and self.transform is not None:
                if torch.utils.data.get_worker_info() is not None:
                    raise Error(
                        "WoodScapeDataset(seed=...) in a DataLoader worker needs the epoch with each index "
                        "(the worker's copy never sees set_epoch): pass "
                        "sampler=fishcam.torch.EpochSampler(...) to the DataLoader"
                    )
                if self.epoch is None:
                    raise Error(
                        "WoodScapeDataset(seed=...): a bare index has no epoch (every epoch would repeat "
                        "epoch 0's changes): pass sampler=fishcam.torch.EpochSampler(...) to the DataLoader, "
                        "index with (epoch, index), or call set_epoch(e) before each epoch"
                    )
                epoch = self.epoch
        if not -len(self.names) <= index < len(self.names):
            raise IndexError(f"WoodScapeDataset: index {index} out of range for {len(self.names)} samples")
        return epoch, index % len(self.names)

    def __len__(self) -> int:
        return len(self.names)

    def camera(self, name: str) -> Camera:
        """The fishcam.Camera of sample ``name`` (read once per distinct file content)."""
        path = os.path.join(self.root, "calibration", name + ".json")
        with open(path, "rb") as f:
            key = f.read()
        camera = self._cameras.get(key)
        if camera is None:
            camera = Camera.read(path)
            self._cameras[key] = camera
        return camera

    @staticmethod
    def _read(path: str, flags: int) -> _transforms.Array:
        image: typing.Optional[_transforms.Array] = _cv2().imread(path, flags)
        if image is None:
            raise Error(f"{path}: cannot read image")
        return image

    def __getitem__(self, key: typing.Union[int, tuple[int, int]]) -> Sample:
        epoch, index = self._epoch_and_index(key)
        name = self.names[index]
        image = self._read(os.path.join(self.root, "rgb_images", self._files[name]), _cv2().IMREAD_COLOR)
        image = _cv2().cvtColor(image, _cv2().COLOR_BGR2RGB)
        mask = self._read(
            os.path.join(self.root, "semantic_annotations", "gtLabels", name + ".png"), _cv2().IMREAD_UNCHANGED
        )
        if mask.ndim != 2:
            raise Error(f"{name}: expected a single-channel label image")
        # The transform gets the mask as decoded (uint8 or uint16: cheaper to resample);
        # the item has it in mask_dtype.
        item = {
            "image": tv_tensors.Image(torch.from_numpy(image).permute(2, 0, 1)),
            "mask": tv_tensors.Mask(torch.from_numpy(mask)),
            "camera": self.camera(name),
            "name": name,
        }
        if self.transform is None:
            return self._with_mask_dtype(item)
        if self.seed is None:
            with record_changes() as records:
                item = self.transform(item)
        else:
            with sample_seed(derive_seed(self.seed, f"epoch{epoch}", index)) as records:
                item = self.transform(item)
        item = self._with_mask_dtype(item)
        item["changes"] = json.dumps(records)
        return item

    def _with_mask_dtype(self, item: Sample) -> Sample:
        mask = item.get("mask") if isinstance(item, dict) else None
        if self.mask_dtype is not None and isinstance(mask, torch.Tensor) and mask.dtype != self.mask_dtype:
            item["mask"] = (
                tv_tensors.wrap(mask.to(self.mask_dtype), like=mask)
                if isinstance(mask, tv_tensors.TVTensor)
                else mask.to(self.mask_dtype)
            )
        return item

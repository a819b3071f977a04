"""Viewpoint augmentation (and the affine baseline, RandomAffine) as numpy transforms,
framework-free, with albumentations' call convention: one change per call, applied
to every target of the sample.

    t = RandomViewpoint(camera, preset="train")
    out = t(image=image, mask=labels)            # dict: image, mask, change
    out = t(image=image, mask=labels, seed=7)    # reproducible: the CLI's --preset train --seed 7
    out = t(image=image, depth_map=depth, keypoints=xy, boxes=xyxy, polygons=[p0, p1], camera=cam)

Targets (docs/python.md, "Targets"): images HxW or HxWxC (uint8, uint16, float32;
bilinear); masks HxW of any integer or bool dtype (nearest, dtype kept; where
there is no source, the label ``fill_mask``, but False for bool masks: "Fill"
below); depth maps HxW float32 (nearest, values re-expressed in the moved camera);
keypoints (N, 2) pixels with a visibility flag; boxes (N, 4) x_min, y_min, x_max,
y_max in pixel-edge coordinates (the tight box of the transformed outline) with the
visible fraction; polygons (K, 2) with edges subdivided to stay within 0.5 px of
the curved image; the camera (its pose moved by the change). Pixel coordinates put
pixel centres at integers (keypoints, polygons; as torchvision and albumentations
do), boxes span pixel edges (the whole image is 0, 0, W, H).

Fill (where the moved view has no source): ``fill`` is a number, the images' value
(one their dtype holds: an integer in range for uint8 and uint16 images, refused at
the call otherwise, rather than saturated or wrapped), or a dict by target,
``{"image": 0, "mask": 255}`` (either key may be left out; any other key is
refused). Semantic masks (HxW labels of an integer dtype) get the mask
value, ``fill_mask`` or ``fill["mask"]``, e.g. the loss's ``ignore_index``: an
integer in 0..65535 that fits the mask's dtype (a non-zero ``fill_mask`` and a
``fill["mask"]`` that disagree are refused). Instance masks get 0 (False) whatever
the mask value says, so that no-source pixels never join an instance: bool masks,
and wherever an adapter knows a mask is an instance's (torch: NxHxW with N >= 2 and
the "masks" of a detection target; albumentations: the ``masks`` target);
``SampleChange.mask(..., instance=True)`` asks for it.

Randomness: no generator lives inside the transform (or any C++ object). Without
``seed=``, one 64-bit seed is drawn per call from the ``rng`` given to the
constructor (a ``numpy.random.Generator``) or else from numpy's global generator,
which PyTorch reseeds in every DataLoader worker; the change then follows from
that seed exactly as the CLI's ``--seed`` does. ``draw(...)`` gives the
``SampleChange`` of one seed, which the torch and albumentations adapters apply to
their targets.

The package, by job: ``options`` (ViewpointOptions and AffineOptions, the options
the numpy, torch and albumentations transforms share, and their defaults),
``viewpoint`` (RandomViewpoint), ``affine`` (RandomAffine), ``sample_change``
(SampleChange and the call applying it to every target), ``geometry`` (points,
box outlines and polygons under a change), ``fill`` (the no-source values),
``checks`` (argument checks), ``records`` (seeds and change records).
"""

# The names imported "as" themselves are not public: the adapters (fishcam.torch,
# fishcam.albumentations) take them from here: the types of arrays, records and
# fills, argument checks, the warps kept per calibration.
from .affine import RandomAffine
from .checks import Array as Array
from .checks import Record as Record
from .checks import _choice as _choice
from .checks import _integer as _integer
from .checks import _number as _number
from .checks import _sequence as _sequence
from .fill import Fill as Fill
from .fill import _split_fill as _split_fill
from .geometry import BOX_MAX_POINTS, POLYGON_TOLERANCE_PX
from .geometry import Forward as Forward
from .options import AFFINE_DEFAULTS, VIEWPOINT_DEFAULTS, AffineOptions, ViewpointOptions
from .records import affine_to_dict, draw_seed
from .records import change_to_dict as change_to_dict
from .sample_change import SampleChange
from .viewpoint import RandomViewpoint
from .viewpoint import _WarpCache as _WarpCache

__all__ = [
    "RandomViewpoint",
    "RandomAffine",
    "SampleChange",
    "ViewpointOptions",
    "AffineOptions",
    "VIEWPOINT_DEFAULTS",
    "AFFINE_DEFAULTS",
    "POLYGON_TOLERANCE_PX",
    "BOX_MAX_POINTS",
    "affine_to_dict",
    "draw_seed",
]

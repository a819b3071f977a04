"""RandomAffine, the paper's affine baseline (§V.C.2) as a numpy transform."""

import typing

import numpy as np

from .. import Camera, Error, _check_seed, _fishcam, _shown
from . import options as _options
from .checks import Array, _check_p, _check_rng, _image_size, _number, _preset_name, _sequence
from .fill import _split_fill
from .options import AffineOptions, Unpack
from .records import _applies, affine_to_dict, draw_seed
from .sample_change import SampleChange, _apply


class RandomAffine:
    __doc__ = _options.docstring(
        """The paper's affine baseline (§V.C.2): rotation about the image centre,
        translation, isotropic scale; no camera model (``camera=`` is accepted by the
        call and passed on, so it can stand where RandomViewpoint does). Resampled as
        RandomViewpoint does (bilinear images, nearest labels, the fills where there
        is no source); the same seed gives the same change as ``fishcam augment
        --method affine --seed``.
        """,
        _options.AFFINE_TEXTS,
        {"rng": _options.RNG_TEXT},
    )

    @_options.takes_options(AffineOptions, _options.AFFINE_DEFAULTS)
    def __init__(self, *, rng: typing.Optional[np.random.Generator] = None, **options: Unpack[AffineOptions]) -> None:
        given = _options.resolved(options, _options.AFFINE_DEFAULTS, "RandomAffine")
        preset, max_rotation_deg, max_translation = given["preset"], given["max_rotation_deg"], given["max_translation"]
        scale_range = given["scale_range"]
        custom = (max_rotation_deg, max_translation, scale_range)
        if any(v is not None for v in custom) and not all(v is not None for v in custom):
            raise Error("max_rotation_deg, max_translation and scale_range go together")
        self.scale_range: typing.Optional[tuple[float, float]] = None
        if max_rotation_deg is not None:
            preset = None
            scales = [_number(v, "scale_range") for v in _sequence(scale_range, "scale_range", "(low, high)")]
            if len(scales) != 2:
                raise Error(f"scale_range: expected (low, high), got {_shown(scale_range)}")
            low, high = scales
            # The library checks the ranges (one message for every binding).
            _fishcam.random_affine_in(
                _number(max_rotation_deg, "max_rotation_deg"), _number(max_translation, "max_translation"), low, high, 0
            )
            self.scale_range = (low, high)
        elif (preset := _preset_name(preset, _fishcam.affine_presets())) not in _fishcam.affine_presets():
            _fishcam.random_affine(preset, 0)  # raises naming the presets
        _check_p(given["p"])
        _check_rng(rng)
        self.fill, self.fill_mask = _split_fill(given["fill"], given["fill_mask"])  # the images', the semantic masks'
        self.preset = preset
        self.max_rotation_deg = max_rotation_deg
        self.max_translation = max_translation
        self.p = float(given["p"])
        self.rng = rng

    def change_for(self, seed: int) -> _fishcam.AffineChange:
        """The change this transform applies for ``seed`` (what the CLI's --seed gives)."""
        seed = _check_seed(seed)
        if self.preset is not None:
            return _fishcam.random_affine(self.preset, seed)
        assert self.max_rotation_deg is not None and self.max_translation is not None and self.scale_range
        return _fishcam.random_affine_in(self.max_rotation_deg, self.max_translation, *self.scale_range, seed)

    def draw(self, size: tuple[int, int], seed: typing.Optional[int] = None) -> SampleChange:
        """The SampleChange of one call for images of ``size`` = (width, height)."""
        width, height = _image_size(size)
        if seed is None:
            seed = draw_seed(self.rng)
        seed = _check_seed(seed)
        change = self.change_for(seed) if _applies(self.p, seed) else _fishcam.AffineChange()
        return self.sample_change((width, height), change, seed)

    def sample_change(
        self, size: tuple[int, int], change: _fishcam.AffineChange, seed: typing.Optional[int] = None
    ) -> SampleChange:
        """The SampleChange of a given ``change`` for images of ``size`` = (width,
        height), under this transform's fill (``seed``: what the record says)."""
        width, height = _image_size(size)
        if not isinstance(change, _fishcam.AffineChange):
            raise Error(f"change: expected a fishcam AffineChange, got {type(change).__name__}")

        def resample(
            image: typing.Optional[Array], labels: typing.Optional[Array], label_fill: int
        ) -> dict[str, Array]:
            given = image if image is not None else labels
            assert given is not None
            if given.shape[:2] != (height, width):
                raise Error(
                    f"{'image' if image is not None else 'mask'}: is {given.shape[1]}x{given.shape[0]} "
                    f"but the sample is {width}x{height}"
                )
            return _fishcam.affine_warp(
                image=image, labels=labels, change=change, fill=self.fill, label_fill=label_fill
            )

        def depth_map(values: Array) -> Array:
            if values.shape != (height, width):
                raise Error(f"depth_map: is {values.shape[1]}x{values.shape[0]} but the sample is {width}x{height}")
            return _fishcam.affine_warp_depth(values, change)

        return SampleChange(
            record=affine_to_dict(change, seed),
            forward=lambda points: _fishcam.affine_forward(points, change, width, height),
            resample=resample,
            depth_map=depth_map,
            camera=lambda c: c,  # no camera model: the camera is passed on as it is
            size=(width, height),
            fill_mask=self.fill_mask,
            fill=self.fill,
        )

    def __call__(
        self,
        image: typing.Optional[Array] = None,
        mask: typing.Optional[Array] = None,
        camera: typing.Optional[Camera] = None,
        seed: typing.Optional[int] = None,
        **targets: typing.Any,
    ) -> dict[str, typing.Any]:
        """As RandomViewpoint's; ``camera`` is passed on unchanged (the baseline has no
        camera model), depth maps keep their values (sampled as masks)."""
        given = next((x for x in (image, mask, targets.get("depth_map")) if x is not None), None)
        if given is None and targets.get("images") is not None:
            given = next(iter(_sequence(targets["images"], "images")), None)
        if given is None:
            raise Error("nothing to transform: pass image= and/or mask= (or images=, depth_map=)")
        if not isinstance(given, np.ndarray) or given.ndim < 2:
            raise Error(f"image: expected an HxW or HxWxC numpy array, got {type(given).__name__}")
        return _apply(self.draw((given.shape[1], given.shape[0]), seed), image, mask, camera, targets)

    def __repr__(self) -> str:
        what = (
            f"preset={self.preset!r}"
            if self.preset is not None
            else f"max_rotation_deg={self.max_rotation_deg}, max_translation={self.max_translation}, "
            f"scale_range={self.scale_range}"
        )
        return f"RandomAffine({what}, p={self.p})"

"""RandomViewpoint, the paper's viewpoint change (eq. 7) as a numpy transform, and
the warps it keeps, one per calibration."""

import typing

import numpy as np

from .. import Camera, Error, ViewpointChange, ViewpointWarp, _check_seed, _fishcam, change_to_dict
from . import options as _options
from .checks import Array, _check_p, _check_rng, _choice, _number, _preset_name
from .fill import _split_fill
from .options import Unpack, ViewpointOptions
from .records import _applies, draw_seed
from .sample_change import SampleChange, _apply


class _WarpCache:
    """One ViewpointWarp per distinct calibration (intrinsics + size): building one
    unprojects every pixel, so it is kept, not rebuilt per sample. Keyed by
    Camera.parameters_key (microseconds; to_json() cost more than a warp)."""

    def __init__(self, limit: int = 64) -> None:
        self._warps: dict[bytes, ViewpointWarp] = {}
        self._warps = {}
        self._limit = limit

    def get(self, camera: Camera) -> ViewpointWarp:
        key = camera.parameters_key(with_pose=False)  # a warp depends on the intrinsics and size only
        warp = self._warps.get(key)
        if warp is None:
            if len(self._warps) >= self._limit:
                self._warps.pop(next(iter(self._warps)))
            warp = ViewpointWarp(camera)
            self._warps[key] = warp
        return warp

    def __getstate__(self) -> dict[str, int]:
        return {"limit": self._limit}  # warps are rebuilt on demand after unpickling

    def __setstate__(self, state: dict[str, int]) -> None:
        self._warps = {}
        self._limit = state["limit"]


class RandomViewpoint:
    __doc__ = _options.docstring(
        """A random viewpoint change per call (the paper's eq. 7), applied exactly to
        every target of the call (fishcam.transforms' docstring): ``t(image=...,
        mask=..., seed=...)`` returns a dict of the same keys and ``change``, the record.
        """,
        {"camera": "the fishcam.Camera of the images (or None: then every call passes camera=)."},
        _options.VIEWPOINT_TEXTS,
        {"rng": _options.RNG_TEXT},
    )

    @_options.takes_options(ViewpointOptions, _options.VIEWPOINT_DEFAULTS)
    def __init__(
        self,
        camera: typing.Optional[Camera] = None,
        *,
        rng: typing.Optional[np.random.Generator] = None,
        **options: Unpack[ViewpointOptions],
    ) -> None:
        given = _options.resolved(options, _options.VIEWPOINT_DEFAULTS, "RandomViewpoint")
        preset, max_rotation_deg, max_translation = given["preset"], given["max_rotation_deg"], given["max_translation"]
        sampling = _choice(given["sampling"], _fishcam.sampling_names(), "sampling")
        depth_values = _choice(given["depth_values"], _fishcam.depth_values_names(), "depth_values")
        if camera is not None and not isinstance(camera, Camera):
            raise Error(f"camera: expected a fishcam.Camera, got {type(camera).__name__}")
        if (max_rotation_deg is None) != (max_translation is None):
            raise Error("max_rotation_deg and max_translation go together")
        if max_rotation_deg is not None:
            preset = None
            rotation = _number(max_rotation_deg, "max_rotation_deg")
            if not (np.isfinite(rotation) and 0 <= rotation <= 180):
                raise Error(f"max_rotation_deg: must be in [0, 180], got {max_rotation_deg}")
            translation = _number(max_translation, "max_translation")
            if not (np.isfinite(translation) and translation >= 0):
                raise Error(f"max_translation: must be finite and >= 0, got {max_translation}")
        else:
            preset = _preset_name(preset, _fishcam.presets())
            _fishcam.check_preset(preset)
        depth = _choice(given["depth"], _fishcam.depth_priors_and_map(), "depth", ", ")
        _check_p(given["p"])
        _check_rng(rng)
        self.fill, self.fill_mask = _split_fill(given["fill"], given["fill_mask"])  # the images', the semantic masks'
        self.camera = camera
        self.preset = preset
        self.max_rotation_deg = max_rotation_deg
        self.max_translation = max_translation
        self.depth = depth
        self.p = float(given["p"])
        self.rng = rng
        self.sampling = sampling
        self.depth_values = depth_values
        self._warps = _WarpCache()

    def change_for(self, seed: int) -> ViewpointChange:
        """The change this transform applies for ``seed`` (what the CLI's --seed gives)."""
        seed = _check_seed(seed)
        if self.preset is not None:
            return _fishcam.random_change(self.preset, seed)
        assert self.max_rotation_deg is not None and self.max_translation is not None
        return _fishcam.random_change_in(self.max_rotation_deg, self.max_translation, seed)

    def draw(
        self,
        camera: typing.Optional[Camera] = None,
        seed: typing.Optional[int] = None,
        depth_map: typing.Optional[Array] = None,
    ) -> SampleChange:
        """The SampleChange of one call: the change of ``seed`` (drawn when None) for
        images of ``camera`` (default: the constructor's); with depth="map", the
        sample's depth map (HxW float32) places every pixel's scene point."""
        camera = camera if camera is not None else self.camera
        if camera is None:
            raise Error("camera: none given (pass camera= to the constructor or the call)")
        if not isinstance(camera, Camera):
            raise Error(f"camera: expected a fishcam.Camera, got {type(camera).__name__}")
        if seed is None:
            seed = draw_seed(self.rng)
        seed = _check_seed(seed)
        change = self.change_for(seed) if _applies(self.p, seed) else _fishcam.ViewpointChange()
        return self.sample_change(camera, change, seed, depth_map)

    def sample_change(
        self,
        camera: Camera,
        change: ViewpointChange,
        seed: typing.Optional[int] = None,
        depth_map: typing.Optional[Array] = None,
    ) -> SampleChange:
        """The SampleChange of a given ``change`` for images of ``camera``, under this
        transform's depth, fill and sampling (``seed``: what the record says; the
        functional API, fishcam.torch.functional, comes here)."""
        if not isinstance(camera, Camera):
            raise Error(f"camera: expected a fishcam.Camera, got {type(camera).__name__}")
        if not isinstance(change, ViewpointChange):
            raise Error(f"change: expected a fishcam.ViewpointChange, got {type(change).__name__}")
        if self.depth == "infinity":
            # The prior at infinity sees no translation: the image gets the rotation
            # alone, and so do the returned camera and the record (what the image got).
            change = ViewpointChange(rotation_deg=change.rotation_deg.ravel(), translation=(0.0, 0.0, 0.0))
        warp = self._warps.get(camera)
        if self.depth == "map":
            if depth_map is None:
                raise Error("depth='map' needs the sample's depth map (depth_map=, HxW float32)")
            if not isinstance(depth_map, np.ndarray) or depth_map.dtype != np.float32 or depth_map.ndim != 2:
                got = (
                    f"{depth_map.dtype} {depth_map.shape}"
                    if isinstance(depth_map, np.ndarray)
                    else type(depth_map).__name__
                )
                raise Error(f"depth_map: expected an HxW float32 array, got {got}")
        maps_depth = depth_map if self.depth == "map" else None

        def resample(
            image: typing.Optional[Array], labels: typing.Optional[Array], label_fill: int
        ) -> dict[str, Array]:
            return warp.warp(
                image=image,
                labels=labels,
                change=change,
                depth=self.depth,
                fill=self.fill,
                label_fill=label_fill,
                sampling=self.sampling,
                depth_map=maps_depth,
                depth_values=self.depth_values,
            )

        return SampleChange(
            record=change_to_dict(change, seed, self.depth),
            forward=lambda points: warp.forward(
                points, change, self.depth, depth_map=maps_depth, depth_values=self.depth_values
            ),
            resample=resample,
            depth_map=lambda depth_map: warp.warp_depth(depth_map, change, self.depth, self.depth_values),
            camera=lambda c: c.augmented(change),
            size=(camera.width, camera.height),
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
        """One change for every target given (module docstring); a dict with the same
        keys, ``change`` (the record) and the visibility of keypoints and boxes."""
        # The augmented camera is returned for a camera given with the sample.
        return _apply(self.draw(camera, seed, targets.get("depth_map")), image, mask, camera, targets)

    def __repr__(self) -> str:
        what = (
            f"preset={self.preset!r}"
            if self.preset is not None
            else f"max_rotation_deg={self.max_rotation_deg}, max_translation={self.max_translation}"
        )
        return (
            f"RandomViewpoint({what}, depth={self.depth!r}, p={self.p}, fill={self.fill}, "
            f"fill_mask={self.fill_mask}, sampling={self.sampling!r}, depth_values={self.depth_values!r})"
        )

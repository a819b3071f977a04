"""Viewpoint augmentation (and the affine baseline, RandomAffine) as numpy transforms
with albumentations' call convention.

    t = RandomViewpoint(camera, preset="train")
    out = t(image=image, mask=labels)            # dict: image, mask, change
    out = t(image=image, mask=labels, seed=7)    # reproducible: the CLI's --preset train --seed 7

Randomness: no generator lives inside the transform (or any C++ object). Without
``seed=``, one 64-bit seed is drawn per call from the ``rng`` given to the
constructor (a ``numpy.random.Generator``) or else from numpy's global generator,
which PyTorch reseeds in every DataLoader worker; the change then follows from
that seed exactly as the CLI's ``--seed`` does.
"""

import numpy as np

from . import Camera, Error, ViewpointWarp, _check_seed, _fishcam, change_to_dict


def draw_seed(rng=None):
    """One 64-bit seed from ``rng`` (a numpy Generator) or numpy's global generator."""
    if rng is not None:
        return int(rng.integers(0, 2**64, dtype=np.uint64))
    hi = int(np.random.randint(0, 2**32, dtype=np.uint64))
    lo = int(np.random.randint(0, 2**32, dtype=np.uint64))
    return (hi << 32) | lo


def _number(value, what):
    """value as a float, or fishcam.Error naming the argument."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise Error(f"{what}: expected a number, got {type(value).__name__}")
    return float(value)


def _integer(value, what):
    """value as an int, or fishcam.Error naming the argument."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise Error(f"{what}: expected an integer, got {type(value).__name__}")
    return int(value)


def _check_p_and_fill(p, fill):
    if not (0 <= _number(p, "p") <= 1):
        raise Error(f"p: must be in [0, 1], got {p}")
    if not np.isfinite(_number(fill, "fill")):
        raise Error("fill: must be finite")


def _labels_for_warp(mask, fill_mask):
    """The mask as the warp takes it (uint8 or uint16: labels are sampled, never
    blended) and a function giving the warped mask its original dtype back. bool,
    int32 and int64 masks (torch's default for class ids) with values in 0..65535
    are taken as uint16 and returned in their dtype; other values are refused."""
    if mask is None or not isinstance(mask, np.ndarray) or mask.dtype in (np.uint8, np.uint16):
        return mask, lambda out: out
    if mask.dtype == np.bool_:
        return mask.view(np.uint8), lambda out: out.astype(np.bool_)
    if mask.dtype.kind not in "iu":
        raise Error(f"mask: expected an integer or bool label array, got dtype {mask.dtype}")
    if mask.size and (mask.min() < 0 or mask.max() > 65535):
        raise Error(f"mask: values {mask.min()}..{mask.max()} outside 0..65535 cannot be warped as labels")
    if not 0 <= fill_mask <= 65535:
        raise Error(f"fill_mask: {fill_mask} outside 0..65535")
    dtype = mask.dtype
    return mask.astype(np.uint16), lambda out: out.astype(dtype)


def _applies(p, seed):
    """Whether a transform with probability p changes the sample of this seed: the
    decision follows from the seed too, so seed= reproduces it."""
    return p >= 1 or np.random.default_rng(seed).random() < p


def _result(out, change):
    """A transform's return value (albumentations' keys) from a warp's output dict."""
    result = {"change": change}
    if "image" in out:
        result["image"] = out["image"]
    if "labels" in out:
        result["mask"] = out["labels"]
    return result


class _WarpCache:
    """One ViewpointWarp per distinct calibration (intrinsics + size): building one
    unprojects every pixel, so it is kept, not rebuilt per sample. Keyed by
    Camera.parameters_key (microseconds; to_json() cost more than a warp)."""

    def __init__(self, limit=64):
        self._warps = {}
        self._limit = limit

    def get(self, camera):
        key = camera.parameters_key(with_pose=False)  # a warp depends on the intrinsics and size only
        warp = self._warps.get(key)
        if warp is None:
            if len(self._warps) >= self._limit:
                self._warps.pop(next(iter(self._warps)))
            warp = ViewpointWarp(camera)
            self._warps[key] = warp
        return warp

    def __getstate__(self):
        return {"limit": self._limit}  # warps are rebuilt on demand after unpickling

    def __setstate__(self, state):
        self._warps = {}
        self._limit = state["limit"]


class RandomViewpoint:
    """A random viewpoint change per call (the paper's eq. 7), applied exactly.

    camera: the fishcam.Camera of the images (or None: then every call passes camera=).
    preset: "small", "medium", "large" or "train"; or give max_rotation_deg and
        max_translation instead (uniform per axis in [-max, max]).
    depth: "source-sphere" (default), "target-sphere" or "infinity".
    p: probability of applying a change (else the identity, still reported).
    fill: image value where the new view has no source; fill_mask: the label there.
    rng: a numpy Generator to draw seeds from (default: numpy's global generator).
    sampling: "grid" (default: maps interpolated from grid nodes, within 1/32 px of
        the per-pixel map, as ``fishcam augment``) or "exact".
    """

    def __init__(self, camera=None, preset="train", max_rotation_deg=None, max_translation=None,
                 depth="source-sphere", p=1.0, fill=0, fill_mask=0, rng=None, sampling="grid"):
        if sampling not in _fishcam.sampling_names():
            raise Error(f"sampling: expected {' or '.join(_fishcam.sampling_names())}, got {sampling!r}")
        if camera is not None and not isinstance(camera, Camera):
            raise Error(f"camera: expected a fishcam.Camera, got {type(camera).__name__}")
        if (max_rotation_deg is None) != (max_translation is None):
            raise Error("max_rotation_deg and max_translation go together")
        if max_rotation_deg is not None:
            preset = None
            if not (np.isfinite(_number(max_rotation_deg, "max_rotation_deg")) and 0 <= max_rotation_deg <= 180):
                raise Error(f"max_rotation_deg: must be in [0, 180], got {max_rotation_deg}")
            if not (np.isfinite(_number(max_translation, "max_translation")) and max_translation >= 0):
                raise Error(f"max_translation: must be finite and >= 0, got {max_translation}")
        else:
            _fishcam.check_preset(preset)
        _fishcam.check_depth_prior(depth)
        _check_p_and_fill(p, fill)
        self.camera = camera
        self.preset = preset
        self.max_rotation_deg = max_rotation_deg
        self.max_translation = max_translation
        self.depth = depth
        self.p = float(p)
        self.fill = fill
        self.fill_mask = _integer(fill_mask, "fill_mask")
        self.rng = rng
        self.sampling = sampling
        self._warps = _WarpCache()

    def change_for(self, seed):
        """The change this transform applies for ``seed`` (what the CLI's --seed gives)."""
        seed = _check_seed(seed)
        if self.preset is not None:
            return _fishcam.random_change(self.preset, seed)
        return _fishcam.random_change_in(self.max_rotation_deg, self.max_translation, seed)

    def __call__(self, image=None, mask=None, camera=None, seed=None):
        camera = camera if camera is not None else self.camera
        if camera is None:
            raise Error("camera: none given (pass camera= to the constructor or the call)")
        if image is None and mask is None:
            raise Error("nothing to transform: pass image= and/or mask=")
        if seed is None:
            seed = draw_seed(self.rng)
        seed = _check_seed(seed)
        change = self.change_for(seed) if _applies(self.p, seed) else _fishcam.ViewpointChange()
        warp = self._warps.get(camera)
        labels, restore = _labels_for_warp(mask, self.fill_mask)
        out = warp.warp(image=image, labels=labels, change=change, depth=self.depth, fill=self.fill,
                        label_fill=self.fill_mask, sampling=self.sampling)
        if "labels" in out:
            out["labels"] = restore(out["labels"])
        return _result(out, change_to_dict(change, seed, self.depth))

    def __repr__(self):
        what = (f"preset={self.preset!r}" if self.preset is not None else
                f"max_rotation_deg={self.max_rotation_deg}, max_translation={self.max_translation}")
        return f"RandomViewpoint({what}, depth={self.depth!r}, p={self.p})"


class RandomAffine:
    """The paper's affine baseline (§V.C.2): rotation about the image centre,
    translation, isotropic scale; no camera model (``camera=`` is accepted and
    ignored, so it can stand where RandomViewpoint does).

    preset: "train" (default; the paper's ranges: 30 deg, 0.3 of the image size,
        scale [0.5, 1.5]), "large" (the same), "medium" and "small" (2/3 and 1/3 of
        them); or give max_rotation_deg, max_translation and scale_range=(lo, hi).
    p, fill, fill_mask, rng: as RandomViewpoint. Resampled as RandomViewpoint does
    (bilinear images, nearest labels, fill where there is no source); the same
    seed gives the same change as ``fishcam augment --method affine --seed``.
    """

    def __init__(self, preset="train", max_rotation_deg=None, max_translation=None, scale_range=None, p=1.0,
                 fill=0, fill_mask=0, rng=None):
        custom = (max_rotation_deg, max_translation, scale_range)
        if any(v is not None for v in custom) and not all(v is not None for v in custom):
            raise Error("max_rotation_deg, max_translation and scale_range go together")
        if max_rotation_deg is not None:
            preset = None
            try:
                low, high = (float(v) for v in scale_range)
            except (TypeError, ValueError):
                raise Error(f"scale_range: expected (low, high), got {scale_range!r}") from None
            # The library checks the ranges (one message for every binding).
            _fishcam.random_affine_in(max_rotation_deg, max_translation, low, high, 0)
            self.scale_range = (low, high)
        elif preset not in _fishcam.affine_presets():
            _fishcam.random_affine(preset, 0)  # raises naming the presets
        else:
            self.scale_range = None
        _check_p_and_fill(p, fill)
        self.preset = preset
        self.max_rotation_deg = max_rotation_deg
        self.max_translation = max_translation
        self.p = float(p)
        self.fill = fill
        self.fill_mask = _integer(fill_mask, "fill_mask")
        self.rng = rng

    def change_for(self, seed):
        """The change this transform applies for ``seed`` (what the CLI's --seed gives)."""
        seed = _check_seed(seed)
        if self.preset is not None:
            return _fishcam.random_affine(self.preset, seed)
        return _fishcam.random_affine_in(self.max_rotation_deg, self.max_translation, *self.scale_range, seed)

    def __call__(self, image=None, mask=None, camera=None, seed=None):
        del camera  # no camera model: the baseline treats the image as flat
        if image is None and mask is None:
            raise Error("nothing to transform: pass image= and/or mask=")
        if seed is None:
            seed = draw_seed(self.rng)
        seed = _check_seed(seed)
        change = self.change_for(seed) if _applies(self.p, seed) else _fishcam.AffineChange()
        labels, restore = _labels_for_warp(mask, self.fill_mask)
        out = _fishcam.affine_warp(image=image, labels=labels, change=change, fill=self.fill,
                                   label_fill=self.fill_mask)
        if "labels" in out:
            out["labels"] = restore(out["labels"])
        return _result(out, affine_to_dict(change, seed))

    def __repr__(self):
        what = (f"preset={self.preset!r}" if self.preset is not None else
                f"max_rotation_deg={self.max_rotation_deg}, max_translation={self.max_translation}, "
                f"scale_range={self.scale_range}")
        return f"RandomAffine({what}, p={self.p})"


def affine_to_dict(change, seed=None):
    """An affine change as the manifest records it (``augment-dataset --method affine``)."""
    return {
        "method": "affine",
        "seed": seed,
        "rotation_deg": float(change.rotation_deg),
        "translation": [float(x) for x in change.translation],
        "scale": float(change.scale),
    }

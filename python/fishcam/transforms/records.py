"""The seed of one call and the record of its change: ``draw_seed`` (the seed a
call without ``seed=`` draws), whether a transform with probability ``p`` changes
the sample of a seed, and the records the manifest keeps (``change_to_dict`` for
viewpoint changes, ``affine_to_dict`` for the affine baseline's)."""

import typing

import numpy as np

from .. import _fishcam, change_to_dict
from .checks import Record

__all__ = ["draw_seed", "change_to_dict", "affine_to_dict"]


def draw_seed(rng: typing.Optional[np.random.Generator] = None) -> int:
    """One 64-bit seed from ``rng`` (a numpy Generator) or numpy's global generator."""
    if rng is not None:
        return int(rng.integers(0, 2**64, dtype=np.uint64))
    hi = int(np.random.randint(0, 2**32, dtype=np.uint64))
    lo = int(np.random.randint(0, 2**32, dtype=np.uint64))
    return (hi << 32) | lo


def _applies(p: float, seed: int) -> bool:
    """Whether a transform with probability p changes the sample of this seed: the
    decision follows from the seed too, so seed= reproduces it."""
    return p >= 1 or np.random.default_rng(seed).random() < p


def affine_to_dict(change: _fishcam.AffineChange, seed: typing.Optional[int] = None) -> Record:
    """An affine change as the manifest records it (``augment-dataset --method affine``)."""
    return {
        "method": "affine",
        "seed": seed,
        "rotation_deg": float(change.rotation_deg),
        "translation": [float(x) for x in change.translation],
        "scale": float(change.scale),
    }

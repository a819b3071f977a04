"""Seeds and change records of one sample: what the transforms draw from, and what
a seeded dataset sets (fishcam.torch's docstring, "Seeding")."""

import contextlib
import contextvars
import typing

import torch

from .. import _check_seed, set_num_threads
from .. import transforms as _transforms


def torch_seed() -> int:
    """One 64-bit seed from torch's (per-worker) generator."""
    hi, lo = torch.randint(0, 2**32, (2,), dtype=torch.int64).tolist()
    return int((hi << 32) | lo)


def worker_init_fn(worker_id: int) -> None:
    """For DataLoader workers: one fishcam thread each (the workers are the parallelism)."""
    del worker_id
    set_num_threads(1)


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

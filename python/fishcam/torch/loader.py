"""DataLoader: torch's, with fishcam's collate and worker set-up by default, and a
main-process run (``num_workers=0``) that its ``generator`` reproduces as it does a
run with workers (fishcam.torch's docstring, "Seeding")."""

import random
import typing

import numpy as np
import torch

from .batch import collate
from .seeding import worker_init_fn

# The states of the generators a DataLoader worker seeds: torch's CPU generator,
# Python's random and numpy's global one.
_States = tuple[torch.Tensor, typing.Any, typing.Any]
# Where torch's DataLoader takes collate_fn and worker_init_fn among the positional
# arguments after the dataset.
_COLLATE_FN_POSITION, _WORKER_INIT_FN_POSITION = 5, 9


def _states() -> _States:
    return torch.get_rng_state(), random.getstate(), np.random.get_state()


def _set_states(states: _States) -> None:
    torch.set_rng_state(states[0])
    random.setstate(states[1])
    np.random.set_state(states[2])


def _seeded_states(seed: int) -> _States:
    """The three generators' states seeded from one 64-bit seed (numpy's through a
    SeedSequence, so its stream is not Python's), the caller's states untouched."""
    outer = _states()
    try:
        torch.default_generator.manual_seed(seed)
        random.seed(seed)
        np.random.seed(np.random.SeedSequence(seed).generate_state(4))
        return _states()
    finally:
        _set_states(outer)


class _OwnRandomStream:
    """Each step of a single-process loader iterator under generators of its own, as
    a worker process has: the training loop's draws between batches neither see nor
    move them."""

    def __init__(self, iterator: typing.Iterator[typing.Any], seed: int) -> None:
        self._iterator = iterator
        self._states = _seeded_states(seed)

    def __iter__(self) -> "_OwnRandomStream":
        return self

    def __next__(self) -> typing.Any:
        outer = _states()
        _set_states(self._states)
        try:
            return next(self._iterator)
        finally:
            self._states = _states()
            _set_states(outer)

    def __len__(self) -> int:
        return len(typing.cast(typing.Sized, self._iterator))


class DataLoader(torch.utils.data.DataLoader[typing.Any]):
    """``torch.utils.data.DataLoader`` with ``collate_fn=fishcam.torch.collate`` and
    ``worker_init_fn=fishcam.torch.worker_init_fn`` unless given, and one difference
    at ``num_workers=0``: each pass draws a seed from ``generator`` (from torch's
    default generator without one, as torch's own DataLoader draws its workers'
    seed) and loads its samples under torch's, Python's and
    numpy's generators seeded from it and kept apart from the main process's. So
    ``generator=torch.Generator().manual_seed(s)`` reproduces an unseeded dataset's
    changes, and those of every other random transform of the pipeline, with or
    without workers, and the model's own draws (dropout, initialisation) between
    batches do not change them. With workers it is torch's DataLoader: torch seeds
    each worker from ``generator``.

    Takes torch's arguments, unchanged.
    """

    def __init__(self, dataset: torch.utils.data.Dataset[typing.Any], *args: typing.Any, **kwargs: typing.Any) -> None:
        # Defaults only where the caller gave neither keyword nor position (torch's
        # order: batch_size, shuffle, sampler, batch_sampler, num_workers, collate_fn,
        # pin_memory, drop_last, timeout, worker_init_fn).
        if len(args) <= _COLLATE_FN_POSITION:
            kwargs.setdefault("collate_fn", collate)
        if len(args) <= _WORKER_INIT_FN_POSITION:
            kwargs.setdefault("worker_init_fn", worker_init_fn)
        super().__init__(dataset, *args, **kwargs)

    def __iter__(self) -> typing.Iterator[typing.Any]:  # type: ignore[override]
        if self.num_workers > 0:
            return super().__iter__()
        # Drawn as torch draws its workers' base seed, from the loader's generator.
        seed = int(torch.empty((), dtype=torch.int64).random_(generator=self.generator).item())
        return _OwnRandomStream(super().__iter__(), seed)

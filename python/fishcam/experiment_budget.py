"""The experiment harness's ``--budget MINUTES`` (docs/experiment.md, "A run that fits
a budget"): the resolution (``--scale``), the number of training images
(``--train-images``), the network's width and the training epochs chosen from costs
measured on this machine, on the dataset itself, before any run trains.

Three costs are measured per candidate scale, each a median of a few repetitions
after a warm-up: a batch of each configuration's training pipeline (reading,
downscaling, augmenting, collating: ``DataLoader`` as the runs use it), a training
iteration per candidate width as the runs make it (the next batch, forward, the
weighted loss, backward, optimiser, schedule: ``experiment.Training.step``), and the
evaluation of one image per width (reading and downscaling it, one pass over the test
images, and the network's forward pass at that scale). Scales are measured from the
finest and stop at the first one that holds every training image at a width of at
least ``PREFERRED_WIDTH`` for ``MIN_EPOCHS``; at every scale but the last, only those
widths are measured. Widths are measured from the narrowest and stop where one no
longer fits; the time the process ran before (its imports, the dataset's scan) and
the measurement itself count against the budget. A run of ``epochs`` on ``images``
training images costs ``epochs x ceil(images / batch size) x (pipeline + step)`` plus
its evaluation; the whole experiment is the sum over the configurations and seeds,
and what remains of the budget after the measurement must hold it (with a margin for
the fidelity tables and figures).

The choice (a pure function of the costs, ``choose``): every training image at full
resolution with the widest width >= ``PREFERRED_WIDTH`` that trains ``MIN_EPOCHS``,
then as many epochs as fit (at most ``MAX_EPOCHS``). When that does not fit, the
settings are reduced in this order, each one to its limit before the next: the
resolution (the next scale of ``SCALES``, with the widest such width again); the
training images (the most, down to ``MIN_IMAGE_SHARE`` of them, that train the
narrowest such width ``MIN_EPOCHS`` at the coarsest scale); the width (the widest
narrower one at the fewest images); the epochs (as many as fit, at least one, at the
narrowest width). An error when one epoch of that does not fit. Settings given on the
command line are kept and skip their step.
"""

import math
import os
import statistics
import time
import typing

import torch

from . import Error

# The widths --budget chooses from (the harness's default, 16, among them).
WIDTHS = (8, 12, 16, 24, 32, 48)
# The scales (downscale factors of the dataset's images) --budget chooses from and
# --scale takes, finest first.
SCALES = (1.0, 0.75, 0.5)
# Narrower networks underfit (docs/experiment.md, runs 2 and 3): the resolution and
# the training images are reduced before the width goes below this.
PREFERRED_WIDTH = 16
# Epochs: at least this many before a wider network is chosen, at most this many.
MIN_EPOCHS, MAX_EPOCHS = 10, 60
# The training images are reduced to this share of them at most before the width is.
MIN_IMAGE_SHARE = 0.5
# The share of the budget kept for what the cost model leaves out (the fidelity
# tables, figures, writing the runs, the noise of a shared machine).
MARGIN = 0.15
REPEATS = 3


class Costs(typing.NamedTuple):
    """Measured seconds, per scale: per training batch of each configuration's data
    pipeline, per training step of the network per width, per evaluated image per
    width; and what the measurement itself took."""

    pipeline: dict[float, dict[str, float]]
    step: dict[float, dict[int, float]]
    evaluation: dict[float, dict[int, float]]
    measured_in: float


class Work(typing.NamedTuple):
    """What the runs are, besides the settings --budget chooses: seeds per
    configuration (the configurations are the costs' pipelines), the images train/
    holds, the batch size, the images each run is evaluated on."""

    seeds: int
    train_images: int
    batch_size: int
    evaluated_images: int


class Fixed(typing.NamedTuple):
    """The settings given on the command line (None: --budget chooses it)."""

    scale: typing.Optional[float] = None
    train_images: typing.Optional[int] = None
    width: typing.Optional[int] = None
    epochs: typing.Optional[int] = None


class Plan(typing.NamedTuple):
    """What --budget chose, what it reduced to fit (in the order of the module
    docstring: ``resolution``, ``training images``, ``width``, ``epochs``), and the
    time it predicts for the runs."""

    scale: float
    train_images: int
    width: int
    epochs: int
    reduced: tuple[str, ...]
    predicted_seconds: float
    budget_seconds: float
    costs: Costs

    def record(self) -> dict[str, typing.Any]:
        """As results.json stores it (scales as keys written as in --scale)."""
        return {
            "minutes": self.budget_seconds / 60,
            "scale": self.scale,
            "train_images": self.train_images,
            "width": self.width,
            "epochs": self.epochs,
            "reduced": list(self.reduced),
            "predicted_run_seconds": self.predicted_seconds,
            "measurement_seconds": self.costs.measured_in,
            "pipeline_seconds_per_batch": {f"{s:g}": dict(c) for s, c in self.costs.pipeline.items()},
            "step_seconds": {f"{s:g}": {str(w): v for w, v in c.items()} for s, c in self.costs.step.items()},
            "evaluation_seconds_per_image": {
                f"{s:g}": {str(w): v for w, v in c.items()} for s, c in self.costs.evaluation.items()
            },
        }


def _median_seconds(action: typing.Callable[[], object], repeats: int = REPEATS) -> float:
    action()  # warm-up: allocations, kernels chosen, a worker's start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def endless(loader: typing.Iterable[typing.Any]) -> typing.Iterator[typing.Any]:
    """A loader's batches epoch after epoch (a small dataset has fewer batches than the
    repetitions)."""
    while True:
        yield from loader


def _pipeline_seconds(loader: typing.Iterable[typing.Any]) -> float:
    """Seconds per batch of a DataLoader, iterated as a run does."""
    batches = endless(loader)
    return _median_seconds(lambda: next(batches))


def _forward_seconds(
    net_for: typing.Callable[[int], torch.nn.Module],
    width: int,
    batch: int,
    image_size: tuple[int, int],
    device: torch.device,
) -> float:
    """Seconds per image of the evaluating forward pass of the network of ``width`` on
    random images of ``image_size`` (height, width)."""
    images = torch.rand((batch, 3, *image_size), generator=torch.Generator().manual_seed(0)).to(device)
    net = net_for(width).to(device)
    net.eval()
    with torch.no_grad():
        return _median_seconds(lambda: net(images)) / batch


def _reading_seconds(loader: typing.Iterable[typing.Any]) -> float:
    """Seconds per image of reading an evaluation folder (one pass of its DataLoader)."""
    start, images = time.perf_counter(), 0
    for batch in loader:
        images += len(batch["image"])
    return (time.perf_counter() - start) / max(images, 1)


def measure(
    loaders: typing.Callable[[float], typing.Mapping[str, typing.Iterable[typing.Any]]],
    evaluation_loader: typing.Callable[[float], typing.Iterable[typing.Any]],
    iteration: typing.Callable[[int, typing.Iterable[typing.Any]], typing.Callable[[], object]],
    net_for: typing.Callable[[int], torch.nn.Module],
    shape: typing.Callable[[float], tuple[int, int, int]],
    device: torch.device,
    widths: typing.Mapping[float, typing.Sequence[int]],
    plan: typing.Callable[[Costs], Plan],
) -> Costs:
    """The costs of this machine at the candidate scales (``widths``: scale -> the
    candidate widths there, finest scale first): each configuration's loader
    (``loaders(scale)``: config -> its training DataLoader); a training iteration as
    the runs make it (``iteration(width, loader)``: an action taking the loader's next
    batch and training on it) per width, on the cheapest configuration's loader;
    reading the test images (``evaluation_loader(scale)``) and the network's forward
    pass (``net_for(width)`` on batches of ``shape(scale)``: batch, height, width) per
    evaluated image. ``plan``: ``choose`` for this budget, which says when the costs
    measured so far settle the choice (the module docstring)."""
    start = time.perf_counter()
    pipeline: dict[float, dict[str, float]] = {}
    step: dict[float, dict[int, float]] = {}
    evaluation: dict[float, dict[int, float]] = {}

    def costs() -> Costs:
        return Costs(pipeline, step, evaluation, time.perf_counter() - start)

    scales = list(widths)
    for k, scale in enumerate(scales):
        last = k == len(scales) - 1
        candidates = sorted(widths[scale])
        if not last:
            # Narrower widths are chosen at the last scale only.
            candidates = [w for w in candidates if w >= PREFERRED_WIDTH] or candidates
        loaders_here = loaders(scale)
        pipeline[scale] = {config: _pipeline_seconds(loader) for config, loader in loaders_here.items()}
        cheapest = min(pipeline[scale], key=lambda config: pipeline[scale][config])
        reading = _reading_seconds(evaluation_loader(scale))
        step[scale], evaluation[scale] = {}, {}
        settled = False
        for width in candidates:
            # The iteration includes the cheapest pipeline's batch: the step is the rest.
            iteration_seconds = _median_seconds(iteration(width, loaders_here[cheapest]))
            step[scale][width] = max(iteration_seconds - pipeline[scale][cheapest], 0.0)
            shaped = shape(scale)
            evaluation[scale][width] = reading + _forward_seconds(net_for, width, shaped[0], shaped[1:], device)
            try:
                chosen = plan(costs())
            except Error:
                break  # not even the narrowest fits: a wider one will not either
            # At every scale but the last, only a plan without reductions but the
            # resolution settles the choice; wider widths matter while the widest
            # measured one is chosen.
            settled = chosen.scale == scale and set(chosen.reduced) <= {"resolution"}
            if chosen.scale != scale or chosen.width < width or not (last or settled):
                break
        if settled:
            break  # a coarser scale would not be chosen
    return costs()


def predicted_seconds(costs: Costs, work: Work, scale: float, train_images: int, width: int, epochs: int) -> float:
    """The runs' time: every configuration's seeds, each ``epochs`` x the batches of
    ``train_images`` of its pipeline and the network's step, then its evaluation, at
    ``scale``."""
    batches = -(-train_images // work.batch_size)
    per_run_evaluation = work.evaluated_images * costs.evaluation[scale][width]
    return sum(
        work.seeds * (epochs * batches * (pipeline + costs.step[scale][width]) + per_run_evaluation)
        for pipeline in costs.pipeline[scale].values()
    )


def seconds_since_process_start() -> float:
    """How long this process has run (its imports included; 0 where /proc does not say)."""
    try:
        with open("/proc/self/stat") as f:
            start_ticks = int(f.read().rsplit(")", 1)[1].split()[19])  # field 22, starttime
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return max(0.0, uptime - start_ticks / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError):
        return 0.0


NOTHING_FIXED = Fixed()


def choose(costs: Costs, minutes: float, work: Work, elapsed: float = 0.0, fixed: Fixed = NOTHING_FIXED) -> Plan:
    """The scale, training images, width and epochs for a budget of ``minutes`` of
    which ``elapsed`` seconds were spent before the measurement, in the module
    docstring's order (``fixed``: the settings given, kept); fishcam.Error when
    nothing fits."""
    budget = minutes * 60
    available = (budget - elapsed - costs.measured_in) * (1 - MARGIN)
    measured = {
        scale: sorted(w for w in step if fixed.width in (None, w)) for scale, step in costs.step.items()
    }  # the widths to choose from
    scales = sorted((s for s in measured if measured[s] and fixed.scale in (None, s)), reverse=True)
    if not scales:
        raise Error(f"--budget {minutes:g}: no cost measured")
    every = fixed.train_images or work.train_images
    fewest = fixed.train_images or max(1, math.ceil(MIN_IMAGE_SHARE * work.train_images))
    least = fixed.epochs or MIN_EPOCHS

    def cost(scale: float, images: int, width: int, epochs: int) -> float:
        return predicted_seconds(costs, work, scale, images, width, epochs)

    def widths(scale: float, preferred: bool) -> list[int]:
        # A width given on the command line counts as preferred: it is never reduced.
        if fixed.width is not None:
            return measured[scale] if preferred else []
        return [w for w in measured[scale] if (w >= PREFERRED_WIDTH) == preferred]

    def plan(scale: float, images: int, width: int, *reduced: str) -> Plan:
        epochs = fixed.epochs
        if epochs is None:
            epochs = 0
            while epochs < MAX_EPOCHS and cost(scale, images, width, epochs + 1) <= available:
                epochs += 1
        if scale < scales[0]:
            reduced = ("resolution",) + reduced
        return Plan(scale, images, width, epochs, reduced, cost(scale, images, width, epochs), budget, costs)

    # Every image, from the finest scale: the widest preferred width that trains `least` epochs.
    for scale in scales:
        fitting = [w for w in widths(scale, True) if cost(scale, every, w, least) <= available]
        if fitting:
            return plan(scale, every, fitting[-1])
    coarsest = scales[-1]
    # Fewer images: the most that train the narrowest preferred width.
    preferred = widths(coarsest, True)
    if preferred:
        for images in range(every - 1, fewest - 1, -1):
            if cost(coarsest, images, preferred[0], least) <= available:
                return plan(coarsest, images, preferred[0], "training images")
    # Narrower widths on the fewest images.
    fitting = [w for w in widths(coarsest, False) if cost(coarsest, fewest, w, least) <= available]
    shrunk = ("training images",) if fewest < every else ()
    if fitting:
        return plan(coarsest, fewest, fitting[-1], *shrunk, "width")
    # Fewer epochs at the narrowest width.
    narrowest = measured[coarsest][0]
    if fixed.epochs is None and cost(coarsest, fewest, narrowest, 1) <= available:
        narrower = ("width",) if narrowest < PREFERRED_WIDTH and fixed.width is None else ()
        return plan(coarsest, fewest, narrowest, *shrunk, *narrower, "epochs")
    raise Error(
        f"--budget {minutes:g}: {least if fixed.epochs else 1} epoch(s) of every run at scale {coarsest:g} on "
        f"{fewest} training image(s) at width {narrowest} take about "
        f"{cost(coarsest, fewest, narrowest, least if fixed.epochs else 1) / 60:.1f} min on this machine, more than "
        f"the {max(available, 0) / 60:.1f} min left (fewer --configs or --seeds, or a smaller dataset)"
    )

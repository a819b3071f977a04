"""The experiment harness's ``--budget MINUTES`` (docs/experiment.md, "A run that fits
a budget"): the network's width and the training epochs chosen from costs measured
on this machine, on the dataset itself, before any run trains.

Three costs are measured, each a median of a few repetitions after a warm-up: a
batch of each configuration's training pipeline (reading, augmenting, collating:
``DataLoader`` as the runs use it), a training iteration per candidate width as the
runs make it (the next batch, forward, the weighted loss, backward, optimiser,
schedule: ``experiment.Training.step``), and the evaluation of one image per width (reading it, one pass over the test images, and
the network's forward pass). Widths are measured from the narrowest and stop where
one no longer fits; the time the process ran before (its imports, the dataset's
scan) and the measurement itself count against the budget. A run of ``epochs`` costs ``epochs x batches x
(pipeline + step)`` plus its evaluation; the whole experiment is the sum over the
configurations and seeds, and what remains of the budget after the measurement must
hold it (with a margin for the fidelity tables and figures).

The choice: the widest candidate width that trains ``MIN_EPOCHS`` epochs within the
budget, then as many epochs as fit at that width (at most ``MAX_EPOCHS``); the
narrowest width with fewer epochs (at least one) when even that does not fit; an
error when one epoch at the narrowest width does not fit.
"""

import os
import statistics
import time
import typing

import torch

from . import Error

# The widths --budget chooses from (the harness's default, 16, among them).
WIDTHS = (8, 12, 16, 24, 32, 48)
# Epochs: at least this many before a wider network is chosen, at most this many.
MIN_EPOCHS, MAX_EPOCHS = 10, 60
# The share of the budget kept for what the cost model leaves out (the fidelity
# tables, figures, writing the runs, the noise of a shared machine).
MARGIN = 0.15
REPEATS = 3


class Costs(typing.NamedTuple):
    """Measured seconds: per training batch of each configuration's data pipeline, per
    training step of the network per width, per evaluated image per width; and what
    the measurement itself took."""

    pipeline: dict[str, float]
    step: dict[int, float]
    evaluation: dict[int, float]
    measured_in: float


class Plan(typing.NamedTuple):
    """What --budget chose, and the time it predicts for the runs."""

    width: int
    epochs: int
    predicted_seconds: float
    budget_seconds: float
    costs: Costs

    def record(self) -> dict[str, typing.Any]:
        """As results.json stores it."""
        return {
            "minutes": self.budget_seconds / 60,
            "width": self.width,
            "epochs": self.epochs,
            "predicted_run_seconds": self.predicted_seconds,
            "measurement_seconds": self.costs.measured_in,
            "pipeline_seconds_per_batch": self.costs.pipeline,
            "step_seconds": {str(w): s for w, s in self.costs.step.items()},
            "evaluation_seconds_per_image": {str(w): s for w, s in self.costs.evaluation.items()},
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
    loaders: typing.Mapping[str, typing.Iterable[typing.Any]],
    evaluation_loader: typing.Iterable[typing.Any],
    iteration: typing.Callable[[int, typing.Iterable[typing.Any]], typing.Callable[[], object]],
    net_for: typing.Callable[[int], torch.nn.Module],
    shape: tuple[int, int, int],
    device: torch.device,
    widths: typing.Sequence[int] = WIDTHS,
    enough: typing.Callable[[Costs], bool] = lambda costs: False,
) -> Costs:
    """The costs of this machine: each configuration's loader (``loaders``: config ->
    its training DataLoader); a training iteration as the runs make it
    (``iteration(width, loader)``: an action taking the loader's next batch and
    training on it) per width, on the cheapest configuration's loader; reading the
    test images (``evaluation_loader``) and the network's forward pass
    (``net_for(width)`` on batches of ``shape``: batch, height, width) per evaluated
    image. Widths from the narrowest; the wider ones are not measured once ``enough``
    says the costs so far already exceed what is needed."""
    start = time.perf_counter()
    pipeline = {config: _pipeline_seconds(loader) for config, loader in loaders.items()}
    cheapest = min(pipeline, key=lambda config: pipeline[config])
    reading = _reading_seconds(evaluation_loader)
    step: dict[int, float] = {}
    evaluation: dict[int, float] = {}
    for width in sorted(widths):
        # The iteration includes the cheapest pipeline's batch: the step is the rest.
        step[width] = max(_median_seconds(iteration(width, loaders[cheapest])) - pipeline[cheapest], 0.0)
        evaluation[width] = reading + _forward_seconds(net_for, width, shape[0], shape[1:], device)
        if enough(Costs(pipeline, step, evaluation, time.perf_counter() - start)):
            break
    return Costs(pipeline, step, evaluation, time.perf_counter() - start)


def predicted_seconds(
    costs: Costs, width: int, epochs: int, seeds: int, batches_per_epoch: int, evaluated_images: int
) -> float:
    """The runs' time: every configuration's seeds, each ``epochs`` x batches of its
    pipeline and the network's step, then its evaluation."""
    per_run_evaluation = evaluated_images * costs.evaluation[width]
    return sum(
        seeds * (epochs * batches_per_epoch * (pipeline + costs.step[width]) + per_run_evaluation)
        for pipeline in costs.pipeline.values()
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


def choose(
    costs: Costs,
    minutes: float,
    seeds: int,
    batches_per_epoch: int,
    evaluated_images: int,
    elapsed: float = 0.0,
    epochs: typing.Optional[int] = None,
) -> Plan:
    """The width and epochs for a budget of ``minutes`` of which ``elapsed`` seconds
    were spent before the measurement (the module docstring says how; ``epochs``
    given: the widest width that trains them); fishcam.Error when nothing fits."""
    budget = minutes * 60
    available = (budget - elapsed - costs.measured_in) * (1 - MARGIN)

    def cost(width: int, epochs: int) -> float:
        return predicted_seconds(costs, width, epochs, seeds, batches_per_epoch, evaluated_images)

    widths = sorted(costs.step)
    fitting = [w for w in widths if cost(w, epochs or MIN_EPOCHS) <= available]
    width = fitting[-1] if fitting else widths[0]
    if epochs is None:
        epochs = 0
        while epochs < MAX_EPOCHS and cost(width, epochs + 1) <= available:
            epochs += 1
    if epochs == 0 or cost(width, epochs) > available:
        raise Error(
            f"--budget {minutes:g}: {max(epochs, 1)} epoch(s) of every run at width {width} take about "
            f"{cost(width, max(epochs, 1)) / 60:.1f} min on this machine, more than the "
            f"{max(available, 0) / 60:.1f} min left (fewer --configs, --seeds or --epochs, or a smaller dataset)"
        )
    return Plan(width, epochs, cost(width, epochs), budget, costs)

"""fishcam for PyTorch: the viewpoint change (and the affine baseline) as
torchvision.transforms.v2 transforms, a WoodScape dataset that hands whole samples
to its transform, an epoch-carrying sampler, and the DataLoader worker set-up.

    from torchvision.transforms import v2
    transform = v2.Compose([fishcam.torch.RandomViewpoint(preset="train"),   # camera from the sample
                            v2.ColorJitter(0.2, 0.2), v2.ToDtype(torch.float32, scale=True)])
    dataset = fishcam.torch.WoodScapeDataset(root, transform=transform, seed=5)
    loader = fishcam.torch.DataLoader(dataset, batch_size=8, num_workers=2,   # fishcam's collate and worker set-up
                                      sampler=fishcam.torch.EpochSampler(torch.utils.data.RandomSampler(dataset)),
                                      persistent_workers=True,  # workers keep their warps
                                      generator=torch.Generator().manual_seed(0))

Seeding: without a dataset seed, each sample's change comes from torch's generator
(two 32-bit draws, since torch.randint cannot draw 64 bits), which the DataLoader
seeds per worker from its own generator: workers differ, and the same generator
seed reproduces a run. At ``num_workers=0`` torch's DataLoader seeds nothing (the
draws come from the main process's generator, shared with the model);
``fishcam.torch.DataLoader`` loads under generators seeded from its ``generator``
there too. With ``WoodScapeDataset(seed=S)``, sample ``i`` of epoch
``e`` gets ``derive_seed(S, f"epoch{e}", i)`` whatever the workers and processes:
the epoch travels with the index from ``EpochSampler``, which runs in the main
process and counts the epochs itself; torch's generator is seeded with that seed
for the call, so the other random transforms of the pipeline follow it too. A
seeded dataset indexed by a bare index raises instead of repeating one epoch's
changes: always inside a DataLoader worker (a worker's copy of the dataset never
sees ``set_epoch`` from the main process), and in the main process until
``set_epoch`` is called.
"""

try:
    from torchvision import tv_tensors
    from torchvision.transforms import v2  # noqa: F401  (what the modules below need)
except ImportError as error:  # pragma: no cover - the message is the point
    raise ImportError(
        "fishcam.torch needs torchvision >= 0.23 (transforms.v2 and tv_tensors.KeyPoints): "
        f"pip install torchvision ({error})"
    ) from None
if not hasattr(tv_tensors, "KeyPoints"):  # pragma: no cover
    raise ImportError("fishcam.torch needs torchvision >= 0.23 (tv_tensors.KeyPoints); pip install -U torchvision")

from . import functional
from .batch import WarpedBatch, collate, warp_batch
from .data import EpochSampler, WoodScapeDataset
from .geometry import CenterCrop, RandomCrop, RandomHorizontalFlip, RandomVerticalFlip, Resize
from .loader import DataLoader
from .seeding import record_changes, sample_seed, torch_seed, worker_init_fn
from .targets import DepthMap, Polygon, is_instance_mask
from .transforms import RandomAffine, RandomViewpoint

__all__ = [
    "functional",
    "RandomViewpoint",
    "RandomAffine",
    "Resize",
    "RandomCrop",
    "CenterCrop",
    "RandomHorizontalFlip",
    "RandomVerticalFlip",
    "DepthMap",
    "Polygon",
    "WoodScapeDataset",
    "EpochSampler",
    "DataLoader",
    "WarpedBatch",
    "warp_batch",
    "collate",
    "sample_seed",
    "record_changes",
    "worker_init_fn",
    "torch_seed",
    "is_instance_mask",
]

"""Train a segmentation network on a WoodScape-layout folder with fishcam's viewpoint
augmentation: a torchvision v2 pipeline, persistent DataLoader workers, a new change
for every sample in every epoch (reproducible from one seed whatever the workers),
and the pixels the moved camera has no source for left out of the loss.

    build/tools/fishcam sample-dataset woodscape-sample --images 16 --seed 1 --size 320x242
    PYTHONPATH=build/python build/venv/bin/python python/examples/train_segmentation.py woodscape-sample

(docs/python.md walks through it.) The network is deliberately tiny: the point is
the data pipeline; put your own model in its place.
"""

import argparse

import fishcam
import fishcam.torch as ft
import torch
from torchvision import tv_tensors
from torchvision.transforms import v2

CLASSES = 10  # WoodScape's semantic classes
NO_SOURCE = 255  # the label where the moved camera sees outside the original image


def tiny_segmentation_net():
    return torch.nn.Sequential(
        torch.nn.Conv2d(3, 16, 3, stride=2, padding=1),
        torch.nn.ReLU(),
        torch.nn.Conv2d(16, 32, 3, stride=2, padding=1),
        torch.nn.ReLU(),
        torch.nn.ConvTranspose2d(32, 16, 4, stride=2, padding=1),
        torch.nn.ReLU(),
        torch.nn.ConvTranspose2d(16, CLASSES, 4, stride=2, padding=1),
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "root", help="a WoodScape-layout folder (rgb_images/, semantic_annotations/gtLabels/, calibration/)"
    )
    parser.add_argument("--epochs", type=int, default=2)
    parser.add_argument("--batch-size", type=int, default=4)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    # One change per sample for the image, the mask and the camera (taken from the
    # sample: every WoodScape image has its own calibration), then photometric
    # transforms, which do not touch the mask.
    transform = v2.Compose(
        [
            ft.RandomViewpoint(preset="train", fill_mask=NO_SOURCE),
            v2.ColorJitter(brightness=0.3, contrast=0.3, saturation=0.3),
            v2.ToDtype({tv_tensors.Image: torch.float32, "others": None}, scale=True),
        ]
    )
    dataset = ft.WoodScapeDataset(args.root, transform=transform, seed=args.seed)
    # EpochSampler hands each index its epoch from the main process: persistent
    # workers see every epoch (a fresh change per sample and epoch).
    sampler = ft.EpochSampler(
        torch.utils.data.RandomSampler(dataset, generator=torch.Generator().manual_seed(args.seed))
    )
    loader = torch.utils.data.DataLoader(
        dataset,
        batch_size=args.batch_size,
        sampler=sampler,
        num_workers=args.workers,
        persistent_workers=args.workers > 0,
        worker_init_fn=ft.worker_init_fn,
        collate_fn=ft.collate,
    )

    torch.manual_seed(args.seed)
    net = tiny_segmentation_net()
    optimiser = torch.optim.Adam(net.parameters(), lr=1e-3)
    for epoch in range(args.epochs):
        total, batches = 0.0, 0
        for batch in loader:
            image, mask = batch["image"], batch["mask"]  # (B, 3, H, W) float32, (B, H, W) int64
            logits = net(image)[..., : mask.shape[-2], : mask.shape[-1]]
            loss = torch.nn.functional.cross_entropy(logits, mask, ignore_index=NO_SOURCE)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            total, batches = total + loss.item(), batches + 1
        print(f"epoch {epoch}: mean loss {total / batches:.4f} over {batches} batches (fishcam {fishcam.__version__})")


if __name__ == "__main__":
    main()

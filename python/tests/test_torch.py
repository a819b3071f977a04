"""fishcam.torch inside DataLoaders and torchvision v2 pipelines: seeding across
workers and epochs, reproducibility, a seeded dataset independent of the number of
workers, dict and tuple samples beside photometric transforms, every tv_tensor
target, bad input."""

import json
import os
import pickle

import fishcam
import fishcam.torch as ft
import numpy as np
import pytest
import torch
from conftest import DATA
from torchvision import tv_tensors
from torchvision.transforms import v2


@pytest.fixture(scope="module")
def small_camera():
    # A small image keeps the loaders fast; the lens is WoodScape's, scaled.
    return fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json")).resized(160, 121)


@pytest.fixture(scope="module")
def dataset_root(tmp_path_factory, small_camera):
    """A WoodScape-layout folder with 6 small samples."""
    import cv2

    root = tmp_path_factory.mktemp("woodscape")
    for sub in ["rgb_images", "semantic_annotations/gtLabels", "calibration"]:
        (root / sub).mkdir(parents=True)
    rng = np.random.default_rng(0)
    for i in range(6):
        name = f"{i:05d}_FV"
        cv2.imwrite(str(root / "rgb_images" / f"{name}.png"), rng.integers(0, 256, (121, 160, 3), dtype=np.uint8))
        cv2.imwrite(
            str(root / "semantic_annotations/gtLabels" / f"{name}.png"), rng.integers(0, 10, (121, 160), dtype=np.uint8)
        )
        small_camera.write(str(root / "calibration" / f"{name}.json"), format="woodscape")
    return root


class Images(torch.utils.data.Dataset):
    def __init__(self, camera, n=8):
        self.camera = camera
        self.transform = ft.RandomViewpoint(camera, preset="train")
        self.n = n

    def __len__(self):
        return self.n

    def __getitem__(self, index):
        image = torch.full((3, self.camera.height, self.camera.width), index, dtype=torch.uint8)
        with ft.record_changes() as records:
            self.transform(image)
        (change,) = records
        return torch.tensor(change["rotation_deg"] + change["translation"], dtype=torch.float64)


def changes(loader, epochs=2):
    return [torch.cat(list(loader)) for _ in range(epochs)]


def test_changes_differ_across_workers_and_epochs_and_reproduce(small_camera):
    def loader(seed):
        return torch.utils.data.DataLoader(
            Images(small_camera),
            batch_size=2,
            num_workers=2,
            worker_init_fn=ft.worker_init_fn,
            generator=torch.Generator().manual_seed(seed),
        )

    a = changes(loader(1))
    rows = torch.cat(a)
    assert len({tuple(r.tolist()) for r in rows}) == rows.shape[0], "a change repeated across workers or epochs"
    b = changes(loader(1))
    for x, y in zip(a, b):
        assert torch.equal(x, y)
    c = changes(loader(2))
    assert not torch.equal(a[0], c[0])


def seed_of(changes):
    (change,) = json.loads(changes)
    return change["seed"]


def epoch_seeds(loader, dataset, epochs, images=None):
    """Per epoch, {index: seed of its change} as the loader delivered them; with
    ``images``, also {(epoch, index): image bytes} into it."""
    out = []
    for e in range(epochs):
        seeds = {}
        for batch in loader:
            for k, (name, changes) in enumerate(zip(batch["name"], batch["changes"])):
                index = dataset.names.index(name)
                assert index not in seeds, "an index delivered twice in one epoch"
                seeds[index] = seed_of(changes)
                if images is not None:
                    images[(e, index)] = batch["image"][k].numpy().tobytes()
        out.append(seeds)
    return out


PIPELINE_IMAGES = {}


@pytest.mark.parametrize("workers,persistent", [(0, False), (1, False), (1, True), (2, False), (2, True)])
def test_every_epoch_reaches_every_worker(dataset_root, workers, persistent):
    """Sample i of epoch e gets derive_seed(S, "epoch{e}", i): persistent workers
    included, whatever the sampler's order (the silent repeat this replaced); the
    whole v2 pipeline (a photometric transform too) gives the same images whatever
    the workers."""
    transform = v2.Compose([ft.RandomViewpoint(preset="medium"), v2.ColorJitter(0.4, 0.4), v2.GaussianBlur(3)])
    ds = ft.WoodScapeDataset(dataset_root, transform=transform, seed=11)
    sampler = ft.EpochSampler(torch.utils.data.RandomSampler(ds, generator=torch.Generator().manual_seed(3)))
    loader = torch.utils.data.DataLoader(
        ds,
        batch_size=4,
        num_workers=workers,
        persistent_workers=persistent,
        sampler=sampler,
        worker_init_fn=ft.worker_init_fn if workers else None,
        collate_fn=ft.collate,
    )
    images = {}
    epochs = epoch_seeds(loader, ds, 3, images)
    assert len(epochs) == 3
    for e, seeds in enumerate(epochs):
        assert seeds == {i: fishcam.derive_seed(11, f"epoch{e}", i) for i in range(len(ds))}, e
    assert len({s for seeds in epochs for s in seeds.values()}) == 3 * len(ds), "a change repeated across epochs"
    assert len(set(images.values())) == len(images), "an image repeated across epochs"
    if PIPELINE_IMAGES:  # the images of the first configuration that ran
        assert images == PIPELINE_IMAGES, "the pipeline's output depends on the worker configuration"
    else:
        PIPELINE_IMAGES.update(images)
    sampler.set_epoch(7)  # resuming: the next pass is epoch 7
    assert epoch_seeds(loader, ds, 1)[0] == {i: fishcam.derive_seed(11, "epoch7", i) for i in range(len(ds))}


def test_distributed_ranks_share_the_epoch_seeds(dataset_root):
    """Two DistributedSampler ranks: together every index once per epoch, with the
    epoch's seed; the inner sampler is told the epoch (its shuffle changes)."""
    ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"), seed=4)
    ranks = [
        ft.EpochSampler(torch.utils.data.DistributedSampler(ds, num_replicas=2, rank=r, shuffle=True, seed=0))
        for r in range(2)
    ]
    for e in range(2):
        seeds = {}
        for sampler in ranks:
            loader = torch.utils.data.DataLoader(
                ds, batch_size=2, num_workers=1, sampler=sampler, collate_fn=ft.collate
            )
            for batch in loader:
                for name, changes in zip(batch["name"], batch["changes"]):
                    seeds[ds.names.index(name)] = seed_of(changes)
        assert seeds == {i: fishcam.derive_seed(4, f"epoch{e}", i) for i in range(len(ds))}
    assert ranks[0].sampler.epoch == 1


def test_a_seeded_dataset_without_the_epoch_in_workers_is_refused(dataset_root):
    ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"), seed=4)
    loader = torch.utils.data.DataLoader(
        ds, batch_size=2, num_workers=1, persistent_workers=True, collate_fn=ft.collate
    )
    with pytest.raises(fishcam.Error, match="EpochSampler"):
        next(iter(loader))
    # In the main process too, without EpochSampler: a bare index before set_epoch would
    # give every epoch epoch 0's changes (num_workers=0 and a plain sampler).
    plain = torch.utils.data.DataLoader(ds, batch_size=2, num_workers=0, collate_fn=ft.collate)
    with pytest.raises(fishcam.Error, match="a bare index has no epoch"):
        next(iter(plain))
    with pytest.raises(fishcam.Error, match="set_epoch"):
        ds[0]
    # After set_epoch a bare index uses its epoch; unseeded datasets take bare indices anywhere.
    ds.set_epoch(2)
    assert seed_of(ds[1]["changes"]) == fishcam.derive_seed(4, "epoch2", 1)
    assert seed_of(ds[(5, 1)]["changes"]) == fishcam.derive_seed(4, "epoch5", 1)
    unseeded = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"))
    assert len(list(torch.utils.data.DataLoader(unseeded, batch_size=3, num_workers=1, collate_fn=ft.collate))) == 2
    with pytest.raises(IndexError):
        ds[(0, len(ds))]
    with pytest.raises(fishcam.Error, match="start_epoch"):
        ft.EpochSampler(range(3), start_epoch=-1)


SEEDING_MATRIX = [
    (workers, persistent, seeded, epoch_sampler)
    for workers, persistent in [(0, False), (1, False), (1, True), (2, False), (2, True)]
    for seeded in (False, True)
    for epoch_sampler in (False, True)
]


@pytest.mark.parametrize("workers,persistent,seeded,epoch_sampler", SEEDING_MATRIX)
def test_every_seeding_configuration_reproduces_or_is_refused(dataset_root, workers, persistent, seeded, epoch_sampler):
    """docs/python.md, "Seeding and workers", with fishcam.torch.DataLoader: a seeded
    dataset without EpochSampler is refused at any worker count; every other
    configuration is reproduced by its generator seed (the model's draws between
    batches change nothing), differs across epochs and, unseeded, across generator
    seeds; seeded, sample i of epoch e has derive_seed(S, "epoch{e}", i)."""
    ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"), seed=9 if seeded else None)

    def run(generator_seed, model_draws):
        sampler = torch.utils.data.RandomSampler(ds, generator=torch.Generator().manual_seed(1))
        loader = ft.DataLoader(
            ds,
            batch_size=2,
            num_workers=workers,
            persistent_workers=persistent,
            sampler=ft.EpochSampler(sampler) if epoch_sampler else sampler,
            generator=torch.Generator().manual_seed(generator_seed),
        )
        epochs = []
        for _ in range(2):
            seeds = {}
            for batch in loader:
                if model_draws:
                    torch.rand(5), np.random.rand(5)  # what a training step draws between batches
                for name, changes in zip(batch["name"], batch["changes"]):
                    seeds[ds.names.index(name)] = seed_of(changes)
            epochs.append(seeds)
        return epochs

    if seeded and not epoch_sampler:
        with pytest.raises(fishcam.Error, match="EpochSampler"):
            run(5, False)
        return
    first = run(5, False)
    assert [len(seeds) for seeds in first] == [len(ds), len(ds)]
    assert run(5, True) == first
    assert not set(first[0].values()) & set(first[1].values()), "a change repeated across epochs"
    if seeded:
        for e, seeds in enumerate(first):
            assert seeds == {i: fishcam.derive_seed(9, f"epoch{e}", i) for i in range(len(ds))}
    else:
        assert not set(run(6, False)[0].values()) & set(first[0].values())


def test_a_plain_dataloader_in_the_main_process_follows_torch_manual_seed(dataset_root):
    """torch's own DataLoader at num_workers=0 seeds nothing: its generator does not
    reproduce an unseeded run, torch.manual_seed does (docs/python.md says so)."""
    ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"))

    def run(manual_seed):
        torch.manual_seed(manual_seed)
        loader = torch.utils.data.DataLoader(
            ds, batch_size=2, generator=torch.Generator().manual_seed(0), collate_fn=ft.collate
        )
        return [seed_of(c) for _ in range(2) for batch in loader for c in batch["changes"]]

    in_main = run(5)
    assert run(5) == in_main and run(6) != in_main
    assert len(set(in_main)) == len(in_main) == 2 * len(ds), "an unseeded change repeated across epochs"


def test_the_dataloader_takes_torch_arguments_by_position_too(dataset_root):
    """collate_fn and worker_init_fn given by position are the caller's (fishcam's
    defaults only fill what was not given), at the positions torch's signature has."""
    import inspect

    names = list(inspect.signature(torch.utils.data.DataLoader.__init__).parameters)[2:]
    assert names.index("collate_fn") == 5 and names.index("worker_init_fn") == 9
    ds = ft.WoodScapeDataset(dataset_root)
    calls = []

    def mine(samples):
        calls.append(len(samples))
        return samples

    loader = ft.DataLoader(ds, 2, False, None, None, 0, mine)
    assert loader.collate_fn is mine and loader.worker_init_fn is ft.worker_init_fn
    next(iter(loader))
    assert calls == [2]
    assert ft.DataLoader(ds, 2).collate_fn is ft.collate


def test_the_dataloader_keeps_the_main_process_generators(dataset_root):
    """With a generator, a pass at num_workers=0 neither reads nor moves the caller's
    torch, Python and numpy generators; torch's arguments pass through; collate is
    fishcam's."""
    import random

    ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"))
    torch.manual_seed(3), random.seed(3), np.random.seed(3)
    expected = (torch.rand(2), random.random(), np.random.rand())
    torch.manual_seed(3), random.seed(3), np.random.seed(3)
    loader = ft.DataLoader(ds, batch_size=4, drop_last=True, generator=torch.Generator().manual_seed(1))
    batches = list(loader)
    assert len(loader) == len(batches) == 1 and isinstance(batches[0]["camera"], list)
    assert len(iter(loader)) == 1
    after = (torch.rand(2), random.random(), np.random.rand())
    assert torch.equal(after[0], expected[0]) and after[1:] == expected[1:]


def test_dataset_items(dataset_root, small_camera):
    ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"), seed=3)
    item = ds[(0, 0)]
    assert isinstance(item["image"], tv_tensors.Image) and item["image"].shape == (3, 121, 160)
    assert item["image"].dtype == torch.uint8
    assert isinstance(item["mask"], tv_tensors.Mask) and item["mask"].dtype == torch.int64
    assert seed_of(item["changes"]) == fishcam.derive_seed(3, "epoch0", 0)
    plain = ds.camera(item["name"])
    assert plain == fishcam.Camera.read(str(dataset_root / "calibration" / f"{item['name']}.json"))
    change = fishcam.random_change("small", fishcam.derive_seed(3, "epoch0", 0))
    assert item["camera"] == plain.augmented(change), "the item's camera is the augmented one"
    untransformed = ft.WoodScapeDataset(dataset_root)[0]
    assert untransformed["camera"] == plain and "changes" not in untransformed
    pickle.loads(pickle.dumps(ds))
    batch = ft.collate([ds[(0, 0)], ds[(0, 1)]])
    assert batch["image"].shape == (2, 3, 121, 160) and len(batch["camera"]) == 2


def sample(camera, with_camera=True):
    rng = torch.Generator().manual_seed(0)
    h, w = camera.height, camera.width
    out = {
        "image": tv_tensors.Image(torch.randint(0, 256, (3, h, w), dtype=torch.uint8, generator=rng)),
        "mask": tv_tensors.Mask(torch.randint(0, 10, (h, w), generator=rng)),
        "boxes": tv_tensors.BoundingBoxes([[40, 30, 90, 70], [100, 60, 130, 100]], format="XYXY", canvas_size=(h, w)),
        "labels": torch.tensor([3, 5]),
        "points": tv_tensors.KeyPoints([[80.0, 60.0], [20.0, 15.0]], canvas_size=(h, w)),
        "depth": ft.DepthMap(torch.full((h, w), 4.0)),
        "polygons": [ft.Polygon([[40.0, 30.0], [90.0, 30.0], [90.0, 70.0]])],
        "name": "sample",
    }
    if with_camera:
        out["camera"] = camera
    return out


def test_v2_pipelines_on_dicts_and_tuples(small_camera):
    """Inside v2.Compose beside photometric and other geometric transforms: the same
    structure and types back; every target under the one change the numpy
    transform applies for the same seed."""
    pipeline = v2.Compose(
        [
            ft.RandomViewpoint(preset="large"),
            v2.ColorJitter(0.3, 0.3),
            v2.GaussianBlur(3),
            v2.RandomHorizontalFlip(p=0.0),
            v2.ToDtype(torch.float32, scale=True),
        ]
    )
    given = sample(small_camera)
    with ft.sample_seed(9) as records:
        out = pipeline(given)
    assert set(out) == set(given) and records[0]["seed"] == 9
    for key in ["image", "mask", "boxes", "points", "depth"]:
        assert type(out[key]) is type(given[key]), key
    assert out["image"].dtype == torch.float32 and out["mask"].dtype == torch.int64
    assert isinstance(out["polygons"][0], ft.Polygon) and out["name"] == "sample"
    assert torch.equal(out["labels"], given["labels"])

    alone = ft.RandomViewpoint(preset="large")
    with ft.sample_seed(9):
        viewpoint_only = alone(sample(small_camera))
    numpy_side = fishcam.transforms.RandomViewpoint(small_camera, preset="large")(
        image=given["image"].permute(1, 2, 0).numpy(),
        mask=given["mask"].numpy(),
        keypoints=given["points"].numpy(),
        boxes=given["boxes"].numpy(),
        depth_map=given["depth"].numpy(),
        polygons=[p.numpy() for p in given["polygons"]],
        camera=small_camera,
        seed=9,
    )
    np.testing.assert_array_equal(viewpoint_only["image"].permute(1, 2, 0).numpy(), numpy_side["image"])
    np.testing.assert_array_equal(viewpoint_only["mask"].numpy(), numpy_side["mask"])
    np.testing.assert_allclose(viewpoint_only["points"].numpy(), numpy_side["keypoints"], rtol=1e-6)
    np.testing.assert_allclose(viewpoint_only["depth"].numpy(), numpy_side["depth_map"])
    np.testing.assert_allclose(viewpoint_only["boxes"].numpy(), np.floor(numpy_side["boxes"]), atol=1)
    np.testing.assert_allclose(viewpoint_only["polygons"][0].numpy(), numpy_side["polygons"][0], rtol=1e-6)
    assert viewpoint_only["camera"] == numpy_side["camera"]

    # A tuple sample (image, mask) with the camera from the constructor; plain tensors too.
    with ft.sample_seed(9):
        image, mask = ft.RandomViewpoint(small_camera, preset="large")((given["image"], given["mask"]))
    assert isinstance(image, tv_tensors.Image) and isinstance(mask, tv_tensors.Mask)
    assert torch.equal(image, viewpoint_only["image"]) and torch.equal(mask, viewpoint_only["mask"])
    with ft.sample_seed(9):
        plain = ft.RandomViewpoint(small_camera, preset="large")(given["image"].as_subclass(torch.Tensor))
    assert type(plain) is torch.Tensor and torch.equal(plain, viewpoint_only["image"].as_subclass(torch.Tensor))
    # A batch of images sharing the camera: each under the same change.
    with ft.sample_seed(9):
        batch = ft.RandomViewpoint(small_camera, preset="large")(torch.stack([given["image"]] * 2))
    assert torch.equal(batch[0], batch[1]) and torch.equal(batch[0], plain)


def test_several_fishcam_transforms_in_one_sample_draw_different_changes(small_camera):
    image = torch.zeros(3, small_camera.height, small_camera.width, dtype=torch.uint8)
    pipeline = v2.Compose(
        [ft.RandomViewpoint(small_camera, preset="small"), ft.RandomViewpoint(small_camera), ft.RandomAffine()]
    )
    with ft.sample_seed(21) as records:
        pipeline(image)
    assert [r["seed"] for r in records] == [
        21,
        fishcam.derive_seed(21, "fishcam-transform", 1),
        fishcam.derive_seed(21, "fishcam-transform", 2),
    ]
    assert [r["method"] for r in records] == ["viewpoint", "viewpoint", "affine"]


def test_instance_masks_give_tight_boxes_and_unseen_boxes_collapse(small_camera):
    """boxes="from_masks", N instance masks paired with N boxes: each box becomes the tight box of its
    transformed mask (in the boxes' own format); an instance the change moves out of
    view collapses and v2.SanitizeBoundingBoxes drops it with its label and mask."""
    h, w = small_camera.height, small_camera.width
    instances = torch.zeros((2, h, w), dtype=torch.uint8)
    instances[0, 30:70, 40:90] = 1
    instances[1, 0:4, 0:4] = 1  # in the corner, outside the lens's image circle: nothing maps
    t = v2.Compose(
        [
            ft.RandomViewpoint(small_camera, preset="small", min_visibility=0.5, boxes="from_masks"),
            v2.SanitizeBoundingBoxes(labels_getter=lambda s: s["labels"]),
        ]
    )
    with ft.sample_seed(3):
        out = t(
            {
                "image": tv_tensors.Image(torch.zeros(3, h, w, dtype=torch.uint8)),
                "masks": tv_tensors.Mask(instances),
                "boxes": tv_tensors.BoundingBoxes([[40, 30, 50, 40], [0, 0, 4, 4]], format="XYWH", canvas_size=(h, w)),
                "labels": torch.tensor([1, 2]),
            }
        )
    assert out["boxes"].format == tv_tensors.BoundingBoxFormat.XYWH
    assert out["labels"].tolist() == [1] and len(out["masks"]) == 1
    ys, xs = torch.nonzero(out["masks"][0], as_tuple=True)
    x0, y0 = xs.min().item(), ys.min().item()
    assert out["boxes"][0].tolist() == [x0, y0, xs.max().item() + 1 - x0, ys.max().item() + 1 - y0]


def test_bad_samples_are_refused_in_one_line(small_camera):
    import PIL.Image

    t = ft.RandomViewpoint(small_camera)
    h, w = small_camera.height, small_camera.width
    cases = [
        ((PIL.Image.new("RGB", (w, h)),), "PIL images"),
        (({"image": np.zeros((h, w, 3), np.uint8)},), "numpy array"),
        ((torch.zeros(3, 10, 10, dtype=torch.uint8),), "is 10x10 but the camera is 160x121"),
        ((torch.zeros(3, h, w, dtype=torch.int64),), "dtype"),
        ((torch.zeros(3, h, w, dtype=torch.uint8, device="meta"),), "CPU"),
        (
            (
                {
                    "image": tv_tensors.Image(torch.zeros(3, h, w, dtype=torch.uint8)),
                    "depth": ft.DepthMap(torch.zeros(h, w, dtype=torch.float64)),
                },
            ),
            "float32",
        ),
        (
            ({"image": torch.zeros(3, h, w, dtype=torch.uint8), "a": small_camera, "b": small_camera.resized(80, 60)},),
            "several different cameras",
        ),
    ]
    for args, message in cases:
        with pytest.raises(fishcam.Error, match=message) as error:
            t(*args)
        assert "\n" not in str(error.value)
    with pytest.raises(fishcam.Error, match="camera: none given"):
        ft.RandomViewpoint()(torch.zeros(3, h, w, dtype=torch.uint8))
    if torch.cuda.is_available():  # pragma: no cover (no GPU here)
        with pytest.raises(fishcam.Error, match="CPU"):
            t(torch.zeros(3, h, w, dtype=torch.uint8, device="cuda"))
    assert "preset='train'" in repr(t) and "min_visibility=0.0" in repr(t)
    pickle.loads(pickle.dumps(t))


def test_no_hang_after_fork(tmp_path):
    """The parent has run fishcam (its thread pool is up); forked DataLoader workers
    still compute. Run in a subprocess so a hang fails the test instead of CI."""
    import subprocess
    import sys
    import textwrap

    script = textwrap.dedent(f"""
        import fishcam, fishcam.torch as ft, torch
        cam = fishcam.Camera.read({os.path.join(DATA, "woodscape_front.json")!r}).resized(320, 242)
        t = ft.RandomViewpoint(cam)
        img = torch.full((3, 242, 320), 9, dtype=torch.uint8)
        for s in range(3):
            with ft.sample_seed(s):
                t(img)
        class D(torch.utils.data.Dataset):
            def __len__(self): return 8
            def __getitem__(self, i): return t(img).float().max()
        for init in [None, ft.worker_init_fn]:
            loader = torch.utils.data.DataLoader(D(), batch_size=2, num_workers=2, worker_init_fn=init,
                                                 multiprocessing_context="fork")
            assert all(float(b.max()) == 9 for b in loader)
        print("ok")
    """)
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stderr


def test_masks_keep_their_dtype(small_camera):
    """int64 (the dataset's own and torch's default), int32, int16, uint16 and bool
    masks go through one change as the uint8 labels do and come back in their dtype;
    values a label image cannot hold are refused."""
    rng = np.random.default_rng(0)
    labels = rng.integers(0, 10, (121, 160)).astype(np.uint8)
    transform = fishcam.transforms.RandomViewpoint(small_camera, preset="medium")
    expected = transform(mask=labels, seed=3)["mask"]
    for dtype in [np.int64, np.int32, np.int16, np.uint16]:
        out = transform(mask=labels.astype(dtype), seed=3)["mask"]
        assert out.dtype == dtype and np.array_equal(out, expected.astype(dtype)), dtype
    flags = transform(mask=labels > 4, seed=3)["mask"]
    assert flags.dtype == np.bool_ and np.array_equal(flags, expected > 4)
    with ft.sample_seed(3):
        mask = ft.RandomViewpoint(small_camera, preset="medium")(
            (torch.zeros(3, 121, 160, dtype=torch.uint8), tv_tensors.Mask(torch.from_numpy(labels.astype(np.int64))))
        )[1]
    assert mask.dtype == torch.int64 and torch.equal(mask, torch.from_numpy(expected.astype(np.int64)))
    with pytest.raises(fishcam.Error, match="outside 0..65535"):
        transform(mask=np.full((121, 160), 70000, np.int64), seed=1)
    with pytest.raises(fishcam.Error, match="dtype float32"):
        transform(mask=np.zeros((121, 160), np.float32), seed=1)


def test_a_sample_with_two_images_is_refused(tmp_path, small_camera):
    """NAME.png beside NAME.jpg listed one sample twice (reading the .png both times): refused, naming both."""
    import cv2

    for sub in ["rgb_images", "semantic_annotations/gtLabels", "calibration"]:
        (tmp_path / sub).mkdir(parents=True)
    image = np.zeros((121, 160, 3), np.uint8)
    for name in ["a.png", "a.jpg", "b.png", "b.txt"]:
        cv2.imwrite(str(tmp_path / "rgb_images" / name), image) if not name.endswith(".txt") else (
            tmp_path / "rgb_images" / name
        ).write_text("notes")
    with pytest.raises(fishcam.Error, match=r"two images of sample 'a', 'a.jpg' and 'a.png'") as error:
        ft.WoodScapeDataset(tmp_path)
    assert "\n" not in str(error.value)
    (tmp_path / "rgb_images" / "a.jpg").unlink()
    for name in ["a", "b"]:
        cv2.imwrite(str(tmp_path / "semantic_annotations/gtLabels" / f"{name}.png"), image[..., 0])
        small_camera.write(str(tmp_path / "calibration" / f"{name}.json"), format="woodscape")
    ds = ft.WoodScapeDataset(tmp_path)
    assert ds.names == ["a", "b"] and ds[1]["name"] == "b", "b.txt is not b's image"
    for key in ["0", 1.5, (0, "x"), None]:
        with pytest.raises(fishcam.Error, match="expected an integer"):
            ds[key]
    with pytest.raises(IndexError):  # the sequence protocol's: iteration stops there
        ds[2]


def test_a_dataset_refuses_files_it_cannot_read_without_blocking(tmp_path, small_camera):
    """A calibration or image that is a FIFO, a device or missing is refused in one
    line before any read: a FIFO would block the DataLoader, /dev/zero fill the memory."""
    import cv2

    for sub in ["rgb_images", "semantic_annotations/gtLabels", "calibration"]:
        (tmp_path / sub).mkdir(parents=True)
    image = np.zeros((121, 160, 3), np.uint8)
    for name in ["a", "b", "c"]:
        cv2.imwrite(str(tmp_path / "rgb_images" / f"{name}.png"), image)
        cv2.imwrite(str(tmp_path / "semantic_annotations/gtLabels" / f"{name}.png"), image[..., 0])
    small_camera.write(str(tmp_path / "calibration" / "a.json"), format="woodscape")
    os.mkfifo(tmp_path / "calibration" / "b.json")
    (tmp_path / "calibration" / "c.json").symlink_to("/dev/zero")
    ds = ft.WoodScapeDataset(tmp_path)
    assert ds[0]["name"] == "a"
    with pytest.raises(fishcam.Error, match=r"b\.json: not a regular file \(expected a camera file\)"):
        ds[1]
    with pytest.raises(fishcam.Error, match=r"c\.json: not a regular file"):
        ds[2]
    (tmp_path / "calibration" / "c.json").unlink()
    with pytest.raises(fishcam.Error, match=r"c\.json: missing"):
        ds[2]
    (tmp_path / "rgb_images" / "c.png").unlink()
    os.mkfifo(tmp_path / "rgb_images" / "c.png")
    small_camera.write(str(tmp_path / "calibration" / "c.json"), format="woodscape")
    with pytest.raises(fishcam.Error, match=r"c\.png: not a regular file \(expected an image\)"):
        ds[2]


@pytest.mark.parametrize(
    "channels, dtype",
    [(3, torch.uint8), (2, torch.uint8), (4, torch.uint8), (2, torch.uint16), (4, torch.float32)],
)
def test_channels_first_images_keep_their_layout(small_camera, channels, dtype):
    """A contiguous CxHxW image (what v2.ToImage, Resize and ColorJitter give), or a
    crop of a larger one, is handed over plane by plane and comes back contiguous
    CxHxW, equal to the same image given channels-last; an HWC-backed one comes back
    as it did."""
    rng = np.random.default_rng(channels)
    hwc = rng.integers(0, 200, (121, 160, channels)).astype(torch.empty(0, dtype=dtype).numpy().dtype)
    transform = ft.RandomViewpoint(preset="medium")
    larger = torch.zeros((channels, 121 + 7, 160 + 9), dtype=dtype)
    cropped = larger[:, 3:124, 5:165]
    cropped.copy_(torch.from_numpy(hwc).permute(2, 0, 1))
    assert not cropped.is_contiguous()
    outputs = []
    for image in (torch.from_numpy(hwc).permute(2, 0, 1), torch.from_numpy(hwc).permute(2, 0, 1).contiguous(), cropped):
        with ft.sample_seed(4):
            outputs.append(transform(tv_tensors.Image(image), small_camera)[0])
    backed, planar, crop = outputs
    for out in (planar, crop):
        assert out.is_contiguous() and out.shape == (channels, 121, 160) and out.dtype == dtype
        assert torch.equal(backed, out)
    # The numpy transform given the same channels-first buffer as an HxWxC view.
    numpy_transform = fishcam.transforms.RandomViewpoint(small_camera, preset="medium")
    view = np.moveaxis(np.ascontiguousarray(np.moveaxis(hwc, -1, 0)), 0, -1)
    out = numpy_transform(view, seed=5)["image"]
    assert np.array_equal(out, numpy_transform(hwc, seed=5)["image"])
    assert out.strides[-1] == out.shape[0] * out.shape[1] * out.itemsize  # written plane by plane
    # A crop's planes are handed over as they lie too (a copy would be interleaved and
    # come back channels-last).
    crop_view = cropped.numpy().transpose(1, 2, 0)
    out = numpy_transform(crop_view, seed=5)["image"]
    assert np.array_equal(out, numpy_transform(hwc, seed=5)["image"])
    assert out.strides[-1] == out.shape[0] * out.shape[1] * out.itemsize

"""fishcam.torch inside DataLoaders: seeding across workers and epochs, reproducibility,
a seeded dataset independent of the number of workers, CPU-only errors."""

import json
import os
import pickle

import numpy as np
import pytest
import torch

import fishcam
import fishcam.torch as ft

DATA = os.environ.get("FISHCAM_DATA_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "data"))


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
        cv2.imwrite(str(root / "semantic_annotations/gtLabels" / f"{name}.png"),
                    rng.integers(0, 10, (121, 160), dtype=np.uint8))
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
        _, _, change = self.transform(image)
        return torch.tensor(change["rotation_deg"] + change["translation"], dtype=torch.float64)


def changes(loader, epochs=2):
    return [torch.cat(list(loader)) for _ in range(epochs)]


def test_changes_differ_across_workers_and_epochs_and_reproduce(small_camera):
    def loader(seed):
        return torch.utils.data.DataLoader(Images(small_camera), batch_size=2, num_workers=2,
                                           worker_init_fn=ft.worker_init_fn,
                                           generator=torch.Generator().manual_seed(seed))
    a = changes(loader(1))
    rows = torch.cat(a)
    assert len({tuple(r.tolist()) for r in rows}) == rows.shape[0], "a change repeated across workers or epochs"
    b = changes(loader(1))
    for x, y in zip(a, b):
        assert torch.equal(x, y)
    c = changes(loader(2))
    assert not torch.equal(a[0], c[0])


def epoch_seeds(loader, dataset, epochs):
    """Per epoch, {index: seed of its change} as the loader delivered them."""
    out = []
    for _ in range(epochs):
        seeds = {}
        for batch in loader:
            for name, change in zip(batch["name"], batch["change"]):
                index = dataset.names.index(name)
                assert index not in seeds, "an index delivered twice in one epoch"
                seeds[index] = json.loads(change)["seed"]
        out.append(seeds)
    return out


@pytest.mark.parametrize("workers,persistent", [(0, False), (1, False), (1, True), (2, False), (2, True)])
def test_every_epoch_reaches_every_worker(dataset_root, workers, persistent):
    """Sample i of epoch e gets derive_seed(S, "epoch{e}", i): persistent workers
    included, whatever the sampler's order (the silent repeat this replaced)."""
    ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="medium"), seed=11)
    sampler = ft.EpochSampler(torch.utils.data.RandomSampler(ds, generator=torch.Generator().manual_seed(3)))
    loader = torch.utils.data.DataLoader(ds, batch_size=4, num_workers=workers, persistent_workers=persistent,
                                         sampler=sampler, worker_init_fn=ft.worker_init_fn if workers else None)
    epochs = epoch_seeds(loader, ds, 3)
    assert len(epochs) == 3
    for e, seeds in enumerate(epochs):
        assert seeds == {i: fishcam.derive_seed(11, f"epoch{e}", i) for i in range(len(ds))}, e
    assert len({s for seeds in epochs for s in seeds.values()}) == 3 * len(ds), "a change repeated across epochs"
    sampler.set_epoch(7)  # resuming: the next pass is epoch 7
    assert epoch_seeds(loader, ds, 1)[0] == {i: fishcam.derive_seed(11, "epoch7", i) for i in range(len(ds))}


def test_distributed_ranks_share_the_epoch_seeds(dataset_root):
    """Two DistributedSampler ranks: together every index once per epoch, with the
    epoch's seed; the inner sampler is told the epoch (its shuffle changes)."""
    ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"), seed=4)
    ranks = [ft.EpochSampler(torch.utils.data.DistributedSampler(ds, num_replicas=2, rank=r, shuffle=True, seed=0))
             for r in range(2)]
    for e in range(2):
        seeds = {}
        for sampler in ranks:
            loader = torch.utils.data.DataLoader(ds, batch_size=2, num_workers=1, sampler=sampler)
            for batch in loader:
                for name, change in zip(batch["name"], batch["change"]):
                    seeds[ds.names.index(name)] = json.loads(change)["seed"]
        assert seeds == {i: fishcam.derive_seed(4, f"epoch{e}", i) for i in range(len(ds))}
    assert ranks[0].sampler.epoch == 1


def test_a_seeded_dataset_without_the_epoch_in_workers_is_refused(dataset_root):
    ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"), seed=4)
    loader = torch.utils.data.DataLoader(ds, batch_size=2, num_workers=1, persistent_workers=True)
    with pytest.raises(fishcam.Error, match="EpochSampler"):
        next(iter(loader))
    # In the main process a bare index uses set_epoch's epoch; unseeded datasets take bare indices anywhere.
    ds.set_epoch(2)
    assert json.loads(ds[1]["change"])["seed"] == fishcam.derive_seed(4, "epoch2", 1)
    assert json.loads(ds[(5, 1)]["change"])["seed"] == fishcam.derive_seed(4, "epoch5", 1)
    unseeded = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="small"))
    assert len(list(torch.utils.data.DataLoader(unseeded, batch_size=3, num_workers=1))) == 2
    with pytest.raises(IndexError):
        ds[(0, len(ds))]
    with pytest.raises(fishcam.Error, match="start_epoch"):
        ft.EpochSampler(range(3), start_epoch=-1)


def test_dataset_items(dataset_root, small_camera):
    ds = ft.WoodScapeDataset(dataset_root, transform=fishcam.transforms.RandomViewpoint(preset="small"), seed=3)
    item = ds[0]
    assert item["image"].shape == (3, 121, 160) and item["image"].dtype == torch.uint8
    assert item["mask"].shape == (121, 160) and item["mask"].dtype == torch.int64
    assert json.loads(item["change"])["seed"] == fishcam.derive_seed(3, "epoch0", 0)
    assert ds.camera(item["name"]) == fishcam.Camera.read(str(dataset_root / "calibration" / f"{item['name']}.json"))
    pickle.loads(pickle.dumps(ds))


def test_tensor_and_numpy_forms_agree(small_camera):
    module = ft.RandomViewpoint(small_camera, preset="large")
    rng = np.random.default_rng(1)
    hwc = rng.integers(0, 256, (121, 160, 3), dtype=np.uint8)
    mask = rng.integers(0, 10, (121, 160), dtype=np.uint8)
    a, am, _ = module(hwc, mask, seed=5)
    b, bm, _ = module(torch.from_numpy(hwc).permute(2, 0, 1), torch.from_numpy(mask), seed=5)
    assert isinstance(b, torch.Tensor) and b.shape == (3, 121, 160)
    np.testing.assert_array_equal(a, b.permute(1, 2, 0).numpy())
    np.testing.assert_array_equal(am, bm.numpy())
    pickle.loads(pickle.dumps(module))


def test_cuda_tensors_and_wrong_types_are_refused(small_camera):
    module = ft.RandomViewpoint(small_camera)
    with pytest.raises(fishcam.Error, match="expected a numpy array or a torch tensor"):
        module([[1, 2], [3, 4]])
    if torch.cuda.is_available():  # pragma: no cover (no GPU here)
        with pytest.raises(fishcam.Error, match="CPU"):
            module(torch.zeros(3, 121, 160, dtype=torch.uint8, device="cuda"))
    fake = torch.zeros(3, 121, 160, dtype=torch.uint8, device="meta")
    with pytest.raises(fishcam.Error, match="CPU"):
        module(fake)


def test_no_hang_after_fork(tmp_path):
    """The parent has run fishcam (its thread pool is up); forked DataLoader workers
    still compute. Run in a subprocess so a hang fails the test instead of CI."""
    import subprocess
    import sys
    import textwrap
    script = textwrap.dedent(f"""
        import fishcam, fishcam.torch as ft, torch
        cam = fishcam.Camera.read({os.path.join(DATA, 'woodscape_front.json')!r}).resized(320, 242)
        t = ft.RandomViewpoint(cam)
        img = torch.full((3, 242, 320), 9, dtype=torch.uint8)
        for s in range(3):
            t(img, seed=s)
        class D(torch.utils.data.Dataset):
            def __len__(self): return 8
            def __getitem__(self, i): return t(img)[0].float().max()
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
    _, mask, _ = ft.RandomViewpoint(small_camera, preset="medium")(
        torch.zeros(3, 121, 160, dtype=torch.uint8), torch.from_numpy(labels.astype(np.int64)), seed=3)
    assert mask.dtype == torch.int64 and torch.equal(mask, torch.from_numpy(expected.astype(np.int64)))
    with pytest.raises(fishcam.Error, match="outside 0..65535"):
        transform(mask=np.full((121, 160), 70000, np.int64), seed=1)
    with pytest.raises(fishcam.Error, match="dtype float32"):
        transform(mask=np.zeros((121, 160), np.float32), seed=1)

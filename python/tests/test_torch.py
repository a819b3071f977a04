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


def test_seeded_dataset_is_independent_of_the_workers(dataset_root):
    def run(workers):
        ds = ft.WoodScapeDataset(dataset_root, transform=ft.RandomViewpoint(preset="medium"), seed=11)
        out = []
        for epoch in range(2):
            ds.set_epoch(epoch)
            loader = torch.utils.data.DataLoader(ds, batch_size=3, num_workers=workers,
                                                 worker_init_fn=ft.worker_init_fn if workers else None)
            for batch in loader:
                out.append((batch["image"], batch["mask"], [json.loads(c)["seed"] for c in batch["change"]]))
        return out
    zero, two = run(0), run(2)
    assert len(zero) == len(two) == 4
    for (i0, m0, s0), (i2, m2, s2) in zip(zero, two):
        assert torch.equal(i0, i2) and torch.equal(m0, m2) and s0 == s2
    assert zero[0][2] != zero[2][2], "epochs must get new changes"


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

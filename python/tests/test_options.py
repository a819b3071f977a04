"""fishcam's option enums (fishcam/options.py): each is the library's own list of names,
and a member is accepted wherever its name is, with the same results (issue 38, item 4)."""

import json
import os

import fishcam
import fishcam.torch as ft
import numpy as np
import pytest
from conftest import DATA
from fishcam import _fishcam


@pytest.mark.parametrize(
    "enum, names",
    [
        (fishcam.DepthSource, _fishcam.depth_priors_and_map()),
        (fishcam.Sampling, _fishcam.sampling_names()),
        (fishcam.DepthValues, _fishcam.depth_values_names()),
        (fishcam.Preset, list(_fishcam.presets())),
        (fishcam.Preset, list(_fishcam.affine_presets())),
        (fishcam.BoxMode, list(ft.transforms.BOX_MODES)),
    ],
)
def test_every_enum_is_the_librarys_list(enum, names):
    assert [m.value for m in enum] == list(names)
    assert all(str(m) == m.value and f"{m}" == m.value for m in enum)


def test_members_stand_for_their_names(tmp_path):
    cam = fishcam.Camera.read(os.path.join(DATA, "woodscape_front.json")).resized(160, 121)
    image = np.random.default_rng(1).integers(0, 256, (cam.height, cam.width, 3), dtype=np.uint8)
    by_name = fishcam.transforms.RandomViewpoint(cam, preset="small", depth="target-sphere", sampling="exact")
    by_enum = fishcam.transforms.RandomViewpoint(
        cam, preset=fishcam.Preset.SMALL, depth=fishcam.DepthSource.TARGET_SPHERE, sampling=fishcam.Sampling.EXACT
    )
    a, b = by_name(image=image, seed=3), by_enum(image=image, seed=3)
    np.testing.assert_array_equal(a["image"], b["image"])
    # Stored and recorded as the plain names: the records stay JSON of strings.
    assert type(by_enum.depth) is str and type(by_enum.preset) is str and type(by_enum.sampling) is str
    assert json.dumps(b["change"]) == json.dumps(a["change"])
    # The extension takes them too.
    warp = fishcam.ViewpointWarp(cam)
    change = fishcam.random_change("small", 3)
    np.testing.assert_array_equal(
        warp.warp(image=image, change=change, depth=fishcam.DepthSource.INFINITY, sampling=fishcam.Sampling.GRID)[
            "image"
        ],
        warp.warp(image=image, change=change, depth="infinity", sampling="grid")["image"],
    )
    assert ft.RandomViewpoint(cam, boxes=fishcam.BoxMode.FROM_MASKS).boxes == "from_masks"
    with pytest.raises(fishcam.Error, match="depth: expected source-sphere, target-sphere, infinity, map"):
        fishcam.transforms.RandomViewpoint(cam, depth=fishcam.Sampling.GRID)

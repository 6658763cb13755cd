"""Frames a little smaller than the calibrated image: a right/bottom crop with a warning (up to
1 %), a 'crop' entry for other edges, and an error naming both sizes otherwise."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from ipf_jax.data.calibration import write_json
from ipf_jax.data.dataset import open_dataset
from ipf_jax.errors import IPFError, IPFWarning
from ipf_jax.geometry.camera import Camera

K = np.array([[500.0, 0, 322.0], [0, 500.0, 241.0], [0, 0, 1]])


def _data(tmp_path, w, h, crop=None):
    cam = Camera(K=K, dist=np.zeros(5), R=np.eye(3), T=np.array([0, 0, 3.0]), width=640,
                 height=480, name="c1")
    write_json([cam], tmp_path / "cameras.json")
    (tmp_path / "FG1").mkdir(exist_ok=True)
    m = np.zeros((h, w), np.uint8)
    m[100:200, 100:150] = 255
    cv2.imwrite(str(tmp_path / "FG1" / "image0000.png"), m)
    entry = {"name": "c1", "masks": "FG1"} | ({"crop": crop} if crop is not None else {})
    (tmp_path / "dataset.json").write_text(json.dumps(
        {"calibration": "cameras.json", "fps": 20, "up_axis": "-y", "cameras": [entry]}))
    return tmp_path


def test_frames_up_to_one_percent_smaller_are_a_right_bottom_crop(tmp_path):
    with pytest.warns(IPFWarning, match=r"636x478 .* calibrated at 640x480.*4 px at the right and "
                                        r"2 px at the bottom cut off"):
        ds = open_dataset(_data(tmp_path, 636, 478))
    cam = ds.cameras[0]
    assert (cam.width, cam.height) == (636, 478)
    np.testing.assert_array_equal(cam.K, K)  # principal point unchanged
    assert ds.masks(0)[0].shape == (478, 636)


@pytest.mark.parametrize("crop, shift", [(["left"], (4, 0)), (["left", "right"], (2, 0)),
                                         ({"left": 1, "top": 2}, (1, 2)), (["top"], (0, 2))])
def test_a_crop_entry_names_the_edges(tmp_path, crop, shift, recwarn):
    ds = open_dataset(_data(tmp_path, 636, 478, crop))
    np.testing.assert_allclose(ds.cameras[0].K[:2, 2], K[:2, 2] - shift)
    assert not [w for w in recwarn if issubclass(w.category, IPFWarning)]


@pytest.mark.parametrize("size, crop, problem", [
    ((600, 480), None, r"more than 1% smaller: give a 'crop' entry"),
    ((700, 480), None, "frames larger than the calibrated image"),
    ((636, 478), ["middle"], "crop must list edges"),
    ((636, 478), {"left": 9}, r"crop left must be a whole number of pixels in 0\.\.4"),
])
def test_other_sizes_are_one_clear_error(tmp_path, size, crop, problem):
    with pytest.raises(IPFError, match=problem):
        open_dataset(_data(tmp_path, *size, crop))

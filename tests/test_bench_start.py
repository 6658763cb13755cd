"""``ipf-jax bench``'s start records: a default run's one-off stages apart from its tracked frames."""
from __future__ import annotations

import pytest

from ipf_jax.profiling import bench_start


def test_a_start_record_splits_the_run_into_its_one_off_stages_and_tracked_frames(shared_data):
    rec = bench_start(shared_data("mocap_walk_render/rajagopal_walk_clean_1cam"), 3)
    assert rec["task"] == "start" and rec["frames"] == 3 and rec["cameras"] == 1
    init, fit, rec_ = rec["initialisation"], rec["shape_fit"], rec["recovery"]
    assert init["evaluations"] > 0 and init["seconds"] > 0
    assert fit["evaluations"] > 0 and fit["seconds"] > 0  # the default fits the shape
    assert rec_["evaluations"] == 0 or rec_["seconds"] > 0
    tracked = rec["tracked_frames"]
    assert tracked["count"] == 2 and tracked["evaluations_per_frame"] == 6561
    assert rec["seconds_total"] >= init["seconds"] + fit["seconds"] + tracked["count"] * tracked["seconds_mean"] * 0.99
    assert rec["seconds_total"] == pytest.approx(
        init["seconds"] + fit["seconds"] + tracked["count"] * tracked["seconds_mean"], rel=0.2)

"""Small pieces of the gait pipeline checked against closed-form answers."""
from __future__ import annotations

import numpy as np
import pytest

from ipf_jax.analysis.gait.angles import joint_angles, sagittal_angle
from ipf_jax.analysis.gait.events import detect, refine_peak
from ipf_jax.analysis.gait.filtering import effective_cutoff, fill_short_gaps, lowpass
from ipf_jax.analysis.gait.parameters import Step, summarise


def test_refine_peak_finds_the_vertex_of_a_sampled_parabola():
    x = np.arange(10.0)
    y = -(x - 4.3) ** 2
    assert refine_peak(y, 4) == pytest.approx(4.3)
    assert refine_peak(np.array([0.0, 1.0, 1.0, 0.0]), 1) == pytest.approx(1.5)


def test_lowpass_is_zero_phase_and_removes_jitter():
    fps = 100.0
    t = np.arange(400) / fps
    slow = np.sin(2 * np.pi * 1.0 * t)
    noisy = slow + 0.3 * np.sin(2 * np.pi * 20.0 * t)
    out = lowpass(noisy[:, None], fps, 5.0)[:, 0]
    inner = slice(50, 350)
    assert np.max(np.abs(out[inner] - slow[inner])) < 0.03
    i = 125  # a peak of the 1 Hz sine (t = 1.25 s): no lag
    assert np.argmax(out[100:150]) + 100 == i


def test_cutoff_is_lowered_at_low_frame_rates():
    assert effective_cutoff(6.0, 100.0) == 6.0
    assert effective_cutoff(6.0, 20.0) == 5.0
    assert effective_cutoff(6.0, 12.0) == 3.0


def test_fill_short_gaps_only():
    x = np.arange(20.0)[:, None].repeat(3, axis=1)
    x[3:5] = np.nan     # 2 frames: filled
    x[10:16] = np.nan   # 6 frames: kept
    out, n = fill_short_gaps(x, max_gap=3)
    assert n == 2 and out[3, 0] == pytest.approx(3.0) and np.isnan(out[12]).all()


def test_zeni_events_on_a_clean_oscillation():
    # heel - sacrum = 0.3 sin(2 pi t / T): maxima at T/4 + kT
    fps, period = 50.0, 1.1
    t = np.arange(300) / fps
    sacrum = 1.2 * t
    heel = sacrum + 0.3 * np.sin(2 * np.pi * t / period)
    toe = sacrum + 0.3 * np.sin(2 * np.pi * (t - 0.3) / period)
    ev = detect(t, sacrum, heel, toe, method="zeni")
    expected_hs = period / 4 + period * np.arange(6)
    np.testing.assert_allclose(ev.heel_strike, expected_hs[expected_hs < t[-1]], atol=2e-3)
    expected_to = 0.3 + 3 * period / 4 + period * np.arange(-1, 5)
    expected_to = expected_to[(expected_to > 0) & (expected_to < t[-1])]
    np.testing.assert_allclose(ev.toe_off, expected_to, atol=2e-3)


def test_sagittal_angles_of_known_postures():
    # walking frame: (forward, left, up)
    assert sagittal_angle(np.array([0.0, 0, -1])) == pytest.approx(0.0)
    assert sagittal_angle(np.array([1.0, 0, 0])) == pytest.approx(90.0)
    thigh = np.array([np.sin(np.radians(30)), 0, -np.cos(np.radians(30))]) * 0.4
    toes_up = np.array([np.cos(np.radians(10)), 0, np.sin(np.radians(10))]) * 0.2
    pts = {"sacrum": np.array([[0.0, 0, 1.0]]), "neck": np.array([[0.0, 0, 1.5]]),
           "left_hip": np.array([[0.0, 0.1, 0.9]])}
    pts["left_knee"] = pts["left_hip"] + thigh
    pts["left_ankle"] = pts["left_knee"] + np.array([0.0, 0, -0.4])
    pts["left_heel"] = pts["left_ankle"] + np.array([-0.05, 0, -0.05])
    pts["left_toe"] = pts["left_heel"] + toes_up
    ang, missing = joint_angles(pts, "left", has_heel=True)
    assert ang["hip"][0] == pytest.approx(30.0)
    assert ang["knee"][0] == pytest.approx(30.0)
    assert ang["ankle"][0] == pytest.approx(10.0)
    assert missing == {}
    ang, missing = joint_angles(pts, "left", has_heel=False)
    assert "ankle" not in ang and "no left heel point" in missing["ankle"]


def test_symmetry_index_sign_and_stats():
    steps = [Step(0, "left", 0, 0.5, 0.5, 0.60, 0.1, 0.2, 0.1, 0.4),
             Step(0, "right", 0.5, 1.0, 0.5, 0.70, 0.1, 0.7, 0.1, 0.4),
             Step(0, "left", 1.0, 1.5, 0.5, 0.62, 0.1, 1.2, 0.1, 0.4)]
    params, sym = summarise(steps, [])
    left = params["step_length_m"]["left"]
    assert left == {"mean": 0.61, "sd": pytest.approx(0.014142, abs=1e-6),
                    "cv_pct": pytest.approx(100 * 0.014142 / 0.61, abs=1e-3), "n": 2}
    assert params["step_length_m"]["right"]["sd"] is None
    assert sym["step_length_m"] == pytest.approx(100 * (0.70 - 0.61) / 0.655, abs=1e-4)
    assert params["cadence_steps_per_min"]["all"]["mean"] == pytest.approx(120.0)  # per step
    assert params["stride_time_s"]["all"]["n"] == 0

"""Self-rendered test scenes: a procedural walk, virtual cameras, and masks drawn with our own model.

Everything here renders with the tracker's own capsule model, so accuracy measured on it is a
*self-rendered check* (it shows the machinery works, not that the model fits real people). Real
accuracy claims use ``mocap_walk_render`` (an independent, non-capsule renderer).
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..body.model import DOF_INDEX, NUM_DOF
from ..body.shape import BodyShape
from ..data.calibration import write_json
from ..data.runfiles import JOINT_COLUMNS
from ..geometry.camera import Camera
from ..geometry.host import forward_kinematics, project_capsules
from ..geometry.posing import POSTURES_DEG, place_on_floor, posture_pose
from ..geometry.world import up_rotation
from ..likelihood.model_mask import model_mask


def look_at_camera(centre, target, *, width: int, height: int, focal_px: float,
                   name: str = "camera", up=(0.0, 0.0, 1.0)) -> Camera:
    """A distortion-free camera at ``centre`` (m) looking at ``target`` with world ``up`` on top."""
    centre, target, up = (np.asarray(v, float) for v in (centre, target, up))
    z = target - centre
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-9:  # looking straight down: any image x
        x = np.cross(z, [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)  # image down
    R = np.stack([x, y, z])
    K = np.array([[focal_px, 0, (width - 1) / 2], [0, focal_px, (height - 1) / 2], [0, 0, 1]])
    return Camera(K=K, dist=np.zeros(5), R=R, T=-R @ centre, width=width, height=height, name=name)


def ring_cameras(n: int = 3, *, radius: float = 5.0, height_m: float = 2.2, width: int = 320,
                 height: int = 240, focal_px: float = 300.0, target=(0.6, 0.0, 0.9),
                 first_angle_deg: float = -90.0) -> list[Camera]:
    """``n`` cameras on a circle around ``target`` (world +z up), looking slightly down."""
    target = np.asarray(target, float)
    cams = []
    for k in range(n):
        a = np.deg2rad(first_angle_deg + 360.0 * k / n)
        centre = target + np.array([radius * np.cos(a), radius * np.sin(a), 0.0])
        centre[2] = height_m
        cams.append(look_at_camera(centre, target, width=width, height=height, focal_px=focal_px,
                                   name=f"Camera{k + 1}"))
    return cams


def procedural_walk(n_frames: int, fps: float = 20.0, *, speed: float = 1.2,
                    cadence_spm: float = 110.0, heading_deg: float = 0.0, start=(0.0, 0.0),
                    shape: BodyShape, up_axis: str = "+z") -> np.ndarray:
    """(T, D) DOF trajectories of a straight walk with textbook joint-angle patterns.

    Sagittal patterns follow the shapes of normal gait (hip +30/-10 deg, knee with a small stance
    peak and a 60 deg swing peak, ankle plantarflexion at push-off, arms swinging against the
    legs); the root height is set so the lowest foot point touches the floor.
    """
    t = np.arange(n_frames) / fps
    stride_hz = cadence_spm / 120.0
    deg = np.deg2rad
    q = np.zeros((n_frames, NUM_DOF))
    for side, offset in (("left", 0.5), ("right", 0.0)):
        ph = (t * stride_hz + offset) % 1.0  # 0 = heel strike of that side
        hip = 10 + 20 * np.cos(2 * np.pi * ph) + 3 * np.sin(4 * np.pi * ph)
        knee = 8 + 7 * np.exp(-((ph - 0.15) / 0.07) ** 2) + 55 * np.exp(-((ph - 0.72) / 0.12) ** 2)
        ankle = 3 - 18 * np.exp(-((ph - 0.62) / 0.07) ** 2) + 6 * np.exp(-((ph - 0.4) / 0.12) ** 2)
        q[:, DOF_INDEX[f"{side}_hip_flexion"]] = deg(hip)
        q[:, DOF_INDEX[f"{side}_knee_flexion"]] = deg(np.maximum(knee, 0.0))
        q[:, DOF_INDEX[f"{side}_ankle_dorsiflexion"]] = deg(ankle)
        q[:, DOF_INDEX[f"{side}_hip_abduction"]] = deg(2.0)
        arm = -20 * np.cos(2 * np.pi * ph)  # opposite to the same-side leg
        q[:, DOF_INDEX[f"{side}_shoulder_flexion"]] = deg(arm)
        q[:, DOF_INDEX[f"{side}_shoulder_abduction"]] = deg(8.0)
        q[:, DOF_INDEX[f"{side}_elbow_flexion"]] = deg(20 + 10 * np.sin(2 * np.pi * ph))
    q[:, DOF_INDEX["trunk_flexion"]] = deg(4.0)
    q[:, DOF_INDEX["root_yaw"]] = deg(heading_deg) + deg(4.0) * np.sin(2 * np.pi * stride_hz * t)
    heading = deg(heading_deg)
    U = up_rotation(up_axis)
    forward_world = U @ np.array([np.cos(heading), np.sin(heading), 0.0])
    side_world = U @ np.array([-np.sin(heading), np.cos(heading), 0.0])
    start_world = U @ np.array([start[0], start[1], 0.0])
    for i in range(n_frames):
        q[i, :3] = start_world + forward_world * speed * t[i] + side_world * 0.01 * np.sin(
            np.pi * stride_hz * 2 * t[i])
        q[i] = place_on_floor(q[i], shape.values, U)
    return q


def walk_turn_crouch(*, shape: BodyShape, fps: float = 20.0, walk_frames: int = 16,
                     turn_frames: int = 10, crouch_frames: int = 16, turn_deg: float = 120.0,
                     up_axis: str = "+z") -> np.ndarray:
    """(T, D) a self-rendered start-walk-turn-crouch-walk sequence: a straight walk along +x, a
    turn on the spot by ``turn_deg``, a deep crouch (down and up again, :data:`POSTURES_DEG`
    ``crouch``), and a walk on in the new heading. T = 2 walk_frames + turn_frames + crouch_frames.
    """
    U = up_rotation(up_axis)
    first = procedural_walk(walk_frames, fps, shape=shape, up_axis=up_axis)
    here = first[-1].copy()
    turn = np.repeat(here[None], turn_frames, axis=0)
    turn[:, 3] = here[3] + np.deg2rad(turn_deg) * (np.arange(1, turn_frames + 1) / turn_frames)
    heading = float(turn[-1, 3])
    crouch = posture_pose(*POSTURES_DEG["crouch"], heading=heading)
    stand = turn[-1].copy()
    depth = np.sin(np.pi * np.arange(1, crouch_frames + 1) / (crouch_frames + 1))  # down, up
    down = np.array([np.r_[stand[:6], stand[6:] + d * (crouch[6:] - stand[6:])] for d in depth])  # (F, D)
    start = (U.T @ stand[:3])[:2]
    last = procedural_walk(walk_frames, fps, heading_deg=float(np.rad2deg(heading)), start=start,
                           shape=shape, up_axis=up_axis)
    q = np.concatenate([first, turn, down, last])
    for i in range(walk_frames, len(q) - walk_frames):
        q[i] = place_on_floor(q[i], shape.values, U)
    return q


def joints_of(q: np.ndarray, shape: BodyShape, up_axis: str = "+z") -> np.ndarray:
    """(T, D) DOF -> (T, J, 3) key points (world metres)."""
    U = up_rotation(up_axis)
    return np.stack([forward_kinematics(qi, shape.values, U).points for qi in q])


def render_masks(q: np.ndarray, shape: BodyShape, cameras: list[Camera],
                 up_axis: str = "+z") -> np.ndarray:
    """(T, D) poses -> (T, C, H, W) bool masks drawn with the model (NumPy reference raster)."""
    U = up_rotation(up_axis)
    h = max(c.height for c in cameras)
    w = max(c.width for c in cameras)
    out = np.zeros((len(q), len(cameras), h, w), bool)
    for i, qi in enumerate(q):
        caps = project_capsules(qi, shape.values, U, cameras)
        for c, cam in enumerate(cameras):
            out[i, c, : cam.height, : cam.width] = model_mask(caps[c], cam.height, cam.width)
    return out


def add_mask_noise(masks: np.ndarray, rng: np.random.Generator, *, flip_fraction: float = 0.002,
                   blobs: int = 3) -> np.ndarray:
    """Salt-and-pepper pixels and a few background blobs (clutter), deterministic given ``rng``."""
    out = masks.copy()
    flips = rng.random(out.shape) < flip_fraction
    out ^= flips
    *lead, h, w = out.shape
    for idx in np.ndindex(*lead):
        for _ in range(blobs):
            r = int(rng.integers(2, 6))
            cy, cx = int(rng.integers(r, h - r)), int(rng.integers(r, w - r))
            yy, xx = np.ogrid[-r:r + 1, -r:r + 1]
            out[idx][cy - r:cy + r + 1, cx - r:cx + r + 1] |= (yy * yy + xx * xx) <= r * r
    return out


def write_dataset(root: Path, cameras, masks: np.ndarray) -> Path:
    """Write masks (T, C, H, W) and cameras in the bodytrack layout (CALIB/cameras.json, FGk/*.png)."""
    (root / "CALIB").mkdir(parents=True, exist_ok=True)
    write_json(cameras, root / "CALIB" / "cameras.json")
    for c in range(masks.shape[1]):
        folder = root / f"FG{c + 1}"
        folder.mkdir(exist_ok=True)
        for t in range(masks.shape[0]):
            cv2.imwrite(str(folder / f"image{t:04d}.png"), masks[t, c].astype(np.uint8) * 255)
    return root


def write_truth(path: Path, joints: np.ndarray, fps: float = 20.0) -> None:
    """Joints (T, J, 3) as a ground-truth CSV in the joints.csv convention (frame t at t / fps)."""
    rows = [",".join(JOINT_COLUMNS)]
    for t, pts in enumerate(joints):
        rows.append(f"{t},{t / fps:.6f}," + ",".join(f"{v:.6f}" for v in pts.ravel()))
    path.write_text("\n".join(rows) + "\n")

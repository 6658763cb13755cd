"""Pose transfer between bodies: the limb angles that keep the limbs' joints where they were.

When a shape fit tries another body on a frame's pose, keeping the joint angles moves every joint
below a changed segment: a thigh 7 cm shorter under a hip 7 cm lower (the feet stay on the floor)
moves the knee of a leg swung 25 deg by about 3 cm along the walk, and the foot with it. The
candidate is then scored with a pose that no longer fits its frame, so a body far from the current
one scores worse than it would with its own poses, and the fit stays near where it started.
:func:`retarget` instead moves the limb angles (hips, knees, ankles, shoulders, elbows) by a few
Gauss-Newton steps so that the knees, ankles, heels, toes, elbows and wrists of the new body come
nearest their places on the old one. The root and trunk stay: the caller places the body on the
floor before and after. What it changed in the fit is measured in docs/shape_fit.md.
"""
from __future__ import annotations

import numpy as np

from ..body.model import DOF_NAMES, FRAMES, POINT_INDEX, POINTS
from .kinematics import FRAMES_BY_NAME, frame_axes, place

#: The limb angles moved (every DOF of the legs and arms).
LIMB_DOFS = np.array([i for i, n in enumerate(DOF_NAMES) if n.startswith(("left_", "right_"))])
#: The joints kept in place (each one below a limb angle).
KEPT_POINTS = np.array([POINT_INDEX[f"{side}_{p}"] for side in ("left", "right")
                        for p in ("knee", "ankle", "heel", "toe", "elbow", "wrist")])


def _moved_by(dof: str) -> np.ndarray:
    """Positions in :data:`KEPT_POINTS` of the kept joints below ``dof`` (its frame or one under
    it): the only ones a change of ``dof`` moves."""
    frame = next(f.name for f in FRAMES if any(d == dof for _, _, d in f.rotation))

    def below(name):
        while name is not None and name != frame:
            name = FRAMES_BY_NAME[name].parent
        return name == frame

    return np.array([t for t, i in enumerate(KEPT_POINTS) if below(POINTS[i].frame)])


#: The limb DOFs (positions in :data:`LIMB_DOFS`) grouped by the kept joints they move (positions
#: in :data:`KEPT_POINTS`): a hip's three angles move its knee, ankle, heel and toe, the knee's
#: angle its ankle, heel and toe, an elbow's its wrist.
def _chains() -> list[tuple[np.ndarray, np.ndarray]]:
    groups: dict[tuple, list[int]] = {}
    for j, d in enumerate(LIMB_DOFS):
        groups.setdefault(tuple(_moved_by(DOF_NAMES[d])), []).append(j)
    return [(np.array(dofs), np.array(pts)) for pts, dofs in groups.items()]


_CHAINS = _chains()


def limb_points(q: np.ndarray, values: np.ndarray, U: np.ndarray, which=None) -> np.ndarray:
    """(..., D) poses, (..., P) bodies -> (..., T, 3) world positions of :data:`KEPT_POINTS`
    (``which``: only those positions of it).

    Only the frames above the kept points are turned and only those points placed
    (:func:`~ipf_jax.geometry.kinematics.frame_axes`, particle axis last), with the arithmetic of
    :func:`~ipf_jax.geometry.kinematics.forward_kinematics` number for number: the same float64
    results, a retarget in less than half the time (the Jacobian places 21 bodies per pose;
    docs/benchmarks.md)."""
    q = np.asarray(q, np.float64)
    lead = q.shape[:-1]
    values = np.broadcast_to(np.asarray(values, np.float64), lead + np.shape(values)[-1:])
    q_t = q.reshape(-1, q.shape[-1]).T  # (D, B)
    v_t = values.reshape(-1, values.shape[-1]).T  # (P, B)
    kept = KEPT_POINTS if which is None else KEPT_POINTS[which]
    world = frame_axes(q_t, v_t, np.asarray(U, np.float64), sorted({POINTS[i].frame for i in kept}))
    xyz = [place(world, POINTS[i].frame, POINTS[i].position, v_t) for i in kept]
    out = np.stack([np.stack(np.broadcast_arrays(*p), -1) for p in xyz], -2)  # (B, T, 3)
    return out.reshape(lead + out.shape[-2:])


#: Positions in :data:`KEPT_POINTS` of the feet's joints (both ankles, heels and toes): what
#: :mod:`ipf_jax.filters.posture` holds in place while it moves the pelvis.
FEET = np.array([t for t, i in enumerate(KEPT_POINTS)
                 if POINTS[i].name.endswith(("_ankle", "_heel", "_toe"))])


def _chains_for(which: np.ndarray) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """The limb DOFs (positions in :data:`LIMB_DOFS`) that move any of the kept joints ``which``
    (positions in :data:`KEPT_POINTS`), and per chain its DOFs' columns among them and the
    positions in ``which`` of the joints it moves."""
    local = {int(p): j for j, p in enumerate(which)}
    chains = [(dofs, np.array([local[int(p)] for p in pts if int(p) in local]))
              for dofs, pts in _CHAINS]
    chains = [(dofs, pts) for dofs, pts in chains if len(pts)]
    moved = np.sort(np.concatenate([dofs for dofs, _ in chains]))
    return moved, [(np.searchsorted(moved, dofs), pts) for dofs, pts in chains]


def _copies(chains) -> list[list[tuple[int, np.ndarray]]]:
    """The forward differences of a Jacobian grouped into perturbed copies of a pose: chains whose
    joints overlap are one limb (a hip's, its knee's and its ankle's), and no limb's angles move
    another limb's joints, so each copy moves one DOF of every limb at once. Copy c is a list of
    (DOF column, the joints it moves) pairs; a leg's six DOFs make six copies for all four limbs."""
    limbs: list[list[tuple[np.ndarray, np.ndarray]]] = []
    for dofs, pts in chains:
        limb = next((lb for lb in limbs if any(np.intersect1d(pts, p).size for _, p in lb)), None)
        if limb is None:
            limbs.append(limb := [])
        limb.append((dofs, pts))
    moves = [[(int(d), pts) for dofs, pts in limb for d in dofs] for limb in limbs]
    return [[m[c] for m in moves if c < len(m)] for c in range(max(map(len, moves)))]


_COPIES = _copies(_CHAINS)


def _jacobian(q: np.ndarray, values: np.ndarray, U: np.ndarray, copies, columns: np.ndarray,
              kept: np.ndarray | None, p0: np.ndarray, step: float) -> np.ndarray:
    """(N, k, 3T) forward-difference Jacobian (transposed) of the kept joints ``p0`` (N, T, 3)
    over the limb angles ``columns``. A DOF moves only its limb's joints: the other entries are
    exactly zero (as the differences of unchanged joints were), and one perturbed copy of a pose
    serves a DOF of every limb (:func:`_copies`): one placement of all the joints for the whole
    Jacobian, each joint's difference the one its own DOF alone would give, number for number."""
    n, k, t = q.shape[0], len(columns), p0.shape[1]
    qq = np.repeat(q[:, None], len(copies), 1)
    for c, moves in enumerate(copies):
        qq[:, c, columns[[d for d, _ in moves]]] += step
    pp = limb_points(qq, values[:, None], U, which=kept)  # (N, C, T, 3)
    J = np.zeros((n, k, t, 3))  # J transposed: (N, k, 3T) once reshaped
    for c, moves in enumerate(copies):
        for d, pts in moves:
            J[:, d, pts] = (pp[:, c, pts] - p0[:, pts]) / step
    return J.reshape(n, k, -1)


def _problem(which: np.ndarray | None):
    """(columns of q moved, their Jacobian's copies, kept positions or None) for :func:`retarget`."""
    if which is None:
        return LIMB_DOFS, _COPIES, None
    which = np.asarray(which)
    dof_pos, chains = _chains_for(which)
    return LIMB_DOFS[dof_pos], _copies(chains), which


def retarget(q: np.ndarray, values: np.ndarray, targets: np.ndarray, U: np.ndarray, clip, *,
             iterations: int = 3, step: float = 1e-3, damping: float = 1e-4,
             which: np.ndarray | None = None) -> np.ndarray:
    """Limb angles of (N, D) poses ``q`` with (N, P) bodies ``values`` moved so that the kept
    joints come nearest ``targets`` (N, T, 3) (least squares, Gauss-Newton with a forward-difference
    Jacobian of ``step`` rad and Levenberg's ``damping``); ``clip`` keeps each pose inside the
    DOF ranges after every step. ``which`` (positions in :data:`KEPT_POINTS`, e.g. :data:`FEET`)
    keeps only those joints (``targets`` (N, len(which), 3)) and moves only the limb angles above
    them. Returns (N, D)."""
    q = np.array(q, np.float64)
    values = np.asarray(values, np.float64)
    columns, copies, kept = _problem(which)
    n, k = q.shape[0], len(columns)
    for _ in range(iterations):
        p0 = limb_points(q, values, U, which=kept)  # (N, T, 3)
        residual = (p0 - targets).reshape(n, -1, 1)
        J = _jacobian(q, values, U, copies, columns, kept, p0, step)
        delta = np.linalg.solve(J @ J.transpose(0, 2, 1) + damping * np.eye(k), -(J @ residual))
        q[:, columns] += delta[..., 0]
        q = clip(q)
    return q


def hold(q: np.ndarray, values: np.ndarray, targets: np.ndarray, U: np.ndarray, clip, *,
         which: np.ndarray, iterations: int = 4, step: float = 1e-3,
         damping: float = 1e-3) -> np.ndarray:
    """:func:`retarget` for targets that may be out of reach (a straight leg under a lifted
    pelvis): Levenberg-Marquardt, each pose's step kept only where it brings the joints nearer
    (then its damping falls 10x), else the pose stays and its damping grows 10x; the damping
    scales the normal matrix's diagonal (Marquardt). Gauss-Newton there overshoots and can swing
    a leg far away; this never ends further from the targets than it started. Returns (N, D)."""
    q = np.array(q, np.float64)
    values = np.asarray(values, np.float64)
    columns, copies, kept = _problem(which)
    n = q.shape[0]
    p0 = limb_points(q, values, U, which=kept)
    cost = ((p0 - targets) ** 2).sum((1, 2))
    lam = np.full(n, float(damping))
    values = np.broadcast_to(values, (n, values.shape[-1]))
    J = _jacobian(q, values, U, copies, columns, kept, p0, step)
    for it in range(iterations):
        A = J @ J.transpose(0, 2, 1)
        diag = np.einsum("nii->ni", A)
        A[:, np.arange(len(columns)), np.arange(len(columns))] += lam[:, None] * np.maximum(diag, 1e-12)
        delta = np.linalg.solve(A, -(J @ (p0 - targets).reshape(n, -1, 1)))[..., 0]
        trial = q.copy()
        trial[:, columns] += delta
        trial = clip(trial)
        p1 = limb_points(trial, values, U, which=kept)
        c1 = ((p1 - targets) ** 2).sum((1, 2))
        better = c1 < cost
        q[better], p0[better], cost[better] = trial[better], p1[better], c1[better]
        lam = np.where(better, lam * 0.1, lam * 10.0)
        if it + 1 < iterations and better.any():  # a refused step's pose and Jacobian stand
            J[better] = _jacobian(q[better], values[better], U, copies, columns, kept, p0[better], step)
    return q


__all__ = ["FEET", "KEPT_POINTS", "LIMB_DOFS", "hold", "limb_points", "retarget"]

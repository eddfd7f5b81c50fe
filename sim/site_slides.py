"""The tool site as a closed-form function of qpos when only slide joints carry it.

site(qpos) = site(qpos0) + (qpos - qpos0) @ matrix [m], each row of matrix the world axis [m/m]
that qpos[i] moves the site along: exact for slides, and checked against ``mj_kinematics`` on
the model (:func:`site_slides` returns None where it does not hold). MuJoCo SI units throughout.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: the closed-form tool site (slides only) must match mj_kinematics to this [m]
SITE_MAP_TOL_M = 1e-12


def site_slides(model: Any, site: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The tool site as site(qpos0) + sum of axis * (q - q0) over the slides carrying it, or
    None when a joint between the site and the world rotates (or the map misses MuJoCo)."""
    import mujoco

    joints: list[int] = []
    body = int(model.site_bodyid[site])
    while body > 0:
        start = int(model.body_jntadr[body])
        joints[:0] = range(start, start + int(model.body_jntnum[body]))
        body = int(model.body_parentid[body])
    if any(model.jnt_type[j] != mujoco.mjtJoint.mjJNT_SLIDE for j in joints):
        return None
    d = mujoco.MjData(model)
    d.qpos[:] = model.qpos0
    mujoco.mj_kinematics(model, d)  # no rotation moves: xaxis is the same at every qpos
    matrix = np.zeros((model.nq, 3))
    for j in joints:
        matrix[model.jnt_qposadr[j]] = d.xaxis[j]
    slides = (d.site_xpos[site].copy(), matrix)
    # proof on this model: the closed form reproduces mj_kinematics at random joint states
    rng = np.random.default_rng(0)
    rows = model.qpos0 + rng.uniform(-0.5, 0.5, (8, model.nq))
    expect = np.empty((rows.shape[0], 3))
    for k, row in enumerate(rows):
        d.qpos[:] = row
        mujoco.mj_kinematics(model, d)
        expect[k] = d.site_xpos[site]
    got = along_slides(slides, model.qpos0, rows)
    return slides if np.abs(got - expect).max() <= SITE_MAP_TOL_M else None


def along_slides(
    slides: tuple[np.ndarray, np.ndarray], qpos0: np.ndarray, qpos: np.ndarray
) -> np.ndarray:
    """site(qpos0) + (q - q0) @ axes for every row of ``qpos`` (N, nq) -> (N, 3) [m]."""
    origin, matrix = slides
    return origin + (qpos - qpos0) @ matrix

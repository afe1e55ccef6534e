"""Second-order auto-regressive dynamics of §2.2: ``X_k = A X_{k-1} + W_k``.

The augmented state stacks the current and previous pose, ``X_k = [x_k; x_{k-1}]``, each
``x = [x, y, s, θ]``. We use the damped constant-velocity form of A,

    x_k = x_{k-1} + a (x_{k-1} - x_{k-2}) + w_k,     A = [[(1 + a) I, -a I], [I, 0]],

where ``a`` (``velocity_damping``) in [0, 1] is how much of the last displacement carries
over (0: random walk, 1: constant velocity). The noise W acts on the current pose only.
"""

from __future__ import annotations

import numpy as np

__all__ = ['ar2_matrix', 'move_states', 'predict']


def ar2_matrix(velocity_damping: float) -> np.ndarray:
    """The ``(8, 8)`` matrix A of §2.2 for the given velocity damping ``a``."""
    if not 0.0 <= velocity_damping <= 1.0:
        raise ValueError(f'velocity_damping must be in [0, 1], got {velocity_damping}')
    a = velocity_damping
    eye = np.eye(4)
    return np.block([[(1.0 + a) * eye, -a * eye], [eye, np.zeros((4, 4))]])


def predict(
    current: np.ndarray,
    previous: np.ndarray,
    velocity_damping: float,
    process_noise: np.ndarray,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """Propagate particles one step with the AR(2) model (the prediction step).

    Args:
        current: ``(P, 4)`` particle poses x_{k-1}: x, y pixels; s pixels/unit; θ radians.
        previous: ``(P, 4)`` the same particles one step earlier, x_{k-2}.
        velocity_damping: a in A, in [0, 1].
        process_noise: ``(4,)`` standard deviations of W: x, y in pixels, s as a fraction
            of the particle's scale (so the noise scales with distance), θ in radians.
        rng: Seeded generator.

    Returns:
        ``(new_current, new_previous)``: x_k and x_{k-1}, each ``(P, 4)``.
    """
    a = velocity_damping
    noise = rng.standard_normal(current.shape) * process_noise
    noise[:, 2] *= current[:, 2]
    predicted = current + a * (current - previous) + noise
    # Scale is a size: keep it strictly positive whatever the noise draws.
    np.maximum(predicted[:, 2], 1e-3, out=predicted[:, 2])
    return predicted, current.copy()


def move_states(states: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """States [x, y, s, θ] ``(P, 4)`` carried by ``transform``: the centre mapped, the scale
    multiplied by the zoom, the angle turned by the rotation."""
    a, b = transform[0, 0], transform[1, 0]
    moved = np.array(states, dtype=np.float64, copy=True)
    moved[:, :2] = states[:, :2] @ transform[:, :2].T + transform[:, 2]
    moved[:, 2] *= np.hypot(a, b)
    moved[:, 3] += np.arctan2(b, a)
    return moved

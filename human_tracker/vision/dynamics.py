"""Second-order auto-regressive dynamics of §2.2: ``X_k = A X_{k-1} + W_k``.

The augmented state stacks the current and previous pose, ``X_k = [x_k; x_{k-1}]``, each
``x = [x, y, s, θ]``. We use the damped constant-velocity form of A,

    x_k = x_{k-1} + a (x_{k-1} - x_{k-2}) + w_k,     A = [[(1 + a) I, -a I], [I, 0]],

where ``a`` (``velocity_damping``) in [0, 1] is how much of the last displacement carries
over (0: random walk, 1: constant velocity). The noise W acts on the current pose only.

A silhouette that stands upright (a head and shoulders: the shoulders are the body's) has a
mean tilt, θ̄ = 0: its θ follows the second-order process about that mean (Blake & Isard,
*Active Contours*, 1998: ``x_k - x̄ = A (x_{k-1} - x̄) + W_k``), with A's θ rows times ``1 - r``,
where ``r`` (``tilt_reversion``) is the share of the predicted tilt that returns to upright each
frame. With r = 0 θ is a random walk with carried velocity, its prior spread unbounded; with
r > 0 the prior spread is stationary (0.13 rad for a = 0.6, W's θ 0.02 rad and r = 0.03), and
only the likelihood takes the contour further. A camera that rolls breaks the assumption:
set r to 0.
"""

from __future__ import annotations

import numpy as np

__all__ = ['ar2_matrix', 'predict', 'predicted_mean']


def ar2_matrix(velocity_damping: float, tilt_reversion: float = 0.0) -> np.ndarray:
    """The ``(8, 8)`` matrix A of §2.2 for the velocity damping ``a`` and tilt reversion ``r``."""
    if not 0.0 <= velocity_damping <= 1.0:
        raise ValueError(f'velocity_damping must be in [0, 1], got {velocity_damping}')
    if not 0.0 <= tilt_reversion <= 1.0:
        raise ValueError(f'tilt_reversion must be in [0, 1], got {tilt_reversion}')
    a = velocity_damping
    keep = np.diag([1.0, 1.0, 1.0, 1.0 - tilt_reversion])
    return np.block([[(1.0 + a) * keep, -a * keep], [np.eye(4), np.zeros((4, 4))]])


def predicted_mean(
    current: np.ndarray, previous: np.ndarray, velocity_damping: float, tilt_reversion: float = 0.0
) -> np.ndarray:
    """``(P, 4)`` the deterministic part of the prediction, the first half of ``A X_{k-1}``.

    Args:
        current: ``(P, 4)`` poses x_{k-1}.
        previous: ``(P, 4)`` the same poses one step earlier, x_{k-2}.
        velocity_damping: a in A, in [0, 1].
        tilt_reversion: r, the share of the predicted θ that returns to 0 (upright), in [0, 1].
    """
    mean = current + velocity_damping * (current - previous)
    if tilt_reversion:
        mean[:, 3] *= 1.0 - tilt_reversion
    return mean


def predict(
    current: np.ndarray,
    previous: np.ndarray,
    velocity_damping: float,
    process_noise: np.ndarray,
    rng: np.random.Generator,
    tilt_reversion: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Propagate particles one step with the AR(2) model (the prediction step).

    Args:
        current: ``(P, 4)`` particle poses x_{k-1}: x, y pixels; s pixels/unit; θ radians.
        previous: ``(P, 4)`` the same particles one step earlier, x_{k-2}.
        velocity_damping: a in A, in [0, 1].
        process_noise: ``(4,)`` standard deviations of W: x, y in pixels, s as a fraction
            of the particle's scale (so the noise scales with distance), θ in radians.
        rng: Seeded generator.
        tilt_reversion: r, the share of the predicted θ that returns to upright
            (:func:`predicted_mean`).

    Returns:
        ``(new_current, new_previous)``: x_k and x_{k-1}, each ``(P, 4)``.
    """
    noise = rng.standard_normal(current.shape) * process_noise
    noise[:, 2] *= current[:, 2]
    predicted = predicted_mean(current, previous, velocity_damping, tilt_reversion) + noise
    # Scale is a size: keep it strictly positive whatever the noise draws.
    np.maximum(predicted[:, 2], 1e-3, out=predicted[:, 2])
    return predicted, current.copy()

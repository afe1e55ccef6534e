"""Labelled skin colour samples: the UCI ``Skin_NonSkin.txt`` format."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ['read_skin_samples']


def read_skin_samples(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read ``B G R class`` lines (class 1 = skin, 2 = non-skin).

    Returns:
        ``(M, 3) uint8`` colours in B, G, R order and ``(M,) bool``, True for skin.

    Raises:
        ValueError: The file is missing, or a line is not four integers with a valid class.
    """
    try:
        table = np.loadtxt(path, dtype=np.int64, ndmin=2)
    except (OSError, ValueError) as err:
        raise ValueError(f'cannot read skin samples {path}: {err}') from err
    if table.shape[1] != 4:
        raise ValueError(f'{path}: expected 4 columns (B G R class), got {table.shape[1]}')
    if table[:, :3].min(initial=0) < 0 or table[:, :3].max(initial=0) > 255:
        raise ValueError(f'{path}: colours must be in 0..255')
    if not np.isin(table[:, 3], (1, 2)).all():
        raise ValueError(f'{path}: class must be 1 (skin) or 2 (non-skin)')
    return table[:, :3].astype(np.uint8), table[:, 3] == 1

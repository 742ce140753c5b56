"""Compact, lossless storage of sampled time series: float64 arrays, zlib-compressed."""

from __future__ import annotations

import zlib

import numpy as np


def pack(time: np.ndarray, columns: dict[str, np.ndarray]) -> tuple[list[str], int, bytes]:
    """(names, n_samples, blob): time first, then the columns in the given order, bit for bit."""
    names = list(columns)
    n = len(time)
    z = zlib.compressobj(6)
    parts = []
    for col in [time] + [columns[k] for k in names]:  # column by column, in slices: no copy of the whole table
        a = np.asarray(col, "<f8")
        if a.shape != (n,):
            raise ValueError(f"every column needs one value per time ({n}), got shape {a.shape}")
        for i in range(0, n, 1 << 18):
            parts.append(z.compress(np.ascontiguousarray(a[i:i + (1 << 18)])))
    parts.append(z.flush())
    return names, n, b"".join(parts)


def unpack(names: list[str], n_samples: int, blob: bytes) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    data = np.frombuffer(zlib.decompress(blob), "<f8").reshape(len(names) + 1, n_samples)
    return data[0].copy(), {n: data[i + 1].copy() for i, n in enumerate(names)}


def unpack_blob(names: list[str], blob: bytes) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """As unpack, with the number of samples taken from the blob's size."""
    raw = zlib.decompress(blob)
    return unpack(names, len(raw) // (8 * (len(names) + 1)), blob)

"""Bitmap bodies: pixels to materials, by grey level or exact colour (Pillow reads the file).

Row 0 of an image is its top; the model's y axis points up, so the image's lower-left
corner sits at `origin`. Later map entries win where two entries match the same pixel.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
from PIL import Image as PILImage


@lru_cache(maxsize=16)
def _pixels(path: str, mtime: float) -> tuple[np.ndarray, np.ndarray]:
    with PILImage.open(path) as im:
        grey = np.asarray(im.convert("L"), dtype=np.int16)
        rgb = np.asarray(im.convert("RGB"), dtype=np.int16)
    return grey, rgb


def load_pixels(body, base_dir) -> tuple[np.ndarray, np.ndarray]:
    p = Path(base_dir) / body.file
    return _pixels(str(p.resolve()), p.stat().st_mtime)


def image_bbox(body, base_dir) -> tuple[np.ndarray, np.ndarray]:
    grey, _ = load_pixels(body, base_dir)
    h, w = grey.shape
    lo = np.array(body.origin, float)
    return lo, lo + body.pixel_size * np.array([w, h], float)


def pixel_classes(body, grey: np.ndarray, rgb: np.ndarray) -> np.ndarray:
    """Map entry index per pixel, -1 where no entry matches."""
    cls = np.full(grey.shape, -1, dtype=np.int64)
    for j, entry in enumerate(body.map):
        if entry.grey is not None:
            lo, hi = entry.grey
            cls[(grey >= lo) & (grey <= hi)] = j
        else:
            cls[np.all(rgb == np.array(entry.color), axis=-1)] = j
    return cls


def image_classes(body, xy: np.ndarray, base_dir) -> np.ndarray:
    """Map entry index for each point, -1 outside the image or on an unmapped pixel."""
    grey, rgb = load_pixels(body, base_dir)
    h, w = grey.shape
    cls = pixel_classes(body, grey, rgb)
    col = np.floor((xy[:, 0] - body.origin[0]) / body.pixel_size).astype(np.int64)
    row_up = np.floor((xy[:, 1] - body.origin[1]) / body.pixel_size).astype(np.int64)
    ok = (col >= 0) & (col < w) & (row_up >= 0) & (row_up < h)
    out = np.full(len(xy), -1, dtype=np.int64)
    out[ok] = cls[h - 1 - row_up[ok], col[ok]]
    return out

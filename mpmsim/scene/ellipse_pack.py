"""The LR paper's §4.2 scene: ellipses packed in a box, each in its own grey level.

Deterministic: the same arguments always give the same pixels (a seeded generator, no
anti-aliasing). Run as a script to write the PNG the `ellipse_box` deck reads:

    python -m mpmsim.scene.ellipse_pack inputs/ellipse_box.png

Row 0 is the image's top (Pillow's convention); the background is white (255) and ellipse k
is grey level `grey_level(k)`, so a deck maps level ranges to materials.
"""

from __future__ import annotations

import sys

import numpy as np
from PIL import Image

WIDTH, HEIGHT = 280, 560  # pixels; the paper's 1 x 2 mm box
BACKGROUND = 255


def grey_level(k: int) -> int:
    """Grey level of ellipse k (0-based): 10, 22, ..., 238 for twenty ellipses."""
    return 10 + 12 * k


def _ellipse_window(cx, cy, a, b, angle, ex, ey, pad):
    """(row slice, col slice, mask): pixels whose centres lie inside the ellipse (semi-axes a, b
    rotated by angle), within its bounding box grown by pad pixels."""
    r0, r1 = int(cy - ey) - pad, int(cy + ey) + pad + 2
    c0, c1 = int(cx - ex) - pad, int(cx + ex) + pad + 2
    rows, cols = np.mgrid[r0:r1, c0:c1]
    x = cols + 0.5 - cx
    y = rows + 0.5 - cy
    c, s = np.cos(angle), np.sin(angle)
    u = (c * x + s * y) / a
    v = (-s * x + c * y) / b
    return slice(r0, r1), slice(c0, c1), u * u + v * v <= 1.0


def _dilate(mask: np.ndarray, r: int) -> np.ndarray:
    """Grow a mask by r pixels (square structuring element); the mask has r empty pixels of
    padding on every side, so shifting never wraps material around."""
    out = mask.copy()
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            out |= np.roll(mask, (dy, dx), axis=(0, 1))
    return out


def ellipse_box(width: int = WIDTH, height: int = HEIGHT, count: int = 20, gap: int = 3,
                seed: int = 2020, tries: int = 4000) -> np.ndarray:
    """Grey image (height, width) of `count` non-touching ellipses packed largest first.

    Each ellipse is drawn from a shrinking size range and placed at the first random spot
    (of `tries`) where it clears every placed ellipse and the box walls by `gap` pixels.
    """
    rng = np.random.default_rng(seed)
    pad = gap + 2  # canvas margin so every window (ellipse box + gap) lies on the canvas
    img = np.full((height + 2 * pad, width + 2 * pad), BACKGROUND, dtype=np.uint8)
    taken = np.zeros(img.shape, dtype=bool)
    scale = 0.42 * width  # largest semi-major axis
    placed = 0
    while placed < count:
        for _ in range(tries):
            a = scale * rng.uniform(0.75, 1.0)
            b = a * rng.uniform(0.45, 0.85)
            angle = rng.uniform(0.0, np.pi)
            # half-extents of the rotated ellipse's bounding box
            ex = np.hypot(a * np.cos(angle), b * np.sin(angle))
            ey = np.hypot(a * np.sin(angle), b * np.cos(angle))
            if 2 * (ex + gap) >= width or 2 * (ey + gap) >= height:
                continue
            cx = rng.uniform(ex + gap, width - ex - gap)
            cy = rng.uniform(ey + gap, height - ey - gap)
            if b > 1.0 and taken[int(cy) + pad, int(cx) + pad]:
                continue  # centre pixel taken: the full mask test below would reject it too
            rows, cols, mask = _ellipse_window(cx + pad, cy + pad, a, b, angle, ex, ey, gap)
            if not (mask & taken[rows, cols]).any():
                img[rows, cols][mask] = grey_level(placed)
                taken[rows, cols] |= _dilate(mask, gap)
                placed += 1
                break
        else:
            scale *= 0.9  # nothing of this size fits any more
    return img[pad:-pad, pad:-pad].copy()


def write_png(path: str, **kwargs) -> None:
    Image.fromarray(ellipse_box(**kwargs), mode="L").save(path)


if __name__ == "__main__":
    write_png(sys.argv[1] if len(sys.argv) > 1 else "ellipse_box.png")

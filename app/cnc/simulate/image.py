"""A picture of the simulated part for the set-up sheet: a shaded plan view as PNG.

Seen from above, +X to the right and +Y up, lit from the upper left; the deeper a surface,
the darker its blue. Cut-through cells are white. Written with zlib (no image library), so
the same part gives the same bytes.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np
import numpy.typing as npt

from app.cnc.simulate.segments import F64
from app.cnc.simulate.stock import Grid

TOP = np.array([205.0, 210.0, 216.0])  # the stock's untouched top: light steel
DEEP = np.array([38.0, 84.0, 150.0])  # the deepest cut: dark blue
THROUGH = np.array([255.0, 255.0, 255.0])


def render(grid: Grid, heights: F64, width: int = 800) -> npt.NDArray[np.uint8]:
    """RGB pixels (rows top to bottom) of the part, about `width` pixels wide."""
    stock = grid.stock
    scale = max(1, round(width / max(grid.nx, grid.ny) * max(grid.nx, grid.ny) / grid.nx))
    depth = np.clip((stock.top - heights) / max(stock.top - stock.bottom, 1), 0.0, 1.0)
    gy, gx = np.gradient(heights, grid.resolution)
    # Lambert shading from the upper left, 45° up.
    light = np.array([-1.0, 1.0, 1.4])
    light /= np.linalg.norm(light)
    normal_z = 1.0 / np.sqrt(gx * gx + gy * gy + 1.0)
    shade = (-gx * light[0] - gy * light[1] + light[2]) * normal_z
    shade = np.clip(0.35 + 0.75 * shade, 0.0, 1.0)
    colour = TOP + (DEEP - TOP) * np.sqrt(depth)[..., None]
    rgb = colour * shade[..., None]
    rgb[heights <= stock.bottom] = THROUGH
    pixels: npt.NDArray[np.uint8] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)[::-1]
    if scale > 1:
        pixels = pixels.repeat(scale, axis=0).repeat(scale, axis=1)
    return pixels


def png_bytes(pixels: npt.NDArray[np.uint8]) -> bytes:
    """An 8-bit RGB PNG of `pixels` (rows, columns, 3)."""
    height, width, _ = pixels.shape
    rows = np.concatenate([np.zeros((height, 1), dtype=np.uint8), pixels.reshape(height, -1)], 1)

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows.tobytes(), 9))
        + chunk(b"IEND", b"")
    )

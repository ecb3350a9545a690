"""The simulated part as a binary STL solid (closed and outward-facing, in millimetres).

The top is the height map through the cell centres (two triangles per square of four
centres), the four sides drop from its border to the stock's bottom, and the bottom is a
fan from its centre to the border, so every edge is shared by exactly two triangles. STL has
no unit; millimetres are what slicers and CAM viewers assume, so inch parts are scaled.
Deterministic: the same heights give the same bytes.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from app.cnc.simulate.segments import F64
from app.cnc.simulate.stock import Grid
from app.cnc.units import NM_PER_MM

HEADER = b"MillBlocks simulated part, millimetres"
_TRIANGLE = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attribute", "<u2")])


def surface_triangles(grid: Grid, heights: F64) -> npt.NDArray[np.float64]:
    """The solid's triangles, (n, 3, 3) vertex coordinates in nm, counter-clockwise seen
    from outside."""
    xs, ys = grid.centres()
    gx, gy = np.meshgrid(xs, ys)
    top = np.stack([gx, gy, heights], axis=-1)
    a, b = top[:-1, :-1], top[:-1, 1:]
    c, d = top[1:, 1:], top[1:, :-1]
    quads = [np.stack([a, b, c], axis=-2), np.stack([a, c, d], axis=-2)]
    faces = [q.reshape(-1, 3, 3) for q in quads]
    # The border, counter-clockwise seen from above, closed.
    loop = np.concatenate(
        [top[0, :], top[1:, -1], top[-1, -2::-1], top[-2:0:-1, 0], top[:1, 0]], axis=0
    )
    bottom = loop.copy()
    bottom[:, 2] = grid.stock.bottom
    p, q = loop[:-1], loop[1:]
    pb, qb = bottom[:-1], bottom[1:]
    faces.append(np.stack([p, pb, qb], axis=1))
    faces.append(np.stack([p, qb, q], axis=1))
    centre = np.array([xs.mean(), ys.mean(), grid.stock.bottom])
    apex = np.broadcast_to(centre, pb.shape)
    faces.append(np.stack([apex, qb, pb], axis=1))
    return np.concatenate(faces, axis=0)


def coarser(grid: Grid, heights: F64, max_cells: int) -> tuple[Grid, F64]:
    """The map on cells k times larger (k the least giving at most `max_cells` along each
    side), each the deepest of the cells it covers, so no hole disappears."""
    k = max(1, -(-max(grid.nx, grid.ny) // max_cells))
    if k == 1:
        return grid, heights
    ny, nx = -(-grid.ny // k), -(-grid.nx // k)
    padded = np.full((ny * k, nx * k), float(grid.stock.top))
    padded[: grid.ny, : grid.nx] = heights
    pooled = padded.reshape(ny, k, nx, k).min(axis=(1, 3))
    return Grid(grid.stock, grid.resolution * k, nx, ny), pooled


def stl_bytes(grid: Grid, heights: F64, max_cells: int = 400) -> bytes:
    """Binary STL of the simulated part (millimetres), on at most `max_cells` cells along
    each side (about 20 bytes per cell: 4.5 MB for 400 × 300)."""
    grid, heights = coarser(grid, heights, max_cells)
    triangles = surface_triangles(grid, heights) / NM_PER_MM
    u = triangles[:, 1] - triangles[:, 0]
    v = triangles[:, 2] - triangles[:, 0]
    normal = np.cross(u, v)
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    data = np.zeros(len(triangles), dtype=_TRIANGLE)
    data["normal"] = normal
    data["vertices"] = triangles
    head = HEADER.ljust(80, b" ")
    return head + np.uint32(len(data)).tobytes() + data.tobytes()

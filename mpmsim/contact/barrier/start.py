"""Checks of a barrier scene's start: no particle inside an FEM body, and no two FEM bodies, or a
particle and an FEM body, closer than dhat (the barrier would start infinite or already
pushing). Each problem is a deck error naming the key or the bodies."""

from __future__ import annotations

import numpy as np

from ...linalg import solve_batch
from ...shapes.cpdi import corner_signs
from .broadphase import box_pairs, point_boxes, point_edge_candidates, simplex_boxes
from .closest import point_triangle_distance
from .distance import point_edge_distance
from .surface import surface_gaps


def particles_inside(x: np.ndarray, verts: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(particle, cell) pairs (k, 2) with the particle strictly inside the triangle (2D) or
    tetrahedron (3D): all barycentric coordinates positive. Candidates from the spatial hash
    of their boxes."""
    z = np.zeros_like(x)
    lo, hi = point_boxes(x, z)
    tlo, thi = simplex_boxes(verts, np.zeros_like(verts), cells, 0.0)
    pairs = box_pairs(lo, hi, tlo, thi, np.full(len(x), -1, np.int64), cells)
    if not len(pairs):
        return pairs
    v0 = verts[cells[pairs[:, 1], 0]]
    T = np.stack([verts[cells[pairs[:, 1], k]] - v0 for k in range(1, cells.shape[1])], axis=2)  # (k, d, d)
    lam = solve_batch(np.ascontiguousarray(T), np.ascontiguousarray(x[pairs[:, 0]] - v0))
    return pairs[(lam > 0.0).all(axis=1) & (lam.sum(axis=1) < 1.0)]


def check_initial_gaps(scene, dhat: float, corners: bool = False) -> None:
    """Deck error when two FEM bodies, or a particle (its domain's corners with `corners`) and
    an FEM body, start closer than dhat (the barrier would start infinite or already pushing)."""
    from ...deck.loader import raise_at
    from ...fem.probes import boundary_gap

    fem = scene.fem
    if fem is None:
        return
    dim = fem.points.shape[1]
    problems = []
    n = len(fem.infos)
    gaps = {}
    if dim == 2:
        for a in range(n):
            for b in range(a + 1, n):
                gaps[a, b] = boundary_gap(fem.points, fem.facets, fem.node_body, a, b)
    elif n > 1:
        gaps = surface_gaps(fem.points, fem.facets, fem.node_body, dhat)
    for (a, b), gap in sorted(gaps.items()):
        if gap <= dhat:
            problems.append((("implicit", "dhat"), f"bodies '{fem.infos[a].name}' and '{fem.infos[b].name}' "
                             f"start {gap:.4g} apart, not farther than dhat = {dhat:g}: move them apart "
                             "or lower dhat"))
    seed = scene.deformable if scene.has_particles else None
    if seed is not None and len(seed.x) and len(fem.cells):
        inside = particles_inside(seed.x, fem.points, fem.cells)
        if len(inside):
            q, e = inside[0]
            problems.append((("bodies",), f"{len(inside)} particle(s) of '{_body_name(scene, seed.body[q])}' start "
                             f"inside FEM body '{fem.infos[fem.cell_body[e]].name}' (first at "
                             f"{seed.x[q].round(6).tolist()}): the bodies overlap"))
    if seed is not None and len(seed.x):
        x, owner = seed.x, np.arange(len(seed.x))
        if corners:  # the corners of the particles' domains
            d = x.shape[1]
            signs = corner_signs(d)
            x = (x[:, None, :] + signs * np.asarray(scene.semi_size)[:d]).reshape(-1, d)
            owner = np.repeat(owner, len(signs))
        pairs = point_edge_candidates(x, np.zeros_like(x), fem.points, np.zeros_like(fem.points), fem.facets, dhat,
                                      np.full(len(x), -1, np.int64))
        distance = point_edge_distance if dim == 2 else point_triangle_distance
        for q, e in pairs:
            a = fem.facets[e, 0]
            d = distance(np.concatenate([x[q], fem.points[fem.facets[e]].ravel()]))
            if d <= dhat:
                what = "a particle's corner" if corners else "a particle"
                problems.append((("implicit", "dhat"), f"{what} of '{_body_name(scene, seed.body[owner[q]])}' at "
                                 f"{x[q].round(6).tolist()} starts {d:.4g} from the boundary of "
                                 f"'{fem.infos[fem.node_body[a]].name}', not farther than dhat = {dhat:g}: move "
                                 "the bodies apart or lower dhat"))
                break
    if problems:
        raise_at(problems, scene.loaded)


def _body_name(scene, body: int) -> str:
    return next(b.name for b in scene.deformable_bodies if b.index == body)

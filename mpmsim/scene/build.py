"""Deck -> Scene: size the grid from the bodies, fill bodies with particles.

Particles sit on a lattice aligned with the grid, `particles_per_direction` per cell edge,
so each particle's domain tiles its cell. Bodies are filled in deck order; a later body
takes the lattice sites of earlier ones it overlaps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..bodies import BodyInfo
from ..deck.loader import LoadedDeck, deck_digest, raise_at
from ..deck.schema import Image, RotationVelocity, SineVelocity
from ..deck.semantics import body_name
from ..fem.mesh import MeshError
from ..materials import MaterialTable
from .materials import build_material_table
from .geometry import bbox, body_materials, inside
from ..shapes import shape_function
from .contact import ContactModel, build_contact_model, inverted_normals, patch_resolution_notices, untouched_pairs
from .fem import FemSeed, build_fem
from .settings import RunSettings, run_settings
from .grid import FACE_CODES, FACES, FREE, ROLLER, GridSpec, plan_grid
from .rings import ring_seed, shell_seed
from .memory import CANDIDATE_BYTES, NODE_BYTES, PARTICLE_BYTES, too_big

SURFACE_SEEDINGS = ("rings", "rings_half_step", "shells")  # seedings that follow the surface, not the lattice


@dataclass
class ParticleSeed:
    x: np.ndarray  # (n, dim)
    v: np.ndarray  # (n, dim)
    vol: np.ndarray  # (n,) initial volume (2D: area x thickness)
    mat: np.ndarray  # (n,) local material index (deformable or rigid numbering)
    body: np.ndarray  # (n,) deck body index


@dataclass
class Scene:
    """The deck resolved once: grid, materials, the bodies with their initial particles (and
    FEM meshes), the contact model and the run settings. Everything downstream (state,
    integrator, output) is built from this; nothing below it reads the deck."""

    loaded: LoadedDeck
    grid: GridSpec
    materials: MaterialTable
    deformable: ParticleSeed
    rigid: ParticleSeed
    semi_size: np.ndarray  # (dim,) undeformed particle semi-lengths
    thickness: float
    contact: ContactModel  # laws per material pair and each contact family's settings
    deformable_bodies: list[BodyInfo]  # deck bodies holding deformable particles
    rigid_bodies: list[BodyInfo]  # deck bodies holding rigid particles
    fem: FemSeed | None  # the FEM bodies' meshes (None: no FEM body)
    settings: RunSettings
    digest: str  # sha256 of the validated deck (a checkpoint belongs to it)
    record: dict  # the validated deck as JSON values (the history's sidecar keeps it)
    notices: tuple = ()  # what `check` and `run` warn about (overlapping bodies, gaps closed by filling)
    seedings: dict | None = None  # particle body's deck index -> Seeding (how it was filled, and why)

    @property
    def has_particles(self) -> bool:
        return self.grid is not None

    @property
    def deck(self):
        return self.loaded.deck

    @property
    def dim(self) -> int:
        return self.settings.dim


def _cell_sizes(deck) -> np.ndarray:
    cs = deck.grid.cell_size
    return np.array(cs, float) if isinstance(cs, list) else np.full(deck.dim, float(cs))



def clipped(box, clip):
    """A body's bounding box cut to its clip box."""
    if clip is None:
        return box
    lo, hi = box
    return np.maximum(lo, np.asarray(clip.min, float)), np.minimum(hi, np.asarray(clip.max, float))

def empty_seed(dim: int) -> ParticleSeed:
    z = np.zeros
    return ParticleSeed(z((0, dim)), z((0, dim)), z(0), z(0, dtype=np.int64), z(0, dtype=np.int64))


def build_scene(loaded: LoadedDeck) -> Scene:
    deck = loaded.deck
    base = loaded.base_dir
    mats = build_material_table(deck)
    fem, problems = build_fem(deck, base, mats) if any(b.discretization == "fem" for b in deck.bodies) else (None, [])
    if problems:
        raise_at(problems, loaded)
    particle_bodies = [(i, b) for i, b in enumerate(deck.bodies) if b.discretization == "particles"]
    settings = run_settings(deck)
    if not particle_bodies:  # FEM bodies only: no background grid, no particles
        dim = deck.dim
        return Scene(loaded, None, mats, empty_seed(dim), empty_seed(dim), None, deck.thickness,
                     build_contact_model(deck, mats, fem), [], [], fem, settings,
                     deck_digest(deck), deck.model_dump(mode="json"))
    grid, deformable, rigid, semi, notices, seedings = build_particles(loaded, mats, particle_bodies)
    infos = lambda seed, kind: [BodyInfo(int(i), body_name(deck.bodies[i], int(i)), kind,  # noqa: E731
                                         deck.bodies[i].material) for i in np.unique(seed.body)]
    contact = build_contact_model(deck, mats, fem, np.unique(deformable.mat))
    if contact.grid is not None and contact.grid.cohesive is not None and len(deformable.x):
        problems = untouched_pairs(deck, list(mats.deformable), deformable.mat, deformable.x, float(grid.h.max()))
        if problems:
            raise_at(problems, loaded)
        notices = list(notices) + inverted_normals(deck, list(mats.deformable), deformable.mat, deformable.x,
                                                   float(grid.h.max()))
    if contact.grid is not None:
        notices = list(notices) + patch_resolution_notices(deck, float(grid.h.max()))
    return Scene(loaded, grid, mats, deformable, rigid, semi, deck.thickness, contact,
                 infos(deformable, "particles"), infos(rigid, "rigid particles"), fem, settings,
                 deck_digest(deck), deck.model_dump(mode="json"), tuple(notices), seedings)


def build_particles(loaded: LoadedDeck, mats: MaterialTable, particle_bodies: list):
    """The background grid and the particles of the particle bodies [(deck index, body)]:
    (grid, deformable seed, rigid seed, particle semi-lengths, notices)."""
    deck = loaded.deck
    base = loaded.base_dir
    dim = deck.dim
    h = _cell_sizes(deck)
    faces = [FACE_CODES[getattr(deck.grid.boundaries, f)] for f in FACES[: 2 * dim]]
    axisymmetric = deck.analysis == "axisymmetric"

    boxes, problems = [], []
    for i, b in particle_bodies:
        try:
            boxes.append(clipped(bbox(b, base, dim), b.clip))
        except MeshError as exc:
            problems.append((("bodies", i, "file"), str(exc)))
            continue
        if axisymmetric and boxes[-1][0][0] < -1e-12 * h[0]:
            who = f"body '{b.name}'" if getattr(b, "name", None) else "the body"
            problems.append((("bodies", i), f"{who} reaches r = {boxes[-1][0][0]:g} < 0: in axisymmetric analysis x is "
                                            "the radius; a body of revolution lies at r >= 0 (clip it at r = 0)"))
    if problems:
        raise_at(problems, loaded)
    if deck.grid.domain is not None:
        lo, hi = np.array(deck.grid.domain.min, float), np.array(deck.grid.domain.max, float)
        explicit = True
    else:
        lo = np.min([b[0] for b in boxes], axis=0)
        hi = np.max([b[1] for b in boxes], axis=0)
        # cover every rigid body's prescribed path
        for (_, body), (blo, bhi) in zip(particle_bodies, boxes):
            name = getattr(body, "material", "")
            if name in mats.rigid:
                dmin, dmax = mats.motions[mats.rigid.index(name)].displacement_envelope(deck.time.end)
                lo = np.minimum(lo, blo + dmin)
                hi = np.maximum(hi, bhi + dmax)
        for a in range(dim):
            if faces[2 * a] == 0:
                lo[a] -= deck.grid.margin * h[a]
            if faces[2 * a + 1] == 0:
                hi[a] += deck.grid.margin * h[a]
        if axisymmetric:
            lo[0] = max(lo[0], 0.0)  # the grid stops at the axis
        explicit = False
    if axisymmetric and lo[0] <= 0.0 and faces[0] == FREE:
        faces[0] = ROLLER  # the axis r = 0 is a symmetry line: no radial velocity there
    grid, problem = plan_grid(dim, h, lo, hi, faces, explicit, shape_function(deck.shape_function).ghost)
    if problem:
        raise_at([(("grid", "domain" if explicit else "cell_size"), problem)], loaded)

    ppd = deck.particles_per_direction
    spacing = h / ppd
    n_lat = (grid.shape[:dim] - 1) * ppd
    lattice = [np.clip(np.floor((bhi - blo) / spacing) + 2, 1, n_lat) for blo, bhi in boxes]
    sites = float(sum(np.prod(n.astype(np.float64)) for n in lattice))
    fields = 1 + len(mats.deformable)  # a field per material where they meet
    nodes = float(np.prod(grid.shape.astype(np.float64)))
    problem = too_big(nodes * NODE_BYTES[dim] * fields + sites * (PARTICLE_BYTES[dim] + CANDIDATE_BYTES),
                      f"{nodes:.3g} grid nodes and up to {sites:.3g} particles",
                      "a coarser grid.cell_size, fewer particles_per_direction or smaller bodies")
    if problem:
        raise_at([(("grid", "cell_size"), problem)], loaded)
    seedings = resolve_seedings(deck, mats, particle_bodies, h)
    while True:  # twice at most: auto-seeded bodies found overlapping others fall back to the lattice
        seeded = _seed_bodies(loaded, particle_bodies, boxes, seedings, grid, spacing, n_lat)
        keys, owners, mat_names, where, vols, n_rings = seeded
        overlaps = _rings_overlaps(particle_bodies, base, seedings, where) if n_rings else []
        if not any(seedings[i].auto for i, _ in overlaps):
            break
        for i, other in overlaps:
            if seedings[i].auto:
                seedings[i] = Seeding("lattice", True, f"auto: it overlaps body '{other}'")
    if overlaps:
        raise_at([(("bodies", i, "seeding"), f"body '{body_name(deck.bodies[i], i)}' is seeded in {seedings[i].how} "
                   f"and overlaps body '{other}': separate the shapes or use seeding: lattice")
                  for i, other in overlaps], loaded)

    keys = np.concatenate(keys)
    owners = np.concatenate(owners)
    mat_names = np.concatenate(mat_names)
    x_all = np.concatenate(where)
    vol_all = np.concatenate(vols)
    # later bodies win: keep the last occurrence of each lattice site (ring particles' keys are unique)
    rev = slice(None, None, -1)
    _, first_in_rev = np.unique(keys[rev], return_index=True)
    keep = np.sort(len(keys) - 1 - first_in_rev)
    notices = overwritten(deck, keys, owners, keep)
    keys, owners, mat_names, x, vol = keys[keep], owners[keep], mat_names[keep], x_all[keep], vol_all[keep]
    if axisymmetric:  # volumes (and so masses) per radian: the r-z area times the particle's radius
        vol = vol * x[:, 0]

    lat = keys >= 0  # gaps closed between lattice-filled bodies (ring bodies' domains end at their surface)
    kk = np.empty((int(lat.sum()), dim), dtype=int)
    rem = keys[lat].copy()
    for a in range(dim):
        kk[:, a] = rem % n_lat[a]
        rem //= n_lat[a]
    notices += gaps_closed(deck, base, keys[lat], kk, owners[lat], x[lat], spacing, n_lat)

    rigid_mask = np.array([m in mats.rigid for m in mat_names], dtype=bool)
    seeds = []
    for want_rigid in (False, True):
        sel = rigid_mask == want_rigid
        xs, own, names = x[sel], owners[sel], mat_names[sel]
        mat = np.array([mats.local_index(m) for m in names], dtype=np.int64)
        v = np.zeros_like(xs)
        for i in np.unique(own):
            on = own == i
            body = deck.bodies[i]
            if want_rigid:
                for r in np.unique(mat[on]):
                    v[on & (mat == r)] = mats.motions[r].velocity(0.0)
            elif isinstance(body.velocity, SineVelocity):
                sv = body.velocity
                phase = 2 * np.pi * (xs[on, "xyz".index(sv.axis)] - sv.origin) / sv.wavelength
                v[on] = np.sin(phase)[:, None] * np.array(sv.amplitude)[None, :]
            elif isinstance(body.velocity, RotationVelocity):
                rv = body.velocity
                r = xs[on] - np.array(rv.center)
                if dim == 2:
                    v[on] = rv.angular_velocity * np.stack([-r[:, 1], r[:, 0]], axis=1)
                else:
                    v[on] = np.cross(np.array(rv.angular_velocity), r)
                if rv.translation is not None:
                    v[on] += np.array(rv.translation)
            elif body.velocity is not None:
                v[on] = np.array(body.velocity)
        seeds.append(ParticleSeed(xs, v, vol[sel], mat, own.astype(np.int64)))
    deformable, rigid = seeds
    if len(deformable.x) == 0 and not any(b.discretization == "fem" for b in deck.bodies):
        raise_at([(("bodies",), "no body made of a deformable material holds any particle")], loaded)
    empty = [(("loads", i, "region"), "holds no particle centre of a deformable material")
             for i, load in enumerate(deck.loads)
             if not np.all((deformable.x >= load.region.min) & (deformable.x <= load.region.max), axis=1).any()]
    if empty:
        raise_at(empty, loaded)
    return grid, deformable, rigid, 0.5 * spacing, notices, seedings


@dataclass
class Seeding:
    """How a particle body is filled: `how` (lattice, rings, rings_half_step, shells), whether
    the deck left it to `auto`, and why (what `mpmsim check` prints)."""

    how: str
    auto: bool
    why: str = ""


def resolve_seedings(deck, mats: MaterialTable, particle_bodies: list, h: np.ndarray) -> dict[int, Seeding]:
    """Each particle body's seeding (deck index -> Seeding). `auto` (a round body's default)
    follows the surface (rings_half_step in 2D, shells for a sphere) where grid contact acts and
    the body can be so seeded; the lattice otherwise (docs/contact.md, "The staircase is the
    error"). Overlaps with other bodies are found after seeding (build_particles)."""
    contact = None
    out = {}
    for i, body in particle_bodies:
        how = getattr(body, "seeding", "lattice")
        if how != "auto":
            out[i] = Seeding(how, False)
            continue
        if contact is None:
            contact = "the implicit step's contact is not grid contact" if deck.integrator == "implicit" else (
                "" if build_contact_model(deck, mats).grid is not None else "no grid contact in the scene")
        surface = "shells" if body.shape == "sphere" else "rings_half_step"
        why = contact or ("laid over another body (overwrites)" if getattr(body, "overwrites", False) else None)
        if not why:
            why = _shells_problem(body, deck.dim, h) if surface == "shells" else _rings_problem(body, deck.dim, h, True)
        out[i] = Seeding("lattice", True, f"auto: {why}") if why else Seeding(
            surface, True, "auto: grid contact acts on it")
    return out


def _seed_bodies(loaded, particle_bodies, boxes, seedings, grid, spacing, n_lat):
    """Particles of each body as its seeding says: (lattice keys (ring particles -1, -2, ...),
    owning body, material names, positions, volumes, ring-seeded count), lists per body."""
    deck, base, dim = loaded.deck, loaded.base_dir, loaded.deck.dim
    h = spacing * deck.particles_per_direction
    keys, owners, mat_names, where, vols = [], [], [], [], []
    lattice_vol = np.prod(spacing) * (deck.thickness if dim == 2 else 1.0)
    problems = []
    n_rings = 0  # ring-seeded particles so far: their keys are -1, -2, ... (no lattice site)
    for (i, body), (blo, bhi) in zip(particle_bodies, boxes):
        seeding = seedings[i].how
        if seeding in SURFACE_SEEDINGS:
            problem = (_shells_problem(body, dim, h) if seeding == "shells"
                       else _rings_problem(body, dim, h, seeding == "rings_half_step"))
            if problem:
                problems.append((("bodies", i, "seeding"), problem))
                continue
            if seeding == "shells":
                pts, vol = shell_seed(body.center, body.radius, float(spacing[0]))
            else:
                r_in = body.inner_radius if body.shape == "annulus" else 0.0
                r_out = body.outer_radius if body.shape == "annulus" else body.radius
                pts, vol = ring_seed(body.center, r_in, r_out, float(spacing[0]), deck.thickness,
                                     half_step=seeding == "rings_half_step", quarters=body.clip is not None)
            if body.clip is not None:  # (planes through the centre between sectors, or missing the body)
                keep = np.all((pts >= np.asarray(body.clip.min)[:dim]) & (pts <= np.asarray(body.clip.max)[:dim]), axis=1)
                pts, vol = pts[keep], vol[keep]
            if np.any((pts < grid.domain_lo) | (pts > grid.domain_hi)):
                who = f"body '{body.name}'" if body.name else "the body"
                problems.append((("bodies", i), f"{who} extends outside grid.domain; enlarge grid.domain or move the body"))
                continue
            keys.append(-1 - n_rings - np.arange(len(pts)))
            n_rings += len(pts)
            owners.append(np.full(len(pts), i))
            mat_names.append(np.full(len(pts), body.material, dtype=object))
            where.append(pts)
            vols.append(vol)
            continue
        klo = np.maximum(np.floor((blo - grid.origin) / spacing - 0.5).astype(int), 0)
        khi = np.minimum(np.ceil((bhi - grid.origin) / spacing - 0.5).astype(int), n_lat - 1)
        if np.any(khi < klo):
            problems.append((("bodies", i), "lies outside the grid"))
            continue
        axes = [np.arange(klo[a], khi[a] + 1) for a in range(dim)]
        k = np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=1)
        pts = grid.origin + (k + 0.5) * spacing
        sel = inside(body, pts, base)
        if body.clip is not None:
            sel &= np.all((pts >= np.asarray(body.clip.min)) & (pts <= np.asarray(body.clip.max)), axis=1)
        if not sel.any():
            what = f"the mesh {base / body.file} " if body.shape == "mesh" else ""
            problems.append((("bodies", i), f"{what}holds no particle centre: it is smaller than the "
                                            f"particle spacing {spacing.min():g} or misplaced"))
            continue
        k, pts = k[sel], pts[sel]
        outside = np.any((pts < grid.domain_lo) | (pts > grid.domain_hi), axis=1)
        if outside.any():  # say where and by how much (the shape's bounding box against the domain)
            lo, hi = np.asarray(blo)[:dim], np.asarray(bhi)[:dim]
            sides = [f"{grid.domain_lo[a] - lo[a]:.4g} below the domain's {'xyz'[a]}min = {grid.domain_lo[a]:g}"
                     for a in range(dim) if lo[a] < grid.domain_lo[a]]
            sides += [f"{hi[a] - grid.domain_hi[a]:.4g} beyond its {'xyz'[a]}max = {grid.domain_hi[a]:g}"
                      for a in range(dim) if hi[a] > grid.domain_hi[a]]
            who = f"body '{body.name}'" if body.name else "the body"
            problems.append((("bodies", i), f"{who} extends outside grid.domain: {', '.join(sides)}; enlarge "
                                            "grid.domain or move the body"))
            continue
        flat = k[:, 0] + n_lat[0] * (k[:, 1] + (n_lat[1] * k[:, 2] if dim == 3 else 0))
        cls = body_materials(body, pts, base)
        names = [e.material for e in body.map] if isinstance(body, Image) else [body.material]
        keys.append(flat)
        owners.append(np.full(len(flat), i))
        mat_names.append(np.array(names, dtype=object)[cls])
        where.append(pts)
        vols.append(np.full(len(flat), lattice_vol))
    if problems:
        raise_at(problems, loaded)
    return keys, owners, mat_names, where, vols, n_rings


def _clip_problem(body, r: float, axes: str, cuts: str, what: str) -> tuple[str | None, bool]:
    """(why the clip of a round body of radius r seeded around its centre cannot be kept, or
    None; whether a clip line or plane passes through the centre). Each side of the clip box must
    miss the body or pass through its centre, the latter only along the axes in `cuts`."""
    c = np.asarray(body.center, float)
    lo, hi = np.asarray(body.clip.min, float), np.asarray(body.clip.max, float)
    tol = 1e-9 * r
    through = False
    for a, name in enumerate(axes):
        on_lo, on_hi = abs(lo[a] - c[a]) <= tol and name in cuts, abs(hi[a] - c[a]) <= tol and name in cuts
        through = through or on_lo or on_hi
        if not ((lo[a] <= c[a] - r or on_lo) and (hi[a] >= c[a] + r or on_hi)):
            return (f"{what} (clip {name} range [{lo[a]:g}, {hi[a]:g}], centre {c[a]:g}, radius {r:g})"), through
    return None, through


def _rings_problem(body, dim: int, h: np.ndarray, half_step: bool) -> str | None:
    """Why a body cannot be seeded in rings (half_step: rings_half_step) (None: it can)."""
    if dim != 2:
        return "rings seed 2D circles and annuli only (not a 3D deck's extruded shape)"
    if h[0] != h[1]:
        return "rings need a grid cell_size that is the same along x and y"
    if body.clip is not None:
        r = float(body.outer_radius if body.shape == "annulus" else body.radius)
        problem, through = _clip_problem(body, r, "xy", "xy", "a body seeded in rings may be clipped only by lines "
                                         "through its centre or lines that miss it")
        if problem:
            return problem
        if through and not half_step:
            return ("rings put particles on the axes through the centre, where the clip cuts: seed a half or "
                    "quarter body with seeding: rings_half_step")
    return None


def _shells_problem(body, dim: int, h: np.ndarray) -> str | None:
    """Why a `seeding: shells` sphere cannot be seeded so (None: it can)."""
    if dim != 3:
        return "shells seed 3D spheres only"
    if np.any(h != h[0]):
        return "shells need a grid cell_size that is the same along x, y and z"
    if body.clip is not None:
        return _clip_problem(body, float(body.radius), "xyz", "xz", "a sphere seeded in shells may be clipped only by "
                             "planes through its centre normal to x or z, or planes that miss it")[0]
    return None


def _rings_overlaps(particle_bodies, base, seedings, where) -> list[tuple[int, str]]:
    """A ring-seeded body takes no part in the lattice's overwriting: each one that overlaps
    another particle body (a particle of either inside the other's shape), as (its deck index,
    the first other body's name)."""
    found = []
    for (i, bi), pi in zip(particle_bodies, where):
        if seedings[i].how not in SURFACE_SEEDINGS:
            continue
        for (j, bj), pj in zip(particle_bodies, where):
            if j != i and (inside(bi, pj, base).any() or _inside_body(bj, pi, base).any()):
                found.append((i, body_name(bj, j)))
                break
    return found


def overwritten(deck, keys: np.ndarray, owners: np.ndarray, keep: np.ndarray) -> list[str]:
    """Where a later body overwrites an earlier one's particles (lattice sites claimed twice):
    one line per (earlier, later) pair with the count, unless the later body says `overwrites`."""
    lost = np.ones(len(keys), bool)
    lost[keep] = False
    if not lost.any():
        return []
    order = np.argsort(keys[keep])
    winner = owners[keep][order][np.searchsorted(keys[keep][order], keys[lost])]
    pairs, counts = np.unique(np.stack([owners[lost], winner], axis=1), axis=0, return_counts=True)
    meant = np.array([deck.bodies[b].overwrites for b in pairs[:, 1]], bool)
    pairs, counts = pairs[~meant], counts[~meant]
    total = np.bincount(owners, minlength=len(deck.bodies))
    return [f"body '{body_name(deck.bodies[a], a)}' loses {n} of its {total[a]} particles to "
            f"'{body_name(deck.bodies[b], b)}' where they overlap (a later body overwrites earlier ones): "
            "separate the shapes if they are meant to meet"
            for (a, b), n in zip(pairs.tolist(), counts.tolist())]


GAP_SAMPLES = 32  # points tested between two neighbouring particle centres of different bodies


def gaps_closed(deck, base, keys, kk, owners, x, spacing, n_lat) -> list[str]:
    """Bodies whose shapes are apart but whose particle domains touch at t = 0: neighbouring
    lattice sites of two bodies with points between their centres inside neither shape. The
    narrowest such stretch estimates the gap where they are closest (to 1/33 of the spacing).
    One line per body pair."""
    dim = x.shape[1]
    order = np.argsort(keys)
    found: dict[tuple[int, int], float] = {}
    stride = np.cumprod(np.r_[1, n_lat[:-1]]).astype(np.int64)
    s = (np.arange(1, GAP_SAMPLES + 1) / (GAP_SAMPLES + 1))[:, None]
    for a in range(dim):
        can = kk[:, a] < n_lat[a] - 1
        nb = keys[can] + stride[a]
        at = np.minimum(np.searchsorted(keys[order], nb), len(keys) - 1)
        hit = keys[order][at] == nb
        i = np.flatnonzero(can)[hit]
        j = order[at[hit]]
        cross = owners[i] != owners[j]
        i, j = i[cross], j[cross]
        for A, B in {(int(p), int(q)) for p, q in zip(owners[i], owners[j])}:
            on = (owners[i] == A) & (owners[j] == B)
            pts = (x[i[on]][None, :, :] * (1 - s[:, :, None]) + x[j[on]][None, :, :] * s[:, :, None]).reshape(-1, dim)
            empty = ~(_inside_body(deck.bodies[A], pts, base) | _inside_body(deck.bodies[B], pts, base))
            counts = empty.reshape(GAP_SAMPLES, -1).sum(axis=0)
            if counts.any():  # the narrowest stretch inside neither shape: the gap where they are closest
                width = counts[counts > 0].min() / (GAP_SAMPLES + 1) * spacing[a]
                key = (min(A, B), max(A, B))
                found[key] = min(found.get(key, np.inf), float(width))
    return [f"bodies '{body_name(deck.bodies[A], A)}' and '{body_name(deck.bodies[B], B)}' are apart (gap about "
            f"{gap:.2g} where closest) but their particles' domains touch at t = 0 (particle spacing {spacing.min():.3g}): the "
            "filling closes the gap and they are in contact from the first step; move them at least one particle "
            "spacing apart, or refine the grid" for (A, B), gap in sorted(found.items())]


def _inside_body(body, pts: np.ndarray, base) -> np.ndarray:
    sel = inside(body, pts, base)
    if body.clip is not None:
        sel &= np.all((pts >= np.asarray(body.clip.min)) & (pts <= np.asarray(body.clip.max)), axis=1)
    return sel

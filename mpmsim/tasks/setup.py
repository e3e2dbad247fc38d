"""Tasks that open a step: choose the time step, evaluate shape functions, find the active box."""

from __future__ import annotations

import numpy as np


def set_time_step(state) -> None:
    """dt from the CFL rule on the current wave speeds (recomputed every step, so a stiffening
    material shortens it), or the deck's fixed dt; never past the end time."""
    deck = state.scene.deck
    if deck.time.dt is not None:
        dt = deck.time.dt
    else:
        cfl = deck.time.cfl if deck.time.cfl is not None else 0.5
        speed = state.wave_max
        if state.n_rigid_materials:
            speed = max(speed, float(np.abs(state.rigid_v_start).max()))
        dt = cfl * float(state.grid.h.min()) / speed
    state.dt_rule = dt
    dt = min(dt, deck.time.end - state.t)
    state.dt = dt
    motions = state.materials.motions
    if motions:
        state.rigid_v_start[:] = [m.velocity(state.t) for m in motions]
        state.rigid_v_end[:] = [m.velocity(state.t + dt) for m in motions]


def compute_shape_functions(state) -> None:
    """Weights of deformable particles (CPDI uses their F) and rigid ones; flags a support
    leaving the grid (the step then stops in check stability)."""
    sf, g = state.shape, state.grid
    semi = state.scene.semi_size
    if state.xref is not state.particles.x:  # APIC keeps the positions its affine terms refer to
        state.xref[:] = state.particles.x
    box, (bad, code) = sf.compute(state.particles.x, state.particles.F, semi, g, state.nchunk, state.sd)
    boxes = [box]
    if bad >= 0:
        state.flags.set(bad, code, 0.0)
    if state.rigid.n:
        rbox, (rbad, rcode) = sf.compute(state.rigid.x, None, semi, g, 1, state.rigid_sd)
        boxes.append(rbox)
        if rbad >= 0:
            state.flags.set_rigid(rbad, rcode)
    state.box.update(boxes, state.sd.lowest, sf.span, state.threads)

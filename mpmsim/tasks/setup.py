"""Tasks that open a step: the time step's prescribed motions, shape functions and the active box."""

from __future__ import annotations

import numpy as np

from ..loads import ramped_gravity


def cfl_rule(fixed_dt: float | None, cfl: float, h_min: float):
    """The explicit step's stable dt: the deck's fixed dt, or cfl h_min / max(c + |v|) on the
    wave speeds of the last stress update (so a stiffening material shortens it), and the
    prescribed rigid speeds."""

    def stable_dt(state) -> float:
        if fixed_dt is not None:
            return fixed_dt
        speed = state.wave_max
        if state.n_rigid_materials:
            speed = max(speed, float(np.abs(state.rigid.v_start).max()))
        return cfl * h_min / speed

    return stable_dt


def prescribed_motion(motions: list):
    """Task "time step": the prescribed rigid velocities at the step's start and end (the run
    loop has set state.dt)."""

    def time_step(state) -> None:
        if motions:
            R = state.rigid
            R.v_start[:] = [m.velocity(state.t) for m in motions]
            R.v_end[:] = [m.velocity(state.t + state.dt) for m in motions]

    return time_step


def gravity_ramp(gravity: np.ndarray, ramp: float):
    """Task "gravity ramp": the step's gravity, the ramp's value at the step's middle. Taken
    there, the velocity it gives a free body is the integral of the ramp exactly (g t^2 /
    (2 ramp) while it grows)."""
    full = np.array(gravity, dtype=np.float64)

    def ramp_gravity(state) -> None:
        state.gravity[:] = ramped_gravity(full, ramp, state.t + 0.5 * state.dt)

    return ramp_gravity


def compute_shape_functions(state) -> None:
    """Weights of deformable particles (CPDI uses their F) and rigid ones; flags a support
    leaving the grid (the step then stops in the stability check)."""
    sf, g, P = state.shape, state.grid, state.particles
    if P.xref is not P.x:  # APIC keeps the positions its affine terms refer to
        P.xref[:] = P.x
    box, (bad, code) = sf.compute(P.x, P.F, P.semi, g, state.nchunk, state.sd)
    boxes = [box]
    if bad >= 0:
        state.flags.set(bad, code, 0.0)
    if state.rigid.n:
        rbox, (rbad, rcode) = sf.compute(state.rigid.x, None, P.semi, g, 1, state.rigid_sd)
        boxes.append(rbox)
        if rbad >= 0:
            state.flags.set_rigid(rbad, rcode)
    state.box.update(boxes, state.sd.lowest, sf.span, state.threads)

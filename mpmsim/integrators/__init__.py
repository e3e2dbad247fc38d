"""Integrators: how a step advances the state. The run loop (mpmsim/solver.py) talks to every
integrator through this small interface and knows nothing else of the method:

    stable_dt(state) -> float     the step the method allows now (the loop cuts it at time.end)
    advance(state, dt) -> float   take one step of at most dt; return the step taken
    timers -> {name: seconds}     where the stepping time went (the run's timing table)
    plan -> [(name, why)], skipped -> [(name, why not)]   what a step does (`mpmsim check`)

Before `advance` the loop has set `state.dt` (= dt) and `state.dt_rule` (the uncut stable
step) and cleared `state.flags`; after it, the loop checks stability, advances the clock and
writes history and output. An integrator may read and change any state array; it must
leave the state consistent at the end of `advance` (positions, velocities and stresses at
t + dt).

Integrators: `explicit` (explicit MPM and FEM, the step as a task list; explicit.py) and
`implicit` (FEM bodies, incremental potential and barrier contact; implicit.py). A new method
is a new class here and an entry in `make_integrator`.
"""

from __future__ import annotations


from .base import Integrator

__all__ = ["Integrator", "make_integrator"]


def make_integrator(scene, device: str = "cpu") -> Integrator:
    """The deck's integrator for this scene; `device="cuda"`: the explicit MPM step on the GPU
    (mpmsim/gpu: the caller has checked the scene with mpmsim.gpu.unsupported)."""
    from .explicit import ExplicitMPM
    from .implicit import ImplicitStep

    if device != "cpu":
        return ExplicitMPM(scene, device=device)
    kinds = {"explicit": ExplicitMPM, "implicit": ImplicitStep}
    return kinds[scene.settings.integrator](scene)

"""The interface every integrator implements (the package docstring describes it)."""

from __future__ import annotations


class Integrator:
    name = "integrator"

    def __init__(self):
        self.timers: dict[str, float] = {}
        self.plan: list[tuple[str, str]] = []
        self.skipped: list[tuple[str, str]] = []

    def stable_dt(self, state) -> float:  # pragma: no cover - every integrator defines it
        raise NotImplementedError

    def advance(self, state, dt: float) -> float:  # pragma: no cover
        raise NotImplementedError

    def dry_parts(self, state) -> list:
        """The step in parts, each a call (mpmsim/compile_ahead.py runs them dry in a helper
        process to learn the kernels a first step compiles; one that stops ends only itself):
        here the whole advance as one part."""
        return [lambda: self.advance(state, state.dt)]

    def to_host(self, state) -> None:
        """Bring the host state up to date before it is read (an integrator that keeps the
        state on a device copies it back here; the CPU integrators have nothing to do)."""

    def host_changed(self, state) -> None:
        """The host state was replaced from outside (a restart): a device copy is stale."""

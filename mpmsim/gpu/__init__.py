"""The explicit MPM step on one NVIDIA GPU (numba-cuda: `pip install mpmsim[cuda]`).

`mpmsim run DECK --device cuda`, `Simulation(..., device="cuda")`. What runs there: single
material 2D and 3D particle scenes (several materials sharing one velocity field too) and
multimaterial grid contact (material fields, every normal method and separation, laws stick,
frictionless and Coulomb, passes 1 to 3: mpmsim/gpu/contact.py), shape functions linear, gimp
(uGIMP) and bspline2; update schemes FLIP, PIC and APIC with either
position form; stress updates USF, USL and USAVG (with or without re-extrapolation); linear
elastic and neo-Hookean materials; rigid materials; fixed and roller grid faces; gravity; grid damping.
Everything else a deck may ask for is refused by `unsupported` with the key that asks for it
(`mpmsim check --device cuda` and `run --device cuda` exit 2 with that line), never run on
the CPU in its place.

This module imports no CUDA: numba.cuda is imported only when a device run is built
(mpmsim/gpu/step.py), so the CPU path's start-up time is unchanged.
"""

from __future__ import annotations

DEVICES = ("cpu", "cuda")
SHAPES = ("linear", "gimp", "bspline2")
SCHEMES = ("flip", "pic", "apic")
MODELS = ("linear_elastic", "neo_hookean")


class DeviceError(Exception):
    """The device asked for cannot be used here (no numba-cuda, no driver): one line."""


def unsupported(scene) -> list[tuple[tuple, str]]:
    """[(deck key path, why)] of what the scene asks for that the CUDA step does not do yet."""
    deck, run = scene.deck, scene.settings
    out: list[tuple[tuple, str]] = []
    later = "is not on the GPU yet (run it without --device cuda)"
    if deck.integrator != "explicit":
        out.append((("integrator",), f"integrator {deck.integrator} {later}"))
    if deck.analysis == "axisymmetric":
        out.append((("analysis",), f"axisymmetric analysis {later}"))
    if scene.fem is not None:
        out.append((("bodies",), f"FEM bodies (discretization: fem) {later}"))
    if deck.shape_function not in SHAPES:
        out.append((("shape_function",), f"shape_function {deck.shape_function} {later}; on the GPU: "
                    + ", ".join(SHAPES)))
    if deck.update.scheme not in SCHEMES:
        out.append((("update", "scheme"), f"update.scheme {deck.update.scheme} {later}; on the GPU: "
                    + ", ".join(SCHEMES)))
    if scene.contact.grid is not None:
        out += _contact_unsupported(scene, later)
    if scene.contact.augury is not None:
        out.append((("contact", "augury"), f"augury contact {later}"))
    for name, m in deck.materials.items():
        if m.type != "rigid" and m.type not in MODELS:
            out.append((("materials", name, "type"), f"material model {m.type} {later}; on the GPU: "
                        + ", ".join(MODELS)))
    if deck.artificial_viscosity is not None:
        out.append((("artificial_viscosity",), f"artificial viscosity {later}"))
    if deck.loads:
        out.append((("loads",), f"traction loads {later}"))
    if deck.gravity_ramp > 0.0:
        out.append((("gravity_ramp",), f"a gravity ramp {later}"))
    if deck.output.energy_ledger:
        out.append((("output", "energy_ledger"), f"the energy ledger {later}"))
    return out


def _contact_unsupported(scene, later: str) -> list[tuple[tuple, str]]:
    """What of the grid contact (mpmsim/gpu/contact.py) the GPU step does not do yet."""
    from ..contact.grid.spec import FIRST_PLUGIN_LAW, INTERFACE, LAW_CODES

    deck, spec = scene.deck, scene.contact.grid
    out: list[tuple[tuple, str]] = []
    for name in scene.materials.rigid:
        if getattr(deck.materials[name], "mode", None) == "contact":
            out.append((("materials", name, "mode"), f"rigid contact materials (mode: contact) {later}"))
    model = scene.contact  # (the resolved contact block: its pairs in deck order)
    laws = [(("contact", "default", "law"), model.default.law)]
    laws += [(("contact", "pairs", i, "law"), law.law) for i, (_, _, law) in enumerate(model.pairs)]
    for key, law in laws:
        code = LAW_CODES[law]
        if code == INTERFACE or code >= FIRST_PLUGIN_LAW:
            kind = "interface" if code == INTERFACE else "plugin"
            out.append((key, f"contact law {law} ({kind} laws) {later}; on the GPU: stick, frictionless, coulomb, "
                        "none"))
    if spec.warm_start:
        out.append((("contact", "warm_start"), f"contact.warm_start {later}"))
    if spec.traction:
        out.append((("output", "contact_traction"), f"output.contact_traction {later}"))
    return out


def require_cuda() -> None:
    """Raise DeviceError (one line) unless numba-cuda is installed and a CUDA driver, or the
    simulator (NUMBA_ENABLE_CUDASIM=1), is there."""
    try:
        from numba import cuda
    except ImportError:  # pragma: no cover - numba without its CUDA target
        raise DeviceError("--device cuda needs numba-cuda: pip install 'mpmsim[cuda]'") from None
    if not _has_numba_cuda():
        raise DeviceError("--device cuda needs numba-cuda: pip install 'mpmsim[cuda]'")
    if not cuda.is_available():
        raise DeviceError("--device cuda: no CUDA driver or GPU found on this machine (numba.cuda.is_available() "
                          "is false; NUMBA_ENABLE_CUDASIM=1 runs numba's CUDA simulator, slowly)")


def _has_numba_cuda() -> bool:
    from importlib.util import find_spec

    return find_spec("numba_cuda") is not None

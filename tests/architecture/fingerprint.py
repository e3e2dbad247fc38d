"""Bit-level fingerprints of short runs: every deck in inputs/ and method variants of a few.

Each case runs a fixed number of steps on one thread (fixed chunking, so reductions add in a
fixed order; implicit decks solve with mpmsim's own LDL^T, which calls no BLAS), recording the
history after every step. The fingerprint is a SHA-256 of the
history rows and of every final particle array, plus the last history row in full (hex
floats) so a mismatch shows its size. `python -m tests.architecture.fingerprint` rewrites
the stored reference; do that only for a change meant to alter results, and say so.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import yaml

from mpmsim.deck.overrides import with_overrides

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = Path(__file__).with_name("reference.json")
STEPS = 25
FEM_STEPS = 12

# method variants over scenes that cover them: (case name, deck, overrides)
VARIANTS = [
    ("two_blocks/avg", "two_blocks", {"contact.normal": "average_gradient"}),
    ("two_blocks/maxgrad", "two_blocks", {"contact.normal": "max_gradient"}),
    ("two_blocks/maxvol", "two_blocks", {"contact.normal": "max_volume"}),
    ("two_blocks/linreg", "two_blocks", {"contact.normal": "linear_regression"}),
    ("two_blocks/specified", "two_blocks", {"contact.normal": "specified", "contact.normal_vector": [0.0, 1.0]}),
    ("two_blocks/avg-cutoff", "two_blocks", {"contact.normal": "average_gradient", "contact.separation": "cutoff"}),
    ("two_blocks/avg-fit", "two_blocks", {"contact.normal": "average_gradient", "contact.separation": "fit"}),
    ("two_blocks/avg-velocity", "two_blocks", {"contact.normal": "average_gradient", "contact.separation": "velocity"}),
    ("two_blocks/lr-displacement", "two_blocks", {"contact.separation": "displacement"}),
    ("two_blocks/once", "two_blocks", {"contact.passes": 1}),
    ("two_blocks/shape-weights", "two_blocks", {"contact.cloud_weights": "shape_function"}),
    ("two_blocks/recheck", "two_blocks", {"contact.pass_3": "recheck"}),
    ("two_blocks/keep", "two_blocks", {"contact.pass_3": "keep"}),
    ("two_blocks/stick", "two_blocks", {"contact.default": {"law": "stick"}}),
    ("two_blocks/frictionless", "two_blocks", {"contact.default": {"law": "frictionless"}}),
    ("two_blocks/xpic3", "two_blocks", {"update": {"scheme": "xpic", "order": 3, "stress": "usavg"}}),
    ("two_blocks/xpic3-uncorrected", "two_blocks", {"update": {"scheme": "xpic", "order": 3, "stress": "usavg"},
                                                    "contact.xpic_contact_term": False}),
    ("two_blocks/fmpm2", "two_blocks", {"update": {"scheme": "fmpm", "order": 2, "stress": "usavg"}}),
    ("two_blocks/apic", "two_blocks", {"update": {"scheme": "apic", "stress": "usavg"}}),
    ("two_blocks/pic-usf", "two_blocks", {"update": {"scheme": "pic", "stress": "usf"}}),
    ("two_blocks/flip-usl", "two_blocks", {"update": {"scheme": "flip", "stress": "usl"}}),
    ("two_blocks/flip-usavg-", "two_blocks", {"update": {"scheme": "flip", "stress": "usavg", "reextrapolate": False}}),
    ("two_blocks/linear", "two_blocks", {"shape_function": "linear"}),
    ("two_blocks/cpdi", "two_blocks", {"shape_function": "cpdi"}),
    ("two_blocks/cpdi_q", "two_blocks", {"shape_function": "cpdi_q"}),
    ("two_blocks/bspline2", "two_blocks", {"shape_function": "bspline2"}),
    ("two_blocks/bspline3", "two_blocks", {"shape_function": "bspline3"}),
    ("two_blocks/b2cpdi", "two_blocks", {"shape_function": "b2cpdi"}),
    ("two_blocks_3d/xpic3", "two_blocks_3d", {"update": {"scheme": "xpic", "order": 3, "stress": "usavg"}}),
    ("two_blocks_3d/avg", "two_blocks_3d", {"contact.normal": "average_gradient"}),
    ("disks/apic", "disks", {"update": {"scheme": "apic", "stress": "usavg"}}),
    ("column/xpic5-bspline2", "column", {"shape_function": "bspline2",
                                          "update": {"scheme": "xpic", "order": 5, "stress": "usavg"}}),
    ("two_layer/nodal-bond", "two_layer", {"contact.interface_bond": "nodal"}),
    ("two_layer/oscillator", "two_layer", {"contact.interface_integration": "oscillator"}),
    # the paper's Fig. 6 settings (the deck uses PIC and a velocity-condition piston): XPIC(5)
    # with 20 materials against a rigid contact piston
    ("ellipse_box/xpic5-contact-piston", "ellipse_box", {
        "update": {"scheme": "xpic", "order": 5, "stress": "usavg"},
        "materials.piston": {"type": "rigid", "mode": "contact", "velocity": [0.0, -100.0]},
        "stability.energy_tolerance": 0.25}),
]


def particle_decks() -> list[str]:
    """The decks of inputs/ whose bodies are all particle bodies, run by the explicit step."""
    return [d for d, fem in _decks() if not fem]


def fem_decks() -> list[str]:
    """The decks of inputs/ with FEM bodies or the implicit integrator (fewer steps: an
    implicit step is a Newton solve)."""
    return [d for d, fem in _decks() if fem]


def _decks() -> list[tuple[str, bool]]:
    out = []
    for p in sorted((ROOT / "inputs").glob("*.yaml")):
        data = yaml.safe_load(p.read_text())
        bodies = data.get("bodies") or []
        fem = data.get("integrator", "explicit") != "explicit" or any(
            b.get("discretization", "particles") != "particles" for b in bodies)
        out.append((p.stem, fem))
    return out


def cases() -> list[tuple[str, str, dict]]:
    return [(d, d, {}) for d in particle_decks()] + [(d, d, {}) for d in fem_decks()] + VARIANTS


def steps_of(name: str) -> int:
    """Steps a new case records: FEM and implicit decks run FEM_STEPS."""
    return FEM_STEPS if name in fem_decks() else STEPS


def _digest(a) -> str:
    a = np.ascontiguousarray(np.asarray(a))
    h = hashlib.sha256()
    h.update(str(a.dtype).encode() + str(a.shape).encode())
    h.update(a.tobytes())
    return h.hexdigest()[:20]


def run_case(deck: str, overrides: dict, steps: int = STEPS, columns: list[str] | None = None):
    """The finished simulation after `steps` steps (one thread), and its history rows (only
    `columns`, in that order, when given: the history may have grown columns since; all but
    wall_s otherwise)."""
    from tests.conftest import deck_from
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    data = yaml.safe_load((ROOT / "inputs" / f"{deck}.yaml").read_text())
    data = with_overrides(data, overrides)
    if data.get("integrator") == "implicit":  # mpmsim's own LDL^T: no BLAS, the same bits on every CPU
        data = with_overrides(data, {"implicit.linear_solver": "ldl"})  # (CHOLMOD is an extra; SuperLU calls BLAS)
    sim = Simulation(build_scene(deck_from(data, ROOT / "inputs", deck)), out_dir=None, threads=1)
    for _ in range(steps):
        sim.step()
        sim.recorder.record(sim.state)
    rows = np.array(sim.recorder.rows, dtype=float)
    names = sim.recorder.names
    if columns is None:  # all but the wall clock, which no rerun reproduces
        columns = [n for n in names if n != "wall_s"]
    rows = rows[:, [names.index(current_name(c)) for c in columns]]
    return sim, rows


def current_name(column: str) -> str:
    """The history's name of a reference column (a material's stress, recorded as syy@m, is syy_mat_m)."""
    stress, at, material = column.partition("@")
    return f"{stress}_mat_{material}" if at else column


def arrays(sim) -> dict[str, np.ndarray]:
    """The final state arrays that a change of results would show in."""
    st = sim.state
    P, R = st.particles, st.rigid
    out = {f"particles.{k}": getattr(P, k) for k in ("x", "v", "F", "stress", "vol", "mass")}
    for k in ("B", "U", "pressure", "q"):  # only where the scene carries them
        if len(getattr(P, k)) == P.n:
            out[f"particles.{k}"] = getattr(P, k)
    if R.n:
        out["rigid.x"], out["rigid.v"] = R.x, R.v
    if st.fem is not None:
        for k in ("x", "v", "a", "a_contact", "B", "contact_work"):
            out[f"fem.{k}"] = getattr(st.fem, k)
    out["reaction"] = st.reaction
    out["work_in"] = np.array([st.work_in, st.interface_energy])
    return out


def fingerprint(deck: str, overrides: dict, steps: int = STEPS, columns: list[str] | None = None) -> dict:
    sim, rows = run_case(deck, overrides, steps, columns)
    names = columns if columns is not None else [n for n in sim.recorder.names if n != "wall_s"]
    return {"steps": steps, "columns": names, "history": _digest(rows),
            "last_row": [float(v).hex() for v in rows[-1]],
            "arrays": {k: _digest(v) for k, v in sorted(arrays(sim).items())}}


def main(argv: list[str]) -> None:
    want = set(argv)
    ref = json.loads(REFERENCE.read_text()) if REFERENCE.exists() else {}
    for name, deck, overrides in cases():
        if want and name not in want:
            continue
        kept = ref.get(name, {})  # a case keeps its step count and history columns
        ref[name] = fingerprint(deck, overrides, kept.get("steps", steps_of(name)), kept.get("columns"))
        print(name, ref[name]["history"], flush=True)
    REFERENCE.write_text(json.dumps(ref, indent=1, sort_keys=True) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])

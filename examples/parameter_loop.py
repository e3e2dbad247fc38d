"""A parameter loop from Python: the rubber disk of docs/tutorial.md dropped on blocks of
three stiffnesses. Each deck is the YAML file's mapping with one value changed; each run keeps
its history in memory (no files); the coefficient of restitution of each goes into a table
and a plot (restitution.png in the current folder).

    python examples/parameter_loop.py
"""

from __future__ import annotations

import copy
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no screen needed
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
import yaml  # noqa: E402

import mpmsim  # noqa: E402

base = yaml.safe_load((Path(__file__).parent / "disk_on_block.yaml").read_text())
rows = []
for E in (0.5e7, 1.0e7, 4.0e7):
    deck = copy.deepcopy(base)
    deck["materials"]["block"]["E"] = E
    sim = mpmsim.Simulation.from_deck(deck, name=f"block_{E:.0e}")
    sim.run()
    h = sim.history  # a pandas DataFrame, one row per history time
    p0, p1 = h.py_disk.iloc[0], h.py_disk.iloc[-1]
    rows.append({"E_block": E, "steps": int(h.step.iloc[-1]), "restitution": -p1 / p0,
                 "max_strain_energy": h.strain_energy.max(), "disk_particles": int((sim.particles["material"] == "rubber").sum())})

table = pd.DataFrame(rows)
print(table.to_string(index=False))

fig, ax = plt.subplots(figsize=(5, 3.5))
ax.semilogx(table.E_block, table.restitution, "o-")
ax.set_xlabel("block Young's modulus (Pa)")
ax.set_ylabel("coefficient of restitution")
fig.tight_layout()
fig.savefig("restitution.png", dpi=120)

"""Contact, one package per family; each reads its settings from the scene's contact model
(mpmsim/scene/contact.py: one law per material pair and each family's own settings).

- `grid/`: multi-velocity grid contact of particle bodies (the LR paper): material fields
  where groups meet, normals and separations, the contact passes, the laws and imperfect
  interfaces. Tasks of the explicit step (`ContactTasks`).
- `augury/`: APIC augury contact of FEM bodies with each other and with particle bodies'
  surface particles. A task of the explicit step (`AuguryContact`).
- `barrier/`: barrier contact of the implicit step (BFEMP): distances, barrier, lagged
  friction, CCD, the inversion bound, broad phase; an energy term of the incremental
  potential.

docs/architecture.md says how a new family or law plugs in.
"""

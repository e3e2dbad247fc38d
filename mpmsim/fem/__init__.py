"""Finite element core for FEM bodies: linear triangles (2D plane strain) and linear
tetrahedra (3D).

Modules (plain arrays in, plain arrays out; the per-step work is numba kernels):
  mesh      FemMesh (points, positively oriented cells, outward facets, boundary nodes, node
            sets), generators (rectangle, box, disk, ring), transforms, read_mesh (meshio)
  elements  reference geometry, deformation gradients, compressible neo-Hookean and linear
            elastic energy / first Piola stress / tangent, element energies, internal forces,
            local Hessians (optionally projected to PSD), Cauchy stress, stable time step,
            lumped masses
  explicit  velocity-Verlet pieces on nodes with per-component constraints and gravity

The FEM energy is the one of the BFEMP paper (shared/papers/bfemp-barrier-mpm-fem.txt):
Psi_FEM = sum_e vol0_e psi(F_e), F_e = D_s D_m^-1; the explicit scheme is the velocity Verlet
of the APIC augury contact paper (shared/papers/apic-augury-contact.txt).
"""

from .mesh import FemMesh, MeshError, box, disk, read_mesh, rectangle, ring, transformed

__all__ = ["FemMesh", "MeshError", "box", "disk", "read_mesh", "rectangle", "ring", "transformed"]

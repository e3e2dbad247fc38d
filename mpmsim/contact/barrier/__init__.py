"""Barrier (IPC-style) contact primitives for the implicit MPM-FEM coupling (BFEMP).

BFEMP: implicit MPM + FEM coupled through barrier contact between MPM particles and FEM
boundary edges (shared/papers/bfemp-barrier-mpm-fem.txt; implementation notes, "BFEMP"), built
on Incremental Potential Contact (Li et al. 2020, doi:10.1145/3386569.3392425) and its additive
CCD (Li, Kaufman & Jiang 2021, doi:10.1145/3450626.3459767).

Modules (numba kernels over plain arrays, with one interface in 2D and 3D: a distance type,
then value, gradient and Hessian on the stacked coordinate vector of the pair):
  distance    2D point-point / point-edge distances (unsigned and squared), types, derivatives,
              closest-point parameter and tangents
  closest     3D point-triangle and edge-edge distances as closest-point problems (one formula
              for every type: the implicit function theorem at the closest points)
  potential   b(d) = -kappa dhat (u - 1)^2 ln u and the pair energies with gradient/Hessian;
              IPC's edge-edge mollifier for nearly parallel edges
  (PSD projection of the local Hessians: mpmsim.fem.elements.project_psd, LAPACK eigh)
  friction    smoothed friction mollifier f0/f1/f2 and the lagged friction pseudo-potential
  ccd         additive CCD (eta = 0.1) for point-edge and point-point linear motion (2D) and
              point-triangle and edge-edge (3D)
  inversion   largest step keeping det(A + alpha B) >= 0.1 det A (2x2, 3x3)
  broadphase  swept-box candidate pairs from a uniform-grid hash; boundary-node correction
  energy      the 2D energy terms of the implicit step: barrier contact (points against FEM boundary
              edges) and its lagged friction; start-up gap and overlap checks
  surface     the 3D terms: points against FEM boundary triangles (the paper's (deg - 1) edge and
              interior-vertex corrections, one PSD projection per point) and their friction
  stiffness   the adaptive barrier stiffness (IPC's rule in this distance form)
"""

from .broadphase import (boundary_vertex_degree, box_pairs, correction_nodes, point_boxes, point_edge_candidates,
                         point_node_candidates, simplex_boxes)
from .ccd import (CCD_ETA, edge_edge_ccd, point_edge_ccd, point_edge_ccd_pairs, point_edge_separation_bound,
                  point_point_ccd, point_triangle_ccd)
from .closest import (edge_edge_distance2, edge_edge_distance2_hessian, edge_edge_distance_hessian,
                      edge_edge_distance_type, point_triangle_distance, point_triangle_distance2,
                      point_triangle_distance2_hessian, point_triangle_distance_hessian, point_triangle_distance_type)
from .distance import (PE_P_E, PE_P_E0, PE_P_E1, point_edge_closest_param, point_edge_distance, point_edge_distance2,
                       point_edge_distance_gradient, point_edge_distance_hessian, point_edge_distance_type,
                       point_edge_friction_frame, point_edge_tangent, point_line_signed_distance_hessian,
                       point_point_distance, point_point_distance2_hessian, point_point_distance_gradient,
                       point_point_distance_hessian)
from .friction import (friction_f0, friction_f1, friction_f1_over_y, friction_f2, friction_f2_y_minus_f1_over_y3,
                       lagged_friction, point_edge_friction, point_edge_friction_operator,
                       point_point_friction_operator)
from .inversion import (DET_FRACTION, det_step_bound, det_step_bound_2x2, det_step_bound_3x3, first_nonpositive_in_unit,
                        triangle_step_bound)
from .potential import (barrier, barrier_first_derivative, barrier_normal_force, barrier_second_derivative,
                        edge_edge_barrier, edge_edge_cross2_hessian, edge_edge_mollifier, edge_edge_mollifier_threshold,
                        mollified_edge_edge_barrier, point_edge_barrier, point_edge_barrier_pairs, point_point_barrier,
                        point_triangle_barrier)
from ...fem.elements import project_psd

__all__ = [
    "CCD_ETA", "DET_FRACTION", "PE_P_E", "PE_P_E0", "PE_P_E1",
    "barrier", "barrier_first_derivative", "barrier_normal_force", "barrier_second_derivative",
    "boundary_vertex_degree", "box_pairs", "correction_nodes", "det_step_bound", "det_step_bound_2x2",
    "det_step_bound_3x3", "edge_edge_barrier", "edge_edge_ccd", "edge_edge_cross2_hessian", "edge_edge_distance2", "edge_edge_distance2_hessian",
    "edge_edge_distance_hessian", "edge_edge_distance_type", "edge_edge_mollifier", "edge_edge_mollifier_threshold",
    "first_nonpositive_in_unit", "mollified_edge_edge_barrier", "friction_f0",
    "friction_f1", "friction_f1_over_y",
    "friction_f2", "friction_f2_y_minus_f1_over_y3", "lagged_friction", "point_boxes", "point_edge_barrier",
    "point_edge_barrier_pairs", "point_edge_candidates", "point_edge_ccd", "point_edge_ccd_pairs",
    "point_edge_closest_param", "point_edge_distance", "point_edge_distance2",
    "point_edge_distance_gradient", "point_edge_distance_hessian",
    "point_edge_distance_type", "point_edge_friction", "point_edge_friction_frame", "point_edge_friction_operator",
    "point_edge_separation_bound", "point_edge_tangent", "point_line_signed_distance_hessian",
    "point_node_candidates", "point_point_barrier", "point_point_ccd", "point_point_distance",
    "point_point_distance2_hessian", "point_point_distance_gradient", "point_point_distance_hessian",
    "point_point_friction_operator", "point_triangle_barrier", "point_triangle_ccd", "point_triangle_distance",
    "point_triangle_distance2", "point_triangle_distance2_hessian", "point_triangle_distance_hessian",
    "point_triangle_distance_type", "project_psd", "simplex_boxes", "triangle_step_bound",
]

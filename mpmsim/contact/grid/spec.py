"""What the grid contact kernels need, as the scene resolves it (mpmsim/scene/contact.py):
material groups, a group law table, and method codes.

A *group* is one velocity field. Deformable materials joined by law `none` (perfect
interface, "the same body") form one group; every rigid contact material is a group of its
own. Contact work happens only where two or more groups meet.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

STICK, FRICTIONLESS, COULOMB, INTERFACE = 0, 1, 2, 3
LAW_CODES = {"stick": STICK, "frictionless": FRICTIONLESS, "coulomb": COULOMB, "none": STICK, "interface": INTERFACE,
             "cohesive": INTERFACE}
BUILT_IN_LAWS = tuple(LAW_CODES)
FIRST_PLUGIN_LAW = 16  # codes of laws registered outside mpmsim (contact/grid/laws.register_law)
PERFECT = -1.0  # interface stiffness code for a perfect direction
# a sliver of mass: a field that only the far edge of a particle's shape function reaches
# (mass ~ S, force ~ grad S) has a velocity that is round-off over a vanishing mass. Below this
# fraction of the mass it is compared with, an interface target is held bonded (pass 2) and the
# energy ledger leaves the field out of its accounts
SLIVER = 1e-12
OSCILLATOR, FORCE_LIMIT, FIRST_ORDER, TRAPEZOIDAL, BACKWARD_EULER = 0, 1, 2, 3, 4
INTEGRATION_CODES = {"oscillator": OSCILLATOR, "force_limit": FORCE_LIMIT, "first_order": FIRST_ORDER,
                     "trapezoidal": TRAPEZOIDAL, "backward_euler": BACKWARD_EULER}

LOGISTIC, LINEAR_REGRESSION, AVERAGE_GRADIENT, MAX_GRADIENT, MAX_VOLUME, SPECIFIED = range(6)
NORMAL_CODES = {"logistic_regression": LOGISTIC, "linear_regression": LINEAR_REGRESSION,
                "average_gradient": AVERAGE_GRADIENT, "max_gradient": MAX_GRADIENT, "max_volume": MAX_VOLUME,
                "specified": SPECIFIED}
SEP_LR, SEP_DISPLACEMENT, SEP_CUTOFF, SEP_FIT, SEP_VELOCITY = range(5)
SEPARATION_CODES = {"logistic_regression": SEP_LR, "displacement": SEP_DISPLACEMENT, "cutoff": SEP_CUTOFF,
                    "fit": SEP_FIT, "velocity": SEP_VELOCITY}


class PairLaws(NamedTuple):
    """Group-by-group tables of the contact laws."""

    law: np.ndarray  # (G, G) law code
    mu: np.ndarray  # (G, G) kinetic friction
    mus: np.ndarray  # (G, G) static friction, -1 when not given
    stiffness: np.ndarray  # (G, G, 3) interface [Dn tension, Dn compression, Dt], PERFECT = -1


class Wants(NamedTuple):
    """Which per-slot sums the scene's contact methods read (fields.scatter_slot_extras)."""

    disp: bool  # mass-weighted displacement (displacement separation)
    pos: bool  # mass-weighted position (CP cutoff, DF fit)
    grad: bool  # volume gradient (gradient normals)
    open: bool  # interface openings
    carry: bool  # openings carried to the interface point (else at the node)
    radius: bool  # axisymmetric: the slots' r-weighted volumes (contact areas per radian)


class Method(NamedTuple):
    """How the geometry and the passes work, as kernel parameters."""

    normal: int  # normal method code
    separation: int  # separation method code
    normal_vec: np.ndarray  # (3,) specified normal
    radial: bool  # specified normal radial from `centre`
    centre: np.ndarray  # (3,)
    rigid_bias: float
    cutoff: float  # CP cutoff, cells
    fit_r: float  # DF fit exponent
    spline: bool  # B-spline grid functions weight the contact area with the spline
    warm: bool  # logistic regression warm-started from the last fit
    integration: int  # interface integrator code
    area_correction: bool
    use_h_perp: bool
    screen: float  # edge-screening volume (0: off)
    touch: float  # touching tolerance, a length
    h_min: float  # smallest cell edge
    axisymmetric: bool  # x = r: areas per radian (x r_i)
    mirror: np.ndarray  # (2, 3) each axis's lower and upper mirror plane (roller faces, the axisymmetric
    # axis; -inf / +inf: none): on and beyond one, the normal has no component across it


@dataclass
class ContactSpec:
    n_groups: int
    n_def_groups: int  # deformable groups are 0..n_def_groups-1, rigid contact groups follow
    mat_group: np.ndarray  # (n_deformable_materials,) group of each deformable material
    rigid_group: np.ndarray  # (n_rigid_materials,) group of each rigid material, -1 for velocity-BC ones
    rigid_of_group: np.ndarray  # (n_groups,) rigid material index of a rigid group, -1 otherwise
    law: np.ndarray  # (G, G) law code
    mu: np.ndarray  # (G, G) kinetic friction
    mu_static: np.ndarray  # (G, G) static friction, -1 when not given
    stiffness: np.ndarray  # (G, G, 3) interface [Dn tension, Dn compression, Dt], PERFECT = -1
    normal: int
    separation: int
    normal_vector: np.ndarray  # (3,)
    rigid_bias: float
    cutoff: float
    touch: float  # touching tolerance, cells
    fit_exponent: float
    passes: int
    recheck: bool  # pass 3 recomputes the geometry and re-tests contact (recheck and persist)
    xpic_term: bool
    warm_start: bool
    shape_weights: bool  # point-cloud regression weights: shape function at the node (else 1)
    group_names: list[str]
    normal_center: np.ndarray  # (3,) centre of a radial specified normal
    radial: bool
    interface_integration: int
    area_correction: bool
    use_h_perp: bool
    edge_screening: float  # fraction of a cell's volume; 0: off
    consistent_bond: bool  # bonded normals held where the interface crosses grid edges (contact.bond)
    opening_at_interface: bool  # interface openings carried to the interface point (else: at the node)
    separation_name: str  # the separation method's deck name
    plugin_laws: tuple = ()  # codes of laws registered outside mpmsim that the law table uses
    traction: bool = False  # record each slot's contact force for the traction output (output.contact_traction)
    persist: bool = False  # pass_3: persist (pass 2 advances where contact persists; pass 3 keeps its contacts
    # unless they separate)
    cohesive: object = None  # CohesiveTable of the cohesive pairs (contact/cohesive_history.py), None: none

    @property
    def normal_name(self) -> str:
        return next(k for k, v in NORMAL_CODES.items() if v == self.normal)

    def describe_separation(self) -> str:
        sep = self.separation_name
        return f"{sep} separation" + (f" (cutoff {self.cutoff:g})" if sep == "cutoff" else "")

    def laws(self) -> PairLaws:
        return PairLaws(self.law, self.mu, self.mu_static, self.stiffness)

    def method(self, h_min: float, spline: bool, screen: float, mirror: np.ndarray,
               axisymmetric: bool = False) -> Method:
        """The kernels' parameters for a grid of smallest cell edge h_min; mirror: see Method."""
        return Method(self.normal, self.separation, self.normal_vector, self.radial, self.normal_center,
                      self.rigid_bias, self.cutoff, self.fit_exponent, spline, self.warm_start,
                      self.interface_integration, self.area_correction, self.use_h_perp, screen, self.touch * h_min,
                      h_min, axisymmetric, mirror)

    def wants(self, axisymmetric: bool = False) -> Wants:
        return Wants(self.needs_displacement, self.needs_position, self.needs_gradients, self.has_interface,
                     self.opening_at_interface, axisymmetric)

    @property
    def has_interface(self) -> bool:
        return bool((self.law == INTERFACE).any())

    @property
    def needs_gradients(self) -> bool:
        return self.normal in (AVERAGE_GRADIENT, MAX_GRADIENT, MAX_VOLUME) or (
            self.normal == LOGISTIC and self.rigid_bias >= 10.0)

    @property
    def needs_cloud(self) -> bool:
        return self.normal in (LOGISTIC, LINEAR_REGRESSION) or self.separation == SEP_LR

    @property
    def needs_displacement(self) -> bool:
        return self.separation == SEP_DISPLACEMENT

    @property
    def needs_position(self) -> bool:
        return self.separation in (SEP_CUTOFF, SEP_FIT)

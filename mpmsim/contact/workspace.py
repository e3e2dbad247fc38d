"""The contact workspace: per-step contact nodes, their material slots and what the passes
compute at them (plain arrays, grown by doubling as a run needs more)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .spec import ContactSpec


@dataclass
class ContactWorkspace:
    spec: ContactSpec
    group: np.ndarray  # (n,) group of each deformable particle
    rgroup: np.ndarray  # (n_rigid_particles,) group of each rigid particle (-1: velocity-condition rigid)
    mask: np.ndarray  # (n_nodes,) uint64 groups touching each node
    node_cn: np.ndarray  # (n_nodes,) contact-node index or -1
    fidx: np.ndarray  # (n, K) field of each deformable particle-node entry
    rfidx: np.ndarray  # (n_rigid_particles, K) slot of each rigid entry, -1 off contact nodes
    warm_phi: np.ndarray  # (n_nodes, G, 4) last logistic fit per node and group (warm start only)
    n_cn: int = 0
    n_slots: int = 0
    cap: int = 0
    cloud_ptr: np.ndarray = None
    cloud_idx: np.ndarray = None
    cloud_w: np.ndarray = None

    def ensure(self, n_cn: int, n_slots: int, dim: int) -> None:
        """Grow the per-contact-node and per-slot arrays (doubling) to hold this step."""
        if n_slots <= self.cap and n_cn < self.cn_nodes.size:
            return
        cap = max(64, 2 * n_slots)
        z = np.zeros
        self.cap = cap
        self.cn_nodes = z(cap, dtype=np.int64)
        self.cn_ptr = z(cap + 1, dtype=np.int64)
        self.slot_group = z(cap, dtype=np.int64)
        self.slot_node = z(cap, dtype=np.int64)
        self.vol, self.delta, self.area = z(cap), z(cap), z(cap)
        self.disp, self.pos, self.grad, self.dp1, self.normal = (z((cap, dim)) for _ in range(5))
        self.udisp, self.ugrad = z((cap, dim)), z((cap, dim, dim))  # interfaces: displacement at the node, gradient
        self.stick2, self.applied2, self.stick_total, self.applied_total = (z((cap, dim)) for _ in range(4))
        self.delta2 = z(cap)
        self.contact2 = z(cap, dtype=np.int64)
        self.role = z(cap, dtype=np.int64)
        self.partner = z(cap, dtype=np.int64)
        self.law = z(cap, dtype=np.int64)
        self.mu, self.mus = z(cap), z(cap)
        self.open, self.stiff = z((cap, dim)), z((cap, 3))  # interfaces: tangential opening, [Dn, Dnc, Dt]
        self.bonded = z(cap, dtype=np.int64)  # interfaces: bit 1 normal, bit 2 tangential act as perfect,
        # bit 4 normal held by the consistent-bond constraints (contact.bond)
        self.level = z(cap)  # signed distance of the node to the interface along n (a's side < 0)
        # consistent-bond constraints: entries con_ptr[q]:con_ptr[q+1], slots of a and b and weights
        self.con_ptr = z(cap + 1, dtype=np.int64)
        self.ent_a, self.ent_b, self.ent_w = z(8 * cap, dtype=np.int64), z(8 * cap, dtype=np.int64), z(8 * cap)
        self.n_con = 0

    @classmethod
    def create(cls, spec: ContactSpec, mat: np.ndarray, rigid_mat: np.ndarray, n_nodes: int, K: int,
               dim: int) -> "ContactWorkspace":
        """For particles of deformable materials `mat` and rigid materials `rigid_mat`, K
        shape-function entries each, on a grid of n_nodes nodes."""
        n, nr = len(mat), len(rigid_mat)
        cs = cls(spec, spec.mat_group[mat], spec.rigid_group[rigid_mat] if nr else np.zeros(0, dtype=np.int64),
                 np.zeros(n_nodes, dtype=np.uint64), np.full(n_nodes, -1, dtype=np.int64),
                 np.zeros((n, K), dtype=np.int64), np.full((nr, K), -1, dtype=np.int64),
                 np.zeros((n_nodes, spec.n_groups, 4) if spec.warm_start else (1, 1, 4)))
        cs.cn_nodes = np.zeros(0, dtype=np.int64)
        cs.ensure(1, 1, dim)
        return cs

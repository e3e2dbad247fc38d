"""J2 plasticity (mpmsim/materials/j2_plasticity.py): the compiled stress update driven at one
material point along prescribed deformation histories, against closed forms; an MPM run
through `Simulation`; and the deck's checks.

The material-point drivers call the model's compiled stress function as the stress kernel
does, with the increment f = F_{n+1} F_n^-1 passed as the velocity gradient L = f - I over
dt = 1 (the kernel's own f is I + dt L)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.materials import MODELS
from mpmsim.materials.j2_plasticity import P_H1, P_YIELD, S_BE, S_EPS, S_TEMP, S_WORK, STATE0
from mpmsim.materials.kernels import VOIGT

from ..conftest import deck_from
from .test_bad_decks import BASE as ELASTIC_BASE

pytestmark = pytest.mark.plasticity

E, NU, RHO, Y0 = 200e3, 0.3, 7.8e-3, 300.0  # MPa, g/mm^3 (mm-g-ms)
K, G = E / (3 * (1 - 2 * NU)), E / (2 * (1 + NU))
MODEL = MODELS["j2_plasticity"]


def row(hardening: dict) -> np.ndarray:
    return MODEL.row(MODEL.schema.model_validate({"type": "j2_plasticity", "E": E, "nu": NU, "density": RHO,
                                                  "yield": Y0, "hardening": hardening}))


LINEAR = {"law": "linear", "modulus": 2000.0}
H = LINEAR["modulus"]


class Point:
    """One material point: its state row, Cauchy stress and deformation gradient."""

    def __init__(self, pr: np.ndarray, dim: int = 3, hs0: tuple = STATE0):
        self.pr, self.dim = pr, dim
        self.fn = MODEL.stress(dim)
        self.hs = np.array(hs0)
        self.s = np.zeros(6)
        self.F = np.eye(3)
        self.scratch = [np.zeros((3, 3)) for _ in range(4)]
        self.eos = np.zeros(6)

    def go(self, F_new: np.ndarray, commit: bool = True, h: np.ndarray | None = None, dt: float = 1.0) -> np.ndarray:
        """Step to F_new in time dt; the new Cauchy stress (the state keeps it only when commit).
        h: the increment f - I (f = F_new F^-1) when the caller knows it without cancellation."""
        L = (F_new @ np.linalg.inv(self.F) - np.eye(3) if h is None else h) / dt
        J = float(np.linalg.det(F_new))
        hs, s = (self.hs, self.s) if commit else (self.hs.copy(), self.s.copy())
        f = F_new[:2, :2] if self.dim == 2 else F_new
        self.fn(self.pr, L, dt, F_new, J, f[0, 0], f[0, 1], f[1, 0], f[1, 1], s, *self.scratch, self.eos, hs)
        if commit:
            self.F = F_new.copy()
        return s

    def be(self) -> np.ndarray:
        """The elastic left Cauchy-Green tensor (the state keeps be - I)."""
        return np.eye(3) + np.array([[self.hs[S_BE + VOIGT[a, b]] for b in range(3)] for a in range(3)])

    def tau(self) -> np.ndarray:
        """Kirchhoff stress J sigma (3x3)."""
        return np.linalg.det(self.F) * np.array([[self.s[VOIGT[a, b]] for b in range(3)] for a in range(3)])


def logm_spd(A: np.ndarray) -> np.ndarray:
    w, V = np.linalg.eigh(A)
    return (V * np.log(w)) @ V.T


def mises(tau: np.ndarray) -> float:
    d = tau - np.trace(tau) / 3 * np.eye(3)
    return float(np.sqrt(1.5 * np.sum(d * d)))


def flow(hardening: dict, eps: float) -> float:
    law = hardening["law"]
    if law == "linear":
        return Y0 + hardening["modulus"] * eps
    if law == "power":
        return Y0 * (1 + hardening["K"] * eps) ** hardening["n"]
    return Y0 + (hardening["saturation"] - Y0) * (1 - np.exp(-hardening["rate"] * eps))


class PlasticWork:
    """sum over steps of tau_{n+1} : d eps_p / rho0, with d eps_p = 1/2 ln(be_trial) - 1/2 ln(be_{n+1})
    and be_trial = f be_n f^T formed here with numpy's eigen-solver (independent of the model's
    Jacobi solver and of its plastic multiplier)."""

    def __init__(self):
        self.w = 0.0

    def step(self, point: Point, F_new: np.ndarray) -> None:
        f = F_new @ np.linalg.inv(point.F)
        trial = f @ point.be() @ f.T
        point.go(F_new)
        deps = 0.5 * (logm_spd(trial) - logm_spd(point.be()))
        self.w += float(np.sum(point.tau() * deps)) / RHO


def path(*stops: float, n: int) -> np.ndarray:
    """Values from stops[0] through each stop in n equal steps per leg (the first excluded)."""
    return np.concatenate([np.linspace(a, b, n + 1)[1:] for a, b in zip(stops[:-1], stops[1:])])


# --- uniaxial strain ---------------------------------------------------------------------


def uniaxial_strain_exact(legs: list[float], lam: float):
    """Closed form of uniaxial strain F = diag(lam, 1, 1) with linear hardening, in log strain.

    With fixed principal axes the exponential map makes log strains additive: the elastic log
    strain is e = (eps - p, p/2, p/2), eps = ln lam, p the axial plastic log strain (plastic
    flow is isochoric and axisymmetric about x), equivalent plastic strain increments |dp|.
    Kirchhoff stress: tau_xx = K eps + 4G/3 (eps - 3p/2), tau_yy = tau_zz = K eps - 2G/3 (eps - 3p/2),
    von Mises stress 2G |eps - 3p/2|. On a leg of monotone strain that starts with (p_a, a_a),
    the state at eps is elastic while 2G |eps - 3p_a/2| <= Y0 + H a_a, and otherwise
        dp = (2G |eps - 3p_a/2| - Y0 - H a_a) / (3G + H),  p = p_a + sign(eps - 3p_a/2) dp,
        eps_p = a_a + dp
    (the consistency condition 2G |eps - 3p/2| = Y0 + H eps_p solved in one step). legs: the
    stretches at which the earlier legs ended; lam on the current leg. Returns (Cauchy sxx,
    syy, szz, eps_p)."""
    p = a = 0.0
    for stretch in list(legs) + [lam]:
        e = np.log(stretch)
        x = e - 1.5 * p
        over = 2 * G * abs(x) - Y0 - H * a
        if over > 0:
            dp = over / (3 * G + H)
            p += np.sign(x) * dp
            a += dp
    e = np.log(lam)
    x = e - 1.5 * p
    return (K * e + 4 * G / 3 * x) / lam, (K * e - 2 * G / 3 * x) / lam, (K * e - 2 * G / 3 * x) / lam, a


@pytest.mark.parametrize("dim", [2, 3])
def test_uniaxial_strain_to_100_percent_unload_reload_is_the_closed_form(dim):
    """F = diag(lam, 1, 1): lam 1 -> 2 -> 1 -> 2 (100% stretch, unloading through reverse
    yield, reloading), 300 steps per leg, plane strain and 3D. Every step's stress and plastic
    strain equal the closed form (uniaxial_strain_exact) to 1e-10 of the stress scale; the
    plastic work equals sum tau : d eps_p (PlasticWork) to 1e-10 and the backward-Euler sum
    sum d eps_p sigma_y(eps_p^{n+1}) / rho0 of the closed form's plastic strains to 1e-10.
    (Measured: 3e-15 on the stress, 4e-16 on the plastic work.)"""
    pt, work = Point(row(LINEAR), dim), PlasticWork()
    stops = [1.0, 2.0, 1.0, 2.0]
    lams = path(*stops, n=300)
    leg = np.repeat(np.arange(3), 300)
    errs, eps_prev, w_exact, scale = [], 0.0, 0.0, Y0
    for k, lam in enumerate(lams):
        work.step(pt, np.diag([lam, 1.0, 1.0]))
        sxx, syy, szz, eps = uniaxial_strain_exact(stops[1:leg[k] + 1], lam)
        scale = max(scale, abs(sxx))
        errs.append(max(abs(pt.s[0] - sxx), abs(pt.s[1] - syy), abs(pt.s[2] - szz)) / scale)
        assert pt.hs[S_EPS] == pytest.approx(eps, rel=1e-10, abs=1e-14)
        w_exact += (eps - eps_prev) * (Y0 + H * eps) / RHO
        eps_prev = eps
        assert max(abs(pt.s[3]), abs(pt.s[4]), abs(pt.s[5])) == 0.0
    assert max(errs) < 1e-10, max(errs)
    assert pt.hs[S_EPS] > 1.0  # (three legs of ~0.69 log strain, each mostly plastic)
    assert pt.be()[2, 2] > 1.5  # be_zz = exp(p) evolves while F_zz = 1 (plane strain too)
    assert pt.hs[S_WORK] == pytest.approx(w_exact, rel=1e-10)
    assert pt.hs[S_WORK] == pytest.approx(work.w, rel=1e-10)


# --- uniaxial stress ---------------------------------------------------------------------


def uniaxial_stress_exact(legs: list[float], lam: float):
    """Closed form of uniaxial Kirchhoff (and Cauchy) stress with linear hardening, in log strain.

    F = diag(lam, mu, mu) with sigma_yy = sigma_zz = 0. The elastic log strain is
    (tau/E - 0, -nu tau/E, -nu tau/E) + the plastic (p, -p/2, -p/2): eps = ln lam = tau/E + p,
    ln mu = -nu tau/E - p/2. On a leg starting with (p_a, a_a): trial tau = E (eps - p_a);
    elastic while |tau| <= Y0 + H a_a, else dp = (|tau| - Y0 - H a_a) / (E + H),
    p = p_a + sign(tau) dp, eps_p = a_a + dp (hence the tangent E H / (E + H)).
    Returns (Cauchy sxx = tau / (lam mu^2), mu, eps_p)."""
    p = a = 0.0
    for stretch in list(legs) + [lam]:
        tau = E * (np.log(stretch) - p)
        over = abs(tau) - Y0 - H * a
        if over > 0:
            dp = over / (E + H)
            p += np.sign(tau) * dp
            a += dp
    tau = E * (np.log(lam) - p)
    mu = np.exp(-NU * tau / E - 0.5 * p)
    return tau / (lam * mu * mu), mu, a


def lateral_free(pt: Point, lam: float, mu0: float) -> float:
    """The lateral stretch mu with sigma_yy = sigma_zz = 0 at axial stretch lam (secant
    iteration on trial steps, to |sigma_yy| <= 1e-12 of the axial stress or Y0: round-off of
    the stress); the step is then taken."""
    g = lambda mu: pt.go(np.diag([lam, mu, mu]), commit=False)  # noqa: E731
    a, b = mu0, mu0 * (1 + 1e-6)
    ga, s = g(a)[1], g(b)
    gb = s[1]
    tol = lambda s: 1e-12 * max(abs(s[0]), Y0)  # noqa: E731
    for _ in range(60):
        if abs(gb) <= tol(s) or gb == ga:
            break
        a, b, ga = b, b - gb * (b - a) / (gb - ga), gb
        s = g(b)
        gb = s[1]
    assert abs(gb) <= tol(s)
    pt.go(np.diag([lam, b, b]))
    return b


def test_uniaxial_stress_to_100_percent_unload_reload_is_the_closed_form():
    """3D, F = diag(lam, mu, mu) with the lateral stretch iterated so sigma_yy = sigma_zz = 0:
    lam 1 -> 2 -> 1 -> 2, 200 steps per leg. Axial stress, lateral stretch and plastic strain
    equal the closed form (uniaxial_stress_exact) to 1e-10 (measured: 4e-15 on the stress)."""
    pt = Point(row(LINEAR), 3)
    stops = [1.0, 2.0, 1.0, 2.0]
    lams = path(*stops, n=200)
    leg = np.repeat(np.arange(3), 200)
    mu, errs = 1.0, []
    for k, lam in enumerate(lams):
        mu = lateral_free(pt, lam, mu)
        sxx, mu_exact, eps = uniaxial_stress_exact(stops[1:leg[k] + 1], lam)
        errs.append(abs(pt.s[0] - sxx) / max(abs(sxx), Y0))
        assert mu == pytest.approx(mu_exact, rel=1e-10)
        assert pt.hs[S_EPS] == pytest.approx(eps, rel=1e-10, abs=1e-14)
    assert max(errs) < 1e-10, max(errs)
    assert pt.hs[S_EPS] > 1.0


# --- nonlinear hardening ------------------------------------------------------------------


@pytest.mark.parametrize("hardening", [{"law": "power", "K": 50.0, "n": 0.3},
                                       {"law": "power", "K": 2.0, "n": 1.5},
                                       {"law": "voce", "saturation": 600.0, "rate": 20.0}],
                         ids=["power-concave", "power-convex", "voce"])
def test_nonlinear_hardening_in_uniaxial_strain_solves_the_consistency_condition(hardening):
    """Monotone uniaxial strain to lam = 2 in 200 steps: every plastic step ends on the yield
    surface, von Mises(tau) = sigma_y(eps_p) to 1e-13; the plastic strain equals the root of
    the path's exact consistency condition 2G (eps - 3p/2) = sigma_y(p) (eps = ln lam, p = eps_p:
    monotone loading) to 1e-10 relative, whatever the number of steps."""
    pt = Point(row(hardening), 3)
    for lam in np.linspace(1, 2, 201)[1:]:
        pt.go(np.diag([lam, 1.0, 1.0]))
        e = np.log(lam)
        if 2 * G * e <= Y0:
            assert pt.hs[S_EPS] == 0.0
            continue
        p = brentq(lambda p: 2 * G * (e - 1.5 * p) - flow(hardening, p), 0.0, e / 1.5, xtol=1e-16, rtol=1e-15)
        assert pt.hs[S_EPS] == pytest.approx(p, rel=1e-10)
        assert mises(pt.tau()) == pytest.approx(flow(hardening, pt.hs[S_EPS]), rel=1e-13)


# --- simple shear -------------------------------------------------------------------------


def shear(g: float) -> np.ndarray:
    F = np.eye(3)
    F[0, 1] = g
    return F


@pytest.mark.parametrize("hardening", [LINEAR, {"law": "voce", "saturation": 600.0, "rate": 20.0}],
                         ids=["linear", "voce"])
def test_simple_shear_to_100_percent_unload_reload(hardening):
    """Simple shear gamma 0 -> 1 -> 0 -> 1, 400 steps per leg, plane strain and 3D together.
    Before first yield the stress is Hencky's of be = F F^T (closed form, 1e-12); on every
    plastic step von Mises(tau) = sigma_y(eps_p) (1e-12); plastic flow keeps det be = J^2
    (1e-12); the plastic work equals sum tau : d eps_p (PlasticWork) to 1e-10; plane strain
    gives the 3D numbers to 1e-13 with s_yz = s_xz = 0."""
    p2, p3, work = Point(row(hardening), 2), Point(row(hardening), 3), PlasticWork()
    for g in path(0.0, 1.0, 0.0, 1.0, n=400):
        F = shear(g)
        eps0 = p3.hs[S_EPS]
        work.step(p3, F)
        p2.go(F)
        tau = p3.tau()
        if p3.hs[S_EPS] == 0.0:
            b = F @ F.T
            h = 0.5 * logm_spd(b)
            exact = K * np.trace(h) * np.eye(3) + 2 * G * (h - np.trace(h) / 3 * np.eye(3))
            assert np.abs(tau - exact).max() < 1e-12 * max(np.abs(exact).max(), Y0)
        elif p3.hs[S_EPS] > eps0:
            assert mises(tau) == pytest.approx(flow(hardening, p3.hs[S_EPS]), rel=1e-12)
        assert np.linalg.det(p3.be()) == pytest.approx(1.0, rel=1e-12)  # J = 1 in simple shear
        assert np.abs(p2.s - p3.s).max() <= 1e-13 * np.abs(p3.s).max()
        assert p2.s[4] == 0.0 and p2.s[5] == 0.0
    assert p3.hs[S_EPS] > 0.5
    assert p3.hs[S_WORK] == pytest.approx(work.w, rel=1e-10)


# --- hydrostatic path ---------------------------------------------------------------------


def test_a_hydrostatic_path_never_yields():
    """3D, F = lam I: lam 1 -> 1.5 -> 0.7 -> 1, volumetric log strains (+-1.2) far past any
    yield strain. eps_p and the plastic work stay exactly 0 and sigma = K ln J / J I (1e-12)."""
    pt = Point(row(LINEAR), 3)
    for lam in path(1.0, 1.5, 0.7, 1.0, n=100):
        pt.go(lam * np.eye(3))
        J = lam**3
        assert pt.hs[S_EPS] == 0.0 and pt.hs[S_WORK] == 0.0
        p = K * np.log(J) / J
        assert np.abs(pt.s[:3] - p).max() <= 1e-12 * K  # (K: the stress of a unit log strain)
        assert np.abs(pt.s[3:]).max() <= 1e-12 * K


# --- the update against numpy's eigen-solver --------------------------------------------------


def reference_update(be_minus_i: np.ndarray, h: np.ndarray, eps: float, y0: float, hh: float) -> tuple:
    """One step of the return map of the module's text with linear hardening (initial yield
    stress y0, modulus hh), written with numpy's eigh: (Cauchy stress 3x3, be - I, eps_p) after the
    increment f = I + h."""
    f = np.eye(3) + h
    B = h + h.T + h @ h.T + f @ be_minus_i @ f.T  # be_tr - I
    mu, V = np.linalg.eigh(B)
    e = 0.5 * np.log1p(mu)
    m = e.sum() / 3
    d = e - m
    q = 2 * G * np.sqrt(1.5 * np.sum(d * d))
    if q > y0 + hh * eps:
        dg = (q - y0 - hh * eps) / (3 * G + hh)
        d *= 1 - 3 * G * dg / q
        eps += dg
    J = np.linalg.det(f)
    tau = K * 3 * m + 2 * G * d
    return (V * tau) @ V.T / J, (V * np.expm1(2 * (m + d))) @ V.T, eps


@pytest.mark.parametrize("size", [1e-7, 1e-3, 2e-2, 0.09, 0.12, 0.5])
@pytest.mark.parametrize("plastic", [False, True], ids=["elastic", "plastic"])
def test_the_update_is_the_spectral_return_map_to_round_off(size, plastic):
    """Random states be_n - I of Frobenius norm `size` and random increments (|h| 1e-4), the
    compiled update against reference_update: stress to 1e-12 of the trial stress's scale
    (K + 2G)|be_tr - I| (a return to a small flow stress cancels most of it), be - I to 1e-13 of
    |be_tr - I| and eps_p to 1e-12. Below |be_tr - I| = 0.1 the update sums its logarithm and
    the plastic factor's exponential as series, above it it takes the Jacobi eigen-solver: both
    must be the same map. `plastic`: a deviatoric be_n - I, an increment along it, and the
    flow stress at half the trial von Mises stress; elastic: the yield stress out of
    reach."""
    rng = np.random.default_rng(int(size * 1e7) + plastic)
    for trial in range(20):
        a = rng.normal(size=(3, 3))
        a = a + a.T
        if plastic:
            a -= np.trace(a) / 3 * np.eye(3)
        a *= size / np.linalg.norm(a)
        h = 1e-4 * (a / np.linalg.norm(a) if plastic else rng.normal(size=(3, 3)))
        eps0 = 0.01
        # plastic: the flow stress y0 + hh eps0 at half the trial von Mises stress (~ G sqrt(3/2) |a|)
        y0 = 0.25 * G * np.sqrt(1.5) * size if plastic else 1e9 * Y0
        hh = y0 / eps0
        pr = row(LINEAR).copy()
        pr[P_YIELD], pr[P_H1] = y0, hh
        pt = Point(pr, 3, tuple(a[[0, 1, 2, 0, 1, 0], [0, 1, 2, 1, 2, 2]]) + (eps0, 0.0))
        sig = pt.go(np.eye(3) + h, h=h)
        ref_s, ref_be, ref_eps = reference_update(a, h, eps0, y0, hh)
        got_s = np.array([[sig[VOIGT[i, j]] for j in range(3)] for i in range(3)])
        got_be = np.array([[pt.hs[S_BE + VOIGT[i, j]] for j in range(3)] for i in range(3)])  # be - I
        f = np.eye(3) + h
        size_trial = np.linalg.norm(h + h.T + h @ h.T + f @ a @ f.T)  # |be_tr - I|
        assert np.abs(got_s - ref_s).max() <= 1e-12 * (K + 2 * G) * size_trial, (trial, got_s, ref_s)
        assert np.abs(got_be - ref_be).max() <= 1e-13 * size_trial, trial
        assert pt.hs[S_EPS] == pytest.approx(ref_eps, rel=1e-12, abs=0)
        assert (pt.hs[S_EPS] > eps0) == plastic


# --- rigid rotation -------------------------------------------------------------------------


def rotation_minus_identity(axis: np.ndarray, theta: float) -> np.ndarray:
    """R(theta) - I about `axis` (Rodrigues: sin(theta) K + 2 sin^2(theta/2) K^2, no cancellation)."""
    a = axis / np.linalg.norm(axis)
    Kx = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.sin(theta) * Kx + 2 * np.sin(0.5 * theta) ** 2 * Kx @ Kx


def rotation(axis: np.ndarray, theta: float) -> np.ndarray:
    return np.eye(3) + rotation_minus_identity(axis, theta)


def invariants(s: np.ndarray) -> tuple[float, float]:
    """(I1, J2) of a Voigt stress."""
    m = (s[0] + s[1] + s[2]) / 3
    j2 = 0.5 * ((s[0] - m) ** 2 + (s[1] - m) ** 2 + (s[2] - m) ** 2) + s[3] ** 2 + s[4] ** 2 + s[5] ** 2
    return s[0] + s[1] + s[2], j2


@pytest.mark.parametrize("dim,axis", [(2, (0.0, 0.0, 1.0)), (3, (1.0, 2.0, 3.0))], ids=["plane-strain", "3d"])
def test_a_yielded_point_spun_ten_turns_keeps_its_invariants(dim, axis):
    """A point yielded by stretch and shear (F0), then F = R(theta) F0 through 10 full turns in
    3600 steps (1 degree each, each step's increment f = R(1 degree) given as f - I without
    cancellation): I1, J2 of the stress and eps_p stay at their values to 1e-12 relative, and
    after the 10 turns the stress is the starting one (1e-12 of its size)."""
    pt = Point(row(LINEAR), dim)
    F0 = np.eye(3)
    F0[0, 0], F0[0, 1] = 1.05, 0.05
    if dim == 3:
        F0[1, 2] = 0.03
    for k in range(1, 21):
        pt.go(np.eye(3) + k / 20 * (F0 - np.eye(3)))
    assert pt.hs[S_EPS] > 0.01
    s0, eps0 = pt.s.copy(), pt.hs[S_EPS]
    i1, j2 = invariants(s0)
    drift = 0.0
    h = rotation_minus_identity(np.array(axis), np.radians(1.0))  # every step's f - I: R(1 degree) - I
    for k in range(1, 3601):
        pt.go(rotation(np.array(axis), np.radians(k)) @ F0, h=h)
        a, b = invariants(pt.s)
        drift = max(drift, abs(a - i1) / abs(i1), abs(b - j2) / j2, abs(pt.hs[S_EPS] - eps0) / eps0)
    assert drift < 1e-12, drift
    assert np.abs(pt.s - s0).max() < 1e-12 * np.abs(s0).max()


# --- Johnson-Cook ----------------------------------------------------------------------------

JC = {"law": "johnson_cook", "A": 300.0, "B": 500.0, "n": 0.4, "C": 0.02, "reference_rate": 1.0, "m": 1.1,
      "melt_temperature": 1800.0, "room_temperature": 293.0, "heat_capacity": 460.0, "taylor_quinney": 0.9}


def jc_point(**change) -> Point:
    h = dict(JC, **change)
    entry = MODEL.schema.model_validate({"type": "j2_plasticity", "E": E, "nu": NU, "density": RHO, "hardening": h})
    return Point(MODEL.row(entry), 3, MODEL.state(entry))


def test_johnson_cook_slow_at_room_temperature_is_A_plus_B_eps_to_the_n():
    """No heating (taylor_quinney 0) and steps of 1e9 time units (plastic strain rates far below
    the reference: the rate factor is 1): monotone uniaxial strain to lam = 1.5 in 200 steps
    gives the eps_p of the consistency condition 2G (eps - 3p/2) = A + B p^n (brentq) to 1e-10,
    and the temperature stays room temperature exactly."""
    pt = jc_point(taylor_quinney=0.0)
    for lam in np.linspace(1, 1.5, 201)[1:]:
        pt.go(np.diag([lam, 1.0, 1.0]), dt=1e9)
        e = np.log(lam)
        if 2 * G * e <= JC["A"]:
            continue
        p = brentq(lambda p: 2 * G * (e - 1.5 * p) - JC["A"] - JC["B"] * p ** JC["n"], 0.0, e / 1.5, xtol=1e-16,
                   rtol=1e-15)
        assert pt.hs[S_EPS] == pytest.approx(p, rel=1e-10)
    assert pt.hs[S_TEMP] == JC["room_temperature"]


def test_johnson_cook_rate_and_adiabatic_heating_meet_the_flow_stress_every_step():
    """Uniaxial strain to lam = 2 in 400 steps of 1e-4 time units (plastic strain rates 2.6 to 16
    times the reference rate): on every plastic step von Mises(tau) = (A + B eps^n)(1 + C ln(d eps_p /
    (dt rate0)))(1 - T*^m) with the temperature at the step's start (1e-12); the temperature
    rises by beta d w_p / c_p each step and ends at T_r + beta w_p / c_p (1e-12); the hot, fast
    flow stress differs from the quasi-static, cold one by its two factors."""
    pt, dt = jc_point(), 1e-4
    heated = 0
    for lam in np.linspace(1, 2, 401)[1:]:
        eps0, T0, w0 = pt.hs[S_EPS], pt.hs[S_TEMP], pt.hs[S_WORK]
        pt.go(np.diag([lam, 1.0, 1.0]), dt=dt)
        dg = pt.hs[S_EPS] - eps0
        if dg == 0.0:
            continue
        ts = (T0 - JC["room_temperature"]) / (JC["melt_temperature"] - JC["room_temperature"])
        sy = ((JC["A"] + JC["B"] * pt.hs[S_EPS] ** JC["n"]) * (1 + JC["C"] * np.log(max(dg / (dt * JC["reference_rate"]), 1.0)))
              * (1 - max(ts, 0.0) ** JC["m"]))
        assert mises(pt.tau()) == pytest.approx(sy, rel=1e-12)
        assert pt.hs[S_TEMP] - T0 == pytest.approx(JC["taylor_quinney"] * (pt.hs[S_WORK] - w0) / JC["heat_capacity"],
                                                   rel=1e-12)
        heated += 1
    assert heated > 300
    rise = pt.hs[S_TEMP] - JC["room_temperature"]
    assert rise == pytest.approx(JC["taylor_quinney"] * pt.hs[S_WORK] / JC["heat_capacity"], rel=1e-12)
    assert rise > 50.0  # (hundreds of MPa over ~0.5 plastic strain, rho c_p ~ 3.6 MPa/K)


def test_a_melted_johnson_cook_point_loses_its_deviatoric_stress_in_one_step():
    """A heat capacity so small that the first plastic steps heat the point past T_m: from the
    step after, each step returns the whole deviator (|dev tau| <= 1e-12 A) and the pressure is
    Hencky's."""
    pt, melted = jc_point(heat_capacity=0.01), 0
    for lam in np.linspace(1, 1.2, 101)[1:]:
        hot = pt.hs[S_TEMP] >= JC["melt_temperature"]
        pt.go(np.diag([lam, 1.0, 1.0]), dt=1e-4)
        if hot:
            tau = pt.tau()
            assert np.abs(tau - np.trace(tau) / 3 * np.eye(3)).max() <= 1e-12 * JC["A"]
            assert np.trace(tau) / 3 == pytest.approx(K * np.log(lam), rel=1e-12)
            melted += 1
    assert melted > 50


# --- MPM run ----------------------------------------------------------------------------------


def platen_deck(ledger: bool = True, hardening: dict | None = None) -> dict:
    """A plane-strain 8 x 10 mm block (320 particles) on a rigid base, compressed 1.5 mm (15%) by a
    rigid platen (ramped to 10 mm/ms, 1% of the wave speed, held, ramped back to rest), roller
    wall at x = 0: yield strain 1%, so the strain is mostly plastic."""
    return {
        "title": "J2 block under a platen", "units": "mm-g-ms", "analysis": "plane_strain",
        "grid": {"cell_size": 1.0, "boundaries": {"xmin": "roller"}, "domain": {"min": [0, -1], "max": [14, 12]}},
        "shape_function": "gimp", "particles_per_direction": 2,
        "materials": {
            "block": {"type": "j2_plasticity", "E": 1000.0, "nu": 0.3, "density": 0.001, "yield": 10.0,
                      "hardening": {"law": "linear", "modulus": 100.0}} if hardening is None else
                     {"type": "j2_plasticity", "E": 1000.0, "nu": 0.3, "density": 0.001, "hardening": hardening},
            "bottom": {"type": "rigid", "velocity": [0.0, 0.0], "constrain": ["y"]},
            "top": {"type": "rigid", "velocity": {"times": [0.0, 0.05, 0.15, 0.2],
                                                 "values": [[0, 0], [0, -10.0], [0, -10.0], [0, 0]]},
                    "constrain": ["y"]}},
        "bodies": [{"shape": "rectangle", "min": [0, -1], "max": [8, 0], "material": "bottom"},
                   {"shape": "rectangle", "min": [0, 0], "max": [8, 10], "material": "block"},
                   {"shape": "rectangle", "min": [0, 10], "max": [8, 11], "material": "top"}],
        "time": {"end": 0.25, "cfl": 0.4}, "update": {"scheme": "flip", "stress": "usavg"},
        "output": {"energy_ledger": ledger, "history_interval": 0.01, "vtu_interval": 0.25}}


PLATEN_JC = {"law": "johnson_cook", "A": 10.0, "B": 20.0, "n": 0.5, "C": 0.05, "reference_rate": 0.01, "m": 1.0,
             "melt_temperature": 400.0, "room_temperature": 293.0, "heat_capacity": 20.0}


@pytest.mark.parametrize("hardening", [None, PLATEN_JC], ids=["linear", "johnson_cook"])
def test_a_block_under_a_platen_yields_and_the_ledger_closes(tmp_path, hardening):
    """platen_deck through Simulation (linear hardening, and Johnson-Cook whose heating softens
    the band where the strain localises up to the melting temperature): the block yields (eps_p > 0.05 at the platen,
    median above the 1% yield strain), the history's plastic_work is sum m w_p and most of the
    work put in, the energy ledger closes to 1% of the work, and the VTU frames carry
    plastic_strain and plastic_work (Johnson-Cook: temperature too, T_r + beta w_p / c_p)."""
    import meshio

    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation
    from mpmsim.tasks.ledger import energy_residual

    sim = Simulation(build_scene(deck_from(platen_deck(hardening=hardening))), out_dir=tmp_path, threads=1)
    sim.run()
    st, P = sim.state, sim.state.particles
    eps = P.mstate[:, S_EPS]
    assert eps.max() > 0.05 and np.median(eps) > 0.01
    names = sim.recorder.names
    last = sim.recorder.rows[-1]
    wp = last[names.index("plastic_work")]
    assert wp == pytest.approx(float(np.sum(P.mass * P.mstate[:, S_WORK])), rel=1e-12)
    assert st.work_in > 0 and 0.5 * st.work_in < wp < st.work_in
    assert abs(energy_residual(st)) < 0.01 * st.work_in, (energy_residual(st), st.work_in)
    frames = sorted(f for f in tmp_path.glob("*_[0-9]*.vtu") if "rigid" not in f.name)
    mesh = meshio.read(frames[-1])
    for name in ("plastic_strain", "plastic_work"):
        assert name in mesh.point_data
    pieces = dict(P.vtu_pieces(st))
    assert np.array_equal(pieces["particles"]["point_data"]["plastic_strain"], eps)
    assert ("temperature" in mesh.point_data) == (hardening is not None)
    if hardening is not None:
        T = mesh.point_data["temperature"]
        assert T == pytest.approx(293.0 + 0.9 * P.mstate[:, S_WORK] / 20.0, rel=1e-12)
        assert T.max() > 300.0


# --- deck checks --------------------------------------------------------------------------------

BASE = ELASTIC_BASE.replace("block: {type: neo_hookean, K: 100.0, G: 50.0, density: 0.001}",
                            "block: {type: j2_plasticity, E: 200000.0, nu: 0.3, density: 0.0078, yield: 300.0, "
                            "hardening: {law: linear, modulus: 2000.0}}")

BAD = [
    ("yield zero", ("yield: 300.0", "yield: 0.0"), "materials.block.yield", "greater than 0"),
    ("E negative", ("E: 200000.0", "E: -1.0"), "materials.block.E", "greater than 0"),
    ("nu 0.5", ("nu: 0.3", "nu: 0.5"), "materials.block.nu", "less than 0.5"),
    ("nu -1", ("nu: 0.3", "nu: -1.0"), "materials.block.nu", "greater than -1"),
    ("negative hardening modulus", ("modulus: 2000.0", "modulus: -5.0"), "materials.block.hardening.modulus",
     "greater than or equal to 0"),
    ("negative exponent", ("law: linear, modulus: 2000.0", "law: power, K: 10.0, n: -0.2"),
     "materials.block.hardening.n", "greater than or equal to 0"),
    ("Voce saturation below yield", ("law: linear, modulus: 2000.0", "law: voce, saturation: 200.0, rate: 5.0"),
     "materials.block.hardening.saturation", "below the yield stress"),
    ("unknown law", ("law: linear", "law: parabolic"), "materials.block.hardening", "'linear'"),
    ("key of another law", ("modulus: 2000.0", "rate: 2000.0"), "materials.block.hardening.rate", "unknown key"),
    ("Johnson-Cook melting below room", ("yield: 300.0, hardening: {law: linear, modulus: 2000.0}",
     "hardening: {law: johnson_cook, A: 300, B: 500, n: 0.4, C: 0.02, reference_rate: 1, m: 1, "
     "melt_temperature: 200, heat_capacity: 460}"), "materials.block.hardening.melt_temperature", "above room_temperature"),
    ("Johnson-Cook with yield", ("hardening: {law: linear, modulus: 2000.0}",
     "hardening: {law: johnson_cook, A: 300, B: 500, n: 0.4, C: 0.02, reference_rate: 1, m: 1, "
     "melt_temperature: 1800, heat_capacity: 460}"), "materials.block.yield", "hardening.A"),
    ("yield missing", ("yield: 300.0, ", ""), "materials.block.yield", "required key is missing"),
    ("Taylor-Quinney above 1", ("yield: 300.0, hardening: {law: linear, modulus: 2000.0}",
     "hardening: {law: johnson_cook, A: 300, B: 500, n: 0.4, C: 0.02, reference_rate: 1, m: 1, "
     "melt_temperature: 1800, heat_capacity: 460, taylor_quinney: 1.5}"), "materials.block.hardening.taylor_quinney",
     "less than or equal to 1"),
    ("FEM body", ("material: block}", "material: block, discretization: fem, element_size: 1.0}"),
     "bodies.0.material", "not j2_plasticity"),
    ("eos gamma0 negative", ("hardening: {law: linear, modulus: 2000.0}", "hardening: {law: linear, modulus: "
     "2000.0}, eos: {type: mie_gruneisen, gamma0: -1.0, S1: 1.4}"), "materials.block.eos.gamma0",
     "greater than or equal to 0"),
    ("eos S1 missing", ("hardening: {law: linear, modulus: 2000.0}", "hardening: {law: linear, modulus: 2000.0}, "
     "eos: {type: mie_gruneisen, gamma0: 2.0}"), "materials.block.eos.S1", "required key is missing"),
    ("eos of another type", ("hardening: {law: linear, modulus: 2000.0}", "hardening: {law: linear, modulus: "
     "2000.0}, eos: {type: tillotson, gamma0: 2.0, S1: 1.4}"), "materials.block.eos.type", "'mie_gruneisen'"),
]


@pytest.mark.parametrize("name,edit,path,words", BAD, ids=[b[0] for b in BAD])
def test_bad_j2_deck_is_one_line_naming_the_key(tmp_path, name, edit, path, words):
    text = BASE.replace(*edit)
    assert text != BASE
    deck = tmp_path / "bad.yaml"
    deck.write_text(text)
    result = CliRunner().invoke(app, ["check", str(deck)])
    out = result.output
    assert result.exit_code == 2, out
    assert "Traceback" not in out
    assert f": {path}: " in out, out
    assert words in out, out
    assert out.strip().splitlines()[0] == "mpmsim: bad deck" and len(out.strip().splitlines()) == 2, out


def test_the_base_deck_is_valid_and_the_gpu_refuses_it(tmp_path):
    deck = tmp_path / "ok.yaml"
    deck.write_text(BASE)
    assert CliRunner().invoke(app, ["check", str(deck)]).exit_code == 0
    result = CliRunner().invoke(app, ["check", str(deck), "--device", "cuda"])
    assert result.exit_code == 2, result.output
    assert ": materials.block.type: material model j2_plasticity is not on the GPU yet" in result.output


def test_a_j2_run_restarted_from_its_checkpoint_ends_as_the_uninterrupted_run(tmp_path):
    """platen_deck to t = 0.1 ms, stopped at step 150 (yielded by then) and restarted from its
    checkpoint: the material state (be - I, eps_p, plastic work) and the history, plastic_work
    column included, end bit for bit as the uninterrupted run's."""
    from mpmsim.output.checkpoint import checkpoint_path
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation, StopRequested

    data = dict(platen_deck(), time={"end": 0.1, "cfl": 0.4},
                output={"energy_ledger": True, "history_interval": 0.01, "checkpoint_interval": "off"})
    sim = lambda out, resume=False: Simulation(build_scene(deck_from(data)), out_dir=out, threads=1,  # noqa: E731
                                               resume=resume)
    whole = sim(tmp_path / "whole")
    whole.run()
    part = sim(tmp_path / "part")

    def stop_here():
        if part.state.step == 150:
            raise StopRequested()

    with pytest.raises(StopRequested):
        part.run(between_steps=stop_here)
    assert part.state.particles.mstate[:, S_EPS].max() > 0.0
    assert checkpoint_path(tmp_path / "part", "deck").exists()
    again = sim(tmp_path / "part", resume=True)
    again.resume()
    assert again.state.step == 150
    again.run()
    assert again.state.step == whole.state.step > 150
    assert np.array_equal(again.state.particles.mstate, whole.state.particles.mstate)
    i = whole.recorder.names.index("wall_s")
    assert [r[:i] + r[i + 1:] for r in again.recorder.rows] == [r[:i] + r[i + 1:] for r in whole.recorder.rows]


# --- with a Mie-Grüneisen equation of state --------------------------------------------------

NI = {"K": 188000.0, "G": 76000.0, "gamma0": 2.0, "S1": 1.44, "density": 0.00887}  # nickel, mm-g-ms


def nickel_j2(yield_stress: float = 1000.0) -> dict:
    """Nickel's Mie-Grüneisen constants (inputs/nickel_shock.yaml) with a shear modulus and a
    yield stress: E and nu from K and G."""
    K_, G_ = NI["K"], NI["G"]
    return {"type": "j2_plasticity", "E": 9 * K_ * G_ / (3 * K_ + G_), "nu": (3 * K_ - 2 * G_) / (2 * (3 * K_ + G_)),
            "density": NI["density"], "yield": yield_stress, "hardening": {"law": "linear", "modulus": 0.0},
            "eos": {"type": "mie_gruneisen", "gamma0": NI["gamma0"], "S1": NI["S1"]}}


def eos_path(name: str, entry: dict, stretches) -> tuple[list, list, list]:
    """Drive a model along uniaxial strain F = diag(lam, 1, 1) as the stress kernel does: the eos
    row carries U and p from step to step, J0 the previous J (no artificial viscosity).
    Returns per step (Cauchy stress, U, eps_p)."""
    from mpmsim.materials.kernels import EOS_J0, EOS_P, EOS_Q, EOS_RHO0, EOS_U

    model = MODELS[name]
    m = model.schema.model_validate(entry)
    pr, hs = model.row(m), np.array(model.state(m) if callable(model.state) else model.state, float)
    fn, s, eos = model.stress(3), np.zeros(6), np.zeros(6)
    scratch = [np.zeros((3, 3)) for _ in range(4)]
    F, U, p = np.eye(3), 0.0, 0.0
    out_s, out_u, out_e = [], [], []
    for lam in stretches:
        Fn = np.diag([lam, 1.0, 1.0])
        L = Fn @ np.linalg.inv(F) - np.eye(3)
        eos[EOS_U], eos[EOS_P], eos[EOS_Q], eos[EOS_J0], eos[EOS_RHO0] = U, p, 0.0, np.linalg.det(F), m.density
        J = float(np.linalg.det(Fn))
        fn(pr, L, 1.0, Fn, J, lam, 0.0, 0.0, 1.0, s, *scratch, eos, hs)
        U, p, F = eos[EOS_U], eos[EOS_P], Fn
        out_s.append(s.copy())
        out_u.append(U)
        out_e.append(hs[S_EPS] if len(hs) > S_EPS else 0.0)
    return out_s, out_u, out_e


def test_a_j2_entry_with_a_mie_gruneisen_eos_runs_the_energy_tracking_model():
    from mpmsim.materials.model import J2_MIE_GRUNEISEN, J2_PLASTICITY, model_for

    base = MODEL.schema.model_validate({"type": "j2_plasticity", "E": E, "nu": NU, "density": RHO, "yield": Y0})
    with_eos = MODEL.schema.model_validate(nickel_j2())
    assert model_for(base).code == J2_PLASTICITY and not model_for(base).internal_energy
    assert model_for(with_eos).code == J2_MIE_GRUNEISEN and model_for(with_eos).internal_energy
    import yaml

    from mpmsim.scene import build_scene

    data = yaml.safe_load(ELASTIC_BASE)
    data["materials"] = {"block": nickel_j2()}
    d = deck_from(data)

    mats = build_scene(d).materials
    assert list(mats.type_code) == [J2_MIE_GRUNEISEN] and mats.energy.all()


def test_uniaxial_strain_with_mie_gruneisen_is_its_pressure_plus_the_j2_deviator():
    """Nickel compressed in uniaxial strain to J = 0.8 in 400 steps: the pressure is the
    mie_gruneisen model's (G = 0) on the same path to 1e-12 (the same equation of state and
    energy update), the deviator sits on the yield surface once yielded (J |s_xx - s_yy| = Y,
    1e-10), and the axial stress where yielding starts is the Hugoniot elastic limit
    Y (1 - nu) / (1 - 2 nu) within 1% (the EOS's stiffening over the elastic strain, 0.3%,
    is the difference)."""
    Y = 1000.0
    lams = np.linspace(1.0, 0.8, 401)[1:]
    s_j2, u_j2, eps = eos_path("j2_plasticity_mie_gruneisen", nickel_j2(Y), lams)
    mg = {"type": "mie_gruneisen", "K": NI["K"], "G": 0.0, "gamma0": NI["gamma0"], "S1": NI["S1"],
          "density": NI["density"]}
    s_mg, u_mg, _ = eos_path("mie_gruneisen", mg, lams)
    for a, b, ua, ub in zip(s_j2, s_mg, u_j2, u_mg):
        assert np.mean(a[:3]) == pytest.approx(np.mean(b[:3]), rel=1e-12)
        assert ua == pytest.approx(ub, rel=1e-12)
    yielded = [k for k, e in enumerate(eps) if e > 0.0]
    assert yielded and yielded[0] > 0
    for k in yielded:
        assert lams[k] * abs(s_j2[k][0] - s_j2[k][1]) == pytest.approx(Y, rel=1e-10)
    nu = (3 * NI["K"] - 2 * NI["G"]) / (2 * (3 * NI["K"] + NI["G"]))
    hel = Y * (1 - nu) / (1 - 2 * nu)
    first = yielded[0]  # the axial stress crosses the HEL between the last elastic step and the first plastic one
    assert -s_j2[first - 1][0] <= hel * 1.01 and -s_j2[first][0] >= hel * 0.99
    assert abs(-s_j2[first - 1][0] - hel) / hel < 0.01 or abs(-s_j2[first][0] - hel) / hel < 0.01

"""Contact laws: impulses in, impulses out (notes §3.3–3.4).

Input: the stick impulse dp (what moves material a to the centre-of-mass, or rigid,
velocity), the unit normal n (a -> b), dotn = dp . n (negative when approaching), and whether
the materials are in contact (the passes decide: touching and approaching, or pass 2's
decision kept). Output: the impulse actually applied to a. In contact the normal part dotn n
is always applied, whatever its sign (pass 3 enforces pass 2's decision that way). Contact area cancels for
Coulomb friction, so it is not an input here; the interface force (pass 2) uses it.

- stick: always dp (bonded; never separates, like NairnMPM's stick).
- frictionless: dotn n when in contact.
- coulomb: when in contact, the tangential stick impulse S = |dp - dotn n| is capped at
  mu_k N (N = |dotn|); with a static coefficient, S <= mu_s N sticks.
- interface: no contact test (tractions act in tension and compression). A direction that is
  perfect, or too stiff for the step, takes the stick impulse (`bonded` bits: 1 normal,
  2 tangential; 4: the normal is held by the consistent-bond constraints of contact.bond,
  applied after the node-wise laws); the others are left free here and get the interface force
  in pass 2 (`interface_impulse`; notes §4.2–4.3).
"""

from __future__ import annotations

import hashlib
import inspect
from dataclasses import dataclass
from functools import cache

import numpy as np
from numba import njit

from ...parallel import specialize
from .spec import (BACKWARD_EULER, COULOMB, FIRST_ORDER, FIRST_PLUGIN_LAW, FORCE_LIMIT, FRICTIONLESS, INTERFACE,
                   LAW_CODES, STICK, TRAPEZOIDAL)


@dataclass(frozen=True)
class LawPlugin:
    """A contact law defined outside this module: `impulse(mu, mu_static, dp, n, dotn, dim, out)`
    (compiled) writes the impulse applied to material a where the surfaces are in contact and
    returns True if anything is applied (the arguments as `apply_law`'s; mu and mu_static are
    the deck entry's `friction` and `static_friction`, -1 when not given)."""

    name: str
    impulse: object
    code: int
    tag: str


LAWS: dict[str, LawPlugin] = {}


def register_law(name: str, impulse) -> LawPlugin:
    """Make `name` a contact law of the grid methods (decks accept it in contact.default and
    contact.pairs); registering a name again replaces its impulse."""
    old = LAWS.get(name)
    code = old.code if old is not None else FIRST_PLUGIN_LAW + len(LAWS)
    src = inspect.getsourcefile(getattr(impulse, "py_func", impulse)) or ""
    digest = hashlib.sha1(open(src, "rb").read()).hexdigest()[:8] if src else "0"
    law = LawPlugin(name, impulse, code, f"{name}_{digest}")
    LAWS[name] = law
    LAW_CODES[name] = code
    return law


@njit(cache=True, inline="always")
def _no_law(law, mu, mu_static, dp, n, dotn, dim, out):
    for d in range(dim):
        out[d] = 0.0
    return False


CODE, IMPULSE, REST = -1, None, _no_law
PLUGIN_LAW = _no_law  # the scene's plugin laws (`plugin_dispatch`), bound in a copy of apply_law


def law_link(law, mu, mu_static, dp, n, dotn, dim, out):
    """One plugin law of a chain: this link's, or the rest of the chain's."""
    if law == CODE:
        return IMPULSE(mu, mu_static, dp, n, dotn, dim, out)
    return REST(law, mu, mu_static, dp, n, dotn, dim, out)


@cache
def plugin_dispatch(codes: tuple):
    """(tag, apply_law with the plugin laws of these codes compiled in)."""
    by_code = {law.code: law for law in LAWS.values()}
    tag, rest = "", _no_law
    for code in reversed(codes):
        law = by_code[code]
        tag = f"{law.tag}_{tag}" if tag else law.tag
        rest = njit(cache=True, inline="always")(specialize(law_link, tag, CODE=code, IMPULSE=law.impulse, REST=rest))
    return tag, njit(cache=True, inline="always")(specialize(apply_law.py_func, tag, PLUGIN_LAW=rest))


@njit(cache=True, inline="always")
def apply_law(law, mu, mu_static, bonded, dp, n, dotn, in_contact, dim, out):
    """Write the applied impulse into out; return True if anything is applied."""
    if law == STICK:
        for d in range(dim):
            out[d] = dp[d]
        return True
    if law == INTERFACE:
        wn = 1.0 if bonded & 1 else 0.0
        wt = 1.0 if bonded & 2 else 0.0
        for d in range(dim):
            out[d] = wn * dotn * n[d] + wt * (dp[d] - dotn * n[d])
        return bonded != 0
    if not in_contact:
        for d in range(dim):
            out[d] = 0.0
        return False
    if law == FRICTIONLESS:
        for d in range(dim):
            out[d] = dotn * n[d]
        return True
    if law >= FIRST_PLUGIN_LAW:  # a law registered outside this module (register_law)
        return PLUGIN_LAW(law, mu, mu_static, dp, n, dotn, dim, out)
    # Coulomb: tangential part of the stick impulse, capped by friction
    s_stick = 0.0
    for d in range(dim):
        t = dp[d] - dotn * n[d]
        s_stick += t * t
    s_stick = np.sqrt(s_stick)
    normal = abs(dotn)
    if mu_static >= 0.0 and s_stick <= mu_static * normal:
        for d in range(dim):
            out[d] = dp[d]
        return True
    s_slide = mu * normal
    if s_stick > s_slide:
        scale = s_slide / s_stick  # 0 for mu = 0: frictionless sliding
        for d in range(dim):
            out[d] = dotn * n[d] + scale * (dp[d] - dotn * n[d])
    else:
        for d in range(dim):
            out[d] = dp[d]
    return True


@njit(cache=True, inline="always")
def oscillator(k, mred, delta0, d, df, dt):
    """One interface direction over the step as an exact harmonic oscillator (notes §4.3):
    m_red delta'' = df - k delta, delta(0) = delta0, m_red delta'(0) = d. Returns the constant
    force on material a that lands the ordinary MPM update on the exact end opening, and
    that end opening."""
    phi2 = k * dt * dt / mred
    if phi2 < 1e-8:  # series: avoids 0/0 as k -> 0
        c1 = 1.0 - phi2 / 12.0  # 2 (1 - cos phi) / phi^2
        sinc = 1.0 - phi2 / 6.0  # sin phi / phi
        cphi = 1.0 - 0.5 * phi2
    else:
        phi = np.sqrt(phi2)
        cphi = np.cos(phi)
        c1 = 2.0 * (1.0 - cphi) / phi2
        sinc = np.sin(phi) / phi
    force = k * delta0 * c1 + 2.0 * d / dt * (1.0 - sinc) + df * (1.0 - c1)
    end = delta0 * cphi + d / mred * dt * sinc + df / mred * dt * dt * 0.5 * c1
    return force, end


@njit(cache=True, inline="always")
def implicit_spring(k, mred, delta0, d, df, dt, theta):
    """One interface direction over the step with the force k ((1 - theta) delta0 + theta
    delta_end), solved together with the end opening the MPM update lands on: delta_end =
    delta0 + dt/m_red (d + dt/2 (df - force)) (FLIP's position update). Returns (force,
    end opening). theta = 1/2 is the trapezoidal rule (implicit midpoint: one isolated pair
    keeps its energy for any phi^2 = k dt^2 / m_red); theta = 1 is backward Euler, which
    damps the interface's own oscillation (tests/unit/test_interfaces.py). At rest both give
    force = k delta."""
    phi2 = k * dt * dt / mred
    free_end = delta0 + dt * d / mred + 0.5 * dt * dt * df / mred  # the end opening without the spring
    force = k * ((1.0 - theta) * delta0 + theta * free_end) / (1.0 + 0.5 * theta * phi2)
    return force, free_end - 0.5 * dt * dt * force / mred


@njit(cache=True, inline="always")
def direction_force(D, area, mred, delta0, d, df, dt, mode):
    """(force on a, energy, bonded?) for one imperfect direction with stiffness D."""
    k = D * area
    if mode == FORCE_LIMIT or mode == FIRST_ORDER:
        # the 2013 paper: first-order force; with its limit, bonded when the force exceeds the
        # one that would bring both materials to the centre of mass within the step (Eq. 26).
        # Without the limit (first_order) a stiff interface goes unstable (paper Fig. 12).
        force = k * delta0
        limit = 2.0 * mred * delta0 / (dt * dt) + 2.0 * d / dt + df
        if mode == FORCE_LIMIT and abs(force) > abs(limit):
            return 0.0, 0.0, True
        return force, 0.5 * k * delta0 * delta0, False
    if mode == BACKWARD_EULER or mode == TRAPEZOIDAL:
        force, end = implicit_spring(k, mred, delta0, d, df, dt, 1.0 if mode == BACKWARD_EULER else 0.5)
    else:
        force, end = oscillator(k, mred, delta0, d, df, dt)
    return force, 0.5 * k * end * end, False


@njit(cache=True, inline="always")
def interface_impulse(stiff, bonded, dp, df, n, delta_n, open_t, area, mred, dt, mode, dim, out):
    """Pass 2 at an interface: bonded directions take the stick impulse dp, the others the
    interface force times dt. dp: stick impulse on the updated momenta; df: relative force
    (m_a/M) F - f_a of the update; delta_n: start-of-step normal opening; open_t: tangential
    opening vector (b - a). Returns the interfacial energy at the end of the step."""
    dotn = 0.0
    dfn = 0.0
    for d in range(dim):
        dotn += dp[d] * n[d]
        dfn += df[d] * n[d]
    energy = 0.0
    # normal: stiffness by the sign of the opening (bilinear law)
    if bonded & 1:
        for d in range(dim):
            out[d] = dotn * n[d]
    elif bonded & 4:  # held by the consistent-bond constraints (contact.bond), applied after this
        for d in range(dim):
            out[d] = 0.0
    else:
        D = stiff[0] if delta_n >= 0.0 else stiff[1]
        f, e, stuck = direction_force(D, area, mred, delta_n, dotn - dfn * dt, dfn, dt, mode)
        if stuck:
            f = dotn / dt
            e = 0.0
        for d in range(dim):
            out[d] = f * dt * n[d]
        energy += e
    # tangential: one direction, that of the tangential opening (or of the stick impulse)
    t0 = 0.0
    t1 = 0.0
    t2 = 0.0
    mag = 0.0
    for d in range(dim):
        mag += open_t[d] * open_t[d]
    use_open = mag > 0.0
    if not use_open:
        for d in range(dim):
            td = dp[d] - dotn * n[d]
            mag += td * td
    if mag > 0.0:
        mag = np.sqrt(mag)
        for d in range(dim):
            td = (open_t[d] if use_open else dp[d] - dotn * n[d]) / mag
            if d == 0:
                t0 = td
            elif d == 1:
                t1 = td
            else:
                t2 = td
    elif dim == 2:
        t0 = -n[1]
        t1 = n[0]
    if bonded & 2:
        for d in range(dim):
            out[d] += dp[d] - dotn * n[d]
        return energy
    dpt = dp[0] * t0 + dp[1] * t1 + (dp[2] * t2 if dim == 3 else 0.0)
    dft = df[0] * t0 + df[1] * t1 + (df[2] * t2 if dim == 3 else 0.0)
    delta_t = mag if use_open else 0.0
    f, e, stuck = direction_force(stiff[2], area, mred, delta_t, dpt - dft * dt, dft, dt, mode)
    if stuck:
        f = dpt / dt
        e = 0.0
    out[0] += f * dt * t0
    out[1] += f * dt * t1
    if dim == 3:
        out[2] += f * dt * t2
    return energy + e


__all__ = ["apply_law", "interface_impulse", "oscillator", "register_law", "plugin_dispatch", "STICK", "FRICTIONLESS",
           "COULOMB", "INTERFACE"]

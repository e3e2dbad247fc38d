"""Cohesive traction-separation laws (mpmsim/contact/cohesive.py) against their closed forms:
loading, unloading and reloading along the damaged stiffness, mode mixing, the energy to full
failure, and damage that never decreases (issue 78, Must show 1)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpmsim.contact.cohesive import (damage_at, dissipation, law_parameters, law_points, scaled_opening, stiffnesses,
                                     toughness, tractions, updated_damage)

pytestmark = pytest.mark.cohesive

SIG, TAU, GI, GII, KN, KT = 30.0, 45.0, 0.3, 0.9, 1.0e4, 4.0e3  # MPa, MPa, mJ/mm^2, MPa/mm


def bilinear(mixed="bk", exponent=2.0):
    return law_parameters("bilinear", SIG, TAU, GI, GII, KN, KT, mixed, exponent)


def exponential(mixed="bk", exponent=2.0):
    return law_parameters("exponential", SIG, TAU, GI, GII, mixed=mixed, exponent=exponent)


def walk(p, path, dt_of=lambda dn: 0.0):
    """Drive the law along normal openings `path` (the tangential one dt_of(dn)): tractions and
    damage at each point, damage carried as the particles carry it."""
    d, out = 0.0, []
    for dn in path:
        d = updated_damage(dn, dt_of(dn), d, p)
        out.append((*tractions(dn, dt_of(dn), d, p), d))
    return np.array(out)


def test_bilinear_mode_one_loading_unloading_reloading_follow_the_triangle():
    """Pure mode I: T = Kn dn to d0 = sigma_c / Kn, then the straight line to zero at
    df = 2 G_Ic / sigma_c; from a peak opening d*, unloading and reloading on T = T(d*) dn / d*;
    past d* the softening line again; compression at the intact stiffness."""
    p = bilinear()
    d0, df = SIG / KN, 2 * GI / SIG
    star = 0.5 * (d0 + df)
    path = np.concatenate([np.linspace(0, star, 41), np.linspace(star, -0.5 * d0, 31), np.linspace(-0.5 * d0, df * 1.2, 61)])
    got = walk(p, path)
    peak = np.maximum.accumulate(path)
    soft = lambda x: np.where(x <= d0, KN * x, np.where(x >= df, 0.0, SIG * (df - x) / (df - d0)))
    secant = np.where(peak > 0, soft(np.maximum(peak, 1e-300)) / np.maximum(peak, 1e-300), KN)
    expect = np.where(path < 0, KN * path, np.where(peak <= d0, KN * path, secant * path))
    assert np.allclose(got[:, 0], expect, rtol=1e-12, atol=1e-12 * SIG)
    assert tractions(d0, 0.0, updated_damage(d0, 0.0, 0.0, p), p)[0] == pytest.approx(SIG, rel=1e-12)  # the peak
    assert np.max(got[:, 0]) <= SIG * (1 + 1e-12)
    assert got[-1, 2] == 1.0 and got[-1, 0] == 0.0


def test_exponential_mode_one_is_xu_needleman_and_unloads_to_the_origin():
    """T = e sigma_c (dn / dc) exp(-dn / dc), dc = G_Ic / (e sigma_c): peak sigma_c at dc;
    unloading from d* along T(d*) dn / d*."""
    p = exponential()
    dc = GI / (math.e * SIG)
    star = 2.5 * dc
    path = np.concatenate([np.linspace(0, star, 51), np.linspace(star, 0.3 * dc, 21), np.linspace(0.3 * dc, 4 * dc, 41)])
    got = walk(p, path)
    xn = lambda x: math.e * SIG * (x / dc) * np.exp(-x / dc)
    peak = np.maximum.accumulate(path)
    expect = np.where(path >= peak, xn(path), xn(peak) * path / np.maximum(peak, 1e-300))
    assert np.allclose(got[:, 0], expect, rtol=1e-12, atol=1e-12 * SIG)
    assert xn(dc) == pytest.approx(SIG, rel=1e-15)
    assert stiffnesses(p)[0] == pytest.approx(math.e * SIG / dc, rel=1e-12)


@pytest.mark.parametrize("make", [bilinear, exponential])
def test_pure_mode_two_is_the_mode_one_law_with_tau_and_G_IIc(make):
    """Shear alone: the tangential traction follows the mode I shape with tau_c, G_IIc, Kt;
    the sign of the slip is the traction's."""
    p = make()
    kt = stiffnesses(p)[1]
    for s in (1.0, -1.0):
        d = 0.0
        for dt in np.linspace(0, 3 * GII / TAU, 200):
            d = updated_damage(0.0, s * dt, d, p)
            tn, tt = tractions(0.0, s * dt, d, p)
            lam = math.sqrt(kt) * dt
            l0, lf = law_points(1.0, p)
            if make is bilinear:
                ref = lam if lam <= l0 else (0.0 if lam >= lf else l0 * (lf - lam) / (lf - l0))
            else:
                ref = lam * math.exp(-lam / l0) if lam < lf else 0.0
            assert tn == 0.0
            assert tt == pytest.approx(s * math.sqrt(kt) * ref, rel=1e-12, abs=1e-12 * TAU)
    assert law_points(1.0, bilinear())[0] * math.sqrt(KT) == pytest.approx(TAU, rel=1e-12)


@pytest.mark.parametrize("mixed,exponent", [("bk", 1.45), ("power_law", 1.0), ("power_law", 2.0)])
def test_mixed_mode_toughness_onset_and_tractions_in_proportional_loading(mixed, exponent):
    """Proportional loading at mixity B: the onset satisfies the quadratic traction criterion
    (sigma / sigma_c)^2 + (tau / tau_c)^2 = 1, the energy at failure is G_c(B) of the criterion
    (BK: G_Ic + (G_IIc - G_Ic) B^eta; power law: (G_I / G_Ic)^a + (G_II / G_IIc)^a = 1), and
    the two tractions stay in the ratio of the openings' stiffness-weighted parts."""
    p = bilinear(mixed, exponent)
    for B in (0.0, 0.2, 0.5, 0.8, 1.0):
        G = toughness(B, p)
        if mixed == "bk":
            assert G == pytest.approx(GI + (GII - GI) * B ** exponent, rel=1e-14)
        else:
            assert ((1 - B) * G / GI) ** exponent + (B * G / GII) ** exponent == pytest.approx(1.0, rel=1e-12)
        l0, lf = law_points(B, p)
        # openings with this mixity: yn = lam sqrt(1 - B), yt = lam sqrt(B)
        dn, dt = l0 * math.sqrt(1 - B) / math.sqrt(KN), l0 * math.sqrt(B) / math.sqrt(KT)
        lam, b = scaled_opening(dn, dt, p)
        assert lam == pytest.approx(l0, rel=1e-13) and b == pytest.approx(B, rel=1e-12, abs=1e-15)
        tn, tt = tractions(dn, dt, updated_damage(dn, dt, 0.0, p), p)
        assert (tn / SIG) ** 2 + (tt / TAU) ** 2 == pytest.approx(1.0, rel=1e-12)
        # the work of the proportional path to failure, integrated exactly on its two lines
        assert 0.5 * l0 * lf == pytest.approx(G, rel=1e-14)
        # beyond the onset: traction ratio = stiffness-weighted opening ratio, both softening together
        x = 0.5 * (l0 + lf) / l0
        d = updated_damage(x * dn, x * dt, 0.0, p)
        tn2, tt2 = tractions(x * dn, x * dt, d, p)
        assert tn2 == pytest.approx((1 - d) * KN * x * dn, rel=1e-13)
        assert tt2 == pytest.approx((1 - d) * KT * x * dt, rel=1e-13, abs=1e-300)


@pytest.mark.parametrize("make", [bilinear, exponential])
@pytest.mark.parametrize("B", [0.0, 0.3, 1.0])
def test_energy_dissipated_to_full_failure_is_G_c(make, B):
    """Summed over any sequence of damage increments, `dissipation` is G_c(B) from intact to
    failed (to 1e-10); and it is what the tractions' work less the stored energy says, on a
    path that unloads and reloads (bilinear: the work integrated exactly piece by piece)."""
    p = make()
    G = toughness(B, p)
    l0, lf = law_points(B, p)
    for n in (1, 7, 1000):
        lams = np.concatenate([np.linspace(0.0, lf, n + 1), [lf * 1.01]])
        ds = [damage_at(x, B, p) for x in lams]
        total = sum(dissipation(a, b, B, p) for a, b in zip(ds[:-1], ds[1:]))
        assert total == pytest.approx(G, rel=1e-10)
    assert dissipation(0.4, 0.4, B, p) == 0.0 and dissipation(0.5, 0.4, B, p) == 0.0
    if make is bilinear:
        # work of the scaled traction (1 - d) lam along lam: 0 -> k1 -> 0.3 k1 -> k2 -> lf, exact (linear pieces)
        k1, k2 = l0 + 0.3 * (lf - l0), l0 + 0.7 * (lf - l0)
        sec = lambda k: 1 - damage_at(k, B, p)
        work = 0.5 * l0 * l0 + 0.5 * (k1 - l0) * (l0 + sec(k1) * k1)  # loading to k1
        work -= 0.5 * sec(k1) * (k1 ** 2 - (0.3 * k1) ** 2)  # unloading to 0.3 k1
        work += 0.5 * sec(k1) * (k1 ** 2 - (0.3 * k1) ** 2)  # reloading to k1
        work += 0.5 * (k2 - k1) * (sec(k1) * k1 + sec(k2) * k2) + 0.5 * (lf - k2) * sec(k2) * k2
        assert work == pytest.approx(G, rel=1e-12)
        stored = 0.5 * sec(k1) * k1 * k1
        assert work - stored - (G - stored) == pytest.approx(0.0, abs=1e-14)
        assert dissipation(0.0, damage_at(k1, B, p), B, p) == pytest.approx(
            0.5 * l0 * l0 + 0.5 * (k1 - l0) * (l0 + sec(k1) * k1) - stored, rel=1e-12)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.05, 0.1), st.floats(-0.1, 0.1)), min_size=1, max_size=40),
       st.sampled_from(["bilinear", "exponential"]), st.sampled_from(["bk", "power_law"]))
def test_damage_never_decreases_and_compression_never_softens(path, shape, mixed):
    """Any path of openings: the damage carried never decreases, stays in [0, 1], and a closed
    normal keeps the intact stiffness whatever the damage."""
    p = law_parameters(shape, SIG, TAU, GI, GII, KN, KT, mixed, 1.7)
    kn = stiffnesses(p)[0]
    d = 0.0
    for dn, dt in path:
        new = updated_damage(dn, dt, d, p)
        assert d <= new <= 1.0
        d = new
        tn, _ = tractions(min(dn, -1e-6), dt, d, p)
        assert tn == pytest.approx(kn * min(dn, -1e-6), rel=1e-15)

"""Error metrics on history columns (dict name -> array), as named in a sweep file.

Also used by bench/ and the tests, so the contact paper's Fig. 5 error and the interface
paper's bulk moduli (Eqs. 34-36) are computed in one place.
"""

from __future__ import annotations

import numpy as np


def column(history: dict, expr: str) -> np.ndarray:
    """A history column by name, or a numpy expression of columns (`-u_platen_y / 100`)."""
    if expr in history:
        return np.asarray(history[expr], dtype=float)
    names = {k: np.asarray(v, dtype=float) for k, v in history.items() if k.isidentifier()}
    try:
        return np.asarray(eval(expr, {"__builtins__": {}, "np": np}, names), dtype=float)  # noqa: S307 (our own sweep files)
    except NameError as exc:
        raise KeyError(f"'{expr}': {exc}; history columns: {', '.join(history)}") from None


def max_rel_error(x: np.ndarray, y: np.ndarray, x_ref: np.ndarray, y_ref: np.ndarray,
                  lo: float = -np.inf, hi: float = np.inf) -> float:
    """max |y - y_ref| / |y_ref| over x in [lo, hi], the reference interpolated at x (no
    extrapolation past its range). NaN if no point is in range."""
    order = np.argsort(x_ref, kind="stable")
    x_ref, y_ref = np.asarray(x_ref)[order], np.asarray(y_ref)[order]
    keep = (x >= lo) & (x <= hi) & (x >= x_ref[0]) & (x <= x_ref[-1])
    if not keep.any():
        return float("nan")
    ref = np.interp(x[keep], x_ref, y_ref)
    return float(np.max(np.abs(y[keep] - ref) / np.abs(ref)))


def relative_error_curve(x, y, x_ref, y_ref, lo=-np.inf, hi=np.inf) -> tuple[np.ndarray, np.ndarray]:
    """(x, (y - y_ref) / |y_ref|) over the same points as max_rel_error (signed, for plots)."""
    order = np.argsort(x_ref, kind="stable")
    x_ref, y_ref = np.asarray(x_ref)[order], np.asarray(y_ref)[order]
    keep = (x >= lo) & (x <= hi) & (x >= x_ref[0]) & (x <= x_ref[-1])
    ref = np.interp(x[keep], x_ref, y_ref)
    return x[keep], (y[keep] - ref) / np.abs(ref)


def zero_crossings(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Times where y changes sign, by linear interpolation."""
    i = np.nonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)[0]
    return t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])


def period(t: np.ndarray, y: np.ndarray) -> float:
    """Mean period of an oscillation from its zero crossings (half a period apart); NaN with
    fewer than two crossings."""
    tc = zero_crossings(np.asarray(t, float), np.asarray(y, float))
    return 2 * (tc[-1] - tc[0]) / (len(tc) - 1) if len(tc) >= 2 else float("nan")


def energy_change(energy: np.ndarray, at: str = "end") -> float:
    e = np.asarray(energy, float)
    change = np.abs(e - e[0]) / abs(e[0])
    return float(change[-1] if at == "end" else change.max())


def cube_bulk_modulus(strain_energy: float, pressure: float, side: float, strain: float) -> tuple[float, float]:
    """(K from energy, K from pressure) of a cube of `side` whose faces are pulled out by
    `strain` in all three directions (imperfect-interface paper, Eqs. 34-36).

    Read at finite strain, as the history reports them: the strain energy is summed over the
    current volume V = (side (1 + strain))^3 and the stress is the Cauchy average, which a
    hypoelastic law integrates against the logarithmic volume strain e_v = ln(V/V0). So
    K = 2 U / (V e_v^2) (Eq. 34) and K = P / e_v (Eq. 36). The paper's small-strain forms
    (V = side^3, e_v = 3 strain) read K from energy 1.0% high and K from pressure 0.25% low
    at 0.5% strain, on a uniform cube as much as on a composite."""
    e_v = 3.0 * np.log1p(strain)
    volume = (side * (1.0 + strain)) ** 3
    return 2.0 * strain_energy / (volume * e_v**2), pressure / e_v


def csa_bulk_modulus(E_m: float, nu_m: float, E_p: float, nu_p: float, fraction: float,
                     Dn: float = np.inf, radius: float = 1.0) -> float:
    """Composite spheres assemblage (Hashin 1962): particles (E_p, nu_p) of `radius` at volume
    `fraction` in a matrix (E_m, nu_m), bonded by a normal interface spring Dn (Hashin 1991;
    Dt does no work under pressure). The composite sphere's radial field, u = A r in the particle
    and u = B r + C / r^2 in the matrix, with the outer radius b moved to u(b) = b:
    sigma_rr continuous at r = a, sigma_rr(a) = Dn [u_m(a) - u_p(a)]; then K = sigma_rr(b) / 3.
    Dn = inf is the perfect interface's closed form."""
    K_m, G_m, K_p = E_m / (3 * (1 - 2 * nu_m)), E_m / (2 * (1 + nu_m)), E_p / (3 * (1 - 2 * nu_p))
    a, b3 = radius, radius**3 / fraction
    system = np.array([[3 * K_p, -3 * K_m, 4 * G_m / a**3],      # radial stress continuous at a
                       [3 * K_p / Dn + a, -a, -1 / a**2],       # the spring: opening = sigma_rr / Dn
                       [0.0, 1.0, 1 / b3]])                     # u(b) = b
    _, B, C = np.linalg.solve(system, [0.0, 0.0, 1.0])
    return float(K_m * B - 4 * G_m * C / (3 * b3))


def evaluate(metric, history: dict, reference: dict | None, analytic) -> float:
    """One sweep metric on a run's history; `reference`: the reference run's history (or None),
    `analytic`: the sweep's reference.analytic (or None)."""
    kind = metric.type
    if kind == "max_rel_error":
        x, y = column(history, metric.x), column(history, metric.column)
        lo, hi = metric.range if metric.range is not None else (-np.inf, np.inf)
        if reference is not None:
            x_ref, y_ref = column(reference, metric.x), column(reference, metric.column)
        else:  # the analytic curve, on the run's own abscissae
            x_ref = x
            curve = analytic.curve
            if curve.expression is not None:
                y_ref = np.broadcast_to(eval(curve.expression, {"__builtins__": {}, "np": np}, {"x": x}), x.shape)  # noqa: S307
            else:
                y_ref = np.interp(x, curve.x, curve.y)
                inside = (x >= min(curve.x)) & (x <= max(curve.x))
                x, y, x_ref, y_ref = x[inside], y[inside], x_ref[inside], y_ref[inside]
            if len(x) == 0:
                return float("nan")
        return max_rel_error(x, y, x_ref, y_ref, lo, hi)
    if kind == "period_error":
        if metric.expected is None:  # the reference run's own period
            expected = period(reference["time"], column(reference, metric.column))
        elif isinstance(metric.expected, str):
            expected = analytic.values[metric.expected]
        else:
            expected = float(metric.expected)
        return abs(period(history["time"], column(history, metric.column)) / expected - 1.0)
    if kind == "energy_change":
        return energy_change(sum(column(history, c) for c in metric.columns), metric.at)
    if kind == "acceleration_error":
        expected = analytic.values[metric.expected] if isinstance(metric.expected, str) else float(metric.expected)
        candidates = [metric.column] if isinstance(metric.column, str) else metric.column
        for k, expr in enumerate(candidates):
            try:
                y = column(history, expr)
                break
            except KeyError:
                if k == len(candidates) - 1:
                    raise
        return abs(acceleration(history["time"], y, metric.range, metric.of == "velocity") / expected - 1.0)
    raise ValueError(f"unknown metric type {kind}")


def acceleration(t: np.ndarray, y: np.ndarray, window=None, velocity: bool = False) -> float:
    """The acceleration of a position (twice the leading coefficient of the parabola fitted by
    least squares) or velocity (the slope of the fitted line) y(t) over the window [a, b] (all
    times when None); nan with too few samples."""
    lo, hi = window if window is not None else (-np.inf, np.inf)
    keep = (t >= lo) & (t <= hi)
    if keep.sum() < 3:
        return float("nan")
    if velocity:
        return float(np.polyfit(t[keep], y[keep], 1)[0])
    return float(2.0 * np.polyfit(t[keep], y[keep], 2)[0])

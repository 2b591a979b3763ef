"""Independent oracles for the condition hierarchy and impossibility diagnostics (issue 15).

Nothing here imports ``hybobs_opt`` except :func:`pendulum`, which only *builds* the system under
test with the package's public constructors.  Every number a test compares against is computed
below from the equations of the damped pendulum written by hand:

    theta'' = -G sin(theta) - DAMPING theta' + u,     y = h(theta),  h in {cos, exp(-z^2), sin},

i.e. ``x' = A x + F f(E x) + B u`` with ``A = [[0, 1], [0, -DAMPING]]``, ``F = [[0], [-G]]``,
``E = [1, 0]``, ``f = sin``, ``C = [1, 0]``.  The oracles are

* closed-form derivatives and their dense sampling (the slope box of an interval);
* the vertex matrices ``A_v = A + F theta_v E``, ``C_v = mu_v C`` of that box, in model or
  scaled coordinates (``x = diag(d) x_bar``, ``d`` the half-widths of the operating box), and the
  numpy eigenvalue check of ``P A_cl + A_cl^T P < 0`` at every vertex;
* the observer LMI of paper 004 with explicit S-procedure multipliers, assembled block by block,
  and the polytopic vertex LMIs, evaluated at random ``(P, L, eps)`` and paired with a
  certificate's multipliers (the duality argument ``<Z, B> > 0``);
* simulations with :func:`scipy.integrate.solve_ivp` of the plant and of the observer (6);
* the closed-form eigenvalue of the linearisation at the upright position.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81
DAMPING = 0.5
BOX_LO = np.array([-math.pi, -10.0])
BOX_HI = np.array([math.pi, 10.0])

A_MAT = np.array([[0.0, 1.0], [0.0, -DAMPING]])
F_MAT = np.array([[0.0], [-G]])
E_MAT = np.array([[1.0, 0.0]])
C_MAT = np.array([[1.0, 0.0]])
B_MAT = np.array([[0.0], [1.0]])

#: sensor name -> (expression for the package, h, h')
SENSORS = {
    "cos": ("cos(z)", np.cos, lambda z: -np.sin(z)),
    "gauss": ("exp(-z**2)", lambda z: np.exp(-z ** 2), lambda z: -2.0 * z * np.exp(-z ** 2)),
    "sin": ("sin(z)", np.sin, np.cos),
}

#: The upright linearisation [[0, 1], [G, -DAMPING]]: its unstable eigenvalue in closed form.
UPRIGHT_EIGENVALUE = (-DAMPING + math.sqrt(DAMPING ** 2 + 4.0 * G)) / 2.0


def pendulum(sensor: str, *, driven: bool = False):
    """The pendulum measured through ``sensor``, built with the package's public constructors."""
    from hybobs_opt.geometry.polytope import Polytope
    from hybobs_opt.systems.scalar_nonlinear import ScalarFunction, ScalarNonlinearSystem

    box = Polytope.from_box(BOX_LO.tolist(), BOX_HI.tolist(), ("theta", "omega"))
    expr = SENSORS[sensor][0]
    kw = dict(B=B_MAT.tolist(), input_names=("torque",)) if driven else {}
    return ScalarNonlinearSystem(
        box=box, C=C_MAT.tolist(), h=(ScalarFunction.from_text(sensor, expr),), A=A_MAT.tolist(), F=F_MAT.tolist(),
        E=E_MAT.tolist(), f=(ScalarFunction.from_text("sin", "sin(z)"),), state_names=("theta", "omega"),
        name=f"pendulum_{sensor}", **kw)


def half_widths() -> np.ndarray:
    """The scaling ``d`` (half-widths of the operating box), from the numbers above."""
    return 0.5 * (BOX_HI - BOX_LO)


# ---------------------------------------------------------------------------- slopes
def slope_box(sensor: str, lo: float, hi: float, samples: int = 200_001) -> tuple[tuple[float, float], tuple[float, float]]:
    """``((theta_min, theta_max), (mu_min, mu_max))``: ranges of ``sin'`` and ``h'`` on ``[lo, hi]``.

    Dense sampling (end points included) plus the closed-form critical points of the derivatives
    that fall inside (``cos'`` at ``k pi``, ``(-sin)'`` at ``pi/2 + k pi``, ``(-2z e^{-z^2})'`` at
    ``+-1/sqrt 2``).
    """
    z = np.linspace(lo, hi, samples)
    crit_f = [k * math.pi for k in range(-3, 4)]
    crit_h = {"cos": [math.pi / 2 + k * math.pi for k in range(-3, 4)], "sin": [k * math.pi for k in range(-3, 4)],
              "gauss": [-1 / math.sqrt(2), 1 / math.sqrt(2)]}[sensor]
    zf = np.concatenate([z, [c for c in crit_f if lo <= c <= hi]])
    zh = np.concatenate([z, [c for c in crit_h if lo <= c <= hi]])
    th = np.cos(zf)
    mu = SENSORS[sensor][2](zh)
    return (float(th.min()), float(th.max())), (float(mu.min()), float(mu.max()))


def vertices(sensor: str, lo: float, hi: float, d: np.ndarray | None = None) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Vertex matrices ``A_v = A + F theta E``, ``C_v = mu C`` of the slope box (4 vertices).

    With ``d``: in the scaled coordinates ``x = diag(d) x_bar`` (``D^-1 A_v D``, ``C_v D``).
    """
    (t0, t1), (m0, m1) = slope_box(sensor, lo, hi)
    As, Cs = [], []
    for th in (t0, t1):
        for mu in (m0, m1):
            Av = A_MAT + th * F_MAT @ E_MAT
            Cv = mu * C_MAT
            if d is not None:
                Av = np.diag(1.0 / d) @ Av @ np.diag(d)
                Cv = Cv @ np.diag(d)
            As.append(Av)
            Cs.append(Cv)
    return As, Cs


def vertex_lyapunov_max_eig(P: np.ndarray, L: np.ndarray, sensor: str, lo: float, hi: float) -> float:
    """``max_v lambda_max(P A_cl + A_cl^T P)`` over the vertices (model coordinates), normalised by
    ``P`` (``P^{-1/2} (...) P^{-1/2}``, so it is ``-`` the decay rate of ``e^T P e`` it proves)."""
    P = 0.5 * (np.asarray(P, float) + np.asarray(P, float).T)
    w, U = np.linalg.eigh(P)
    assert w.min() > 0, f"P is not positive definite: eigenvalues {w}"
    Pih = U @ np.diag(w ** -0.5) @ U.T
    out = -np.inf
    for Av, Cv in zip(*vertices(sensor, lo, hi)):
        Acl = Av - np.asarray(L, float).reshape(2, 1) @ Cv
        M = Pih @ (P @ Acl + Acl.T @ P) @ Pih
        out = max(out, float(np.linalg.eigvalsh(0.5 * (M + M.T)).max()))
    return out


# ---------------------------------------------------------------------------- LMIs written from the paper
def scaled_data(d: np.ndarray) -> dict[str, np.ndarray]:
    """``A, F, E, C`` in the coordinates ``x = diag(d) x_bar``."""
    D, Di = np.diag(d), np.diag(1.0 / d)
    return {"A": Di @ A_MAT @ D, "F": Di @ F_MAT, "E": E_MAT @ D, "C": C_MAT @ D}


def observer_lmi_matrix(data: dict, P, Y, eps_f: float, eps_h: float, U: float, V: float, M: float, N: float,
                        sigma: float = 0.0) -> np.ndarray:
    """LMI (8)-type block matrix of paper 004 for one ``f`` and one nonlinear output, multipliers explicit.

    ``[[He(PA) + sigma P - eps_f U V E^T E - eps_h M N C^T C, PF + eps_f (U+V)/2 E^T, -Y + eps_h (M+N)/2 C^T],
       [*, -eps_f, 0], [*, 0, -eps_h]]`` (Y = P L; the output error enters through the off-diagonal block).
    """
    A, F, E, C = data["A"], data["F"], data["E"], data["C"]
    B11 = P @ A + A.T @ P + sigma * P - eps_f * U * V * E.T @ E - eps_h * M * N * C.T @ C
    B12 = P @ F + eps_f * 0.5 * (U + V) * E.T
    B13 = -Y + eps_h * 0.5 * (M + N) * C.T
    out = np.zeros((4, 4))
    out[:2, :2] = B11
    out[:2, 2:3], out[2:3, :2] = B12, B12.T
    out[:2, 3:4], out[3:4, :2] = B13, B13.T
    out[2, 2], out[3, 3] = -eps_f, -eps_h
    return 0.5 * (out + out.T)


def vertex_lmi_matrices(As, Cs, P, Y, sigma: float = 0.0) -> list[np.ndarray]:
    """``B_v = P A_v + A_v^T P - Y C_v - C_v^T Y^T + sigma P`` for every vertex."""
    out = []
    for Av, Cv in zip(As, Cs):
        B = P @ Av + Av.T @ P - Y @ Cv - Cv.T @ Y.T + sigma * P
        out.append(0.5 * (B + B.T))
    return out


def random_pd(rng: np.random.Generator, n: int) -> np.ndarray:
    """A random positive definite matrix with condition number up to ~1e4."""
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    w = 10.0 ** rng.uniform(-2, 2, size=n)
    return Q @ np.diag(w) @ Q.T


def random_gain(rng: np.random.Generator, n: int, p: int) -> np.ndarray:
    """A random gain, entries of magnitude 1e-2 .. 1e2 (scaled coordinates)."""
    return rng.normal(size=(n, p)) * 10.0 ** rng.uniform(-2, 2)


def inner(X: np.ndarray, Y: np.ndarray) -> float:
    return float(np.sum(X * Y))


# ---------------------------------------------------------------------------- simulations
def reference(lo: float, hi: float):
    """``theta_ref(t) = mid + 0.25 width sin t`` and its first two derivatives."""
    mid, a = 0.5 * (lo + hi), 0.25 * (hi - lo)
    return (lambda t: mid + a * math.sin(t)), (lambda t: a * math.cos(t)), (lambda t: -a * math.sin(t))


def computed_torque(lo: float, hi: float, kp: float = 25.0, kd: float = 10.0):
    """A controller ``u(t, x)`` making theta track the reference exactly from the reference's initial state."""
    r, rd, rdd = reference(lo, hi)

    def u(t, x):
        th, om = x
        return rdd(t) + G * math.sin(th) + DAMPING * om + kp * (r(t) - th) + kd * (rd(t) - om)

    return u, np.array([r(0.0), rd(0.0)])


def simulate_observer(sensor: str, L: np.ndarray, lo: float, hi: float, e0: np.ndarray, T: float = 20.0,
                      samples: int = 2001, method: str = "DOP853"):
    """Plant under computed torque and the observer (6) ``x_hat' = f(x_hat) + B u + L (y - h(x_hat))``.

    Returns ``(t, x, x_hat)``; the observer starts at ``x(0) + e0``.
    """
    h = SENSORS[sensor][1]
    u, x0 = computed_torque(lo, hi)
    L = np.asarray(L, dtype=float).reshape(2)

    def rhs(t, s):
        x, xh = s[:2], s[2:]
        ut = u(t, x)
        dx = [x[1], -G * math.sin(x[0]) - DAMPING * x[1] + ut]
        innov = float(h(x[0]) - h(xh[0]))
        dxh = [xh[1] + L[0] * innov, -G * math.sin(xh[0]) - DAMPING * xh[1] + ut + L[1] * innov]
        return dx + dxh

    t_eval = np.linspace(0.0, T, samples)
    sol = solve_ivp(rhs, (0.0, T), np.concatenate([x0, x0 + np.asarray(e0, float)]), method=method,
                    rtol=1e-11, atol=1e-13, t_eval=t_eval)
    assert sol.success, sol.message
    return sol.t, sol.y[:2].T, sol.y[2:].T


def simulate_outputs(sensor: str, x0: np.ndarray, T: float = 10.0, samples: int = 1001):
    """The undriven pendulum from ``x0`` and its output ``y = h(theta)`` on a grid of ``[0, T]``."""
    h = SENSORS[sensor][1]

    def rhs(t, x):
        return [x[1], -G * math.sin(x[0]) - DAMPING * x[1]]

    t_eval = np.linspace(0.0, T, samples)
    sol = solve_ivp(rhs, (0.0, T), np.asarray(x0, float), method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t_eval)
    assert sol.success, sol.message
    return sol.t, sol.y.T, h(sol.y[0])


def linearisation(theta: float) -> np.ndarray:
    """Jacobian of the pendulum's vector field at angle ``theta`` (any omega)."""
    return np.array([[0.0, 1.0], [-G * math.cos(theta), -DAMPING]])


def unobservable_unstable_modes(sensor: str, theta: float, tol: float = 1e-9) -> list[complex]:
    """Eigenvalues ``lambda`` (Re >= 0) of the linearisation at ``theta`` with ``h'(theta) C v = 0`` (PBH)."""
    J = linearisation(theta)
    c = SENSORS[sensor][2](np.array([theta]))[0] * C_MAT
    lam, V = np.linalg.eig(J)
    return [complex(l) for l, v in zip(lam, V.T) if l.real >= -tol and abs(c @ v)[0] <= tol * max(1.0, np.linalg.norm(v))]

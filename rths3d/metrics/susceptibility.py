"""How susceptible a test is to transfer-system errors: φ, κ, ζ, τ-ratios (eqs. 12–14), PSI.

Single DOF (the paper): φ = m_NUM/m_EXP, κ = k_NUM/k_EXP, ζ = d_NUM / (2√(k_NUM m_NUM)),
ω_0,NUM = √(k_NUM/m_NUM), ω_0,DYN = √((k_NUM + k_EXP)/(m_NUM + m_EXP)).

Several DOF (this package's generalisation, documented in docs/metrics.md):

- ω_0,NUM is the *fastest* eigenfrequency of the numerical substructure, K v = ω² M v;
  ω_0,DYN the fastest of the coupled system M + Γ M_EXP Γᵀ, K + Γ K_EXP Γᵀ (Γ maps interface
  DOFs to numerical DOFs). For one DOF these reduce to the formulas above.
- ζ is the modal damping ratio vᵀCv / (2 ω vᵀMv) of that fastest numerical mode.
- φ and κ compare what each substructure presents at the interface: m_NUM,i = Γ_iᵀ M Γ_i and
  the static stiffness k_NUM,i = 1 / (Γ_iᵀ K⁻¹ Γ_i) for interface DOF i, against the diagonal of
  M_EXP and K_EXP.

Delay ratios (dimensionless): τ_ratio,NUM = d ω_0,NUM (eq. 13), τ_ratio,DYN = d ω_0,DYN (eq. 12),
and τ_ratio,max = d / τ_max (eq. 14), where the phase margin PM (rad) of the interface loop at
its crossover ω_c (rad/s) is converted into the delay margin τ_max = PM / ω_c so that the ratio is
dimensionless (a phase divided by a time is not).

PSI (Maghareh et al. 2017): PSI = log10(τ_cr / 1 ms), τ_cr the smallest interface delay at which
the coupled linear system with delayed interface coupling
    M ẍ + C ẋ + K x + Γ [M_EXP z̈' + C_EXP ż' + K_EXP z'] = 0,   z'(t) = Γᵀ x(t − τ)
loses stability. Its characteristic equation is det(I + L(iω) e^(−iωτ)) = 0 with the interface
loop L(iω) = Q_EXP(iω) Γᵀ P(iω)⁻¹ Γ (P = −ω²M + iωC + K, Q_EXP likewise). A delay can only
destabilise at a crossover, where an eigenvalue μ of L has |μ| = 1; there the phase margin
PM = angle(−μ) (wrapped to [0, 2π)) and the delay margin PM/ω_c. τ_cr is the smallest delay
margin over all crossovers; none (|μ| < 1 everywhere) means stable for every delay, τ_cr = ∞.
If |μ| > 1 as ω → ∞ (an experimental mass larger than the numerical one, a neutral system)
any delay destabilises: τ_cr = 0, PSI = −∞; so does a coupled system that is already unstable
without delay (an eigenvalue with Re > 0, e.g. negative damping). Classes: PSI > 0.7
slightly, 0…0.7 moderately, < 0 extremely sensitive.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ConfigError


def _mat(name: str, value, n: int | None = None) -> np.ndarray:
    try:
        arr = np.atleast_2d(np.asarray(value, dtype=float))
    except (TypeError, ValueError) as exc:
        raise ConfigError(name, value, "must be a number in SI units, without unit text, "
                                       "or a square matrix of numbers") from exc
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise ConfigError(name, arr.shape, "must be a square matrix (or a scalar)")
    if n is not None and arr.shape[0] != n:
        raise ConfigError(name, arr.shape, f"must be {n}×{n}")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(name, value, "must be finite")
    return arr


def _positive(name: str, value: float, unit: str) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise ConfigError(name, v, f"{unit}; must be finite and > 0")
    return v


def mass_ratio(m_num: float, m_exp: float) -> float:
    """Mass ratio φ = m_NUM / m_EXP (dimensionless; both in kg)."""
    return _positive("m_num", m_num, "kg") / _positive("m_exp", m_exp, "kg")


def stiffness_ratio(k_num: float, k_exp: float) -> float:
    """Stiffness ratio κ = k_NUM / k_EXP (dimensionless; both in N/m)."""
    return _positive("k_num", k_num, "N/m") / _positive("k_exp", k_exp, "N/m")


def damping_ratio(d_num: float, k_num: float, m_num: float) -> float:
    """Critical damping ratio ζ = d_NUM / (2√(k_NUM m_NUM)) of the numerical part."""
    d = float(d_num)
    if not math.isfinite(d) or d < 0:
        raise ConfigError("d_num", d, "kg/s; must be finite and >= 0")
    return d / (2.0 * math.sqrt(_positive("k_num", k_num, "N/m") *
                                _positive("m_num", m_num, "kg")))


def eigenfrequencies(M: ArrayLike, K: ArrayLike) -> np.ndarray:
    """Undamped eigenfrequencies ω (rad/s, ascending) from K v = ω² M v (M positive definite)."""
    import scipy.linalg

    m = _mat("M", M)
    k = _mat("K", K, m.shape[0])
    try:
        lam = scipy.linalg.eigh(k, m, eigvals_only=True)
    except np.linalg.LinAlgError as exc:
        raise ConfigError("M", m.tolist(), "must be symmetric positive definite") from exc
    return np.sqrt(np.clip(lam, 0.0, None))


def fastest_mode(M: ArrayLike, C: ArrayLike, K: ArrayLike) -> tuple[float, float]:
    """(ω_max in rad/s, modal damping ratio ζ of that mode) of M ẍ + C ẋ + K x = 0.

    M (kg) must be positive definite and C (N·s/m) positive semi-definite (d_NUM ≥ 0, as
    for :func:`damping_ratio`).
    """
    import scipy.linalg

    m = _mat("M", M)
    k = _mat("K", K, m.shape[0])
    c = _mat("C", C, m.shape[0])
    scale = float(np.abs(c).max())
    if scale > 0 and np.linalg.eigvalsh(0.5 * (c + c.T)).min() < -1e-12 * scale:
        raise ConfigError("C", c.tolist(), "N·s/m; damping must be >= 0 "
                          "(positive semi-definite)")
    try:
        lam, vec = scipy.linalg.eigh(k, m)
    except np.linalg.LinAlgError as exc:
        raise ConfigError("M", m.tolist(), "kg; must be symmetric positive definite") from exc
    v = vec[:, -1]
    w = math.sqrt(max(float(lam[-1]), 0.0))
    zeta = float(v @ c @ v) / (2.0 * w * float(v @ m @ v)) if w > 0 else float("nan")
    return w, zeta


def omega_num(M: ArrayLike, K: ArrayLike) -> float:
    """ω_0,NUM (rad/s): fastest eigenfrequency of the numerical substructure (eq. 13)."""
    return float(eigenfrequencies(M, K)[-1])


def _gamma(gamma, n: int, nd: int | None = None) -> np.ndarray:
    try:
        g = np.asarray(gamma if gamma is not None else np.ones((n, 1)), dtype=float)
    except (TypeError, ValueError) as exc:
        raise ConfigError("gamma", gamma, "must be a matrix of numbers") from exc
    if g.size == 0 or g.size % n:
        raise ConfigError("gamma", g.tolist(), f"must be {n}×ndof (numerical × interface DOFs)")
    g = g.reshape(n, -1)
    if nd is not None and g.shape[1] != nd:
        raise ConfigError("gamma", g.shape, f"must be {n}×{nd} (numerical × interface DOFs)")
    return g


def omega_dyn(M: ArrayLike, K: ArrayLike, M_exp: ArrayLike, K_exp: ArrayLike,
              gamma: ArrayLike | None = None) -> float:
    """ω_0,DYN (rad/s): fastest eigenfrequency of the coupled system (eq. 12).

    Coupled mass M + Γ M_EXP Γᵀ and stiffness K + Γ K_EXP Γᵀ; for one DOF
    √((k_NUM + k_EXP)/(m_NUM + m_EXP)).
    """
    m = _mat("M", M)
    n = m.shape[0]
    me = _mat("m_exp", M_exp)
    ke = _mat("k_exp", K_exp, me.shape[0])
    g = _gamma(gamma, n, me.shape[0])
    return omega_num(m + g @ me @ g.T, _mat("K", K, n) + g @ ke @ g.T)


def interface_properties(M: ArrayLike, K: ArrayLike, gamma: ArrayLike | None = None
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Mass Γ_iᵀ M Γ_i (kg) and static stiffness 1/(Γ_iᵀ K⁻¹ Γ_i) (N/m) per interface DOF i."""
    m = _mat("M", M)
    k = _mat("K", K, m.shape[0])
    g = _gamma(gamma, m.shape[0])
    mass = np.einsum("ij,ik,kj->j", g, m, g)
    try:
        flex = np.einsum("ij,ij->j", g, np.linalg.solve(k, g))
    except np.linalg.LinAlgError:
        flex = np.full(g.shape[1], np.inf)  # no static stiffness (free body): κ = 0
    with np.errstate(divide="ignore"):
        stiff = np.where(flex > 0, 1.0 / flex, np.inf)
    return mass, stiff


def tau_ratio(d: float, omega: float) -> float:
    """τ-ratio d / ω⁻¹ = d ω (eqs. 12, 13): delay d (s) times an eigenfrequency ω (rad/s)."""
    return float(d) * float(omega)


def delay_margin(phase_margin: float, crossover: float) -> float:
    """τ_max = PM / ω_c (s) from a phase margin PM (rad, in [0, 2π)) at crossover ω_c (rad/s).

    A PM outside [0, 2π) is refused: it is almost always a value in degrees, which would
    silently give a delay margin 57 times too large.
    """
    pm = float(phase_margin)
    wc = _positive("crossover", crossover, "rad/s")
    if not (math.isfinite(pm) and 0.0 <= pm < 2.0 * math.pi):
        raise ConfigError("phase_margin", pm, "rad, not degrees; must be in [0, 2π)")
    return pm / wc


def tau_ratio_max(d: float, tau_max: float) -> float:
    """τ_ratio,max = d / τ_max (eq. 14, with the phase margin as delay margin τ_max in s)."""
    tm = float(tau_max)
    if tm == math.inf:
        return 0.0
    return float(d) / tm if tm > 0 else float("nan")


@dataclass(frozen=True)
class InterfaceLoop:
    """Stability of the delayed interface loop L(iω) = Q_EXP Γᵀ P⁻¹ Γ.

    ``crossovers`` (rad/s) and ``phase_margins`` (rad) at every |μ| = 1 crossing;
    ``tau_cr`` (s) the smallest delay margin (∞: no crossing; 0: neutral, unstable for any
    delay, or already unstable without delay, where ``crossover`` and ``phase_margin`` are
    NaN); ``crossover`` and ``phase_margin`` of the crossing that sets τ_cr.
    """

    crossovers: np.ndarray
    phase_margins: np.ndarray
    tau_cr: float
    crossover: float
    phase_margin: float

    @property
    def psi(self) -> float:
        """Predictive stability indicator PSI = log10(τ_cr / 1 ms)."""
        if self.tau_cr <= 0.0:
            return -math.inf
        return math.log10(self.tau_cr / 1e-3)


def _loop_eigs(w: np.ndarray, m, c, k, me, ce, ke, g) -> np.ndarray:
    """Eigenvalues μ of L(iω) for an array of ω (shape (len(w), ndof))."""
    s = 1j * np.asarray(w, dtype=float).reshape(-1, 1, 1)
    p = (s * s) * m + s * c + k
    q = (s * s) * me + s * ce + ke
    gb = np.broadcast_to(g, (p.shape[0],) + g.shape)
    try:
        x = np.linalg.solve(p, gb)
    except np.linalg.LinAlgError:
        # an undamped numerical mode makes P(iω) exactly singular at its eigenfrequency, where
        # |μ| is unbounded: evaluate 1e-9 (relative) beside it, where μ is finite and huge
        x = np.empty(gb.shape, dtype=complex)
        for i in range(p.shape[0]):
            try:
                x[i] = np.linalg.solve(p[i], g)
            except np.linalg.LinAlgError:
                si = s[i] * (1.0 + 1e-9)
                x[i] = np.linalg.solve((si * si) * m + si * c + k, g)
    return np.linalg.eigvals(q @ (g.T @ x))


def interface_loop(M: ArrayLike, C: ArrayLike, K: ArrayLike, M_exp: ArrayLike,
                   C_exp: ArrayLike, K_exp: ArrayLike, gamma: ArrayLike | None = None, *,
                   n_grid: int = 2000) -> InterfaceLoop:
    """Crossovers, phase margins and critical delay of the coupled linear system.

    ``M, C, K``: numerical substructure (n × n, SI); ``M_exp, C_exp, K_exp``: experimental
    part at the interface (ndof × ndof or scalars); ``gamma``: Γ (n × ndof, default ones).
    If the coupled system without delay is already unstable (an eigenvalue of
    (M + ΓM_EXPΓᵀ)s² + (C + ΓC_EXPΓᵀ)s + K + ΓK_EXPΓᵀ with Re s > 1e-8 |s|_max) every delay
    is too much: τ_cr = 0, PSI = −∞ (extremely sensitive). An undamped coupled system sits on
    the boundary (Re s = 0), counts as stable and gives τ_cr = 0 from its crossover at ω_0,DYN
    (μ = −1, zero phase margin). Crossings are found on a logarithmic
    grid of ``n_grid`` frequencies spanning four decades around the eigenfrequencies (plus the
    eigenfrequencies themselves) and refined by Brent's method on |μ| − 1 (eigenvalues sorted
    by modulus).
    """
    m = _mat("M", M)
    n = m.shape[0]
    c = _mat("C", C, n)
    k = _mat("K", K, n)
    me = _mat("m_exp", M_exp)
    nd = me.shape[0]
    ce = _mat("c_exp", C_exp, nd)
    ke = _mat("k_exp", K_exp, nd)
    g = _gamma(gamma, n, nd)
    args = (m, c, k, me, ce, ke, g)
    w_num = eigenfrequencies(m, k)  # first: refuses an M that is not positive definite
    if not _stable_without_delay(m + g @ me @ g.T, c + g @ ce @ g.T, k + g @ ke @ g.T):
        return InterfaceLoop(np.array([]), np.array([]), 0.0, math.nan, math.nan)
    # a neutral loop (|μ| > 1 as ω → ∞) is unstable for any delay
    m_red = g.T @ np.linalg.solve(m, g)
    if np.max(np.abs(np.linalg.eigvals(me @ m_red))) > 1.0:
        return InterfaceLoop(np.array([]), np.array([]), 0.0, math.inf, 0.0)
    wn = np.concatenate([w_num, eigenfrequencies(m + g @ me @ g.T, k + g @ ke @ g.T)])
    wn = wn[wn > 0]
    lo = (wn.min() if wn.size else 1.0) * 1e-2
    hi = (wn.max() if wn.size else 1.0) * 1e2
    # the loop gain peaks at the numerical resonances; sampling them exactly keeps the narrow
    # |μ| > 1 band of a lightly damped mode from falling between two grid points
    grid = np.unique(np.concatenate([np.geomspace(lo, hi, int(n_grid)), wn]))

    def mods(w: float) -> np.ndarray:
        return np.sort(np.abs(_loop_eigs(np.array([w]), *args)[0]))

    from scipy.optimize import brentq

    table = np.sort(np.abs(_loop_eigs(grid, *args)), axis=1) - 1.0
    cross, pms = [], []
    for j in range(table.shape[1]):
        sgn = np.signbit(table[:, j])
        for i in np.flatnonzero(sgn[1:] != sgn[:-1]):
            # |μ_j(ω)| − 1 changes sign in [grid[i], grid[i+1]]: Brent's method on log ω
            lo_w, hi_w = math.log(grid[i]), math.log(grid[i + 1])
            fa, fb = (mods(math.exp(lw))[j] - 1.0 for lw in (lo_w, hi_w))
            if np.signbit(fa) != np.signbit(fb):
                wc = math.exp(brentq(lambda lw, j=j: mods(math.exp(lw))[j] - 1.0,
                                     lo_w, hi_w, xtol=1e-13))
            else:
                # |μ| − 1 is at round-off on a grid point (an undamped system's crossover at
                # ω_0,DYN, sampled exactly), and exp(log ω) moved it across zero
                wc = float(grid[i] if abs(table[i, j]) <= abs(table[i + 1, j])
                           else grid[i + 1])
            mu = _loop_eigs(np.array([wc]), *args)[0]
            mu_c = mu[np.argmin(np.abs(np.abs(mu) - 1.0))]
            # 1 + μ e^(−iωτ) = 0 ⇔ ωτ = angle(μ) − π (mod 2π): the phase left before −1
            pm = (np.angle(mu_c) + math.pi) % (2 * math.pi)
            cross.append(wc)
            pms.append(pm)
    if not cross:
        return InterfaceLoop(np.array([]), np.array([]), math.inf, math.nan, math.nan)
    cross_a, pm_a = np.array(cross), np.array(pms)
    margins = pm_a / cross_a
    i = int(np.argmin(margins))
    return InterfaceLoop(cross_a, pm_a, float(margins[i]), float(cross_a[i]), float(pm_a[i]))


def _stable_without_delay(mc: np.ndarray, cc: np.ndarray, kc: np.ndarray) -> bool:
    """Whether Mc ẍ + Cc ẋ + Kc x = 0 has no eigenvalue with Re s > 1e-8 max|s| (round-off
    puts the eigenvalues of an undamped system a hair to either side of the axis)."""
    import scipy.linalg

    n = mc.shape[0]
    eye, zero = np.eye(n), np.zeros((n, n))
    a = np.block([[zero, eye], [-kc, -cc]])
    b = np.block([[eye, zero], [zero, mc]])
    lam = scipy.linalg.eigvals(a, b)
    lam = lam[np.isfinite(lam)]
    if lam.size == 0:
        return True
    return bool(np.max(lam.real) <= 1e-8 * np.max(np.abs(lam)))


def psi(tau_cr: float) -> float:
    """Predictive stability indicator PSI = log10(τ_cr / 1 ms) (τ_cr in s); −∞ for τ_cr = 0."""
    t = float(tau_cr)
    return -math.inf if t <= 0 else math.log10(t / 1e-3)


def psi_class(value: float) -> str:
    """Maghareh's classes: 'slightly' (PSI > 0.7), 'moderately' (0…0.7), 'extremely' (< 0)."""
    if value > 0.7:
        return "slightly sensitive"
    if value >= 0.0:
        return "moderately sensitive"
    return "extremely sensitive"

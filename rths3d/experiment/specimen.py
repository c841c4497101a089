"""Vectorised numpy model of the 1-D experimental parts (paper Figs. 4 and 5).

The paper's own specimen model: a rigid mass m_EXP on a spring k_EXP (damper d_EXP) whose
base is the platform's force-torque sensor, moving at the achieved interface displacement
z'; contact with the world-fixed surface h_0 above the mass is a penalty spring-damper
(k_c, d_c) acting only in compression. Displacements from static equilibrium (gravity only
preloads), z up, K tests as arrays. The measured restoring force (the force the mount
exerts on the specimen, paper F_m) is

    F_m = k_EXP (z' − x) + d_EXP (ż' − ẋ)

Integration over one interface step with the mount moving linearly from z'_n to z'_{n+1}:
``euler`` (semi-implicit Euler with ``substeps`` substeps, as MuJoCo's Euler integrator) or
``rk4`` (classical Runge–Kutta, for reference solutions).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..kernels import block_kernel, ready


@block_kernel
def euler_kernel(p, s, z0, z1, f):
    """One interface step of K parts (semi-implicit Euler substeps, see the module
    docstring). ``p`` rows: [k h/m, d h/m, k_c h/m, d_c h/m, h0 (1e300: none), k, d, ΔT,
    substeps, h]; ``s`` rows: [x, ẋ, previous mount position]. The arithmetic is that of the
    numpy model, operation for operation."""
    for r in range(z0.shape[0]):
        kh, dh, kch, dch, h0 = p[r, 0], p[r, 1], p[r, 2], p[r, 3], p[r, 4]
        k, d, dt, ns, h = p[r, 5], p[r, 6], p[r, 7], int(p[r, 8]), p[r, 9]
        a0 = z0[r]
        a1 = z1[r]
        dz = a1 - a0
        vm = dz / dt
        dz = dz / ns
        x = s[r, 0]
        v = s[r, 1]
        for j in range(ns):
            # dv = h/m · (k (z_m − x) + d (ż_m − ẋ) − F_c), F_c ≥ 0 only in contact
            if j:
                dv = (a0 + j * dz) - x
            else:
                dv = a0 - x
            dv *= kh
            if dh != 0.0:
                dv += dh * (vm - v)
            pen = x - h0
            if pen > 0.0:
                fc = kch * pen
                fc += dch * v
                if fc > 0.0:
                    dv -= fc
            v += dv
            x += v * h
        s[r, 0] = x
        s[r, 1] = v
        s[r, 2] = a1
        # F_m at the end of the step: k (z'_{n+1} − x) + d (ż' − ẋ)
        f[r] = k * (a1 - x) + d * (vm - v)


@njit(cache=True, nogil=True)
def rk4_kernel(inv_m, k, d, h0, kc, dc, dt, ns, h, a0, a1, x, v, zprev, f):  # pragma: no cover
    """One interface step of K parts by classical RK4 with ``ns`` substeps of ``h`` (the
    reference's model), the mount moving linearly over the step; ``x``, ``v``, ``zprev`` and
    ``f`` (K,) are updated in place."""
    for r in range(a0.shape[0]):
        im, kr, dr, hr, kcr, dcr = inv_m[r], k[r], d[r], h0[r], kc[r], dc[r]
        b0, b1 = a0[r], a1[r]
        vm = (b1 - b0) / dt
        xr, vr = x[r], v[r]
        dz = b1 - b0
        for j in range(ns):
            zs = b0 + dz * (j / ns)
            zh = b0 + dz * ((j + 0.5) / ns)
            ze = b0 + dz * ((j + 1.0) / ns)
            k1v = _acc(zs, xr, vr, vm, im, kr, dr, hr, kcr, dcr)
            k2x = vr + 0.5 * h * k1v
            k2v = _acc(zh, xr + 0.5 * h * vr, vr + 0.5 * h * k1v, vm, im, kr, dr, hr, kcr, dcr)
            k3x = vr + 0.5 * h * k2v
            k3v = _acc(zh, xr + 0.5 * h * k2x, vr + 0.5 * h * k2v, vm, im, kr, dr, hr, kcr,
                       dcr)
            k4x = vr + h * k3v
            k4v = _acc(ze, xr + h * k3x, vr + h * k3v, vm, im, kr, dr, hr, kcr, dcr)
            xr += h / 6.0 * (vr + 2 * k2x + 2 * k3x + k4x)
            vr += h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
        x[r] = xr
        v[r] = vr
        zprev[r] = b1
        f[r] = kr * (b1 - xr) + dr * (vm - vr)


@njit(cache=True, nogil=True, inline="always")
def _acc(zm, x, v, vm, im, k, d, h0, kc, dc):  # pragma: no cover - jit
    fc = 0.0
    if x > h0:
        fc = kc * (x - h0) + dc * v
        if fc < 0.0:
            fc = 0.0
    return (k * (zm - x) + d * (vm - v) - fc) * im


class Specimen1D:
    """K one-DOF specimens stepped together.

    Parameters (scalars or (K,) arrays, SI): ``m`` kg, ``k`` N/m, ``d`` N·s/m, ``h0`` m
    (``inf``: no contact, the linear part), ``k_contact`` N/m, ``d_contact`` N·s/m.
    """

    n_if = 1
    tolerance = 1e-11
    """Reference convergence (m): the RK4 model reproduces itself to rounding."""

    def __init__(self, K: int, m, k, d=0.0, h0=np.inf, k_contact=1e5, d_contact=0.0, *,
                 dt: float = 1e-3, substeps: int = 4, method: str = "euler"):
        b = lambda v: np.broadcast_to(np.asarray(v, float), (K,)).copy()  # noqa: E731
        self.K = K
        self.m, self.k, self.d, self.h0 = b(m), b(k), b(d), b(h0)
        self.kc, self.dc = b(k_contact), b(d_contact)
        self.dt = float(dt)
        self.substeps = int(substeps)
        self.method = method
        if method == "euler":
            ready(euler_kernel)
        # state rows [x, ẋ, previous mount position]; x, v are views of it
        self.state = np.zeros((K, 3))
        self.x = self.state[:, 0]
        self.v = self.state[:, 1]
        self._zm_prev = self.state[:, 2]
        self.f = np.zeros((K, 1))
        self._inv_m = 1.0 / self.m
        h = self.dt / self.substeps
        # per-substep velocity increments per unit displacement / velocity (no divisions
        # in the hot loop)
        self._kh = self.k * h / self.m
        self._dh = self.d * h / self.m
        self._kch = self.kc * h / self.m
        self._dch = self.dc * h / self.m
        self._h0 = np.where(np.isfinite(self.h0), self.h0, 1e300)
        self.params = np.ascontiguousarray(np.stack([
            self._kh, self._dh, self._kch, self._dch, self._h0, self.k, self.d,
            np.full(K, self.dt), np.full(K, float(self.substeps)), np.full(K, h)], axis=1))

    def reset(self) -> None:
        """Rest at static equilibrium."""
        self.state[:] = 0.0
        self.f[:] = 0.0

    def compiled(self):
        """(kernel, params, state) of the Euler model for the compiled loop; None for RK4
        (the reference's model, stepped from Python)."""
        if self.method != "euler":
            return None
        return euler_kernel, self.params, self.state

    def get_state(self) -> np.ndarray:
        """Copy of (x, v, previous mount position), shape (3, K)."""
        return np.stack([self.x, self.v, self._zm_prev])

    def set_state(self, s: np.ndarray) -> None:
        """Restore a state from :meth:`get_state`."""
        self.x[:], self.v[:], self._zm_prev[:] = s[0], s[1], s[2]

    def advance(self, z0: np.ndarray, z1: np.ndarray) -> np.ndarray:
        """Move the mount linearly from ``z0`` to ``z1`` (K, 1) over ΔT; return F_m (K, 1)
        at the end of the step (N)."""
        a0 = z0[:, 0]
        a1 = z1[:, 0]
        ns = self.substeps
        h = self.dt / ns
        if self.method == "euler":
            euler_kernel(self.params, self.state, np.ascontiguousarray(a0),
                         np.ascontiguousarray(a1), self.f[:, 0])
            return self.f
        rk4_kernel(self._inv_m, self.k, self.d, self.h0, self.kc, self.dc, self.dt, ns, h,
                   np.ascontiguousarray(a0), np.ascontiguousarray(a1), self.x, self.v,
                   self._zm_prev, self.f[:, 0])
        return self.f

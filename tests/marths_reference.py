"""Independent solutions for the maRTHS tests (not part of the package): the structure by
the trapezoidal rule on the first-order descriptor form (scipy LU), the plant by an RK4
stepping loop on a given realisation, the coupler kinematics and the specimen force written
out from the benchmark's formulas, and RoDeAC by plain numpy with its algebraic loop solved
by fixed-point iteration."""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
import scipy.signal

DV = math.hypot(0.2667, 0.127)
ALPHA = 25.4633 * math.pi / 180  # the benchmark's rounded angle


def trapezoid(M, C, K, l, ag, dt, F=None):  # noqa: E741
    """U (N, n) of M Ü + C U̇ + K U = −M l ẍ_g − F by the trapezoidal rule on
    E ż = A z + b with z = [U, U̇], E = diag(I, M) (M may be singular), from rest."""
    n = K.shape[0]
    E = np.block([[np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), M]])
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -C]])
    lu = scipy.linalg.lu_factor(E - 0.5 * dt * A)
    Bp = E + 0.5 * dt * A
    N = ag.size
    load = np.zeros((N, 2 * n))
    load[:, n:] = -np.outer(ag, M @ l)
    if F is not None:
        load[:, n:] -= F
    z = np.zeros(2 * n)
    prev = np.zeros(2 * n)
    out = np.empty((N, n))
    for k in range(N):
        z = scipy.linalg.lu_solve(lu, Bp @ z + 0.5 * dt * (prev + load[k]))
        prev = load[k]
        out[k] = z[:n]
    return out


def rk4_outputs(A, B, C, u, dt):
    """y_k = C x(t_k) of ẋ = A x + B u with u_k held over [t_k, t_k+1), one RK4 step each."""
    x = np.zeros(A.shape[0])
    y = np.empty((u.shape[0], C.shape[0]))
    for k in range(u.shape[0]):
        y[k] = C @ x
        f = B @ u[k]
        k1 = A @ x + f
        k2 = A @ (x + 0.5 * dt * k1) + f
        k3 = A @ (x + 0.5 * dt * k2) + f
        k4 = A @ (x + dt * k3) + f
        x = x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return y


def frame_to_actuator(x, th):
    """(mm) from x (m), θ (rad), both actuators."""
    return (1000 * (x + DV * (np.cos(th - ALPHA) - math.cos(ALPHA))),
            1000 * (x + DV * (np.cos(th + ALPHA) - math.cos(ALPHA))))


def actuator_to_frame(a1_mm, a2_mm):
    a1, a2 = a1_mm / 1000, a2_mm / 1000
    s = (a1 - a2) / (2 * DV * math.sin(ALPHA))
    return a1 - DV * (np.cos(s - ALPHA) - math.cos(ALPHA)), np.arcsin(s)


def specimen_force(x, th, K5, C5, M5, G, dt):
    """F5[:3] (N, 3) from the measured x (m), θ (rad): q = [x, θ, G[x, θ]], backward
    differences with q̇_0 = q̈_0 = 0."""
    q = np.column_stack([x, th, np.column_stack([x, th]) @ G.T])
    qd = np.zeros_like(q)
    qd[1:] = np.diff(q, axis=0) / dt
    qdd = np.zeros_like(q)
    qdd[1:] = np.diff(qd, axis=0) / dt
    return (q @ K5.T + qd @ C5.T + qdd @ M5.T)[:, :3]


def rodeac_reference(target, plant, theta0, P0, b, a, lam=1.0, scale=1000.0, iters=50):
    """RoDeAC for one channel in closed loop with ``plant(k, u_history) -> measured at k``
    (channel units), the algebraic loop through the filter's direct term solved by
    fixed-point iteration on ũ_k. Returns the commands (channel units)."""
    N = len(theta0)
    th = np.array(theta0, float)
    P = np.array(P0, float).reshape(N, N)
    xt = scale * np.asarray(target, float)
    xm = np.zeros(xt.size)
    u = np.zeros(xt.size)
    for k in range(xt.size):
        xm[k] = scale * plant(k, u[:k] / scale)
        xf = scipy.signal.lfilter(b, a, xm[:k + 1])
        pt = np.array([xt[k - i] if k - i >= 0 else 0.0 for i in range(N)])
        ph = np.array([xf[k - i] if k - i >= 0 else 0.0 for i in range(N)])
        g = P @ ph / (lam + ph @ P @ ph)
        uk = th @ pt
        th_k = th
        for _ in range(iters):  # ũ_k from the filter on u_0 … u_k
            u[k] = uk
            uf = scipy.signal.lfilter(b, a, u[:k + 1])[-1]
            th_k = th + g * (uf - th @ ph)
            uk_new = th_k @ pt
            done = abs(uk_new - uk) <= 1e-15 * max(1.0, abs(uk))
            uk = uk_new
            if done:
                break
        u[k] = uk
        th = th_k
        P = (P - np.outer(g, ph @ P)) / lam
    return u / scale

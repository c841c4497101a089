"""The compiled step of the linear numerical substructure (shared by both loop drivers)."""

from __future__ import annotations

from ..kernels import njit

__all__ = ["linear_step", "load_terms_1dof"]


@njit
def linear_step(Ad, Bf, P, n, f, s, s_next, Czx, Czv, Cx, z, zd, x):
    """s_{n+1} = A_d s_n + P_n − B_f F'_m(t_n) per test (matrices shared when their first
    axis is 1; the load terms P (N, K, S) step by step), then z = C_zx s, ż = C_zv s,
    x = C_x s."""
    K, S = s.shape
    nd = f.shape[1]
    shared = Ad.shape[0] == 1
    for k in range(K):
        kk = 0 if shared else k
        for i in range(S):
            acc = 0.0
            for j in range(S):
                acc += s[k, j] * Ad[kk, i, j]
            acc += P[n, k, i]
            fb = 0.0
            for d in range(nd):
                fb += f[k, d] * Bf[kk, i, d]
            s_next[k, i] = acc - fb
        for i in range(S):
            s[k, i] = s_next[k, i]
        for j in range(z.shape[1]):
            a = 0.0
            b = 0.0
            for i in range(S):
                a += s[k, i] * Czx[j, i]
                b += s[k, i] * Czv[j, i]
            z[k, j] = a
            zd[k, j] = b
        for j in range(x.shape[1]):
            a = 0.0
            for i in range(S):
                a += s[k, i] * Cx[j, i]
            x[k, j] = a


@njit
def load_terms_1dof(p, A, B, P):
    """The load terms P (N, K, S) of one-DOF substructures: P[n, k] = A p_n + B p_{n+1} for
    the loads p (K, N+1) and the per-test (or shared, first axis 1) columns A, B (·, S) (B
    all zero: the held-load integrator). Blocks of steps, so that the loads (read along
    time) and P (written across tests) stay in cache."""
    K, N1 = p.shape
    shared = A.shape[0] == 1
    blk = 64
    for n0 in range(0, N1 - 1, blk):
        n1 = min(N1 - 1, n0 + blk)
        for k in range(K):
            kk = 0 if shared else k
            for n in range(n0, n1):
                for s in range(A.shape[1]):
                    P[n, k, s] = p[k, n] * A[kk, s] + p[k, n + 1] * B[kk, s]

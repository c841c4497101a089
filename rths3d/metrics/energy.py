"""Energy-based error monitors: E_error, E_input, E_strain, HSEM^S, HSEM^I (paper eqs. 9–11), EEI.

Work integrals ∫ F dz are trapezoidal sums over the samples, Σ ½ (F_i + F_{i+1})(z_{i+1} − z_i),
per interface DOF; J for translations (N·m) and for rotations (N·m·rad). Sign conventions
follow the record schema: ``f_meas`` F'_m is the restoring force of the experimental part (a
positive F'_m resists a positive z).

- E_error = ∫ F'_m dz − ∫ F'_m dz' (eq. 9): work the numerical substructure believes it did on
  the specimen minus the work actually done on it. For a spring F'_m = k z' driven at
  z = Z sin ωt with z' = a Z sin ω(t − τ), each whole period gives E_error = −π k a Z² sin ωτ:
  a lagging transfer system gives E_error < 0 (energy fed into the test, the negative damping
  of delay).
- E_input = ∫ F_ext dz (eq. 10): work of the external force along the commanded motion.
- E_strain = ½ z_maxᵀ k_EXP z_max (eq. 10), evaluated as the maximum over the record of
  ½ z'(t)ᵀ k_EXP z'(t), the largest strain energy the specimen reached. For one DOF this is
  ½ k_EXP max(z')², i.e. eq. (10) with z_max the largest achieved deformation; for several
  DOF it avoids combining peaks that occur at different times.
- HSEM^S = E_error / E_strain, HSEM^I = E_error / (E_strain + E_input) (eq. 11).
- EEI (energy error indicator): the residual of the whole hybrid test's energy balance,
  R = W_ext − ΔT − E_D − ΔU − ∫ F'_mᵀ dz', from the numerical states x (kinetic T = ½ ẋᵀMẋ,
  damping E_D = ∫ ẋᵀCẋ dt, strain U = ½ xᵀKx, W_ext = ∫ pᵀ dx) and the work done on the
  specimen. With exact integration R = E_error; the difference is the integration error.
  EEI = R / E_strain, the same normaliser as HSEM^S, so that EEI = HSEM^S for an exactly
  integrated test (as the paper observed in its implementation).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..errors import RecordError
from ._signals import as_pair, as_signal, check_dt, out, ratio


def work(force: ArrayLike, disp: ArrayLike) -> float | np.ndarray:
    """Trapezoidal work ∫ F dz per DOF (J). ``force`` and ``disp`` (N,) or (N, ndof)."""
    f, z, one = as_pair(force, disp, ("force", "displacement"), min_samples=2)
    dz = np.diff(z, axis=0)
    return out(0.5 * (np.einsum("ij,ij->j", f[:-1], dz) + np.einsum("ij,ij->j", f[1:], dz)),
               one)


def e_error(z: ArrayLike, z_meas: ArrayLike, f_meas: ArrayLike) -> float | np.ndarray:
    """Error energy E_error = ∫ F'_m dz − ∫ F'_m dz' (eq. 9), per DOF, in J."""
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"), min_samples=2)
    f, _, _ = as_pair(f_meas, a, ("f_meas", "z"), min_samples=2)
    return out(np.asarray(work(f, a - b), dtype=float).reshape(-1), one)


def e_input(z: ArrayLike, f_ext: ArrayLike) -> float | np.ndarray:
    """Input energy E_input = ∫ F_ext^NUM dz (eq. 10), per DOF, in J."""
    f, a, one = as_pair(f_ext, z, ("f_ext", "z"), min_samples=2)
    return out(np.asarray(work(f, a), dtype=float).reshape(-1), one)


def e_strain(z_meas: ArrayLike, k_exp: ArrayLike) -> float:
    """Maximum strain energy E_strain = max_t ½ z'(t)ᵀ k_EXP z'(t) (eq. 10), in J.

    ``k_exp`` is a scalar (one DOF, N/m or N·m/rad) or the (ndof, ndof) interface stiffness
    matrix of the experimental part. Must be finite; a zero stiffness gives 0 (and HSEM NaN).
    """
    zp, _ = as_signal(z_meas, "z_meas", min_samples=1)
    k = np.atleast_2d(np.asarray(k_exp, dtype=float))
    nd = zp.shape[1]
    if k.shape == (1, 1) and nd > 1:
        k = np.eye(nd) * k[0, 0]
    if k.shape != (nd, nd):
        raise RecordError(f"k_exp: shape {k.shape} does not match {nd} interface DOF(s)")
    if not np.all(np.isfinite(k)):
        raise RecordError("k_exp: contains NaN/inf (interface stiffness in N/m)")
    energy = 0.5 * np.einsum("ij,jk,ik->i", zp, k, zp)
    return float(np.max(energy))


def hsem_s(e_err: ArrayLike, e_str: ArrayLike) -> float | np.ndarray:
    """HSEM^S = E_error / E_strain (eq. 11), dimensionless; NaN if E_strain = 0."""
    return _scalar_or_array(ratio(e_err, e_str))


def hsem_i(e_err: ArrayLike, e_str: ArrayLike, e_in: ArrayLike) -> float | np.ndarray:
    """HSEM^I = E_error / (E_strain + E_input) (eq. 11), dimensionless; NaN if the sum is 0."""
    return _scalar_or_array(ratio(e_err, np.asarray(e_str) + np.asarray(e_in)))


def _scalar_or_array(x: np.ndarray) -> float | np.ndarray:
    return float(x) if np.ndim(x) == 0 else x


def energy_balance_residual(x: ArrayLike, M: ArrayLike, C: ArrayLike, K: ArrayLike,
                            p: ArrayLike, gamma: ArrayLike, f_meas: ArrayLike,
                            z_meas: ArrayLike, dt: float,
                            v: ArrayLike | None = None) -> np.ndarray:
    """Running residual R(t) of the hybrid test's energy balance (J), R(t_0) = 0.

    Parameters
    ----------
    x:
        Numerical substructure displacements, (N, n) (m or rad).
    M, C, K:
        Its (n, n) mass, damping and stiffness matrices (SI).
    p:
        External force on the numerical DOFs, (N, n) (N), the p(t) of
        M ẍ + C ẋ + K x = p − Γ F'_m.
    gamma:
        Γ, (n, ndof) map from interface forces to numerical DOFs; z = Γᵀ x.
    f_meas, z_meas:
        Measured interface force F'_m and achieved displacement z', (N, ndof).
    dt:
        Sample interval (s).
    v:
        Velocities ẋ (N, n); by default second-order finite differences of x.

    R = ∫ pᵀ dx − [T] − ∫ ẋᵀ C ẋ dt − [U] − ∫ F'_mᵀ dz', see the module docstring.
    """
    step = check_dt(dt)
    xs, _ = as_signal(x, "x_num")
    ps, _ = as_signal(p, "p_num")
    fm, _ = as_signal(f_meas, "f_meas")
    zm, _ = as_signal(z_meas, "z_meas")
    n = xs.shape[1]
    mats = []
    for name, mat in (("M", M), ("C", C), ("K", K)):
        arr = np.atleast_2d(np.asarray(mat, dtype=float))
        if arr.shape != (n, n):
            raise RecordError(f"numerical.{name}: shape {arr.shape}, expected ({n}, {n})")
        mats.append(arr)
    m_, c_, k_ = mats
    g = np.asarray(gamma, dtype=float).reshape(n, -1)
    if ps.shape != xs.shape or fm.shape != zm.shape or fm.shape[0] != xs.shape[0] \
            or g.shape[1] != fm.shape[1]:
        raise RecordError(f"energy balance: shapes x {xs.shape}, p {ps.shape}, gamma {g.shape},"
                          f" f_meas {fm.shape}, z_meas {zm.shape} do not match")
    vs = np.gradient(xs, step, axis=0) if v is None else as_signal(v, "v_num")[0]
    kin = 0.5 * np.einsum("ij,jk,ik->i", vs, m_, vs)
    pot = 0.5 * np.einsum("ij,jk,ik->i", xs, k_, xs)
    pd = np.einsum("ij,jk,ik->i", vs, c_, vs)
    damp = np.concatenate(([0.0], np.cumsum(0.5 * (pd[1:] + pd[:-1]) * step)))

    def cumwork(f: np.ndarray, z: np.ndarray) -> np.ndarray:
        dz = np.diff(z, axis=0)
        inc = 0.5 * np.einsum("ij,ij->i", f[1:] + f[:-1], dz)
        return np.concatenate(([0.0], np.cumsum(inc)))

    return (cumwork(ps, xs) - (kin - kin[0]) - damp - (pot - pot[0]) - cumwork(fm, zm))


def eei(residual: float, e_str: float) -> float:
    """Energy error indicator EEI = R / E_strain (dimensionless); NaN if E_strain = 0."""
    return float(ratio(residual, e_str))


def hsem(f_meas: ArrayLike, z: ArrayLike, z_meas: ArrayLike, k_exp: ArrayLike) -> float:
    """HSEM^S of one record in one call: E_error(z, z', F'_m) / E_strain(z', k_EXP).

    Signals (N,) or (N, ndof); energies summed over DOFs. Dimensionless; NaN if E_strain = 0.
    """
    err = np.sum(np.atleast_1d(e_error(z, z_meas, f_meas)))
    return float(ratio(err, e_strain(z_meas, k_exp)))

"""The reference solution z^r (paper Section "Reference errors"): the coupled system with
compatibility and equilibrium satisfied exactly — no transfer dynamics, no coupling lag.

Method: **interface iteration within each step** (a strongly coupled partitioned scheme).
For each step t_n → t_{n+1} the state of both substructures is saved; a guess of z_{n+1}
(quadratic extrapolation from z_n, z_{n−1}, z_{n−2}) drives the experimental part's mount
linearly from z_n to z_{n+1}, its restoring force F_{n+1} at t_{n+1} goes into the numerical
substructure, which is stepped with the interface force interpolated linearly from F_n to
F_{n+1} (exact discretisation of the state space with first-order hold, implicit in F_{n+1});
both states are reset and the step repeated until |Δz| < ``tol`` (or, for the MuJoCo part,
until the iteration stagnates at its contact solver's noise, ~1e-9 m). The pass z ↦ g(z) (guess
to numerical interface displacement) is affine within a contact regime, so from the second
pass on the new guess is the secant step z + (g − z)/(1 − s), s the pass's slope per test and
DOF measured on the last two passes and kept across steps: a batch of tests as stiff and as
soft as Table 1's converges in 2 passes per step instead of 3. At convergence the mount
displacement equals the numerical interface displacement and the force is the same on both
sides at every sample.

The 1-D parts use the numpy specimen with classical Runge–Kutta substeps; the multi-DOF part
uses the MuJoCo specimen (its own integrator) reset to the saved state at every iteration.
Order: the numerical side is exact for a piecewise-linear interface force, so the coupling
error is O(ΔT²); smooth (linear) problems converge at second order, contact (a kink in the
force) at least at first order — both measured in tests/test_reference.py.
"""

from __future__ import annotations

import numpy as np

from .config import Scene
from .experiment import build_part_model
from .numerical import LinearSubstructure, NumericalFactory, numerical_factory

REFERENCE_SUBSTEPS = 2
"""RK4 substeps per interface step of the numpy specimen in the reference."""
NUMPY_TOL = 1e-11
"""Interface convergence of the reference with the numpy part (m, rad)."""
MUJOCO_TOL = 1e-9
"""Interface convergence with the MuJoCo part: its contact solver's reproducibility (m, rad)."""


def reference_solution(scenes: list[Scene], *, tol: float | None = None, max_iter: int = 30,
                       nthread: int = 0, progress: bool = False, specimen: str = "auto",
                       numerical: NumericalFactory | None = None) -> dict[str, np.ndarray]:
    """z^r for K tests that share dt, duration, DOFs and experiment kind.

    Returns arrays ``z_ref`` (K, N+1, n_if) in m/rad, ``f_ref`` (K, N+1, n_if) in N/N·m,
    ``x_ref`` (K, N+1, n), ``iterations`` (max per step) and ``mean_iterations`` (passes per
    step, averaged over the steps). ``specimen``: ``numpy``
    (RK4 penalty model, 1-D parts only), ``mujoco`` (the MuJoCo part, as mounted on the
    platform) or ``auto`` (numpy for 1-D parts). ``numerical``: factory of a plugged-in
    numerical substructure (see :func:`rths3d.loop.run`). ``tol``: interface convergence
    |Δz| (m, rad); default 1e-11 for the numpy part and 1e-9 for the MuJoCo part, whose
    contact solver is not reproducible below that (iterating further only repeats its noise).
    """
    base = scenes[0]
    N = base.n_steps
    # a plugged-in substructure must integrate implicitly in F_{n+1} when given f_next
    if numerical is None and not base.numerical.has_matrices:
        numerical = numerical_factory(base)  # the scene's kind (e.g. an OpenSees model)
    num = numerical(scenes) if numerical is not None else \
        LinearSubstructure.from_scenes(scenes, method="exact")
    spec = build_part_model([s.experiment for s in scenes], base.dofs, base.dt,
                            model=specimen, method="rk4", substeps=REFERENCE_SUBSTEPS,
                            nthread=nthread)
    # default: the part model's own reproducibility (1e-11 numpy, 1e-9 MuJoCo contact)
    tol = spec.tolerance if tol is None else tol
    if not getattr(num, "rolls_back", True):  # e.g. an OpenSees model of yielding materials
        return couple_predicted(num, spec, N, tol=tol, max_iter=max_iter)
    return couple_exact(num, spec, N, tol=tol, max_iter=max_iter, progress=progress)


def couple_predicted(num, part, n_steps: int, *, tol: float = NUMPY_TOL, max_iter: int = 30
                     ) -> dict[str, np.ndarray]:
    """The reference of a numerical substructure that cannot go back a step (an OpenSees
    model whose materials commit their history): one committed step per interface step
    with the interface force extrapolated (quadratic, F_g), then the part iterated against
    the step's interface flexibility Φ = ∂z_{n+1}/∂F_{n+1} (``num.step_flexibility()``):
    z_{n+1} = z_g + Φ (F_{n+1} − F_g), F_{n+1} = part(z_n → z_{n+1}). The substructure saw
    F_g instead of F_{n+1}: an error of O(ΔT³) in the force at each step. Same returns as
    :func:`couple_exact`."""
    N = int(n_steps)
    K, n_if = num.z.shape
    Phi = np.asarray(num.step_flexibility(), float)
    z_ref = np.zeros((K, N + 1, n_if))
    f_ref = np.zeros((K, N + 1, n_if))
    x_ref = np.zeros((K, N + 1, num.n))
    f_n, f_p, f_pp = (np.zeros((K, n_if)) for _ in range(3))
    iters = passes = 0
    for n in range(N):
        ss = part.get_state()
        z_n = z_ref[:, n]
        f_g = 3.0 * (f_n - f_p) + f_pp
        num.step(n, f_n, f_g)
        z_g = num.z.copy()
        z1 = z_g
        for it in range(max_iter):  # noqa: B007
            part.set_state(ss)
            f1 = part.advance(z_n, z1).copy()
            z_new = z_g + (f1 - f_g) @ Phi.T
            err = float(np.max(np.abs(z_new - z1)))
            z1 = z_new
            if err <= tol:
                break
        part.set_state(ss)
        f1 = part.advance(z_n, z1).copy()
        iters = max(iters, it + 1)
        passes += it + 1
        f_pp, f_p, f_n = f_p, f_n, f1
        z_ref[:, n + 1] = z1
        f_ref[:, n + 1] = f1
        x_ref[:, n + 1] = num.x + (z1 - z_g) @ num.gamma.T
    return {"z_ref": z_ref, "f_ref": f_ref, "x_ref": x_ref, "iterations": np.array(iters),
            "mean_iterations": np.array(passes / max(N, 1))}


def couple_exact(num, part, n_steps: int, *, tol: float = NUMPY_TOL, max_iter: int = 30,
                 progress: bool = False) -> dict[str, np.ndarray]:
    """Couple a numerical substructure ``num`` and a part model ``part`` with compatibility
    and equilibrium exact at every sample (the interface iteration of the module docstring).

    ``num``: a numerical substructure (``step(n, f_n, f_next)``, ``z``, ``x``,
    ``get_state``/``set_state``; e.g. :class:`~rths3d.numerical.LinearSubstructure` built with
    ``method="exact"``). ``part``: any model of the experimental part for K tests with
    ``advance(z_from, z_to) -> F`` ((K, n_if) arrays: the mount moves linearly from
    ``z_from`` to ``z_to`` over one step, F is the restoring force at its end) and
    ``get_state``/``set_state``; the specimen models, or an identified surrogate. Returns
    ``z_ref``, ``f_ref`` (K, N+1, n_if), ``x_ref`` (K, N+1, n), ``iterations`` and
    ``mean_iterations``.
    """
    N = int(n_steps)
    K, n_if = num.z.shape
    spec = part
    z_ref = np.zeros((K, N + 1, n_if))
    f_ref = np.zeros((K, N + 1, n_if))
    x_ref = np.zeros((K, N + 1, num.n))
    f_n = np.zeros((K, n_if))
    z_prev = np.zeros((K, n_if))
    z_prev2 = np.zeros((K, n_if))
    slope = np.zeros((K, n_if))  # d g / d z of the interface pass, per test and DOF
    iters = 0
    passes = 0
    rng = range(N)
    # a callable: called every 500 steps with the tests' worth of work done since (K·500/N)
    report = progress if callable(progress) else None
    if progress and report is None:
        from tqdm import tqdm

        rng = tqdm(rng, desc="reference", unit="step", mininterval=0.5, disable=None)
    for n in rng:
        sn = num.get_state()
        ss = spec.get_state()
        z_n = num.z.copy()
        # quadratic extrapolation: an O(ΔT³) first guess saves an iteration on smooth parts
        z1 = 3.0 * (z_n - z_prev) + z_prev2
        it = 0
        prev = np.inf
        z_last = g_last = z1
        for it in range(max_iter):  # noqa: B007 (it is the iteration count after the loop)
            spec.set_state(ss)
            f1 = spec.advance(z_n, z1).copy()
            num.set_state(sn)
            num.step(n, f_n, f1)
            g = num.z.copy()
            err = float(np.max(np.abs(g - z1)))
            # converged, or stagnating at the part's own solver noise (MuJoCo contact)
            if err <= tol or (it >= 3 and err > 0.5 * prev):
                z1 = g
                break
            prev = err
            if it > 0:
                # within a contact regime the pass z -> g(z) is affine: the slope of two passes
                # (kept across steps) makes the next pass a secant step onto its fixed point
                dz = z1 - z_last
                moved = np.abs(dz) > 100.0 * tol  # below: noise of the part, not a slope
                np.copyto(slope, (g - g_last) / np.where(moved, dz, 1.0), where=moved)
                # s ≤ 0.9 bounds the step at 10× the plain pass (a slope measured across a
                # contact change is wrong for a step); the next pass re-measures it
                np.clip(slope, -10.0, 0.9, out=slope)
            z_last, g_last = z1, g
            z1 = z1 + (g - z1) / (1.0 - slope)
        else:
            z1 = g
        iters = max(iters, it + 1)
        passes += it + 1
        if it > 0 and err > tol:
            # last numerical step used the converged force; re-run the part to match z1
            spec.set_state(ss)
            f1 = spec.advance(z_n, z1).copy()
        z_prev2 = z_prev
        z_prev = z_n
        f_n = f1
        z_ref[:, n + 1] = num.z
        f_ref[:, n + 1] = f1
        x_ref[:, n + 1] = num.x
        if report is not None and (n + 1) % 500 == 0:
            report(500 * K / N)
    return {"z_ref": z_ref, "f_ref": f_ref, "x_ref": x_ref, "iterations": np.array(iters),
            "mean_iterations": np.array(passes / max(N, 1))}

"""All measures of one record: :func:`compute_measures` and :func:`feature_row`.

One code path for one DOF and for several: every interface measure is computed per DOF on the
(N, ndof) signals of the record; a single-DOF record returns a flat dict, a multi-DOF record
``{"dofs": {"z": {...}, ...}, "aggregate": {...}}``.

Aggregate (multi-DOF). Dimensionless interface measures (tracking, SSP, FEI, reference
errors, J1–J9 and the τ-ratios) and the bench-load peaks are those of the **dominant DOF**:
the DOF that exchanges the most power at the interface, largest std(z)·std(F'_m) (J for
translations and rotations alike; means removed, so a static offset exchanges none); without
``f_meas`` the DOF of largest std(z) (which then compares m with rad).
Energies add up: ``e_error`` and ``e_input`` are sums over the DOFs, ``e_strain`` uses the full
k_EXP matrix, and ``hsem_s``/``hsem_i``/``eei`` are formed from these totals. System-level
quantities (φ, κ, ζ, ω's, τ_max, τ_cr, PSI, EEI) appear once, in the aggregate (and in the flat
dict of a single-DOF record). ``dominant_dof`` names the DOF.

Inputs come from the record (columns and ``meta``) and may be given or overridden as keyword
``context`` (SI):

``k_exp``, ``m_exp``, ``c_exp``
    experimental part at the interface (scalars or ndof × ndof); default ``meta["experiment"]``.
``M``, ``C``, ``K``, ``gamma``
    numerical substructure; default ``meta["numerical"]``; or scalars ``m_num``, ``k_num``,
    ``d_num`` (one DOF, Γ = 1).
``phase_margin`` (rad), ``crossover`` (rad/s)
    of the interface loop; default ``meta``, else computed from the model when known.
``omega_num_max``, ``omega_dyn_max`` (rad/s)
    override the eigen-analysis; default ``meta``.
``z_ref``
    reference displacement (N, ndof) array, or ``reference=<Record>`` (its ``z_ref`` or
    ``z_meas`` columns); default the record's ``z_ref`` columns.
``l``
    FEI weight exponent (default 2). ``j_convention``: ``"code"`` (default) or ``"paper"``.

A measure whose inputs are missing is left out (never guessed); one that is undefined on the
data (zero normaliser) is NaN.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import ConfigError, RecordError
from ..record import Record
from . import bench, energy, frequency, reference, ssp, susceptibility, tracking
from ._signals import dominant_dof
from .features import SURROGATE, feature_names

SYSTEM_KEYS: tuple[str, ...] = (
    "phi", "kappa", "zeta", "omega_num", "omega_dyn", "tau_ratio_num", "tau_ratio_dyn",
    "tau_max", "tau_ratio_max", "tau_cr", "psi",
)


def _get(context: dict, meta: dict, key: str, *paths: tuple[str, ...]) -> Any:
    if key in context and context[key] is not None:
        return context[key]
    for path in paths:
        node: Any = meta
        for p in path:
            node = node.get(p) if isinstance(node, dict) else None
        if node is not None:
            return node
    return None


def _floats(value: Any, name: str) -> np.ndarray:
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ConfigError(name, value, "must be a number in SI units, without unit text, "
                                       "or a matrix of numbers") from exc


def _scalar(value: Any, name: str) -> float:
    arr = _floats(value, name)
    if arr.size != 1:
        raise ConfigError(name, arr.tolist(), "must be a scalar (one numerical DOF)")
    return float(arr.reshape(-1)[0])


def _matrix(value: Any, nd: int, name: str) -> np.ndarray:
    arr = np.atleast_2d(_floats(value, name))
    if arr.shape == (1, 1) and nd > 1:
        arr = np.eye(nd) * arr[0, 0]
    if arr.shape != (nd, nd) or not np.all(np.isfinite(arr)):
        raise ConfigError(name, arr.tolist(), f"must be a finite scalar or {nd}×{nd} matrix")
    return arr


def _numerical(context: dict, meta: dict) -> tuple[np.ndarray, ...] | None:
    num = meta.get("numerical") if isinstance(meta.get("numerical"), dict) else {}
    mats = [context.get(k, num.get(k)) for k in ("M", "C", "K")]
    gamma = context.get("gamma", num.get("gamma"))
    if any(m is None for m in mats):
        params = meta.get("params") if isinstance(meta.get("params"), dict) else {}
        m = context.get("m_num", params.get("m_num"))
        k = context.get("k_num", params.get("k_num"))
        d = context.get("d_num", params.get("d_num", 0.0))
        if m is None or k is None:
            return None
        m, k, d = (_scalar(v, name) for v, name in ((m, "m_num"), (k, "k_num"), (d, "d_num")))
        susceptibility._positive("m_num", m, "kg")
        if not (math.isfinite(d) and d >= 0):
            raise ConfigError("d_num", d, "kg/s; must be finite and >= 0")
        mats, gamma = [m, d, k], [[1.0]]
    M, C, K = (np.atleast_2d(_floats(x, f"numerical.{name}"))
               for x, name in zip(mats, "MCK", strict=True))
    n = M.shape[0]
    if gamma is None:
        G = np.ones((n, 1))
    else:
        G = _floats(gamma, "numerical.gamma")
        if G.size == 0 or G.size % n:
            raise ConfigError("numerical.gamma", G.tolist(),
                              f"must be {n}×ndof (numerical × interface DOFs)")
        G = G.reshape(n, -1)
    return M, C, K, G


def _reference_signal(record: Record, context: dict, dofs: tuple[str, ...]) -> np.ndarray | None:
    if context.get("z_ref") is not None:
        zr, _ = _as2d(context["z_ref"], "z_ref")
    elif context.get("reference") is not None:
        ref = context["reference"]
        if not isinstance(ref, Record):
            raise ConfigError("reference", type(ref).__name__, "must be a Record")
        sig = "z_ref" if ref.has("z_ref", dofs) else "z_meas"
        zr = ref.signal(sig, dofs)
    elif record.has("z_ref", dofs):
        return _signal(record, "z_ref", dofs)
    else:
        return None
    if zr.shape != (record.n, len(dofs)):
        raise RecordError(f"reference has shape {zr.shape}, the record needs "
                          f"({record.n}, {len(dofs)}): same samples and DOFs "
                          f"({', '.join(dofs)})")
    return zr


def _signal(record: Record, name: str, dofs: tuple[str, ...]) -> np.ndarray:
    """(N, ndof) view of a Fortran-ordered stack: each DOF's samples stay contiguous, which
    keeps the per-DOF reductions and FFTs along axis 0 fast."""
    stacked = np.stack([record.columns[f"{name}.{d}"] for d in dofs])
    bad = ~np.isfinite(stacked)
    if bad.any():
        j, i = np.argwhere(bad)[0]
        raise RecordError(f"record column '{name}.{dofs[j]}' has a non-finite value "
                          f"{stacked[j, i]!r} at row {int(i)} (t = {record.t[i]:.6g} s)")
    return stacked.T


def _as2d(x: Any, name: str) -> tuple[np.ndarray, bool]:
    from ._signals import as_signal

    return as_signal(x, name)


def _columns(record: Record, prefix: str) -> np.ndarray | None:
    """Columns ``prefix.0``, ``prefix.1``, … as (N, n), or None."""
    group = record.group(prefix)
    keys = []
    while str(len(keys)) in group:
        keys.append(str(len(keys)))
    return np.column_stack([group[k] for k in keys]) if keys else None


def _criteria(record: Record, z: np.ndarray, zp: np.ndarray, zr: np.ndarray | None,
              dt: float, convention: str) -> list[dict[str, float]] | None:
    """J1–J9 per DOF when :mod:`.criteria` is available (z as x_cmd, z' as x_meas).

    J4/J5 use the DOF's reference z^r; for a single-DOF record with floor columns
    ``x_num.<i>`` and ``x_ref.<i>`` (i = 0, 1, 2, …; floor 1 = the interface) J6–J9 use them.
    """
    try:
        from . import criteria  # the benchmark criteria module; optional
    except ImportError:
        return None
    fn = getattr(criteria, "j_criteria", None)
    if fn is None:
        return None
    n = z.shape[0]
    max_lag = max(1, min(50, n - 2))
    floors_num = _columns(record, "x_num") if z.shape[1] == 1 else None
    floors_ref = _columns(record, "x_ref") if z.shape[1] == 1 else None
    res = []
    for j in range(z.shape[1]):
        ref: np.ndarray | None = None if zr is None else zr[:, j]
        num = None
        if (floors_num is not None and floors_ref is not None and zr is not None
                and floors_num.shape[1] >= 3 and floors_ref.shape[1] >= 3):
            num = floors_num
            ref = np.column_stack([zr[:, j], floors_ref[:, 1:]])
        # contiguous copies: reductions over strided column views are several times slower
        row = dict(fn(np.ascontiguousarray(z[:, j]), np.ascontiguousarray(zp[:, j]), num,
                      None if ref is None else np.ascontiguousarray(ref), dt=dt,
                      convention=convention, max_lag=max_lag))
        # keep only the criteria whose inputs exist: J4/J5 need z^r, J6–J9 the floors
        drop = ([] if zr is not None else ["j4", "j5"]) + ([] if num is not None else
                                                          ["j6", "j7", "j8", "j9"])
        if np.ptp(z[:, j]) == 0.0 or np.ptp(zp[:, j]) == 0.0:
            row["j1"] = math.nan  # no correlation to maximise: the delay is undefined
        res.append({k: v for k, v in row.items() if k not in drop})
    return res


def compute_measures(record: Record, *, surrogate: bool = False, **context: Any
                     ) -> dict[str, Any]:
    """Every measure the record has inputs for (see the module docstring for keys and units).

    ``surrogate=True`` adds the reference errors estimated without the reference
    (:mod:`.fidelity`: ``e_rel_ref_hat``, its spread ``e_rel_ref_hat_std``,
    ``surrogate_validation``, …; the aggregate of a multi-DOF record), when the record has
    the numerical substructure and its load (identification and coupling take ~0.1–1 s).

    Keys (where inputs exist): ``e_rel_track``, ``e_mte_track``, ``e_peak_track``,
    ``e_rel_track_f``, ``ti``, ``theta_pc``, ``paei_phase`` (rad), ``paei_amp``, ``fei_A``,
    ``fei_phi`` (rad), ``fei_d`` (s), ``f_eq`` (Hz), ``e_error`` (J), ``e_input`` (J),
    ``e_strain`` (J), ``hsem_s``, ``hsem_i``, ``eei``, ``e_rel_ref``, ``e_mre_ref``,
    ``e_peak_ref``, ``e_rel_ref_f``, ``j1`` (s) … ``j9`` (%), and the system keys ``phi``,
    ``kappa``, ``zeta``, ``omega_num``, ``omega_dyn`` (rad/s), ``tau_ratio_num``,
    ``tau_ratio_dyn``, ``tau_max`` (s), ``tau_ratio_max``, ``tau_cr`` (s), ``psi``; and the
    bench load ``stroke_peak`` (m), ``velocity_peak`` (m/s), ``force_peak`` (N) of
    :mod:`.bench`.
    """
    if not isinstance(record, Record):
        raise RecordError(f"compute_measures needs a Record, got {type(record).__name__}")
    meta = record.meta or {}
    dofs = record.dofs
    if not dofs:
        raise RecordError("record has no interface columns (e.g. 'z_cmd.z', 'z_meas.z')")
    for sig in ("z_cmd", "z_meas"):
        if not record.has(sig, dofs):
            raise RecordError(f"record has no {sig!r} column for every DOF "
                              f"({', '.join(dofs)}): tracking measures need both z and z'")
    dt = record.dt
    if not (math.isfinite(dt) and dt > 0):
        raise RecordError(f"record time step dt = {dt!r} s is not > 0")
    nd = len(dofs)
    z = _signal(record, "z_cmd", dofs)
    zp = _signal(record, "z_meas", dofs)
    fm = _signal(record, "f_meas", dofs) if record.has("f_meas", dofs) else None
    fx = _signal(record, "f_ext", dofs) if record.has("f_ext", dofs) else None
    zr = _reference_signal(record, context, dofs)
    per: dict[str, np.ndarray] = {}

    per["e_rel_track"] = np.atleast_1d(tracking.e_rel_track(z, zp))
    per["e_mte_track"] = np.atleast_1d(tracking.e_mte_track(z, zp))
    per["e_peak_track"] = np.atleast_1d(tracking.e_peak_track(z, zp))
    # spectra once, shared by eq. (4), the FEI and e_rel,ref,f
    z_spec, zp_spec = tracking.one_sided_amplitude(z), tracking.one_sided_amplitude(zp)
    per["e_rel_track_f"] = tracking.spectral_rel_error(z_spec, zp_spec)
    per["ti"] = np.atleast_1d(ssp.ti(z, zp))
    per["theta_pc"] = np.atleast_1d(ssp.theta_pc(z, zp))
    ph, am = ssp.paei(z, zp)
    per["paei_phase"], per["paei_amp"] = np.atleast_1d(ph), np.atleast_1d(am)
    l_exp = float(context.get("l", 2.0))
    if not (math.isfinite(l_exp) and l_exp > 0):
        raise ConfigError("l", l_exp, "FEI weight exponent must be finite and > 0")
    f = frequency.fei_from_spectra(z_spec, zp_spec, record.n, dt, l_exp)
    per["fei_A"], per["fei_phi"] = np.atleast_1d(f.A), np.atleast_1d(f.phi)
    per["fei_d"], per["f_eq"] = np.atleast_1d(f.d), np.atleast_1d(f.f_eq)
    per["stroke_peak"] = np.atleast_1d(bench.stroke_peak(z))
    per["velocity_peak"] = np.atleast_1d(bench.velocity_peak(z, dt))
    if fm is not None:
        per["force_peak"] = np.atleast_1d(bench.force_peak(fm))

    k_exp_raw = _get(context, meta, "k_exp", ("experiment", "k_exp"), ("params", "k_exp"))
    k_exp = None if k_exp_raw is None else _matrix(k_exp_raw, nd, "k_exp")
    totals: dict[str, float] = {}
    if fm is not None:
        per["e_error"] = np.atleast_1d(energy.e_error(z, zp, fm))
        totals["e_error"] = float(per["e_error"].sum())
    if fx is not None:
        per["e_input"] = np.atleast_1d(energy.e_input(z, fx))
        totals["e_input"] = float(per["e_input"].sum())
    if k_exp is not None:
        per["e_strain"] = np.array([energy.e_strain(zp[:, j], k_exp[j, j]) for j in range(nd)])
        totals["e_strain"] = energy.e_strain(zp, k_exp)
        if fm is not None:
            per["hsem_s"] = np.asarray(energy.hsem_s(per["e_error"], per["e_strain"]))
            totals["hsem_s"] = float(energy.hsem_s(totals["e_error"], totals["e_strain"]))
            if fx is not None:
                per["hsem_i"] = np.asarray(energy.hsem_i(per["e_error"], per["e_strain"],
                                                         per["e_input"]))
                totals["hsem_i"] = float(energy.hsem_i(totals["e_error"], totals["e_strain"],
                                                       totals["e_input"]))
    if zr is not None:
        per["e_rel_ref"] = np.atleast_1d(reference.e_rel_ref(zr, zp))
        per["e_mre_ref"] = np.atleast_1d(reference.e_mre_ref(zr, zp))
        per["e_peak_ref"] = np.atleast_1d(reference.e_peak_ref(zr, zp))
        per["e_rel_ref_f"] = tracking.spectral_rel_error(tracking.one_sided_amplitude(zr),
                                                         zp_spec)
    js = _criteria(record, z, zp, zr, dt, str(context.get("j_convention", "code")))
    if js is not None:
        for key in js[0]:
            per[key] = np.array([row[key] for row in js], dtype=float)

    dom = dominant_dof(z, fm)

    system = _system(record, context, meta, nd, dofs, float(per["fei_d"][dom]), k_exp)
    eei = _eei(record, context, meta, fm, zp, dt, totals.get("e_strain"))
    if eei is not None:
        system["eei"] = eei

    dof_dicts = {d: {k: float(v[j]) for k, v in per.items()} for j, d in enumerate(dofs)}
    for row in dof_dicts.values():  # per-DOF τ-ratios use that DOF's delay
        for key, w in (("tau_ratio_num", "omega_num"), ("tau_ratio_dyn", "omega_dyn")):
            if w in system:
                row[key] = susceptibility.tau_ratio(row["fei_d"], system[w])
        if "tau_max" in system:
            row["tau_ratio_max"] = susceptibility.tau_ratio_max(row["fei_d"], system["tau_max"])
    if surrogate and fm is not None:
        from .fidelity import surrogate_measures

        system.update(surrogate_measures(record))
    if nd == 1:
        flat = dict(dof_dicts[dofs[0]])
        flat.update(system)
        return flat
    agg = dict(dof_dicts[dofs[dom]])
    for key in ("e_error", "e_input", "e_strain", "hsem_s", "hsem_i"):
        agg.pop(key, None)
    agg.update(totals)
    agg.update(system)
    agg["dominant_dof"] = dofs[dom]
    return {"dofs": dof_dicts, "aggregate": agg}


def _system(record: Record, context: dict, meta: dict, nd: int, dofs: tuple[str, ...],
            d: float, k_exp: np.ndarray | None) -> dict[str, float]:
    out: dict[str, float] = {}
    num = _numerical(context, meta)
    m_exp_raw = _get(context, meta, "m_exp", ("experiment", "m_exp_matrix"),
                     ("experiment", "m_exp"), ("params", "m_exp"))
    c_exp_raw = _get(context, meta, "c_exp", ("experiment", "c_exp"), ("experiment", "d_exp"),
                     ("params", "d_exp"))
    m_exp = None if m_exp_raw is None else _matrix(m_exp_raw, nd, "m_exp")
    c_exp = np.zeros((nd, nd)) if c_exp_raw is None else _matrix(c_exp_raw, nd, "c_exp")
    w_num = _get(context, meta, "omega_num_max", ("omega_num_max",))
    w_dyn = _get(context, meta, "omega_dyn_max", ("omega_dyn_max",))
    loop = None
    if num is not None:
        M, C, K, G = num
        if G.shape[1] != nd:
            raise ConfigError("numerical.gamma", list(G.shape),
                              f"must map {nd} interface DOF(s) ({', '.join(dofs)})")
        w_max, zeta = susceptibility.fastest_mode(M, C, K)
        out["zeta"] = zeta
        if w_num is None:
            w_num = w_max
        m_if, k_if = susceptibility.interface_properties(M, K, G)
        for name, mat, why in (("m_exp", m_exp, "kg; must be > 0: φ = m_NUM/m_EXP"),
                               ("k_exp", k_exp, "N/m; must be > 0: κ = k_NUM/k_EXP")):
            if mat is not None and not np.all(np.diag(mat) > 0):
                shown = float(mat[0, 0]) if nd == 1 else np.diag(mat).tolist()
                raise ConfigError(name, shown, why)
        if m_exp is not None:
            out["phi"] = float(np.mean(m_if / np.diag(m_exp))) if nd > 1 else \
                float(m_if[0] / m_exp[0, 0])
        if k_exp is not None:
            out["kappa"] = float(np.mean(k_if / np.diag(k_exp))) if nd > 1 else \
                float(k_if[0] / k_exp[0, 0])
        if m_exp is not None and k_exp is not None:
            if w_dyn is None:
                w_dyn = susceptibility.omega_dyn(M, K, m_exp, k_exp, G)
            loop = susceptibility.interface_loop(M, C, K, m_exp, c_exp, k_exp, G)
            out["tau_cr"] = loop.tau_cr
            out["psi"] = loop.psi
    if w_num is not None:
        out["omega_num"] = float(w_num)
        out["tau_ratio_num"] = susceptibility.tau_ratio(d, float(w_num))
    if w_dyn is not None:
        out["omega_dyn"] = float(w_dyn)
        out["tau_ratio_dyn"] = susceptibility.tau_ratio(d, float(w_dyn))
    pm = _get(context, meta, "phase_margin", ("phase_margin",))
    wc = _get(context, meta, "crossover", ("crossover",))
    tau_max = None
    if pm is not None and wc is not None:
        tau_max = susceptibility.delay_margin(float(pm), float(wc))
    elif loop is not None:
        tau_max = loop.tau_cr
    if tau_max is not None:
        out["tau_max"] = tau_max
        out["tau_ratio_max"] = susceptibility.tau_ratio_max(d, tau_max)
    return out


def _eei(record: Record, context: dict, meta: dict, fm: np.ndarray | None, zp: np.ndarray,
         dt: float, e_str: float | None) -> float | None:
    """EEI when the record carries the numerical states ``x_num.<i>`` and the model.

    The external force on the numerical DOFs is ``p_num.<i>`` if recorded, else recovered from
    the interface load f_ext = Γᵀ p when Γ is square; otherwise EEI is left out.
    """
    xs = record.group("x_num")
    if not xs or fm is None or e_str is None:
        return None
    num = _numerical(context, meta)
    if num is None:
        return None
    M, C, K, G = num
    n = M.shape[0]
    keys = [str(i) for i in range(n)]
    if any(k not in xs for k in keys):
        return None
    x = np.column_stack([xs[k] for k in keys])
    ps = record.group("p_num")
    if all(k in ps for k in keys):
        p = np.column_stack([ps[k] for k in keys])
    elif record.has("f_ext") and G.shape[0] == G.shape[1]:
        # f_ext is the load seen at the interface, Γᵀ p: invertible only for a square Γ
        try:
            p = np.linalg.solve(G.T, record.signal("f_ext").T).T
        except np.linalg.LinAlgError:
            return None
    else:
        return None
    vs = record.group("v_num")
    v = np.column_stack([vs[k] for k in keys]) if all(k in vs for k in keys) else None
    res = energy.energy_balance_residual(x, M, C, K, p, G, fm, zp, dt, v)
    return energy.eei(float(res[-1]), e_str)


def feature_row(record: Record, set: int | Sequence[str] = 1,  # noqa: A002
                **context: Any) -> dict[str, float]:
    """One row of Table-3 feature set ``set`` (1, 2 or 3, or a list of names, which may hold
    the surrogate inputs :data:`~rths3d.metrics.features.SURROGATE`) for one test.

    Values come from :func:`compute_measures` (its aggregate for a multi-DOF record; the
    surrogate estimate computed when asked for); a feature whose inputs are missing is NaN.
    Keys in the order of the set.
    """
    names = feature_names(set)
    if any(n in SURROGATE for n in names):
        context.setdefault("surrogate", True)
    m = compute_measures(record, **context)
    flat = m["aggregate"] if "aggregate" in m else m
    return {k: float(flat.get(k, math.nan)) for k in names}

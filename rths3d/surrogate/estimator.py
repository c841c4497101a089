"""The surrogate reference ẑ^r of a hybrid test, estimated from its own record.

Procedure (one record, or many stepped together):

1. **Identify the part.** From the measured interface displacement z' and force F'_m, fit
   every candidate model class (:data:`CANDIDATES`: linear ARX and switched ARX of two
   orders each, the switched class with and without the guard around its switch; no prior
   knowledge of the part) and score each by its output error on held-out blocks of the
   record (:meth:`~rths3d.surrogate.base.LagModel.validate`).
2. **Couple every candidate and check its run.** Each candidate is coupled to the numerical
   substructure of the record (M, C, K, Γ from ``meta["numerical"]``, its load p from the
   ``p_num.<i>`` columns) with compatibility and equilibrium exact at every sample (the
   machinery of the reference solution), and its run is checked (:mod:`.checks`: it must
   not grow through a regime it occupies, nor diverge). The consistent candidate of best
   held-out score gives ẑ^r(t).
3. **Errors, band and flag.** ê(t) = z'(t) − ẑ^r(t) gives every reference error measure
   (ê_rel,ref = RMS(ê)/RMS(ẑ^r), …) and the running RMS at every step. *Members*: the
   chosen model, its refits on each half of the record (bootstrap blocks) and every
   consistent candidate that validates within ``accept`` times its score; their range of
   ê_rel,ref, widened, is the band. The estimate is flagged unreliable, with its reasons,
   when no candidate is consistent, when the model's replay of the record misses F'_m, when
   the members disagree or when ẑ^r extrapolates the part; when every candidate diverges
   its status is ``failed`` (:func:`.checks.flag_reasons`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import RecordError
from ..metrics._signals import dominant_dof
from ..record import Record
from .arx import ARX
from .base import LagModel, LagPart, Switch, check_signals, first_sample
from .checks import band, check_run, flag_reasons
from .running import WINDOW, running_rms
from .switched import GUARD, SwitchedARX

CANDIDATES: tuple[tuple[str, int, int], ...] = (
    ("arx", 4, 2), ("arx", 6, 4), ("switched", 4, 2), ("switched", 6, 4))
"""Candidate model classes and orders (class, nb, na), scored on held-out blocks."""

CANDIDATES_MIMO: tuple[tuple[str, int, int], ...] = (("arx", 4, 2), ("switched", 4, 2))
"""Candidates for several interface DOFs: the lowest orders only. Higher MIMO orders fit the
record as well but couple badly (modes the record never excited), and the search for the
switch's direction costs a free run per candidate."""

CLASSES = {"arx": ARX, "switched": SwitchedARX}
"""Model class name → class (one file each in this package)."""

DIVERGED = 1e3
"""A member diverges when its force exceeds this many times the measured peak force."""


@dataclass(frozen=True)
class SurrogateConfig:
    """Settings of the surrogate reference.

    ``candidates``: (class, nb, na) triples (``candidates_mimo`` for several DOFs);
    ``n_blocks``: held-out blocks of the validation;
    ``couplings``: for several DOFs, full and/or diagonal (and ``mixed`` for the switched
    class; see :data:`~rths3d.surrogate.base.COUPLINGS`); ``accept``: a candidate of another
    class whose validation error is within this factor of the best joins the members;
    ``halves``: refit the best on each half of the record as two more members; ``tol``
    (m, rad) and ``max_iter``: the interface iteration of the coupling; ``window``:
    running-RMS window (s); ``guards``: the switched class is fitted once per entry, with
    that many rows on either side of a change of regime left out of the regimes' fits
    (:data:`~rths3d.surrogate.switched.GUARD`).
    """

    candidates: tuple[tuple[str, int, int], ...] = CANDIDATES
    candidates_mimo: tuple[tuple[str, int, int], ...] = CANDIDATES_MIMO
    n_blocks: int = 4
    accept: float = 2.0
    halves: bool = True
    tol: float = 1e-10
    max_iter: int = 30
    window: float = WINDOW
    couplings: tuple[str, ...] = ("full", "diagonal")
    guards: tuple[int, ...] = (0, GUARD)

    def __post_init__(self) -> None:
        from ..errors import ConfigError

        for cls, nb, na in self.candidates + self.candidates_mimo:
            if cls not in CLASSES:
                raise ConfigError("candidates", cls, f"one of {', '.join(CLASSES)}")
            if nb < 1 or na < 0:
                raise ConfigError("candidates", (cls, nb, na), "nb >= 1 and na >= 0")
        if not self.candidates:
            raise ConfigError("candidates", (), "at least one model class")
        if self.n_blocks < 2:
            raise ConfigError("n_blocks", self.n_blocks, "at least 2 held-out blocks")
        if any(g < 0 for g in self.guards) or 0 not in self.guards:
            raise ConfigError("guards", self.guards, "non-negative, 0 among them")
        if not (self.accept >= 1.0):
            raise ConfigError("accept", self.accept, "must be >= 1")


@dataclass
class Identification:
    """The part identified from one record: candidates with their validation errors
    (``scores``, relative RMS output error on held-out blocks; ``insample``: free run over
    the whole record), their ranking ``order``, the chosen ``model`` and the uncertainty
    ``members`` (the chosen one first)."""

    candidates: list[LagModel]
    scores: list[float]
    model: LagModel
    members: list[LagModel] = field(default_factory=list)
    member_names: list[str] = field(default_factory=list)
    insample: list[float] = field(default_factory=list)
    order: list[int] = field(default_factory=list)


def identify(z: np.ndarray, f: np.ndarray, config: SurrogateConfig | None = None,
             stable: Callable[[LagModel], bool] | None = None) -> Identification:
    """Fit and score every candidate on (z', F'_m) (N, d); see the module docstring.

    ``stable``: a test of a fitted model (e.g. :func:`coupled_stability` of the record's
    numerical substructure); models that fail it are ranked after every model that passes
    and do not become members (unless none passes)."""
    cfg = config or SurrogateConfig()
    z, f = check_signals(z, f)
    cands: list[LagModel] = []
    scores: list[float] = []
    insample: list[float] = []
    with np.errstate(all="ignore"):
        switch: dict[str, Switch] = {}
        mimo = z.shape[1] > 1
        couplings = cfg.couplings if mimo else ("full",)
        cands_cfg = cfg.candidates_mimo if mimo else cfg.candidates
        for (cls, nb, na), cp in itertools.product(cands_cfg, couplings):
            if cp == "mixed" and cls != "switched":
                continue  # one regime: mixed is diagonal
            try:
                if cls == "switched":
                    # the switch found with the first (lowest) orders serves the others
                    m = SwitchedARX(nb, na, cp, switch.get(cp)).fit(z, f)
                    switch[cp] = m.switch_
                    fits = [m] + [SwitchedARX(nb, na, cp, m.switch_, guard=g).fit(z, f)
                                  for g in cfg.guards if g > 0]
                else:
                    fits = [CLASSES[cls](nb, na, cp).fit(z, f)]
            except (np.linalg.LinAlgError, ValueError):
                continue
            for m in fits:
                try:
                    s = m.validate(z, f, cfg.n_blocks)
                    s_in = m.simulation_error(z, f)
                except (np.linalg.LinAlgError, ValueError):
                    continue
                cands.append(m)
                scores.append(s)
                insample.append(s_in)
    if not cands:
        raise RecordError("no part model could be fitted to z' and F'_m")
    # held-out error first; among equals (e.g. every candidate diverging on some held-out
    # block of a record with few cycles) the in-sample free-run error decides
    ok = [True] * len(cands) if stable is None else [bool(stable(m)) for m in cands]
    if not any(ok):
        ok = [True] * len(cands)  # nothing passes: rank them all (the estimate says so)
    order = np.lexsort((insample, scores, [not v for v in ok]))
    best = cands[int(order[0])]
    members: list[LagModel] = [best]
    names = [best.label]
    if cfg.halves:
        L = first_sample(best.nb, best.na)
        n = len(z) - L
        for name, rows in (("first half", np.arange(n) < n // 2),
                           ("second half", np.arange(n) >= n // 2)):
            try:
                with np.errstate(all="ignore"):
                    half = best.refit(z, f, rows)
            except (np.linalg.LinAlgError, ValueError):
                continue
            if stable is None or stable(half):
                members.append(half)
                names.append(f"{best.label} {name}")
    s0 = scores[int(order[0])]
    for i in order[1:]:
        m = cands[int(i)]
        if (m.name != best.name and ok[int(i)]
                and scores[int(i)] <= cfg.accept * max(s0, 1e-12)):
            members.append(m)
            names.append(m.label)
            break
    return Identification(cands, scores, best, members, names, insample,
                          [int(i) for i in order])


STABLE_RADIUS = 1.0 + 1e-5
"""Largest spectral radius of the coupled one-step map accepted (1 + 10⁻⁵: at most 8 %
growth over 8000 steps)."""


def coupled_stability(record: Record) -> Callable[[LagModel], bool]:
    """The test ``model -> bool`` that the model, coupled exactly to the record's numerical
    substructure, neither grows in its free nor in its switched regime
    (:func:`~rths3d.surrogate.online.coupled_radius` ≤ :data:`STABLE_RADIUS`)."""
    from ..numerical import discretise
    from .online import coupled_radius

    M, C, K, G, _ = numerical_of(record)
    D = discretise(M, C, K, record.dt, "exact")
    mats = (D.Ad, (D.G1 - D.G2) @ G, D.G2 @ G, G.T @ D.Cx)

    def stable(model: LagModel) -> bool:
        try:
            return coupled_radius(*mats, model) <= STABLE_RADIUS
        except np.linalg.LinAlgError:
            return False

    return stable


def coupled_radii_of(record: Record) -> Callable[[LagModel], tuple[float, float]]:
    """``model -> (r_lo, r_hi)``: the coupled spectral radii of each regime of a model on the
    record's numerical substructure (:func:`~rths3d.surrogate.online.coupled_radii`; inf
    where the map cannot be formed)."""
    from ..numerical import discretise
    from .online import coupled_radii

    M, C, K, G, _ = numerical_of(record)
    D = discretise(M, C, K, record.dt, "exact")
    mats = (D.Ad, (D.G1 - D.G2) @ G, D.G2 @ G, G.T @ D.Cx)

    def radii(model: LagModel) -> tuple[float, float]:
        try:
            return coupled_radii(*mats, model)
        except np.linalg.LinAlgError:
            return (math.inf, math.inf)

    return radii


def _halves(record: Record, model: LagModel) -> list[LagModel]:
    """``model`` refitted on the first and on the second half of the record (bootstrap
    blocks; those that fail to fit left out)."""
    z, f = record.signal("z_meas"), record.signal("f_meas")
    L = first_sample(model.nb, model.na)
    n = len(z) - L
    out = []
    for rows in (np.arange(n) < n // 2, np.arange(n) >= n // 2):
        try:
            with np.errstate(all="ignore"):
                out.append(model.refit(z, f, rows))
        except (np.linalg.LinAlgError, ValueError):
            continue
    return out


def _member_name(m: LagModel, halves: list, best: LagModel) -> str:
    if m in halves:
        return f"{best.label} {'first' if halves.index(m) == 0 else 'second'} half"
    return m.label


def numerical_of(record: Record):
    """The record's numerical substructure (M, C, K, Γ) and its load p (N, n)."""
    meta = record.meta or {}
    num = meta.get("numerical") if isinstance(meta.get("numerical"), dict) else None
    if not num or any(k not in num for k in ("M", "C", "K")):
        raise RecordError("the surrogate reference needs the numerical substructure: "
                          "meta['numerical'] with M, C, K (and gamma)")
    M, C, K = (np.atleast_2d(np.asarray(num[k], dtype=float)) for k in ("M", "C", "K"))
    n = M.shape[0]
    G = np.asarray(num.get("gamma", np.ones((n, 1))), dtype=float).reshape(n, -1)
    if G.shape[1] != len(record.dofs):
        raise RecordError(f"meta['numerical']['gamma'] maps {G.shape[1]} interface DOF(s), "
                          f"the record has {len(record.dofs)} ({', '.join(record.dofs)})")
    ps = record.group("p_num")
    if all(str(i) in ps for i in range(n)):
        p = np.column_stack([ps[str(i)] for i in range(n)])
    elif record.has("f_ext") and G.shape[0] == G.shape[1]:
        # f_ext = Γᵀ p: recoverable only for a square Γ
        p = np.linalg.solve(G.T, record.signal("f_ext").T).T
    else:
        raise RecordError("the surrogate reference needs the load on the numerical "
                          "substructure: columns p_num.<i> (or f_ext with a square gamma)")
    return M, C, K, G, p


def couple_members(records: Sequence[Record], members: Sequence[Sequence[LagModel]],
                   config: SurrogateConfig | None = None, *, with_forces: bool = False):
    """ẑ^r of every member of every record, coupled in one batch per record shape.

    Returns per record an (M, N, d) array (NaN for a diverged member); ``with_forces``:
    (that list, the members' part forces in the same shape)."""
    from ..numerical import LinearSubstructure
    from ..reference import couple_exact
    from .online import couple_closed_form

    cfg = config or SurrogateConfig()
    out: list[np.ndarray | None] = [None] * len(records)
    forces: list[np.ndarray | None] = [None] * len(records)
    groups: dict[tuple, list[int]] = {}
    nums = [numerical_of(r) for r in records]
    for i, r in enumerate(records):
        key = (r.n, round(r.dt, 12), len(r.dofs), nums[i][0].shape[0],
               np.asarray(nums[i][3]).tobytes())
        groups.setdefault(key, []).append(i)
    for idx in groups.values():
        Ms, Cs, Ks, ps, models, owner, limits = [], [], [], [], [], [], []
        for i in idx:
            M, C, K, G, p = nums[i]
            peak = float(np.max(np.abs(records[i].signal("f_meas")))) or 1.0
            for m in members[i]:
                Ms.append(M)
                Cs.append(C)
                Ks.append(K)
                ps.append(p)
                models.append(m)
                owner.append(i)
                limits.append(DIVERGED * peak)
        r0 = records[idx[0]]
        G = nums[idx[0]][3]
        num = LinearSubstructure(np.array(Ms), np.array(Cs), np.array(Ks), G, np.array(ps),
                                 r0.dt, "exact")
        part = LagPart(models, np.array(limits))
        with np.errstate(all="ignore"):
            if all(m.switch_.lagged or not np.isfinite(m.switch_.h) for m in models):
                # affine within every step: the fixed point in closed form (~20× faster)
                ref = couple_closed_form(num, part, r0.n - 1)
            else:
                ref = couple_exact(num, part, r0.n - 1, tol=cfg.tol, max_iter=cfg.max_iter)
        zr, fr = ref["z_ref"], ref["f_ref"]
        zr[part.diverged] = np.nan
        fr[part.diverged] = np.nan
        k = 0
        for i in idx:
            n_m = len(members[i])
            out[i] = zr[k:k + n_m]
            forces[i] = fr[k:k + n_m]
            k += n_m
    return (out, forces) if with_forces else out  # type: ignore[return-value]


def _errors(zr: np.ndarray, zp: np.ndarray, dom: int) -> dict[str, float]:
    from ..metrics import reference as ref
    from ..metrics import tracking

    a, b = zr[:, dom], zp[:, dom]
    return {"e_rel_ref": float(ref.e_rel_ref(a, b)), "e_mre_ref": float(ref.e_mre_ref(a, b)),
            "e_peak_ref": float(ref.e_peak_ref(a, b)),
            "e_rel_ref_f": float(tracking.spectral_rel_error(
                tracking.one_sided_amplitude(a[:, None]),
                tracking.one_sided_amplitude(b[:, None]))[0])}


class SurrogateReference:
    """Estimate the reference ẑ^r of hybrid-test records from their own data.

    ``SurrogateReference(config).fit(records)`` (one :class:`~rths3d.record.Record` or a
    list, which are coupled together in batches). Fitted attributes, one entry per record
    (lists, or the value itself after fitting a single record):

    ``z_ref_``
        ẑ^r (N, d), m / rad.
    ``z_ref_members_``
        ẑ^r of every member that coupled without diverging (M, N, d), the estimate first.
    ``identification_``
        :class:`Identification`: candidates, validation errors, chosen model, members.
    ``estimates_``
        dict of ê_rel,ref, ê_MRE,ref, ê_peak,ref, ê_rel,ref,f (dominant DOF, dimensionless)
        and ``e_rel_ref_std`` (spread of ê_rel,ref over the members), ``e_rel_ref_members``,
        ``e_rel_ref_lo``, ``e_rel_ref_hi`` (the band, :func:`.checks.band`), ``model``
        (chosen candidate), ``validation`` (its held-out output error), ``replay`` (its
        free run over the whole record), ``n_members``, ``status`` (``ok``, ``unreliable``
        or ``failed``), ``reliable`` and ``reason`` (:func:`.checks.flag_reasons`).

    ``columns(record)`` gives the per-step columns of a fitted record (see
    :func:`rths3d.surrogate.fidelity_columns`).
    """

    def __init__(self, config: SurrogateConfig | None = None):
        self.config = config or SurrogateConfig()

    def fit(self, records: Record | Sequence[Record]) -> SurrogateReference:
        single = isinstance(records, Record)
        recs = [records] if single else list(records)
        cfg = self.config
        ids: list[Identification] = []
        for r in recs:
            dofs = r.dofs
            if not (r.has("z_meas", dofs) and r.has("f_meas", dofs)):
                raise RecordError("the surrogate reference needs z_meas and f_meas columns "
                                  f"for every DOF ({', '.join(dofs)})")
            ids.append(identify(r.signal("z_meas"), r.signal("f_meas"),
                                replace(cfg, halves=False)))
        # 1. every candidate coupled; each run checked (coupled_check)
        radii = [coupled_radii_of(r) for r in recs]
        zs, fs = couple_members(recs, [i.candidates for i in ids], cfg, with_forces=True)
        peaks = [float(np.max(np.abs(r.signal("f_meas")))) for r in recs]
        checks = [[check_run(m, radii[i](m), zs[i][j], fs[i][j], peaks[i], STABLE_RADIUS)
                   for j, m in enumerate(ids[i].candidates)] for i in range(len(recs))]
        # 2. the best consistent candidate (held-out error, then in-sample); its halves
        best_j, halves = [], []
        for i, ident in enumerate(ids):
            ok = [c.ok for c in checks[i]]
            alive = [np.isfinite(zs[i][j]).all() for j in range(len(ok))]
            rank = np.lexsort((ident.insample, ident.scores, [not a for a in alive],
                               [not v for v in ok]))
            ident.order = [int(j) for j in rank]
            j = int(rank[0])
            best_j.append(j)
            ident.model = ident.candidates[j]
            hv = []
            if cfg.halves and checks[i][j].ok:
                hv = _halves(recs[i], ident.model)
            halves.append(hv)
        zh, fh = couple_members(recs, halves, cfg, with_forces=True)
        z_ref, est, members_z = [], [], []
        for i, (r, ident) in enumerate(zip(recs, ids, strict=True)):
            est_i, zr, zm = self._estimate(r, ident, checks[i], best_j[i], zs[i], halves[i],
                                           zh[i], fh[i], radii[i], peaks[i])
            z_ref.append(zr)
            members_z.append(zm)
            est.append(est_i)
        self.identification_ = ids[0] if single else ids
        self.z_ref_ = z_ref[0] if single else z_ref
        self.z_ref_members_ = members_z[0] if single else members_z
        self.estimates_ = est[0] if single else est
        self._records = recs
        return self

    def _estimate(self, r: Record, ident: Identification, checks: list, j: int,
                  zc: np.ndarray, halves: list, zh: np.ndarray, fh: np.ndarray, radii,
                  peak: float) -> tuple[dict, np.ndarray, np.ndarray]:
        """Members, estimate, band and flag of one record (see :mod:`.checks`)."""
        cfg = self.config
        zp = r.signal("z_meas")
        dom = dominant_dof(zp, r.signal("f_meas"))
        best = ident.candidates[j]
        s0 = ident.scores[j]
        members: list[LagModel] = []
        runs: list[np.ndarray] = []
        if np.isfinite(zc[j]).all():
            members.append(best)
            runs.append(zc[j])
        for h, m in enumerate(halves):
            if check_run(m, radii(m), zh[h], fh[h], peak, STABLE_RADIUS).ok:
                members.append(m)
                runs.append(zh[h])
        for q in ident.order:
            if q != j and checks[q].ok and ident.scores[q] <= cfg.accept * max(s0, 1e-12):
                members.append(ident.candidates[q])
                runs.append(zc[q])
        ident.members = members
        ident.member_names = [_member_name(m, halves, best) for m in members]
        keys = ("e_rel_ref", "e_mre_ref", "e_peak_ref", "e_rel_ref_f")
        if not members:
            reason = ("every identified part model diverged when coupled to the numerical "
                      "substructure: no estimate")
            e = dict.fromkeys(keys, math.nan)
            e.update({"e_rel_ref_std": math.nan, "e_rel_ref_members": [],
                      "e_rel_ref_lo": math.nan, "e_rel_ref_hi": math.nan,
                      "model": best.label, "validation": s0,
                      "replay": ident.insample[j], "n_members": 0,
                      "status": "failed", "reliable": False, "reason": reason})
            return e, np.full_like(zp, np.nan), np.zeros((0,) + zp.shape)
        vals = [_errors(z, zp, dom) for z in runs]
        rel = np.array([v["e_rel_ref"] for v in vals])
        lo, hi = band(rel, s0)
        replay = ident.insample[j]
        reasons = flag_reasons(checks[j].ok, checks[j], replay, rel)
        e = dict(vals[0])
        e.update({"e_rel_ref_std": float(np.std(rel)) if len(rel) > 1 else math.nan,
                  "e_rel_ref_members": rel.tolist(), "e_rel_ref_lo": lo, "e_rel_ref_hi": hi,
                  "model": best.label, "validation": s0, "replay": replay,
                  "n_members": len(members), "status": "unreliable" if reasons else "ok",
                  "reliable": not reasons,
                  "reason": "; ".join(reasons)})
        return e, runs[0], np.stack(runs)

    def columns(self, record: Record, index: int = 0) -> dict[str, np.ndarray]:
        """Per-step columns of the ``index``-th fitted record (see :func:`fidelity_columns`)."""
        one = isinstance(self.z_ref_, np.ndarray)
        zr = self.z_ref_ if one else self.z_ref_[index]
        zm = self.z_ref_members_ if one else self.z_ref_members_[index]
        return fidelity_columns(record, zr, self.config.window, zm)


def fidelity_columns(record: Record, z_ref_hat: np.ndarray, window: float = WINDOW,
                     members: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The documented per-step columns of a record with an estimated reference (m or rad):

    ``z_ref_hat.<dof>``
        the surrogate reference ẑ^r;
    ``e_hat.<dof>``
        the estimated reference error ê = z' − ẑ^r (the error e_rel,ref averages);
    ``e_hat_rms.<dof>``
        its running RMS over ``window`` s (:func:`~rths3d.surrogate.running.running_rms`);
    ``e_hat_rms_lo.<dof>``, ``e_hat_rms_hi.<dof>``
        the band of the running RMS over the ``members`` ((M, N, d) ẑ^r of each member; the
        smallest and largest at every sample), when given.
    """
    zp = record.signal("z_meas")
    zr = np.asarray(z_ref_hat, dtype=float).reshape(zp.shape)
    e = zp - zr
    rms = running_rms(e, record.dt, window)
    cols: dict[str, np.ndarray] = {}
    band = None
    if members is not None and len(members):
        # members[0] is the estimate itself: the band contains its running RMS
        r_m = np.stack([running_rms(zp - m, record.dt, window) for m in members])
        band = (r_m.min(axis=0), r_m.max(axis=0))
    for j, d in enumerate(record.dofs):
        cols[f"z_ref_hat.{d}"] = zr[:, j]
        cols[f"e_hat.{d}"] = e[:, j]
        cols[f"e_hat_rms.{d}"] = rms[:, j]
        if band is not None:
            cols[f"e_hat_rms_lo.{d}"] = band[0][:, j]
            cols[f"e_hat_rms_hi.{d}"] = band[1][:, j]
    return cols


def surrogate_reference(record: Record, config: SurrogateConfig | None = None,
                        *, columns: bool = True) -> tuple[Record, dict]:
    """One record → (a copy with the per-step columns of :func:`fidelity_columns` added and
    the estimates in ``meta["surrogate"]``, the estimates of
    :attr:`SurrogateReference.estimates_`). Save the copy (``Record.save``) to keep them."""
    est = SurrogateReference(config).fit(record)
    cols = dict(record.columns)
    if columns:
        cols.update(est.columns(record))
    meta = dict(record.meta)
    e = est.estimates_
    meta["surrogate"] = {k: v for k, v in e.items()}
    meta["surrogate"]["window"] = est.config.window
    return Record(record.t.copy(), cols, meta), e

"""Reference errors estimated without the reference: the surrogate estimate of a record.

The experimental part is identified from the record's own z' and F'_m and coupled exactly to
its numerical substructure (:mod:`rths3d.surrogate`); the estimated reference ẑ^r replaces
z^r in the reference errors. Keys (dimensionless; the dominant DOF for several DOFs):

==========================  ==============================================================
``e_rel_ref_hat``           ê_rel,ref = RMS(ẑ^r − z') / RMS(ẑ^r)
``e_mre_ref_hat``           ê_MRE,ref, ``e_peak_ref_hat`` ê_peak,ref, ``e_rel_ref_f_hat``
``e_rel_ref_hat_std``       spread (standard deviation) of ê_rel,ref over the members:
                            halves of the record, a second model class (0 with one member)
``surrogate_validation``    output error of the chosen part model on held-out blocks of
                            the record, RMS(F_sim − F'_m)/RMS(F'_m): how well the model
                            class describes this part (large: outside the classes)
``surrogate_members``       members that coupled without diverging
``e_rel_ref_hat_lo``,       the band of ê_rel,ref: the members' range, widened by 5 % plus
``e_rel_ref_hat_hi``        the held-out error (:mod:`rths3d.surrogate.checks`)
``surrogate_flag``          1 when the estimate is unreliable or failed (the reason says
                            why), else 0
``surrogate_reason``        ``ok``, or ``unreliable: …`` / ``failed: …`` with the reasons
==========================  ==============================================================

``e_rel_ref_hat``, ``e_rel_ref_hat_std`` and ``surrogate_validation`` are the ANN inputs
:data:`rths3d.metrics.features.SURROGATE`, beside the Table-3 features. A record without
the numerical substructure (``meta["numerical"]``), its load (``p_num.<i>``, or ``f_ext``
with a square Γ) or ``f_meas`` gets none of these keys.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from ..errors import RecordError
from ..record import Record

KEYS: tuple[str, ...] = ("e_rel_ref_hat", "e_mre_ref_hat", "e_peak_ref_hat", "e_rel_ref_f_hat",
                         "e_rel_ref_hat_std", "surrogate_validation", "surrogate_members",
                         "e_rel_ref_hat_lo", "e_rel_ref_hat_hi", "surrogate_flag",
                         "surrogate_reason")
"""Keys of :func:`surrogate_measures`."""


def _flat(e: dict) -> dict[str, float | str]:
    """The keys of this module from :attr:`SurrogateReference.estimates_` of a record."""
    std = e["e_rel_ref_std"]
    return {"e_rel_ref_hat": e["e_rel_ref"], "e_mre_ref_hat": e["e_mre_ref"],
            "e_peak_ref_hat": e["e_peak_ref"], "e_rel_ref_f_hat": e["e_rel_ref_f"],
            "e_rel_ref_hat_std": 0.0 if (math.isnan(std) and e["n_members"] == 1) else std,
            "surrogate_validation": float(e["validation"]),
            "surrogate_members": float(e["n_members"]),
            "e_rel_ref_hat_lo": e["e_rel_ref_lo"], "e_rel_ref_hat_hi": e["e_rel_ref_hi"],
            "surrogate_flag": 0.0 if e["reliable"] else 1.0,
            "surrogate_reason": f"{e['status']}: {e['reason']}" if e["reason"] else "ok"}


def can_estimate(record: Record) -> bool:
    """Whether the record has what the surrogate needs (f_meas, the numerical model, its
    load)."""
    from ..surrogate.estimator import numerical_of

    if not (record.has("z_meas") and record.has("f_meas")):
        return False
    try:
        numerical_of(record)
    except RecordError:
        return False
    return True


def surrogate_measures(records: Record | Sequence[Record], config=None
                       ) -> dict[str, float] | list[dict[str, float]]:
    """The surrogate estimates (keys :data:`KEYS`) of one record, or of many (identified one
    by one, coupled together). A record without the inputs gets an empty dict."""
    from ..surrogate import SurrogateReference

    single = isinstance(records, Record)
    recs = [records] if single else list(records)
    out: list[dict[str, float]] = [{} for _ in recs]
    idx = [i for i, r in enumerate(recs) if can_estimate(r)]
    if idx:
        est = SurrogateReference(config).fit([recs[i] for i in idx])
        for i, e in zip(idx, est.estimates_, strict=True):
            out[i] = _flat(e)
    return out[0] if single else out

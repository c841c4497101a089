"""The stream of samples the view reads: a :class:`rths3d.record.RecordBuffer`.

A live run writes its ``RecordBuffer`` row by row (``data[k]`` then ``n = k + 1``) and the
view, in another thread, reads ``data[:n]`` at most 30 times a second. A saved record is
replayed through the very same structure: :func:`buffer_from_record` copies it into a full
buffer, so live view and replay share every line of drawing code.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..record import DOFS, INTERFACE_SIGNALS, Record, RecordBuffer

MODEL_PREFIX = "model."
"""Prefix of model columns beside measured ones (e.g. ``model.z_meas.z`` next to
``z_meas.z``): a diagnosis record holds both and the view shows them side by side."""


def buffer_from_record(record: Record) -> RecordBuffer:
    """A full :class:`RecordBuffer` (``n`` = number of samples) holding ``record``'s columns."""
    names = ["t", *record.columns]
    buf = RecordBuffer(names, record.n, record.meta)
    buf.data[:, 0] = record.t
    for i, name in enumerate(names[1:], start=1):
        buf.data[:, i] = record.columns[name]
    buf.n = record.n
    return buf


def stream_dofs(columns: tuple[str, ...]) -> tuple[str, ...]:
    """Interface DOFs present in a stream's columns, in platform order (``x … rz``)."""
    found = set()
    for name in columns:
        if name.startswith(MODEL_PREFIX):
            name = name[len(MODEL_PREFIX):]
        sig, _, dof = name.partition(".")
        if sig in INTERFACE_SIGNALS and dof in DOFS:
            found.add(dof)
    return tuple(d for d in DOFS if d in found)


@dataclass(frozen=True)
class Channels:
    """Column indices of the signals the view draws for one interface DOF (−1: absent).

    ``z_cmd`` z, ``z_meas`` z', ``z_ref`` z^r, ``f_meas`` F'_m; the ``model_*`` entries are the
    same signals predicted by a model (``model.<signal>.<dof>`` columns).
    """

    dof: str
    t: int
    z_cmd: int
    z_meas: int
    z_ref: int
    f_meas: int
    model_z_meas: int
    model_f_meas: int

    @property
    def has_model(self) -> bool:
        """True when the stream carries model predictions beside the measurement."""
        return self.model_z_meas >= 0 or self.model_f_meas >= 0


def channels(index: dict[str, int], dof: str) -> Channels:
    """Look the view's columns up once (never per update) for interface DOF ``dof``."""
    def col(name: str) -> int:
        return index.get(name, -1)

    return Channels(dof, index["t"], col(f"z_cmd.{dof}"), col(f"z_meas.{dof}"),
                    col(f"z_ref.{dof}"), col(f"f_meas.{dof}"),
                    col(f"{MODEL_PREFIX}z_meas.{dof}"), col(f"{MODEL_PREFIX}f_meas.{dof}"))


def group_indices(index: dict[str, int], prefix: str, names: tuple[str, ...]) -> np.ndarray:
    """Indices of ``prefix.<name>`` for each name, or an empty array if any is missing."""
    cols = [index.get(f"{prefix}.{n}", -1) for n in names]
    return np.array([], dtype=int) if min(cols) < 0 else np.array(cols, dtype=int)


COMP_PREFIX = "comp."
"""Prefix of a compensator's coefficient columns, ``comp.<coefficient>.<channel>`` (channel:
an interface DOF, or ``leg0``…``leg5`` for per-leg compensation)."""


def coefficient_columns(index: dict[str, int]) -> dict[str, list[tuple[str, int]]]:
    """The compensator's coefficients in a stream: coefficient → [(channel, column), …], in
    column order (looked up once, never per update)."""
    out: dict[str, list[tuple[str, int]]] = {}
    for name, col in sorted(index.items(), key=lambda kv: kv[1]):
        if name.startswith(COMP_PREFIX):
            coef, _, channel = name[len(COMP_PREFIX):].partition(".")
            out.setdefault(coef, []).append((channel, col))
    return out

"""Which bench a measurement is compared with: the record's own, or a scene the user names.

The vRTHS loop writes the whole scene into a record (``meta["scene_def"]``: numerical
substructure, part, leg servos, sensor, effects). :func:`resolve_bench` takes that bench when
no scene is given; ``--scene`` accepts a scene file or the name of a shipped scene of any
experiment kind (``paper_contact``, ``paper_linear``, ``multidof``). The diagnosis always
replays through the Stewart platform (:class:`rths3d.bench.Bench`); every fallback to a
default is returned as a warning naming the value.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..config import Scene
from ..errors import ConfigError

__all__ = ["resolve_bench"]


def resolve_bench(scene: str | Path | None, meta: Mapping[str, Any] | None
                  ) -> tuple[Scene, list[str]]:
    """The bench scene (transfer ``stewart``) for a measurement and the warnings of every
    fallback: ``scene`` (a TOML path or a shipped scene's name) or the record's
    ``meta["scene_def"]``; without either, the ``paper_contact`` scene (with a warning)."""
    from ..scene import load_scene, scene_from_dict

    warns: list[str] = []
    meta = meta or {}
    if scene is not None and str(scene) != "":
        sc = load_scene(scene)
    elif isinstance(meta.get("scene_def"), Mapping):
        try:
            sc = scene_from_dict(meta["scene_def"], name=str(meta.get("scene", "record")))
        except ConfigError as exc:
            raise ConfigError("meta.scene_def", None, "", message=(
                f"the record's bench (meta.scene_def) is invalid: {exc}; pass --scene")) \
                from None
    else:
        sc = load_scene("paper_contact")
        warns.append("the record names no bench (no meta.scene_def): using the shipped scene "
                     "'paper_contact' (part contact, m = 0.38 kg, k = 8650 N/m); pass --scene")
    from ..transfer import StewartTransfer, transfer_class

    if not getattr(transfer_class(sc.transfer.kind), "replays_bench", False):
        warns.append(f"the bench's transfer system is {sc.transfer.kind!r}: the diagnosis "
                     "replays it through the Stewart platform with the same leg-servo "
                     "settings")
        sc = dataclasses.replace(sc, transfer=dataclasses.replace(sc.transfer,
                                                                  kind=StewartTransfer.kind))
    return sc, warns

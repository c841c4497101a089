"""The user's own part, as MuJoCo describes it: an MJCF fragment mounted on the FTS site.

The scene names a file (``experiment.kind = "mjcf"``, ``file``, ``dofs``): a ``<mujoco>``
document whose ``<worldbody>`` holds

- the bodies mounted on the FTS: any bodies, joints, inertials and geoms, written in the FTS
  site frame (z up at home, origin at the sensor's reference point), and
- the world-fixed bodies, those whose name starts with ``world_`` (e.g. a contact surface),
  plus any geom or site placed directly in the worldbody; they are written in the same
  frame at home (axes parallel to the world's) and fixed to the world there.

``<default>``, ``<asset>`` (files relative to the fragment's folder), ``<contact>`` and
``<equality>`` sections are allowed; a
``<compiler>`` may only say ``angle="radian"`` (the platform's convention). Every name and
default class of the file gets the prefix ``part_`` (references follow), so the part's names
never clash with the platform's; the file's top-level defaults become the class
``part_main`` of its root bodies. The part runs on the platform (:class:`rths3d.bench.Bench`)
and, for the 1-D transfer systems and the reference, in MuJoCo behind a prescribed mount
(:class:`~rths3d.experiment.mujoco_specimen.MujocoSpecimen`): it has no numpy twin.
Its interface mass matrix m_EXP is its composite rigid inertia about the FTS origin with every
joint of the fragment locked; k_EXP and c_EXP are not derived from the fragment (zero).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from collections.abc import Hashable, Mapping
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ..config import ExperimentConfig
from ..errors import ConfigError
from .base import NO_TWIN, ExperimentalPart, register_part

PREFIX = "part_"
WORLD = "world_"
"""Name prefix of the file's world-fixed bodies."""
SECTIONS = ("default", "asset", "contact", "equality")
REFS = ("class", "childclass", "mesh", "material", "texture", "hfield", "body1", "body2",
        "geom1", "geom2", "joint", "joint1", "joint2", "site", "site1", "site2", "tendon",
        "tendon1", "tendon2", "body", "target", "objname")
"""Attributes that refer to a named element (renamed with the names they refer to)."""
ALL_DOFS = ("x", "y", "z", "rx", "ry", "rz")


class _Fragment:
    """The parsed file: mounted bodies, world-fixed elements and top-level sections."""

    def __init__(self, path: str):
        self.path = path
        field = "experiment.file"
        try:
            root = ET.parse(path).getroot()
        except OSError as exc:
            raise ConfigError(field, path, f"cannot read: {exc.strerror or exc}") from None
        except ET.ParseError as exc:
            raise ConfigError(field, path, f"not valid XML: {exc}") from None
        if root.tag != "mujoco":
            raise ConfigError(field, path, f"root element is <{root.tag}>, must be <mujoco>")
        folder = Path(path).resolve().parent
        for e in root.iter():           # asset files (meshes, textures) beside the fragment
            f = e.get("file")
            if f and not Path(f).is_absolute():
                e.set("file", str(folder / f))
        names = {e.get("name") for e in root.iter() if e.get("name")}
        classes = {e.get("class") for e in root.iter("default") if e.get("class")}
        for e in root.iter():
            for a in REFS:
                v = e.get(a)
                if v is None:
                    continue
                if (a in ("class", "childclass") and v in classes) or \
                        (a not in ("class", "childclass") and v in names):
                    e.set(a, PREFIX + v)
            if e.get("name"):
                e.set("name", PREFIX + e.get("name"))
        mounted: list[ET.Element] = []
        world: list[ET.Element] = []
        sections: list[ET.Element] = []
        defaults: list[ET.Element] = []
        for child in root:
            if child.tag == "worldbody":
                for e in child:
                    if e.tag == "body" and not (e.get("name") or "").startswith(PREFIX + WORLD):
                        mounted.append(e)
                    elif e.tag in ("body", "geom", "site"):
                        world.append(e)
                    elif e.tag not in ("light", "camera"):
                        raise ConfigError(field, path, f"<worldbody> may hold <body>, <geom> "
                                          f"and <site> elements, not <{e.tag}>")
            elif child.tag == "default":
                defaults.extend(child)
            elif child.tag in SECTIONS:
                sections.append(child)
            elif child.tag == "compiler":
                if child.get("angle", "degree") != "radian" or set(child.attrib) - {"angle"}:
                    raise ConfigError(field, path, '<compiler> may only say angle="radian" '
                                      "(the platform model's angles are in rad)")
            else:
                raise ConfigError(field, path, f"<{child.tag}> is not allowed (allowed: "
                                  f"worldbody, {', '.join(SECTIONS)}, compiler)")
        if not mounted:
            raise ConfigError(field, path, "no body to mount on the FTS: <worldbody> needs a "
                              f"<body> whose name does not start with {WORLD!r}")
        for e in mounted + world:
            if e.tag == "body" and not e.get("childclass"):
                e.set("childclass", PREFIX + "main")
            elif e.tag != "body" and not e.get("class"):
                e.set("class", PREFIX + "main")
        main = ET.Element("default", {"class": PREFIX + "main"})
        main.extend(defaults)
        top = ET.Element("default")
        top.append(main)

        def text(es: list[ET.Element]) -> str:
            return "".join(ET.tostring(e, encoding="unicode") for e in es)

        self.mounted = text(mounted)
        self.world = text(world)
        self.extra = text([top, *sections])


@lru_cache(maxsize=32)
def _fragment(path: str, stamp: tuple[float, int]) -> _Fragment:
    return _Fragment(path)


def load_fragment(path: str) -> _Fragment:
    """The parsed fragment of ``path`` (cached while the file is unchanged)."""
    try:
        st = os.stat(path)
    except OSError:
        raise ConfigError("experiment.file", path, "file not found") from None
    return _fragment(str(path), (st.st_mtime, st.st_size))


@register_part
class MjcfPart(ExperimentalPart):
    """The user's MJCF fragment mounted on the FTS site (see the module docstring).

    ``file``: the fragment (a path relative to the scene file in the scene); ``dofs``: the
    interface DOFs it is tested through (default: the scene's ``dofs``). MuJoCo only."""

    kind = "mjcf"
    dofs = ()

    @classmethod
    def interface_dofs(cls, cfg: ExperimentConfig) -> tuple[str, ...]:
        return tuple(d for d in ALL_DOFS if d in cfg.dofs)

    @classmethod
    def validate(cls, cfg: ExperimentConfig) -> None:
        if not cfg.file:
            raise ConfigError("experiment.file", None, "required for kind = 'mjcf': the "
                              "part's MJCF file (relative to the scene file)")
        bad = [d for d in cfg.dofs if d not in ALL_DOFS]
        if bad or not cfg.dofs or len(set(cfg.dofs)) != len(cfg.dofs):
            raise ConfigError("experiment.dofs", list(cfg.dofs), "must be a non-empty list of "
                              f"distinct DOFs from {', '.join(ALL_DOFS)}")
        part = cls(cfg)
        part._matrix()  # compiles the fragment behind a prescribed mount: MuJoCo's errors

    @property
    def has_contact(self) -> bool:  # type: ignore[override]
        """Whether the file has world-fixed bodies (a surface the part may meet)."""
        return bool(self._frag().world)

    def _frag(self) -> _Fragment:
        return load_fragment(self.cfg.file)

    def payload_xml(self) -> str:
        return self._frag().mounted

    def world_xml(self, site_pos: tuple[float, float, float]) -> str:
        w = self._frag().world
        if not w:
            return ""
        return f'<frame pos="{" ".join(f"{v:.12g}" for v in site_pos)}">{w}</frame>'

    def extra_xml(self) -> str:
        return self._frag().extra

    def _matrix(self) -> np.ndarray:
        """Composite rigid inertia (6, 6) of the mounted bodies about the FTS origin, joints
        locked, over x, y, z, rx, ry, rz (kg, kg·m)."""
        return _composite(self.cfg.file, load_fragment(self.cfg.file))

    def interface_matrices(self) -> tuple[list[list[float]], list[list[float]]]:
        idx = [ALL_DOFS.index(d) for d in self.interface_dofs(self.cfg)]
        M = self._matrix()[np.ix_(idx, idx)]
        return np.zeros_like(M).tolist(), M.tolist()

    def damping_matrix(self) -> list[list[float]]:
        n = len(self.interface_dofs(self.cfg))
        return [[0.0] * n for _ in range(n)]

    def meta(self) -> dict[str, Any]:
        k_exp, m_exp = self.interface_matrices()
        return {"kind": self.kind, "file": self.cfg.file,
                "m_exp": float(self._matrix()[0, 0]), "k_exp": k_exp, "m_exp_matrix": m_exp,
                "d_exp": 0.0, "c_exp": self.damping_matrix(), "h0": None,
                "k_contact": None, "d_contact": None,
                "model": NO_TWIN}

    @classmethod
    def batch_key(cls, settings: Mapping[str, Any]) -> Hashable:
        return (*super().batch_key(settings), str(settings.get("experiment.file", "")),
                tuple(settings.get("experiment.dofs", ())))


def _composite(path: str, frag: _Fragment) -> np.ndarray:
    import mujoco

    xml = (f'<mujoco><compiler angle="radian"/><worldbody>'
           f'<body name="mount"><freejoint/><inertial pos="0 0 0" mass="1" '
           f'diaginertia="1 1 1"/>{frag.mounted}</body>{frag.world}</worldbody>'
           f'{frag.extra}</mujoco>')
    try:
        model = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:
        msg = "; ".join(s.strip() for s in str(exc).splitlines() if s.strip())
        raise ConfigError("experiment.file", path, f"MuJoCo rejects the part: {msg}") from None
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    mount = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "mount")
    M = np.zeros((6, 6))
    for b in range(model.nbody):
        if b == mount or not _below(model, b, mount):
            continue
        m = float(model.body_mass[b])
        c = data.xipos[b]
        R = data.ximat[b].reshape(3, 3)
        Ic = R @ np.diag(model.body_inertia[b]) @ R.T
        S = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
        M[:3, :3] += m * np.eye(3)
        M[:3, 3:] -= m * S
        M[3:, :3] += m * S
        M[3:, 3:] += Ic - m * S @ S
    return M


def _below(model: Any, b: int, root: int) -> bool:
    while b > 0:
        if b == root:
            return True
        b = int(model.body_parentid[b])
    return False


def fragment_path(file: str, folder: str | Path) -> str:
    """``file`` resolved against ``folder`` (the scene file's) when relative."""
    f = Path(file).expanduser()
    return str(f if f.is_absolute() else Path(folder).resolve() / f)

"""A numerical substructure from OpenSees: the user's finite-element model, stepped in the loop.

``[numerical] kind = "opensees"``: ``model`` names a Python file (relative to the scene file)
with a function ``build(ops)`` that creates the model with the openseespy commands it is
given (nodes, masses, elements, materials, damping; no analysis, no loads). The scene maps
each interface DOF (``dofs``, x … rz) to one model DOF, ``interface = [[node, dof], ...]``
(OpenSees numbering, dof 1…ndf). Force coupling: every interface step imposes −F'_m at the
interface DOFs through one ``Plain`` pattern per interface DOF whose unit nodal load is
scaled by a ``parameter`` (``updateParameter`` each step, no domain change), advances one
``analyze(1, ΔT)`` with the OpenSees integrator the scene names (``Newmark``, ``HHT``, …, its
arguments ``integrator_args``) and reads back the interface displacement and velocity
(``z``, ``ż``). The excitation is applied inside the model: ``ground`` as a
``UniformExcitation`` pattern along model DOF ``ground_dof`` (relative displacements), or
``force`` as a ``Path`` time series at ``loads = [[node, dof, factor], ...]``.

The load of the interface step acts at t_{n+1}: held at F'_m(t_n) in the loop, and F_{n+1}
itself in the reference (implicit, as the reference's interface iteration needs). One
OpenSees domain per process: a group of tests holds one test (``max_batch = 1``); sweeps
run their tests in worker processes, each with its own domain. A failed ``analyze`` (no
convergence) raises :class:`~rths3d.errors.NumericalFailure`: the loop stops the test
safely and keeps its record. ``get_state``/``set_state`` (the reference's rollback) restore
every node's displacement, velocity and acceleration and the time and rebuild the analysis
(``domainChange``): exact for models whose state is their nodes' (elastic elements); for
path-dependent materials a rolled-back pass has been committed, so their reference
(``numerical.reference = "predict"``, the default) takes one committed step per interface
step instead (:func:`rths3d.reference.couple_predicted`; docs/opensees.md).
"""

from __future__ import annotations

import atexit
import importlib.util
import math
import os
import sys
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config import NumericalConfig
from ..errors import ConfigError, NumericalFailure
from ..transfer.base import RecordSignal
from .excitation import excitation_signal

if TYPE_CHECKING:
    from ..config import Scene

INTEGRATORS = ("Newmark", "HHT", "GeneralizedAlpha", "TRBDF2", "ExplicitDifference")
"""OpenSees transient integrators the scene may name (``numerical.integrator``)."""
DEFAULT_ARGS = {"Newmark": (0.5, 0.25), "HHT": (1.0,), "GeneralizedAlpha": (1.0, 1.0),
                "TRBDF2": (), "ExplicitDifference": ()}
ALGORITHMS = ("Linear", "LinearFactorOnce", "Newton", "ModifiedNewton", "KrylovNewton")
"""Solution algorithms (``numerical.algorithm``); ``LinearFactorOnce``: ``Linear
-factorOnce`` (linear models: the cheapest step)."""
KEYS = ("kind", "model", "interface", "integrator", "integrator_args", "algorithm", "loads",
        "ground_dof", "tol", "max_iter", "elements", "reference")
REFERENCES = ("predict", "iterate")
"""How the reference couples the model (``numerical.reference``): ``predict`` (default: one
committed step per interface step, the part iterated against the step's interface
flexibility; right for any model, materials with a history included) or ``iterate`` (the
model rolled back to the step's start for every interface pass through its nodes' state:
exact for elastic models only — a yielding material's history is not rolled back)."""
_TAG = 970000
"""First tag of the time series, patterns and parameters rths3d adds to the user's model."""


def opensees_module() -> Any:
    """``openseespy.opensees`` (a ConfigError on one line when it cannot be imported)."""
    try:
        import openseespy.opensees as ops
    except ImportError as exc:  # the package, or the BLAS/LAPACK it loads
        raise ConfigError("numerical.kind", "opensees",
                          f"needs openseespy (pip install 'openseespy>=3.7.1,<3.9'): "
                          f"{exc}") from None
    if not getattr(opensees_module, "quiet", False):
        # openseespy writes "Process 0 Terminating" to stderr when the process ends: keep a
        # command's error on one line
        atexit.register(_silence_stderr)
        opensees_module.quiet = True  # type: ignore[attr-defined]
    return ops


def _silence_stderr() -> None:
    try:
        sys.stderr.flush()
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, 2)
    except OSError:
        pass


def _pairs(field: str, value: Any, width: int) -> tuple[tuple[float, ...], ...]:
    if not isinstance(value, list | tuple) or not all(
            isinstance(r, list | tuple) and len(r) == width for r in value):
        what = "node, dof, factor" if width == 3 else "node, dof"
        raise ConfigError(field, value, f"must be a list of [{what}] entries")
    out = []
    for i, row in enumerate(value):
        for j, v in enumerate(row):
            ok = isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            if not ok or (j < 2 and (int(v) != v or v < 1)):
                raise ConfigError(f"{field}[{i}]", list(row), "node tags and DOFs are integers "
                                  ">= 1, factors finite numbers")
        out.append(tuple(float(v) if j == 2 else int(v) for j, v in enumerate(row)))
    return tuple(out)


def opensees_config(sec: Mapping[str, Any], dofs: Sequence[str], source: str) -> NumericalConfig:
    """The ``[numerical]`` table of ``kind = "opensees"`` validated (the model file is
    resolved relative to the scene file ``source``; it is built, and its nodes checked, when
    the test starts)."""
    for key in sec:
        if key not in KEYS:
            raise ConfigError(f"numerical.{key}", sec[key], "unknown field for kind = "
                              f"'opensees' (known: {', '.join(KEYS)})")
    model = sec.get("model")
    if not isinstance(model, str) or not model:
        raise ConfigError("numerical.model", model, "required: the Python file with build(ops)")
    path = Path(model)
    if not path.is_absolute():
        path = (Path(source).parent if source else Path.cwd()) / path
    path = path.resolve()
    if not path.is_file():
        raise ConfigError("numerical.model", model, f"file not found ({path})")
    interface = _pairs("numerical.interface", sec.get("interface"), 2)
    if len(interface) != len(dofs):
        raise ConfigError("numerical.interface", sec.get("interface"),
                          f"needs one [node, dof] per interface DOF {list(dofs)}")
    if len(set(interface)) != len(interface):
        raise ConfigError("numerical.interface", sec.get("interface"), "entries must differ")
    integ = sec.get("integrator", "Newmark")
    if integ not in INTEGRATORS:
        raise ConfigError("numerical.integrator", integ, f"for kind = 'opensees' one of "
                          f"{', '.join(INTEGRATORS)}")
    args = sec.get("integrator_args", list(DEFAULT_ARGS[integ]))
    if not isinstance(args, list | tuple) or not all(
            isinstance(a, int | float) and not isinstance(a, bool) and math.isfinite(a)
            for a in args):
        raise ConfigError("numerical.integrator_args", args, "must be a list of numbers")
    algo = sec.get("algorithm", "Newton")
    if algo not in ALGORITHMS:
        raise ConfigError("numerical.algorithm", algo, f"must be one of {', '.join(ALGORITHMS)}")
    loads = _pairs("numerical.loads", sec.get("loads", []), 3)
    gdof = sec.get("ground_dof", 1)
    if isinstance(gdof, bool) or not isinstance(gdof, int) or gdof < 1:
        raise ConfigError("numerical.ground_dof", gdof, "must be an integer >= 1")
    tol = sec.get("tol", 1e-12)
    if isinstance(tol, bool) or not isinstance(tol, int | float) or not tol > 0:
        raise ConfigError("numerical.tol", tol, "must be > 0 m (displacement increment)")
    it = sec.get("max_iter", 25)
    if isinstance(it, bool) or not isinstance(it, int) or not 1 <= it <= 1000:
        raise ConfigError("numerical.max_iter", it, "must be an integer in 1…1000")
    elements = sec.get("elements", [])
    if not isinstance(elements, list | tuple) or not all(
            isinstance(e, int) and not isinstance(e, bool) and e >= 1 for e in elements):
        raise ConfigError("numerical.elements", elements, "must be a list of element tags "
                          "(integers >= 1) whose force and deformation the record keeps")
    ref = sec.get("reference", "predict")
    if ref not in REFERENCES:
        raise ConfigError("numerical.reference", ref, f"must be one of {', '.join(REFERENCES)}")
    n = len(dofs)
    eye = tuple(tuple(1.0 if i == j else 0.0 for j in range(n)) for i in range(n))
    zero = tuple((0.0,) * n for _ in range(n))
    return NumericalConfig(M=eye, C=zero, K=zero, gamma=eye, integrator=integ, kind="opensees",
                           model=str(path), interface=interface,  # type: ignore[arg-type]
                           integrator_args=tuple(float(a) for a in args), algorithm=algo,
                           loads=loads, ground_dof=gdof, tol=float(tol), max_iter=it,
                           elements=tuple(elements), reference=ref)


def opensees_section(nm: NumericalConfig) -> dict[str, Any]:
    """The ``[numerical]`` table of an OpenSees substructure (inverse of
    :func:`opensees_config`)."""
    return {"kind": "opensees", "model": nm.model, "interface": [list(p) for p in nm.interface],
            "integrator": nm.integrator, "integrator_args": list(nm.integrator_args),
            "algorithm": nm.algorithm, "loads": [list(p) for p in nm.loads],
            "ground_dof": nm.ground_dof, "tol": nm.tol, "max_iter": nm.max_iter,
            "elements": list(nm.elements), "reference": nm.reference}


def load_build(path: str, field: str = "numerical.model") -> Any:
    """The ``build(ops)`` function of the model file ``path`` (a ConfigError naming ``field``
    on one line: not a Python file, a syntax error with its line, a failed import, no
    ``build``)."""
    spec = importlib.util.spec_from_file_location(f"_rths3d_opensees_{abs(hash(path))}", path)
    if spec is None or spec.loader is None:
        raise ConfigError(field, path, "not a Python file")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except SyntaxError as exc:
        raise ConfigError(field, path, f"syntax error at line {exc.lineno}: {exc.msg}") from None
    except Exception as exc:  # the user's module: anything it raises, on one line
        raise ConfigError(field, path, f"failed to load: {type(exc).__name__}: {exc}") from None
    build = getattr(module, "build", None)
    if not callable(build):
        raise ConfigError(field, path, "defines no function build(ops)")
    return build



def assembled_matrix(ops, m: float, c: float, k: float) -> np.ndarray:
    """m·M + c·C + k·K of the model ``ops`` holds, as OpenSees assembles it at rest
    (``GimmeMCK``; equation numbering of the ``Plain`` numberer). Leaves an analysis
    defined: wipe it before the next."""
    ops.wipeAnalysis()
    ops.constraints("Transformation")
    ops.numberer("Plain")
    ops.system("FullGeneral")
    ops.algorithm("Linear")
    ops.integrator("GimmeMCK", m, c, k)
    ops.analysis("Transient")
    ops.analyze(1, 0.0)
    size = ops.systemSize()
    return np.array(ops.printA("-ret"), float).reshape(size, size)

class OpenSeesSubstructure:
    """One test's OpenSees model behind the :class:`~rths3d.numerical.NumericalSubstructure`
    protocol (see the module docstring). ``z``, ``zdot``, ``x`` (1, n_if): the interface
    DOFs' displacement (m, rad) and velocity; ``p`` (1, N+1, n_if): the excitation's load
    where it acts on an interface DOF (N, N·m), else 0."""

    max_batch = 1
    """Tests per group: one OpenSees domain per process."""
    config = staticmethod(opensees_config)
    section = staticmethod(opensees_section)

    def __init__(self, scene: Scene):
        nm = scene.numerical
        self.scene, self.cfg = scene, nm
        self.dt = float(scene.dt)
        self.n_if = self.n = len(scene.dofs)
        self.gamma = np.eye(self.n_if)
        self.rolls_back = nm.reference == "iterate"
        """Whether the reference may roll the model back (see :data:`REFERENCES`)."""
        self.method = f"opensees {nm.integrator} {' '.join(f'{a:g}' for a in nm.integrator_args)}"
        self.z = np.zeros((1, self.n_if))
        self.zdot = np.zeros((1, self.n_if))
        self.x = np.zeros((1, self.n_if))
        t = np.arange(scene.n_steps + 1) * self.dt
        exc = scene.excitation
        self._signal = excitation_signal(exc, t, scene.experiment.h0)[0] \
            if exc.kind != "none" else np.zeros_like(t)
        self.p = np.zeros((1, len(t), self.n_if))
        if exc.kind == "force":
            for node, dof, factor in nm.loads:
                for i, (inode, idof) in enumerate(nm.interface):
                    if (inode, idof) == (node, dof):
                        self.p[0, :, i] += factor * self._signal
        self._log = ""
        self.ops = opensees_module()
        # the record's signals ele_force.<tag> (N or N·m) and ele_deformation.<tag> (m or
        # rad): each listed element's first basic force and deformation (a zeroLength
        # storey: its shear and drift)
        labels = tuple(str(e) for e in nm.elements)
        self._ele = np.zeros((1, len(labels)))
        self._eld = np.zeros((1, len(labels)))
        self.signals = (RecordSignal("ele_force", labels, self._ele),
                        RecordSignal("ele_deformation", labels, self._eld)) if labels else ()
        self._build()

    @classmethod
    def from_scenes(cls, scenes: Sequence[Scene], method: str | None = None
                    ) -> OpenSeesSubstructure:
        """The substructure of one scene (a group of OpenSees tests holds one)."""
        if len(scenes) != 1:
            raise ValueError(f"an OpenSees substructure steps one test, {len(scenes)} given")
        return cls(scenes[0])

    # ------------------------------------------------------------------ building
    def _fail(self, what: str) -> ConfigError:
        return ConfigError("numerical.model", self.cfg.model, f"{what}{self._opensees_said()}")

    def _opensees_said(self) -> str:
        try:
            lines = [s.strip() for s in Path(self._log).read_text(errors="replace").splitlines()
                     if s.strip()]
        except OSError:
            return ""
        return f"; OpenSees: {lines[-1][:200]}" if lines else ""

    def _load_model(self) -> Any:
        return load_build(self.cfg.model)

    def _build(self) -> None:
        ops, nm = self.ops, self.cfg
        build = self._load_model()
        ops.wipe()
        if not self._log:
            fd, self._log = tempfile.mkstemp(prefix="rths3d-opensees-", suffix=".log")
            os.close(fd)
        ops.logFile(self._log, "-noEcho")  # OpenSees' messages: read back into our errors
        try:
            build(ops)
        except Exception as exc:  # the user's model (OpenSeesError among others)
            raise self._fail(f"build(ops) failed: {type(exc).__name__}: {exc}") from None
        nodes = set(ops.getNodeTags())
        for field, entries in (("interface", nm.interface), ("loads", nm.loads)):
            for i, entry in enumerate(entries):
                node, dof = int(entry[0]), int(entry[1])
                if node not in nodes:
                    raise ConfigError(f"numerical.{field}[{i}]", list(entry),
                                      f"node {node} does not exist in {Path(nm.model).name} "
                                      f"({len(nodes)} nodes, tags {min(nodes, default=0)}…"
                                      f"{max(nodes, default=0)})")
                ndf = len(ops.nodeDisp(node))
                if dof > ndf:
                    raise ConfigError(f"numerical.{field}[{i}]", list(entry),
                                      f"node {node} has {ndf} DOFs")
                if field == "interface" and node in ops.getFixedNodes() and \
                        dof in ops.getFixedDOFs(node):
                    raise ConfigError(f"numerical.{field}[{i}]", list(entry),
                                      "is fixed: an interface DOF must be free")
        tags = set(ops.getEleTags())
        for i, e in enumerate(nm.elements):
            if e not in tags:
                raise ConfigError(f"numerical.elements[{i}]", e, f"element {e} does not exist "
                                  f"in {Path(nm.model).name} ({len(tags)} elements)")
        self.nodes = sorted(nodes)
        self.ndf = {n: len(ops.nodeDisp(n)) for n in self.nodes}
        self._linearise()
        self._analysis()

    def _linearise(self) -> None:
        """M, C, K of the model at rest (OpenSees ``GimmeMCK``) and the equation of each
        interface DOF: the τ-ratios' and delay margin's linear model."""
        ops = self.ops
        mats = []
        eqs: list[int] = []
        for m, c, k in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
            mats.append(assembled_matrix(ops, m, c, k))
            if not eqs:
                eqs = [int(ops.nodeDOFs(node)[dof - 1]) for node, dof in self.cfg.interface]
        ops.wipeAnalysis()
        ops.setTime(0.0)
        self.eqs = eqs
        self._M, self._C, self._K = mats

    def linearised(self, test: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                 np.ndarray]:
        """(M, C, K, Γ) of the model at rest, the DOFs without mass (and not at the
        interface) condensed statically: the record's ω_0,NUM, ω_0,DYN and delay margin."""
        M, C, K = self._M, self._C, self._K
        n = M.shape[0]
        G = np.zeros((n, self.n_if))
        for i, e in enumerate(self.eqs):
            if e >= 0:
                G[e, i] = 1.0
        keep = (np.abs(M).sum(axis=1) > 0) | (G.sum(axis=1) > 0)
        if keep.all():
            return M, C, K, G
        a, b = np.flatnonzero(keep), np.flatnonzero(~keep)
        T = -np.linalg.solve(K[np.ix_(b, b)], K[np.ix_(b, a)])
        red = lambda A: A[np.ix_(a, a)] + A[np.ix_(a, b)] @ T  # noqa: E731
        return M[np.ix_(a, a)], red(C), red(K), G[a]

    def step_flexibility(self) -> np.ndarray:
        """Φ = ∂z_{n+1}/∂F'_m (n_if × n_if, m/N) of one step of the model at rest: −Γᵀ K̂⁻¹ Γ,
        K̂ = K + γ/(βΔt) C + M/(βΔt²) (Newmark's effective stiffness; the other integrators
        with γ ½, β ¼)."""
        g, b = (self.cfg.integrator_args[:2] if self.cfg.integrator == "Newmark"
                else (0.5, 0.25))
        dt = self.dt
        Kh = self._K + g / (b * dt) * self._C + self._M / (b * dt**2)
        G = np.zeros((Kh.shape[0], self.n_if))
        for i, e in enumerate(self.eqs):
            G[e, i] = 1.0
        return -G.T @ np.linalg.solve(Kh, G)

    def _analysis(self) -> None:
        ops, nm = self.ops, self.cfg
        tag = _TAG
        self._pids = []
        for i, (node, dof) in enumerate(nm.interface):
            unit = [0.0] * self.ndf[node]
            unit[dof - 1] = 1.0
            ops.timeSeries("Constant", tag + i)
            ops.pattern("Plain", tag + i, tag + i)
            ops.load(node, *unit)
            ops.parameter(tag + i, "loadPattern", tag + i, "loadAtNode", node, dof)
            self._pids.append(tag + i)
        exc = self.scene.excitation
        ts = tag + 50
        if exc.kind in ("force", "ground"):
            ops.timeSeries("Path", ts, "-dt", self.dt, "-values", *self._signal.tolist())
        if exc.kind == "force":
            if not nm.loads:
                raise ConfigError("numerical.loads", None, "required for a force excitation "
                                  "of an OpenSees model: [[node, dof, factor], ...]")
            ops.pattern("Plain", ts, ts)
            for node, dof, factor in nm.loads:
                vec = [0.0] * self.ndf[int(node)]
                vec[int(dof) - 1] = float(factor)
                ops.load(int(node), *vec)
        elif exc.kind == "ground":
            ops.pattern("UniformExcitation", ts, nm.ground_dof, "-accel", ts)
        elif exc.kind != "none":
            raise ConfigError("excitation.kind", exc.kind, "an OpenSees model takes 'none', "
                              "'force' or 'ground'")
        ops.constraints("Transformation")
        ops.numberer("RCM")
        ops.system("BandGen")
        ops.test("NormDispIncr", nm.tol, nm.max_iter)
        if nm.algorithm == "LinearFactorOnce":
            ops.algorithm("Linear", "-factorOnce")
        else:
            ops.algorithm(nm.algorithm)
        try:
            ops.integrator(nm.integrator, *nm.integrator_args)
        except Exception as exc:  # wrong arguments for the integrator
            raise ConfigError("numerical.integrator_args", list(nm.integrator_args),
                              f"rejected by OpenSees' {nm.integrator}: {exc}"
                              f"{self._opensees_said()}") from None
        ops.analysis("Transient")
        # per step: bound functions and plain tuples, nothing looked up by name
        self._analyze, self._update = ops.analyze, ops.updateParameter
        self._disp, self._vel = ops.nodeDisp, ops.nodeVel
        self._bforce, self._bdef = ops.basicForce, ops.basicDeformation
        self._iface = tuple((int(node), int(dof)) for node, dof in nm.interface)
        self._elements = tuple(int(e) for e in nm.elements)
        self._halted = False

    # ------------------------------------------------------------------ protocol
    def reset(self) -> None:
        """Back to rest at t = 0 (the model rebuilt when it has been stepped)."""
        if self.ops.getTime() != 0.0 or self._halted:
            self._build()
        self.z[:] = 0.0
        self.zdot[:] = 0.0
        self.x[:] = 0.0

    def step(self, n: int, f_n: np.ndarray, f_next: np.ndarray | None = None) -> None:
        """t_n → t_{n+1} with −F'_m at the interface DOFs (held: ``f_n``; the reference's
        implicit step: ``f_next``); raises NumericalFailure when ``analyze`` fails."""
        if self._halted:
            return
        f = f_n if f_next is None else f_next
        upd = self._update
        for i, pid in enumerate(self._pids):
            upd(pid, -float(f[0, i]))
        if self._analyze(1, self.dt) != 0:
            self._halted = True
            raise NumericalFailure(0, f"the OpenSees model did not converge at t = "
                                   f"{(n + 1) * self.dt:.4f} s ({self.cfg.algorithm}, "
                                   f"{self.cfg.max_iter} iterations, tol {self.cfg.tol:g})"
                                   f"{self._opensees_said()}")
        disp, vel, z, zd = self._disp, self._vel, self.z, self.zdot
        for i, (node, dof) in enumerate(self._iface):
            z[0, i] = disp(node, dof)
            zd[0, i] = vel(node, dof)
        self.x[0] = z[0]
        for i, e in enumerate(self._elements):
            self._ele[0, i] = self._bforce(e)[0]
            self._eld[0, i] = self._bdef(e)[0]

    def get_state(self) -> np.ndarray:
        """Every node's displacement, velocity and acceleration and the time."""
        ops = self.ops
        out = [ops.getTime()]
        for node in self.nodes:
            out += ops.nodeDisp(node) + ops.nodeVel(node) + ops.nodeAccel(node)
        return np.array(out)

    def set_state(self, state: np.ndarray) -> None:
        """Restore :meth:`get_state` (committed) and renew the analysis (``domainChange``)."""
        ops = self.ops
        j = 1
        for node in self.nodes:
            nd = self.ndf[node]
            for d in range(nd):
                ops.setNodeDisp(node, d + 1, float(state[j + d]), "-commit")
                ops.setNodeVel(node, d + 1, float(state[j + nd + d]), "-commit")
                ops.setNodeAccel(node, d + 1, float(state[j + 2 * nd + d]), "-commit")
            j += 3 * nd
        ops.setTime(float(state[0]))
        ops.domainChange()
        if self.cfg.algorithm == "LinearFactorOnce":  # the renewed system is not factored:
            ops.algorithm("Linear")  # rolled-back passes (the reference) factor each step
        for i, (node, dof) in enumerate(self._iface):
            self.z[0, i] = ops.nodeDisp(node, dof)
            self.zdot[0, i] = ops.nodeVel(node, dof)
        self.x[0] = self.z[0]
        self._halted = False

    def halt(self, k: int) -> None:
        """The test stopped: the model is no longer stepped (z, ż held at 0)."""
        self._halted = True
        self.z[:] = 0.0
        self.zdot[:] = 0.0
        self.x[:] = 0.0

    def compiled(self) -> None:
        """Stepped from Python (OpenSees): no compiled kernel."""
        return None

    def close(self) -> None:
        """Wipe the domain and remove the OpenSees log."""
        self.ops.wipe()
        if self._log:
            Path(self._log).unlink(missing_ok=True)
            self._log = ""

    def __del__(self) -> None:
        log = getattr(self, "_log", "")
        if log:
            Path(log).unlink(missing_ok=True)

    def meta(self, test: int = 0) -> dict:
        """Record metadata ``numerical``: the model file, its interface and analysis."""
        nm = self.cfg
        M, _, K, _ = self.linearised()
        try:
            import scipy.linalg

            w2 = scipy.linalg.eigh(K, M, eigvals_only=True)
            w = float(np.sqrt(max(float(w2.max()), 0.0)))
        except (ValueError, np.linalg.LinAlgError):
            w = math.nan
        return {"kind": "opensees", "model": nm.model,
                "interface": [list(p) for p in nm.interface], "integrator": self.method,
                "algorithm": nm.algorithm, "equations": int(self._M.shape[0]),
                "omega_max": w, "gamma": self.gamma.tolist()}

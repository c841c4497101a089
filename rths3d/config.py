"""The configuration of one vRTHS test: frozen dataclasses, SI units (m, rad, s, kg, N, N·m).

:class:`Scene` holds the numerical substructure, its excitation, the experimental part, the
transfer system, the force sensor and the safety limits. This module only describes; reading
and validating TOML scenes is :mod:`rths3d.scene`, which re-exports these classes. Components
(experimental parts, transfer systems) import their configuration from here, so that the
scene parser may ask them what they accept without an import circle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import TYPE_CHECKING, Any

from .errors import ConfigError

if TYPE_CHECKING:  # the geometry is built by rths3d.scene; config only describes
    from .platform.geometry import StewartGeometry

__all__ = [
    "COMPENSATE",
    "COMP_INIT",
    "ControllerConfig",
    "EffectConfig",
    "ExcitationConfig",
    "ExperimentConfig",
    "Matrix",
    "NetworkConfig",
    "NumericalConfig",
    "PlatformDescription",
    "SafetyConfig",
    "SafetyLimits",
    "Scene",
    "SensorConfig",
    "TransferConfig",
]

Matrix = tuple[tuple[float, ...], ...]

COMPENSATE = ("interface", "legs")
"""Where a compensator acts (``transfer.compensate``): per interface DOF, or per leg."""
COMP_INIT = ("predicted", "given")
"""How adaptive and model-based compensators start (``transfer.comp_init``)."""


@dataclass(frozen=True)
class NumericalConfig:
    """Linear numerical substructure ``M ẍ + C ẋ + K x = p(t) − Γ F'_m`` (SI).

    ``M`` (kg or kg·m²), ``C`` (N·s/m), ``K`` (N/m) are n×n; ``gamma`` (Γ) is n × n_if and
    maps the interface DOFs (``Scene.dofs``) to numerical DOFs: the commanded interface
    displacement is ``z = Γᵀ x``. ``integrator`` is ``exact`` (exact discretisation of the
    state space with the force held over a step, unconditionally stable on its own) or
    ``central_difference`` (explicit, stable for ω_max ΔT < 2, checked with the part's
    spring added). The coupled loop (force held over a step) is only conditionally stable.

    ``kind``: ``linear`` (these matrices) or ``opensees`` (an OpenSees model: ``model`` file,
    ``interface`` [node, dof] per interface DOF, the OpenSees ``integrator`` and its
    ``integrator_args``, ``algorithm``, force ``loads`` [node, dof, factor], ``ground_dof``,
    convergence ``tol`` (m) and ``max_iter``; M, C, K, Γ are then placeholders, see
    :mod:`rths3d.numerical.opensees`).
    """

    M: Matrix
    C: Matrix
    K: Matrix
    gamma: Matrix
    integrator: str = "exact"
    kind: str = "linear"
    model: str = ""
    interface: tuple[tuple[int, int], ...] = ()
    integrator_args: tuple[float, ...] = ()
    algorithm: str = "Newton"
    loads: tuple[tuple[float, ...], ...] = ()
    ground_dof: int = 1
    tol: float = 1e-12
    max_iter: int = 25
    elements: tuple[int, ...] = ()
    reference: str = "predict"

    @property
    def n(self) -> int:
        """Number of numerical DOFs."""
        return len(self.M)

    @property
    def has_matrices(self) -> bool:
        """Whether M, C, K are the substructure itself (no ``model`` file): its m, c, k may
        be overridden and shown as parameters; an OpenSees model's live in its file."""
        return not self.model


NUMERICAL_EXTRA = ("kind", "model", "interface", "integrator_args", "algorithm", "loads",
                   "ground_dof", "tol", "max_iter", "elements", "reference")
"""Fields of :class:`NumericalConfig` that only another ``kind`` than ``linear`` uses (not in
a linear scene's parameters)."""


@dataclass(frozen=True)
class ExcitationConfig:
    """Excitation of the numerical substructure.

    ``kind``: ``none``; ``force`` (p = a(t)·direction, N); ``support`` (support motion u(t):
    p = k_s u + c_s u̇ with k_s = K·1, c_s = C·1, the paper's suspension cosine z_d);
    ``ground`` (ground acceleration ü_g: p = −M·1·ü_g). The signal a(t) / u(t) / ü_g(t) is
    ``sine`` (amplitude·sin(2π f t + phase)), ``raised_cosine`` (the paper's z_d =
    peak/2·(1 − cos 2π f_d t), peak = ``amplitude`` or h_0 + ``overtravel`` Δz_d), ``file``
    (CSV with columns ``t`` and ``column``) or ``array`` (``times``, ``values``); recorded
    signals are interpolated linearly and scaled by ``scale``.
    """

    kind: str = "none"
    signal: str = "sine"
    amplitude: float = 0.0
    frequency: float = 0.0
    phase: float = 0.0
    overtravel: float = float("nan")
    file: str = ""
    column: str = "value"
    scale: float = 1.0
    times: tuple[float, ...] = ()
    values: tuple[float, ...] = ()
    direction: tuple[float, ...] = ()


@dataclass(frozen=True)
class ExperimentConfig:
    """Experimental part mounted on the force-torque sensor (paper Figs. 4 and 5).

    ``contact``: mass ``m`` (kg) on a spring ``k`` (N/m, damper ``d`` N·s/m) above the FTS,
    hitting a world-fixed surface ``h0`` (m) above its static equilibrium; penalty contact
    with stiffness ``k_contact`` (N/m) and damping ``d_contact`` (N·s/m).
    ``linear``: the same part without the surface (Fig. 5).
    ``multidof``: a rigid bar (mass ``m``, pitch inertia ``inertia`` kg·m²) on a heave
    spring ``k`` and a pitch spring ``k_rot`` (N·m/rad) whose end (``arm`` m from the axis)
    hits the surface: interface DOFs z and ry.
    ``rigid``: a rigid payload of mass ``m`` with its centre of mass ``com`` (x, y, z from
    the FTS origin, sensor frame, m; empty: 0.02 m above it on the axis) and its inertia
    about the centre of mass, ``inertia`` (kg·m², the same about each axis) or
    ``inertia_tensor`` (Ixx, Iyy, Izz, Ixy, Ixz, Iyz, kg·m²; the scene's ``inertia = [...]``).
    ``mjcf``: the user's MuJoCo fragment ``file`` (bodies mounted on the FTS site, bodies
    named ``world_*`` fixed to the world), tested through the interface DOFs ``dofs``.
    ``substeps``: physics steps per interface step for the specimen models.
    """

    kind: str = "contact"
    m: float = 0.38
    k: float = 8650.0
    d: float = 0.0
    h0: float = 0.005
    k_contact: float = 1.0e5
    d_contact: float = 40.0
    inertia: float = 2.0e-3
    k_rot: float = 400.0
    d_rot: float = 0.0
    arm: float = 0.1
    substeps: int = 4
    com: tuple[float, ...] = ()
    inertia_tensor: tuple[float, ...] = ()
    file: str = ""
    dofs: tuple[str, ...] = ()


EXPERIMENT_EXTRA = ("com", "inertia_tensor", "file", "dofs")
"""Fields of :class:`ExperimentConfig` written to a scene only when given (empty by default),
so that a scene that does not use them reads and writes as before."""


HOLD = ("ramp", "zoh")
"""Set-point holds over an interface step: first-order (ramp) or zero-order."""
SAMPLE = ("end", "start")
"""Sampling instants of the bench's channels within an interface step."""
FEEDFORWARD = ("backward", "central", "none")
"""Difference forms of the velocity feed-forward."""
LAG = ("setpoint", "servo")
"""Where the leg servo's first-order lag (``timeconst``) sits: a digital filter of the
set-point at the interface rate before the hold (``setpoint``, today's bench), or continuous
dynamics of the servo after the hold, integrated with the physics (``servo``)."""
GRAVITY = ("nominal", "measured", "none")
"""Sources of the gravity compensation: the nominal model, the bench's own holding forces at
rest (measured), or none."""
SERVO_RANGES = {"kp": (0.0, 1e9, "N/m"), "kv": (0.0, 1e7, "N·s/m"),
                "timeconst": (0.0, 1.0, "s"), "delay": (0.0, 0.5, "s"),
                "valve_hz": (0.0, 1e4, "Hz"), "valve_damping": (0.0, 10.0, "1")}
"""The leg servo's numbers a scene's ``[controller]`` table states (kept in
:class:`TransferConfig`, where their defaults are): (lower, upper limit, unit) each; ``kp``
must exceed its lower limit, the others may equal it. ``valve_hz`` and ``valve_damping``:
the servo-valve's second-order response after the hold, natural frequency (Hz; 0: none,
today's bench) and damping ratio."""
VALVE_KEYS = ("valve_hz", "valve_damping")
"""The servo-valve's keys: written to a scene only when it has a valve (``valve_hz > 0``),
so that a scene without one reads and writes as before."""
SERVO_CONVENTIONS = {"hold": HOLD, "sample": SAMPLE, "feedforward": FEEDFORWARD,
                     "gravity": GRAVITY, "lag": LAG}
"""The ``[controller]`` conventions and their allowed values (defaults in
:class:`ControllerConfig`)."""
CONTROLLER_KEYS = (*SERVO_RANGES, *SERVO_CONVENTIONS)
"""Every key of a scene's ``[controller]`` table."""


def check_servo_number(field_name: str, name: str, value: Any) -> float:
    """The one validation of a leg servo number ``name`` (``kp``, ``kv``, ``timeconst``,
    ``delay``; :data:`SERVO_RANGES`) wherever it is given — a scene's ``[controller]`` or
    ``[transfer]`` table, a platform's ``ActuatorConfig``, the command line: ``value`` as a
    float, or a :class:`~rths3d.errors.ConfigError` naming ``field_name``, the value and the
    limits."""
    lo, hi, unit = SERVO_RANGES[name]
    ok = not isinstance(value, bool) and isinstance(value, int | float) and \
        math.isfinite(value) and (value > lo if name == "kp" else value >= lo) and value <= hi
    if not ok:
        raise ConfigError(field_name, value, f"must be {'>' if name == 'kp' else '>='} {lo:g}"
                          f" and <= {hi:g} {unit}")
    return float(value)


@dataclass(frozen=True)
class ControllerConfig:
    """The leg controller's conventions (the scene's ``[controller]`` table).

    ``hold``: the set-point over an interface step, ``ramp`` (first-order hold, today's
    bench) or ``zoh`` (held from the start of the step); ``sample``: when the bench samples
    its channels, at the ``end`` of the interface step (today's) or at its ``start``;
    ``feedforward``: the velocity feed-forward's difference form, ``backward`` (today's),
    ``central`` or ``none``; ``gravity``: gravity compensation from the ``nominal`` model
    (today's), from the holding forces ``measured`` on the bench at rest, or ``none``;
    ``lag``: where the servo's first-order lag ``timeconst`` sits (:data:`LAG`): a digital
    filter of the set-point before the hold (``setpoint``, today's) or continuous dynamics
    after it (``servo``, a valve or amplifier; integrated with the physics). The
    servo's gains, lag, transport delay and valve (``kp``, ``kv``, ``timeconst``, ``delay``,
    ``valve_hz``, ``valve_damping`` of ``[controller]``) are kept in :class:`TransferConfig`
    (``transfer.kp`` …), where every consumer reads them. ``given``: the keys the scene's
    ``[controller]`` table set (``rths3d diagnose`` names them).
    """

    hold: str = "ramp"
    sample: str = "end"
    feedforward: str = "backward"
    gravity: str = "nominal"
    lag: str = "setpoint"
    given: tuple[str, ...] = ()


@dataclass(frozen=True)
class PlatformDescription:
    """The Stewart platform of the bench (the scene's ``[platform]`` table), SI units.

    ``geometry``: the platform's :class:`~rths3d.platform.geometry.StewartGeometry` (by
    parameters, by explicit anchors, or the calibrated geometry of ``geometry_file``, with the
    scene's limits and masses); ``None``: today's default platform. ``fts_pose``: the FTS
    site's mounting pose on the plate (x, y, z m; rx, ry, rz rad, R = Rz·Ry·Rx); empty: on
    the plate's axis, ``fts_height`` above it. ``geometry_file``: the calibrated-geometry file
    it came from (absolute path), or "". ``given``: the keys the scene's ``[platform]`` table
    set (``rths3d diagnose`` names them).
    """

    geometry: StewartGeometry | None = None
    fts_pose: tuple[float, ...] = ()
    geometry_file: str = ""
    given: tuple[str, ...] = ()
    plate_inertia: tuple[float, ...] = ()
    """The plate's principal moments (Ixx, Iyy, Izz) about its centre of mass along the plate's
    axes, kg·m², the sensor housing included; empty: from the plate's shape (today's)."""
    plate_com: tuple[float, ...] = ()
    """The plate's centre of mass (x, y, z) in the plate frame, m (with ``plate_inertia``)."""


def check_plate_inertial(inertia: Any, com: Any) -> tuple[tuple[float, ...],
                                                          tuple[float, ...]]:
    """The one validation of a stated plate inertia (``[platform] plate_inertia``, kg·m²,
    principal moments about the centre of mass) and centre of mass (``plate_com``, m, plate
    frame): both as float tuples (com (0, 0, 0) when only the inertia is given), or a
    :class:`~rths3d.errors.ConfigError` naming the key, the value and the limit."""
    def floats(key: str, v: Any) -> tuple[float, ...]:
        try:
            out = tuple(float(x) for x in v)
        except (TypeError, ValueError):
            raise ConfigError(f"platform.{key}", v, "need three numbers") from None
        if len(out) != 3 or not all(math.isfinite(x) for x in out):
            raise ConfigError(f"platform.{key}", list(v), "need three finite numbers")
        return out

    ii = floats("plate_inertia", inertia)
    if min(ii) <= 0 or 2 * max(ii) > sum(ii) * (1 + 1e-12):
        raise ConfigError("platform.plate_inertia", list(ii), "need Ixx, Iyy, Izz > 0 kg·m², "
                          "each at most the sum of the other two")
    c = floats("plate_com", com) if len(com) else (0.0, 0.0, 0.0)
    if max(abs(x) for x in c) > 1.0:
        raise ConfigError("platform.plate_com", list(c), "need |x|, |y|, |z| <= 1 m")
    return ii, c


@dataclass(frozen=True)
class TransferConfig:
    """Transfer system between command z and achieved z'.

    ``kind``: ``ideal`` (z' = z), ``delay`` (z'(t) = z(t − ``delay``)), ``lti`` (continuous
    transfer function ``num``/``den`` in s, discretised exactly with a held input, after a
    pure ``delay``; empty num/den loads ``assets/platform_heave_tf.json`` with its identified
    transport delay, ``delay`` then replacing the identification run's actuator delay, or a
    50 Hz second-order lag) or ``stewart`` (the MuJoCo Stewart platform). ``compensation``
    ``velocity`` adds ``comp_time``·ż to the command; ``polynomial`` extrapolates the command
    ``comp_time`` ahead with a polynomial of ``poly_order`` through the last samples; any
    other registered compensator (``ats``, ``rls``, ``inverse``, ``model_based``, ``lead``)
    takes its parameters from ``compensator``. ``compensate``: where the compensator acts,
    ``interface`` (one channel per interface DOF, any transfer system) or ``legs`` (the
    Stewart platform's six leg lengths, one channel per leg: decentralised compensation).
    ``comp_init``: the initial coefficients of the adaptive and model-based compensators,
    ``predicted`` (from the transfer system's predicted delay, unless ``compensator`` sets
    them) or ``given`` (the compensator's own defaults and ``compensator``).
    ``kp``, ``kv`` (N/m, N·s/m), ``timeconst`` (s), ``velocity_ff`` and ``substeps`` tune the
    Stewart platform's leg servos; the ``lti`` path with the identified model follows
    ``timeconst`` and ``velocity_ff`` (with kv/kp) too, by exchanging the identification run's
    first-order lags for the scene's (:func:`rths3d.transfer.actuators.follow_servo_settings`).
    ``integrator``: the Stewart platform's MuJoCo integrator, ``RK4`` (fourth order: one
    substep of 1 ms agrees with sixteen to 0.0005 µm, what the diagnosis' replay relies on) or
    ``implicitfast`` (first order, about 2.5× faster per physics step, 3 µm from the converged
    pose with one substep; docs/platform.md).
    """

    kind: str = "ideal"
    delay: float = 0.0
    num: tuple[float, ...] = ()
    den: tuple[float, ...] = ()
    compensation: str = "none"
    comp_time: float = 0.0
    poly_order: int = 2
    kp: float = 2.0e5
    kv: float = 2.0e3
    timeconst: float = 0.0
    velocity_ff: bool = True
    substeps: int = 1
    integrator: str = "RK4"
    valve_hz: float = 0.0
    """The servo-valve's natural frequency (Hz): a second-order response of the servo after
    the hold, integrated with the physics (:mod:`rths3d.platform.model`); 0: none."""
    valve_damping: float = 0.7
    """The servo-valve's damping ratio (1), with ``valve_hz``."""
    compensator: tuple[tuple[str, Any], ...] = ()
    """The compensator's own parameters (the ``[transfer.compensator]`` table, sorted
    key–value pairs; see :mod:`rths3d.compensation`)."""
    compensate: str = "interface"
    comp_init: str = "predicted"


@dataclass(frozen=True)
class SensorConfig:
    """Force-torque sensor model between F_m and F'_m.

    ``kind`` ``ideal`` or ``first_order`` (time constant ``time_constant`` s); then
    F'_m = ``gain``·F + ``offset`` + white noise of std ``noise_std`` (N), delayed by
    ``delay`` (s). ``seed`` seeds the noise.
    """

    kind: str = "ideal"
    time_constant: float = 0.0
    noise_std: float = 0.0
    gain: float = 1.0
    offset: float = 0.0
    delay: float = 0.0
    seed: int = 0


@dataclass(frozen=True)
class SafetyLimits:
    """Bench limits: the test stops (SafetyStop) when one is exceeded.

    ``stroke`` (m) and ``rotation`` (rad) bound |z|; ``velocity`` (m/s) bounds |ż| of the
    command; ``force`` (N) and ``torque`` (N·m) bound |F'_m| (the FTS range);
    ``divergence`` (m) bounds any numerical displacement. A growing interface oscillation
    (a delay-induced RTHS instability) also counts as divergence: the peak |F'_m| of each DOF
    over windows of ``growth_window`` (s) grew by more than ``growth`` (factor per window) in
    ``growth_windows`` consecutive windows, each peak above 2 % of the FTS range
    (``growth_windows = 0`` switches this off).

    The online fidelity monitor (:mod:`rths3d.surrogate.monitor`): ``fidelity_limit`` (m or
    rad; 0: off) bounds the running RMS (0.25 s) of the estimated error ê = z' − ẑ^r of
    every interface DOF, ẑ^r the surrogate reference identified from the test's first
    ``fidelity_warmup`` seconds (s); ``fidelity_action`` ``"warn"`` (the record's metadata
    names the crossing) or ``"stop"`` (a safety stop).
    """

    stroke: float = 0.04
    rotation: float = 0.2
    velocity: float = 0.5
    force: float = 1000.0
    torque: float = 100.0
    divergence: float = 1.0
    growth: float = 1.25
    growth_window: float = 0.5
    growth_windows: int = 4
    fidelity_limit: float = 0.0
    fidelity_action: str = "warn"
    fidelity_warmup: float = 1.0


SafetyConfig = SafetyLimits


@dataclass(frozen=True)
class NetworkConfig:
    """The test over the network (``[network]``; docs/network.md).

    ``host``/``port``: where ``rths3d serve`` listens (``host`` 127.0.0.1 unless opened on
    purpose; ``port`` 0: any free port, printed) and where the ``remote`` transfer system
    connects. ``timeout`` (s): longest silence of the peer within a test before it stops
    safely; ``first_timeout`` (s): the wait for the peer's first message after it connects
    (an OpenSees model still setting up its analysis). ``element_map``: the interface
    displacements of the element's, z = T u (rows: the scene's interface DOFs; columns:
    the element DOFs of the ``genericClient``, in its order); the forces go back as
    Tᵀ F'_m. Empty: the two-node element of one DOF per node and interface DOF,
    T = [−I, I] (z the elongation of the element). ``site``: see below.
    """

    host: str = "127.0.0.1"
    port: int = 8090
    timeout: float = 0.1
    first_timeout: float = 30.0
    element_map: Matrix = ()
    site: str = "lab"
    """What the ``remote`` transfer system talks to: ``lab`` (``rths3d serve``, an
    OpenFresco SimApp site server: trial, commit, getDaqResponse per step) or ``adapter``
    (OpenSees' ``adapter`` element: trial, then getForce answered with the measured
    displacement and force)."""


@dataclass(frozen=True)
class EffectConfig:
    """One physical effect of the bench, declared in a scene's ``[[effect]]`` table.

    ``name``: an effect of :mod:`rths3d.effects` (``rths3d effects`` lists them); ``value``:
    its parameter in the SI unit of the effect; ``leg`` (0–5): the leg a per-leg effect acts
    on (−1: all legs, where the effect allows it); ``axis``: the axis of an effect that has
    one (an FTS channel ``fx … tz``, a cross-talk ``fx.fz`` (row.column), an anchor or
    offset direction ``x``/``y``/``z``). Spec-stage effects edit the bench's MuJoCo model,
    set-point effects are per-leg signal blocks of the controller, sensor effects act on the
    measured channels (:class:`rths3d.bench.Bench`).
    """

    name: str
    value: float
    leg: int = -1
    axis: str = ""

    @property
    def label(self) -> str:
        """``name``, ``name.leg<i>``, ``name.<axis>`` or ``name.leg<i>.<axis>``."""
        out = self.name
        if self.leg >= 0:
            out += f".leg{self.leg}"
        if self.axis:
            out += f".{self.axis}"
        return out


@dataclass(frozen=True)
class Scene:
    """A complete vRTHS test description (SI units). See the module docstring."""

    name: str
    dofs: tuple[str, ...]
    numerical: NumericalConfig
    experiment: ExperimentConfig
    excitation: ExcitationConfig = field(default_factory=ExcitationConfig)
    transfer: TransferConfig = field(default_factory=TransferConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    safety: SafetyLimits = field(default_factory=SafetyLimits)
    dt: float = 1.0e-3
    duration: float = 10.0
    source: str = ""
    effects: tuple[EffectConfig, ...] = ()
    """The bench's physical effects (``[[effect]]`` tables), in the order declared."""
    platform: PlatformDescription = field(default_factory=PlatformDescription)
    """The platform (``[platform]``): today's bench unless the scene says otherwise."""
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    """The leg controller's conventions (``[controller]``)."""
    network: NetworkConfig = field(default_factory=NetworkConfig)
    """The test over the network (``[network]``): ``rths3d serve`` and the ``remote``
    transfer system."""

    @property
    def n_steps(self) -> int:
        """Number of interface steps (samples = n_steps + 1)."""
        return int(round(self.duration / self.dt))

    def params(self) -> dict[str, Any]:
        """Flat dict of all scalar parameters, keyed by dotted field names (a new dict on
        every call; the scene, frozen, computes it once: a batch asks each test's scene
        for it when grouping and again for its record)."""
        cached = self.__dict__.get("_params")
        if cached is None:
            cached = self._flat_params()
            object.__setattr__(self, "_params", cached)
        return dict(cached)

    def _flat_params(self) -> dict[str, Any]:
        out: dict[str, Any] = {"dt": self.dt, "duration": self.duration}
        for sec in ("numerical", "experiment", "excitation", "transfer", "sensor", "safety"):
            obj = getattr(self, sec)
            for f in fields(obj):
                v = getattr(obj, f.name)
                if sec == "experiment" and f.name in EXPERIMENT_EXTRA and not v:
                    continue
                if sec == "numerical" and f.name in NUMERICAL_EXTRA and obj.has_matrices:
                    continue
                out[f"{sec}.{f.name}"] = v
        for e in self.effects:
            out[f"effect.{e.label}"] = e.value
        for f in fields(ControllerConfig):
            if f.name != "given" and getattr(self.controller, f.name) != f.default:
                out[f"controller.{f.name}"] = getattr(self.controller, f.name)
        return out

    def with_transfer(self, kind: str) -> Scene:
        """The same scene with another transfer system (checked where it is built:
        :func:`rths3d.transfer.transfer_class`)."""
        return replace(self, transfer=replace(self.transfer, kind=kind))

"""The MuJoCo model of the Stewart platform, generated from its geometry.

Structure (stable names for consumers):

* ``base``: the fixed base (visual mesh).
* ``leg{i}_cyl``: cylinder body on a universal joint (hinges ``leg{i}_u1``, ``leg{i}_u2``)
  at base anchor ``b_i``, its frame z axis along the home leg direction.
* ``leg{i}_piston``: piston on the slide joint ``leg{i}_slide`` (0 at the home length), with
  the tip site ``leg{i}_tip`` at the home leg length.
* ``plate``: the top plate on a free joint ``plate_free``; its frame is the plate frame of
  :mod:`~rths3d.platform.geometry` (origin at the centre of the top-anchor circle, at
  ``home_height`` at home). Sites ``plate_anchor{i}`` at ``p_i``. Each tip is tied to its
  plate anchor by an equality ``connect`` named ``leg{i}_connect``.
* ``fts_body``: a massless body welded on top of the plate (the force-torque sensor's tool
  side; the sensor housing, ``fts_mass``, belongs to the plate). At the sensor's upper face it
  carries the site ``fts`` (frame parallel to the plate frame, z up at home) and the
  sensors ``fts_force`` (N) / ``fts_torque`` (N·m). MuJoCo reports the force and torque that
  the plate exerts on ``fts_body`` and everything mounted on it, in the site frame, torque
  about the site origin: statically ``+m·g`` upwards for a payload of mass m.
* ``payload_xml`` bodies are children of ``fts_body`` in the ``fts`` site frame.
* ``leg{i}``: position servos on the slide joints: force ``kp·(act − s) − kv·ṡ`` with the
  piston extension ``s`` and the set-point ``act`` (m), an activation integrated from the
  control (the set-point rate, m/s), so that the set-point ramps between interface samples.
* ``leg{i}_lag`` (only with ``lag = "servo"`` and ``timeconst`` τ > 0): the servo's
  continuous first-order lag after the hold. The lagged set-point x (ẋ = (r − x)/τ of the
  held set-point r = ``act``) is ``x = r − τ·f`` with ``f`` a filter activation of the
  same control (ḟ = (ṙ − f)/τ), so this actuator adds the force ``−kp·τ·f`` on the same
  slide: ``kp·(x − s) − kv·ṡ`` in total, integrated with the physics. The leg-force sensors
  ``leg{i}_force`` then read the total actuator force on the slide.
* With a servo-valve (``valve_hz`` > 0): the servo acts on the valve's output y, the
  second-order response ÿ + 2ζω ẏ + ω² y = ω² r of the held set-point r = ``act``
  (ω = 2π·``valve_hz``, ζ = ``valve_damping``), integrated with the physics. y is the
  position of a spool, ``leg{i}_spool`` (a slide along world x, no geoms, no gravity along
  it), in the scaled coordinate Y = y/ε (ε = :data:`SPOOL_SCALE`): ``leg{i}`` (the
  set-point integrator) drives it as a mass–spring–damper of natural frequency ω and damping
  ζ towards r/ε, and the servo's force ``kp·(y − s)`` is the actuator ``leg{i}_valve`` on
  the fixed tendon ``leg{i}_valve`` (length s − ε·Y), with the damping ``−kv·ṡ`` as the
  actuator ``leg{i}_damping`` on the slide. The tendon pushes back on the spool by ε times
  the servo's force: over the spool's mass and the scale that moves y by
  kp·ε²/(m ω²) of (s − y), 2e-9 of it (1e-12 m) for a 50 Hz valve, so y is the valve's
  response. The leg-force sensors read the total actuator force on the slide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..config import (
    SERVO_CONVENTIONS,
    SERVO_RANGES,
    ControllerConfig,
    TransferConfig,
    check_plate_inertial,
    check_servo_number,
)
from ..errors import ConfigError
from .geometry import DEFAULT_GEOMETRY, StewartGeometry

SPOOL_SCALE = 1e-4
"""ε: the valve spool's coordinate is its output y over ε (module docstring)."""
SPOOL_MASS = 1.0
"""The valve spool's mass in its scaled coordinate (kg): of the order of the legs' masses,
so that the solver's mean inertia is the bench's."""

__all__ = [
    "SPOOL_MASS",
    "SPOOL_SCALE",
    "ActuatorConfig",
    "PlatformConfig",
    "build_model",
    "build_spec",
    "model_xml",
    "predicted_delay",
]


def _check(name: str, value: float, ok: bool, limit: str) -> None:
    if not ok:
        raise ConfigError(name, value, limit)


@dataclass(frozen=True)
class ActuatorConfig:
    """Leg actuation: a position servo per leg with optional lag, delay and feed-forward.

    The MuJoCo actuator force is ``f = kp·(a − s) − kv·ṡ`` with the piston extension ``s``
    (m) and the set-point ``a``; ``a`` follows the command through the controller's
    set-point blocks, a first-order lag of time constant ``timeconst`` and a transport delay
    ``delay`` (:mod:`rths3d.platform.sim`, at the interface rate).

    Attributes
    ----------
    kp:
        Position gain (N/m).
    kv:
        Velocity gain (N·s/m). It damps the absolute leg velocity, which lags the leg by
        ``kv/kp`` (s) unless ``velocity_ff`` is on.
    timeconst:
        Time constant of the first-order lag of the set-point (s); 0 disables it.
    delay:
        Transport delay of the set-point (s); 0 disables it.
    velocity_ff:
        Add ``(kv/kp)·dL/dt`` to the set-point (velocity feed-forward), which cancels the
        ``kv/kp`` lag of the servo.
    gravity_comp:
        Add the static leg force at home divided by ``kp`` to the set-point so the platform
        does not sag under its own and the payload's weight.
    gravity_source:
        Where those forces come from: ``"nominal"`` (the controller's model of the bench,
        today's) or ``"measured"`` (the holding forces of the bench itself over its own
        gains, as a bench that offsets each leg until its encoder reads home under load:
        no sag at rest even where the model is wrong).
    stroke, velocity_limit, force_limit:
        Override the geometry's total stroke (m), piston-speed limit (m/s) and actuator-force
        limit (N); ``None`` takes the geometry's values.
    hold:
        How the servo's set-point is held over an interface step: ``"ramp"`` (first-order
        hold, interpolated from c_k to c_{k+1}; today's bench) or ``"zoh"`` (zero-order hold:
        c_{k+1} from the start of the step).
    sample:
        When the bench samples its channels: ``"end"`` of the interface step (t_{k+1}, after
        the new set-point acted; today's bench) or ``"start"`` (t_k, before it acts: every
        measured channel one sample earlier).
    feedforward:
        Difference form of the velocity feed-forward when ``velocity_ff`` is on:
        ``"backward"`` ((L_{k+1} − L_k)/ΔT, today's), ``"central"`` ((L_{k+2} − L_k)/(2ΔT),
        needs the next set-point: a planned trajectory or a replay) or ``"none"``.
    lag:
        Where the first-order lag ``timeconst`` sits: ``"setpoint"`` (a digital filter of
        the set-point at the interface rate before the hold, today's bench) or ``"servo"``
        (the servo's continuous dynamics after the hold, a valve or amplifier: MuJoCo
        actuator dynamics integrated with the physics at the physics step; the model's
        ``leg{i}_lag`` actuators).
    valve_hz, valve_damping:
        A servo-valve's second-order response after the hold, natural frequency (Hz) and
        damping ratio (1), integrated with the physics (module docstring); ``valve_hz`` 0
        (the default): none. Not with ``lag = "servo"`` (state one continuous servo
        dynamics).
    """

    kp: float = TransferConfig.kp
    kv: float = TransferConfig.kv
    timeconst: float = 0.003
    delay: float = 0.001
    velocity_ff: bool = True
    gravity_comp: bool = True
    gravity_source: str = "nominal"
    stroke: float | None = None
    velocity_limit: float | None = None
    force_limit: float | None = None
    hold: str = ControllerConfig.hold
    sample: str = ControllerConfig.sample
    feedforward: str = ControllerConfig.feedforward
    lag: str = ControllerConfig.lag
    valve_hz: float = TransferConfig.valve_hz
    valve_damping: float = TransferConfig.valve_damping

    def __post_init__(self) -> None:
        for name, allowed in (*SERVO_CONVENTIONS.items(),
                              ("gravity_source", ("nominal", "measured"))):
            if name == "gravity":  # gravity_comp / gravity_source here
                continue
            v = getattr(self, name)
            _check(f"controller.{name}", v, v in allowed, "one of " + " | ".join(allowed))
        for name in SERVO_RANGES:  # one home: rths3d.config
            check_servo_number(f"actuator.{name}", name, getattr(self, name))
        if self.valve_hz > 0 and self.servo_lag > 0:
            raise ConfigError("controller.valve_hz", self.valve_hz, "", message=(
                f"controller.valve_hz: {self.valve_hz:g} Hz with lag = 'servo' (timeconst "
                f"{self.timeconst:g} s): state the servo's continuous dynamics as one, the "
                "valve or the lag after the hold (lag = 'setpoint' keeps the set-point "
                "filter)"))
        for name, unit in (("stroke", "m"), ("velocity_limit", "m/s"), ("force_limit", "N")):
            v = getattr(self, name)
            if v is not None:
                _check(f"actuator.{name}", v, math.isfinite(v) and v > 0, f"must be > 0 {unit}")

    @property
    def servo_lag(self) -> float:
        """The time constant (s) of the servo's continuous lag after the hold (0: none)."""
        return self.timeconst if self.lag == "servo" else 0.0

    @property
    def setpoint_lag(self) -> float:
        """The time constant (s) of the digital set-point lag before the hold (0: none)."""
        return self.timeconst if self.lag == "setpoint" else 0.0

    @property
    def valve(self) -> tuple[float, float] | None:
        """(ω rad/s, ζ) of the servo-valve after the hold, or None without one."""
        if self.valve_hz <= 0:
            return None
        return 2 * math.pi * self.valve_hz, self.valve_damping


@dataclass(frozen=True)
class PlatformConfig:
    """Everything that defines a simulated platform (SI units).

    Attributes
    ----------
    geometry, actuator:
        Platform dimensions/masses and leg actuation.
    dt:
        Interface (control) step ΔT (s); the loop commands a pose once per ``dt``.
    substeps:
        MuJoCo steps per interface step; the physics ``timestep`` is ``dt / substeps``.
    eq_solref, eq_solimp:
        MuJoCo solver parameters of the six tip-to-plate ``connect`` constraints. The default
        ``solref`` of 0.02 s is far too soft for a closed chain: ``(0.002, 1)`` keeps the gap
        at a few µm (MuJoCo clamps the time constant to at least 2·timestep).
    integrator:
        MuJoCo integrator name (``RK4``, ``implicitfast``, ``Euler``, ``implicit``). ``RK4``
        (the default) converges at fourth order in the physics step: a replay with one
        substep of 1 ms reproduces a run with four substeps to 0.06 µm in pose and 0.03 N in
        the FTS force on a 31 Hz multisine, where ``implicitfast`` (first order: the
        explicit servo stiffness leads by about half a physics step) differs by 6 µm and
        0.6 N. A stiff servo (kp ≳ 1e6 N/m at 1 ms) needs substeps with RK4.
    gravity:
        Gravitational acceleration (m/s², acting along −z).
    fts_pose:
        Mounting pose of the FTS site on the plate, ``(x, y, z, rx, ry, rz)`` (m, rad;
        R = Rz·Ry·Rx) in the plate frame; the part's bodies hang in this frame and the
        sensor reports in it. Empty (the default): on the plate's axis, ``fts_height``
        above it, parallel to the plate. The sensor housing (``fts_mass``) fills the
        ``z`` between plate and site.
    plate_inertia, plate_com:
        The plate's principal moments of inertia (Ixx, Iyy, Izz) about its centre of mass,
        along the plate's axes (kg·m²), and that centre (x, y, z in the plate frame, m), the
        sensor housing included (mass ``plate_mass + fts_mass``). Empty (the default): from
        the plate's and the housing's shapes (today's bench; a disc plate, a plate of
        another shape states its own).
    """

    geometry: StewartGeometry = DEFAULT_GEOMETRY
    actuator: ActuatorConfig = field(default_factory=ActuatorConfig)
    dt: float = 1.0e-3
    substeps: int = 1
    eq_solref: tuple[float, float] = (0.002, 1.0)
    eq_solimp: tuple[float, float, float] = (0.99, 0.999, 0.0001)
    integrator: str = "RK4"
    gravity: float = 9.81
    fts_pose: tuple[float, ...] = ()
    plate_inertia: tuple[float, ...] = ()
    plate_com: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        _check("platform.dt", self.dt, math.isfinite(self.dt) and 1e-5 <= self.dt <= 0.02,
               "must be in [1e-5, 0.02] s")
        _check("platform.substeps", self.substeps,
               isinstance(self.substeps, int) and 1 <= self.substeps <= 100,
               "must be an integer in [1, 100]")
        _check("platform.integrator", self.integrator,
               self.integrator in ("implicitfast", "Euler", "RK4", "implicit"),
               "one of implicitfast, Euler, RK4, implicit")
        _check("platform.gravity", self.gravity,
               math.isfinite(self.gravity) and self.gravity >= 0, "must be >= 0 m/s²")
        if len(self.eq_solref) != 2 or len(self.eq_solimp) != 3:
            raise ConfigError("platform.eq_solref/eq_solimp", (self.eq_solref, self.eq_solimp),
                              "need 2 and 3 numbers")
        if self.integrator == "RK4":
            # explicit: the servo damping on the piston alone must stay inside RK4's
            # stability region (|λ h| < 2.78 on the real axis)
            lam = self.actuator.kv * self.timestep / self.geometry.piston_mass
            if lam > 2.5:
                need = int(math.ceil(lam / 2.5 * self.substeps))
                raise ConfigError("platform.substeps", self.substeps, "", message=(
                    f"platform.substeps: {self.substeps} is too few for RK4 with kv = "
                    f"{self.actuator.kv:g} N·s/m on a {self.geometry.piston_mass:g} kg piston "
                    f"(kv·h/m = {lam:.3g} must be <= 2.5): use substeps >= {need} or "
                    "integrator = 'implicitfast'"))
        tau = self.actuator.servo_lag
        # the servo lag's activation is integrated explicitly with the physics (RK4's stage
        # derivatives, or explicit Euler in the other integrators)
        top = 2.5 if self.integrator == "RK4" else 1.0
        if tau > 0 and self.timestep / tau > top:
            need = int(math.ceil(self.timestep / tau / top * self.substeps))
            raise ConfigError("platform.substeps", self.substeps, "", message=(
                f"platform.substeps: {self.substeps} is too few for a servo lag of "
                f"{tau:g} s after the hold with {self.integrator} (physics step / "
                f"timeconst = {self.timestep / tau:.3g} must be <= {top:g}): use "
                f"substeps >= {need}"))
        valve = self.actuator.valve
        # the spool is integrated explicitly with the physics: |λ·h| = ω·h for ζ <= 1
        lam = 0.0 if valve is None else valve[0] * max(
            1.0, valve[1] + math.sqrt(max(valve[1] ** 2 - 1.0, 0.0))) * self.timestep
        if lam > top:
            need = int(math.ceil(lam / top * self.substeps))
            raise ConfigError("platform.substeps", self.substeps, "", message=(
                f"platform.substeps: {self.substeps} is too few for a servo-valve of "
                f"{self.actuator.valve_hz:g} Hz (damping {self.actuator.valve_damping:g}) with "
                f"{self.integrator} (its fastest rate × physics step = {lam:.3g} must be <= "
                f"{top:g}): use substeps >= {need}"))
        if self.fts_pose:
            fp = tuple(float(v) for v in self.fts_pose)
            _check("platform.fts_pose", list(self.fts_pose),
                   len(fp) == 6 and all(math.isfinite(v) for v in fp) and 0 < fp[2] <= 1.0
                   and max(abs(v) for v in fp[3:]) <= math.pi,
                   "need (x, y, z, rx, ry, rz): 0 < z <= 1 m above the plate, |angles| <= pi "
                   "rad")
            object.__setattr__(self, "fts_pose", fp)
        if self.plate_inertia or self.plate_com:
            ii, com = check_plate_inertial(self.plate_inertia, self.plate_com)
            object.__setattr__(self, "plate_inertia", ii)
            object.__setattr__(self, "plate_com", com)
        short = float(self.geometry.home_leg_lengths().min())
        _check("actuator.stroke", self.stroke, self.stroke / 2 < short,
               f"half the stroke must be shorter than the home leg length {short:.4g} m")

    def fts_site(self) -> tuple[np.ndarray, np.ndarray]:
        """Position (3,) (m) and rotation matrix (3, 3) of the FTS site in the plate frame."""
        if not self.fts_pose:
            return np.array([0.0, 0.0, self.geometry.fts_height]), np.eye(3)
        from .kinematics import rotation_matrix

        return np.array(self.fts_pose[:3]), rotation_matrix(*self.fts_pose[3:])

    @property
    def timestep(self) -> float:
        """MuJoCo physics timestep ``dt / substeps`` (s)."""
        return self.dt / self.substeps

    @property
    def stroke(self) -> float:
        """Total piston stroke (m), centred on the home length."""
        return self.actuator.stroke if self.actuator.stroke is not None else \
            self.geometry.stroke

    @property
    def velocity_limit(self) -> float:
        """Piston-speed limit (m/s)."""
        a = self.actuator.velocity_limit
        return a if a is not None else self.geometry.leg_velocity_limit

    @property
    def force_limit(self) -> float:
        """Actuator-force limit (N)."""
        a = self.actuator.force_limit
        return a if a is not None else self.geometry.leg_force_limit


def predicted_delay(config: PlatformConfig, frequency: float = 1.0,
                    payload_mass: float = 0.0) -> float:
    """Phase delay (s) of the achieved motion behind the command, from the actuator settings.

    Timing convention (:mod:`rths3d.platform.sim`): the pose commanded at interface step k is
    the target for the end of that step, t_{k+1}; its leg set-point c_{k+1} (inverse
    kinematics, velocity feed-forward by backward difference) passes the controller's
    set-point blocks (lag ``timeconst``, transport ``delay``, both at the interface rate);
    during the step the servo holds the mid-step value (c_k + c_{k+1})/2 (a second-order
    hold: no lead, no lag against the continuous set-point) and every channel is read at
    t_{k+1}. The chain is therefore

    * the lag block α/(1 − (1 − α) z⁻¹), α = 1 − exp(−ΔT/τ) (exact for a held input: its
      delay is ≈ τ − ΔT/2) when ``timeconst`` τ > 0 and ``lag = "setpoint"``; with
      ``lag = "servo"`` the continuous lag 1/(1 + jωτ) after the hold instead;
    * the delay block (linear interpolation between samples): ``delay``;
    * the mid-step hold: phase 0 (the ΔT/2 lead of holding a value over the step that ends
      at its time cancels the ΔT/2 of averaging two samples);
    * the servo ``(kp + kv·jω·F)/(kp − m ω² + kv·jω)`` with the backward-difference
      feed-forward F = (1 − e^{−jωΔT})/(jωΔT) (0 without feed-forward, a lag of kv/kp) and
      the mass ``m`` each leg moves in heave, ``(plate + FTS + payload_mass)/(6 u_z²) +
      piston`` (u_z: vertical component of the home leg direction).

    The physics step does not enter (RK4 integration converges well below these figures).
    Evaluated exactly at ``frequency`` (Hz).
    """
    a = config.actuator
    w = 2 * math.pi * frequency
    T = config.dt
    zinv = complex(math.cos(w * T), -math.sin(w * T))
    H = complex(1.0, 0.0)
    if a.setpoint_lag > 0:
        al = 1.0 - math.exp(-T / a.timeconst)
        H *= al / (1.0 - (1.0 - al) * zinv)
    if a.servo_lag > 0:  # continuous, after the hold
        H /= complex(1.0, w * a.servo_lag)
    if a.valve is not None:  # the servo-valve, continuous after the hold
        wn, zeta = a.valve
        H *= wn * wn / complex(wn * wn - w * w, 2 * zeta * wn * w)
    if a.delay > 0:
        steps = a.delay / T
        d0 = math.floor(steps + 1e-12)
        fr = steps - d0
        H *= zinv ** d0 * ((1.0 - fr) + fr * zinv)
    g = config.geometry
    uz = g.home_leg_vectors()[:, 2] / g.home_leg_lengths()
    m = (g.plate_mass + g.fts_mass + payload_mass) / (6 * float(np.mean(uz ** 2))) + \
        g.piston_mass
    F = (1.0 - zinv) / complex(0.0, w * T) if a.velocity_ff else 0.0
    H *= complex(a.kp, 0.0) + complex(0.0, w * a.kv) * F
    H /= complex(a.kp - m * w * w, w * a.kv)
    return -math.atan2(H.imag, H.real) / w


def _fmt(v: np.ndarray | list | tuple) -> str:
    return " ".join(f"{float(x):.12g}" for x in v)


def _quat_z_to(u: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) rotating the z axis onto the unit vector u."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, u)
    s = np.linalg.norm(axis)
    c = float(np.dot(z, u))
    if s < 1e-15:
        return np.array([1.0, 0.0, 0.0, 0.0])
    ang = math.atan2(s, c)
    axis = axis / s
    return np.concatenate([[math.cos(ang / 2)], math.sin(ang / 2) * axis])


def _quat_of(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).reshape(9))
    return q


@lru_cache(maxsize=16)
def _plate_meshes(geom: StewartGeometry) -> tuple[str, str]:
    """Convex visual meshes (MJCF <mesh> elements) of the base and of the top plate."""
    import trimesh

    def prism(radius_pts: np.ndarray, z0: float, z1: float) -> trimesh.Trimesh:
        pts = np.concatenate([np.c_[radius_pts, np.full(len(radius_pts), z0)],
                              np.c_[radius_pts, np.full(len(radius_pts), z1)]])
        return trimesh.convex.convex_hull(pts)

    def outline(angles: np.ndarray, r: float) -> np.ndarray:
        # rounded triangle-ish plate through the anchors, 15 % larger than the anchor circle
        a = np.sort(np.mod(angles, 2 * math.pi))
        mids = a + np.diff(np.r_[a, a[0] + 2 * math.pi]) / 2
        ring = np.sort(np.r_[a, mids])
        rr = np.where(np.isin(ring, a), 1.15 * r, 0.95 * r)
        return np.c_[rr * np.cos(ring), rr * np.sin(ring)]

    base = prism(outline(geom.base_angles(), geom.base_radius), -0.03, 0.0)
    plate = prism(outline(geom.top_angles(), geom.top_radius), -geom.plate_thickness, 0.0)

    def mjcf(name: str, m: trimesh.Trimesh) -> str:
        return (f'<mesh name="{name}" vertex="{_fmt(m.vertices.reshape(-1))}" '
                f'face="{" ".join(str(int(i)) for i in m.faces.reshape(-1))}"/>')

    return mjcf("base_mesh", base), mjcf("plate_mesh", plate)


def model_xml(config: PlatformConfig, payload_xml: str | None = None,
              world_xml: str | None = None, extra_xml: str | None = None) -> str:
    """MJCF text of the platform (see the module docstring for the names); ``extra_xml``:
    top-level sections the part needs (``<default>``, ``<asset>``, ``<contact>`` …)."""
    g = config.geometry
    a = config.actuator
    b = g.base_anchors()
    p = g.top_anchors()
    lv = g.home_leg_vectors()
    L = g.home_leg_lengths()
    ts = config.timestep
    base_mesh, plate_mesh = _plate_meshes(g)
    leg_r = 0.02
    legs = []
    for i in range(6):
        u = lv[i] / L[i]
        q = _quat_z_to(u)
        cyl_len = 0.55 * L[i]
        pis_len = 0.55 * L[i]
        legs.append(f"""
    <body name="leg{i}_cyl" pos="{_fmt(b[i])}" quat="{_fmt(q)}">
      <joint name="leg{i}_u1" type="hinge" axis="1 0 0"/>
      <joint name="leg{i}_u2" type="hinge" axis="0 1 0"/>
      <geom name="leg{i}_cyl" class="platform" type="cylinder"
            size="{leg_r} {cyl_len / 2:.12g}"
            pos="0 0 {cyl_len / 2:.12g}" mass="{g.cylinder_mass:.12g}" rgba="0.35 0.38 0.42 1"/>
      <body name="leg{i}_piston">
        <joint name="leg{i}_slide" type="slide" axis="0 0 1"/>
        <geom name="leg{i}_piston" class="platform" type="cylinder"
              size="{0.6 * leg_r} {pis_len / 2:.12g}"
              pos="0 0 {L[i] - pis_len / 2:.12g}" mass="{g.piston_mass:.12g}"
              rgba="0.75 0.77 0.8 1"/>
        <site name="leg{i}_tip" pos="0 0 {L[i]:.12g}" size="0.006"/>
      </body>
    </body>""")
    anchors = "\n".join(
        f'      <site name="plate_anchor{i}" pos="{_fmt(p[i])}" size="0.008"/>' for i in range(6))
    eqs = "\n".join(
        f'    <connect name="leg{i}_connect" site1="leg{i}_tip" site2="plate_anchor{i}" '
        f'solref="{_fmt(config.eq_solref)}" solimp="{_fmt(config.eq_solimp)}"/>'
        for i in range(6))
    # the lag and the transport delay of the set-point are signal blocks of the platform's
    # controller (rths3d.platform.sim), not MuJoCo actuator dynamics: one implementation for
    # the loop, the replay and the diagnosis, at the interface rate whatever the physics step.
    # The servo's set-point is its activation, integrated from the set-point rate (ctrl):
    # the set-point ramps linearly between interface samples (a first-order hold) instead of
    # jumping at each sample, so the sampled forces do not depend on the sampling instant.
    # force = kp·(act − q) − kv·q̇ (the position actuator's law with act as its set-point).
    valve = a.valve
    spools = tendons = ""
    if valve is None:
        acts = "\n".join(
            f'    <general name="leg{i}" joint="leg{i}_slide" dyntype="integrator" '
            f'gaintype="fixed" gainprm="{a.kp:.12g}" biastype="affine" '
            f'biasprm="0 {-a.kp:.12g} {-a.kv:.12g}"/>' for i in range(6))
    else:
        # the servo-valve (module docstring): the set-point integrator drives the spool
        # (Y = y/ε) towards act/ε as a mass-spring-damper of frequency ω and damping ζ; the
        # servo's stiffness acts through the tendon s − ε·Y, its damping on the slide
        wn, zeta = valve
        eps, ms = SPOOL_SCALE, SPOOL_MASS
        k_s, c_s = ms * wn * wn, 2 * zeta * wn * ms
        spools = "".join(
            f'    <body name="leg{i}_spool" pos="0 0 {-1 - 0.1 * i:.12g}">\n'
            f'      <joint name="leg{i}_spool" type="slide" axis="1 0 0"/>\n'
            f'      <inertial pos="0 0 0" mass="{ms:.12g}" diaginertia="1 1 1"/>\n'
            f'    </body>\n' for i in range(6))
        tendons = "  <tendon>\n" + "\n".join(
            f'    <fixed name="leg{i}_valve"><joint joint="leg{i}_slide" coef="1"/>'
            f'<joint joint="leg{i}_spool" coef="{-eps:.12g}"/></fixed>' for i in range(6)) \
            + "\n  </tendon>\n"
        acts = "\n".join(
            f'    <general name="leg{i}" joint="leg{i}_spool" dyntype="integrator" '
            f'gaintype="fixed" gainprm="{k_s / eps:.12g}" biastype="affine" '
            f'biasprm="0 {-k_s:.12g} {-c_s:.12g}"/>' for i in range(6))
        acts += "\n" + "\n".join(
            f'    <general name="leg{i}_valve" tendon="leg{i}_valve" gaintype="fixed" '
            f'gainprm="0" biastype="affine" biasprm="0 {-a.kp:.12g} 0"/>' for i in range(6))
        acts += "\n" + "\n".join(
            f'    <general name="leg{i}_damping" joint="leg{i}_slide" gaintype="fixed" '
            f'gainprm="0" biastype="affine" biasprm="0 0 {-a.kv:.12g}"/>' for i in range(6))
    tau = a.servo_lag
    if tau > 0:
        # the servo's continuous lag after the hold (module docstring): the lagged set-point
        # is act − τ·f with f filtering the same control (the set-point rate), so this
        # actuator adds −kp·τ·f on the slide; its control is written with the leg's
        acts += "\n" + "\n".join(
            f'    <general name="leg{i}_lag" joint="leg{i}_slide" dyntype="filter" '
            f'dynprm="{tau:.12g}" gaintype="fixed" gainprm="{-a.kp * tau:.12g}" '
            f'biastype="none"/>' for i in range(6))
    fts_r = 0.05
    # the FTS site and the frame of the part: on the plate's axis (today's bench) or at the
    # scene's fts_pose (the sensor housing then spans the plate-to-site height at its x, y)
    fts_h = g.fts_height
    fts_at = f'pos="0 0 {g.fts_height:.12g}"'
    fts_geom_xy = "0 0"
    if config.fts_pose:
        pos, R = config.fts_site()
        fts_h = float(pos[2])
        fts_geom_xy = _fmt(pos[:2])
        fts_at = f'pos="{_fmt(pos)}" quat="{_fmt(_quat_of(R))}"'
    # a stated plate inertia replaces the one MuJoCo computes from the plate's and the
    # housing's geoms (an <inertial> element overrides the geoms' in MJCF)
    plate_inertial = "" if not config.plate_inertia else (
        f'      <inertial pos="{_fmt(config.plate_com)}" '
        f'mass="{g.plate_mass + g.fts_mass:.12g}" '
        f'diaginertia="{_fmt(config.plate_inertia)}"/>\n')
    # the leg forces and the sensor's orientation as sensors too: evaluated only at the start
    # of a step (RK4's later stages overwrite actuator_force and site_xmat), so a replay can
    # read a step's end-of-step sample at the start of the next (rths3d.platform.sim)
    legsens = "\n".join(f'    <actuatorfrc name="leg{i}_force" actuator="leg{i}"/>'
                         for i in range(6))
    if tau > 0 or valve is not None:  # the leg's force: every actuator's on its slide
        legsens = "\n".join(f'    <jointactuatorfrc name="leg{i}_force" joint="leg{i}_slide"/>'
                             for i in range(6))
    return f"""<mujoco model="rths3d_stewart">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{ts:.12g}" integrator="{config.integrator}"
          gravity="0 0 {-config.gravity:.12g}"/>
  <visual><global offwidth="1280" offheight="960"/></visual>
  <asset>
    {base_mesh}
    {plate_mesh}
  </asset>
  <default>
    <default class="platform">
      <geom contype="0" conaffinity="0"/>
    </default>
  </default>
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1" directional="true"/>
    <body name="base">
      <geom name="base" class="platform" type="mesh" mesh="base_mesh" rgba="0.25 0.27 0.3 1"/>
    </body>
{"".join(legs)}
    <body name="plate" pos="0 0 {g.home_height:.12g}">
      <freejoint name="plate_free"/>
{plate_inertial}      <geom name="plate" class="platform" type="mesh" mesh="plate_mesh"
            mass="{g.plate_mass:.12g}" rgba="0.55 0.6 0.68 1"/>
{anchors}
      <geom name="fts" class="platform" type="cylinder" size="{fts_r} {fts_h / 2:.12g}"
            pos="{fts_geom_xy} {fts_h / 2:.12g}" mass="{g.fts_mass:.12g}" rgba="0.85 0.55 0.1 1"/>
      <body name="fts_body">
        <site name="fts" {fts_at} size="0.01"/>
        <frame {fts_at}>
{payload_xml or ""}
        </frame>
      </body>
    </body>
{world_xml or ""}
{spools}  </worldbody>
  <equality>
{eqs}
  </equality>
{tendons}  <actuator>
{acts}
  </actuator>
  <sensor>
    <force name="fts_force" site="fts"/>
    <torque name="fts_torque" site="fts"/>
{legsens}
    <framequat name="fts_quat" objtype="site" objname="fts"/>
  </sensor>{extra_xml or ""}
</mujoco>
"""


def _one_line(exc: Exception) -> str:
    return "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())


def build_spec(config: PlatformConfig | None = None, payload_xml: str | None = None,
               world_xml: str | None = None,
               extra_xml: str | None = None):  # -> mujoco.MjSpec
    """The platform as an editable ``mujoco.MjSpec`` (payload under ``fts_body``).

    ``payload_xml``: MJCF ``<body>`` element(s), the experimental part, in the ``fts`` site
    frame (z up at home). ``world_xml``: extra MJCF elements for the worldbody (e.g. a
    contact surface). ``extra_xml``: top-level sections the fragments need. Raises
    :class:`ConfigError` naming the fragment if MuJoCo rejects it.
    """
    import mujoco

    config = config or PlatformConfig()
    xml = model_xml(config, payload_xml, world_xml, extra_xml)
    try:
        return mujoco.MjSpec.from_string(xml)
    except ValueError as exc:
        raise ConfigError("payload_xml/world_xml", None, "",
                          message="payload_xml/world_xml: the platform MJCF with these "
                                  "fragments is invalid: " + _one_line(exc)) from exc


def build_model(config: PlatformConfig | None = None, payload_xml: str | None = None,
                world_xml: str | None = None,
                extra_xml: str | None = None):  # -> mujoco.MjModel
    """Compiled ``mujoco.MjModel`` of the platform (see :func:`build_spec`)."""
    spec = build_spec(config, payload_xml, world_xml, extra_xml)
    try:
        return spec.compile()
    except ValueError as exc:
        raise ConfigError("payload_xml/world_xml", None, "",
                          message="payload_xml/world_xml: the platform model does not "
                                  "compile: " + _one_line(exc)) from exc

"""Experimental parts as MJCF fragments to mount on the force-torque-sensor (FTS) site.

``payload_xml(cfg)`` gives the bodies to attach at the FTS site (coordinates in the site
frame, z up); ``world_xml(cfg, site_pos)`` the world-fixed contact surface, given the
world position of the FTS site at the home pose. Geometry is mirrored from paper Fig. 4
(see docs/architecture.md): the mass sits on its spring above the FTS and the surface is
``h0`` above the mass's contact tip at static equilibrium. The joint springs carry
``springref`` so that gravity only preloads (equilibrium at q = 0).

Contact uses MuJoCo's soft contact (frictionless, condim 1) set to the penalty law of the
numpy model: negative solref (stiffness k_c/m, damping d_c/m, mass-normalised) with a small
impedance (``CONTACT_IMPEDANCE``), see ``contact_solref``.

``specimen_model_xml`` builds a specimen-only model whose mount follows a prescribed motion
(the ideal and LTI transfer systems): heavy mount joints for the interface DOFs driven each
physics step so that the mount reaches the commanded pose exactly.
"""

from __future__ import annotations

from ..scene import ExperimentConfig

GRAVITY = 9.81
MASS_HEIGHT = 0.02
"""Height of the specimen body above the FTS site (m)."""
TIP_RADIUS = 0.005
BODY_HALF = 0.01
CONTACT_GROUP = 4
"""contype/conaffinity bit used only by the specimen tip and its surface."""


CONTACT_IMPEDANCE = 0.01
"""MuJoCo solimp impedance d of the specimen contact. With a negative solref the contact
acceleration is a = (1 − d)·a₀ + (k_c·p + d_c·ṗ)/m_eff (MuJoCo's soft-constraint law), so a
small d makes it the penalty law of the numpy model up to d·a₀."""


def _tip_mass(cfg: ExperimentConfig) -> float:
    """Effective mass (kg) of the part at its contact tip, along the contact normal."""
    if cfg.kind == "multidof":
        return 1.0 / (1.0 / cfg.m + cfg.arm**2 / cfg.inertia)
    return cfg.m


def contact_solref(cfg: ExperimentConfig, mass: float | None = None) -> str:
    """MuJoCo solref (negative: mass-normalised stiffness and damping) of the penalty
    contact (k_c, d_c) at a tip of effective mass ``mass`` (default: the part's)."""
    m = _tip_mass(cfg) if mass is None else mass
    return f"{-cfg.k_contact / m:.9g} {-cfg.d_contact / m:.9g}"


def _contact_attrs(cfg: ExperimentConfig) -> str:
    if cfg.kind == "multidof":
        # the bar's tip is light (m_eff ≈ 0.14 kg): the penalty law would ring at ~130 Hz
        # against the platform's 1 ms step; MuJoCo's usual impedance-0.99 contact with the
        # time constant and damping ratio of k_c on the bar's mass stays stable
        m = cfg.m
        wc = (cfg.k_contact / m) ** 0.5
        zeta = max(cfg.d_contact / (2.0 * (cfg.k_contact * m) ** 0.5), 0.05)
        ref = f"{1.0 / (zeta * wc):.9g} {zeta:.9g}"
        imp = "0.99 0.99 0.001 0.5 2"
    else:
        d = CONTACT_IMPEDANCE
        ref = contact_solref(cfg)
        imp = f"{d} {d} 0.001 0.5 2"
    return (f'contype="{CONTACT_GROUP}" conaffinity="{CONTACT_GROUP}" condim="1" '
            f'solref="{ref}" solimp="{imp}" margin="0"')


def payload_xml(cfg: ExperimentConfig) -> str:
    """Bodies of the experimental part, in the FTS site frame (attach at the site)."""
    if cfg.kind in ("contact", "linear"):
        sref = cfg.m * GRAVITY / cfg.k
        tip = ""
        if cfg.kind == "contact":
            tip = (f'<geom name="exp_tip" type="sphere" size="{TIP_RADIUS}" '
                   f'pos="0 0 {BODY_HALF + TIP_RADIUS}" mass="0" {_contact_attrs(cfg)} '
                   f'rgba="0.9 0.3 0.2 1"/>')
        return (
            f'<body name="exp_mass" pos="0 0 {MASS_HEIGHT}">'
            f'<joint name="exp_heave" type="slide" axis="0 0 1" stiffness="{cfg.k:.12g}" '
            f'damping="{cfg.d:.12g}" springref="{sref:.12g}" armature="0"/>'
            f'<geom name="exp_body" type="cylinder" size="0.03 {BODY_HALF}" mass="{cfg.m:.12g}" '
            f'contype="0" conaffinity="0" rgba="0.2 0.5 0.9 1"/>'
            f'{tip}<site name="exp_com" pos="0 0 0" size="0.003"/></body>'
        )
    if cfg.kind == "multidof":
        sref = cfg.m * GRAVITY / cfg.k
        return (
            f'<body name="exp_bar" pos="0 0 {MASS_HEIGHT}">'
            f'<joint name="exp_heave" type="slide" axis="0 0 1" stiffness="{cfg.k:.12g}" '
            f'damping="{cfg.d:.12g}" springref="{sref:.12g}"/>'
            f'<joint name="exp_pitch" type="hinge" axis="0 1 0" stiffness="{cfg.k_rot:.12g}" '
            f'damping="{cfg.d_rot:.12g}"/>'
            f'<inertial pos="0 0 0" mass="{cfg.m:.12g}" '
            f'diaginertia="{cfg.inertia:.9g} {cfg.inertia:.9g} {cfg.inertia:.9g}"/>'
            f'<geom name="exp_body" type="box" size="{cfg.arm:.6g} 0.02 {BODY_HALF}" mass="0" '
            f'contype="0" conaffinity="0" rgba="0.2 0.5 0.9 1"/>'
            f'<geom name="exp_tip" type="sphere" size="{TIP_RADIUS}" '
            f'pos="{cfg.arm:.9g} 0 {BODY_HALF + TIP_RADIUS}" mass="0" {_contact_attrs(cfg)} '
            f'rgba="0.9 0.3 0.2 1"/>'
            f'<site name="exp_com" pos="0 0 0" size="0.003"/></body>'
        )
    raise ValueError(cfg.kind)


def surface_height(cfg: ExperimentConfig, site_z: float) -> float:
    """World z (m) of the surface's lower face for an FTS site at ``site_z`` (home)."""
    return site_z + MASS_HEIGHT + BODY_HALF + 2 * TIP_RADIUS + cfg.h0


def world_xml(cfg: ExperimentConfig, site_pos: tuple[float, float, float]) -> str:
    """World-fixed parts (the contact surface) for an FTS site at ``site_pos`` (home, m)."""
    if cfg.kind == "linear":
        return ""
    x = site_pos[0] + (cfg.arm if cfg.kind == "multidof" else 0.0)
    z = surface_height(cfg, site_pos[2]) + 0.005
    return (f'<geom name="exp_surface" type="box" size="0.04 0.04 0.005" '
            f'pos="{x:.9g} {site_pos[1]:.9g} {z:.9g}" {_contact_attrs(cfg)} '
            f'rgba="0.5 0.5 0.5 0.6"/>')


_MOUNT_JOINT = {"x": ("slide", "1 0 0"), "y": ("slide", "0 1 0"), "z": ("slide", "0 0 1"),
                "rz": ("hinge", "0 0 1"), "ry": ("hinge", "0 1 0"), "rx": ("hinge", "1 0 0")}
MOUNT_ARMATURE = 1.0e7
"""Armature of the prescribed mount joints (kg or kg·m²): the specimen's reaction changes
the mount acceleration by < 1e-5 relative."""


def specimen_model_xml(cfg: ExperimentConfig, dofs: tuple[str, ...], timestep: float) -> str:
    """A specimen-only MJCF model: prescribed mount (joints for ``dofs``), FTS, payload."""
    order = [d for d in ("x", "y", "z", "rz", "ry", "rx") if d in dofs]
    joints = "".join(
        f'<joint name="mount_{d}" type="{_MOUNT_JOINT[d][0]}" axis="{_MOUNT_JOINT[d][1]}" '
        f'armature="{MOUNT_ARMATURE:g}" damping="0"/>' for d in order)
    return (
        f'<mujoco model="specimen_{cfg.kind}"><compiler angle="radian"/>'
        f'<option timestep="{timestep:.12g}" gravity="0 0 -{GRAVITY}" integrator="Euler"/>'
        f'<worldbody>{world_xml(cfg, (0.0, 0.0, 0.0))}'
        f'<body name="mount" pos="0 0 0">{joints}'
        f'<geom type="box" size="0.05 0.05 0.005" pos="0 0 -0.005" mass="1" contype="0" '
        f'conaffinity="0"/>'
        f'<body name="ft_body" pos="0 0 0"><site name="fts" pos="0 0 0" size="0.004"/>'
        f'{payload_xml(cfg)}</body></body></worldbody>'
        f'<sensor><force name="fts_force" site="fts"/><torque name="fts_torque" site="fts"/>'
        f'</sensor></mujoco>'
    )


def interface_matrices(cfg: ExperimentConfig, dofs: tuple[str, ...]
                       ) -> tuple[list[list[float]], list[list[float]]]:
    """Interface stiffness k_EXP (N/m, N·m/rad) and mass m_EXP matrices (rigid part,
    contact open) for the τ-ratios and the strain energy (paper eqs. 10, 12)."""
    if cfg.kind == "multidof":
        jm = cfg.inertia + cfg.m * MASS_HEIGHT**2
        return ([[cfg.k, 0.0], [0.0, cfg.k_rot]], [[cfg.m, 0.0], [0.0, jm]])
    return ([[cfg.k]], [[cfg.m]])

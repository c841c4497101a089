"""Geometry and kinematics of the Stewart platform against exact answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d.errors import ConfigError, RthsError
from rths3d.platform import (
    DEFAULT_GEOMETRY,
    ForwardKinematicsError,
    ScalarIK,
    StewartGeometry,
    check_workspace,
    forward_kinematics,
    inverse_kinematics,
    jacobian,
    rotation_matrix,
)
from rths3d.platform.kinematics import euler_from_matrix

G = DEFAULT_GEOMETRY


def _random_reachable(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1, 1, size=(3 * n, 6)) * np.array([0.03, 0.03, 0.03, 0.08, 0.08, 0.08])
    L = inverse_kinematics(G, q)
    lo, hi = G.leg_length_limits()
    ok = np.all((L > lo) & (L < hi), axis=1)
    return q[ok][:n]


def test_home_geometry_is_symmetric():
    """All six home legs have one length and the anchors lie on their circles."""
    L = G.home_leg_lengths()
    assert np.ptp(L) < 1e-15
    assert np.allclose(np.linalg.norm(G.base_anchors()[:, :2], axis=1), G.base_radius)
    assert np.allclose(np.linalg.norm(G.top_anchors()[:, :2], axis=1), G.top_radius)
    # leg length from Pythagoras for leg 0: horizontal distance between its anchors
    b, p = G.base_anchors()[0], G.top_anchors()[0]
    assert L[0] == pytest.approx(math.hypot(math.dist(b[:2], p[:2]), G.home_height), rel=1e-15)


def test_ik_pure_heave_is_pythagoras():
    """A pure heave dz changes every leg to sqrt(d_h² + (h + dz)²)."""
    dz = 0.0123
    b, p = G.base_anchors()[0], G.top_anchors()[0]
    expect = math.hypot(math.dist(b[:2], p[:2]), G.home_height + dz)
    assert np.allclose(inverse_kinematics(G, [0, 0, dz, 0, 0, 0]), expect, rtol=0, atol=1e-15)


def test_ik_threefold_symmetry():
    """Turning a translation+yaw pose by 120° about z permutes the legs by two."""
    dx, dy, dz, yaw = 0.012, -0.007, 0.004, 0.03
    a = 2 * math.pi / 3
    L = inverse_kinematics(G, [dx, dy, dz, 0, 0, yaw])
    L_rot = inverse_kinematics(G, [dx * math.cos(a) - dy * math.sin(a),
                                   dx * math.sin(a) + dy * math.cos(a), dz, 0, 0, yaw])
    assert np.allclose(L_rot, np.roll(L, 2), rtol=0, atol=1e-15)
    assert np.ptp(L) > 1e-3  # the pose is not trivially symmetric


def test_rotation_convention_and_euler_round_trip():
    """R = Rz Ry Rx (fixed axes) and euler_from_matrix inverts it."""
    rx, ry, rz = 0.1, -0.2, 0.3
    c, s = math.cos, math.sin
    Rx = np.array([[1, 0, 0], [0, c(rx), -s(rx)], [0, s(rx), c(rx)]])
    Ry = np.array([[c(ry), 0, s(ry)], [0, 1, 0], [-s(ry), 0, c(ry)]])
    Rz = np.array([[c(rz), -s(rz), 0], [s(rz), c(rz), 0], [0, 0, 1]])
    R = rotation_matrix(rx, ry, rz)
    assert np.allclose(R, Rz @ Ry @ Rx, atol=1e-15)
    assert np.allclose(euler_from_matrix(R), [rx, ry, rz], atol=1e-14)


def test_ik_fk_round_trip_1000_poses():
    """IK∘FK: leg lengths and poses agree to < 1e-9 over 1000 random reachable poses."""
    q = _random_reachable(1000)
    assert q.shape == (1000, 6)
    L = inverse_kinematics(G, q)
    q2 = forward_kinematics(G, L)
    assert np.max(np.abs(q2 - q)) < 1e-9
    assert np.max(np.abs(inverse_kinematics(G, q2) - L)) < 1e-9


def test_scalar_ik_matches_vectorised():
    """The pure-math fast path gives the vectorised IK to machine precision."""
    ik = ScalarIK(G)
    for q in _random_reachable(50, seed=1):
        got = ik.ik(*map(float, q))
        assert isinstance(got[0], float)
        assert np.allclose(got, inverse_kinematics(G, q), rtol=0, atol=1e-15)


def test_jacobian_matches_finite_differences():
    """∂L/∂q agrees with central differences at random poses."""
    e = 1e-6
    for q in _random_reachable(5, seed=2):
        Jn = np.stack([(inverse_kinematics(G, q + e * np.eye(6)[k])
                        - inverse_kinematics(G, q - e * np.eye(6)[k])) / (2 * e)
                       for k in range(6)], axis=1)
        assert np.max(np.abs(Jn - jacobian(G, q))) < 1e-8


def test_default_jacobian_well_conditioned():
    """The default geometry is well conditioned at home (cond 5.70 SI, 1.77 scaled)."""
    J = jacobian(G, np.zeros(6))
    assert np.linalg.cond(J) == pytest.approx(5.6988, abs=1e-3)
    Js = J.copy()
    Js[:, 3:] /= G.top_radius
    assert np.linalg.cond(Js) < 2.0


def test_fk_unreachable_raises_convergence_error():
    """Leg lengths no pose can reach raise ForwardKinematicsError (an RthsError)."""
    L = G.home_leg_lengths().copy()
    L[0] = 5.0 * L[0]
    with pytest.raises(ForwardKinematicsError, match="forward kinematics") as info:
        forward_kinematics(G, L, max_iter=30)
    assert isinstance(info.value, RthsError)


def test_workspace_names_leg_quantity_value_limit():
    """An out-of-stroke pose names the leg, 'length', the value and the range."""
    L = check_workspace(G, [0, 0, 0.02, 0, 0, 0])
    assert np.all(L > G.home_leg_lengths())
    with pytest.raises(ConfigError) as info:
        check_workspace(G, [0, 0, 0.2, 0, 0, 0])
    msg = str(info.value)
    assert "leg 0 length" in msg and "m is outside its range" in msg
    assert f"{G.home_leg_lengths()[0] + G.stroke / 2:.6g}" in msg
    # a surge of 120 mm shortens legs 0, 1 beyond the stroke while others stay inside
    with pytest.raises(ConfigError, match=r"leg 0 length 0\.39"):
        check_workspace(G, [0.12, 0, 0, 0, 0, 0])


def test_workspace_trajectory_reports_sample_and_joint_angle():
    """A trajectory names the first bad sample; a steep leg breaks the joint-angle limit."""
    traj = np.zeros((10, 6))
    traj[7, 2] = 0.2
    with pytest.raises(ConfigError, match="sample 7"):
        check_workspace(G, traj)
    steep = StewartGeometry(stroke=0.6, joint_angle_limit=0.05)
    with pytest.raises(ConfigError, match="joint angle"):
        check_workspace(steep, [0.05, 0, 0, 0, 0, 0])


def test_bad_geometry_and_pose_values_are_named():
    """Bad configuration values raise ConfigError naming the field."""
    with pytest.raises(ConfigError, match="geometry.top_radius"):
        StewartGeometry(top_radius=-1.0)
    with pytest.raises(ConfigError, match="geometry.stroke"):
        StewartGeometry(stroke=2.0)
    with pytest.raises(ConfigError, match="pose"):
        inverse_kinematics(G, [0, 0, float("nan"), 0, 0, 0])
    with pytest.raises(ConfigError, match="pose"):
        inverse_kinematics(G, [0, 0, 0])


def test_fk_rejects_the_mirrored_branch_naming_sample_and_lengths():
    """A solution with the plate at or below the base (mirrored branch) raises, naming the
    sample and its leg lengths, instead of returning it."""
    L = G.home_leg_lengths()
    with pytest.raises(ForwardKinematicsError, match=r"lengths \[0\.451197 .*at or below the "
                                                     r"base"):
        forward_kinematics(G, L, guess=[0, 0, -0.7, 0, 0, 0])
    guess = np.array([[0, 0, 0, 0, 0, 0], [0, 0, -0.7, 0, 0, 0]], float)
    with pytest.raises(ForwardKinematicsError, match=r"sample 1, lengths \[0\.451197"):
        forward_kinematics(G, np.stack([L, L]), guess=guess)
    assert np.allclose(forward_kinematics(G, L), 0.0, atol=1e-12)  # home from above


def test_fk_failures_name_sample_and_lengths():
    """Non-convergence and a singular Jacobian name the failing sample and its lengths."""
    L = G.home_leg_lengths()
    short = np.full(6, 0.1)  # no pose reaches it
    with pytest.raises(ForwardKinematicsError, match=r"did not converge .*sample 1, lengths "
                                                     r"\[0\.1 0\.1 0\.1"):
        forward_kinematics(G, np.stack([L, short]))
    with pytest.raises(ForwardKinematicsError, match=r"lengths \[0\.451197.*singular"):
        forward_kinematics(G, L, guess=[0, 0, -G.home_height, 0, 0, 0])

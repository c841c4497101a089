"""Tests of the live view and replay (rths3d.viz): drawing kinematics, playback clock, panel
data, the 3-D scene on a real viser server, the headless websocket stream and the CLI."""

from __future__ import annotations

import math
import subprocess
import sys
import time

import numpy as np
import pytest

from rths3d.errors import ConfigError
from rths3d.platform import DEFAULT_GEOMETRY, inverse_kinematics
from rths3d.platform import rotation_matrix as platform_rotation
from rths3d.record import DOFS, Record
from rths3d.viz import Playback, Viewer, buffer_from_record
from rths3d.viz.kinematics import (
    leg_segments,
    quat_from_matrix,
    quat_rotate,
    quat_z_to,
    rotation_matrix,
    transform_points,
)
from rths3d.viz.panels import coefficient_data, history_data, ssp_data, stride, window
from rths3d.viz.stream import channels, coefficient_columns, stream_dofs
from rths3d.viz.wire import HeadlessClient

DT = 1e-3
AMP = 0.005  # m
FREQ = 1.0  # Hz
TAU = 0.02  # s, delay of z' behind z
K_EXP = 2.0e4  # N/m


def delayed_sine_record(duration: float = 3.0, model: bool = False) -> Record:
    """A 1 kHz record: z = A sin ωt, z' = z delayed by TAU, F'_m = k z', a roll of the plate,
    the leg lengths of that pose from inverse kinematics and two numerical DOFs."""
    t = np.arange(0.0, duration, DT)
    w = 2 * math.pi * FREQ
    z = AMP * np.sin(w * t)
    zm = AMP * np.sin(w * (t - TAU))
    pose = np.zeros((t.size, 6))
    pose[:, 2] = zm
    pose[:, 3] = 0.01 * np.sin(0.5 * w * t)
    legs = inverse_kinematics(DEFAULT_GEOMETRY, pose)
    cols = {"z_cmd.z": z, "z_meas.z": zm, "z_ref.z": AMP * np.sin(w * (t - 0.005)),
            "f_meas.z": K_EXP * zm, "f_ext.z": np.zeros_like(t),
            "x_num.0": z, "x_num.1": 1.6 * z}
    cols.update({f"pose_meas.{d}": pose[:, i] for i, d in enumerate(DOFS)})
    cols.update({f"leg_len.{i}": legs[:, i] for i in range(6)})
    if model:
        cols["model.z_meas.z"] = AMP * np.sin(w * (t - 0.015))
        cols["model.f_meas.z"] = K_EXP * cols["model.z_meas.z"]
    meta = {"scene": "delayed-sine", "transfer": "stewart", "dt": DT,
            "experiment": {"k_exp": [[K_EXP]], "m_exp": 1.0}, "params": {"h0": 0.01}}
    return Record(t, cols, meta)


@pytest.fixture(scope="module")
def record() -> Record:
    return delayed_sine_record()


# ---------------------------------------------------------------------- kinematics
def test_rotation_matches_platform_convention():
    """The view's R = Rz Ry Rx equals the platform module's rotation for random angles."""
    rng = np.random.default_rng(0)
    for rx, ry, rz in rng.uniform(-1.0, 1.0, (20, 3)):
        np.testing.assert_allclose(rotation_matrix(rx, ry, rz),
                                   platform_rotation(rx, ry, rz), atol=1e-14)


def test_quaternion_of_matrix_rotates_like_the_matrix():
    """quat_from_matrix(R) rotates vectors exactly as R does, and has unit norm, w >= 0."""
    rng = np.random.default_rng(1)
    for rx, ry, rz in rng.uniform(-3.0, 3.0, (50, 3)):
        R = rotation_matrix(rx, ry, rz)
        q = quat_from_matrix(R)
        assert abs(np.linalg.norm(q) - 1) < 1e-12 and q[0] >= 0
        v = rng.normal(size=3)
        np.testing.assert_allclose(quat_rotate(q, v), R @ v, atol=1e-12)


def test_quat_z_to_turns_z_axis_onto_direction():
    """quat_z_to(d) maps +z onto d/|d|, including the anti-parallel limit."""
    for d in ([1.0, 2.0, 3.0], [0.0, 0.0, -2.0], [0.3, -0.1, 0.0], [0.0, 0.0, 1.0]):
        d = np.array(d)
        np.testing.assert_allclose(quat_rotate(quat_z_to(d), [0, 0, 1.0]),
                                   d / np.linalg.norm(d), atol=1e-12)


def test_leg_segments_span_base_to_tip_with_ik_lengths():
    """Cylinder starts at the base anchor, piston ends at the plate anchor, and the drawn leg
    lengths equal the platform's inverse kinematics for the same pose."""
    g = DEFAULT_GEOMETRY
    pose = np.array([0.01, -0.02, 0.015, 0.03, -0.02, 0.05])
    tips = transform_points(g.top_anchors(), pose, g.home_position())
    c = 0.25
    cyl, piston, quats, lengths = leg_segments(g.base_anchors(), tips, c)
    np.testing.assert_allclose(lengths, inverse_kinematics(g, pose), atol=1e-12)
    for i in range(6):
        axis = quat_rotate(quats[i], [0, 0, 1.0])
        np.testing.assert_allclose(cyl[i] - 0.5 * c * axis, g.base_anchors()[i], atol=1e-12)
        np.testing.assert_allclose(piston[i] + 0.5 * c * axis, tips[i], atol=1e-12)


# ---------------------------------------------------------------------- playback
class FakeClock:
    """A settable wall clock (s) so the playback needs no sleeping."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_playback_speed_pause_seek_and_loop():
    """Record time advances at speed × wall time, holds when paused, jumps on seek, and wraps
    at the end when looping."""
    clk = FakeClock()
    pb = Playback(0.0, 4.0, speed=2.0, clock=clk)
    clk.now += 0.5
    assert pb.time() == pytest.approx(1.0)
    pb.pause()
    clk.now += 10.0
    assert pb.time() == pytest.approx(1.0) and not pb.playing
    pb.seek(3.5)
    pb.play()
    clk.now += 0.5  # 3.5 + 1.0 → wraps to 0.5
    assert pb.time() == pytest.approx(0.5)
    pb.set_speed(0.5)  # no jump when the speed changes
    assert pb.time() == pytest.approx(0.5)
    clk.now += 1.0
    assert pb.time() == pytest.approx(1.0)
    pb.seek(-5.0)
    assert pb.time() == pytest.approx(0.0)
    pb.restart()
    assert pb.time() == 0.0 and pb.playing


def test_playback_stops_at_end_without_loop():
    """Without looping the clock holds at the last sample and pauses itself."""
    clk = FakeClock()
    pb = Playback(1.0, 2.0, loop=False, clock=clk)
    clk.now += 5.0
    assert pb.time() == pytest.approx(2.0) and not pb.playing
    pb.play()  # from the end: starts over
    assert pb.time() == pytest.approx(1.0)


@pytest.mark.parametrize("speed", [0.0, -1.0, 1e6])
def test_playback_rejects_bad_speed(speed):
    """A speed outside its limits is a ConfigError naming 'speed'."""
    with pytest.raises(ConfigError, match="speed"):
        Playback(0.0, 1.0, speed=speed)


# ---------------------------------------------------------------------- panels
def test_window_and_stride(record):
    """The window spans `span` seconds ending at the current sample; decimation keeps at most
    MAX points, evenly spaced, and always the newest sample."""
    t = record.t
    i0, i1 = window(t, 2500, 1.0)
    assert i1 == 2501 and t[i0] >= t[2500] - 1.0 - 1e-12 and t[i0 - 1] < t[2500] - 1.0
    s = stride(i0, i1, 400)
    rows = np.arange(i1)[s]
    assert len(rows) <= 400 and rows[-1] == 2500 and rows[0] >= i0
    assert len(set(np.diff(rows))) == 1
    assert stride(5, 9, 400) == slice(5, 9, 1)


def test_ssp_data_keeps_pairs_and_sorts_by_z(record):
    """The SSP series are (z, z') pairs of the same samples, sorted by z, plus the unit-slope
    line; a model column adds a fourth series."""
    buf = buffer_from_record(delayed_sine_record(model=True))
    ch = channels(buf.index, "z")
    rows = stride(1000, 2000, 400)
    z, zm, line, zmod = ssp_data(buf.data, ch, rows)
    assert np.all(np.diff(z) >= 0)
    np.testing.assert_array_equal(line, z)
    pairs = set(zip(buf.data[rows, ch.z_cmd], buf.data[rows, ch.z_meas], strict=True))
    assert set(zip(z, zm, strict=True)) == pairs
    assert zmod.shape == z.shape


def test_history_data_has_model_beside_measurement():
    """Time histories carry t, z, z', z^r (and the model z' / F'_m when recorded)."""
    buf = buffer_from_record(delayed_sine_record(model=True))
    ch = channels(buf.index, "z")
    assert ch.has_model
    disp, force = history_data(buf.data, ch, slice(0, 100, 1))
    assert len(disp) == 5 and len(force) == 3
    np.testing.assert_array_equal(disp[0], buf.data[:100, 0])
    np.testing.assert_allclose(force[2], K_EXP * disp[4])


def test_buffer_from_record_round_trips(record):
    """A replay buffer holds exactly the record's samples and DOFs."""
    buf = buffer_from_record(record)
    assert buf.n == record.n and stream_dofs(buf.columns) == ("z",)
    back = buf.to_record()
    np.testing.assert_array_equal(back.t, record.t)
    for k, v in record.columns.items():
        np.testing.assert_array_equal(back.columns[k], v)


def compensated_record(duration: float = 3.0) -> Record:
    """The delayed-sine record with a per-leg compensator's coefficients: a1 of leg i rises
    from 5 ms to (5 + i) ms over the record, a0 stays 1 (the columns the loop writes)."""
    rec = delayed_sine_record(duration)
    t = rec.t
    for i in range(6):
        rec.columns[f"comp.a0.leg{i}"] = np.ones_like(t)
        rec.columns[f"comp.a1.leg{i}"] = 0.005 + 0.001 * i * t / t[-1]
    rec.meta["transfer_meta"] = {"compensator": {"name": "ats", "compensate": "legs"}}
    return rec


def test_coefficient_columns_and_data():
    """The compensator's columns are found once per coefficient, channels in column order;
    the plot data is (t, one series per channel) over the rows asked."""
    buf = buffer_from_record(compensated_record())
    cols = coefficient_columns(buf.index)
    assert list(cols) == ["a0", "a1"]
    assert [ch for ch, _ in cols["a1"]] == [f"leg{i}" for i in range(6)]
    rows = stride(100, 900, 400)
    t, *legs = coefficient_data(buf.data, buf.index["t"], cols["a1"], rows)
    np.testing.assert_array_equal(t, buf.data[rows, 0])
    for i, series in enumerate(legs):
        np.testing.assert_array_equal(series, buf.data[rows, buf.index[f"comp.a1.leg{i}"]])
    assert coefficient_columns(buffer_from_record(delayed_sine_record()).index) == {}


def test_viewer_shows_the_coefficients_over_time():
    """Replaying a record with a per-leg compensator, a browser-like client receives a
    panel of a1 (s) over time with one series per leg whose points are the recorded
    (t, a1) pairs; choosing a0 shows that coefficient instead."""
    rec = compensated_record()
    v = Viewer(buffer_from_record(rec), port=0, rate=30).start()
    try:
        with HeadlessClient(v.port) as client:
            time.sleep(1.5)
            with v._lock:
                v.coef_dropdown.value = "a0"
                v._on_coef(None)
            time.sleep(0.8)
            msgs = client.snapshot()
    finally:
        v.stop()
    assert any(m["type"] == "GuiFolderMessage" and "Compensator: ats (legs)" in
               str(m["props"].get("label")) for m in msgs)
    uuid = _uplot_uuid(msgs, "a1 (s) over time")
    sent = [m["updates"]["data"] for m in msgs if m["type"] == "GuiUpdateMessage"
            and m["uuid"] == uuid and "data" in m["updates"]]
    assert len(sent) >= 5
    t, *legs = sent[-1]
    assert len(legs) == 6 and t.size > 10
    for i, series in enumerate(legs):
        want = np.interp(t, rec.t, rec.columns[f"comp.a1.leg{i}"])
        np.testing.assert_allclose(series, want, rtol=1e-12)
    a0 = _uplot_uuid(msgs, "a0 (-) over time")
    assert any(m["type"] == "GuiUpdateMessage" and m["uuid"] == a0 for m in msgs)


# ---------------------------------------------------------------------- server
@pytest.fixture(scope="module")
def viewer(record):
    v = Viewer(buffer_from_record(record), port=0, rate=30).start()
    yield v
    v.stop()


def test_scene_follows_pose_legs_and_spring(viewer, record):
    """Moving the scene to a sample puts the plate at home + pose, the piston ends at the
    recorded leg length from the base, and stretches the spring by −F'_m,z / k_exp."""
    sc = viewer.scene
    i = 1234
    row = viewer.buffer.data[i].copy()
    with viewer._lock:
        sc.exaggeration = 1.0
        sc.update(row)
        pose = np.array([record.columns[f"pose_meas.{d}"][i] for d in DOFS])
        np.testing.assert_allclose(sc.plate_frame.position,
                                   DEFAULT_GEOMETRY.home_position() + pose[:3], atol=1e-6)
        q = np.asarray(sc.plate_frame.wxyz)
        R = rotation_matrix(*pose[3:])
        for e in np.eye(3):
            np.testing.assert_allclose(quat_rotate(q, e), R @ e, atol=1e-6)
        for k in range(6):
            axis = quat_rotate(np.asarray(sc.pistons.batched_wxyzs[k], float), [0, 0, 1.0])
            end = np.asarray(sc.pistons.batched_positions[k], float) \
                + 0.5 * sc.cylinder_length * axis
            length = np.linalg.norm(end - DEFAULT_GEOMETRY.base_anchors()[k])
            assert length == pytest.approx(record.columns[f"leg_len.{k}"][i], abs=1e-6)
        spring = sc.spring.scale[2]
        expected = sc.specimen.spring_length - record.columns["f_meas.z"][i] / K_EXP
        assert spring == pytest.approx(expected, abs=1e-9)
        viewer._dirty = True


def test_replay_viewer_updates_at_most_30_per_second(viewer):
    """The view's own thread updates at ≤ 30 Hz and the shown time advances in replay."""
    u0, t0 = viewer.updates, time.monotonic()
    i0 = viewer.current_index()
    time.sleep(1.0)
    rate = (viewer.updates - u0) / (time.monotonic() - t0)
    assert 5 < rate <= 31
    assert viewer.current_index() != i0


def test_viewer_rejects_bad_options(record):
    """Bad view options raise ConfigError naming the option."""
    buf = buffer_from_record(record)
    with pytest.raises(ConfigError, match="rate"):
        Viewer(buf, rate=60)
    with pytest.raises(ConfigError, match="span"):
        Viewer(buf, span=0)
    with pytest.raises(ConfigError, match="exaggeration"):
        Viewer(buf, exaggeration=0.5)


def _until(condition, timeout_s: float) -> None:
    """Poll ``condition`` every 50 ms until it holds or ``timeout_s`` passes (the test's
    assertions then say what was missing)."""
    end = time.monotonic() + timeout_s
    while not condition() and time.monotonic() < end:
        time.sleep(0.05)


def _plate_moves(msgs: list[dict]) -> int:
    return sum(m["type"] == "SetPositionMessage" and m["name"] == "/platform/top"
               for m in msgs)


def _uplot_uuid(msgs: list[dict], title_start: str) -> str:
    """uuid of the uPlot panel whose title starts with ``title_start``."""
    for m in msgs:
        if m["type"] == "GuiUplotMessage" and (m["props"].get("title") or "").startswith(
                title_start):
            return m["uuid"]
    raise AssertionError(f"no uPlot panel titled {title_start!r}")


@pytest.mark.slow  # a live test watched to its end
def test_headless_client_sees_scene_and_plot_updates_while_test_runs():
    """While the real loop runs the paper's contact test on the Stewart platform (paced at
    real time) and the view serves it from its own process, a websocket client (subprotocol
    viser-v<version>) receives plate poses and SSP / history data that advance with the
    samples the loop writes; after a restart with the LTI transfer system it follows the new
    run."""
    from rths3d.scene import scene_with
    from rths3d.viz.live import LiveRun, load_target

    scene = scene_with(load_target("paper_contact"), {"duration": 4.0})
    run = LiveRun(scene, transfer="stewart", speed=1.0, start_paused=True, reference=False)
    v = run.view_process(port=0, rate=30).start()
    try:
        with HeadlessClient(v.port) as client:  # its connection starts the paused run
            # waited for by what it shows, not by the clock: a cold start compiles the loop
            _until(lambda: run._buffers and run._buffers[0].n >= 1500, 180.0)
            live = run._buffers[0]
            n_written = live.n
            running = run.running
            msgs = client.snapshot()
            # The page's "Run / restart" with another transfer system: the view follows.
            v._handle(("restart", "lti", {"numerical.k": 5000.0}))
            _until(lambda: _plate_moves(client.snapshot()[len(msgs):]) >= 5, 180.0)
            after = client.snapshot()[len(msgs):]
            status = run.status()
    finally:
        v.stop()
        run.close()
    assert "(lti)" in status
    assert _plate_moves(after) >= 5
    assert running and 500 < n_written < live.data.shape[0]  # watched mid-test
    plate = [m["position"] for m in msgs
             if m["type"] == "SetPositionMessage" and m["name"] == "/platform/top"]
    assert len(plate) >= 10
    assert len({round(p[2], 9) for p in plate}) >= 5  # the plate moves
    ssp_uuid = _uplot_uuid(msgs, "SSP")
    ssp = [m["updates"]["data"] for m in msgs if m["type"] == "GuiUpdateMessage"
           and m["uuid"] == ssp_uuid and "data" in m["updates"]]
    assert len(ssp) >= 10
    z, zm = ssp[-1][0], ssp[-1][1]
    assert z.size > 10 and np.all(np.diff(z) >= 0)
    written = set(zip(live.data[:n_written, live.index["z_cmd.z"]],
                      live.data[:n_written, live.index["z_meas.z"]], strict=True))
    assert set(zip(z, zm, strict=True)) <= written  # each dot is one recorded (z, z') pair
    disp_uuid = _uplot_uuid(msgs, "z, z'")
    t_last = [m["updates"]["data"][0][-1] for m in msgs if m["type"] == "GuiUpdateMessage"
              and m["uuid"] == disp_uuid and "data" in m["updates"]]
    assert len(t_last) >= 10 and np.all(np.diff(t_last) > 0)
    assert t_last[-1] <= live.data[n_written - 1, 0] + 1e-12
    assert 1.0 < t_last[-1] < 3.5  # paced at real time: about 2.5 s simulated in 2.5 s


def _until_running(rows, timeout: float = 300.0) -> None:
    """Wait until a live run has written some rows (its first steps wait for the compiled
    loop, which a fresh clone compiles on its first run: tens of seconds)."""
    end = time.monotonic() + timeout
    while rows() < 20:
        assert time.monotonic() < end, "the live run did not start"
        time.sleep(0.05)


def test_in_process_live_viewer_follows_the_newest_sample():
    """The in-process viewer of a live run shows the newest sample the loop has published."""
    from rths3d.scene import scene_with
    from rths3d.viz.live import LiveRun, load_target

    scene = scene_with(load_target("paper_contact"), {"duration": 3.0})
    run = LiveRun(scene, transfer="lti", speed=2.0, reference=False)
    v = run.viewer(port=0, rate=30).start()
    try:
        _until_running(lambda: v.buffer.n)  # a cold cache compiles the loop first
        time.sleep(1.0)
        i = v.current_index()
        assert i == v.buffer.n - 1 or i == v.buffer.n - 2 or v.buffer.n - 1 - i < 50
        assert v.updates >= 5
        assert v.buffer.data[i, 0] > 0.5
    finally:
        v.stop()
        run.close()


def test_live_run_pauses_resumes_and_restarts_with_another_transfer():
    """Pause holds simulated time, resume continues, and a restart with the LTI transfer
    system and another k_NUM runs a new test whose metadata carries the new values."""
    from rths3d.scene import scene_with
    from rths3d.viz.live import LiveRun, load_target

    scene = scene_with(load_target("paper_contact"), {"duration": 3.0})
    run = LiveRun(scene, transfer="stewart", speed=4.0, reference=False)
    buf = run.start()
    try:
        _until_running(lambda: buf.n)  # a cold cache compiles the loop first
        time.sleep(0.5)
        run.pause()
        time.sleep(0.3)
        t1 = buf.data[buf.n - 1, 0]
        time.sleep(0.5)
        assert buf.data[buf.n - 1, 0] == t1 and t1 > 0
        run.resume()
        time.sleep(0.3)
        assert buf.data[buf.n - 1, 0] > t1
        new = run.restart("lti", {"numerical.k": 5000.0})
        assert new is not buf and new.meta["transfer"] == "lti"
        assert new.meta["numerical"]["K"][0][0] == pytest.approx(5000.0)
        assert "pose_meas.z" not in new.index
    finally:
        run.close()
    assert run.result is not None


# ---------------------------------------------------------------------- CLI
def test_cli_replays_a_record_and_prints_the_url(tmp_path, record):
    """`rths3d view RECORD --port 0 --seconds 1` serves the replay on 127.0.0.1 and exits 0."""
    path = record.save(tmp_path / "rec.parquet")
    out = subprocess.run([sys.executable, "-m", "rths3d", "view", str(path), "--port", "0",
                          "--seconds", "1"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "rths3d view: http://127.0.0.1:" in out.stdout


@pytest.mark.parametrize("args, needle", [
    (["missing.parquet"], "does not exist"),
    (["rec.csv", "--rate", "100"], "--rate"),
])
def test_cli_bad_input_is_one_line_exit_2(tmp_path, args, needle, record):
    """Bad CLI input prints one line naming the problem and exits with code 2."""
    record.save(tmp_path / "rec.csv")
    out = subprocess.run([sys.executable, "-m", "rths3d", "view", *args], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert needle in out.stderr and "Traceback" not in out.stderr


@pytest.mark.parametrize("args, needle", [
    (["rec.csv", "--host", "192.0.2.1"], "--host: '192.0.2.1' (not an address of this machine)"),
    (["rec.csv", "--host", "no-such-host.invalid"], "not an address of this machine"),
    (["rec.csv", "--transfer", "lti"], "--transfer: 'lti' (applies to a live scene run only"),
    (["rec.csv", "--set", "duration=1"], "--set:"),
    (["rec.csv", "--out", "x.parquet"], "--out:"),
    (["paper_contact", "--out", "foo.txt"], "--out: 'foo.txt' (the record file must end in"),
    (["paper_contact", "--out", "rec.csv/x.parquet"], "'rec.csv' is a file, not a folder"),
])
def test_cli_host_and_options_checked_before_serving(tmp_path, args, needle, record):
    """A host not of this machine, replay-only misuse of live-run options and an unusable
    --out exit 2 with one line at once (no hang, nothing run)."""
    record.save(tmp_path / "rec.csv")
    out = subprocess.run([sys.executable, "-m", "rths3d", "view", *args, "--port", "0",
                          "--seconds", "1"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 2, out.stderr
    assert needle in out.stderr and len(out.stderr.strip().splitlines()) == 1
    assert "rths3d view:" not in out.stdout


def test_check_host_accepts_this_machine_and_rejects_others():
    """`check_host` passes loopback names and raises ConfigError for a foreign address."""
    from rths3d.viz.app import check_host

    for host in ("127.0.0.1", "localhost", "0.0.0.0"):
        check_host(host)
    with pytest.raises(ConfigError, match="not an address of this machine"):
        check_host("192.0.2.1")


# ---------------------------------------------------------------------- running measures
def test_running_measures_of_a_delayed_sine(record):
    """Over two whole periods of z = A sin ωt, z' = A sin ω(t − τ), F'_m = k z': e_rel,track
    = √(2 − 2 cos ωτ), FEI delay = τ and HSEM^S = −2π·2·sin ωτ (E_error = −k π A² sin ωτ per
    period, E_strain = ½ k A²)."""
    from rths3d.viz.measures import RunningMeasures

    buf = buffer_from_record(record)
    ch = channels(buf.index, "z")
    m = RunningMeasures(buf.meta)
    i1 = 2500
    i0 = i1 - 2000  # exactly two periods at 1 Hz, 1 kHz
    v = m.compute(buf.data, ch, i0, i1)
    phi = 2 * math.pi * FREQ * TAU
    assert v["e_rel_track"] == pytest.approx(math.sqrt(2 - 2 * math.cos(phi)), rel=1e-3)
    assert v["fei_delay"] == pytest.approx(TAU, rel=2e-2)
    assert v["hsem_s"] == pytest.approx(-4 * math.pi * math.sin(phi), rel=2e-2)
    text = m.markdown(v)
    assert f"{v['fei_delay'] * 1e3:.3g} ms" in text
    short = m.compute(buf.data, ch, 0, 10)
    assert all(math.isnan(x) for x in short.values())
    assert "—" in m.markdown(short)


def test_cli_runs_a_scene_live_for_a_browser(tmp_path):
    """`rths3d view SCENE` prints the URL, waits for a client, runs the test live, serves the
    platform's moving plate to it and saves the record with --out."""
    out_file = tmp_path / "live.parquet"
    proc = subprocess.Popen(
        [sys.executable, "-m", "rths3d", "view", "paper_contact", "--port", "0", "--transfer",
         "lti", "--set", "duration=3", "--speed", "2", "--seconds", "2.5", "--out",
         str(out_file)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = ""
        while "rths3d view: http://127.0.0.1:" not in line:
            line = proc.stdout.readline()
            assert line, proc.stderr.read()
        port = int(line.split("http://127.0.0.1:")[1].split()[0])
        with HeadlessClient(port) as client:
            time.sleep(2.0)
            msgs = client.snapshot()
        rest, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    plate = [m for m in msgs if m["type"] == "SetPositionMessage"
             and m["name"] == "/platform/top"]
    assert len(plate) >= 10
    assert "record saved:" in rest
    rec = Record.load(out_file)
    assert rec.meta["transfer"] == "lti" and 1.0 < rec.duration <= 3.0


def test_shared_stream_copies_new_rows_and_survives_close():
    """The shared stream copies exactly the rows written (z^r filled in later included with
    publish_all), a reader in the same process sees them, and publishing after close is a
    harmless no-op (a loop may still be running when the view stops)."""
    from rths3d.record import RecordBuffer
    from rths3d.viz.process import SharedRecordBuffer, SharedStream

    buf = RecordBuffer(["t", "z_cmd.z", "z_ref.z"], 100, {"scene": "s"})
    buf.data[:40, 0] = np.arange(40) * DT
    buf.data[:40, 1] = np.sin(np.arange(40))
    buf.n = 40
    stream = SharedStream(buf)
    assert stream.publish() == 40
    reader = SharedRecordBuffer(stream.spec(), other_process=False)
    assert reader.n == 40 and reader.meta["scene"] == "s"
    np.testing.assert_array_equal(reader.data[:40], buf.data[:40])
    buf.data[:40, 2] = 1.0  # the loop fills z^r after the run
    stream.publish_all()
    np.testing.assert_array_equal(reader.data[:40, 2], 1.0)
    stream.close()
    buf.n = 60
    assert stream.publish() == 40 and reader.n == 40

"""`rths3d serve` as the laboratory of an OpenSees model: an openseespy SDOF with a
`genericClient` element (in its own process) runs a hybrid test against the served lab (the
ideal transfer moving the paper's linear part), and equals the same test run in-process —
the lab object driven by a Newmark/Linear step written here from OpenSees' algorithm,
through the same call sequence — to 1e-9; both agree with the combined continuous linear
system integrated independently; the record loads in `rths3d metrics`; nothing is left
running or listening."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from netproc import ENV, ROOT, has_openseespy, opensees, port_listeners, serve  # noqa: E402

from rths3d.network.server import Lab  # noqa: E402
from rths3d.network.simapp import Header  # noqa: E402
from rths3d.record import Record  # noqa: E402
from rths3d.scene import load_scene  # noqa: E402

pytestmark = pytest.mark.skipif(not has_openseespy(), reason="needs openseespy")

# the OpenSees side (tests/opensees/sdof_client.py): m (kg), k (N/m), a0 (1/s), F0 (N),
# f (Hz), dt (s)
M, K, A0, F0, F, DT = 10.0, 4.0e4, 2.0, 50.0, 2.0, 1e-3
STEPS = 1000

SCENE = """
name = "served_linear"
dofs = ["z"]
dt = 0.001
duration = {duration}
[numerical]
m = 10.0
c = 20.0
k = 40000.0
[experiment]
kind = "linear"
m = 0.38
k = 8650.0
d = 5.0
[transfer]
kind = "{transfer}"
[network]
port = 0
timeout = {timeout}
"""


def write_scene(tmp_path: Path, transfer: str = "ideal", duration: float = 2.0,
                timeout: float = 2.0) -> Path:
    p = tmp_path / f"lab_{transfer}.toml"
    p.write_text(SCENE.format(transfer=transfer, duration=duration, timeout=timeout))
    return p


def newmark_linear(lab: Lab, steps: int, m: float = M, k: float = K, a0: float = A0,
                   f0: float = F0, f: float = F) -> np.ndarray:
    """OpenSees' Newmark (γ ½, β ¼) with the Linear algorithm on the SDOF of
    tests/opensees/sdof_client.py, its genericClient replaced by ``lab`` called as the
    element calls its server: a trial at the step's start (displacement unchanged, predicted
    velocity and acceleration), tangent, damping, force, the new trial, commit."""
    M, K, A0, F0, F = m, k, a0, f0, f  # noqa: N806
    h = Header((2, 2, 2, 0, 1), (0, 0, 0, 2, 0), 256)
    g, b = 0.5, 0.25
    c2, c3 = g / (b * DT), 1.0 / (b * DT * DT)
    msg, out = np.zeros(256), np.zeros(256)
    U = V = A = 0.0
    u = np.zeros(steps + 1)

    def trial(t: float) -> None:
        msg[:] = 0.0
        msg[0], msg[2], msg[4], msg[6], msg[7] = 3, U, V, A, t
        lab.trial(msg, h)

    for n in range(steps):
        t1 = (n + 1) * DT
        V, A = (1 - g / b) * V + DT * (1 - g / (2 * b)) * A, -V / (b * DT) + (1 - 1 / (2 * b)) * A
        trial(t1)
        lab.reply(13, out, h)
        kt = out[3]
        lab.reply(10, out, h)
        f_el = out[1]
        keff = K + kt + c2 * A0 * M + c3 * M
        R = F0 * np.sin(2 * np.pi * F * t1) - K * U - f_el - A0 * M * V - M * A
        dU = R / keff
        U, V, A = U + dU, V + c2 * dU, A + c3 * dU
        trial(t1)
        lab.commit()
        u[n + 1] = U
    return u


def combined_exact(steps: int, coupled: bool = True) -> np.ndarray:
    """The node's displacement of the coupled continuous system — the SDOF and the linear
    part (m_EXP 0.38 kg on k_EXP 8650 N/m, d_EXP 5 N·s/m) on an ideal transfer — integrated
    to 1e-11 (no partitioning, no Newmark)."""
    from scipy.integrate import solve_ivp

    me, ke, de = (0.38, 8650.0, 5.0) if coupled else (0.38, 0.0, 0.0)

    def rhs(t, s):
        U, V, q, w = s
        f = ke * (U - q) + de * (V - w)  # the part's restoring force on the platform
        return [V, (F0 * np.sin(2 * np.pi * F * t) - K * U - A0 * M * V - f) / M, w, f / me]

    t = np.arange(steps + 1) * DT
    sol = solve_ivp(rhs, (0, t[-1]), [0, 0, 0, 0], t_eval=t, rtol=1e-11, atol=1e-14,
                    method="DOP853")
    return sol.y[0]


def test_generic_client_against_serve_equals_the_in_process_test(tmp_path) -> None:
    """An openseespy genericClient SDOF (1000 steps of 1 ms) against `rths3d serve` with the
    ideal transfer and the linear part: the node's displacement and the served record (z,
    z', F'_m) equal the in-process test to 1e-9 of their peaks; both within 4 % of the peak
    of the coupled continuous system (the partitioned exchange's first-order error at 1 ms:
    3.2 %, 1.8 % at 0.5 ms, 0.9 % at 0.25 ms; a third of the error without the lab's force); the
    record loads in `rths3d metrics`; no
    process of either session is left, nothing listens on the port."""
    scene = write_scene(tmp_path)
    rec_path = tmp_path / "served.parquet"
    server, port = serve(scene, "--out", str(rec_path), "--json")
    client = None
    try:
        client = opensees("sdof_client.py", port, tmp_path / "u.npy", STEPS)
        code_c, err_c = client.finish(120)
        code_s, err_s = server.finish(60)
    finally:
        server.kill()
        if client is not None:
            client.kill()
    assert code_c == 0, err_c
    assert code_s == 0, err_s
    summary = server.json
    assert summary["status"] == "ok" and summary["steps"] == STEPS, summary
    assert summary["header"] == [2, 2, 2, 0, 1, 0, 0, 0, 2, 0, 256]
    assert server.left() == [] and client.left() == []
    assert port_listeners(port) == []

    u_net = np.load(tmp_path / "u.npy")
    lab = Lab(load_scene(scene))
    u_in = newmark_linear(lab, STEPS)
    peak = np.max(np.abs(u_in))
    assert peak > 1e-4
    assert np.max(np.abs(u_net - u_in)) <= 1e-9 * peak
    served, local = Record.load(rec_path), lab.record()
    assert served.n == local.n == STEPS + 1
    for col in ("z_cmd.z", "z_meas.z", "f_meas.z", "x_num.1"):
        a, b = served.columns[col], local.columns[col]
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b)), col
    # z = u2 − u1 with node 1 fixed: the record's command is the node's displacement
    assert np.max(np.abs(served.columns["z_cmd.z"] - u_net)) <= 1e-9 * peak

    exact = combined_exact(STEPS)
    err = np.max(np.abs(u_in - exact)) / np.max(np.abs(exact))
    assert err <= 0.04
    # the check could fail: the SDOF alone (no lab force) is far from the coupled answer
    lone = combined_exact(STEPS, coupled=False)
    assert np.max(np.abs(u_in - exact)) < 0.4 * np.max(np.abs(lone - exact))

    res = subprocess.run([sys.executable, "-m", "rths3d", "metrics", str(rec_path), "--json"],
                         capture_output=True, text=True, cwd=ROOT, env=ENV, timeout=120)
    assert res.returncode == 0, res.stderr
    m = json.loads(res.stdout.strip().splitlines()[-1])
    assert m["e_rel_track"] == pytest.approx(0.0, abs=1e-12)  # ideal transfer: z' = z

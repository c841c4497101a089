"""The issue's must-show for `rths3d serve`: an openseespy SDOF with a `genericClient`
element, in its own process, runs a hybrid test against `rths3d serve` with the paper's
contact part (0.38 kg on 8650 N/m whose tip hits a surface 5 mm above it, 1e5 N/m, 40 N·s/m)
moved by the ideal transfer and by the Stewart platform (MuJoCo), and equals the same test
in-process — the served lab driven through the same call sequence by a Newmark/Linear step
written here from OpenSees' algorithm; the record loads in `rths3d metrics` and
`rths3d view` (headless, as tests/test_view_cli.py runs it); nothing is left running or
listening."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from netproc import ENV, ROOT, has_openseespy, opensees, port_listeners, serve  # noqa: E402
from test_network_serve import newmark_linear  # noqa: E402

from rths3d.network.server import Lab  # noqa: E402
from rths3d.record import Record  # noqa: E402
from rths3d.scene import load_scene  # noqa: E402

pytestmark = pytest.mark.skipif(not has_openseespy(), reason="needs openseespy")

# the OpenSees SDOF (tests/opensees/sdof_client.py): m (kg), k (N/m), a0 (1/s), F0 (N),
# f (Hz), dt (s): a static 8 mm amplitude, so the part's tip (5 mm gap) hits the surface
M, K, A0, F0, F, DT = 10.0, 4.0e4, 2.0, 320.0, 2.0, 1e-3
STEPS = 1000

SCENE = """
name = "served_contact"
dofs = ["z"]
dt = 0.001
duration = 1.0
[numerical]
m = 10.0
c = 20.0
k = 40000.0
[experiment]
kind = "contact"
m = 0.38
k = 8650.0
d = 0.0
h0 = 0.005
k_contact = 1.0e5
d_contact = 40.0
substeps = 4
[transfer]
kind = "{transfer}"
[network]
port = 0
timeout = 5.0
"""


@pytest.mark.parametrize("transfer", ["ideal", "stewart"])
def test_generic_client_contact_part(tmp_path, transfer) -> None:
    """1000 steps of 1 ms: the OpenSees node's displacement and the served record (z, z',
    F'_m) equal the in-process test to 1e-9 of their peaks — with the ideal transfer and
    with the Stewart platform (the served bench is the same deterministic MuJoCo model;
    measured: 1.1e-16 m of a 8.9 mm peak in u, 4.4e-12 N of 30 N in F'_m), stricter than the
    loop's own tolerance; the contact was hit (with the surface out of reach the force
    differs by more than 20 % of its peak); the record loads in `rths3d metrics` (ideal:
    e_rel,track 0; Stewart: measured 0.015) and `rths3d view`."""
    scene = tmp_path / f"contact_{transfer}.toml"
    scene.write_text(SCENE.format(transfer=transfer))
    rec_path = tmp_path / "served.parquet"
    server, port = serve(scene, "--out", str(rec_path), "--json")
    client = None
    try:
        client = opensees("sdof_client.py", port, tmp_path / "u.npy", STEPS, M, K, A0, F0, F,
                          DT)
        code_c, err_c = client.finish(240)
        code_s, err_s = server.finish(60)
    finally:
        server.kill()
        if client is not None:
            client.kill()
    assert code_c == 0, err_c
    assert code_s == 0, err_s
    assert server.json["status"] == "ok" and server.json["steps"] == STEPS, server.json
    assert server.left() == [] and client.left() == [] and port_listeners(port) == []

    u_net = np.load(tmp_path / "u.npy")
    lab = Lab(load_scene(scene))
    u_in = newmark_linear(lab, STEPS, M, K, A0, F0, F)
    peak = np.max(np.abs(u_in))
    assert peak > 0.006  # beyond the 5 mm gap
    assert np.max(np.abs(u_net - u_in)) <= 1e-9 * peak
    served, local = Record.load(rec_path), lab.record()
    assert served.meta["transfer"] == transfer
    assert served.n == local.n == STEPS + 1
    for col in ("z_cmd.z", "z_meas.z", "f_meas.z", "x_num.1"):
        a, b = served.columns[col], local.columns[col]
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b)), col
    # the contact acted: the same test with the surface out of reach (h0 = 0.5 m) gives a
    # force differing by more than 20 % of the peak (measured: the peak 27 N with contact)
    free = Lab(load_scene(scene, ["experiment.h0=0.5", "transfer.kind=ideal"]))
    newmark_linear(free, STEPS, M, K, A0, F0, F)
    f, f_free = served.columns["f_meas.z"], free.record().columns["f_meas.z"]
    assert np.max(np.abs(f - f_free)) > 0.2 * np.max(np.abs(f))

    res = subprocess.run([sys.executable, "-m", "rths3d", "metrics", str(rec_path), "--json"],
                         capture_output=True, text=True, cwd=ROOT, env=ENV, timeout=120)
    assert res.returncode == 0, res.stderr
    m = json.loads(res.stdout.strip().splitlines()[-1])
    assert np.isfinite(m["e_rel_track"])
    if transfer == "ideal":
        assert m["e_rel_track"] == pytest.approx(0.0, abs=1e-12)
    else:
        assert m["e_rel_track"] > 0  # the platform tracks with an error
    res = subprocess.run([sys.executable, "-m", "rths3d", "view", str(rec_path), "--port", "0",
                          "--seconds", "1"], capture_output=True, text=True, cwd=ROOT, env=ENV,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert any(ln.startswith("rths3d view: http://127.0.0.1:") for ln in res.stdout.splitlines())

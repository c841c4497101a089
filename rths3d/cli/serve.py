"""CLI command ``rths3d serve SCENE``: the scene's lab as a SimApp server for one test."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import typer

from ._app import app, json_line
from ._output import Keeper, check_file

RECORD_SUFFIXES = (".parquet", ".csv")


@app.command()
def serve(
    scene: str = typer.Argument(..., help="Scene TOML file (or a name from scenes/)."),
    transfer: str = typer.Option(None, "--transfer", "-t",
                                 help="Transfer system of the lab: ideal | delay | lti | "
                                      "stewart (default: the scene's)."),
    set_: list[str] = typer.Option([], "--set", "-s",
                                   help="Override a scene value, e.g. --set network.port=9000."),
    host: str = typer.Option(None, "--host", help="Address to listen on (default: the "
                                                  "scene's network.host, 127.0.0.1)."),
    port: int = typer.Option(None, "--port", "-p", help="TCP port (default: the scene's "
                                                        "network.port; 0: any free port)."),
    timeout: float = typer.Option(None, "--timeout", help="Longest silence of the client "
                                                          "within a test, s (default: the "
                                                          "scene's network.timeout)."),
    wait: float = typer.Option(None, "--wait", help="Give up when no client connects within "
                                                    "this many s (default: wait for ever)."),
    out: Path = typer.Option(None, "--out", "-o", help="Write the record (.parquet or .csv)."),
    json_: bool = typer.Option(False, "--json", help="Print one JSON object at the end "
                                                     "instead of a summary."),
    rt_priority: int = typer.Option(0, "--rt-priority",
                                    help="Serve under the real-time FIFO scheduler at this "
                                         "priority (1-99; root or CAP_SYS_NICE): answers in "
                                         "time on a loaded machine; 0: the normal scheduler."),
) -> None:
    """Serve SCENE's lab (transfer system + part) to one SimApp client — an OpenSees
    `genericClient` element, an OpenFresco SimApp client or `rths3d run` with transfer kind
    `remote` — and record the test.

    Prints `listening on HOST:PORT` when ready. The test ends when the client sends DIE;
    a client that closes, stops answering (`--timeout`) or sends a malformed message stops it
    safely, as does Ctrl-C: the record keeps every executed step. A header that does not fit
    the lab (sizes, dataSize) or a port in use: one error line, exit code 2.
    """
    from ..errors import ConfigError
    from ..network.server import LabServer
    from ..scene import load_scene, transfer_kinds

    if transfer is not None and transfer not in transfer_kinds():
        raise ConfigError("--transfer", transfer, f"must be one of {', '.join(transfer_kinds())}")
    if transfer == "remote":
        raise ConfigError("--transfer", transfer, "a served lab needs a transfer system of "
                          "its own, not another remote one")
    if timeout is not None and not timeout > 0:
        raise ConfigError("--timeout", timeout, "must be > 0 s")
    if wait is not None and not wait > 0:
        raise ConfigError("--wait", wait, "must be > 0 s")
    if not 0 <= rt_priority <= 99:
        raise ConfigError("--rt-priority", rt_priority, "must be in 0..99 (0: the normal "
                          "scheduler)")
    if out is not None:
        check_file(out, "--out", RECORD_SUFFIXES)
    sc = load_scene(scene, set_)
    if transfer is not None:
        sc = sc.with_transfer(transfer)
    if sc.transfer.kind == "remote":
        raise ConfigError("transfer.kind", "remote", "a served lab needs a transfer system of "
                          "its own: pass --transfer")
    from ..network.pacing import realtime_priority

    prio = contextlib.ExitStack()
    try:
        prio.enter_context(realtime_priority(rt_priority))
    except PermissionError as exc:
        raise ConfigError("--rt-priority", rt_priority, f"the process may not use the "
                          f"real-time scheduler ({exc.strerror}): run as root or with "
                          f"CAP_SYS_NICE, or 0") from None
    server = LabServer(sc, host=host, port=port, timeout=timeout)
    if server.public:
        typer.echo(f"warning: listening on {server.host}, reachable from other machines: "
                   "anyone who connects drives the bench", err=True)
    print(f"listening on {server.host}:{server.port}", flush=True)
    keeper = Keeper()
    try:
        res = server.serve(accept_timeout=wait)
    finally:
        server.close()
        prio.close()
    if out is not None:
        res.out = str(keeper.write(res.record.save, out, "--out"))
    summary = {"status": res.status, "reason": res.reason, "scene": sc.name,
               "transfer": sc.transfer.kind, "steps": res.steps, "messages": res.messages,
               "header": res.header, "wall": res.wall, "out": res.out}
    if json_:
        typer.echo(json_line(summary))
    else:
        typer.echo(f"{sc.name}, lab '{sc.transfer.kind}': {res.status}"
                   + (f" — {res.reason}" if res.reason else ""))
        typer.echo(f"  steps        = {res.steps} ({res.steps * sc.dt:g} s of bench time)")
        typer.echo(f"  messages     = {res.messages} in {res.wall:.3f} s")
        if res.out:
            typer.echo(f"  record       → {res.out}")
    sys.stdout.flush()
    keeper.finish()

"""CLI commands: view (registered on the shared app)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import app, warn_implausible

RECORD_SUFFIXES = (".parquet", ".csv")


VIEW_HELP = (
    "Watch a hybrid test in the browser: run SCENE live, or replay a saved RECORD.\n\n"
    "Prints the address of the page. A live run waits for the first browser to connect, runs "
    "at --speed × real time and can be paused, stopped and restarted from the page.\n\n"
    "The view shows the platform, the sensor, the experimental part, a ghost of the numerical "
    "substructure and the interface force, the SSP (z' against z), time histories of z, z', "
    "z^r and F'_m, and running measures."
)


@app.command(help=VIEW_HELP)
def view(
    target: str = typer.Argument(..., help="A saved record (.parquet/.csv) to replay, or a "
                                 "scene (TOML file or scene name) to run live."),
    host: str = typer.Option("127.0.0.1", help="Address to listen on (127.0.0.1: this "
                             "machine only)."),
    port: int = typer.Option(8080, help="Port to listen on (0: any free port)."),
    speed: float = typer.Option(1.0, help="Replay / run speed, × real time."),
    exaggeration: float = typer.Option(1.0, help="Display factor k on platform motions "
                                       "(1 = true scale)."),
    span: float = typer.Option(2.0, help="Length of the panels' time window (s)."),
    rate: float = typer.Option(30.0, help="View updates per second (at most 30)."),
    transfer: str = typer.Option("", help="Live run: transfer system (default: the scene's)."),
    seconds: float = typer.Option(0.0, help="Serve this long (s) and exit; 0 = until Ctrl-C."),
    out: str = typer.Option("", help="Live run: save the record here on exit "
                            "(.parquet/.csv)."),
    autostart: bool = typer.Option(True, help="Live run: start when the first page connects "
                                   "(--no-autostart: wait for Run / Resume on the page, to "
                                   "choose the transfer system and parameters first)."),
    set_: list[str] = typer.Option([], "--set", help="Live run: scene override KEY=VALUE "
                                   "(dotted keys, e.g. numerical.k=5000; repeatable)."),
) -> None:
    """Watch a hybrid test in the browser (help text: VIEW_HELP)."""
    import signal
    import sys
    import threading
    import time

    from ..errors import ConfigError

    if not 0 < rate <= 30:
        raise ConfigError("--rate", rate, "updates per second must be in (0, 30]")
    if seconds < 0:
        raise ConfigError("--seconds", seconds, "must be >= 0")
    if not span > 0:
        raise ConfigError("--span", span, "window length must be > 0 s")
    if not exaggeration >= 1:
        raise ConfigError("--exaggeration", exaggeration, "display factor must be >= 1")
    from ..viz.app import check_host, check_port

    check_host(host, "--host")
    check_port(host, port, "--port")
    replay = Path(target).suffix.lower() in RECORD_SUFFIXES
    if replay:
        from ..viz.playback import MAX_SPEED, MIN_SPEED

        if not MIN_SPEED <= speed <= MAX_SPEED:
            raise ConfigError("--speed", speed, f"must be within [{MIN_SPEED}, {MAX_SPEED}] "
                              "× real time")
        for option, given in (("--transfer", transfer), ("--set", set_), ("--out", out)):
            if given:
                raise ConfigError(option, given, "applies to a live scene run only, not to "
                                  "the replay of a record")
    else:
        if not 0 <= speed <= 100:
            raise ConfigError("--speed", speed, "must be within [0, 100] × real time "
                              "(0: unpaced)")
        if out:
            from ._output import check_file

            if Path(out).suffix.lower() not in RECORD_SUFFIXES:
                raise ConfigError("--out", out, "the record file must end in .parquet or .csv")
            check_file(out, "--out")
    common = dict(host=host, port=port, exaggeration=exaggeration, span=span, rate=rate)
    if replay:
        from ..record import Record
        from ..viz import Viewer, buffer_from_record

        record = Record.load(target)
        warn_implausible(record, target)
        viewer = Viewer(buffer_from_record(record), speed=speed,
                        title=f"rths3d · {Path(target).name}", **common)
        run = None
    else:
        from ..viz.live import LiveRun

        run = LiveRun.from_scene(target, transfer=transfer or None, speed=speed,
                                 out=out or None, overrides=set_)
        # The page is served from its own process so that watching does not slow the loop.
        viewer = run.view_process(autostart=autostart, **common)
    # SIGTERM (a service manager, `kill`) shuts down like Ctrl-C: the view process ends,
    # the shared memory is freed and the record is saved
    main_thread = threading.current_thread() is threading.main_thread()
    if main_thread:
        def _terminate(signum, frame):
            raise KeyboardInterrupt

        previous = signal.signal(signal.SIGTERM, _terminate)
    keeper = None
    started = False
    try:
        try:
            viewer.start()
            started = True
            picked = " (--port 0: a free port was picked)" if port == 0 else ""
            typer.echo(f"rths3d view: {viewer.url}{picked}  (Ctrl-C to stop)", err=False)
            sys.stdout.flush()
            if seconds > 0:
                time.sleep(seconds)
            else:
                viewer.wait()
        except KeyboardInterrupt:
            pass
        finally:
            if main_thread:  # no second interruption halfway through the clean-up
                signal.signal(signal.SIGTERM, signal.SIG_IGN)
            viewer.stop()
            if run is not None and not started:  # the view failed: nothing ran to save
                run.out = None
            if run is not None:
                from ._output import Keeper

                keeper = Keeper()  # a record --out refuses now is kept elsewhere
                saved = run.close(save=lambda rec, path: keeper.write(rec.save, path, "--out"))
                if saved:
                    typer.echo(f"record saved: {saved}")
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, previous)
    if keeper is not None:
        keeper.finish()

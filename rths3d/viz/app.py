"""The viewer: a viser server showing one stream of samples live or in replay.

The view pulls from the stream (a :class:`rths3d.record.RecordBuffer`) in its own thread at
most ``rate`` times per second; the loop that fills the buffer never calls the view. Each
update reads the newest sample (live) or the sample at the playback time (replay), moves the
3-D scene to it and sends the panels a decimated window ending there.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from numbers import Integral
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..platform import StewartGeometry
from ..record import DOFS, RecordBuffer
from .measures import RunningMeasures
from .panels import (
    coefficient_data,
    coefficient_unit,
    fidelity_cols,
    fidelity_data,
    history_data,
    leg_columns,
    leg_data,
    leg_residual_data,
    ssp_data,
    stride,
    window,
)
from .playback import Playback
from .scene3d import PlatformScene, geometry_from_meta
from .stream import Channels, channels, coefficient_columns, stream_dofs

MAX_RATE = 30.0
"""Most view updates per second (the issue's ≤ 30 Hz)."""

UNITS = {"x": "m", "y": "m", "z": "m", "rx": "rad", "ry": "rad", "rz": "rad"}
FORCE_UNITS = {"x": "N", "y": "N", "z": "N", "rx": "N·m", "ry": "N·m", "rz": "N·m"}


@dataclass
class RunControl:
    """What a live run offers the view's controls (filled by :mod:`rths3d.viz.live`).

    ``transfers`` lists the transfer systems to choose from; ``params`` maps a key parameter
    to ``(value, min, max, step)`` (SI). ``restart(transfer, params)`` starts a new run and
    returns its buffer; ``pause``/``resume``/``stop`` act on the running one;
    ``set_speed(s)`` paces it at ``s`` × real time.
    """

    transfers: tuple[str, ...]
    transfer: str
    params: dict[str, tuple[float, float, float, float]]
    restart: Callable[[str, dict[str, float]], RecordBuffer]
    pause: Callable[[], None]
    resume: Callable[[], None]
    stop: Callable[[], None]
    set_speed: Callable[[float], None]
    status: Callable[[], str] = field(default=lambda: "")
    paused: bool = False
    """The run waits (paused) for the page's Resume or Run / restart."""


COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")
"""Line colours of the compensator's channels (six legs at most)."""

def check_host(host: str, field: str = "host", timeout: float = 5.0) -> None:
    """ConfigError unless ``host`` resolves (within ``timeout`` s) to an address of this
    machine that a server can bind (viser would otherwise wait forever)."""
    import socket

    found: dict[str, Any] = {}

    def _resolve() -> None:
        try:
            found["infos"] = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)
        except (OSError, UnicodeError):
            pass

    worker = threading.Thread(target=_resolve, name="rths3d-resolve", daemon=True)
    worker.start()
    worker.join(timeout)
    for family, kind, proto, _, addr in found.get("infos", ()):
        try:
            with socket.socket(family, kind, proto) as sock:
                sock.bind((addr[0], 0, *addr[2:]))
            return
        except OSError:
            continue
    raise ConfigError(field, host, "not an address of this machine")


def check_port(host: str, port: int, field: str = "port") -> None:
    """ConfigError unless ``port`` is a TCP port (0: any free one) that a server can bind on
    ``host`` now; a port another server holds is named as such (viser would quietly serve
    on the next free port instead)."""
    import socket

    if isinstance(port, bool) or not isinstance(port, Integral) or not 0 <= port <= 65535:
        raise ConfigError(field, port, "must be a TCP port in [0, 65535] (0: any free port)")
    if port == 0:
        return
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except (OSError, UnicodeError):
        return  # an unknown host is check_host's to report
    for family, kind, proto, _, addr in infos[:1]:
        with socket.socket(family, kind, proto) as sock:
            # as the server will: a port left in TIME_WAIT by a previous run is free
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                sock.bind(addr)
            except OSError as exc:
                raise ConfigError(field, port, f"cannot listen on {host}: "
                                  f"{exc.strerror or exc} (another server holds it? "
                                  "--port 0 picks a free port)") from None


class Viewer:
    """Browser view of a stream of samples (live) or of a saved record (replay).

    Parameters
    ----------
    buffer:
        The stream: a :class:`RecordBuffer` the loop is filling (``live=True``) or a full one
        (see :func:`rths3d.viz.stream.buffer_from_record`).
    live:
        Follow the newest sample instead of a playback clock.
    geometry:
        Platform geometry (default: from ``buffer.meta['geometry']`` or the default one).
    host, port:
        Where the server listens (127.0.0.1 by default; port 0 picks a free port).
    rate:
        View updates per second, at most :data:`MAX_RATE`.
    span:
        Length of the panels' time window (s).
    exaggeration:
        Display factor k on platform motions (1 = true scale).
    speed:
        Replay speed (record s per wall s).
    control:
        Live-run controls, or None.
    """

    def __init__(self, buffer: RecordBuffer, *, live: bool = False,
                 geometry: StewartGeometry | None = None, host: str = "127.0.0.1",
                 port: int = 8080, rate: float = MAX_RATE, span: float = 2.0,
                 exaggeration: float = 1.0, speed: float = 1.0,
                 control: RunControl | None = None, title: str = "rths3d"):
        if not 0 < rate <= MAX_RATE:
            raise ConfigError("rate", rate, f"updates per second must be in (0, {MAX_RATE}]")
        if not span > 0:
            raise ConfigError("span", span, "window length in s must be > 0")
        if not exaggeration >= 1:
            raise ConfigError("exaggeration", exaggeration, "display factor must be >= 1")
        if isinstance(port, bool) or not isinstance(port, Integral) or not 0 <= port <= 65535:
            raise ConfigError("port", port, "must be a TCP port in [0, 65535] (0: any free port)")
        self.buffer = buffer
        self.live = live
        self.geometry = geometry or geometry_from_meta(buffer.meta)
        self.rate = float(rate)
        self.span = float(span)
        self.control = control
        self.title = title
        self._host, self._port = host, int(port)
        self._exaggeration = float(exaggeration)
        self._speed = float(speed)
        self.dofs = stream_dofs(buffer.columns) or ("z",)
        self.dof = "z" if "z" in self.dofs else self.dofs[0]
        self.playback: Playback | None = None
        if not live:
            if buffer.n < 2:
                raise ConfigError("record", buffer.n, "replay needs at least 2 samples")
            t = buffer.data[: buffer.n, 0]
            self.playback = Playback(float(t[0]), float(t[-1]), speed=speed)
        self.on_first_client: Callable[[], None] | None = None
        """Called once when the first browser connects (a live run starts then)."""
        self.updates = 0
        """View updates sent so far (scene and panels moved to a new sample)."""
        self.server: Any = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._lock = threading.RLock()
        self._last_i = -1
        self._leg = 0
        self.leg_dropdown = None
        self.leg_plot = self.legres_plot = None
        self._legs = None
        self._dirty = True
        self._last_measure = -math.inf
        self._wrench_max = (0.0, 0.0)

    # ------------------------------------------------------------------ lifecycle
    @property
    def url(self) -> str:
        """Address of the page (http)."""
        return f"http://{self._host}:{self.port}"

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return int(self.server.get_port()) if self.server is not None else self._port

    def start(self) -> Viewer:
        """Start the server, build the scene and panels and begin updating."""
        import viser

        check_host(self._host)
        check_port(self._host, self._port)
        self.server = viser.ViserServer(host=self._host, port=self._port, verbose=False)
        if self._port and self.server.get_port() != self._port:
            # taken between the check and the server's start: viser moved to the next port
            self.server.stop()
            self.server = None
            raise ConfigError("port", self._port, f"cannot listen on {self._host}: in use "
                              "(--port 0 picks a free port)")
        self.server.gui.configure_theme(control_width="large", dark_mode=False,
                                        show_logo=False)
        self.server.initial_camera.position = (0.9, -1.05, 0.8)
        self.server.initial_camera.look_at = (-0.2, 0.0, 0.36)
        # Replay from the start (or let a paused live run begin) for whoever opens the page
        # first.
        first = threading.Event()

        def _on_connect(_client: Any) -> None:
            if not first.is_set():
                first.set()
                if self.playback is not None:
                    self.playback.restart()
                if self.on_first_client is not None:
                    self.on_first_client()

        self.server.on_client_connect(_on_connect)
        self.scene = PlatformScene(self.server, self.buffer, self.geometry)
        self.scene.exaggeration = self._exaggeration
        self._build_gui()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="rths3d-view", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop updating and shut the server down."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        if self.server is not None:
            self.server.stop()
            self.server = None

    def __enter__(self) -> Viewer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def wait(self) -> None:
        """Block until interrupted (Ctrl-C) — for the command line."""
        try:
            while not self._stop.is_set():
                time.sleep(0.2)
        except KeyboardInterrupt:
            pass

    # ------------------------------------------------------------------ GUI
    def _build_gui(self) -> None:
        gui = self.server.gui
        gui.add_markdown(f"**{self.title}** — " + ("live run" if self.live else "replay")
                         + f" · {self._describe()}")
        if self.control is not None:
            self._build_run_controls()
        with gui.add_folder("Playback" if not self.live else "View"):
            if not self.live:
                self.play_button = gui.add_button("Pause", icon=None)
                self.play_button.on_click(lambda _: self._toggle_play())
                t0, t1 = self.playback.t_start, self.playback.t_end
                step = max(self.buffer.data[1, 0] - self.buffer.data[0, 0], (t1 - t0) / 2000)
                self.time_slider = gui.add_slider("time (s)", min=t0, max=t1, step=step,
                                                  initial_value=t0)
                self.time_slider.on_update(self._on_scrub)
                restart = gui.add_button("Restart")
                restart.on_click(lambda _: self._restart_replay())
            self.speed_slider = gui.add_slider("speed (× real time)", min=0.1, max=4.0,
                                               step=0.1, initial_value=min(self._speed, 4.0))
            self.speed_slider.on_update(self._on_speed)
            if len(self.dofs) > 1:
                self.dof_dropdown = gui.add_dropdown("DOF", options=self.dofs,
                                                     initial_value=self.dof)
                self.dof_dropdown.on_update(self._on_dof)
            self.exag_slider = gui.add_slider("motion exaggeration k", min=1.0, max=200.0,
                                              step=1.0, initial_value=self._exaggeration)
            self.exag_slider.on_update(self._on_exaggeration)
            self.span_slider = gui.add_slider("window (s)", min=0.2, max=20.0, step=0.1,
                                              initial_value=min(self.span, 20.0))
            self.span_slider.on_update(self._on_span)
        self._channels = channels(self.buffer.index, self.dof)
        self._build_panels()
        self.comp_folder: Any = None
        self._build_compensator()
        self._build_leg_panels()
        self.fid_folder = gui.add_folder("Fidelity estimate (surrogate reference)")
        self.fid_plot: Any = None
        self._build_fidelity()
        with gui.add_folder("Running measures"):
            self.measures = RunningMeasures(self.buffer.meta)
            self.measures_md = gui.add_markdown(self.measures.markdown(None))

    def _describe(self) -> str:
        meta = self.buffer.meta
        parts = [str(meta[k]) for k in ("scene", "transfer") if meta.get(k)]
        if meta.get("status") == "stopped" and meta.get("reason"):
            parts.append(f"stopped: {meta['reason']}")
        return ", ".join(parts) or "unnamed test"

    def _build_panels(self) -> None:
        gui = self.server.gui
        ch = self._channels
        u, fu = UNITS[ch.dof], FORCE_UNITS[ch.dof]
        model = ch.has_model
        empty = np.zeros(2)
        with gui.add_folder("Panels"):
            ssp_series = [{"label": f"z ({u})"},
                          {"label": "z' measured", "stroke": "rgba(0,0,0,0)",
                           "points": {"show": True, "size": 4, "stroke": "#1f77b4",
                                      "fill": "#1f77b4"}},
                          {"label": "z' = z", "stroke": "#999999", "width": 1,
                           "points": {"show": False}}]
            if model:
                ssp_series.append({"label": "z' model", "stroke": "rgba(0,0,0,0)",
                                   "points": {"show": True, "size": 3, "stroke": "#ff7f0e",
                                              "fill": "#ff7f0e"}})
            self.ssp_plot = gui.add_uplot(
                data=tuple(empty for _ in ssp_series), series=tuple(ssp_series),
                title=f"SSP: z' against z ({ch.dof})", scales={"x": {"time": False}},
                axes=({}, {"size": 64}), aspect=1.2)
            disp_series = [{"label": "t (s)"},
                           {"label": f"z ({u})", "stroke": "#2ca02c", "width": 1.5},
                           {"label": "z' meas.", "stroke": "#1f77b4", "width": 1.5},
                           {"label": "z^r", "stroke": "#9467bd", "width": 1, "dash": [4, 4]}]
            force_series = [{"label": "t (s)"},
                            {"label": f"F'_m meas. ({fu})", "stroke": "#d62728", "width": 1.5}]
            if model:
                disp_series.append({"label": "z' model", "stroke": "#ff7f0e", "width": 1.5,
                                    "dash": [6, 3]})
                force_series.append({"label": "F'_m model", "stroke": "#ff7f0e",
                                     "width": 1.5, "dash": [6, 3]})
            self.disp_plot = gui.add_uplot(
                data=tuple(empty for _ in disp_series), series=tuple(disp_series),
                title=f"z, z', z^r ({ch.dof}, {u})", scales={"x": {"time": False}},
                axes=({}, {"size": 64}), aspect=2.0)
            self.force_plot = gui.add_uplot(
                data=tuple(empty for _ in force_series), series=tuple(force_series),
                title=f"F'_m ({ch.dof}, {fu})", scales={"x": {"time": False}},
                axes=({}, {"size": 64}), aspect=2.4)

    def _build_compensator(self) -> None:
        """The compensator's coefficients over time, one line per channel (interface DOF or
        leg), for the coefficient chosen; nothing when the stream has none."""
        self._coefs = coefficient_columns(self.buffer.index)
        self.coef_plot = None
        if not self._coefs:
            return
        gui = self.server.gui
        names = list(self._coefs)
        if getattr(self, "coef", None) not in names:
            self.coef = "a1" if "a1" in names else ("lead" if "lead" in names else names[0])
        comp = (self.buffer.meta.get("transfer_meta") or {}).get("compensator") or {}
        label = f"{comp.get('name', 'compensator')} ({comp.get('compensate', 'interface')})"
        self.comp_folder = gui.add_folder(f"Compensator: {label}")
        with self.comp_folder:
            if len(names) > 1:
                self.coef_dropdown = gui.add_dropdown("coefficient", options=names,
                                                      initial_value=self.coef)
                self.coef_dropdown.on_update(self._on_coef)
        self._build_coef_plot()

    def _build_coef_plot(self) -> None:
        gui = self.server.gui
        cols = self._coefs[self.coef]
        unit = coefficient_unit(self.coef)
        series = [{"label": "t (s)"}] + [
            {"label": ch, "stroke": COLORS[i % len(COLORS)], "width": 1.5}
            for i, (ch, _) in enumerate(cols)]
        with self.comp_folder:
            self.coef_plot = gui.add_uplot(
                data=tuple(np.zeros(2) for _ in series), series=tuple(series),
                title=f"{self.coef} ({unit}) over time", scales={"x": {"time": False}},
                axes=({}, {"size": 72}), aspect=2.4)

    def _on_coef(self, _: Any) -> None:
        with self._lock:
            self.coef = str(self.coef_dropdown.value)
            if self.coef_plot is not None:
                self.coef_plot.remove()
            self._build_coef_plot()

    def _build_leg_panels(self) -> None:
        """Measurement and model leg by leg (a diagnosis replay with ``model.leg_force.*``):
        one leg's force, measured and model, and every leg's residual in noise units."""
        self.leg_plot = self.legres_plot = None
        self._legs = leg_columns(self.buffer.index)
        if self._legs is None:
            return
        gui = self.server.gui
        empty = np.zeros(2)
        with gui.add_folder("Legs: measurement and model"):
            self.leg_dropdown = gui.add_dropdown("leg", options=[str(i) for i in range(6)],
                                                 initial_value=str(self._leg))
            self.leg_dropdown.on_update(self._on_leg)
            series = [{"label": "t (s)"},
                      {"label": "measured (N)", "stroke": "#1f77b4", "width": 1.5},
                      {"label": "model (N)", "stroke": "#ff7f0e", "width": 1.5, "dash": [6, 3]}]
            self.leg_plot = gui.add_uplot(
                data=tuple(empty for _ in series), series=tuple(series),
                title="leg forces of the chosen leg: measured and model (N)",
                scales={"x": {"time": False}}, axes=({}, {"size": 64}), aspect=2.4)
            colours = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")
            rseries = [{"label": "t (s)"}] + [
                {"label": f"leg {i}", "stroke": c, "width": 1} for i, c in enumerate(colours)]
            self.legres_plot = gui.add_uplot(
                data=tuple(empty for _ in rseries), series=tuple(rseries),
                title="residual per leg (leg force, noise units)",
                scales={"x": {"time": False}}, axes=({}, {"size": 64}), aspect=2.4)

    def _on_leg(self, _: Any) -> None:
        with self._lock:
            self._leg = int(self.leg_dropdown.value)
            self._dirty = True

    def _build_run_controls(self) -> None:
        gui, ctl = self.server.gui, self.control
        with gui.add_folder("Run"):
            self.transfer_dropdown = gui.add_dropdown("transfer system", options=ctl.transfers,
                                                      initial_value=ctl.transfer)
            self.param_inputs = {
                name: gui.add_number(name, initial_value=v, min=lo, max=hi, step=st)
                for name, (v, lo, hi, st) in ctl.params.items()}
            run = gui.add_button("Run / restart")
            run.on_click(lambda _: self._restart_live())
            self.pause_button = gui.add_button("Resume" if ctl.paused else "Pause")
            self.pause_button.on_click(lambda _: self._toggle_live_pause())
            stop = gui.add_button("Stop")
            stop.on_click(lambda _: ctl.stop())
            self.status_md = gui.add_markdown(ctl.status() or "running")

    # ------------------------------------------------------------------ callbacks
    def _toggle_play(self) -> None:
        pb = self.playback
        if pb.playing:
            pb.pause()
            self.play_button.label = "Play"
        else:
            pb.play()
            self.play_button.label = "Pause"
        self._dirty = True

    def _on_scrub(self, event: Any) -> None:
        if event.client is None:  # our own update of the slider while playing
            return
        self.playback.seek(float(self.time_slider.value))
        self._dirty = True

    def _restart_replay(self) -> None:
        self.playback.restart()
        self.play_button.label = "Pause"
        self._dirty = True

    def _on_speed(self, _: Any) -> None:
        s = float(self.speed_slider.value)
        if self.playback is not None:
            self.playback.set_speed(s)
        elif self.control is not None:
            self.control.set_speed(s)

    def _build_fidelity(self) -> None:
        """The running RMS of the estimated error ê = z' − ẑ^r of the chosen DOF with the
        members' band and the monitor's limit (records with the surrogate's columns)."""
        self._fid = fidelity_cols(self.buffer.index, self.dof)
        self.fid_folder.visible = self._fid is not None
        if self._fid is None:
            return
        fid = self.buffer.meta.get("fidelity") or {}
        self._fid_limit = float(fid.get("limit", math.nan))
        unit = UNITS.get(self.dof, "")
        series = ({"label": "t (s)"},
                  {"label": f"ê RMS ({unit})", "stroke": "#d62728", "width": 1.5},
                  {"label": "band low", "stroke": "#d6272855", "width": 0.5},
                  {"label": "band high", "stroke": "#d6272855", "width": 0.5},
                  {"label": f"limit ({unit})", "stroke": "#444", "width": 1, "dash": [4, 4]})
        with self.fid_folder:
            self.fid_plot = self.server.gui.add_uplot(
                data=tuple(np.zeros(2) for _ in series), series=series,
                bands=({"series": (3, 2), "fill": "#d6272822"},),
                title=f"running RMS of ê = z' − ẑ^r, {self.dof} ({unit}, 0.25 s)",
                scales={"x": {"time": False}}, axes=({}, {"size": 72}), aspect=2.4)

    def _on_dof(self, _: Any) -> None:
        with self._lock:
            self.dof = str(self.dof_dropdown.value)
            self._channels = channels(self.buffer.index, self.dof)
            for h in (self.ssp_plot, self.disp_plot, self.force_plot):
                h.remove()
            self._build_panels()
            if self.fid_plot is not None:
                self.fid_plot.remove()
                self.fid_plot = None
            self._build_fidelity()
            self._dirty = True

    def _on_exaggeration(self, _: Any) -> None:
        self.scene.exaggeration = float(self.exag_slider.value)
        self._dirty = True

    def _on_span(self, _: Any) -> None:
        self.span = float(self.span_slider.value)
        self._dirty = True

    def _restart_live(self) -> None:
        params = {k: float(h.value) for k, h in self.param_inputs.items()}
        try:
            buffer = self.control.restart(str(self.transfer_dropdown.value), params)
        except Exception as exc:  # a bad value: say so in the page, keep the old run shown
            self.status_md.content = f"**could not restart:** {exc}"
            return
        self.set_buffer(buffer)
        self.pause_button.label = "Pause"

    def set_buffer(self, buffer: RecordBuffer) -> None:
        """Show another stream from now on (a restarted run). Columns may differ (another
        transfer system records the platform pose, for example): the scene and panels are
        rebuilt then."""
        with self._lock:
            same = buffer.columns == self.buffer.columns
            self.buffer = buffer
            self._last_i = -1
            self._wrench_max = (0.0, 0.0)
            self.measures = RunningMeasures(buffer.meta)
            if not same and self.server is not None:
                self.dofs = stream_dofs(buffer.columns) or ("z",)
                if self.dof not in self.dofs:
                    self.dof = "z" if "z" in self.dofs else self.dofs[0]
                self.server.scene.reset()
                self.scene = PlatformScene(self.server, buffer, self.geometry)
                self.scene.exaggeration = float(self.exag_slider.value)
                if self.comp_folder is not None:
                    self.comp_folder.remove()
                    self.comp_folder = None
                self._build_compensator()
            self._channels = channels(buffer.index, self.dof)
            self._dirty = True

    def _toggle_live_pause(self) -> None:
        if self.pause_button.label == "Pause":
            self.control.pause()
            self.pause_button.label = "Resume"
        else:
            self.control.resume()
            self.pause_button.label = "Pause"

    # ------------------------------------------------------------------ updates
    def _run(self) -> None:
        period = 1.0 / self.rate
        next_t = time.monotonic()
        while not self._stop.is_set():
            try:
                self.tick()
            except Exception as exc:  # keep the view alive; say what went wrong once
                print(f"rths3d view: update failed: {exc!r}")
                self._stop.wait(1.0)
            next_t += period
            delay = next_t - time.monotonic()
            if delay < 0:  # behind: do not try to catch up with a burst
                next_t = time.monotonic()
                delay = 0.0
            self._stop.wait(delay)

    def current_index(self) -> int:
        """Row of the sample shown now (−1 while the stream is empty)."""
        buf = self.buffer
        n = buf.n
        if n == 0:
            return -1
        if self.live:
            return n - 1
        t = buf.data[:n, 0]
        return max(0, min(n - 1, int(np.searchsorted(t, self.playback.time(), "right")) - 1))

    def tick(self) -> bool:
        """One view update; returns True when something new was sent."""
        with self._lock:
            buf = self.buffer
            i = self.current_index()
            if i < 0 or (i == self._last_i and not self._dirty):
                return False
            data = buf.data
            row = data[i].copy()
            ch: Channels = self._channels
            i0, i1 = window(data[:, 0], i, self.span)
            rows = stride(i0, i1)
            self._update_wrench_scale(data, i)
            with self.server.atomic():
                self.scene.update(row)
                self.ssp_plot.data = ssp_data(data, ch, rows)
                disp, force = history_data(data, ch, rows)
                self.disp_plot.data = disp
                self.force_plot.data = force
                if self.coef_plot is not None:
                    self.coef_plot.data = coefficient_data(data, ch.t, self._coefs[self.coef],
                                                           rows)
                if self.fid_plot is not None:
                    self.fid_plot.data = fidelity_data(data, ch.t, self._fid, rows,
                                                       self._fid_limit)
                if self.leg_plot is not None:
                    meas, model, res = self._legs
                    self.leg_plot.data = leg_data(data, ch.t, int(meas[self._leg]),
                                                  int(model[self._leg]), rows)
                    self.legres_plot.data = leg_residual_data(data, ch.t, res, rows)
                if not self.live:
                    self.time_slider.value = float(row[0])
            now = time.monotonic()
            if now - self._last_measure >= 0.5:
                self._last_measure = now
                self.measures_md.content = self.measures.markdown(
                    self.measures.compute(data, ch, i0, i1))
                if self.control is not None:
                    self.status_md.content = self.control.status() or "running"
            self._last_i = i
            self._dirty = False
            self.updates += 1
            return True

    def _update_wrench_scale(self, data: np.ndarray, i: int) -> None:
        """Arrow scale from the largest |force| / |torque| seen (whole record in replay)."""
        if not self.live and self._wrench_max != (0.0, 0.0):
            return
        idx = self.buffer.index
        fc = [idx[f"f_meas.{d}"] for d in DOFS[:3] if f"f_meas.{d}" in idx]
        tc = [idx[f"f_meas.{d}"] for d in DOFS[3:] if f"f_meas.{d}" in idx]
        stop = self.buffer.n if not self.live else i + 1
        start = 0 if not self.live else max(0, min(self._last_i, i))
        fmax = float(np.max(np.abs(data[start:stop, fc]))) if fc else 0.0
        tmax = float(np.max(np.abs(data[start:stop, tc]))) if tc else 0.0
        fmax, tmax = max(fmax, self._wrench_max[0]), max(tmax, self._wrench_max[1])
        if (fmax, tmax) != self._wrench_max:
            self._wrench_max = (fmax, tmax)
            self.scene.set_wrench_scale(fmax, tmax)

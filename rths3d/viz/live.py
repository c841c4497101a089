"""A live run for the view: the loop in a worker thread, paced, pausable, restartable.

The loop (:func:`rths3d.loop.run`) writes its :class:`~rths3d.record.RecordBuffer` and checks
its :class:`~rths3d.loop.LoopControl` every few steps; it never calls the view. Here a
:class:`PacedControl` — a LoopControl whose ``wait`` also sleeps so that simulated time runs
at ``speed`` × wall time — lets the view's controls pause, resume, stop, change the speed and
restart with another transfer system or parameters.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..errors import ConfigError, RthsError
from ..loop import LoopControl, RunResult, run
from ..record import RecordBuffer
from ..scene import Scene, load_scene, scene_with, transfer_kinds
from .app import RunControl, Viewer

KEY_PARAMS: dict[str, tuple[float, float, float]] = {
    "numerical.m": (1e-3, 1e4, 0.01),
    "numerical.c": (0.0, 1e5, 1.0),
    "numerical.k": (0.0, 1e8, 10.0),
    "experiment.h0": (0.0, 0.05, 0.0005),
    "excitation.frequency": (0.01, 50.0, 0.01),
    "excitation.overtravel": (0.0, 0.05, 0.0005),
    "excitation.amplitude": (0.0, 1e4, 0.001),
    "transfer.delay": (0.0, 0.1, 0.001),
}
"""Scene parameters offered before a (re)start: name → (min, max, step), SI units. Only those
the scene has (and, for the numerical matrices, single-DOF scalars) are shown."""

CHECK_EVERY = 20
"""Steps between the loop's looks at its control (pacing, pause, stop, buffer length)."""


PUBLISH_RATE = 30.0
"""Most copies per second of new samples to a view process."""


class PacedControl(LoopControl):
    """Pause / stop like :class:`LoopControl`, plus pacing at ``speed`` × real time, plus
    publishing new samples to a view process.

    ``speed = 0`` runs as fast as the machine allows. Pacing is anchored afresh after every
    pause or speed change, so a resumed run does not race to catch up. With a
    ``stream_factory`` the loop's own thread, at its control checks (every CHECK_EVERY steps)
    and at most PUBLISH_RATE times a second, copies the rows written since the last copy into
    the shared-memory stream the factory made for its buffer: no other thread of the loop's
    process wakes up to feed the view, so the loop never waits for the GIL because of it.
    """

    def __init__(self, buffers: list[RecordBuffer], speed: float = 1.0,
                 stream_factory: Any = None):
        super().__init__(realtime=False, every=CHECK_EVERY)
        self._buffers = buffers
        self._anchor: tuple[float, float] | None = None
        self.speed = _check_speed(speed)
        self._factory = stream_factory
        self._stream: Any = None
        self._next_publish = 0.0

    def set_speed(self, speed: float) -> None:
        """Run at ``speed`` × real time from now on (0: unpaced)."""
        self.speed = _check_speed(speed)
        self._anchor = None

    def pause(self) -> None:
        super().pause()
        self._anchor = None

    def wait(self) -> None:
        if self._factory is not None and self._buffers:
            if self._stream is None:
                self._stream = self._factory(self._buffers[0])
            now = time.perf_counter()
            if now >= self._next_publish:
                self._stream.publish()
                self._next_publish = now + 1.0 / PUBLISH_RATE
        super().wait()
        if self.speed <= 0 or not self._buffers:
            return
        buf = self._buffers[0]
        t_sim = float(buf.data[buf.n - 1, 0])
        now = time.perf_counter()
        anchor = self._anchor
        if anchor is None:
            self._anchor = (now, t_sim)
            return
        ahead = anchor[0] + (t_sim - anchor[1]) / self.speed - now
        if ahead > 0:
            time.sleep(ahead)


def _check_speed(speed: float) -> float:
    s = float(speed)
    if not 0 <= s <= 100:
        raise ConfigError("speed", s, "must be within [0, 100] × real time (0: unpaced)")
    return s


def load_target(target: str, overrides: list[str] | tuple[str, ...] = ()) -> Scene:
    """A scene from a TOML path or a scene name (``paper_contact``), with ``KEY=VALUE``
    overrides."""
    if Path(target).suffix.lower() not in ("", ".toml"):
        raise ConfigError("scene", target, "expected a scene (.toml or name) or a record "
                          "(.parquet/.csv)")
    return load_scene(target, list(overrides))


class LiveRun:
    """One test running in a worker thread, restartable from the view.

    Parameters
    ----------
    scene:
        The scene to run.
    transfer:
        Transfer system (default: the scene's).
    speed:
        Pace in × real time (0: unpaced).
    start_paused:
        Hold the loop before its first step until :meth:`resume` (the view resumes when the
        first browser connects, so nobody misses the start).
    out:
        Save the record of the last run there on :meth:`close` (.parquet/.csv).
    reference:
        Compute the reference solution z^r when a run ends (the loop does it then; the view
        shows z^r from that moment).
    """

    def __init__(self, scene: Scene, *, transfer: str | None = None, speed: float = 1.0,
                 start_paused: bool = False, out: str | None = None, reference: bool = True):
        self.scene = scene.with_transfer(transfer) if transfer else scene
        self.speed = _check_speed(speed)
        self.start_paused = start_paused
        self.out = out
        self.reference = reference
        self.result: RunResult | None = None
        self.error: BaseException | None = None
        self._thread: threading.Thread | None = None
        self._buffers: list[RecordBuffer] = []
        self.stream_factory: Any = None
        """Set by a view process: makes the shared stream of each new run's buffer."""
        self.control = PacedControl(self._buffers, self.speed)

    @classmethod
    def from_scene(cls, target: str, *, transfer: str | None = None, speed: float = 1.0,
                   out: str | None = None, overrides: list[str] | tuple[str, ...] = ()
                   ) -> LiveRun:
        """A live run of a scene file or name, paused until a browser connects."""
        return cls(load_target(target, overrides), transfer=transfer, speed=speed,
                   start_paused=True, out=out)

    # ------------------------------------------------------------------ running
    def start(self, timeout: float = 60.0) -> RecordBuffer:
        """Start the loop; returns its buffer as soon as the loop has created it."""
        self._buffers.clear()
        self.result, self.error = None, None
        self.control = PacedControl(self._buffers, self.speed, self.stream_factory)
        if self.start_paused:
            self.control.pause()
        self._thread = threading.Thread(target=self._work, name="rths3d-loop", daemon=True)
        self._thread.start()
        t_end = time.monotonic() + timeout
        while not self._buffers:
            if self.error is not None:
                raise self.error
            if not self._thread.is_alive() and not self._buffers:
                raise RuntimeError("the loop ended before creating its buffer")
            if time.monotonic() > t_end:
                raise TimeoutError(f"the loop did not start within {timeout} s")
            time.sleep(0.01)
        return self._buffers[0]

    def _work(self) -> None:
        try:
            self.result = run(self.scene, reference=self.reference, control=self.control,
                              buffers=self._buffers)
        except RthsError as exc:  # bad scene value: keep it for the caller / status line
            self.error = exc
        except BaseException as exc:  # noqa: BLE001 — reported through status()
            self.error = exc

    @property
    def running(self) -> bool:
        """True while the loop thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def join(self, timeout: float | None = None) -> RunResult | None:
        """Wait for the run to end; its result (None if it failed)."""
        if self._thread is not None:
            self._thread.join(timeout)
        return self.result

    def pause(self) -> None:
        """Hold the loop at its next control check."""
        self.control.pause()

    def resume(self) -> None:
        """Continue a paused loop."""
        self.control.resume()

    def stop(self) -> None:
        """Stop the loop safely (the record so far is kept, status 'stopped')."""
        self.control.stop()

    def set_speed(self, speed: float) -> None:
        """Pace at ``speed`` × real time (0: unpaced)."""
        self.speed = _check_speed(speed)
        self.control.set_speed(self.speed)

    def restart(self, transfer: str, params: dict[str, float]) -> RecordBuffer:
        """Stop the current run and start a new one with ``transfer`` and ``params``."""
        self.stop()
        self.join(30.0)
        scene = scene_with(self.scene, params).with_transfer(transfer)
        self.scene = scene
        self.start_paused = False
        return self.start()

    def status(self) -> str:
        """One line: running time, or how the run ended."""
        if self.error is not None:
            return f"error: {self.error}"
        if self.result is not None:
            r = self.result
            return (f"finished ({r.status}{': ' + r.reason if r.reason else ''}), "
                    f"{r.record.duration:.2f} s simulated, RTF {r.rtf:.2f}")
        if self._buffers:
            b = self._buffers[0]
            return (f"running: t = {b.data[b.n - 1, 0]:.2f} s of {self.scene.duration:g} s "
                    f"({self.scene.transfer.kind})")
        return "starting"

    def close(self, save: Callable[[Any, str], Any] | None = None) -> str | None:
        """Stop, wait and save the record if ``out`` was given; returns the file written.

        ``save(record, out)`` writes it instead of ``record.save(out)`` (the command line
        keeps a record that ``out`` refuses elsewhere) and returns the path written."""
        self.stop()
        res = self.join(60.0)
        if self.out and res is not None:
            if save is not None:
                return str(save(res.record, self.out))
            return str(res.record.save(self.out))
        return None

    # ------------------------------------------------------------------ view
    def key_params(self) -> dict[str, tuple[float, float, float, float]]:
        """The GUI's parameters: name → (value, min, max, step)."""
        p = self.scene.params()
        out: dict[str, tuple[float, float, float, float]] = {}
        for name, (lo, hi, step) in KEY_PARAMS.items():
            v: Any = p.get(name)
            if name.startswith("numerical.") and not self.scene.numerical.has_matrices:
                continue  # an OpenSees model's parameters live in its file
            if v is None and name.startswith("numerical.") and self.scene.numerical.n == 1:
                v = p.get(name.upper().replace("NUMERICAL.", "numerical."))
                v = v[0][0] if isinstance(v, tuple) else v
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                if name == "excitation.amplitude" and not v:
                    continue
                out[name] = (float(v), lo, max(hi, float(v)), step)
        return out

    def view_process(self, **kwargs: Any):
        """A live view of this run served from its own process (see :mod:`.process`);
        call ``start()`` on it (which starts the run)."""
        from .process import ViewProcess

        kwargs.setdefault("title", f"rths3d · {self.scene.name}")
        kwargs.setdefault("speed", self.speed or 1.0)
        return ViewProcess(self, **kwargs)

    def viewer(self, **kwargs: Any) -> Viewer:
        """A live :class:`Viewer` of this run with run controls (starts the run)."""
        buffer = self.start()
        control = RunControl(
            transfers=transfer_kinds(), transfer=self.scene.transfer.kind,
            params=self.key_params(), restart=self.restart, pause=self.pause,
            resume=self.resume, stop=self.stop, set_speed=self.set_speed, status=self.status)
        view = Viewer(buffer, live=True, control=control, speed=self.speed or 1.0,
                      title=f"rths3d · {self.scene.name}", **kwargs)
        view.on_first_client = self.resume
        return view

"""Playback clock of a replay: play/pause, speed, scrub and restart.

Time is the record's time t (s). The clock maps wall time to record time as
``t = t_anchor + speed · (wall − wall_anchor)`` while playing and holds while paused; at the
end it either stops or loops. The clock function is injectable so tests need no sleeping.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from ..errors import ConfigError

MIN_SPEED = 0.01
MAX_SPEED = 100.0


class Playback:
    """Record-time clock for replay.

    Parameters
    ----------
    t_start, t_end:
        First and last sample times of the record (s).
    speed:
        Record seconds per wall second (1 = real time), in [MIN_SPEED, MAX_SPEED].
    loop:
        Start again from ``t_start`` when the end is reached.
    clock:
        Wall clock in s (default ``time.monotonic``).
    """

    def __init__(self, t_start: float, t_end: float, *, speed: float = 1.0, loop: bool = True,
                 clock: Callable[[], float] = time.monotonic):
        if not t_end > t_start:
            raise ConfigError("playback.t_end", t_end, f"must be > t_start = {t_start}")
        self.t_start = float(t_start)
        self.t_end = float(t_end)
        self.loop = loop
        self._clock = clock
        self._lock = threading.Lock()
        self._speed = self._check_speed(speed)
        self._anchor_t = self.t_start
        self._anchor_wall = clock()
        self._playing = True

    @staticmethod
    def _check_speed(speed: float) -> float:
        s = float(speed)
        if not MIN_SPEED <= s <= MAX_SPEED:
            raise ConfigError("speed", s, f"must be within [{MIN_SPEED}, {MAX_SPEED}]")
        return s

    def _now_locked(self) -> float:
        if not self._playing:
            return self._anchor_t
        t = self._anchor_t + self._speed * (self._clock() - self._anchor_wall)
        if t >= self.t_end:
            if self.loop:
                span = self.t_end - self.t_start
                t = self.t_start + (t - self.t_start) % span
            else:
                t = self.t_end
                self._anchor_t, self._playing = t, False
        return t

    def time(self) -> float:
        """Current record time (s), within [t_start, t_end]."""
        with self._lock:
            return self._now_locked()

    @property
    def playing(self) -> bool:
        """True while the clock advances."""
        with self._lock:
            self._now_locked()
            return self._playing

    @property
    def speed(self) -> float:
        """Record seconds per wall second."""
        return self._speed

    def _reanchor(self, t: float) -> None:
        self._anchor_t = min(max(float(t), self.t_start), self.t_end)
        self._anchor_wall = self._clock()

    def play(self) -> None:
        """Advance from the current time (from the start if the end was reached)."""
        with self._lock:
            t = self._now_locked()
            self._reanchor(self.t_start if t >= self.t_end else t)
            self._playing = True

    def pause(self) -> None:
        """Hold the current time."""
        with self._lock:
            self._reanchor(self._now_locked())
            self._playing = False

    def seek(self, t: float) -> None:
        """Jump to record time ``t`` (s), clamped to the record; keeps playing or paused."""
        with self._lock:
            self._reanchor(t)

    def set_speed(self, speed: float) -> None:
        """Change the speed without a jump in record time."""
        s = self._check_speed(speed)
        with self._lock:
            self._reanchor(self._now_locked())
            self._speed = s

    def restart(self) -> None:
        """Back to the first sample, playing."""
        with self._lock:
            self._reanchor(self.t_start)
            self._playing = True

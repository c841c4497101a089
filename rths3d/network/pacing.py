"""Pacing a loop on the wall clock: step n starts at t0 + n·ΔT, as on a bench at 1 kHz.

:meth:`Pacer.wait` is called before each step: it sleeps until ``spin`` seconds before the
step's deadline (the operating system's sleep overshoots by tens of µs), then spins on the
clock to it. A step whose predecessor ended after this deadline is an **overrun**: it starts
at once, late, and the schedule of the later steps moves with it (a bench does not run
steps back to back to catch up). Per step, preallocated (no allocation on the paced path):
the **jitter** (start − deadline, s; a few µs when on time) and the **latency** (the step's
own work, s: for the remote transfer the round trip to the site). The overrun policy:
``max_overruns`` 0 counts them (the summary warns), N > 0 stops the test safely at the N-th.

The first step is the warm-up (it loads the compiled kernels and builds the bench: 10 ms to
2 s): its latency is kept, but the clock starts when it ends, and it is not an overrun.
On a machine shared with other work, the operating system's scheduler makes steps late by
milliseconds (measured here: 1.1 % overruns at a load average of 3.8 on 2 cores);
``priority`` > 0 runs the paced loop under the real-time FIFO scheduler at that priority
(1–99, needs root or CAP_SYS_NICE; measured: 1 overrun in 5000 steps at the same load), and
restores the previous policy at :meth:`finish`.
"""

from __future__ import annotations

import contextlib
import gc
import math
import os
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

__all__ = ["Pacer", "realtime_priority"]


class Pacer:
    """Wall-clock pacing of up to ``n_steps`` steps of ``dt`` seconds (module docstring)."""

    def __init__(self, dt: float, n_steps: int, *, spin: float = 3e-4, max_overruns: int = 0,
                 priority: int = 0):
        if not dt > 0:
            raise ValueError(f"dt = {dt} s: must be > 0")
        self.dt = float(dt)
        self.priority = int(priority)
        self._policy: Any = None
        self._gc = False
        self.spin = float(spin)
        self.max_overruns = int(max_overruns)
        self.jitter = np.zeros(n_steps + 1)
        self.latency = np.zeros(n_steps + 1)
        self.t0 = 0.0
        self.steps = 0
        self.overruns = 0
        self.first_overrun = -1
        self._start = 0.0
        self._clock = time.perf_counter
        self._sleep = time.sleep

    def start(self) -> None:
        """Step 0 (the warm-up) starts now; with ``priority``, the real-time scheduler from
        now until :meth:`finish` (PermissionError when the process may not use it)."""
        if self.priority > 0 and self._policy is None:
            self._policy = _fifo(self.priority)
        # the cyclic garbage collector's full passes take milliseconds: none while paced
        # (the paced path keeps nothing per step); collected once now, on again at finish
        gc.collect()
        self._gc = gc.isenabled()
        gc.disable()
        self.t0 = self._start = self._clock()
        self.steps = 0
        self.overruns = 0
        self.first_overrun = -1

    def finish(self) -> None:
        """Back to the scheduling policy and the garbage collector before :meth:`start`."""
        if self._gc:
            self._gc = False
            gc.enable()
        if self._policy is not None:
            policy, param = self._policy
            self._policy = None
            os.sched_setscheduler(0, policy, param)

    def wait(self, n: int) -> bool:
        """Wait for step n's deadline (t0 + n·ΔT), after step n − 1 ended; False when the
        overrun policy stops the test (the N-th overrun)."""
        clock = self._clock
        now = clock()
        if n > 0 and n - 1 < self.latency.shape[0]:
            self.latency[n - 1] = now - self._start
        if n <= 1:  # after the warm-up step: the clock starts now, step 1 at once
            self.t0 = now - n * self.dt
        deadline = self.t0 + n * self.dt
        late = now > deadline
        if late:
            self.overruns += 1
            if self.first_overrun < 0:
                self.first_overrun = n
            # the schedule moves with the late step: later steps keep their ΔT apart
            # instead of running back to back to catch up (one hiccup, one overrun)
            self.t0 += now - deadline
        else:
            rest = deadline - now - self.spin
            if rest > 0:
                self._sleep(rest)
            while clock() < deadline:
                pass
            now = clock()
        if n < self.jitter.shape[0]:
            self.jitter[n] = now - deadline
        self._start = now
        self.steps = n
        return not (late and 0 < self.max_overruns <= self.overruns)

    def stats(self) -> dict[str, Any]:
        """Jitter and latency (s: mean, p99, max), overruns (count, fraction, first step)."""
        n = max(self.steps, 0)
        j = self.jitter[2:n + 1]  # step 1 starts the clock: its jitter is 0 by definition
        lat = self.latency[1:n]  # step 0, the warm-up, is warmup_s

        def three(a: np.ndarray) -> tuple[float, float, float]:
            if not a.size:
                return (math.nan,) * 3
            return float(a.mean()), float(np.percentile(a, 99)), float(a.max())

        jm, jp, jx = three(j)
        lm, lp, lx = three(lat)
        return {"rate_hz": 1.0 / self.dt, "steps": n, "overruns": self.overruns,
                "overrun_fraction": self.overruns / n if n else 0.0,
                "first_overrun": self.first_overrun, "max_overruns": self.max_overruns,
                "priority": self.priority, "warmup_s": float(self.latency[0]),
                "jitter_mean_s": jm, "jitter_p99_s": jp, "jitter_max_s": jx,
                "latency_mean_s": lm, "latency_p99_s": lp, "latency_max_s": lx}


def _fifo(priority: int) -> tuple[int, Any]:
    """The real-time FIFO scheduler at ``priority`` for this process; the policy before."""
    before = (os.sched_getscheduler(0), os.sched_getparam(0))
    os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    return before


@contextlib.contextmanager
def realtime_priority(priority: int) -> Iterator[None]:
    """The block under the real-time FIFO scheduler at ``priority`` and without the cyclic
    garbage collector's pauses (0: unchanged), both restored after it (PermissionError when
    the process may not use the scheduler)."""
    if priority <= 0:
        yield
        return
    policy, param = _fifo(priority)
    collect = gc.isenabled()
    gc.collect()
    gc.disable()
    try:
        yield
    finally:
        if collect:
            gc.enable()
        os.sched_setscheduler(0, policy, param)

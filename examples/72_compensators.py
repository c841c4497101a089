"""Delay compensators side by side: on a six-channel transfer system (one compensator per
channel, as per Stewart leg) and on the community RTHS benchmark in place of its phase lead.

Part 1 (no data needed): six channels, each the platform's identified heave model after a
5 ms transport delay, with gains 0.9…1.1 that differ per channel. Every compensator is first
calibrated offline on a predefined displacement test (a multisine sent uncompensated), then
drives a different, broadband test; the table gives the relative tracking error per
compensator and the worst channel. Last, an ATS whose channel gain jumps out of its bounds
is stopped with the reason.

Part 2 (needs the benchmark data beside the repository, or RTHS3D_BENCHMARK_DIR): case 1,
El Centro × 0.4, with every compensator in place of the phase lead, beside the benchmark's
controller (same as ``rths3d benchmark rths --compensator all --case 1``).

Run: ``python examples/72_compensators.py [--no-benchmark] [--plot compensators.png]``.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from rths3d.compensation import CALIBRATIONS, build, compensator_names, config_from_dict
from rths3d.transfer.actuators import DelayLine, LTIActuator, default_transfer_function

DT = 1e-3  # the loop's step (s)
GAINS = np.array([[0.9, 0.95, 1.0, 1.0, 1.05, 1.1]])  # per channel (leg)


class Legs:
    """Six channels: transport delay 5 ms, identified heave model, a gain per channel."""

    def __init__(self, gains: np.ndarray = GAINS):
        num, den, _ = default_transfer_function()
        self.delay = DelayLine(1, 6, 0.005, DT)
        self.act = LTIActuator(1, 6, num, den, DT)
        self.gains = gains.copy()

    def __call__(self, u: np.ndarray) -> np.ndarray:
        return self.gains * self.act(self.delay(u))


def multisine(t: np.ndarray, seed: int, f_max: float = 5.0) -> tuple[np.ndarray, np.ndarray]:
    """Six channels of a faded-in random-phase multisine (m) up to f_max Hz and its rate."""
    rng = np.random.default_rng(seed)
    f = np.linspace(0.2, f_max, 12)
    amp = 1.5e-3 / np.sqrt(f.size) / np.maximum(1.0, f / 2.0)
    ph = rng.uniform(0, 2 * np.pi, (6, f.size))
    fade = np.minimum(t / 1.0, 1.0)[:, None]
    arg = 2 * np.pi * f[None, None, :] * t[:, None, None] + ph[None]
    z = (amp * np.sin(arg)).sum(axis=2)
    zd = (amp * 2 * np.pi * f * np.cos(arg)).sum(axis=2)
    return fade * z, fade * zd + np.where(t < 1.0, 1.0, 0.0)[:, None] * z


def run(comp, legs: Legs, z: np.ndarray, zd: np.ndarray) -> np.ndarray:
    """The closed loop; returns the measurements (N, 6), row k passed at call k."""
    zm = np.zeros((1, 6))
    out = np.zeros_like(z)
    for k in range(z.shape[0]):
        out[k] = zm
        u = comp.command(z[k:k + 1], zd[k:k + 1], zm)
        zm = legs(u).copy()
        if comp.stopped.any():
            return out[:k + 1]
    return out


def part1(plot: str) -> None:
    t = np.arange(int(20.0 / DT)) * DT
    zc, zdc = multisine(t, seed=1, f_max=20.0)  # the predefined displacement test
    legs = Legs()
    record = np.zeros_like(zc)
    for k in range(t.size):  # sent uncompensated; measurement of call k answers call k − 1
        record[k] = legs(zc[k:k + 1])
    meas_cal = np.vstack([np.zeros((1, 6)), record[:-1]])
    z, zd = multisine(t, seed=2)  # the test itself
    print("six channels: 5 ms delay + identified heave model, gains 0.9–1.1 per channel")
    print(f"{'compensator':<12} {'e_rel (all)':>12} {'worst channel':>14}  final coefficients")
    errs = {}
    for name in compensator_names():
        if name == "lead":  # the benchmark's phase lead, designed for its 4096 Hz loop
            continue
        config = config_from_dict(name)
        cal = CALIBRATIONS.get(name)
        if cal is not None:
            # decentralised schemes: one calibration per leg; the others one model for all,
            # calibrated on the nominal leg (channel 2, gain 1)
            per_channel = name in ("ats", "rls")
            u_rec = zc if per_channel else zc[:, 2]
            m_rec = meas_cal if per_channel else meas_cal[:, 2]
            config = cal(u_rec, m_rec, DT, config)
        comp = build(name, 1, 6, DT, config)
        m = run(comp, Legs(), z, zd)
        e = m[1:] - z[:m.shape[0] - 1]  # measurement of call k + 1 against the target of k
        rel = np.sqrt(np.mean(e**2, axis=0)) / np.sqrt(np.mean(z**2, axis=0))
        errs[name] = e
        coefs = ", ".join(f"{k}={float(np.mean(v)):.4g}" for k, v in comp.coefficients().items()
                          if k in ("tau", "a0", "a1", "a2", "gain", "lead", "u_fb"))
        print(f"{name:<12} {np.sqrt(np.mean(e**2)) / np.sqrt(np.mean(z**2)):12.4f} "
              f"{rel.max():14.4f}  {coefs}")

    # drift safety: channel 5's gain jumps to 2 at t = 10 s (ATS a0 would have to be 0.5)
    legs = Legs()
    comp = build("ats", 1, 6, DT, CALIBRATIONS["ats"](zc, meas_cal, DT, config_from_dict("ats")))
    zm = np.zeros((1, 6))
    for k in range(t.size):
        if k == int(10.0 / DT):
            legs.gains[0, 5] = 2.0
        u = comp.command(z[k:k + 1], zd[k:k + 1], zm)
        zm = legs(u).copy()
        if comp.stopped[0]:
            break
    print("gain jump on channel 5 at t = 10 s:", comp.reasons[0] or "not stopped")

    if plot:
        from rths3d.figures import new_figure, save_figure

        fig = new_figure((9, 4))
        ax = fig.subplots()
        for name, e in errs.items():
            ax.plot(t[1:e.shape[0] + 1], 1e3 * e[:, 5], lw=0.8, label=name)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("tracking error, channel 5 (mm)")
        ax.legend(loc="upper right", ncol=4, fontsize=8)
        print("wrote", save_figure(fig, plot))


def part2() -> None:
    from rths3d.community import BenchmarkConfig, load_excitation, run_case
    from rths3d.community.compensated import (
        calibrated_config,
        calibration_record,
        run_compensated,
    )
    from rths3d.errors import ConfigError

    try:
        gm = load_excitation("ElCentro")
    except ConfigError as exc:
        print(f"(benchmark part skipped: {exc})")
        return
    cfg = BenchmarkConfig(case=1)
    record = calibration_record(cfg)
    keys = ("J1", "J2", "J3", "J4", "J5")
    print("\nRTHS benchmark, case 1, El Centro × 0.4 (J1 ms, others %):")
    print(f"{'':<12}" + "".join(f"{k:>8}" for k in keys))
    row = run_case(cfg, gm=gm).table_row()
    print(f"{'benchmark':<12}" + "".join(f"{row[k]:8.2f}" for k in keys))
    for name in compensator_names():
        res = run_compensated(cfg, name, calibrated_config(name, cfg, record=record), gm=gm)[0]
        if res.status != "ok":
            print(f"{name:<12}STOPPED: {res.reason}")
            continue
        row = res.table_row()
        print(f"{name:<12}" + "".join(f"{row[k]:8.2f}" for k in keys))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-benchmark", action="store_true", help="skip part 2")
    ap.add_argument("--plot", default="", help="PNG of channel 5's tracking errors")
    args = ap.parse_args()
    if args.plot and not args.plot.endswith(".png"):
        print(f"error: --plot: {args.plot!r} (must end in .png)", file=sys.stderr)
        sys.exit(2)
    part1(args.plot)
    if not args.no_benchmark:
        part2()


if __name__ == "__main__":
    main()

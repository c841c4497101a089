"""RoDeAC's offline calibration on the maRTHS benchmark (``Offline_calibration.m``,
``Model_Calibration.slx``): open loop, the numerical substructure without feedback force,
its frame→actuator targets driving the plant directly, measured = plant output + noise.

For each record × intensity × plant and each actuator, θ and P come from RoDeAC's batch
least squares (:func:`rths3d.compensation.rodeac.fit_inverse`, in m); the stored initial
parameters are their element-wise means over the runs (3 records × {0.2, 0.4, 0.6} ×
[nominal + 10 perturbed plants] = 99 runs). The perturbed plants are drawn once from
``numpy.random.default_rng(seed)`` and used for every record and intensity; the noise is
the benchmark's (std 0.0124 mm at 1024 Hz), seed ``noise_seed`` + plant index.

``python -m rths3d.community.marths.calibration [--data DIR]`` writes the result to
``rodeac_initial.json`` beside this module (the benchmark's default θ₀, P₀).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ...compensation.rodeac import fit_inverse
from ...lti import recur
from .data import RECORDS, load_record
from .engine import INITIAL_FILE, MarthsConfig, _grid, structure
from .model import COUPLER, frame_to_actuator, newmark_matrices, newmark_response
from .plant import NOMINAL, PlantZPK, perturbed_plants

__all__ = ["Calibration", "calibration_record", "compensator_configs", "offline_calibration",
           "open_loop_measured", "open_loop_targets"]


@dataclass(eq=False)
class Calibration:
    """Per-run θ (R, 2, 4) and P (R, 2, 4, 4) (in m), their means, and the runs' labels."""

    theta: np.ndarray
    P: np.ndarray
    runs: list[str]

    @property
    def theta_mean(self) -> np.ndarray:
        return self.theta.mean(axis=0)

    @property
    def P_mean(self) -> np.ndarray:
        return self.P.mean(axis=0)

    def to_json(self) -> dict:
        return {
            "theta0": {f"act{j + 1}": self.theta_mean[j].tolist() for j in range(2)},
            "P0": {f"act{j + 1}": self.P_mean[j].tolist() for j in range(2)},
            "runs": len(self.runs),
        }


def open_loop_targets(record: str, intensity: float = 1.0, fs: float = 1024.0,
                      data_path: str | None = None) -> np.ndarray:
    """The actuator targets (N, 2) in mm of the numerical substructure without feedback."""
    cfg = MarthsConfig(record=record, intensity=intensity, fs=fs)
    gm = load_record(record, intensity, data_path)
    part = structure(str(data_path) if data_path else None)
    N, t = _grid(cfg, gm)
    nm = newmark_matrices(part.MN, part.CN, part.KN, part.l, cfg.dt)
    U = newmark_response(nm, gm(t))
    return np.stack(frame_to_actuator(U[:, 26], -U[:, 20], COUPLER), axis=1)


def open_loop_measured(plant: PlantZPK, commands: np.ndarray, fs: float = 1024.0,
                       noise: np.ndarray | None = None) -> np.ndarray:
    """Measured displacements (N, 2) in mm: the plant (RK4 steps, command held) driven by
    ``commands`` (N, 2) mm from rest, y_k = C x_k, plus ``noise`` (N,) on both channels."""
    Phi, Gam, C = plant.step_matrices(1.0 / fs)
    X = np.zeros((commands.shape[0], Phi.shape[0]))
    X[1:] = recur(Phi, np.zeros(Phi.shape[0]), commands[:-1] @ Gam.T)
    y = X @ C.T
    return y if noise is None else y + noise[:, None]


def offline_calibration(records: Sequence[str] = RECORDS,
                        intensities: Sequence[float] = (0.2, 0.4, 0.6), n_perturbed: int = 10,
                        seed: int = 123, noise_seed: int = 123, fs: float = 1024.0,
                        noise_cov: float = 1.5e-7, data_path: str | None = None
                        ) -> Calibration:
    """RoDeAC's calibration over records × intensities × [nominal + n_perturbed plants]."""
    plants = [NOMINAL, *perturbed_plants(n_perturbed, seed)]
    thetas, Ps, runs = [], [], []
    std = math.sqrt(noise_cov * fs)
    for rec in records:
        base = open_loop_targets(rec, 1.0, fs, data_path)
        for inten in intensities:
            xt = base * inten
            for ip, p in enumerate(plants):
                n = std * np.random.default_rng(noise_seed + ip).standard_normal(xt.shape[0])
                xm = open_loop_measured(p, xt, fs, n)
                th, P = zip(*(fit_inverse(1e-3 * xt[:, j], 1e-3 * xm[:, j]) for j in range(2)),
                            strict=True)
                thetas.append(np.stack(th))
                Ps.append(np.stack(P))
                runs.append(f"{rec} x {inten} plant {ip}")
    return Calibration(np.stack(thetas), np.stack(Ps), runs)


def main(argv: Sequence[str] | None = None) -> None:
    import argparse

    ap = argparse.ArgumentParser(description="RoDeAC's offline calibration on maRTHS; "
                                 "writes rodeac_initial.json beside the module")
    ap.add_argument("--data", default=None, help="maRTHS benchmark folder holding data/")
    args = ap.parse_args(argv)
    cal = offline_calibration(data_path=args.data)
    d = cal.to_json()
    d["_source"] = ("rths3d.community.marths.calibration.offline_calibration(): 3 records x "
                    "{0.2, 0.4, 0.6} x [nominal + 10 perturbed plants, seed 123]; means in m")
    INITIAL_FILE.write_text(json.dumps(d, indent=1) + "\n")
    print(json.dumps({"theta0": d["theta0"], "runs": d["runs"]}))


if __name__ == "__main__":
    main()


def calibration_record(fs: float = 1024.0, intensity: float = 0.4, noise_seed: int = 123,
                       noise_cov: float = 1.5e-7, data_path: str | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """A predefined-displacement record for the project's compensators: the three records'
    open-loop targets at ``intensity`` (one after the other) sent to the nominal plant, and
    the measurements; (commands, measurements) (N, 2) in m at the same calls."""
    xs, ms = [], []
    std = math.sqrt(noise_cov * fs)
    for i, rec in enumerate(RECORDS):
        xt = intensity * open_loop_targets(rec, 1.0, fs, data_path)
        n = std * np.random.default_rng(noise_seed + 100 + i).standard_normal(xt.shape[0])
        xs.append(xt)
        ms.append(open_loop_measured(NOMINAL, xt, fs, n))
    return 1e-3 * np.concatenate(xs), 1e-3 * np.concatenate(ms)


def compensator_configs(name: str, params: dict | None = None, fs: float = 1024.0,
                        record: tuple[np.ndarray, np.ndarray] | None = None,
                        data_path: str | None = None) -> tuple:
    """One config per actuator for compensator ``name``: its defaults with ``params`` then,
    for compensators with an offline calibration (:data:`rths3d.compensation.CALIBRATIONS`),
    calibrated per actuator on :func:`calibration_record` (keys given in ``params`` kept)."""
    from dataclasses import replace

    from ...compensation import CALIBRATIONS, config_from_dict

    params = dict(params or {})
    config = config_from_dict(name, params)
    cal = CALIBRATIONS.get(name)
    if cal is None:
        return config, config
    u, zm = record if record is not None else calibration_record(fs, data_path=data_path)
    keep = {k: getattr(config, k) for k in params}
    return tuple(replace(cal(u[:, j], zm[:, j], 1.0 / fs, config), **keep) for j in range(2))

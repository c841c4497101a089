"""The multi-parameter candidates of a diagnosis: the kinematic calibration (42 geometry
parameters from the measured poses and leg encoders) and the FTS calibration (6×6 matrix and
offset from the measured wrench), each returned as the geometry / FTS effects it identifies."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..effects import WRENCH
from ..errors import ConfigError
from ..record import DOFS
from .result import effect_configs

__all__ = ["Calibrations"]


class Calibrations:
    """The calibrations of a :class:`~.engine.Diagnosis` (which derives from this class),
    fitted on its training samples (``train``) of its measured channels (``measured``)."""

    def _multi(self, label: str, base: Mapping[str, np.ndarray]) -> dict[str, float] | None:
        """The effects of the calibration ``label`` (``kinematic_calibration`` or
        ``fts_calibration``) fitted on the training samples, or None."""
        return self._kinematic(base) if label == "kinematic_calibration" else self._fts(base)

    def _kinematic(self, base: Mapping[str, np.ndarray]) -> dict[str, float] | None:
        """Kinematic calibration (42 parameters) from the measured absolute poses and leg
        encoders of the training samples: the identified deviations as geometry effects."""
        from ..platform.calibrate.kinematic import KinematicCalibration, parameter_names

        need = [f"pose_meas.{d}" for d in DOFS] + [f"leg_len.{i}" for i in range(6)]
        if not all(c in self.measured for c in need):
            return None
        bench = self.replay.bench(effect_configs({**self.base_effects, **self.accepted}))
        nominal = bench.true_geometry()
        rows = np.flatnonzero(self.train)[:: max(1, int(0.005 / self.dt))]
        q = np.column_stack([self.measured[f"pose_meas.{d}"][rows] for d in DOFS])
        L = np.column_stack([self.measured[f"leg_len.{i}"][rows] for i in range(6)])
        sig = float(np.median([self.sigma[f"leg_len.{i}"] for i in range(6)]))
        try:
            # a prior of 2 mm (manufacturing tolerance) keeps what the poses cannot see near
            # the drawing; the identifiability report says which parameters those are
            cal = KinematicCalibration(nominal, sigma=max(sig, 1e-7), prior_sigma=2e-3,
                                       tolerance=1e-4).fit(q, L)
        except ConfigError:
            return None
        self.kinematic_ = cal
        out: dict[str, float] = {}
        for name, dev in zip(parameter_names(), cal.deviation_, strict=True):
            if abs(dev) <= 1e-7:
                continue
            kind, rest = name.split("[")  # base_anchor[i].x, top_anchor[i].z, leg_offset[i]
            leg = int(rest[0])
            axis = rest.split(".")[-1] if "." in rest else ""
            lab = f"{kind}.leg{leg}" + (f".{axis}" if axis else "")
            out[lab] = self.accepted.get(lab, 0.0) + float(dev)
        return out or None

    def _fts(self, base: Mapping[str, np.ndarray]) -> dict[str, float] | None:
        """FTS calibration: the 6×6 matrix and offset that map the model's wrench onto the
        measured one (least squares on the training samples), as gain, cross-talk and
        offset effects."""
        cols = [f"fts.{c}" for c in WRENCH]
        if not all(c in self.measured for c in cols):
            return None
        tr = self.train
        W = np.column_stack([base[c][tr] for c in cols] + [np.ones(int(tr.sum()))])
        Y = np.column_stack([self.measured[c][tr] for c in cols])
        X, *_ = np.linalg.lstsq(W, Y, rcond=None)
        C = X[:6].T
        b = X[6]
        out: dict[str, float] = {}
        sw = np.sqrt(np.mean(W[:, :6] ** 2, axis=0)) + 1e-12
        for r, rn in enumerate(WRENCH):
            sr = self.sigma[f"fts.{rn}"]
            for c, cn in enumerate(WRENCH):
                v = C[r, c] - (1.0 if r == c else 0.0)
                # keep entries that move the channel by more than a tenth of its noise
                if abs(v) * sw[c] > 0.1 * sr:
                    lab = f"fts_gain.{rn}" if r == c else f"fts_crosstalk.{rn}.{cn}"
                    out[lab] = self.accepted.get(lab, 0.0) + float(v)
            if abs(b[r]) > 0.1 * sr:
                lab = f"fts_offset.{rn}"
                out[lab] = self.accepted.get(lab, 0.0) + float(b[r])
        return out or None

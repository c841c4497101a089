"""Training: Levenberg–Marquardt (as MATLAB ``trainlm``) and an Adam baseline.

Both minimise the mean squared error of the normalised residuals e = a − t on the training
set, watch the validation set after every epoch (early stopping: ``max_fail`` consecutive
epochs without a new best validation MSE, 6 as in MATLAB) and return the weights with the best
validation MSE. Both record a history (wall time, epoch, training and validation MSE), which the
LM-vs-Adam benchmark reads.

Levenberg–Marquardt step (Marquardt 1963; Hagan & Menhaj 1994):
``Δw = −(JᵀJ + μ I)⁻¹ Jᵀ e`` with J = ∂e/∂w (N × P, all weights). μ starts at 10⁻³, is
multiplied by 0.1 after a successful step and by 10 after a failed one, and training stops when
μ exceeds 10¹⁰ (MATLAB's mu, mu_dec, mu_inc, mu_max).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import torch

from ..errors import ConfigError
from .network import DTYPE, Topology, forward, init_weights, jacobian


@dataclass(frozen=True)
class LMConfig:
    """Levenberg–Marquardt settings (MATLAB ``trainlm`` defaults)."""

    epochs: int = 1000
    mu: float = 1e-3
    mu_dec: float = 0.1
    mu_inc: float = 10.0
    mu_max: float = 1e10
    max_fail: int = 6
    min_grad: float = 1e-7
    goal: float = 0.0

    def __post_init__(self) -> None:
        if self.epochs < 1:
            raise ConfigError("lm.epochs", self.epochs, "must be >= 1")
        if not (0 < self.mu_dec < 1 < self.mu_inc):
            raise ConfigError("lm.mu_dec/mu_inc", (self.mu_dec, self.mu_inc),
                              "need 0 < mu_dec < 1 < mu_inc")
        if self.max_fail < 1:
            raise ConfigError("lm.max_fail", self.max_fail, "must be >= 1")


@dataclass(frozen=True)
class AdamConfig:
    """Full-batch Adam baseline settings (learning rate in normalised units per step)."""

    epochs: int = 20000
    lr: float = 1e-2
    max_fail: int = 200
    time_limit: float = math.inf
    target_val_mse: float = 0.0
    """Stop as soon as the validation MSE reaches this (0: never; used by the benchmark)."""


@dataclass
class TrainResult:
    """Outcome of one training: best-validation weights and the history.

    ``history`` rows are (wall time s, epoch, training MSE, validation MSE), MSE on the
    normalised scale. ``stop`` says why training ended.
    """

    topology: Topology
    weights: torch.Tensor
    epochs: int
    best_epoch: int
    stop: str
    train_mse: float
    val_mse: float
    seconds: float
    history: list[tuple[float, int, float, float]] = field(default_factory=list)

    def predict(self, xn: np.ndarray) -> np.ndarray:
        """Normalised net output for normalised inputs."""
        with torch.no_grad():
            x = torch.as_tensor(np.asarray(xn, dtype=float), dtype=DTYPE)
            return forward(self.topology, self.weights, x).numpy().copy()


def _tensors(topo: Topology, x: np.ndarray, t: np.ndarray, name: str
             ) -> tuple[torch.Tensor, torch.Tensor]:
    """Checked (N, n_in) inputs and (N,) targets of the ``name`` set as torch tensors."""
    x = np.asarray(x, dtype=float)
    _check(x, t, topo, name)
    return (torch.as_tensor(np.ascontiguousarray(x), dtype=DTYPE),
            torch.as_tensor(np.ascontiguousarray(t, dtype=float).ravel(), dtype=DTYPE))


def _check(x: np.ndarray, t: np.ndarray, topo: Topology, name: str) -> None:
    if x.ndim != 2 or x.shape[1] != topo.n_in:
        raise ConfigError(f"{name}.X", x.shape, f"must be (N, {topo.n_in})")
    if x.shape[0] != np.asarray(t).size:
        raise ConfigError(f"{name}.y", np.asarray(t).size, f"must have {x.shape[0]} values")
    if x.shape[0] < 1:
        raise ConfigError(f"{name}.X", x.shape, "needs at least one sample")


def train_lm(topo: Topology, x_train: np.ndarray, t_train: np.ndarray, x_val: np.ndarray,
             t_val: np.ndarray, *, seed: int = 0, config: LMConfig = LMConfig(),
             w0: torch.Tensor | None = None) -> TrainResult:
    """Train a net with Levenberg–Marquardt and validation early stopping.

    Inputs and targets must already be normalised to [−1, 1]. Returns the weights of the
    epoch with the smallest validation MSE (MATLAB returns the same).
    """
    xt, tt = _tensors(topo, x_train, t_train, "train")
    xv, tv = _tensors(topo, x_val, t_val, "val")
    w = init_weights(topo, np.random.default_rng(seed)) if w0 is None else w0.clone()
    n_p = w.numel()
    eye = torch.eye(n_p, dtype=DTYPE)

    def resid(wv: torch.Tensor) -> torch.Tensor:
        return forward(topo, wv, xt) - tt

    start = time.perf_counter()
    with torch.no_grad():
        e = resid(w)
        perf = float(torch.mean(e * e))
        vperf = float(torch.mean((forward(topo, w, xv) - tv) ** 2))
    best_w, best_v, best_epoch, fails = w.clone(), vperf, 0, 0
    history = [(0.0, 0, perf, vperf)]
    mu = config.mu
    stop = "max epochs"
    epoch = 0
    for epoch in range(1, config.epochs + 1):
        with torch.no_grad():
            _, j = jacobian(topo, w, xt)
            jj = j.T @ j
            je = j.T @ e
            if float(torch.linalg.vector_norm(2.0 * je / e.numel())) < config.min_grad:
                stop = "minimum gradient"
                epoch -= 1
                break
            improved = False
            while mu <= config.mu_max:
                try:
                    dw = torch.linalg.solve(jj + mu * eye, je)
                except torch.linalg.LinAlgError:
                    # JᵀJ + μI numerically singular (dead units give zero Jacobian columns and
                    # μ has shrunk below their round-off): a failed step, raise μ
                    mu *= config.mu_inc
                    continue
                w2 = w - dw
                e2 = resid(w2)
                perf2 = float(torch.mean(e2 * e2))
                if perf2 < perf:
                    w, e, perf = w2, e2, perf2
                    mu *= config.mu_dec
                    improved = True
                    break
                mu *= config.mu_inc
            vperf = float(torch.mean((forward(topo, w, xv) - tv) ** 2))
        history.append((time.perf_counter() - start, epoch, perf, vperf))
        if vperf < best_v:
            best_w, best_v, best_epoch, fails = w.clone(), vperf, epoch, 0
        elif vperf > best_v:
            fails += 1
        if not improved:
            stop = "maximum mu"
            break
        if fails >= config.max_fail:
            stop = "validation stop"
            break
        if perf <= config.goal:
            stop = "performance goal"
            break
    with torch.no_grad():
        tr = float(torch.mean((forward(topo, best_w, xt) - tt) ** 2))
    return TrainResult(topo, best_w, epoch, best_epoch, stop, tr, best_v,
                       time.perf_counter() - start, history)


def train_adam(topo: Topology, x_train: np.ndarray, t_train: np.ndarray, x_val: np.ndarray,
               t_val: np.ndarray, *, seed: int = 0,
               config: AdamConfig = AdamConfig()) -> TrainResult:
    """Baseline: full-batch Adam on the same loss, same initialisation and early stopping.

    Used to measure how much faster Levenberg–Marquardt reaches a given validation MSE.
    """
    xt, tt = _tensors(topo, x_train, t_train, "train")
    xv, tv = _tensors(topo, x_val, t_val, "val")
    w = init_weights(topo, np.random.default_rng(seed)).requires_grad_(True)
    opt = torch.optim.Adam([w], lr=config.lr)
    start = time.perf_counter()
    with torch.no_grad():
        vperf = float(torch.mean((forward(topo, w, xv) - tv) ** 2))
        perf = float(torch.mean((forward(topo, w, xt) - tt) ** 2))
    best_w, best_v, best_epoch, fails = w.detach().clone(), vperf, 0, 0
    history = [(0.0, 0, perf, vperf)]
    stop = "max epochs"
    epoch = 0
    for epoch in range(1, config.epochs + 1):
        opt.zero_grad(set_to_none=True)
        loss = torch.mean((forward(topo, w, xt) - tt) ** 2)
        loss.backward()
        opt.step()
        with torch.no_grad():
            vperf = float(torch.mean((forward(topo, w, xv) - tv) ** 2))
        elapsed = time.perf_counter() - start
        history.append((elapsed, epoch, float(loss.detach()), vperf))
        if vperf < best_v:
            best_w, best_v, best_epoch, fails = w.detach().clone(), vperf, epoch, 0
        elif vperf > best_v:
            fails += 1
        if config.target_val_mse > 0 and best_v <= config.target_val_mse:
            stop = "target reached"
            break
        if fails >= config.max_fail:
            stop = "validation stop"
            break
        if elapsed > config.time_limit:
            stop = "time limit"
            break
    with torch.no_grad():
        tr = float(torch.mean((forward(topo, best_w, xt) - tt) ** 2))
    return TrainResult(topo, best_w, epoch, best_epoch, stop, tr, best_v,
                       time.perf_counter() - start, history)


def time_to_val_mse(result: TrainResult, target: float) -> float:
    """Wall time (s) when the validation MSE first reaches ``target`` (inf if never)."""
    for t, _e, _tr, v in result.history:
        if v <= target:
            return t
    return math.inf

"""The feed-forward network (FNN) of the paper, as a pure function of a flat weight vector.

Layers: ``n_in → h_1 → … → h_k → 1``; hidden activation the symmetric saturating linear
function ``satlins(g) = clip(g, −1, 1)`` (MATLAB ``satlins``, torch ``hardtanh``), output
activation linear (the paper's choice for regression). With ``bypass=True`` the inputs also feed
the output directly (a linear bypass, as MATLAB's ``cascadeforwardnet``): the net is a linear
model plus saturating corrections, so it keeps extrapolating along the linear trend where every
hidden unit saturates, instead of flattening at the edge of the training range. Inputs and
targets are expected already normalised to [−1, 1] (see :mod:`rths3d.ann.normalize`).

The weights live in ONE flat float64 vector ``w`` so that Levenberg–Marquardt can form the
Jacobian of the residuals with respect to all weights at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

DTYPE = torch.float64


@dataclass(frozen=True)
class Topology:
    """Network shape: number of inputs and hidden-layer widths (one linear output).

    ``hidden=(5,)`` is the paper's selected net (k = 1 hidden layer, five neurons).
    """

    n_in: int
    hidden: tuple[int, ...] = (5,)
    bypass: bool = False
    """Direct input → output weights (a linear bypass; ``n_in`` extra weights, stored last)."""

    def __post_init__(self) -> None:
        from ..errors import ConfigError

        if self.n_in < 1:
            raise ConfigError("topology.n_in", self.n_in, "must be >= 1")
        if not self.hidden:
            raise ConfigError("topology.hidden", self.hidden, "at least one hidden layer")
        for h in self.hidden:
            if int(h) < 1:
                raise ConfigError("topology.hidden", self.hidden, "every width must be >= 1")

    @property
    def sizes(self) -> tuple[int, ...]:
        """Layer sizes including input and output."""
        return (self.n_in, *self.hidden, 1)

    @property
    def n_weights(self) -> int:
        """Number of weights and biases."""
        s = self.sizes
        return sum((s[i] + 1) * s[i + 1] for i in range(len(s) - 1)) + \
            (self.n_in if self.bypass else 0)

    def label(self) -> str:
        """Short text label, e.g. ``"5"``, ``"10x10"``, ``"5+lin"`` (with the bypass)."""
        return "x".join(str(h) for h in self.hidden) + ("+lin" if self.bypass else "")


def _slices(topo: Topology) -> list[tuple[slice, slice, int, int]]:
    s = topo.sizes
    out = []
    k = 0
    for i in range(len(s) - 1):
        n_w = s[i] * s[i + 1]
        out.append((slice(k, k + n_w), slice(k + n_w, k + n_w + s[i + 1]), s[i], s[i + 1]))
        k += n_w + s[i + 1]
    return out


def _bypass_slice(topo: Topology) -> slice:
    n = topo.n_weights
    return slice(n - topo.n_in, n)


def forward(topo: Topology, w: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
    """Net output a for normalised inputs ``x`` (N, n_in) → (N,).

    Hidden layers ``a = satlins(W a_prev + b)``, output ``a = W a_prev + b`` (linear).
    """
    a = x
    layers = _slices(topo)
    last = len(layers) - 1
    for i, (sw, sb, n_prev, n_next) in enumerate(layers):
        weight = w[sw].reshape(n_next, n_prev)
        a = a @ weight.T + w[sb]
        if i < last:
            a = torch.clamp(a, -1.0, 1.0)
    out = a[:, 0]
    if topo.bypass:
        out = out + x @ w[_bypass_slice(topo)]
    return out


def jacobian(topo: Topology, w: torch.Tensor, x: torch.Tensor
             ) -> tuple[torch.Tensor, torch.Tensor]:
    """Net output a (N,) and its Jacobian ∂a/∂w (N, P), by analytic back-propagation.

    For the saturating hidden units the derivative is 1 inside (−1, 1) and 0 in saturation
    (the one-sided derivative at ±1 taken as 0, as torch's ``hardtanh``). Analytic instead of
    autograd because LM needs the full per-sample Jacobian every epoch, and for nets this small
    the framework overhead of ``jacrev`` would dominate.
    """
    layers = _slices(topo)
    acts = [x]
    masks = []
    a = x
    last = len(layers) - 1
    for i, (sw, sb, n_prev, n_next) in enumerate(layers):
        z = a @ w[sw].reshape(n_next, n_prev).T + w[sb]
        if i < last:
            masks.append((z > -1.0) & (z < 1.0))
            a = torch.clamp(z, -1.0, 1.0)
            acts.append(a)
        else:
            a = z
    n = x.shape[0]
    jac = torch.empty((n, w.numel()), dtype=w.dtype)
    delta = torch.ones((n, 1), dtype=w.dtype)
    for i in range(last, -1, -1):
        sw, sb, n_prev, n_next = layers[i]
        jac[:, sw] = (delta[:, :, None] * acts[i][:, None, :]).reshape(n, n_next * n_prev)
        jac[:, sb] = delta
        if i > 0:
            delta = (delta @ w[sw].reshape(n_next, n_prev)) * masks[i - 1]
    out = a[:, 0]
    if topo.bypass:
        sk = _bypass_slice(topo)
        out = out + x @ w[sk]
        jac[:, sk] = x
    return out, jac


def init_weights(topo: Topology, rng: np.random.Generator) -> torch.Tensor:
    """Nguyen–Widrow initialisation (MATLAB's default ``initnw``) for the hidden layers.

    Each hidden layer of H neurons over n inputs gets random weight rows scaled to length
    β = 0.7 H^(1/n) and biases spread uniformly in [−β, β], so the active (linear) regions of
    the neurons tile the normalised input box [−1, 1]^n. The output layer is uniform in
    [−0.5, 0.5]; bypass weights (``bypass=True``) start at 0.
    """
    parts = []
    layers = _slices(topo)
    for i, (_sw, _sb, n_prev, n_next) in enumerate(layers):
        if i < len(layers) - 1:
            beta = 0.7 * n_next ** (1.0 / n_prev)
            wmat = rng.uniform(-1.0, 1.0, size=(n_next, n_prev))
            norms = np.linalg.norm(wmat, axis=1, keepdims=True)
            wmat = beta * wmat / np.maximum(norms, 1e-12)
            bias = beta * np.linspace(-1.0, 1.0, n_next) * np.sign(wmat[:, 0]) if n_next > 1 \
                else rng.uniform(-beta, beta, size=1)
            parts += [wmat.ravel(), bias]
        else:
            parts += [rng.uniform(-0.5, 0.5, size=n_prev * n_next),
                      rng.uniform(-0.5, 0.5, size=n_next)]
    if topo.bypass:
        parts.append(np.zeros(topo.n_in))
    return torch.as_tensor(np.concatenate(parts), dtype=DTYPE)


__all__ = ["DTYPE", "Topology", "forward", "init_weights", "jacobian"]


"""The fidelity ANN: a feed-forward net trained with Levenberg–Marquardt (paper Sect. on ANNs).

Predicts the relative RMS reference error e_rel,ref from indicators available without a
reference solution (a Table-3 feature set). Pieces: :mod:`.network` (satlins FNN),
:mod:`.normalize` ([−1, 1] scaling and the 70/15/15 split), :mod:`.training` (LM, Adam
baseline), :mod:`.estimator` (topology search + ensemble, save/load), :mod:`.sensitivity`,
:mod:`.plots`, :mod:`.scores`, :mod:`.learning_curve` (accuracy against the number of training
tests).
"""

from .estimator import (
    DEFAULT_TOPOLOGIES,
    ExtrapolationWarning,
    FidelityANN,
    NonFiniteInputWarning,
    TopologyScore,
    parse_topologies,
)
from .learning_curve import LearningPoint, learning_curve
from .network import Topology
from .normalize import MinMax, split_indices
from .scores import mse, pearson_rho
from .sensitivity import rank, sensitivity_mean, sensitivity_permutation
from .training import AdamConfig, LMConfig, TrainResult, time_to_val_mse, train_adam, train_lm

__all__ = [
    "DEFAULT_TOPOLOGIES", "AdamConfig", "ExtrapolationWarning", "FidelityANN", "LMConfig",
    "LearningPoint", "MinMax", "NonFiniteInputWarning", "Topology", "TopologyScore",
    "TrainResult", "learning_curve", "mse", "parse_topologies", "pearson_rho", "rank",
    "sensitivity_mean", "sensitivity_permutation", "split_indices", "time_to_val_mse",
    "train_adam", "train_lm",
]

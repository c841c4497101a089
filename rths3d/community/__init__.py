"""The community benchmark problems: Silva et al.'s RTHS benchmark (this package; the
multi-axial maRTHS frame with RoDeAC in :mod:`.marths`).

The RTHS benchmark (benchmark control problem for real-time hybrid simulation) as an rths3d
scene family: four partitioning cases of a 3-story frame, a
servo-hydraulic transfer system with control–structure interaction, a PI + phase-lead
controller at 4096 Hz, converters, noise, and the criteria J1–J9; and the same loop with
any compensator of :mod:`rths3d.compensation` in place of the controller's phase lead
(:func:`run_compensated`).
"""

from .compensated import calibrated_config, calibration_record, run_compensated
from .config import EXCITATIONS, BenchmarkConfig, ControllerParams, data_dir, load_excitation
from .plant import PLANT_STD, PlantParams, plant_ss, plant_step_matrices, plant_tf
from .published import PUBLISHED_TABLE3
from .simulate import BenchmarkResult, reference_response, run_case, run_trials
from .structure import CASES, case_matrices, frame_stiffness, modal_damping

__all__ = [
    "CASES", "EXCITATIONS", "PLANT_STD", "PUBLISHED_TABLE3", "BenchmarkConfig",
    "BenchmarkResult", "ControllerParams", "PlantParams", "calibrated_config",
    "calibration_record", "case_matrices", "data_dir",
    "frame_stiffness", "load_excitation", "modal_damping", "plant_ss", "plant_step_matrices",
    "plant_tf", "reference_response", "run_case", "run_compensated", "run_trials",
]

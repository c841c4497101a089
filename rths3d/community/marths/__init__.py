"""The multi-axial RTHS benchmark (maRTHS; Condori Uribe et al. 2023) with its reference
controller RoDeAC (Quiroz, Gálmez & Fermandois 2024; FermandoisLab/maRTHS-bmk-RoDeAC):
a one-bay frame cut from a 29-DOF three-storey frame, loaded by two coupled actuators
(translation x and rotation θ of the interface node) through an identified 2×2 plant with
parametric uncertainty and sensor noise, scored by J1–J10 (24 numbers).

:func:`run_marths` runs K plants with any compensator of :mod:`rths3d.compensation`, per
actuator or for both channels; :func:`offline_calibration` is RoDeAC's calibration.
"""

from .criteria import J_COUNTS, find_delay, flat_keys, marths_criteria, report
from .data import RECORDS, data_dir, load_record, load_reference_matrices
from .engine import (
    MarthsConfig,
    MarthsResult,
    default_config,
    reference_signals,
    rodeac_initial,
    run_marths,
    stored_initial,
    structure,
)
from .model import (
    COUPLER,
    Partition,
    Specimen,
    actuator_to_frame,
    frame_to_actuator,
    ideal_physical,
    newmark_matrices,
    newmark_response,
    partition,
    specimen,
)
from .opensees_frame import OpenSeesFrame
from .plant import NOMINAL, PlantZPK, perturbed_plants

__all__ = [
    "COUPLER", "J_COUNTS", "NOMINAL", "RECORDS", "MarthsConfig", "MarthsResult", "OpenSeesFrame",
    "Partition",
    "PlantZPK", "Specimen", "actuator_to_frame", "data_dir", "default_config", "find_delay",
    "flat_keys", "frame_to_actuator", "ideal_physical", "load_record",
    "load_reference_matrices", "marths_criteria", "newmark_matrices", "newmark_response",
    "offline_calibration", "partition", "perturbed_plants", "reference_signals", "report",
    "rodeac_initial", "run_marths", "specimen", "stored_initial", "structure",
]


def offline_calibration(*args, **kwargs):  # type: ignore[no-untyped-def]
    """RoDeAC's offline calibration (:func:`.calibration.offline_calibration`)."""
    from .calibration import offline_calibration as _cal

    return _cal(*args, **kwargs)

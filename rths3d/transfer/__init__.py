"""Transfer systems (ideal, pure delay, 1-D LTI actuator, MuJoCo Stewart platform), delay
compensation and the force-sensor model, interchangeable behind one small protocol."""

from .actuators import (
    Compensator,
    DelayLine,
    LTIActuator,
    SensorModel,
    default_transfer_function,
    default_transport_delay,
)
from .systems import ActuatorTransfer, StewartTransfer, TransferSystem, build_transfer

__all__ = [
    "ActuatorTransfer",
    "Compensator",
    "DelayLine",
    "LTIActuator",
    "SensorModel",
    "StewartTransfer",
    "TransferSystem",
    "build_transfer",
    "default_transfer_function",
    "default_transport_delay",
]

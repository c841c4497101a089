"""Transfer systems: one class per kind (ideal, pure delay, 1-D LTI, MuJoCo Stewart
platform), registered by name behind :class:`TransferSystem`; compensators and the
force-sensor model as components of them."""

from .actuators import (
    DelayLine,
    LTIActuator,
    PerTestDelayLine,
    PerTestLTIActuator,
    SensorModel,
    default_transfer_function,
    default_transport_delay,
    discretise_tf,
)
from .base import (
    TRANSFERS,
    CompiledTransfer,
    RecordSignal,
    TransferSystem,
    batch_key,
    build_transfer,
    register_transfer,
    transfer_class,
    transfer_kinds,
)
from .chain import ChainTransfer
from .commands import compensator_key, compensator_of
from .compensator import Compensator
from .delay import DelayTransfer
from .ideal import IdealTransfer
from .lti import LTITransfer
from .remote import RemoteTransfer
from .stewart import StewartTransfer

__all__ = [
    "TRANSFERS",
    "ChainTransfer",
    "Compensator",
    "CompiledTransfer",
    "DelayLine",
    "DelayTransfer",
    "IdealTransfer",
    "LTIActuator",
    "LTITransfer",
    "PerTestDelayLine",
    "PerTestLTIActuator",
    "RecordSignal",
    "RemoteTransfer",
    "SensorModel",
    "StewartTransfer",
    "TransferSystem",
    "batch_key",
    "build_transfer",
    "compensator_key",
    "compensator_of",
    "default_transfer_function",
    "default_transport_delay",
    "discretise_tf",
    "register_transfer",
    "transfer_class",
    "transfer_kinds",
]

"""One model of a Stewart-platform test bench, for the vRTHS loop, the diagnosis' replay and
synthetic measurements (:class:`Bench`, :func:`platform_batch`, :class:`BenchReplay`)."""

from .base import Bench, platform_batch, platform_config
from .replay import BenchReplay, ReplayInput

__all__ = ["Bench", "BenchReplay", "ReplayInput", "platform_batch", "platform_config"]

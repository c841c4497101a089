"""User-facing errors and safe stops.

Every error a user can cause (a bad scene value, a malformed record, an unreachable pose)
is an :class:`RthsError`. The command line prints its message on one line and exits with a
non-zero code, without a traceback. Programming errors stay ordinary exceptions.
"""

from __future__ import annotations

import functools
from typing import Any


class RthsError(Exception):
    """Base class of every error caused by user input or by a test leaving its limits."""


class ConfigError(RthsError, ValueError):
    """A configuration value is missing, of the wrong type or out of its limits.

    The message names the field, the value and the limit, e.g.
    ``numerical.m: -1.0 kg is out of range (must be > 0)``.
    """

    def __init__(self, field: str, value: Any = None, limit: str = "", *, message: str = ""):
        self.field = field
        self.value = value
        self.limit = limit
        if not message:
            shown = "missing" if value is None else repr(value)
            message = f"{field}: {shown}" + (f" ({limit})" if limit else "")
        super().__init__(message)

    def __reduce__(self):
        # rebuilt from its fields (not from the message alone), so it crosses process pools
        return (functools.partial(type(self), message=str(self)),
                (self.field, self.value, self.limit), self.__dict__)


class NumericalFailure(RthsError, RuntimeError):
    """A numerical substructure could not advance a step (e.g. an OpenSees ``analyze`` that
    did not converge): the loop stops test ``test`` safely at that step and keeps its
    record; ``reason`` says what and when."""

    def __init__(self, test: int, reason: str):
        self.test = int(test)
        self.reason = reason
        super().__init__(reason)

    def __reduce__(self):
        return (type(self), (self.test, self.reason))


class MissingDependency(RthsError, ImportError):
    """An optional dependency a feature needs is not installed; the message names the extra
    to install, e.g. ``the screenshot needs playwright: pip install 'rths3d[browser]'``."""

    def __init__(self, module: str, feature: str, extra: str):
        self.module = module
        self.extra = extra
        super().__init__(f"{feature} needs {module}, which is not installed: "
                         f"pip install 'rths3d[{extra}]'")


class RecordError(RthsError, ValueError):
    """A record file is unreadable or does not follow the documented schema."""


class SafetyStop(RthsError):
    """A running test left a safety limit and was stopped, as a real bench would stop.

    Attributes
    ----------
    quantity:
        What left its limit, e.g. ``"leg 3 velocity"``, ``"fts force"``, ``"divergence"``.
    value, limit:
        The offending value and the limit, in SI units.
    t:
        Simulated time of the step at which the limit was hit (s).
    test:
        Index of the test within a batch (0 for a single run).
    """

    def __init__(self, quantity: str, value: float, limit: float, t: float, test: int = 0,
                 unit: str = ""):
        self.quantity = quantity
        self.value = float(value)
        self.limit = float(limit)
        self.t = float(t)
        self.test = int(test)
        self.unit = unit
        u = f" {unit}" if unit else ""
        super().__init__(
            f"stopped at t = {self.t:.3f} s: {quantity} = {self.value:.6g}{u} exceeds the "
            f"limit {self.limit:.6g}{u}" + (f" (test {self.test})" if test else "")
        )

    def __reduce__(self):
        # rebuilt from its fields: the default would call __init__ with the message only
        return (type(self), (self.quantity, self.value, self.limit, self.t, self.test,
                             self.unit), self.__dict__)

    @property
    def reason(self) -> str:
        """One-line reason, as stored in records and sweep tables."""
        return str(self)

"""One home per parameter of the bench: the leg servo's gain ``kp`` and the set-point hold
``hold`` followed from the scene to the MuJoCo model, their defaults and allowed values
written once (rths3d.config) and validated by one function wherever they are given."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import rths3d
from rths3d.bench.base import platform_config
from rths3d.config import HOLD, SERVO_CONVENTIONS, ControllerConfig, TransferConfig
from rths3d.errors import ConfigError
from rths3d.platform.model import ActuatorConfig, build_model
from rths3d.scene import load_scene

ROOT = Path(rths3d.__file__).parent


def _modules_with(pattern: str) -> list[str]:
    rx = re.compile(pattern)
    return sorted(str(p.relative_to(ROOT)) for p in ROOT.rglob("*.py")
                  if rx.search(p.read_text(encoding="utf-8")))


def test_defaults_and_allowed_values_are_written_once():
    """The servo gain's default (2.0e5 N/m) and the hold's allowed values appear as literals
    in rths3d/config.py only; the platform, the command line and the diagnosis' candidates
    read them from there."""
    assert TransferConfig.kp == 2.0e5
    assert _modules_with(r"(?<![\w.])(2\.0e5|2e5|200000|200_000)(?![\w.])") == ["config.py"]
    assert _modules_with(r"\(\s*\"ramp\",\s*\"zoh\"\s*\)") == ["config.py"]
    assert ActuatorConfig().kp == TransferConfig.kp and ActuatorConfig().kv == TransferConfig.kv
    assert ActuatorConfig().hold == ControllerConfig().hold == HOLD[0] == "ramp"
    from rths3d.diagnose.candidates.controller import CONVENTIONS, DEFAULTS

    assert CONVENTIONS["hold"] is SERVO_CONVENTIONS["hold"] is HOLD
    assert DEFAULTS == {k: getattr(ControllerConfig(), k) for k in CONVENTIONS}


def test_kp_and_hold_followed_from_the_scene_to_the_mujoco_model():
    """A scene's kp and [controller] hold reach the platform's actuator configuration and the
    compiled MuJoCo model's position servos (gain and bias), unchanged."""
    scene = load_scene("paper_contact", {"transfer.kind": "stewart", "transfer.kp": 3.5e5,
                                         "controller.hold": "zoh"})
    assert scene.transfer.kp == 3.5e5 and scene.controller.hold == "zoh"
    cfg = platform_config(scene)
    assert cfg.actuator.kp == 3.5e5 and cfg.actuator.hold == "zoh"
    model = build_model(cfg)
    servos = [i for i in range(model.nu)
              if model.actuator(i).name.startswith("leg") and "lag" not in
              model.actuator(i).name]
    assert len(servos) == 6
    for i in servos:
        assert model.actuator_gainprm[i, 0] == 3.5e5  # N/m
        assert model.actuator_biasprm[i, 1] == -3.5e5


@pytest.mark.parametrize("where, overrides", [
    ("controller.kp", {"controller.kp": -1.0}),
    ("transfer.kp", {"transfer.kp": -1.0}),
    ("controller.delay", {"controller.delay": 0.6}),
    ("transfer.delay", {"transfer.delay": 0.6}),
])
def test_one_validation_of_the_servo_numbers(where, overrides):
    """The same limit, the same words, whichever table states the number (and the platform's
    own configuration)."""
    with pytest.raises(ConfigError) as exc:
        load_scene("paper_contact", {"transfer.kind": "stewart", **overrides})
    assert str(exc.value).startswith(f"{where}: ")
    name = where.split(".")[1]
    with pytest.raises(ConfigError) as own:
        ActuatorConfig(**{name: next(iter(overrides.values()))})
    assert str(exc.value).split("(", 1)[1] == str(own.value).split("(", 1)[1]

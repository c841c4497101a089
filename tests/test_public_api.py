"""The public API: every exported name resolves, is documented and is typed."""

from __future__ import annotations

import inspect
import subprocess
import sys

import pytest

import rths3d

PUBLIC = [n for n in rths3d.__all__ if not n.startswith("_")]


@pytest.mark.parametrize("name", PUBLIC)
def test_export_resolves_and_has_a_docstring(name):
    """Each public name imports and carries a docstring of its own."""
    obj = getattr(rths3d, name)
    if inspect.isclass(obj) or inspect.isfunction(obj):
        doc = inspect.getdoc(obj)
        assert doc and len(doc) > 20, f"{name} needs a docstring"


@pytest.mark.parametrize("name", [n for n in PUBLIC
                                  if inspect.isfunction(getattr(rths3d, n))])
def test_public_functions_are_type_hinted(name):
    """Public functions annotate every named parameter and their return value."""
    sig = inspect.signature(getattr(rths3d, name))
    for p in sig.parameters.values():
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        assert p.annotation is not inspect.Parameter.empty, f"{name}({p.name}) has no hint"
    assert sig.return_annotation is not inspect.Signature.empty, f"{name} has no return hint"


def test_core_import_is_light():
    """Importing rths3d loads neither the viewer, the CLI, torch nor MuJoCo."""
    code = ("import sys, rths3d; bad = [m for m in ('rths3d.viz', 'rths3d.cli', 'torch', "
            "'mujoco', 'viser') if m in sys.modules]; print(','.join(bad))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == ""


def test_core_never_imports_viewer_or_cli():
    """No core module imports rths3d.viz or rths3d.cli (the viewer sits beside the core)."""
    import re
    from pathlib import Path

    root = Path(rths3d.__file__).parent
    pattern = re.compile(r"^\s*(from|import)\s+(rths3d\.(viz|cli)|\.+(viz|cli))\b", re.M)
    offenders = []
    for path in root.rglob("*.py"):
        rel = path.relative_to(root).parts
        if rel[0] in ("viz", "cli", "__main__.py"):
            continue
        if pattern.search(path.read_text()):
            offenders.append(str(path.relative_to(root)))
    assert offenders == []


MOVED = {
    # old module → (new module, names that moved there)
    "rths3d.jit": ("rths3d.kernels.layout", ("AnyLayout", "kernel_type")),
    "rths3d.scene_bench": ("rths3d.scene.bench", ("bench_scene_text", "bench_origin",
                                                  "controller_table", "platform_table")),
    "rths3d.scene_checks": ("rths3d.scene.checks", ("check_coupled_stability", "check_reach")),
    "rths3d.platform.identify": ("rths3d.platform.calibrate.heave", (
        "HeaveTF", "identify_heave", "load_heave_tf", "multisine", "fit_transfer_function")),
    "rths3d.platform.fts_calibration": ("rths3d.platform.calibrate.fts", ("FTSCalibration",
                                                                          "skew")),
    "rths3d.platform.calibration": ("rths3d.platform.calibrate.kinematic", (
        "KinematicCalibration", "CalibratedGeometry", "load_geometry")),
    "rths3d.platform.pose_design": ("rths3d.platform.calibrate.poses", ("select_poses",)),
    "rths3d.rthsbench": ("rths3d.community", ("run_case", "BenchmarkConfig", "marths")),
    "rths3d.effects.blocks": ("rths3d.kernels", ("Block", "Chain", "run_chain", "run_blocks",
                                                 "padded_kernels", "njit", "inline_njit",
                                                 "block_kernel", "ready", "kernel_tuple",
                                                 "KernelTuple", "BLOCK_SIG", "F1", "F2")),
}


WHOLE = ("rths3d.jit", "rths3d.scene_bench", "rths3d.scene_checks", "rths3d.rthsbench",
         "rths3d.platform.identify", "rths3d.platform.fts_calibration",
         "rths3d.platform.calibration", "rths3d.platform.pose_design")
"""Modules that moved as a whole: importing the old name warns."""


@pytest.mark.parametrize("old", sorted(MOVED))
def test_moved_names_still_import_from_their_old_module(old):
    """Every name that moved to another module still imports from where it was, and is the
    same object; a module that moved as a whole warns that it did (DeprecationWarning)."""
    import importlib
    import warnings

    new, names = MOVED[old]
    if old in WHOLE:  # a shim: import it afresh to see its warning (re-importing a module
        sys.modules.pop(old, None)  # with classes would give other tests twin classes)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        before = importlib.import_module(old)
    target = importlib.import_module(new)
    for name in names:
        assert getattr(before, name) is getattr(target, name), f"{old}.{name}"
    if old in WHOLE:
        assert any(issubclass(w.category, DeprecationWarning) and new.rsplit(".", 1)[0] in
                   str(w.message) for w in caught)


def test_shared_helpers_have_one_home():
    """The multisine and the transfer-function fit are rths3d.lti's, skew the kinematics';
    the platform's calibration and identification use those very functions."""
    from rths3d.lti import identify as lti_identify
    from rths3d.platform import kinematics
    from rths3d.platform.calibrate import fts, heave

    assert heave.multisine is lti_identify.multisine
    assert heave.fit_transfer_function is lti_identify.fit_transfer_function
    assert fts.skew is kinematics.skew

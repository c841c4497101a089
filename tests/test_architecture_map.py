"""docs/architecture.md's map is true: every module it names imports, every file or folder
path it names (with a folder part) exists."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TEXT = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
MODULES = sorted(set(re.findall(r"`(rths3d(?:\.[A-Za-z_]+)+)", TEXT)))
PATHS = sorted(set(re.findall(r"`((?:[a-z_]+/)+[a-z_]*(?:\.py|\.toml|\.md)?)`", TEXT)))


def test_the_map_names_modules_and_paths():
    assert len(MODULES) >= 10 and len(PATHS) >= 30


@pytest.mark.parametrize("name", MODULES)
def test_named_module_imports(name):
    """A dotted name is a module, or an attribute of one (a class, a function)."""
    try:
        importlib.import_module(name)
    except ModuleNotFoundError:
        parent, _, attr = name.rpartition(".")
        assert hasattr(importlib.import_module(parent), attr), name


@pytest.mark.parametrize("path", PATHS)
def test_named_path_exists(path):
    """A path with a folder part exists in the repository or in the package."""
    assert any((base / path).exists() for base in (ROOT, ROOT / "rths3d")), path

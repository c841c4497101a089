"""Components say what they have: nothing outside the registries compares a part kind, a
transfer kind or an effect name (issue: "components, not kind strings")."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rths3d.diagnose.engine import default_candidates
from rths3d.effects import REGISTRY
from rths3d.experiment import PARTS, part_class
from rths3d.scene import load_scene

PKG = Path(__file__).resolve().parents[1] / "rths3d"
KINDS = "|".join(sorted({*PARTS, "stewart", "ideal", "lti", "delay", "remote"}))
NAMES = "|".join(sorted(REGISTRY))
COMPARISON = re.compile(
    rf"""(\.kind|\.name|\bname|part_model)\s*(==|!=|\bin\b|\bnot in\b)\s*[\(\[{{]?\s*
         ["']({KINDS}|{NAMES})["']""", re.VERBOSE)
STARTS = re.compile(rf"""startswith\(\s*["']({NAMES})""")


def test_no_kind_or_effect_name_comparison_outside_the_registries() -> None:
    hits = []
    for path in PKG.rglob("*.py"):
        rel = path.relative_to(PKG).as_posix()
        if rel.startswith("cli/"):
            continue  # the command line maps user words to components
        for no, line in enumerate(path.read_text().splitlines(), 1):
            if COMPARISON.search(line) or STARTS.search(line):
                hits.append(f"{rel}:{no}: {line.strip()}")
    assert not hits, "\n".join(hits)


@pytest.mark.parametrize("scene", ["paper_contact", "paper_linear", "multidof"])
def test_candidates_follow_what_the_part_has(scene: str) -> None:
    """A contact gap only where the part meets a surface, the part's own stiffness and
    damping only where it has them; anchors and the FTS matrix come from the calibrations."""
    sc = load_scene(scene)
    part = part_class(sc.experiment.kind)
    names = {c.split(".")[0] for c in default_candidates(sc)}
    assert ("contact_gap" in names) == part.has_contact
    assert ("specimen_stiffness" in names) == part.has_spring
    assert "base_anchor" not in names and "fts_crosstalk" not in names
    assert "sensor_noise" not in names

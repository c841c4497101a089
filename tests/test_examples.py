"""The example scripts: `--help` only prints usage, bad arguments give one line and exit 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(tmp_path: Path, script: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(EXAMPLES / script), *args], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("script", ["12_platform_batch.py", "30_metrics_from_record.py",
                                    "60_find_missing_effect.py", "70_rths_benchmark.py"])
def test_help_prints_usage_without_running(tmp_path, script):
    """`--help` prints the usage and exits 0 without running or writing anything."""
    out = _run(tmp_path, script, "--help")
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("usage:") and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("script, args, needle", [
    ("10_platform_tracking.py", ["--out", "c.parquet"], "--out: 'c.parquet'"),
    ("20_contact_test.py", ["--duration", "-1"], "duration: -1.0"),
    ("30_metrics_from_record.py", ["c.parquet"], "OUT_DIR: 'c.parquet'"),
    ("51_replay.py", ["missing.parquet"], "missing.parquet"),
])
def test_bad_arguments_give_one_line_and_exit_2(tmp_path, script, args, needle):
    """A user mistake in an example's arguments prints one `error:` line, no traceback."""
    (tmp_path / "c.parquet").write_text("x")
    out = _run(tmp_path, script, *args)
    err = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(err) == 1, out.stderr
    assert err[0].startswith("error: ") and needle in err[0]


def test_usage_docstrings_list_every_option():
    """The usage lines of 41 and 42 name the options their parsers accept."""
    doc41 = (EXAMPLES / "41_paper_protocol.py").read_text().split('"""')[1]
    doc42 = (EXAMPLES / "42_learning_curve.py").read_text().split('"""')[1]
    assert "[--trainings N]" in doc41 and "table1_lti_large" in doc41
    assert "[--test N]" in doc42

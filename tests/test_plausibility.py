"""Plausibility of records in SI units: one set of checks, used by metrics, predict, view and
the diagnosis. Records in other units are made from a real run by transforms written here."""

from __future__ import annotations

import subprocess

import pytest
from cli_cases import run_in_process

from rths3d.plausibility import MAX_DT, TRANSLATION_LIMIT, implausible
from rths3d.record import Record


def cli(*args: str) -> subprocess.CompletedProcess:
    return run_in_process(*args)  # as python -m rths3d runs it, in this process


@pytest.fixture(scope="module")
def run_record(tmp_path_factory):
    """A real 2-s contact test on the LTI path, in SI units."""
    path = tmp_path_factory.mktemp("rec") / "si.parquet"
    p = cli("run", "paper_contact", "-t", "lti", "--set", "duration=2", "--out", str(path),
            "--json")
    assert p.returncode == 0, p.stderr
    return path


def in_mm(rec: Record) -> Record:
    """The record with every displacement in mm (the user's mistake)."""
    cols = {k: (v * 1e3 if k.split(".")[0] in ("z_cmd", "z_meas", "z_ref") else v)
            for k, v in rec.columns.items()}
    return Record(rec.t, cols, dict(rec.meta))


def in_ms(rec: Record) -> Record:
    """The record with its time in ms."""
    return Record(rec.t * 1e3, dict(rec.columns), dict(rec.meta))


def test_si_record_is_plausible(run_record) -> None:
    """The loop's own record raises no warning."""
    assert implausible(Record.load(run_record)) == []


def test_mm_and_ms_are_named(run_record) -> None:
    """Displacements in mm are named by column with the value and the limit; time in ms by
    the sampling interval."""
    rec = Record.load(run_record)
    mm = implausible(in_mm(rec))
    assert {line.split("'")[1] for line in mm} == {"z_cmd.z", "z_meas.z", "z_ref.z"}
    assert all(f"limit {TRANSLATION_LIMIT:g} m" in line and "mm?" in line for line in mm)
    ms = implausible(in_ms(rec))
    assert len(ms) == 1 and ms[0].startswith("column 't' steps 1 s per sample")
    assert f"{MAX_DT:g} s" in ms[0]
    deg = Record(rec.t, {"z_cmd.ry": rec.columns["z_cmd.z"] * 0 + 30.0,
                         "z_meas.ry": rec.columns["z_cmd.z"] * 0 + 30.0}, {})
    assert "degrees?" in implausible(deg)[0]


def test_metrics_warns_but_computes(run_record, tmp_path) -> None:
    """`metrics` on a record in mm and ms: exit 0, the measures, and one warning line per
    implausible number on stderr (none for the SI record)."""
    rec = Record.load(run_record)
    bad = in_ms(in_mm(rec)).save(tmp_path / "mm_ms.parquet")
    p = cli("metrics", str(bad), "--json")
    assert p.returncode == 0, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 4 and all(ln.startswith(f"warning: {bad}: column ") for ln in lines)
    assert "e_rel_track" in p.stdout
    ok = cli("metrics", str(run_record), "--json")
    assert ok.returncode == 0 and ok.stderr == ""


def test_view_replay_warns(run_record, tmp_path) -> None:
    """`view` of a record in mm warns before serving it."""
    bad = in_mm(Record.load(run_record)).save(tmp_path / "mm.parquet")
    p = cli("view", str(bad), "--port", "0", "--seconds", "0.5")
    assert p.returncode == 0, p.stderr
    assert "warning:" in p.stderr and "'z_cmd.z' reaches" in p.stderr
    assert "rths3d view: http://127.0.0.1:" in p.stdout


def test_diagnosis_refuses_with_the_same_check(run_record, tmp_path) -> None:
    """The diagnosis fits physical parameters: a record in mm is refused with the same line
    the other commands warn with."""
    from rths3d.diagnose import load_measurement
    from rths3d.errors import RecordError

    bad = in_mm(Record.load(run_record))
    path = bad.save(tmp_path / "mm.parquet")
    with pytest.raises(RecordError) as info:
        load_measurement(path)
    assert str(info.value) == f"{path}: {implausible(bad, ('z_cmd.z',))[0]}"

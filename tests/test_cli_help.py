"""`rths3d … --help`: every word of the help reaches the terminal, paragraphs reflowed."""

from __future__ import annotations

import re

import pytest

from rths3d.cli import main


def _help(argv, capsys, monkeypatch) -> str:
    monkeypatch.setenv("COLUMNS", "200")
    with pytest.raises(SystemExit) as info:
        main([*argv, "--help"])
    assert info.value.code == 0
    return capsys.readouterr().out


def _words(text: str) -> str:
    """The help without the box drawing and the padding of the rich layout."""
    return re.sub(r"[\s│─╭╮╰╯]+", " ", text)


@pytest.mark.parametrize("argv, words", [
    (["sweep"], ["write OUT/<name>.parquet."]),
    (["train"], ["Target column (target.<name>)."]),
    (["diagnose"], ["EFFECT[.leg<i>][.<axis>] (fitted)"]),
    (["benchmark", "rths"], ["(and <name>_trials.png"]),
])
def test_help_keeps_bracketed_words(argv, words, capsys, monkeypatch):
    """Angle and square brackets in a help text survive the markup."""
    text = _words(_help(argv, capsys, monkeypatch))
    for w in words:
        assert w in text, (argv, w)


def test_help_reflows_a_docstring_paragraph(capsys, monkeypatch):
    """A docstring paragraph wrapped in the source fills the terminal's width."""
    lines = _help(["sweep"], capsys, monkeypatch).splitlines()
    assert any("Resumable:" in ln and "with their reason." in ln for ln in lines)


COMMANDS = [["run"], ["metrics"], ["sweep"], ["train"], ["predict"], ["view"], ["diagnose"],
            ["effects"], ["benchmark", "rths"], ["platform", "track"],
            ["platform", "identify"], ["platform", "info"]]


@pytest.mark.parametrize("argv", COMMANDS, ids=" ".join)
def test_flags_show_no_value_type(argv, capsys, monkeypatch):
    """An on/off flag takes no value, so its help shows none (`--json`, not `--json <bool>`);
    options that take a value keep their type."""
    text = _help(argv, capsys, monkeypatch)
    assert "<bool>" not in text
    flags = [ln for ln in text.splitlines() if re.search(r"--(json|help)\b", ln)]
    assert flags and all("<" not in ln.split("--")[1].split("  ")[0] for ln in flags)
    if argv == ["run"]:
        assert re.search(r"--out\s.*<path>", text)

"""Run many command lines of ``rths3d`` in one process, each as ``python -m rths3d`` would.

``python tests/cli_cases.py CASES.json RESULTS.json``: CASES is a list of ``{"argv": [...],
"cwd": "..."}``; for each, the working directory is set, file descriptors 1 and 2 are sent
to files of the case's own (so that whatever writes to them — Python, typer, C code — is
caught), ``rths3d.cli.main(argv)`` runs as ``rths3d/__main__.py`` runs it, and the exit code
(``SystemExit``; 0 when it returns; 1 with the traceback on stderr for any other exception,
as the interpreter does) is kept. RESULTS gets ``{"code", "stdout", "stderr"}`` per case.

The bad-input table runs its cases through this (a few processes, each importing the
package once) instead of a fresh interpreter per case, which spent ≈ 2 s of imports on each.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import traceback


def _run(argv: list[str], cwd: str) -> dict:
    from rths3d.cli import main

    out = tempfile.TemporaryFile(mode="w+b")
    err = tempfile.TemporaryFile(mode="w+b")
    saved = os.dup(1), os.dup(2)
    here = os.getcwd()
    sys.stdout.flush()
    sys.stderr.flush()
    os.dup2(out.fileno(), 1)
    os.dup2(err.fileno(), 2)
    # Python's own streams onto those descriptors too (under pytest they are its capture
    # objects, not descriptors 1 and 2)
    streams = sys.stdout, sys.stderr
    sys.stdout = open(1, "w", encoding="utf-8", closefd=False)  # noqa: SIM115
    sys.stderr = open(2, "w", encoding="utf-8", closefd=False)  # noqa: SIM115
    code = 0
    try:
        os.chdir(cwd)
        try:
            main(argv)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            if not isinstance(exc.code, int) and exc.code is not None:
                print(exc.code, file=sys.stderr)
        except BaseException:  # noqa: BLE001 - what the interpreter would print
            traceback.print_exc()
            code = 1
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        sys.stdout, sys.stderr = streams
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        os.close(saved[0])
        os.close(saved[1])
        os.chdir(here)
    texts = []
    for f in (out, err):
        f.seek(0)
        texts.append(f.read().decode("utf-8", "replace"))
        f.close()
    return {"code": code, "stdout": texts[0], "stderr": texts[1]}


def run_in_process(*argv: str, cwd: str | None = None) -> subprocess.CompletedProcess:
    """``rths3d ARGV`` in this process, as ``python -m rths3d`` runs it: the exit code and
    what it wrote to file descriptors 1 and 2. For tests that run the same command line many
    times (a fresh interpreter spends ≈ 2–3 s importing torch and the package per call)."""
    res = _run(list(argv), cwd or os.getcwd())
    return subprocess.CompletedProcess(list(argv), res["code"], res["stdout"], res["stderr"])


def main() -> None:
    cases_path, results_path = sys.argv[1], sys.argv[2]
    with open(cases_path) as fh:
        cases = json.load(fh)
    results = [_run(c["argv"], c["cwd"]) for c in cases]
    with open(results_path, "w") as fh:
        json.dump(results, fh)


if __name__ == "__main__":
    main()

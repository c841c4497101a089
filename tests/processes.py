"""Processes a command left running: the tests of `kill -9` and of stopped servers."""

from __future__ import annotations

import os


def alive_in_session(sid: int) -> list[tuple[int, str]]:
    """Live processes (no zombies) of session ``sid``, with their command lines."""
    found = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            with open(f"/proc/{d}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z":
            found.append((int(d), cmd))
    return found

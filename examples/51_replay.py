"""Replay a saved test in the browser — and make the README picture.

Runs the paper's contact test on the Stewart platform with a 20 ms transport delay in the
legs (so the SSP opens into an ellipse), saves the record, and replays it in the browser:

    python examples/51_replay.py                      # serve until Ctrl-C
    python examples/51_replay.py out/contact.parquet  # replay a record of your own
    python examples/51_replay.py --screenshot docs/img/viewer.png

With ``--screenshot`` the replay is paused at ``--at`` seconds and photographed in headless
Chromium (/usr/bin/chromium, Playwright), then the script exits.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from rths3d.loop import run
from rths3d.record import Record
from rths3d.scene import load_scene
from rths3d.viz import Viewer, buffer_from_record


def make_record(path: Path) -> Path:
    """The contact test with delayed legs, 6 s, saved as Parquet (SI units)."""
    scene = load_scene("paper_contact", ["transfer.delay=0.02", "duration=6"])
    result = run(scene, "stewart", out=str(path), progress=True)
    print(f"{result.status}: {result.record.duration:.1f} s simulated, RTF {result.rtf:.1f}, "
          f"saved {result.out}")
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("record", nargs="?", help="a saved record (.parquet/.csv)")
    ap.add_argument("--screenshot", help="save a PNG of the page here and exit")
    ap.add_argument("--at", type=float, default=3.1, help="replay time of the picture (s)")
    ap.add_argument("--exaggeration", type=float, default=10.0, help="display factor k")
    ap.add_argument("--port", type=int, default=8080)
    ap.add_argument("--seconds", type=float, default=0.0, help="serve this long, then exit")
    args = ap.parse_args()
    if args.screenshot:
        from rths3d.figures import check_output
        from rths3d.viz.screenshot import require_browser

        require_browser()  # Playwright and Chromium, before the test runs
        check_output(args.screenshot, "--screenshot")

    path = Path(args.record) if args.record else make_record(Path("out/contact_delay.parquet"))
    record = Record.load(path)
    viewer = Viewer(buffer_from_record(record), port=0 if args.screenshot else args.port,
                    exaggeration=args.exaggeration, title=f"rths3d · {path.name}")
    if args.screenshot:
        def hold() -> None:  # the first page to connect sees the chosen moment
            viewer.playback.seek(args.at)
            viewer.playback.pause()

        viewer.on_first_client = hold
    viewer.start()
    print(f"replay: {viewer.url}")
    try:
        if args.screenshot:
            from rths3d.viz.screenshot import screenshot

            Path(args.screenshot).parent.mkdir(parents=True, exist_ok=True)
            check = screenshot(viewer.url, args.screenshot, width=1500, height=1080, settle=6.0)
            print(f"saved {args.screenshot}: {check}")
        elif args.seconds > 0:
            time.sleep(args.seconds)
        else:
            viewer.wait()
    finally:
        viewer.stop()


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None

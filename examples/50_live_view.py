"""Watch a hybrid test live in the browser while it runs.

Runs the paper's contact test (numerical mass-spring-damper on a moving support, coupled
through the Stewart platform and its force-torque sensor to a mass on a spring that hits a
surface) at real time. The page shows the platform, the specimen, the numerical substructure
as a ghost, the interface force, the SSP, z / z' / z^r / F'_m and running measures; its
controls pause, stop, change the speed, and restart with another transfer system or other
parameters. The run waits for the first browser to connect.

    python examples/50_live_view.py                   # open the printed address
    python examples/50_live_view.py --transfer lti --speed 0.5
    python examples/50_live_view.py --seconds 20 --out out/live.parquet
"""

from __future__ import annotations

import argparse
import time

from rths3d.viz.live import LiveRun


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="paper_contact", help="scene file or name")
    ap.add_argument("--transfer", default="stewart", help="ideal | delay | lti | stewart")
    ap.add_argument("--speed", type=float, default=1.0, help="× real time")
    ap.add_argument("--exaggeration", type=float, default=10.0, help="display factor k")
    ap.add_argument("--port", type=int, default=8080)
    ap.add_argument("--seconds", type=float, default=0.0, help="serve this long, then exit")
    ap.add_argument("--out", help="save the record of the last run (.parquet/.csv)")
    args = ap.parse_args()
    if args.out:
        from rths3d.figures import check_output

        check_output(args.out, "--out")

    live = LiveRun.from_scene(args.scene, transfer=args.transfer, speed=args.speed,
                              out=args.out)
    # The page is served from its own process; the loop copies new samples to it at its
    # control checks (≤ 30 times a second), so watching costs the loop almost nothing.
    view = live.view_process(port=args.port, exaggeration=args.exaggeration).start()
    print(f"live view: {view.url}  — the test starts when the page connects (Ctrl-C ends)")
    try:
        if args.seconds > 0:
            time.sleep(args.seconds)
        else:
            view.wait()
    except KeyboardInterrupt:
        pass
    finally:
        view.stop()
        saved = live.close()
        print(live.status())
        if saved:
            print(f"record saved: {saved}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None

"""Every accuracy measure of a hybrid test, from a record file.

A self-contained example: the paper's linear system (Fig. 5, Table 2: m_NUM = 9.62 kg,
k_NUM = 1e4 N/m, d_NUM = 100 kg/s, a spring specimen k_EXP = 8650 N/m, m_EXP = 0.38 kg, a
20 N, 0.5 Hz force on the numerical mass) is coupled through a lagging actuator (first-order
lag of 5 ms plus 3 ms transport delay) and, for the reference z^r, through an ideal one. The
test is written as a Parquet record, read back and measured:

    python examples/30_metrics_from_record.py [OUT_DIR]

It prints the measures and the ANN feature rows (paper Table 3), and writes the record and the
SSP, FEI-spectrum and time-history plots into OUT_DIR (default ``metrics_example_out``). The
same numbers come from the command line: ``rths3d metrics OUT_DIR/linear_test.parquet``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from rths3d.figures import check_output
from rths3d.metrics import FEATURE_SETS, compute_measures, feature_row
from rths3d.metrics.plots import plot_record
from rths3d.record import Record

DT = 1e-3  # s, interface time step ΔT
M_NUM, D_NUM, K_NUM = 9.62, 100.0, 1e4  # kg, kg/s, N/m
M_EXP, K_EXP = 0.38, 8650.0  # kg, N/m (the specimen is modelled as its spring here)
T_LAG, T_DELAY = 0.005, 0.003  # s: actuator first-order lag and transport delay


def simulate(seconds: float = 20.0, ideal: bool = False) -> dict[str, np.ndarray]:
    """Semi-implicit Euler at ΔT of m ẍ + d ẋ + k x = F_ext − F'_m, z = x, F'_m = k_EXP z'."""
    n = int(round(seconds / DT))
    t = np.arange(n) * DT
    f_ext = 20.0 * np.sin(2 * np.pi * 0.5 * t)
    x = v = zp = 0.0
    lag = int(round(T_DELAY / DT))
    z_hist = np.zeros(n)
    zp_hist = np.zeros(n)
    f_hist = np.zeros(n)
    for k in range(n):
        z_hist[k] = x
        if ideal:
            zp = x
        else:
            delayed = z_hist[k - lag] if k >= lag else 0.0
            zp += DT / T_LAG * (delayed - zp)
        zp_hist[k] = zp
        f_meas = K_EXP * zp
        f_hist[k] = f_meas
        v += DT * (f_ext[k] - f_meas - D_NUM * v - K_NUM * x) / M_NUM
        x += DT * v
    return {"t": t, "z_cmd": z_hist, "z_meas": zp_hist, "f_meas": f_hist, "f_ext": f_ext}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir", nargs="?", type=Path, default=Path("metrics_example_out"),
                    help="folder for the record and plots (default: metrics_example_out)")
    out_dir = check_output(ap.parse_args().out_dir, "OUT_DIR", folder=True)
    test = simulate()
    reference = simulate(ideal=True)
    meta = {"scene": "paper_linear (example)", "dt": DT, "transfer": "first-order lag + delay",
            "params": {"m_num": M_NUM, "k_num": K_NUM, "d_num": D_NUM},
            "experiment": {"m_exp": M_EXP, "k_exp": [[K_EXP]]}}
    columns = {k: v for k, v in test.items() if k != "t"}
    columns["z_ref"] = reference["z_cmd"]
    path = Record(test["t"], columns, meta).save(out_dir / "linear_test.parquet")
    record = Record.load(path)

    measures = compute_measures(record)
    print(f"record {path} ({record.n} samples, {record.duration:.1f} s)")
    for key, value in measures.items():
        print(f"  {key:15s} {value: .6g}")
    # the Euler-discretised lag y_k = y_(k−1) + ΔT/T (u_k − y_(k−1)) delays by T − ΔT
    expected = T_DELAY + T_LAG - DT
    print(f"actuator delay at low frequency: {1e3 * expected:.1f} ms expected, "
          f"FEI d = {1e3 * measures['fei_d']:.2f} ms, J1 = "
          f"{1e3 * measures.get('j1', float('nan')):.1f} ms")
    for s in (1, 2, 3):
        row = feature_row(record, set=s)
        print(f"feature set {s} ({len(FEATURE_SETS[s])}):",
              ", ".join(f"{k}={v:.4g}" for k, v in row.items()))
    for png in plot_record(record, out_dir):
        print(f"wrote {png}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None

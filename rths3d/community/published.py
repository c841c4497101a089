"""Published Table 3 of the benchmark paper (El Centro × 0.4, nominal plant, sample
controller, with noise): per case J1 (ms) and J2–J9 (%), in the evaluation code's order."""

from __future__ import annotations

PUBLISHED_TABLE3: dict[int, dict[str, float]] = {
    case: dict(zip([f"J{i}" for i in range(1, 10)], row, strict=True))
    for case, row in {
        1: (4.6, 10.4, 11.5, 36.1, 19.0, 32.3, 32.4, 14.8, 14.8),
        2: (4.6, 9.8, 11.1, 33.1, 17.1, 30.5, 30.5, 15.3, 15.2),
        3: (4.6, 9.1, 10.2, 49.9, 36.7, 49.8, 49.8, 35.5, 35.6),
        4: (4.6, 10.5, 11.3, 72.6, 35.2, 68.5, 68.7, 33.4, 33.3),
    }.items()
}

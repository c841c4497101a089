"""Resumable sweep storage: one Parquet part per finished batch, merged into one table.

Layout under the output folder ``DIR``::

    DIR/manifest.json          spec name, digest, batch size, batching scheme, number of
                               tests, hash of each family's scene file
    DIR/parts/<batch>.parquet  rows of one finished batch (written atomically)
    DIR/records/<test>.parquet per-test records (optional, ``keep_records``)
    DIR/<sweep name>.parquet   the merged table (written atomically when all parts exist)

A part appears only complete (temporary file + ``os.replace``), so a killed sweep leaves
finished parts intact and no half-written ones; re-running finds the parts and skips those
batches, so nothing is computed twice or duplicated.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import ConfigError

if TYPE_CHECKING:
    import pandas as pd

TABLE_META_KEY = b"rths3d_sweep"


def _text_if_mixed(frame):
    """``frame`` with every column that mixes text and other values (a parameter that is a
    number in one family and text in another) as text; missing values stay missing."""
    mixed = [c for c in frame.columns if frame[c].dtype.kind == "O"
             and len({isinstance(v, str) for v in frame[c].dropna()}) > 1]
    if not mixed:
        return frame
    frame = frame.copy()
    for c in mixed:
        frame[c] = frame[c].map(lambda v: v if v is None or v != v else str(v))
    return frame


def _atomic_write_table(frame, path: Path, meta: dict[str, Any] | None = None) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    path.parent.mkdir(parents=True, exist_ok=True)
    table = pa.Table.from_pandas(_text_if_mixed(frame), preserve_index=False)
    if meta is not None:
        md = dict(table.schema.metadata or {})
        md[TABLE_META_KEY] = json.dumps(meta, default=str).encode()
        table = table.replace_schema_metadata(md)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    pq.write_table(table, tmp)
    os.replace(tmp, path)


BATCHING = "group-aligned/2"
"""How tests are cut into batches (:func:`~rths3d.dataset.execute.batches_of`); a folder
written with another scheme holds other batch ids and cannot be resumed."""


class SweepStore:
    """The output folder of one sweep (see module docstring)."""

    def __init__(self, root: str | os.PathLike, name: str, digest: str, batch_size: int,
                 n_tests: int, scenes: Mapping[str, str] | None = None):
        self.root = Path(root)
        self.name = name
        self.digest = digest
        self.batch_size = batch_size
        self.n_tests = n_tests
        self.scenes = dict(scenes or {})
        """Hash of each family's scene file, by family name."""
        self.parts = self.root / "parts"
        self.records = self.root / "records"
        self.table_path = self.root / f"{name}.parquet"

    def open(self) -> SweepStore:
        """Create the folder or check that an existing one belongs to the same spec."""
        try:
            self.parts.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError("out", str(self.root),
                              f"cannot create the output folder: {exc.strerror}") from None
        man = self.root / "manifest.json"
        want = {"name": self.name, "digest": self.digest, "batch_size": self.batch_size,
                "batching": BATCHING, "n_tests": self.n_tests, "scenes": self.scenes}
        if man.exists():
            try:
                have = json.loads(man.read_text())
            except (OSError, UnicodeDecodeError, ValueError) as exc:
                raise ConfigError("out", str(man), f"unreadable manifest ({exc}); use a new "
                                  "--out folder") from None
            if not isinstance(have, dict):
                raise ConfigError("out", str(man), "not a sweep manifest; use a new --out "
                                  "folder")
            for key in ("digest", "batch_size", "batching"):
                if have.get(key) != want[key]:
                    what = {"batching": "folder was cut into batches by another rths3d version",
                            "batch_size": "batch_size differs"}.get(key,
                                                                    "folder holds another sweep")
                    raise ConfigError(
                        f"out ({self.root}) {key}", have.get(key),
                        f"{what} (this one: {want[key]}); use a new --out folder")
            # manifests written before scene hashes were kept have none: nothing to compare
            old = have.get("scenes")
            for fam, h in (old.items() if isinstance(old, dict) else ()):
                if fam in self.scenes and self.scenes[fam] != h:
                    raise ConfigError(
                        f"out ({self.root}) family {fam!r} scene", h,
                        "the scene file changed since this folder was started (its results "
                        "would mix both versions); use a new --out folder")
        else:
            tmp = man.with_name(f".{man.name}.tmp{os.getpid()}")
            tmp.write_text(json.dumps(want, indent=1))
            os.replace(tmp, man)
        return self

    def part_path(self, batch_id: str) -> Path:
        return self.parts / f"{batch_id}.parquet"

    def done(self) -> set[str]:
        """Batch ids whose parts are complete on disk."""
        return {p.stem for p in self.parts.glob("*.parquet")}

    def write_part(self, batch_id: str, rows: Sequence[dict[str, Any]]) -> Path:
        """Write one batch's rows atomically."""
        import pandas as pd

        path = self.part_path(batch_id)
        _atomic_write_table(pd.DataFrame(list(rows)), path)
        return path

    def merge(self, batch_ids: Sequence[str], meta: dict[str, Any],
              order: Sequence[str] | None = None):
        """Concatenate the parts into the sweep table (atomic) and return it: rows in the
        order of the test ids ``order`` (the spec's), else in batch order."""
        import pandas as pd

        frames = [pd.read_parquet(self.part_path(b)) for b in batch_ids]
        frame = pd.concat(frames, ignore_index=True, sort=False) if frames else pd.DataFrame()
        if order is not None and len(frame):
            pos = {tid: i for i, tid in enumerate(order)}
            frame = frame.iloc[frame["test_id"].map(pos).argsort(kind="stable")]
            frame = frame.reset_index(drop=True)
        frame = _text_if_mixed(frame)  # the returned table equals the written one
        _atomic_write_table(frame, self.table_path, meta)
        return frame


def read_table(path: str | os.PathLike) -> pd.DataFrame:
    """Read a sweep table (Parquet or CSV) as a DataFrame; ConfigError if unreadable."""
    import pandas as pd

    path = Path(path)
    if path.is_dir():
        cands = sorted(p for p in path.glob("*.parquet"))
        if len(cands) != 1:
            raise ConfigError("table", str(path), "folder must hold exactly one merged .parquet")
        path = cands[0]
    if not path.is_file():
        raise ConfigError("table", str(path), "file does not exist")
    try:
        if path.suffix.lower() == ".csv":
            return pd.read_csv(path)
        return pd.read_parquet(path)
    except Exception as exc:  # unreadable: name the file and the reason
        raise ConfigError("table", str(path), f"not a readable table: {exc}") from exc


def join_tables(frames: Sequence[pd.DataFrame]) -> pd.DataFrame:
    """One table of several sweep tables (rows stacked, columns united).

    A test that appears in more than one table (the same ``test_id``: the same family and
    parameters) is kept once, its first row, so that it cannot sit in the training and the
    test set at once; a ``UserWarning`` says how many were dropped.
    Parameter columns one sweep does not have are NaN in its rows.
    """
    import warnings

    import pandas as pd

    frames = [f for f in frames if f is not None and len(f)]
    if not frames:
        raise ConfigError("table", "no rows", "at least one table with tests")
    if len(frames) == 1:
        return frames[0]
    frame = _text_if_mixed(pd.concat(frames, ignore_index=True, sort=False))
    if "test_id" in frame.columns:
        dup = frame["test_id"].duplicated()
        if dup.any():
            warnings.warn(f"{int(dup.sum())} tests appear in more than one table; each is "
                          "kept once", UserWarning, stacklevel=2)
            frame = frame[~dup].reset_index(drop=True)
    return frame

"""Rows to Parquet as they arrive, in parts that a crash cannot damage.

A sink holds one or more tables, each a folder of Parquet files
(``OUT/<table>/part-00000.parquet``, ...) that ``pyarrow.parquet.read_table`` or
``pandas.read_parquet`` reads as one table. Rows are buffered and written as one
part per flush (every ``row_group`` rows or ``flush_s`` seconds, and at the end):
each table's part is written under a temporary name, then all are renamed, so a
part is either whole or absent. A flush writes the same part number in every
table; on resume a number that some table lacks (a crash between the renames) is
removed with its rows, and their jobs run again. A job's rows are never split
between parts, so the done jobs are exactly the keys found in ``key_table``.
"""

from __future__ import annotations

import os
import re
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from wsgrasp.errors import InputError

__all__ = ["PartSink", "require_pyarrow"]

_PART = re.compile(r"^part-(\d{5,})\.parquet$")


def require_pyarrow() -> Any:
    """``pyarrow``, or an ``InputError`` saying how to install it."""
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError as exc:
        raise InputError(
            f"Parquet output needs pyarrow, which is not installed ({exc})",
            hint="pip install pyarrow (or reinstall wsgrasp)",
        ) from None
    return pyarrow


class PartSink:
    """Tables of rows written to ``out`` part by part.

    Parameters
    ----------
    out
        The output folder; each table is a folder in it.
    schemas
        Table name → ``pyarrow.Schema``.
    key_table, key_columns
        The table whose ``key_columns`` name a job (one job: one or more rows).
    resume
        Continue what ``out`` holds; without it, a folder that holds rows is
        refused.
    row_group, flush_s
        Rows (of ``key_table``'s jobs) and seconds between flushes.
    """

    def __init__(
        self,
        out: Path,
        schemas: dict[str, Any],
        key_table: str,
        key_columns: Sequence[str],
        *,
        resume: bool = False,
        row_group: int = 64,
        flush_s: float = 10.0,
    ) -> None:
        require_pyarrow()
        self.out = Path(out)
        self.schemas = schemas
        self.key_table = key_table
        self.key_columns = tuple(key_columns)
        self.row_group = max(1, int(row_group))
        self.flush_s = float(flush_s)
        self._rows: dict[str, list[dict[str, Any]]] = {t: [] for t in schemas}
        self._jobs = 0
        self._last = time.monotonic()
        self.rows_written = 0
        parts = self._existing_parts()
        if parts and not resume:
            raise InputError(
                f"{self.out} already holds {len(parts)} parts of a run",
                hint="pass --resume to continue it, or choose another output folder",
            )
        if parts:
            self._check_columns(parts[-1])
        self._next = max(parts, default=-1) + 1
        self.done = self._done_keys() if parts else set()

    def _check_columns(self, n: int) -> None:
        """Refuse to resume a run whose parts have other columns than these
        tables' (one written by another wsgrasp version): the parts would not
        read back as one table."""
        import pyarrow.parquet as pq

        for table, schema in self.schemas.items():
            have = pq.read_schema(self._path(table, n)).names
            if have != schema.names:
                missing = [c for c in schema.names if c not in have]
                extra = [c for c in have if c not in schema.names]
                what = "; ".join(
                    f"{label} {', '.join(cols)}"
                    for label, cols in (("without", missing), ("with", extra))
                    if cols
                )
                raise InputError(
                    f"{self.out / table} was written with other columns ({what}) "
                    "than this version writes",
                    hint="write to a new output folder, or resume with the "
                    "wsgrasp version that started it",
                )

    # ----------------------------------------------------------------------------
    def _existing_parts(self) -> list[int]:
        """Part numbers found in every table; the rest (and temporary files of a
        crashed flush) are removed."""
        found: dict[str, set[int]] = {}
        for table in self.schemas:
            folder = self.out / table
            found[table] = set()
            if not folder.is_dir():
                continue
            for f in folder.iterdir():
                m = _PART.match(f.name)
                if m:
                    found[table].add(int(m.group(1)))
                elif f.name.startswith(".part-"):
                    f.unlink(missing_ok=True)
        whole = set.intersection(*found.values()) if found else set()
        for table, numbers in found.items():
            for n in numbers - whole:
                self._path(table, n).unlink(missing_ok=True)
        return sorted(whole)

    def _path(self, table: str, n: int) -> Path:
        return self.out / table / f"part-{n:05d}.parquet"

    def _done_keys(self) -> set[tuple[Any, ...]]:
        import pyarrow.parquet as pq

        folder = self.out / self.key_table
        t = pq.read_table(folder, columns=list(self.key_columns))
        cols = [t.column(c).to_pylist() for c in self.key_columns]
        return set(zip(*cols, strict=True))

    def missing(self, keys: Sequence[tuple[Any, ...]]) -> list[int]:
        """Indices of the ``keys`` (in order) whose jobs are not written yet."""
        return [i for i, k in enumerate(keys) if k not in self.done]

    # ----------------------------------------------------------------------------
    def add(self, rows: dict[str, list[dict[str, Any]]]) -> None:
        """One job's rows, by table; flushed with the next part when due."""
        for table, rs in rows.items():
            self._rows[table].extend(rs)
        for r in rows.get(self.key_table, []):
            self.done.add(tuple(r[c] for c in self.key_columns))
        self._jobs += 1
        due = len(self._rows[self.key_table]) >= self.row_group
        if due or time.monotonic() - self._last >= self.flush_s:
            self.flush()

    def flush(self) -> None:
        """Write the buffered rows as one part of every table (none if empty)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        self._last = time.monotonic()
        if not self._jobs:
            return
        n = self._next
        written: list[tuple[Path, Path]] = []
        for table, schema in self.schemas.items():
            path = self._path(table, n)
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.parent / f".{path.name}.{os.getpid()}"
            data = pa.Table.from_pylist(self._rows[table], schema=schema)
            pq.write_table(data, tmp, compression="zstd")
            written.append((tmp, path))
        for tmp, path in written:
            os.replace(tmp, path)
        self.rows_written += len(self._rows[self.key_table])
        self._rows = {t: [] for t in self.schemas}
        self._jobs = 0
        self._next = n + 1

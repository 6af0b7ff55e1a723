"""``--delivered``: the order ids an earlier stops file delivered (sim.scenario)."""

from __future__ import annotations

import os
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from marops_cli.errors import InputError
from marops_cli.sim.scenario import delivered_orders


def _write(path: Path, kind: pa.Array, order_id: pa.Array) -> Path:
    pq.write_table(pa.table({"kind": kind, "order_id": order_id}), path)
    return path


def test_the_customers_ids_are_read(tmp_path: Path) -> None:
    kinds = pa.array(["depot", "customer", "customer", "depot"])
    p = _write(tmp_path / "stops.parquet", kinds, pa.array([None, "7", "9", None]))
    # Each id with its stops' places; none in a file of ids alone (by hand): every
    # request of the id counts as delivered.
    assert delivered_orders(p) == {"7": None, "9": None}
    assert delivered_orders(tmp_path) == {"7": None, "9": None}  # a folder: its stops.parquet
    q = _write(tmp_path / "ints.parquet", kinds, pa.array([None, 7, 9, None]))
    assert delivered_orders(q) == {"7": None, "9": None}  # ids written as numbers by hand


@pytest.mark.parametrize(
    ("kind", "order_id", "column"),
    [
        (pa.array(["customer"]), pa.array([["7"]]), "order_id"),
        (pa.array(["customer"]), pa.array([b"7"]), "order_id"),
        (pa.array([["customer"]]), pa.array(["7"]), "kind"),
    ],
    ids=["list-ids", "binary-ids", "list-kinds"],
)
def test_columns_that_match_nothing_are_refused(tmp_path, kind, order_id, column) -> None:
    # A list or bytes never equals an order id: the file would silently deliver nothing.
    p = _write(tmp_path / "stops.parquet", kind, order_id)
    with pytest.raises(InputError, match=rf"column '{column}': not a marops stops file"):
        delivered_orders(p)


def test_a_file_of_more_rows_than_any_day_has_stops_is_refused_unread(tmp_path: Path) -> None:
    """Millions of repeated rows compress to kilobytes (30 million: 168 kB), and every
    row was read into memory (3 GB, a minute and a half): one row more than any day's
    stops is refused by the file's footer, naming the file."""
    import numpy as np

    from marops_cli.config import MAX_DAY_STOPS

    n = MAX_DAY_STOPS + 1
    zeros = pa.array(np.zeros(n, dtype=np.int32))
    kinds = pa.DictionaryArray.from_arrays(zeros, pa.array(["customer"]))
    p = _write(tmp_path / "stops.parquet", kinds, pa.DictionaryArray.from_arrays(zeros, ["7"]))
    assert p.stat().st_size < 1 << 20
    with pytest.raises(InputError, match=rf"{n:,} rows, more than the {n - 1:,} stops") as e:
        delivered_orders(p)
    assert e.value.file == str(p)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_a_pipe_is_no_stops_file(tmp_path: Path) -> None:
    fifo = tmp_path / "stops.parquet"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="not a regular file"):
        delivered_orders(fifo)


def test_a_file_without_the_columns_or_of_json_says_what_it_lacks(tmp_path: Path) -> None:
    """A Parquet file of other columns names the one missing (it showed Arrow's
    'No match for FieldRef.Name(kind)'); a JSON run's stops say why they cannot serve."""
    p = tmp_path / "other.parquet"
    pq.write_table(pa.table({"order_id": ["7"]}), p)
    with pytest.raises(InputError, match=r"not a marops stops file \(no column 'kind'\)$"):
        delivered_orders(p)
    day = tmp_path / "json-day"
    day.mkdir()
    (day / "stops.json").write_text("{}")
    for given in (day, day / "stops.json"):
        with pytest.raises(InputError, match="writes stops.json instead: replay that day"):
            delivered_orders(given)

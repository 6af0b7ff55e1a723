"""Result tables that fit the terminal with every cell whole.

rich shrinks a table wider than the terminal by cutting its cells (``15…``, ``0.…``),
which leaves numbers unreadable on an 80-column terminal. Here each column is as wide
as its widest cell, its header wraps within that width, and the columns that do not fit
beside the key columns (the first ``keys``: day, method, metric) go on to a further
table that repeats the keys.
"""

from __future__ import annotations

from rich.cells import cell_len
from rich.table import Column, Table

_PER_COLUMN = 3  # a cell's padding (one space each side) and the border after it
_EDGE = 1  # the table's left border


def _need(column: Column) -> int:
    """Width that shows every cell whole and the header's longest word."""
    header = str(column.header).split() or [""]
    cells = [cell_len(str(c)) for c in column.cells]
    return max([cell_len(w) for w in header] + cells)


def fit_table(table: Table, width: int, keys: int = 1) -> list[Table]:
    """``table`` as one or more tables no wider than ``width``, every cell whole: the
    columns after the first ``keys`` are spread over as many tables as needed, each
    repeating the keys (a part's title says which part it is)."""
    columns = list(table.columns)
    keys = min(keys, len(columns))
    need = [_need(c) for c in columns]
    key_cost = _EDGE + sum(n + _PER_COLUMN for n in need[:keys])
    parts: list[list[int]] = [[]]
    used = key_cost
    for i in range(keys, len(columns)):
        cost = need[i] + _PER_COLUMN
        if parts[-1] and used + cost > width:
            parts.append([])
            used = key_cost
        parts[-1].append(i)
        used += cost
    return [
        _part(table, columns, need, [*range(keys), *rest], (n, len(parts)))
        for n, rest in enumerate(parts, 1)
    ]


def _part(
    table: Table, columns: list[Column], need: list[int], keep: list[int], which: tuple[int, int]
) -> Table:
    """A table of the columns ``keep`` of ``table``, each exactly as wide as it needs."""
    title = table.title
    if which[1] > 1 and title is not None:
        title = f"{title} ({which[0]}/{which[1]})"
    part = Table(
        title=title,
        title_justify=table.title_justify,
        show_header=table.show_header,
        box=table.box,
        show_edge=table.show_edge,
        pad_edge=table.pad_edge,
    )
    for i in keep:
        c = columns[i]
        part.add_column(c.header, justify=c.justify, style=c.style, width=need[i], overflow="fold")
    cells = [list(columns[i].cells) for i in keep]
    for row in zip(*cells, strict=True):
        part.add_row(*row)
    return part

"""The one-line form of a bad-input error (docs/outputs.md, exit codes)."""

from __future__ import annotations

from pathlib import Path

from marops_cli.errors import InputError


def test_a_table_names_row_and_column() -> None:
    line = str(InputError("not a number", file="day.csv", row=3, column="lat"))
    assert line == "day.csv, row 3, column 'lat': not a number"


def test_a_config_or_sidecar_names_the_key() -> None:
    line = str(InputError("expected > 0", file="fleet.toml", column="types.jet.speed_ms"))
    assert line == "fleet.toml, key 'types.jet.speed_ms': expected > 0"
    assert "key 'format'" in str(InputError("bad", file="a.JSON", column="format"))
    # a tensor of a weights file is not a key of a TOML or JSON file
    assert "column 'weight'" in str(InputError("bad", file="a.safetensors", column="weight"))


def test_not_found_says_why_a_path_leads_to_nothing(tmp_path: Path) -> None:
    from marops_cli.errors import not_found

    missing = tmp_path / "missing.json"
    assert str(not_found(missing, "depots file")) == f"{missing}: depots file not found"
    dangling = tmp_path / "link.json"
    dangling.symlink_to(missing)
    assert str(not_found(dangling, "depots file")) == (
        f"{dangling}: depots file not found: a symbolic link to {missing}, which does not exist"
    )
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    assert str(not_found(loop)) == f"{loop}: is a loop of symbolic links, not a file"


def test_a_path_that_is_no_file_says_what_it_is(tmp_path: Path) -> None:
    """A folder or a pipe where a policy file goes exists: not 'not found'."""
    import os

    from marops_cli.errors import not_a_file

    folder = tmp_path / "actor.pt"
    folder.mkdir()
    assert str(not_a_file(folder, "policy file")) == (
        f"{folder}: is a folder, expected a policy file"
    )
    pipe = tmp_path / "actor.safetensors"
    os.mkfifo(pipe)
    assert "is not a regular file" in str(not_a_file(pipe, "policy file"))
    missing = tmp_path / "missing.pt"
    assert str(not_a_file(missing, "policy file")) == f"{missing}: policy file not found"


def test_a_number_too_long_to_read_is_said_as_such() -> None:
    # Python's message advises calling sys.set_int_max_str_digits(): no use on a command line.
    import pytest

    from marops_cli.data.jsonfile import parse_json, parse_toml

    for parse, text in ((parse_json, "[1" + "0" * 5000 + "]"), (parse_toml, "x = 1" + "0" * 5000)):
        with pytest.raises(ValueError, match="^a number of 5001 digits, more than the 4300 read$"):
            parse(text)
    with pytest.raises(ValueError, match="Expecting"):  # other malformed documents as before
        parse_json("[1,")


def test_a_huge_value_in_a_message_keeps_the_line_short() -> None:
    """A file's value of megabytes quoted in an error: the line keeps its start and its
    end (what failed, what to do) and stays short; ``quoted`` clips a value to 80."""
    from marops_cli.errors import MAX_MESSAGE, RunError, quoted

    value = "x" * 10_000_000
    err = InputError(f"got {value!r}; use another file", file="a.json", column="k" * 5000)
    line = str(err)
    assert line.startswith("a.json, key 'kkk") and line.endswith("; use another file")
    assert len(err.message) <= MAX_MESSAGE + 40 and len(line) < 2 * MAX_MESSAGE
    assert "characters)…" in line
    assert len(str(RunError(value))) < 20_000
    assert quoted(value) == "'" + "x" * 78 + "…" and quoted("short") == "'short'"
    # A message within the bound is as written.
    assert str(InputError("got 'y'", file="a.json")) == "a.json: got 'y'"

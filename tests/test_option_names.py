"""A bad option's error names it as its caller spells it: the Python API's keyword
(``alpha``), the command line's flag (``--alpha``), from one message of the use case."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from marops_cli import api as marops
from marops_cli.cli.app import app
from marops_cli.errors import InputError, keyword, option, switch


def test_a_message_names_an_option_as_a_flag_until_respelled_as_a_keyword() -> None:
    exc = InputError(f"{option('n_depots')} 0: pass {switch('force')}", file="a.csv")
    assert str(exc) == exc.format() == "a.csv: --n-depots 0: pass --force"
    assert exc.message == "--n-depots 0: pass --force"
    exc.respell(keyword)
    assert str(exc) == "a.csv: n_depots 0: pass force=True"
    assert exc.file == "a.csv"
    # An option's flag or keyword of another name: segment's --seed sets segment_seed.
    assert str(InputError(option("segment_seed") + " " + option("fmt"))) == "--seed --format"
    renamed = InputError(option("segmentation") + " " + option("segment_seed"))
    renamed.respell(keyword)
    assert str(renamed) == "segmentation seed"


Call = Callable[[Path, Path, Path], Any]


@pytest.fixture(scope="module")
def depots(example_csv: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A depots file of the example, for the checks made once the depots are read."""
    path = tmp_path_factory.mktemp("depots") / "depots.json"
    marops.segment(example_csv, out=path, dates="0801..0803")
    return path


API_CASES: list[tuple[str, Call, str]] = [
    ("read_lade", lambda d, t, k: marops.read_lade(d, year=1900), r"^read_lade\(\): year: "),
    ("segment", lambda d, t, k: marops.segment(d, n_depots=0), r"^invalid option n_depots: "),
    (
        "segment",
        lambda d, t, k: marops.segment(d, segmentation="nope"),
        r"^invalid option segmentation: ",
    ),
    ("segment", lambda d, t, k: marops.segment(d, center="north"), r"^center expects LNG,LAT"),
    ("segment", lambda d, t, k: marops.segment(d, dates="x"), r"^invalid option dates: "),
    ("segment", lambda d, t, k: marops.segment(d, hubs=0), r"^hubs expects a number of hubs"),
    (
        "segment",
        lambda d, t, k: marops.segment(d, actions=99),
        r"give actions 16 or fewer, or n_depots 99 or more$",
    ),
    (
        "plan_window",
        lambda d, t, k: marops.plan_window(d, t / "depots.json", "0811", 5, alpha=2),
        r"^invalid option alpha: Input should be less than or equal to 1, got 2.0",
    ),
    (
        "plan_window",
        lambda d, t, k: marops.plan_window(d, k, "0811", 99),
        r"^window 99 is outside 0\.\.15$",
    ),
    (
        "plan_window",
        lambda d, t, k: marops.plan_window(d, t / "depots.json", "x", 5),
        r"^invalid option date: ",
    ),
    (
        "plan_window",
        lambda d, t, k: marops.plan_window(d, t / "depots.json", "0811", 5, fmt="xml"),
        r"^fmt expects parquet or json",
    ),
    (
        "replay_day",
        lambda d, t, k: marops.replay_day(d, "0811", method="nope"),
        r"^unknown method 'nope'",
    ),
    (
        "replay_day",
        lambda d, t, k: marops.replay_day(d, "0811", segment="nope"),
        r"^segment expects kmeans or squares",
    ),
    (
        "replay_day",
        lambda d, t, k: marops.replay_day(d, "0811", drones=0),
        r"^invalid option drones: ",
    ),
    (
        "evaluate",
        lambda d, t, k: marops.evaluate(d, workers=0),
        r"^workers expects 1 to 256, got 0$",
    ),
    (
        "evaluate",
        lambda d, t, k: marops.evaluate(d, workers=1, repeats=0),
        r"^invalid option repeats: got 0",
    ),
    (
        "evaluate",
        lambda d, t, k: marops.evaluate(d, workers=1, split="nope"),
        r"^split expects test or train",
    ),
    (
        "evaluate",
        lambda d, t, k: marops.evaluate(d, workers=1, alpha="0.2,x"),
        r"^alpha expects numbers separated by commas",
    ),
    (
        "evaluate",
        lambda d, t, k: marops.evaluate(d, workers=1, methods=" "),
        r"^methods lists no method$",
    ),
    (
        "evaluate",
        lambda d, t, k: marops.evaluate(d, workers=1, methods=","),
        r"^methods expects method names separated by commas, got ','$",
    ),
    (
        "evaluate",
        lambda d, t, k: marops.evaluate(d, workers=1, methods="stay", against="myopic"),
        r"^against 'myopic' is not among methods \(stay\); add it to methods$",
    ),
    (
        # The reference alone: nothing to pair with it (paired.csv was an empty file).
        "evaluate",
        lambda d, t, k: marops.evaluate(d, workers=1, methods="stay", against="stay"),
        r"^against 'stay' leaves no other method of methods \(stay\) to compare with it; "
        r"add one to methods$",
    ),
    (
        "evaluate",
        lambda d, t, k: marops.evaluate(d, workers=1, policy=t / "actor.pt"),
        r"actor.pt: trained actor not found \(policy\)$",
    ),
    ("report", lambda d, t, k: marops.report(5), r"^report\(\): folder expects a path"),
]


@pytest.mark.parametrize(
    ("call", "message"),
    [case[1:] for case in API_CASES],
    ids=[f"{i}-{case[0]}" for i, case in enumerate(API_CASES)],
)
def test_the_api_names_the_keyword(
    example_csv: Path, tmp_path: Path, depots: Path, call: Call, message: str
) -> None:
    with pytest.raises(InputError, match=message) as err:
        call(example_csv, tmp_path, depots)
    assert "--" not in str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_every_api_function_has_a_case() -> None:
    functions = {n for n in marops.__all__ if callable(getattr(marops, n)) and n[0].islower()}
    assert functions == {case[0] for case in API_CASES}


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["segment", "{data}", "--n-depots", "0"], "invalid option --n-depots: "),
        (["segment", "{data}", "--hubs", "0"], "--hubs expects a number of hubs"),
        # A stage's own check of two settings names the options given of it.
        (
            ["segment", "{data}", "--segmentation", "squares", "--n-depots", "7"],
            "invalid option --n-depots, --segmentation: expected a square number of depots",
        ),
        (
            ["segment", "{data}", "--n-depots", "4096", "--actions", "4096"],
            "invalid option --n-depots, --actions: 4096 depots",
        ),
        (
            ["plan-window", "{data}", "--depots", "{tmp}/d.json", "--date", "0811"]
            + ["--window", "5", "--alpha", "2"],
            "invalid option --alpha: Input should be less than or equal to 1, got 2.0",
        ),
        (
            ["plan-window", "{data}", "--depots", "{depots}", "--date", "0811"]
            + ["--window", "99"],
            "marops: error: --window 99 is outside 0..15",
        ),
        (["replay-day", "{data}", "--date", "0811", "--segment", "x"], "--segment expects"),
        (["evaluate", "{data}", "--workers", "0"], "--workers expects 1 to 256, got 0"),
        (["evaluate", "{data}", "--alpha", "0.2,x"], "--alpha expects numbers separated"),
        # Numbers in ASCII digits only: int() and float() read these Arabic-Indic ones.
        (["segment", "{data}", "--hubs", "\u0663"], "--hubs expects a number of hubs"),
        (["segment", "{data}", "--center", "\u0661\u0662\u0661,\u0663\u0661"], "--center expects"),
        (["evaluate", "{data}", "--alpha", "0.2,\u0660.\u0665"], "--alpha expects numbers"),
        (["evaluate", "{data}", "--drones", "\uff18"], "--drones expects whole numbers"),
        (
            ["evaluate", "{data}", "--methods", "stay", "--against", "myopic"],
            "--against 'myopic' is not among --methods (stay); add it to --methods",
        ),
        (
            ["evaluate", "{data}", "--methods", "stay", "--against", "stay"],
            "--against 'stay' leaves no other method of --methods (stay) to compare with it",
        ),
    ],
)
def test_the_command_line_names_the_flag(
    example_csv: Path,
    tmp_path: Path,
    depots: Path,
    fails_cleanly: Callable[..., str],
    args: list[str],
    message: str,
) -> None:
    out = {"segment": "d.json"}.get(args[0], "out")
    given = [a.format(data=example_csv, tmp=tmp_path, depots=depots) for a in args]
    fails_cleanly([*given, "--out", str(tmp_path / out)], tmp_path, message)


def test_the_api_asks_for_the_keyword_where_the_command_asks_for_the_flag(
    example_csv: Path, tmp_path: Path
) -> None:
    mine = tmp_path / "depots.json"
    mine.write_text("mine\n")
    with pytest.raises(InputError) as err:
        marops.segment(example_csv, out=mine)
    assert str(err.value).endswith(
        "depots.json: exists and was not written by marops; pass force=True to replace it"
    )
    with pytest.raises(InputError, match=r"is not a folder \(the out of replay-day, "):
        marops.report(mine)
    assert mine.read_text() == "mine\n"
    res = CliRunner().invoke(app, ["segment", str(example_csv), "--out", str(mine)])
    assert res.exit_code == 2
    assert res.stderr.endswith(
        "depots.json: exists and was not written by marops; pass --force to replace it\n"
    )

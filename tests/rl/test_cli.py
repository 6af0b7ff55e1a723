"""``marops train`` on the command line: thin over the library, its actor replays a day."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from marops_cli.cli.app import app
from marops_cli.rl.es import write_landing_actor

runner = CliRunner()
pytestmark = pytest.mark.filterwarnings("ignore:`torch.jit:DeprecationWarning")


def test_train_then_replay(tiny_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "cli.pt"
    res = runner.invoke(
        app,
        [
            "train",
            str(tiny_csv),
            "--episodes",
            "2",
            "--workers",
            "1",
            "--drones",
            "4",
            "--n-depots",
            "8",
            "--data-origin",
            "tiny synth",
            "--out",
            str(out),
        ],
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(out.with_suffix(".json").read_text())
    assert doc["episodes"] == 2 and doc["data"]["origin"] == "tiny synth"
    assert doc["planner_config"]["sim"]["drones"] == 4
    assert "held-out" in res.output  # the table of the last evaluation
    wrote = next(line for line in res.stderr.splitlines() if line.startswith("wrote "))
    for suffix in (".pt", ".safetensors", ".json", ".curve.png", ".ckpt"):  # all it wrote
        assert str(out.with_suffix(suffix)) in wrote and out.with_suffix(suffix).is_file()
    day = doc["data"]["heldout_days"][0]
    res = runner.invoke(
        app,
        [
            "replay-day",
            str(tiny_csv),
            "--date",
            day,
            "--policy",
            str(out),
            "--drones",
            "4",
            "--n-depots",
            "8",
            "--out",
            str(tmp_path / "replay"),
        ],
    )
    assert res.exit_code == 0, res.output


def test_train_refuses_a_foreign_checkpoint(tiny_csv: Path, tmp_path: Path) -> None:
    out = tmp_path / "x.pt"
    out.with_suffix(".ckpt").write_bytes(b"not a checkpoint")
    res = runner.invoke(app, ["train", str(tiny_csv), "--episodes", "2", "--out", str(out)])
    # a checkpoint marops did not write is not marops's, whatever its name
    assert res.exit_code == 2 and "not written by marops" in res.output


def test_train_refuses_a_checkpoint_that_is_not_this_runs(
    tiny_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """A checkpoint naming marops's format that is no state of this run's networks, a
    list or a real one with an edited actor, is one line naming it, nothing written."""
    import torch

    args = ["train", str(tiny_csv), "--workers", "1", "--drones", "4", "--n-depots", "8"]
    out = tmp_path / "a.pt"
    ckpt = out.with_suffix(".ckpt")
    torch.save(["marops-train-ckpt/1"], ckpt)
    line = fails_cleanly([*args, "--episodes", "1", "--out", str(out)], tmp_path, str(ckpt))
    assert "not a training checkpoint" in line and "pass --no-resume" in line
    ckpt.unlink()
    res = runner.invoke(app, [*args, "--episodes", "1", "--out", str(out)])
    assert res.exit_code == 0, res.output
    state = torch.load(ckpt, weights_only=True)
    state["actor"]["extra.weight"] = torch.zeros(1)
    torch.save(state, ckpt)
    line = fails_cleanly([*args, "--episodes", "2", "--out", str(out)], tmp_path, str(ckpt))
    assert "not a training checkpoint of this run" in line and '"extra.weight"' in line
    del state["actor"]["extra.weight"]
    del state["history"]
    torch.save(state, ckpt)
    line = fails_cleanly([*args, "--episodes", "2", "--out", str(out)], tmp_path, str(ckpt))
    assert "(history: a training checkpoint needs history); pass --no-resume" in line
    state["history"], state["episode"], state["update"] = [], -5, -5
    torch.save(state, ckpt)
    line = fails_cleanly([*args, "--episodes", "2", "--out", str(out)], tmp_path, str(ckpt))
    assert "(episode: expected episode ≥ 0, got -5); pass --no-resume" in line
    state["episode"] = state["update"] = float("inf")
    torch.save(state, ckpt)
    line = fails_cleanly([*args, "--episodes", "2", "--out", str(out)], tmp_path, str(ckpt))
    assert "(episode: expected a whole number, got inf); pass --no-resume" in line


def test_train_refuses_an_edited_checkpoint_before_training(
    tiny_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """A checkpoint with this run's fingerprint whose weights are not finite or whose
    progress (best actor, evaluations, learning curve, counts) could not be read back
    at the end is refused up front in one line, not by a traceback after the training."""
    import pickle

    import torch

    args = ["train", str(tiny_csv), "--workers", "1", "--drones", "4", "--n-depots", "8"]
    out = tmp_path / "a.pt"
    res = runner.invoke(app, [*args, "--episodes", "2", "--out", str(out)])
    assert res.exit_code == 0, res.output
    ckpt = out.with_suffix(".ckpt")
    good = torch.load(ckpt, weights_only=True)

    def nan(part: str):
        return lambda s: s[part]["head.bias"].fill_(float("nan"))

    edits = {
        "actor holds NaN": nan("actor"),
        "critic holds NaN": lambda s: next(iter(s["critic"].values())).fill_(float("inf")),
        "best actor holds NaN": lambda s: s["best"]["actor"]["head.bias"].fill_(float("nan")),
        "best must be one of the evaluations": lambda s: s["best"].update(episode=99),
        "(best.daily_combined_cost: a best evaluation needs daily_combined_cost)": lambda s: s[
            "best"
        ].pop("daily_combined_cost"),
        "best's actor is not this run's network": lambda s: s["best"]["actor"].update(
            {"head.bias": torch.zeros(1)}
        ),
        "(history[0].reward: a history entry needs reward)": lambda s: s.update(
            history=[{"episode": 1}]
        ),
        "(evals[0].episode: expected a whole number, got '2')": lambda s: s["evals"][0].update(
            episode="2"
        ),
        "(episode: expected a whole number, got 1.5)": lambda s: s.update(episode=1.5),
    }
    for needle, edit in edits.items():
        state = pickle.loads(pickle.dumps(good))
        edit(state)
        torch.save(state, ckpt)
        line = fails_cleanly([*args, "--episodes", "4", "--out", str(out)], tmp_path, str(ckpt))
        assert needle in line and "pass --no-resume" in line, (needle, line)


def test_train_names_what_differs_from_the_checkpoint(
    tiny_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """Resuming after changing an option names the setting and both values; a checkpoint
    of the other --algorithm says so (it was 'not valid JSON', or torch's advice to load
    it unsafely)."""
    args = ["train", str(tiny_csv), "--workers", "1", "--drones", "4", "--n-depots", "8"]
    out = tmp_path / "a.pt"
    res = runner.invoke(app, [*args, "--episodes", "1", "--out", str(out)])
    assert res.exit_code == 0, res.output
    line = fails_cleanly([*args, "--episodes", "2", "--seed", "3", "--out", str(out)], tmp_path)
    assert "other settings (train.seed: 0 in it, 3 now); pass --no-resume" in line
    line = fails_cleanly([*args, "--episodes", "2", "--alpha", "0.3", "--out", str(out)], tmp_path)
    assert "(planner.plan.alpha: 0.5 in it, 0.3 now)" in line
    res = runner.invoke(app, [*args, "--episodes", "2", "--out", str(out)])
    assert res.exit_code == 0, res.output
    # fewer episodes than it holds: it exported the longer run's actor as this one's
    line = fails_cleanly([*args, "--episodes", "1", "--out", str(out)], tmp_path)
    assert "checkpoint is at episode 2, past --episodes 1: pass --episodes 2 or more" in line
    es = [*args, "--algorithm", "es", "--episodes", "1", "--out", str(tmp_path / "a.safetensors")]
    line = fails_cleanly(es, tmp_path, str(out.with_suffix(".ckpt")))
    assert "the recurrent actor's training checkpoint (--algorithm ppo)" in line
    landing = tmp_path / "b.pt"
    landing.with_suffix(".ckpt").write_text('{"format": "marops-landing-ckpt/1"}')
    line = fails_cleanly([*args, "--episodes", "1", "--out", str(landing)], tmp_path)
    assert "the landing actor's training checkpoint (--algorithm es)" in line


def test_train_on_cities_with_fewer_depots_than_destinations_names_them(
    tiny_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """A segmentation of 2 depots gives each drone 2 destinations, 8 depots give 4: one
    actor cannot serve both, and the line says which counts differ and what to ask."""
    args = ["train", str(tiny_csv), "--workers", "1", "--drones", "4", "--n-depots", "8,2"]
    line = fails_cleanly([*args, "--episodes", "1", "--out", str(tmp_path / "a.pt")], tmp_path)
    assert "destinations per drone (segment.n_actions)" in line
    assert "2 with 2 depots, 4 with 8 depots" in line
    assert "at least 4 depots in every city (--n-depots)" in line


def test_train_refuses_more_scenarios_than_a_run_trains_on_before_reading(
    tiny_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """Every file × area count × fleet size × battery setting is a scenario evaluated on
    its held-out days: 1000 fleet sizes × 199 area counts made 199,000 of them and ran
    out of memory, 1000 alone queued days of evaluation. Over 1000, one line naming the
    counts, before any file is read."""
    drones = ",".join(str(u) for u in range(1, 201))
    args = ["train", str(tiny_csv), "--workers", "1"]
    args += ["--drones", drones, "--n-depots", "2,3,4,5,6,7"]
    line = fails_cleanly([*args, "--episodes", "1", "--out", str(tmp_path / "a.pt")], tmp_path)
    assert line == (
        "marops: error: training would make 1200 scenarios (1 file × 6 area counts × "
        "200 fleet sizes × 1 battery setting), more than the 1,000 one run trains on "
        "(docs/config.md): give fewer values of --n-depots, --drones, --spares or --batteries"
    )


@pytest.mark.parametrize(
    ("flag", "values", "says"),
    [
        ("--drones", "4,1001", "got 1001 (expected 1 ≤ drones ≤ 1000"),
        ("--n-depots", "8,5000", "got 5000 (expected 1 ≤ n_depots ≤ 4096"),
        ("--spares", "1,10001", "got 10001 (expected 0 ≤ batteries_per_depot ≤ 10000"),
    ],
)
def test_every_value_of_a_training_sweep_is_checked_before_reading(
    tmp_path: Path, fails_cleanly, flag: str, values: str, says: str
) -> None:
    """Only the first of several fleet sizes, depot counts or spare counts was checked up
    front; the others once the file was read (and segmented), called by their setting
    (``invalid option sim.drones``). Now every value, named by its flag, before any file
    is read: a file that is no LaDe export is never opened."""
    data = tmp_path / "lade.csv"
    data.write_text("not a LaDe export\n")
    args = ["train", str(data), "--episodes", "1", "--workers", "1", flag, values]
    line = fails_cleanly([*args, "--out", str(tmp_path / "a.pt")], tmp_path)
    assert line.startswith(f"marops: error: invalid option {flag}: ") and says in line


def test_a_checkpoint_that_unpacks_to_gigabytes_is_refused_unopened(
    tiny_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """A torch archive whose listing says its pickle unpacks to 5 GB is neither read to
    see whose it is nor loaded to resume: one line, nothing written."""
    import pickle
    import struct
    import zipfile

    out = tmp_path / "a.pt"
    ckpt = out.with_suffix(".ckpt")
    with zipfile.ZipFile(ckpt, "w") as archive:
        archive.writestr("a/data.pkl", pickle.dumps({"format": "marops-train-ckpt/1"}))
    raw = bytearray(ckpt.read_bytes())
    central = raw.rindex(b"PK\x01\x02")  # the listing's entry: its uncompressed size
    raw[central + 24 : central + 28] = struct.pack("<I", 0xFFFFFFF0)
    ckpt.write_bytes(bytes(raw))
    assert zipfile.ZipFile(ckpt).infolist()[0].file_size == 0xFFFFFFF0
    args = ["train", str(tiny_csv), "--workers", "1", "--drones", "4", "--n-depots", "8"]
    line = fails_cleanly([*args, "--episodes", "1", "--out", str(out)], tmp_path, str(ckpt))
    assert "not a training checkpoint: it unpacks to 4.3 GB" in line


def test_train_rejects_bad_options(tiny_csv: Path, tmp_path: Path) -> None:
    res = runner.invoke(app, ["train", str(tiny_csv), "--out", str(tmp_path / "x.onnx")])
    assert res.exit_code != 0 and ".pt" in res.output
    res = runner.invoke(
        app, ["train", str(tiny_csv), "--method", "dqn", "--out", str(tmp_path / "x.pt")]
    )
    assert res.exit_code != 0 and "method" in res.output


def test_train_refuses_an_observation_version_the_actor_does_not_use(
    tiny_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """--obs-version 5 with mappo or the landing actor was ignored (the sidecar's
    train_config said 5 of an actor of version 2)."""
    args = ["train", str(tiny_csv), "--obs-version", "5", "--episodes", "1"]
    line = fails_cleanly([*args, "--method", "mappo", "--out", str(tmp_path / "a.pt")], tmp_path)
    assert "--obs-version is the recurrent marops actor's; --method mappo has its own" in line
    es = [*args, "--algorithm", "es", "--out", str(tmp_path / "a.safetensors")]
    assert "--algorithm es (the landing actor)" in fails_cleanly(es, tmp_path)


def test_train_days_the_file_lacks_name_the_file(
    tiny_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    args = ["train", str(tiny_csv), "--episodes", "1", "--workers", "1", "--dates", "0901..0902"]
    line = fails_cleanly([*args, "--out", str(tmp_path / "a.pt")], tmp_path)
    days = "2022-09-01, 2022-09-02"
    assert line == f"marops: error: {tiny_csv}: training days not in the file: {days}"


@pytest.mark.parametrize("seed", ["-1", "4294967296", "99999999999999999999"])
def test_train_refuses_a_seed_out_of_range(
    tiny_csv: Path, tmp_path: Path, fails_cleanly, seed: str
) -> None:
    """As the planner's --seed: one line with the range, before any training."""
    args = ["train", str(tiny_csv), "--episodes", "1", "--workers", "1", "--seed", seed]
    line = fails_cleanly([*args, "--out", str(tmp_path / "a.pt")], tmp_path, "--seed")
    assert f"got {seed} (expected 0 ≤ seed ≤ 4294967295)" in line


def test_training_log_gives_the_time_left(monkeypatch) -> None:
    """Without a terminal each logged episode says how long the rest will take, at the
    pace so far: 10 of 100 episodes in 60 s leaves 90 × 6 s = 9 min."""
    from marops_cli.app.train import Note
    from marops_cli.cli import train_cmd

    clock = iter([0.0, 1000.0, 1060.0])  # created, started, asked
    monkeypatch.setattr(train_cmd.time, "perf_counter", lambda: next(clock))
    monkeypatch.setattr(train_cmd, "is_terminal", lambda: False)
    rep = train_cmd._Reporter(every=200)
    start = {"kind": "start", "episode": 0, "episodes": 100, "resumed": False}
    rep.message(Note("training on 8 days, held out 2; starting at episode 0 of 100", **start))
    rep.start("episodes", 100, "episodes")
    assert rep.eta_s(10) == pytest.approx(540.0)


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (["--obs-version", "7"], "invalid option --obs-version: Input should be 4 or 5"),
        (["--eval-days", "-1"], "invalid option --eval-days: "),
        (["--alpha-range", "0.5-0.2"], "invalid option --alpha-range: expected 0.001 <= low"),
        (["--energy-slack", "2"], "invalid option --energy-slack: "),
        (["--features", "deep"], "invalid option --features: Input should be 'basic', 'co"),
        (["--energy-per", "km"], "invalid option --energy-per: Input should be 'drone' or"),
        (["--eval-every", "0"], "invalid option --eval-every: "),
        (["--spares", "0"], "--spares expects positive whole numbers"),
        (["--drones", "\u0668"], "--drones expects whole numbers separated by commas"),
        (["--alpha-range", "\u0660.\u0661-\u0660.\u0669"], "--alpha-range expects LOW-HIGH"),
        (["--rules", "flow,stay"], "invalid option --rules: expected distinct names of ops-global"),
        (["--batteries", "plenty"], "--batteries: unknown battery regime 'plenty' (expected"),
        (["--batteries", ","], "--batteries expects names of scarce, default, ample"),
        (
            ["--batteries", "scarce,ample,scarce"],
            "--batteries: battery regime 'scarce' given twice",
        ),
        (["--batteries", "ample", "--spares", "2"], "give batteries per depot (--spares) or"),
        (["--train-weights", "new"], "--train-weights new trains the features --init's actor"),
        (["--train-weights", "some"], "invalid option --train-weights: Input should be 'all'"),
    ],
)
def test_a_bad_training_flag_is_named_as_typed(
    tiny_csv: Path, tmp_path: Path, args: list[str], line: str
) -> None:
    res = runner.invoke(app, ["train", str(tiny_csv), "--out", str(tmp_path / "a.pt"), *args])
    assert res.exit_code == 2
    assert res.stderr.count("\n") == 1 and res.stderr.startswith(f"marops: error: {line}")
    assert "_" not in res.stderr.split(":")[2]  # the flag as typed, not the setting's name
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("text", ["1e-3,0.9", "1e-3-0.9", "0.001-9e-1", "0.001,0.9"])
def test_alpha_range_takes_numbers_written_with_an_exponent(text: str) -> None:
    """``--alpha-range 1e-3,0.9`` was refused as not LOW-HIGH: the comma was made a dash
    and the text split at every dash, the exponent's too."""
    from marops_cli.cli.train_cmd import _alpha_range

    assert _alpha_range(text) == {"alpha_range": (0.001, 0.9)}


def test_init_must_be_a_landing_actor(tiny_csv: Path, tmp_path: Path) -> None:
    other = tmp_path / "notes.txt"
    other.write_text("not an actor\n")
    out = tmp_path / "out" / "a.safetensors"
    out.parent.mkdir()
    actor = tmp_path / "b.safetensors"
    write_landing_actor(
        np.zeros(22),
        actor,
        {"format": "marops-landing-actor/3", "operating_model": "stock=home, batteries, busy"},
    )
    for algo, init, more, line in (
        ("ppo", other, [], "--init is the landing actor's (--algorithm es)"),
        ("es", other, [], f"{other}: --init must name a landing actor's .safetensors file"),
        ("es", actor, [], f"{actor}: its 22 weights do not fit --features basic (16 weights)"),
        (
            "es",
            actor,
            ["--features", "context", "--train-weights", "new"],
            f"{actor}: it has every weight of --features context: --train-weights new",
        ),
    ):
        dest = out if algo == "es" else out.with_suffix(".pt")
        args = ["train", str(tiny_csv), "--algorithm", algo, "--init", str(init), *more]
        res = runner.invoke(app, [*args, "--out", str(dest)])
        assert res.exit_code == 2, res.output
        assert res.stderr.count("\n") == 1 and line in res.stderr
    assert not list(out.parent.iterdir())
    assert other.read_text() == "not an actor\n"


class _RunsOnUnpickle:
    """A pickled object whose loading would run a shell command creating ``target``."""

    def __init__(self, target: Path) -> None:
        self.target = target

    def __reduce__(self) -> tuple[object, tuple[str]]:
        import os

        return (os.system, (f"touch '{self.target}'",))


def test_a_checkpoint_that_would_run_code_is_refused_without_running_it(
    tiny_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    """A checkpoint holding a pickled callable: one line saying what it would load,
    nothing run, and not torch's advice to load it unsafely."""
    import torch

    planted = tmp_path / "planted"
    out = tmp_path / "a.pt"
    ckpt = out.with_suffix(".ckpt")
    torch.save({"format": "marops-train-ckpt/1", "x": _RunsOnUnpickle(planted)}, ckpt)
    args = ["train", str(tiny_csv), "--workers", "1", "--episodes", "1", "--out", str(out)]
    line = fails_cleanly(args, tmp_path, str(ckpt), "pass --no-resume")
    assert "never loads" in line and "system" in line and "weights_only" not in line, line
    assert not planted.exists()


def test_train_warns_when_its_record_is_a_link_and_leaves_it(
    tiny_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """This installation's record of trained actors as a symbolic link: never appended to
    through it (the file it leads to unchanged); the run says the actor went unrecorded."""
    from marops_cli.policies.installation import record_path

    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    elsewhere = tmp_path / "elsewhere.txt"
    elsewhere.write_text("mine\n")
    record_path().parent.mkdir(parents=True)
    record_path().symlink_to(elsewhere)
    out = tmp_path / "a.pt"
    args = ["train", str(tiny_csv), "--episodes", "1", "--workers", "1", "--out", str(out)]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert elsewhere.read_text() == "mine\n" and record_path().is_symlink()
    said = " ".join(res.stderr.split())
    assert f"{record_path()}: this installation's record of trained actors was not" in said
    assert "--trust-actor" in said, said


def test_train_knows_its_actor_recorded_without_reading_the_record_back(
    tiny_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Whether the actor went into this installation's record is what writing it said:
    the run neither reads the record back nor hashes the actor again."""
    from marops_cli.policies import installation

    def read_back(actor: bytes) -> bool:
        raise AssertionError("the record was read back after training")

    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    monkeypatch.setattr(installation, "trained_here", read_back)
    out = tmp_path / "a.pt"
    args = ["train", str(tiny_csv), "--episodes", "1", "--workers", "1", "--out", str(out)]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert "record of trained actors was not" not in res.output
    monkeypatch.undo()
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    assert installation.trained_here(out.read_bytes())

"""Actor files never run code unless trusted (docs/method.md §6, "Trust model of actor
files"): the weights load as data from ``NAME.safetensors``; a TorchScript file, which
runs its author's code when loaded, only with ``--trust-actor``."""

from __future__ import annotations

import json
import os
import pickle
from collections.abc import Callable
from pathlib import Path

import pytest
import torch
from safetensors.torch import save_file

from marops_cli.errors import InputError
from marops_cli.policies.network import Actor
from marops_cli.policies.observation import n_choices, obs_dim
from marops_cli.policies.registry import make_policy
from marops_cli.policies.torchscript import TorchScriptPolicy
from marops_cli.policies.weights import MAX_SIZES, weights_path
from marops_cli.rl.export import write_actor

# torch 2.13 deprecates TorchScript; the tests still need it to build hostile files.
pytestmark = pytest.mark.filterwarnings("ignore:`torch.jit:DeprecationWarning")

N_ACTIONS = 4
WIDTH = obs_dim(N_ACTIONS)  # the current observation version, as plan-window flies it
LOGITS = n_choices(N_ACTIONS)
HIDDEN = 8
SIDECAR = {
    "format": "marops-actor/1",
    "obs_version": 4,
    "n_actions": N_ACTIONS,
    "obs_dim": WIDTH,
    "n_logits": LOGITS,
    "hidden_size": HIDDEN,
}


class WritesOnLoad(torch.nn.Module):
    """Creates ``target`` when TorchScript restores it (``__setstate__``)."""

    def __init__(self, target: str) -> None:
        super().__init__()
        self.target = target

    def forward(self, obs: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return obs[:, :5], h

    @torch.jit.export
    def __getstate__(self) -> tuple[str, bool]:
        return (self.target, self.training)

    @torch.jit.export
    def __setstate__(self, state: tuple[str, bool]) -> None:
        self.target = state[0]
        planted = torch.from_file(self.target, shared=True, size=16)
        self.training = state[1] and planted.numel() > 0  # used, so the JIT keeps the call


class WritesOnForward(torch.nn.Module):
    """Creates ``target`` on every call, the probe call included."""

    def __init__(self, target: str) -> None:
        super().__init__()
        self.target = target

    def forward(self, obs: torch.Tensor, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        planted = torch.from_file(self.target, shared=True, size=1)
        return obs[:, :5] + 0.0 * planted.sum(), h


class SystemOnUnpickle:
    """A plain pickle whose loading runs a shell command touching ``target``."""

    def __init__(self, target: Path) -> None:
        self.target = target

    def __reduce__(self) -> tuple[Callable[[str], int], tuple[str]]:
        return (os.system, (f"touch '{self.target}'",))


def _paper(example_csv: Path) -> list[str]:
    """The paper's operating model, which recurrent actors are trained for: the actor
    file itself is judged, not the model it was made for (docs/method.md §6.1)."""
    return ["--config", str(example_csv.parent / "paper.toml")]


def _torchscript(module: torch.nn.Module, path: Path) -> Path:
    torch.jit.save(torch.jit.script(module), str(path))
    return path


def _hostile(kind: str, folder: Path, target: Path) -> Path:
    """A hostile ``evil.pt`` in ``folder`` whose payload creates ``target``."""
    path = folder / "evil.pt"
    if kind == "pickle":
        path.write_bytes(pickle.dumps(SystemOnUnpickle(target)))
        return path
    cls = WritesOnLoad if kind == "setstate" else WritesOnForward
    return _torchscript(cls(str(target)), path)


def test_the_hostile_files_do_write_when_loaded_as_trusted(tmp_path: Path) -> None:
    """The payloads work: plain torch.jit.load (and a call) writes the attacker's file."""
    on_load, on_forward = tmp_path / "a.pth", tmp_path / "b.pth"
    torch.jit.load(str(_torchscript(WritesOnLoad(str(on_load)), tmp_path / "l.pt")))
    assert on_load.exists()
    module = torch.jit.load(str(_torchscript(WritesOnForward(str(on_forward)), tmp_path / "f.pt")))
    assert not on_forward.exists()
    module(torch.zeros(2, WIDTH), torch.zeros(2, HIDDEN))
    assert on_forward.exists()
    planted = tmp_path / "c.pth"
    pickle.loads(pickle.dumps(SystemOnUnpickle(planted)))
    assert planted.exists()


def _bad_weights(path: Path) -> None:
    """A weights file whose encoder is not the sidecar's (16 features, not WIDTH)."""
    state = {k: v.contiguous() for k, v in Actor(16, LOGITS, HIDDEN).state_dict().items()}
    save_file(state, str(weights_path(path)))


BESIDE = ("nothing", "sidecar", "sidecar and other weights")


@pytest.mark.parametrize("beside", BESIDE)
@pytest.mark.parametrize("kind", ["setstate", "forward", "pickle"])
@pytest.mark.parametrize("command", ["plan-window", "replay-day"])
def test_a_hostile_actor_file_runs_nothing(
    example_csv: Path, tmp_path: Path, fails_cleanly, command: str, kind: str, beside: str
) -> None:
    folder, victim = tmp_path / "actor", tmp_path / "victim"
    folder.mkdir()
    victim.mkdir()
    target = victim / "planted.pth"
    path = _hostile(kind, folder, target)
    needles = [str(path.with_suffix(".json")), "not found"]  # the sidecar is read first
    if beside != "nothing":
        path.with_suffix(".json").write_text(json.dumps(SIDECAR))
    if beside == "sidecar":
        needles = [str(path), "--trust-actor"]
    if beside == "sidecar and other weights":
        _bad_weights(path)
        needles = [str(weights_path(path)), "encoder.weight"]
    out = tmp_path / "out"
    args = [command, str(example_csv), "--date", "0811", "--policy", str(path), "--out", str(out)]
    args += _paper(example_csv)
    if command == "plan-window":
        args += ["--window", "20", "--depots", str(tmp_path / "depots.json")]
    fails_cleanly(args, tmp_path, *needles)
    assert not target.exists(), "the actor file's payload ran"
    assert list(victim.iterdir()) == []


def test_even_trusted_a_plain_pickle_is_never_unpickled(
    example_csv: Path, tmp_path: Path, fails_cleanly
) -> None:
    target = tmp_path / "victim.pth"
    path = _hostile("pickle", tmp_path, target)
    path.with_suffix(".json").write_text(json.dumps(SIDECAR))
    args = ["replay-day", str(example_csv), "--date", "0811", "--policy", str(path)]
    args += ["--trust-actor", "--out", str(tmp_path / "out"), *_paper(example_csv)]
    fails_cleanly(args, tmp_path, str(path), "not a TorchScript module")
    assert not target.exists()


def _valid(tmp_path: Path, seed: int = 0) -> tuple[Path, Actor]:
    torch.manual_seed(seed)
    actor = Actor(WIDTH, LOGITS, HIDDEN)
    with torch.no_grad():  # non-trivial logits: the head starts near zero
        actor.head.weight.normal_(0.0, 1.0)
    path = tmp_path / "mine.pt"
    write_actor(actor, path, {})
    return path, actor


def test_a_valid_actor_loads_as_data_with_the_actions_of_its_torchscript(tmp_path: Path) -> None:
    path, _ = _valid(tmp_path)
    assert weights_path(path).is_file()
    pol = make_policy(f"torchscript:{path}")
    assert isinstance(pol._module, Actor), "rebuilt from the weights, not TorchScript"
    scripted = torch.jit.load(str(path))
    obs = torch.rand(6, WIDTH, generator=torch.Generator().manual_seed(1)) * 3.0
    h = torch.zeros(6, HIDDEN)
    with torch.no_grad():
        for _ in range(3):  # the hidden state carries over steps
            got, got_h = pol._module(obs, h)
            want, want_h = scripted(obs, h)
            assert torch.equal(got, want) and torch.equal(got_h, want_h)
            h = got_h
    assert got.argmax(1).tolist() == want.argmax(1).tolist()


def test_an_actor_shared_as_data_alone_loads_from_its_weights(tmp_path: Path) -> None:
    """The weights and the sidecar, without the TorchScript file: ``--policy
    NAME.safetensors`` flies the same network, named by its weights file; without the
    sidecar it is one line naming it."""
    path, _ = _valid(tmp_path)
    whole = make_policy(f"torchscript:{path}")
    path.unlink()  # what is left is data only
    alone = make_policy(str(weights_path(path)))
    assert isinstance(alone, TorchScriptPolicy) and isinstance(alone._module, Actor)
    assert alone.identity == weights_path(path)
    for name, tensor in whole._module.state_dict().items():
        assert torch.equal(alone._module.state_dict()[name], tensor), name
    path.with_suffix(".json").unlink()
    with pytest.raises(InputError, match=r"\.json"):
        make_policy(str(weights_path(path)))


def test_a_recurrent_actor_s_weights_header_is_parsed_once_by_marops(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The weights file is read and its header parsed once, by marops, where the
    safetensors reader parsed it a second time; the actor acts as written."""
    import safetensors

    from marops_cli.policies.weights import load_weights

    path, actor = _valid(tmp_path)
    want = actor.state_dict()

    def refused(*_a: object, **_k: object) -> None:
        raise AssertionError("the header was parsed a second time")

    monkeypatch.setattr(safetensors, "safe_open", refused)
    sidecar = path.with_suffix(".json")
    got = load_weights(path, json.loads(sidecar.read_text()), sidecar).state_dict()
    assert got.keys() == want.keys()
    assert all(torch.equal(got[k], want[k]) for k in want)


def _load_error(path: Path) -> str:
    with pytest.raises(InputError) as err:
        TorchScriptPolicy(path)
    return str(err.value)


def test_a_sidecar_that_does_not_describe_the_weights_is_refused(tmp_path: Path) -> None:
    path, _ = _valid(tmp_path)
    side = json.loads(path.with_suffix(".json").read_text())
    path.with_suffix(".json").write_text(json.dumps({**side, "hidden_size": 16}))
    line = _load_error(path)
    assert str(weights_path(path)) in line and "'encoder.weight'" in line
    assert "[16, " in line and f"[{HIDDEN}, {WIDTH}]" in line


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"hidden_size": MAX_SIZES["hidden_size"] + 1}, "hidden_size"),
        ({"obs_dim": 10**9}, "obs_dim"),
        ({"n_logits": "many"}, "n_logits"),
        ({"n_logits": 100_000, "hidden_size": 4096}, "hidden_size"),  # too many weights
        ({"format": "pickle"}, "format"),
    ],
)
def test_sizes_beyond_the_bounds_are_refused_before_allocating(
    tmp_path: Path, change: dict, key: str
) -> None:
    path, _ = _valid(tmp_path)
    side = json.loads(path.with_suffix(".json").read_text())
    path.with_suffix(".json").write_text(json.dumps({**side, **change}))
    line = _load_error(path)
    assert str(path.with_suffix(".json")) in line and f"'{key}'" in line


def test_weights_with_other_tensors_or_dtypes_are_refused(tmp_path: Path) -> None:
    path, actor = _valid(tmp_path)
    state = {k: v.contiguous() for k, v in actor.state_dict().items()}
    save_file({**state, "extra": torch.zeros(2)}, str(weights_path(path)))
    assert "'extra'" in _load_error(path)
    save_file({**state, "head.bias": state["head.bias"].double()}, str(weights_path(path)))
    assert "'head.bias'" in _load_error(path) and "F64" in _load_error(path)
    del state["gru.bias_hh"]
    save_file(state, str(weights_path(path)))
    assert "'gru.bias_hh'" in _load_error(path)
    weights_path(path).write_bytes(b"\xff" * 64)
    assert "not a safetensors weights file" in _load_error(path)


def test_finite_weights_beyond_the_documented_range_are_refused_on_load(tmp_path: Path) -> None:
    """A weights file whose float32 values are huge yet finite (±3.4e38) is refused as it
    loads, naming the file and the tensor, rather than flying NaN logits."""
    import hashlib

    path, actor = _valid(tmp_path)
    state = {k: v.contiguous() for k, v in actor.state_dict().items()}
    state["head.weight"] = state["head.weight"].clone()
    state["head.weight"][0, 0] = 3.4e38
    save_file(state, str(weights_path(path)))
    side = json.loads(path.with_suffix(".json").read_text())
    side["weights_sha256"] = hashlib.sha256(weights_path(path).read_bytes()).hexdigest()
    path.with_suffix(".json").write_text(json.dumps(side))
    line = _load_error(path)
    assert str(weights_path(path)) in line and "'head.weight'" in line and "3.4e+38" in line


def test_trust_actor_loads_a_benign_torchscript_only_file(
    example_csv: Path, tmp_path: Path, fails_cleanly, monkeypatch: pytest.MonkeyPatch
) -> None:
    from typer.testing import CliRunner

    from marops_cli.cli.app import app

    path, _ = _valid(tmp_path)
    weights_path(path).unlink()  # TorchScript and sidecar only
    # As on another installation, which did not train it.
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "elsewhere"))
    # Two days go to worker processes, which load the actor as the command was told to.
    args = ["replay-day", str(example_csv), "--dates", "0811..0812", "--workers", "2"]
    args += ["--policy", str(path), *_paper(example_csv)]
    fails_cleanly([*args, "--out", str(tmp_path / "refused")], tmp_path, "--trust-actor")
    res = CliRunner().invoke(app, [*args, "--trust-actor", "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "o" / "2022-08-12" / "metrics.json").is_file()
    evaluate = ["evaluate", str(example_csv), "--methods", "marops", "--policy", str(path)]
    evaluate += _paper(example_csv)
    fails_cleanly([*evaluate, "--out", str(tmp_path / "ev")], tmp_path, "--trust-actor")


def test_a_config_file_cannot_grant_trust(tmp_path: Path) -> None:
    """Only the person at the command line trusts an actor file: a config file saying
    ``[sim] trust_actor = true`` is refused, naming the key."""
    from marops_cli.config import load_config

    cfg = tmp_path / "planner.toml"
    cfg.write_text("[sim]\ntrust_actor = true\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"key 'sim.trust_actor': only the --trust-actor"):
        load_config(cfg)


@pytest.mark.parametrize("how", ["cli", "api"])
def test_the_flag_does_not_trust_an_actor_only_a_config_file_names(
    example_csv: Path, tmp_path: Path, how: str
) -> None:
    """``--trust-actor`` trusts the actor the person at the command line names by
    ``--policy``: a config file from elsewhere naming a TorchScript file as ``[sim]
    policy`` would otherwise choose which code the flag lets run. Refused before any
    work, naming the key; given as ``--policy``, the same file is trusted."""
    from typer.testing import CliRunner

    from marops_cli import api
    from marops_cli.cli.app import app

    victim = tmp_path / "victim"
    victim.mkdir()
    target = victim / "planted.pth"
    path = _hostile("setstate", tmp_path, target)
    path.with_suffix(".json").write_text(json.dumps(SIDECAR))
    paper = (example_csv.parent / "paper.toml").read_text(encoding="utf-8")
    cfg = tmp_path / "foreign.toml"
    cfg.write_text(f"{paper}\n[sim]\npolicy = {json.dumps(str(path))}\n", encoding="utf-8")
    if how == "cli":
        args = ["replay-day", str(example_csv), "--date", "0811", "--config", str(cfg)]
        res = CliRunner().invoke(app, [*args, "--trust-actor", "--out", str(tmp_path / "o")])
        assert res.exit_code == 2, res.output
        line = res.stderr.strip()
        assert line.startswith(f"marops: error: {cfg}, key 'sim.policy': --trust-actor trusts")
        assert "give it as --policy" in line and "\n" not in line
    else:
        with pytest.raises(InputError, match=r"key 'sim.policy': trust_actor trusts .* policy"):
            api.replay_day(example_csv, date="0811", config=cfg, trust_actor=True)
    assert not target.exists() and not (tmp_path / "o").exists()


def test_an_actor_this_installation_trained_loads_without_the_flag(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """marops train records the SHA-256 of each TorchScript file it writes, under
    $XDG_DATA_HOME/marops only; a file of those bytes loads without --trust-actor, on
    another installation (another record) it does not."""
    from marops_cli.policies.installation import record_path

    home = tmp_path / "home"
    monkeypatch.setenv("XDG_DATA_HOME", str(home))
    path, _ = _valid(tmp_path)
    weights_path(path).unlink()
    assert record_path() == home / "marops" / "trained-actors.jsonl"
    assert [p.relative_to(home).as_posix() for p in home.rglob("*")] == [
        "marops",
        "marops/trained-actors.jsonl",
    ]
    pol = make_policy(f"torchscript:{path}")
    assert not isinstance(pol._module, Actor), "its TorchScript, trusted as trained here"
    path.write_bytes(path.read_bytes() + b"\0")  # other bytes: not the file trained here
    assert "--trust-actor" in _load_error(path)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "elsewhere"))
    path.write_bytes(path.read_bytes()[:-1])
    said = _load_error(path)
    assert "this installation did not train it" in said
    assert f"ask them for {path.stem}.safetensors, the weights file marops train" in said


def test_a_torn_or_foreign_record_line_grants_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from marops_cli.policies.installation import record_path, trained_here

    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    record_path().parent.mkdir(parents=True)
    record_path().write_text('{"sha256": "ab\n[1, 2]\nnot json\n', encoding="utf-8")
    assert not trained_here(b"x")


def test_a_relative_xdg_data_home_or_a_record_others_can_write_vouches_for_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A relative XDG_DATA_HOME (a folder brought along with the actor, where the run
    starts) is ignored, and a record that others may write grants nothing."""
    import hashlib
    import os

    from marops_cli.policies.installation import record_path, trained_here

    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_DATA_HOME", "xd")
    assert (
        record_path() == tmp_path / "home" / ".local" / "share" / "marops" / "trained-actors.jsonl"
    )
    planted = tmp_path / "xd" / "marops" / "trained-actors.jsonl"
    planted.parent.mkdir(parents=True)
    line = f'{{"sha256": "{hashlib.sha256(b"evil").hexdigest()}"}}\n'
    planted.write_text(line, encoding="utf-8")
    assert not trained_here(b"evil")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xd"))
    os.chmod(planted, 0o600)
    assert trained_here(b"evil")  # this user's own record, absolute: it vouches
    os.chmod(planted, 0o602)
    assert not trained_here(b"evil")
    os.chmod(planted, 0o620)
    assert not trained_here(b"evil")


def test_a_record_that_is_a_pipe_is_neither_waited_on_nor_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The installation's record as a named pipe: reading it does not wait for a writer
    (it grants nothing), and training does not write its line into it."""
    import signal

    from marops_cli.policies.installation import record_path, record_trained, trained_here

    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    record_path().parent.mkdir(parents=True)
    os.mkfifo(record_path())

    def hung(*_: object) -> None:
        raise AssertionError("waited on the pipe")

    # A guard against hanging the suite, not a time limit on the work.
    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(60)
    try:
        assert not trained_here(b"x")
        reader = os.open(record_path(), os.O_RDONLY | os.O_NONBLOCK)
        try:
            assert not record_trained(b"x", tmp_path / "a.pt")
            assert os.read(reader, 1) == b"", "a line was written into the pipe"
        finally:
            os.close(reader)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def test_a_record_that_is_a_symbolic_link_is_never_followed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The installation's record as a link: training's line never lands in the file it
    leads to, and the lines there vouch for nothing."""
    from marops_cli.policies.installation import record_path, record_trained, trained_here

    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    elsewhere = tmp_path / "elsewhere.jsonl"
    elsewhere.write_text("")
    os.chmod(elsewhere, 0o600)
    record_path().parent.mkdir(parents=True)
    record_path().symlink_to(elsewhere)
    assert not record_trained(b"x", tmp_path / "a.pt")
    assert elsewhere.read_text() == "" and record_path().is_symlink()
    record_path().unlink()
    assert record_trained(b"x", tmp_path / "a.pt") and trained_here(b"x")  # a record of its own
    os.replace(record_path(), elsewhere)
    record_path().symlink_to(elsewhere)
    assert not trained_here(b"x")


def test_weights_that_are_not_the_sidecars_are_refused(tmp_path: Path) -> None:
    """The sidecar records the weights' SHA-256: other weights of the same shapes (another
    actor's) are refused, naming the sidecar's key."""
    import hashlib

    path, _ = _valid(tmp_path)
    side = json.loads(path.with_suffix(".json").read_text())
    assert side["weights_sha256"] == hashlib.sha256(weights_path(path).read_bytes()).hexdigest()
    (tmp_path / "other").mkdir()
    other, _ = _valid(tmp_path / "other", seed=7)
    weights_path(path).write_bytes(weights_path(other).read_bytes())
    line = _load_error(path)
    assert str(path.with_suffix(".json")) in line and "'weights_sha256'" in line


def test_outputs_record_the_weights_that_ran(tmp_path: Path) -> None:
    """The run identity in every output's metadata holds the weights file's SHA-256
    beside the actor file's, so other weights never pass for the same run."""
    import hashlib

    from marops_cli.io.meta import run_meta

    path, _ = _valid(tmp_path)
    policy = run_meta(command="replay-day", policy=path, stamp=False)["policy"]
    assert policy == {
        "name": "mine.pt",
        "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
        "weights_sha256": hashlib.sha256(weights_path(path).read_bytes()).hexdigest(),
    }
    weights_path(path).unlink()  # a TorchScript-only actor: its file is what runs
    assert "weights_sha256" not in run_meta(command="x", policy=path)["policy"]


def test_the_api_trusts_an_actor_file_as_the_flag_does(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The API's keywords are the commands' flags: trust_actor=True is --trust-actor.
    from marops_cli import api

    path, _ = _valid(tmp_path)
    weights_path(path).unlink()  # TorchScript and sidecar only
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "elsewhere"))
    paper = example_csv.parent / "paper.toml"
    day = {"method": "marops", "policy": str(path), "config": paper}
    with pytest.raises(InputError, match="--trust-actor"):
        api.replay_day(example_csv, "0811", **day)
    assert api.replay_day(example_csv, "0811", trust_actor=True, **day).metrics["delivered"] > 0
    run = {"methods": "marops", "dates": "0811", "policy": path, "config": paper, "workers": 1}
    with pytest.raises(InputError, match="--trust-actor"):
        api.evaluate(example_csv, **run)
    assert api.evaluate(example_csv, trust_actor=True, **run).results.num_rows == 1
    depots = tmp_path / "depots.json"
    api.segment(example_csv, out=depots, dates="0801..0810")
    window = {"method": "marops", "policy": str(path), "config": paper}
    with pytest.raises(InputError, match="--trust-actor"):
        api.plan_window(example_csv, depots, "0811", 5, **window)
    assert api.plan_window(example_csv, depots, "0811", 5, trust_actor=True, **window).metrics


def test_an_actor_whose_file_name_is_not_utf8_loads_its_weights(tmp_path: Path) -> None:
    """A file name may be any bytes: the weights still load as data, the same numbers."""
    path, actor = _valid(tmp_path)
    odd = Path(os.fsdecode(bytes(tmp_path) + b"/\xffactor.pt"))
    for ext in (".pt", ".json", ".safetensors"):
        path.with_suffix(ext).rename(odd.with_suffix(ext))
    pol = make_policy(f"torchscript:{odd}")
    assert isinstance(pol._module, Actor)
    got = pol._module.state_dict()
    assert all(torch.equal(got[k], v) for k, v in actor.state_dict().items())


@pytest.mark.parametrize("kind", ["folder", "pipe", "broken link"])
def test_a_weights_path_that_is_no_file_is_an_error_not_a_missing_file(
    tmp_path: Path, kind: str
) -> None:
    """``NAME.safetensors`` that is a folder, a pipe or a link to nothing is named, even
    with trust: it is not read as "no weights file" (which would run the TorchScript)."""
    path, _ = _valid(tmp_path)
    weights = weights_path(path)
    weights.unlink()
    if kind == "folder":
        weights.mkdir()
    elif kind == "pipe":
        os.mkfifo(weights)
    else:
        weights.symlink_to(tmp_path / "gone.safetensors")
    with pytest.raises(InputError) as err:
        TorchScriptPolicy(path, trust=True)
    line = str(err.value)
    assert line.startswith(f"{weights}:") and "weights file" in line, line


@pytest.mark.parametrize(
    ("change", "key"),
    [({"n_actions": 10**6}, "n_actions"), ({"hidden_size": 10**6}, "hidden_size")],
)
def test_a_trusted_actor_is_not_called_with_sizes_beyond_the_bounds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, change: dict, key: str
) -> None:
    """A TorchScript-only actor's sidecar (no obs_dim: one written before it) is bounded
    too: its first call would allocate by n_actions and hidden_size."""
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "elsewhere"))
    path, _ = _valid(tmp_path)
    weights_path(path).unlink()
    side = json.loads(path.with_suffix(".json").read_text())
    del side["obs_dim"], side["n_logits"]
    path.with_suffix(".json").write_text(json.dumps({**side, **change}))
    with pytest.raises(InputError) as err:
        TorchScriptPolicy(path, trust=True)
    line = str(err.value)
    assert line.startswith(f"{path.with_suffix('.json')}, key '{key}': expected a whole number")


@pytest.mark.parametrize("flag", ["--policy", "--mappo-policy"])
def test_evaluate_runs_nothing_of_a_hostile_actor_file(
    example_csv: Path, tmp_path: Path, fails_cleanly, monkeypatch: pytest.MonkeyPatch, flag: str
) -> None:
    """evaluate loads every method's actor up front, with worker processes too: a
    TorchScript file that writes when loaded is refused without running, for either
    learned method."""
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "elsewhere"))
    folder, target = tmp_path / "actor", tmp_path / "planted.pth"
    folder.mkdir()
    path = _hostile("setstate", folder, target)
    side = {**SIDECAR, "plan_slots": 2, "n_logits": 2 * LOGITS} if flag == "--mappo-policy" else {}
    path.with_suffix(".json").write_text(json.dumps({**SIDECAR, **side}))
    method = "mappo" if flag == "--mappo-policy" else "marops"
    args = ["evaluate", str(example_csv), "--methods", method, "--dates", "0811"]
    args += [flag, str(path), "--workers", "2", "--out", str(tmp_path / "ev"), *_paper(example_csv)]
    fails_cleanly(args, tmp_path, str(path), "--trust-actor")
    assert not target.exists(), "the actor file's payload ran"


def test_the_api_runs_nothing_of_a_hostile_actor_file(
    example_csv: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from marops_cli import api

    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "elsewhere"))
    target = tmp_path / "planted.pth"
    path = _hostile("setstate", tmp_path, target)
    path.with_suffix(".json").write_text(json.dumps(SIDECAR))
    paper = example_csv.parent / "paper.toml"
    depots = tmp_path / "depots.json"
    api.segment(example_csv, out=depots, dates="0801..0810")
    actor = {"policy": str(path), "config": paper}
    calls = [
        lambda: api.replay_day(example_csv, "0811", method="marops", **actor),
        lambda: api.plan_window(example_csv, depots, "0811", 5, method="marops", **actor),
        lambda: api.evaluate(example_csv, methods="marops", dates="0811", workers=1, **actor),
    ]
    for call in calls:
        with pytest.raises(InputError, match="--trust-actor"):
            call()
    assert not target.exists(), "the actor file's payload ran"


def test_a_misspelt_sidecar_key_is_not_read_as_a_missing_one(tmp_path: Path) -> None:
    """A sidecar without ``operating_model`` loads under any model: one whose key is
    misspelt is refused naming it, not flown as if it named none. Keys the loader does
    not read (provenance) are kept as they are."""
    path, _ = _valid(tmp_path)
    side = json.loads(path.with_suffix(".json").read_text())
    path.with_suffix(".json").write_text(json.dumps({**side, "notes": "mine", "alpha": 0.3}))
    assert isinstance(make_policy(f"torchscript:{path}")._module, Actor)
    path.with_suffix(".json").write_text(json.dumps({**side, "operating-model": "stock=home"}))
    line = _load_error(path)
    assert line == (
        f"{path.with_suffix('.json')}, key 'operating-model': unknown key 'operating-model' "
        "(did you mean operating_model?)"
    )

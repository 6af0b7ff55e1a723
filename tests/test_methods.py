"""A landing rule is one class and one registry entry (marops_cli/methods.py): with no
other file touched it is a policy, a method, in the help texts, in evaluate's list and
in the API (docs/decisions.md, "Adding a landing rule")."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from marops_cli import api as marops
from marops_cli import methods
from marops_cli.policies.base import WindowView
from marops_cli.policies.rules import BacklogPolicy

ROOT = Path(__file__).resolve().parents[1]


class ToyRule(BacklogPolicy):
    """The backlog rule's landings, counting the windows it chose for."""

    name = "toy"
    windows = 0

    def act(self, view: WindowView) -> np.ndarray:
        ToyRule.windows += 1
        return super().act(view)


@pytest.fixture
def toy_rule(monkeypatch: pytest.MonkeyPatch) -> Iterator[methods.Method]:
    """The toy rule registered for one test, the registry as it was afterwards."""
    monkeypatch.setattr(methods, "_REGISTRY", dict(methods._REGISTRY))
    monkeypatch.setattr(methods, "_KINDS", dict(methods._KINDS))
    ToyRule.windows = 0
    yield methods.landing_rule("toy", ToyRule, "the backlog rule's landings, counted")


def test_a_registered_rule_is_a_policy_and_a_method(toy_rule: methods.Method) -> None:
    from marops_cli.app.evaluate import default_methods
    from marops_cli.policies.registry import PolicySpec, make_policy

    assert methods.policy_names().endswith("battery, toy")
    assert methods.method_names().endswith("myopic, toy")
    assert methods.METHODS["toy"] == ("kmeans", "toy")
    assert str(PolicySpec.parse("toy")) == "toy" and isinstance(make_policy("toy"), ToyRule)
    assert default_methods({})[-1] == "toy"  # evaluate's list without --methods
    assert methods.reference_rules() == {
        "ops-global": "global",
        "backlog": "backlog",
        "rebalance": "rebalance",
        "flow": "flow",
        "battery": "battery",
    }, "a rule is a reference of training only when registered as one"


@pytest.mark.filterwarnings("ignore:.*stayed undelivered")  # 8 drones on a busy day
def test_the_api_evaluates_a_registered_rule(toy_rule: methods.Method, example_csv: Path) -> None:
    one = {"area": "square"}  # one study square: a city's 12 hubs would only take longer
    ev = marops.evaluate(example_csv, methods="toy", dates="0811", workers=1, plots=False, **one)
    assert set(ev.results.column("method").to_pylist()) == {"toy"}
    assert ToyRule.windows > 0, "the rule's own class chose the landings"
    ToyRule.windows = 0
    day = marops.replay_day(example_csv, "0811", method="greedy", policy="toy", **one)
    assert day.metrics["delivered"] > 0 and ToyRule.windows > 0  # policy= names it too


def test_a_registered_rule_is_in_the_help_texts() -> None:
    """Help texts are made when the command line loads: a rule registered before that
    (as a plugin would be) is listed by --policy, --method and evaluate's --methods."""
    code = (
        "from marops_cli.methods import landing_rule\n"
        "from marops_cli.policies.rules import BacklogPolicy\n"
        "class ToyRule(BacklogPolicy):\n"
        "    name = 'toy'\n"
        "landing_rule('toy', ToyRule, 'the backlog rule, renamed')\n"
        "from marops_cli.cli.app import main; main()"
    )

    def help_text(command: str) -> str:
        res = subprocess.run(
            [sys.executable, "-c", code, command, "--help"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert res.returncode == 0, res.stderr
        return " ".join(res.stdout.replace("│", " ").split())

    replay = help_text("replay-day")
    assert "Flight-range policy: stay, random, greedy, global, myopic, backlog, " in replay
    assert "rebalance, flow, battery, toy, or a trained actor" in replay
    assert "stay, myopic, toy (docs/method.md §7)" in replay  # --method
    assert "myopic, toy (docs/method.md §7) [default: every one" in help_text("evaluate")

"""Docs and code cite only files that are in the repository (and no design notes outside it)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted(
    [
        *ROOT.glob("marops_cli/**/*.py"),
        *ROOT.glob("benchmarks/*.py"),
        *ROOT.glob("tests/**/*.py"),
        *ROOT.glob("docs/*.md"),
        *ROOT.glob("examples/*.toml"),
        ROOT / "README.md",
        ROOT / "policies/README.md",
    ]
)
# A path into the repository as code comments and docs write it.
CITED = re.compile(
    r"(?<![\w/.-])((?:docs|policies|examples|benchmarks|marops_cli|tests)/[\w./-]*\w)"
)
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")  # Markdown links
# Documents that are not part of the repository.
FOREIGN = re.compile(r"\bSPEC\b|\bENERGY\.md\b|\bOUTPUTS\.md\b|\bSTYLE\.md\b|shared/(design|paper)")


def _rel(path: Path) -> str:
    return str(path.relative_to(ROOT))


def _exists(ref: str) -> bool:
    ref = ref.rstrip(".")
    if "*" in ref or "<" in ref or "NAME" in ref:
        return True
    if (ROOT / ref).exists() or (ROOT / "marops_cli" / ref).exists():  # or package-relative
        return True
    # ``plans/order.py:subset_energies`` and ``marops_cli.x`` style remain paths before ":"
    return (ROOT / ref.split(":")[0]).exists()


@pytest.mark.parametrize("path", SOURCES, ids=_rel)
def test_cited_files_exist(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    missing = []
    for m in CITED.finditer(text):
        ref = m.group(1)
        if not _exists(ref) and not ref.endswith((".pt", ".ckpt", ".csv", ".parquet", ".png")):
            missing.append(ref)
    if path.suffix == ".md":
        for m in LINK.finditer(text):
            ref = m.group(1)
            if "://" in ref:
                continue
            if not (path.parent / ref).exists():
                missing.append(ref)
    assert not missing, f"{_rel(path)} cites files not in the repository: {sorted(set(missing))}"


@pytest.mark.parametrize("path", SOURCES, ids=_rel)
def test_no_design_notes_outside_the_repository(path: Path) -> None:
    hits = [m.group(0) for m in FOREIGN.finditer(path.read_text(encoding="utf-8"))]
    if path.name == "test_docs.py":
        return
    assert not hits, f"{_rel(path)} cites documents users do not have: {sorted(set(hits))}"

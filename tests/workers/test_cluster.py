"""The local Dask cluster of ``--scheduler local`` serves its owner alone: every port
speaks TLS with a certificate made for the run and demands one from its peer, so a
process without it (another user's) cannot run code there; no HTTP server answers
(README.md "Sweeps on a cluster")."""

from __future__ import annotations

import os
import socket
import subprocess
import sys

import pytest

# Another process tries what the audit did: a Client of each address, then client.run.
ATTACK = """
import os, sys
import distributed
from distributed.security import Security

for address in sys.argv[1:]:
    tries = {
        "no certificate": (address, None),
        "plain TCP": (address.replace("tls://", "tcp://"), None),
        "another certificate": (address, Security.temporary()),
    }
    for name, (where, security) in tries.items():
        try:
            extra = {} if security is None else {"security": security}
            client = distributed.Client(where, timeout=5, **extra)
            print("RAN", name, where, client.run(os.getuid), flush=True)
        except Exception as exc:
            print("refused", name, where, type(exc).__name__, flush=True)
os._exit(0)  # no waiting on half-made clients as the interpreter ends
"""


def _another_user() -> dict[str, int]:
    """Run as ``nobody`` where this is root and ``nobody`` can run this Python; else as
    this user (then only the credentials differ, which is what the cluster checks)."""
    if not hasattr(os, "getuid") or os.getuid() != 0:
        return {}
    as_nobody = {"user": 65534, "group": 65534}
    try:
        subprocess.run([sys.executable, "-c", "import distributed"], check=True, **as_nobody)
    except (OSError, subprocess.CalledProcessError):
        return {}
    return as_nobody


def test_a_local_cluster_runs_nothing_for_a_process_without_its_certificate() -> None:
    pytest.importorskip("distributed")
    pytest.importorskip("cryptography")
    from marops_cli.workers.cluster import connect

    with connect("local", 1) as client:
        info = client.scheduler_info()
        workers = info["workers"]
        addresses = [client.scheduler.address, *workers]
        addresses += [w["nanny"] for w in workers.values() if w.get("nanny")]
        assert list(client.run(os.getpid)) == list(workers)  # its owner runs code there
        attack = subprocess.run(
            [sys.executable, "-c", ATTACK, *addresses],
            capture_output=True,
            text=True,
            timeout=300,
            cwd="/",
            **_another_user(),
        )
        # No dashboard, no metrics: the HTTP ports Dask opened are closed again.
        http = [*info.get("services", {}).values()]
        http += [p for w in workers.values() for p in w.get("services", {}).values()]
        answering = []
        for port in http:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    answering.append(port)
    lines = attack.stdout.splitlines()
    assert len(lines) == 3 * len(addresses), (attack.stdout, attack.stderr[-2000:])
    assert all(line.startswith("refused ") for line in lines), attack.stdout
    assert answering == [], f"HTTP answers on {answering}"
    assert all(a.startswith("tls://127.0.0.1:") for a in addresses), addresses


def test_without_cryptography_a_local_cluster_says_how_to_install_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The certificate is made with the cryptography package (the cluster extra's): without
    it, one line saying so, never a cluster open to all."""
    pytest.importorskip("distributed")
    from marops_cli.errors import InputError
    from marops_cli.workers.cluster import connect

    monkeypatch.setitem(sys.modules, "cryptography", None)  # import cryptography fails
    wanted = r"cryptography package: pip install 'marops\[cluster\]'"
    with pytest.raises(InputError, match=wanted), connect("local", 1):
        pass

"""docs/design.md §5 on a real PostgreSQL server: two worker processes of
``python -m spine_gym.design optimize`` on one study stored in PostgreSQL give the same trials as the
same command on a journal file, and a wrong password or a closed port gives the documented
``cannot open storage postgresql+psycopg2://spine:***@...: <reason>`` (exit status 2).

Needs the URL of an empty database in ``SPINE_GYM_TEST_PG_URL`` (``.ci/run`` starts a throwaway
server with ``.ci/postgres.sh`` and exports it; CI fails if these tests are skipped).
"""

from __future__ import annotations

import csv
import json
import os
import socket
import subprocess
import sys
import uuid
from pathlib import Path

import pytest
from repo import ROOT
from sqlalchemy.engine import make_url

PG_URL = os.environ.get("SPINE_GYM_TEST_PG_URL")
pytestmark = pytest.mark.skipif(
    not PG_URL, reason="SPINE_GYM_TEST_PG_URL is not set (no PostgreSQL server; .ci/run starts one)"
)
# a random sampler seeded per worker (seed + i) draws the same designs whatever the interleaving of
# the two processes, so the set of trials is reproducible across storages
PROBLEM = [
    "--space", "a=6e-3:14e-3",
    "--space", "n_w=1,2",
    "--maximize", "stable_angle",
    "--constraint", "ability>=0.02",
    "--protocol", "t_stable=10,t_respond=6,t_load=4",
    "--sampler", "random",
    "--seed", "3",
]  # fmt: skip


def _design(*args, timeout=300):
    return subprocess.run(
        [sys.executable, "-m", "spine_gym.design", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def _optimize(storage: str, study: str, out: Path) -> tuple[dict, list[dict]]:
    r = _design(
        "optimize", *PROBLEM, "--n-trials", "6", "--n-workers", "2",
        "--storage", storage, "--study-name", study, "--no-progress", "--out", str(out),
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    with (out / "trials.csv").open() as fh:
        trials = list(csv.DictReader(fh))
    return json.loads((out / "best.json").read_text()), trials


def _url_with(password: str | None = None, port: int | None = None) -> str:
    url = make_url(PG_URL)
    url = url.set(password=password) if password is not None else url
    url = url.set(port=port) if port is not None else url
    return url.render_as_string(hide_password=False)


def test_two_workers_on_postgres_equal_a_journal_run(tmp_path):
    study = f"pg-{uuid.uuid4().hex[:12]}"  # a fresh study on every run of the shared database
    pg, pg_trials = _optimize(PG_URL, study, tmp_path / "pg")
    journal, journal_trials = _optimize(str(tmp_path / "study.journal"), study, tmp_path / "journal")

    assert pg["n_trials"] == journal["n_trials"] == len(pg_trials) == 6
    assert pg["best"] is not None and pg["n_feasible"] == journal["n_feasible"] > 0
    assert pg["best"]["value"] == journal["best"]["value"]
    assert pg["best"]["params"] == journal["best"]["params"]
    designs = [
        sorted((t["a"], t["n_w"], t["stable_angle_deg"]) for t in run) for run in (pg_trials, journal_trials)
    ]
    assert designs[0] == designs[1]  # the same six designs, whichever process ran which
    assert len({t["worker"] for t in pg_trials}) == 2  # both processes wrote to PostgreSQL
    password = make_url(PG_URL).password
    assert password not in json.dumps(pg) and ":***@" in pg["storage"]  # no password in the files

    shown = _design("best", "--storage", PG_URL, "--study-name", study)  # as a third machine would
    assert shown.returncode == 0, shown.stderr
    assert "trials: 6 finished" in shown.stdout


def test_wrong_password_gives_the_documented_error():
    r = _design("best", "--storage", _url_with(password="not-the-password"), "--study-name", "x", timeout=60)
    assert r.returncode == 2
    assert "cannot open storage postgresql+psycopg2://spine:***@" in r.stderr
    assert "password authentication failed" in r.stderr
    assert "not-the-password" not in r.stderr


def test_unreachable_server_gives_the_documented_error():
    with socket.socket() as s:  # a loopback port on which nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    r = _design("best", "--storage", _url_with(port=port), "--study-name", "x", timeout=60)
    assert r.returncode == 2
    assert f"cannot open storage postgresql+psycopg2://spine:***@127.0.0.1:{port}/" in r.stderr
    assert "Connection refused" in r.stderr or "could not connect" in r.stderr

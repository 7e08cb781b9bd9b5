"""Shared test set-up: one torch thread (on 2 cores a second one made PPO slower); under pytest-xdist with
``--dist loadgroup`` (``scripts/test.sh``) the tests of a file with a fixture built once per module run on
one worker, which builds it once, and every other test is dealt out on its own."""

import importlib.util
import os
import re
from functools import cache
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

try:  # torch comes with the [rl] extra; the physics and env tests run without it
    import torch

    torch.set_num_threads(1)
except ImportError:  # pragma: no cover
    pass

SHARED_FIXTURE = re.compile(r"@pytest\.fixture\(\s*scope\s*=\s*[\"'](module|package|session)[\"']")


@cache
def shares_a_fixture(path: Path) -> bool:
    """Whether the test file ``path`` defines a fixture built once per module (or package, session)."""
    return path.is_file() and bool(SHARED_FIXTURE.search(path.read_text()))


if importlib.util.find_spec("xdist") is not None:  # the hook exists only with the plugin
    from xdist.scheduler import LoadScopeScheduling

    class FilesWithSharedFixtures(LoadScopeScheduling):
        """``loadgroup``'s scheduler here: a file of :func:`shares_a_fixture` is one work unit, any
        other test one of its own. (xdist's own groups, marked on the test, do not reach its
        scheduler with pytest 9.2's structured node ids: pytest-xdist issue 1386.)"""

        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.split("::", 1)[0]
            return path if shares_a_fixture(self.config.rootpath / path) else nodeid

    def pytest_xdist_make_scheduler(config, log):
        if config.getvalue("dist") == "loadgroup":
            return FilesWithSharedFixtures(config, log)
        return None

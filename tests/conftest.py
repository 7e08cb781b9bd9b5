"""Shared test set-up: one torch thread (on 2 cores a second one made PPO slower); under pytest-xdist
(``scripts/test.sh``: ``-n N --dist loadgroup``) the tests of a file with a fixture built once per module
run on one worker, one after the other, which builds it once."""

import inspect
import os

import pytest

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

try:  # torch comes with the [rl] extra; the physics and env tests run without it
    import torch

    torch.set_num_threads(1)
except ImportError:  # pragma: no cover
    pass


def _shares_a_fixture(item) -> bool:
    """Whether ``item`` uses a fixture of its own file that is built once per module (or session)."""
    here = str(item.path)
    for defs in item._fixtureinfo.name2fixturedefs.values():
        d = defs[-1]
        if d.scope != "function" and inspect.getsourcefile(d.func) == here:
            return True
    return False


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook, which reads the groups
def pytest_collection_modifyitems(config, items):
    if not getattr(config.option, "loadgroup", False):  # what an xdist worker of --dist loadgroup is told
        return
    # the whole file: a test of another file run in between would tear the module's fixture down
    shared = {item.path for item in items if _shares_a_fixture(item)}
    for item in items:
        if item.path in shared:
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))

"""Every row of ``spine-gym evaluate`` says the envelope it ran in: the voltage ceiling, the plant's
cut-off and who cuts a hot wire (``guard``: the plant, the controller or nothing). On a ``-v2`` id
the plant cuts every controller's wires at 418 K and the registry's controllers bring no guard of
their own; on ``-v1`` the PID has its guard and a learned policy none."""

from __future__ import annotations

import numpy as np
import pytest

from spine_gym.agents import evaluation as ev
from spine_gym.agents.runtime import build_controller, make_env
from spine_gym.agents.scenarios import get_suite


class ConstantPolicy:
    """A policy without a guard: full voltage on every wire (SB3's ``predict``)."""

    def __init__(self, n_wires: int):
        self.action = np.ones(n_wires, dtype=np.float32)

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return self.action, state


@pytest.mark.parametrize(
    "env_id, pid_guard, policy_guard, cutoff",
    [("SmaSpine-v1", "controller 418 K", "none", None), ("SmaSpine-v2", "plant 418 K", "plant 418 K", 418.0)],
)
def test_rows_summaries_and_tables_carry_the_envelope(env_id, pid_guard, policy_guard, cutoff):
    probe = make_env({}, env_id=env_id)
    controllers = {"pid": build_controller("pid", probe), "full": ConstantPolicy(2)}
    suite = get_suite("quick", names=["step_cross"], env_id=env_id)
    rows, _ = ev.evaluate(controllers, suite)
    by = {r["controller"]: r for r in rows}
    assert by["pid"]["guard"] == pid_guard and by["full"]["guard"] == policy_guard
    assert by["pid"]["cutoff_K"] == by["full"]["cutoff_K"] == cutoff
    assert by["pid"]["v_max_V"] == by["full"]["v_max_V"] == 5.0
    summary = ev.summarize(rows)
    assert {s["controller"]: s["guard"] for s in summary} == {"pid": pid_guard, "full": policy_guard}
    table = ev.format_tables(summary, use_rich=False)
    assert "v_max [V]" in table and "guard" in table
    assert all(g in table for g in (pid_guard, policy_guard))
    if cutoff is not None:  # the plant's cut-off keeps full voltage under the limit
        assert by["full"]["time_over_limit_s"] == 0.0
    else:
        assert by["full"]["time_over_limit_s"] > 0.0
    probe.close()

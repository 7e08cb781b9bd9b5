"""The README's main command (``bash scripts/run.sh`` = ``python -m spine_gym.agents.family_comparison``):
every family, equal terms, no warnings, a closing summary of where the files went."""

import csv

import pytest
from agent_cli import run_cli

from spine_gym.agents import evaluate as ev
from spine_gym.agents import family_comparison as fc


def test_every_family_is_compared_and_no_policy_is_ranked_against_baselines_with_another_ceiling(tmp_path):
    ids = [*fc.FAMILY_IDS, "SmaSpine3D-v1"]  # the last: a 6-V policy beside 5-V ones
    runs = fc.comparisons(ids, tmp_path)
    assert [r.env_id for r in runs if not r.envelope] == ids  # each id at its own envelope
    compared = {}
    for run in runs:
        for name, folder in run.models.items():
            assert fc.policy_envelope(folder, run.defaults) == run.envelope, name
            compared[name] = run.env_id
        if run.envelope:  # the baselines are given the policies' ceiling
            argv = run.argv([])
            assert argv[argv.index("--env-kwargs") + 1 :][:1] == [f"v_max={run.envelope['v_max']:g}"]
            assert run.out.name.endswith(f"_v_max_{run.envelope['v_max']:g}")
    # every shipped policy of these ids is compared once, in the right table
    assert compared == {n: e for e in ids for n in ev.shipped_policies(e)}
    assert all(ev.shipped_policies(e) for e in fc.FAMILY_IDS)  # each family's default id has a policy
    eco = next(r for r in runs if "ppo_3d_v1_eco" in r.models)
    assert eco.envelope == {"v_max": 6.0} and "ppo_3d_v1" not in eco.models


def test_a_bad_argument_for_one_family_stops_the_command_before_any_episode(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:  # the planar suite has a hard group, the 3-D suite does not
        fc.main(["--envs", "SmaSpine-v1", "SmaSpine3D-v1", "--groups", "hard", "-o", str(tmp_path / "out")])
    assert e.value.code == 2 and "hard" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    with pytest.raises(SystemExit) as e:  # the comparisons set the env, the policies and the envelope
        fc.main(["--env", "SmaSpine-v0", "-o", str(tmp_path / "out")])
    assert e.value.code == 2 and "--envs" in capsys.readouterr().err


def test_the_command_runs_each_envelope_prints_no_warning_and_says_where_its_files_went(tmp_path):
    # one 20-s scenario of the 3-D id: its default table and the 6-V one of ppo_3d_v1_eco
    out = tmp_path / "eval"
    proc = run_cli(
        "-m", "spine_gym.agents.family_comparison", "--envs", "SmaSpine3D-v1", "-o", str(out),
        "--suite", "quick", "--scenarios", "step_diag", "--baselines", "pid", "--no-trajectories", "--plain",
        "--no-progress",
        cwd=tmp_path, timeout=600,
    )  # fmt: skip
    # -v1 asked for by name: Gymnasium's note that a -v2 exists is the only warning
    lines = (proc.stdout + proc.stderr).lower().splitlines()
    noted = [ln for ln in lines if "out of date" in ln or ln.strip() == "logger.deprecation("]
    assert noted and not [ln for ln in lines if "warn" in ln and ln not in noted]
    default, six = out / "SmaSpine3D-v1", out / "SmaSpine3D-v1_v_max_6"
    tail = proc.stdout[proc.stdout.index("tables and plots:") :]
    for folder in (default, six):
        assert (folder / "summary.csv").exists() and (folder / "plots" / "pid_nominal.png").exists()
        assert f"{folder}/ (summary.csv, relative.csv, metrics.csv, plots/)" in tail

    def pid_energy(folder):
        rows = list(csv.DictReader((folder / "summary.csv").open()))
        return next(float(r["energy_J"]) for r in rows if r["controller"] == "pid")

    assert pid_energy(six) != pid_energy(default)  # the PID of the 6-V table ran at 6 V

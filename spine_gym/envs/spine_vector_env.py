"""The native vector env every spine_gym id is built on: N spines stepped by one numba loop (serial or
parallel: the faster).

``gym.make_vec(id, num_envs=N)`` builds a subclass of :class:`SpineVectorEnv` (the geometry's:
:mod:`.planar_env`, :mod:`.spatial_env`). It runs the same
:class:`~spine_gym.envs.batch.TableBatch` as the single env with B = N: random draws (targets, loads,
randomised parameters, sensor noise) happen in Python from one generator per sub-env, seeded
``seed + i`` like ``SyncVectorEnv``; the physics and bookkeeping of all N spines is one jitted call
per step (:mod:`spine_gym.envs.step_kernels`, serial or ``prange``: from 64 envs whichever runs faster
now, :mod:`spine_gym.envs._kernel_choice`). Row i therefore equals
``gym.make(id)`` reset with ``seed + i`` and fed the same actions (tested bit for bit).
A step writes the batch's preallocated buffers (observations, table rows, flags) and hands out
fresh copies of them (:meth:`SpineVectorEnv.step_arrays`); the Gymnasium info dict is a plain
``dict`` of views of the copied rows (:func:`~spine_gym.envs._infos.vector_info`), and the SB3
adapter builds its per-env dicts from the same rows.
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ._infos import row_infos, status_texts, vector_info, vector_info_keys
from ._kernel_choice import KernelChoice, launch_threads
from .batch import SpineSnapshot
from .config import EPISODE_ATTRS, RESET_OPTION_KEYS
from .env_facts import EnvFacts, make_config

__all__ = ["SpineVectorEnv", "StepArrays", "FinalArrays", "PARALLEL_MIN_ENVS"]

# fewest sub-envs for which the default (parallel=None) chooses the kernel online, serial below it
PARALLEL_MIN_ENVS = 64

# a vector step as fresh arrays (SpineVectorEnv.step_arrays); ``rows`` (n, width) the table rows
StepArrays = namedtuple("StepArrays", ["obs", "reward", "terminated", "truncated", "rows", "status", "final"])
# SAME_STEP: the sub-envs whose episode ended and their last observation, table row and status
FinalArrays = namedtuple("FinalArrays", ["env_ids", "obs", "rows", "status"])


class SpineVectorEnv(EnvFacts, VectorEnv):
    """``num_envs`` copies of a :class:`~spine_gym.envs.spine_env.SpineEnv` in one jitted loop over spines.

    A subclass sets ``CONFIG`` and ``BATCH`` as its single env does; action, observation, reward,
    info keys and arguments are those of that single env (its class docstring is the
    documentation); the vector-specific parts are:

    * **Autoreset** (``metadata["autoreset_mode"]``): ``AutoresetMode.NEXT_STEP`` by default, as
      Gymnasium's ``SyncVectorEnv``: the step after a sub-env terminated or truncated resets it
      (its action is ignored; reward 0, ``terminated = truncated = False``, the info is the reset
      info). ``autoreset_mode=AutoresetMode.SAME_STEP`` resets in the step that ended the episode
      and puts the last observation and info in ``info["final_obs"]`` / ``info["final_info"]``
      (the Stable-Baselines3 adapter uses this mode); ``DISABLED`` leaves resets to the caller
      (``reset(options={"reset_mask": mask})``).
    * **Truncation**: the env truncates on its own after ``episode_duration / control_period``
      steps, or after ``max_episode_steps`` if that is smaller (``gym.make_vec`` passes the
      registration's 600, matching what ``gym.make``'s TimeLimit does to the single env).
    * **Seeding**: ``reset(seed=s)`` seeds sub-env i with ``s + i`` and records ``s`` as
      ``np_random_seed`` (as Gymnasium's own vector envs do); a list gives one seed per env (and
      leaves ``np_random_seed`` alone); ``None`` keeps each sub-env's generator running (fresh
      entropy on the first reset). ``get_attr("np_random_seed")`` gives the sub-envs' seeds.
    * **Options**: ``reset(options={"target": ..., "loads": ..., "params": ...})``; each value is one
      object for all sub-envs or a list of ``num_envs`` (``None`` entries draw as usual);
      ``"reset_mask"`` (bool (num_envs,)) resets only those sub-envs.
    * **Info**: a dict of arrays with one row per sub-env and the ``_key`` masks of Gymnasium, with
      the keys and masks ``SyncVectorEnv`` gives over single envs (``status_text`` as an object
      array, only on rows whose step failed).
    * ``get_attr(name)``: one value per sub-env, as ``SyncVectorEnv.get_attr`` asks each single env:
      the single spaces for ``observation_space``/``action_space``, each sub-env's generator, seed,
      state and episode for ``np_random``, ``np_random_seed``, ``state``, ``target_profile``,
      ``load_schedule``, ``model_params``; any other attribute is shared and repeated.
    * ``parallel``: which of the two bit-identical step kernels runs the loop over spines: the
      ``prange`` one on all numba threads (``True``), the serial one (``False``), or whichever is
      faster now, chosen online by measurement (``"auto"``; the default ``None`` is ``"auto"``
      from ``PARALLEL_MIN_ENVS`` = 64 sub-envs on and serial below). The chooser
      (:class:`~spine_gym.envs._kernel_choice.KernelChoice`, ``kernel_choice``) times every step,
      tries the other kernel for a few steps now and then (at once when the steps get slower) and
      keeps the faster; the probes become rarer while the choice holds (~1 % of the steps). Why:
      a parallel step waits at its join for every thread, and beside a CPU-bound process one of
      the two threads shares its core and is scheduled late; with GNU OpenMP's spinning idle
      workers the parallel kernel at 64 envs fell to 0.05-0.16x the serial one there, while on
      idle cores it runs ~1.8x. The env therefore also starts numba's threads with sleeping idle
      workers (``OMP_WAIT_POLICY=PASSIVE`` while libgomp loads, unless ``OMP_WAIT_POLICY`` or
      ``GOMP_SPINCOUNT`` is set; :func:`spine_gym.envs._kernel_choice.launch_threads`), which are woken
      at once when the next step starts. Both kernels give the same results bit for bit, so a
      switch changes nothing but speed (tested). Measurements and the command:
      ``benchmarks/bench_contention.py``, benchmarks/README.md. Below 64 envs the default never
      starts OpenMP's threads (the serial kernel; a step is too short for them to pay reliably).
    * ``render()`` returns a tuple of ``num_envs`` frames.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10, "autoreset_mode": AutoresetMode.NEXT_STEP}
    CONFIG: type = None  # the configuration class (its fields are the keyword arguments)
    BATCH: type = None  # the batch class

    def __init__(
        self,
        num_envs: int = 1,
        render_mode: str | None = None,
        *,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        max_episode_steps: int | None = None,
        parallel: bool | str | None = None,
        **env_kwargs,
    ):
        self._renderer = None  # first: gymnasium < 1.3 closes an env whose __init__ raised
        if isinstance(num_envs, bool) or not isinstance(num_envs, int | np.integer) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        self.config = cfg = make_config(self.CONFIG, type(self).__name__, env_kwargs)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ValueError(
                f"autoreset_mode must be one of {[m.value for m in AutoresetMode]}, got {autoreset_mode!r}"
            ) from None
        if isinstance(parallel, bool | np.bool_):
            parallel = bool(parallel)
        elif not (parallel is None or (isinstance(parallel, str) and parallel == "auto")):
            raise ValueError(f"parallel must be True, False, None or 'auto', got {parallel!r}")
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.autoreset_mode = mode
        self.metadata = {**self.metadata, "autoreset_mode": mode, "render_fps": 1.0 / cfg.control_period}
        self.kernel_choice = self._kernel_choice(parallel)
        start_parallel = parallel is True if self.kernel_choice is None else self.kernel_choice.parallel
        self._core = self.BATCH(cfg, self.num_envs, parallel=start_parallel)
        self.single_action_space = spaces.Box(-1.0, 1.0, (cfg.n_wires,), np.float32)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.single_observation_space = spaces.Box(self._core.obs_low, self._core.obs_high, dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.max_steps = cfg.n_steps
        if max_episode_steps is not None:
            if (
                isinstance(max_episode_steps, bool)
                or not isinstance(max_episode_steps, int | np.integer)
                or max_episode_steps < 1
            ):
                raise ValueError(
                    f"max_episode_steps must be None or an integer >= 1, got {max_episode_steps!r}"
                )
            self.max_steps = min(self.max_steps, int(max_episode_steps))
        self._core.max_steps = self.max_steps
        self._rngs: list[np.random.Generator | None] = [None] * self.num_envs
        self._sub_seeds: list[int | None] = [None] * self.num_envs
        self._no_seeds: list[int | None] = [None] * self.num_envs
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)
        self._ever_reset = False
        self._info_keys = vector_info_keys(self._core.table)

    # ------------------------------------------------------------------ kernel choice
    def _kernel_choice(self, parallel: bool | str | None) -> KernelChoice | None:
        """The online chooser for ``parallel=None`` (from PARALLEL_MIN_ENVS envs on) and ``"auto"``,
        else None (a fixed kernel). Starts numba's threads if the parallel kernel may run
        (:func:`spine_gym.envs._kernel_choice.launch_threads`: idle workers sleep)."""
        if parallel is False or (parallel is None and self.num_envs < PARALLEL_MIN_ENVS):
            return None
        launch_threads()
        return None if parallel is True else KernelChoice(parallel=True)

    @property
    def parallel(self) -> bool:
        """Whether the next step runs the parallel kernel (fixed, or the chooser's current pick)."""
        return self._core.parallel

    def _advance(self, actions: np.ndarray, rows: np.ndarray | None) -> None:
        """One step of ``rows`` (None: all) with the chosen kernel, timed for the chooser."""
        choice = self.kernel_choice
        if choice is None:
            self._core.advance(actions, self._rngs, rows)
            return
        self._core.parallel = choice.parallel
        choice.start()
        self._core.advance(actions, self._rngs, rows)
        choice.stop(self.num_envs if rows is None else rows.size)

    # ------------------------------------------------------------------ facts (as the single env)
    @property
    def np_randoms(self) -> list[np.random.Generator | None]:
        """The per-sub-env generators (sub-env i seeded ``seed + i``)."""
        return list(self._rngs)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """One value per sub-env, as ``SyncVectorEnv.get_attr`` (see the class docstring)."""
        return tuple(self._sub_env_attr(name, i) for i in range(self.num_envs))

    def _sub_env_attr(self, name: str, i: int) -> Any:
        if name in ("observation_space", "action_space"):
            return getattr(self, "single_" + name)
        if name in ("np_random", "np_random_seed"):
            if self._rngs[i] is None:  # drawn on first use, as gymnasium.Env.np_random
                self._rngs[i], self._sub_seeds[i] = seeding.np_random()
            return self._rngs[i] if name == "np_random" else self._sub_seeds[i]
        if name == "state":
            return self._core.states[i].copy()
        if name in EPISODE_ATTRS:
            episode = self._core.episodes[i]
            if episode is None:
                raise RuntimeError("call reset() first")
            return episode[EPISODE_ATTRS.index(name)]
        return getattr(self, name)

    # ------------------------------------------------------------------ reset
    def _seeds(self, seed) -> list[int | None]:
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, int | np.integer) and not isinstance(seed, bool):
            return [int(seed) + i for i in range(self.num_envs)]
        seeds = list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(
                f"a list of seeds must have num_envs = {self.num_envs} entries, got {len(seeds)}"
            )
        return seeds

    def _options_for(self, options: dict[str, Any], i: int) -> dict[str, Any]:
        out = {}
        for key in RESET_OPTION_KEYS:
            v = options.get(key)
            if isinstance(v, list | tuple):
                if len(v) != self.num_envs:
                    raise ValueError(
                        f"options[{key!r}] as a list must have num_envs = {self.num_envs} entries, "
                        f"got {len(v)}"
                    )
                v = v[i]
            if v is not None:
                out[key] = v
        return out

    def _reset_rows(self, rows: np.ndarray, seeds: Sequence[int | None], options: dict[str, Any]) -> None:
        for i in rows:
            if seeds[i] is not None or self._rngs[i] is None:
                self._rngs[i], self._sub_seeds[i] = seeding.np_random(seeds[i])
            self._core.reset_env(int(i), self._rngs[i], self._options_for(options, int(i)))
        self._autoreset[rows] = False

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None):
        """Reset all sub-envs (or those of ``options["reset_mask"]``); returns ``(obs, info)``."""
        seeds = self._seeds(seed)
        options = dict(options or {})
        unknown = set(options) - set(RESET_OPTION_KEYS) - {"reset_mask"}
        if unknown:
            raise ValueError(
                f"unknown reset option(s) {sorted(unknown)}; valid keys: {(*RESET_OPTION_KEYS, 'reset_mask')}"
            )
        mask = options.pop("reset_mask", None)
        if mask is None:
            rows = np.arange(self.num_envs)
        else:
            mask = np.asarray(mask)
            if mask.shape != (self.num_envs,) or mask.dtype != np.bool_ or not mask.any():
                raise ValueError(
                    f"options['reset_mask'] must be a bool array of shape ({self.num_envs},) with a True "
                    f"entry, got {mask!r}"
                )
            if not self._ever_reset and not mask.all():
                raise ValueError(
                    "the first reset must reset every sub-env (no reset_mask or an all-True one)"
                )
            rows = np.flatnonzero(mask)
        self._reset_rows(rows, seeds, options)
        if isinstance(seed, int | np.integer) and not isinstance(seed, bool):
            super().reset(seed=int(seed))  # records np_random_seed
        self._ever_reset = True
        infos: dict[str, Any] = {}
        self._merge(infos, self._core.reset_info(rows), rows)
        return self._core.obs.copy(), infos

    # ------------------------------------------------------------------ step
    def step(self, actions):
        """Step every sub-env; see the class docstring for the autoreset convention."""
        out = self.step_arrays(actions)
        infos = self._infos(out.rows, out.status)
        if out.final is not None:
            n = self.num_envs
            f = out.final
            final: dict[str, Any] = {}
            self._merge_step(final, self._info_arrays(f.rows, f.status), f.env_ids)
            final_obs = np.full(n, None, dtype=object)
            for j, i in enumerate(f.env_ids):
                final_obs[i] = f.obs[j]
            infos["final_obs"] = final_obs
            infos["_final_obs"] = np.isin(np.arange(n), f.env_ids)
            infos["final_info"] = final
            infos["_final_info"] = infos["_final_obs"].copy()
        return out.obs, out.reward, out.terminated, out.truncated, infos

    def step_arrays(self, actions) -> StepArrays:
        """One vector step as fresh arrays (what :meth:`step` and the SB3 adapter build their infos
        from): observations, rewards, flags, the step rows (n, width) of the env's table and the
        status codes after the autoresets, and in ``SAME_STEP`` mode the finished episodes' last
        observations, rows and status (``final``, else None)."""
        if not self._ever_reset:
            raise RuntimeError("call reset() before step()")
        actions = self._core.check_actions(actions)
        core = self._core
        rows = None
        if self.autoreset_mode == AutoresetMode.NEXT_STEP and self._autoreset.any():
            reset_rows = np.flatnonzero(self._autoreset)
            rows = np.flatnonzero(~self._autoreset)
            self._reset_rows(reset_rows, self._no_seeds, {})
        if rows is None or rows.size:
            self._advance(actions, rows)
        terminated, truncated = core.terminated.copy(), core.truncated.copy()
        reward = core.last_row[:, core.reward_col].copy()
        self._autoreset = terminated | truncated
        final = None
        if self.autoreset_mode == AutoresetMode.SAME_STEP and self._autoreset.any():
            done = np.flatnonzero(self._autoreset)
            final = FinalArrays(done, core.obs[done], core.last_row[done], core.status[done])
            self._reset_rows(done, self._no_seeds, {})
        return StepArrays(
            core.obs.copy(), reward, terminated, truncated, core.last_row.copy(), core.status.copy(), final
        )

    def row_infos(
        self,
        rows: np.ndarray | None = None,
        status: np.ndarray | None = None,
        truncated: list[bool] | None = None,
    ) -> list[dict[str, Any]]:
        """One info dict per row, as the single env gives it, of table ``rows`` and ``status`` from
        :meth:`step_arrays` (default: every sub-env's last step or reset). With ``truncated`` (one
        ``TimeLimit.truncated`` flag per row, SB3's key) the dicts carry that key and fill
        themselves on first use (:func:`spine_gym.envs._infos.row_infos`)."""
        if rows is None:
            rows, status = self._core.last_row.copy(), self._core.status.copy()
        if truncated is None:
            return self._core.row_infos(rows, status)
        return row_infos(self._core.table, rows, status, truncated)

    def _info_arrays(self, rows: np.ndarray, status: np.ndarray) -> dict[str, np.ndarray]:
        """The table's info arrays (views of ``rows``) and ``status``."""
        arrays = self._core.table.info_dict(rows)
        arrays["status"] = status
        return arrays

    def _infos(self, rows: np.ndarray, status: np.ndarray) -> dict[str, Any]:
        """Gymnasium's info dict (a plain ``dict``) of a step in which every sub-env has every key
        (views of the fresh ``rows``, all-True ``_key`` masks; :func:`~._infos.vector_info`), with
        ``status_text`` on the failed rows if a step failed."""
        infos = vector_info(self._info_keys, rows, status)
        if status.any():  # some step failed (layout.OK is 0)
            failed, texts = status_texts(status)
            self._merge(infos, {"status_text": texts}, failed)
        return infos

    def _merge_step(self, infos: dict[str, Any], arrays: dict[str, np.ndarray], rows: np.ndarray) -> None:
        """:meth:`_merge` of step infos plus ``status_text`` on the rows whose step failed."""
        self._merge(infos, arrays, rows)
        failed, texts = status_texts(arrays["status"])
        self._merge(infos, {"status_text": texts}, rows[failed])

    def _merge(self, infos: dict[str, Any], arrays: dict[str, np.ndarray], rows: np.ndarray) -> None:
        """Write per-row arrays into full-size info arrays with Gymnasium's ``_key`` masks (as
        ``VectorEnv._add_info``: no rows add no key; object arrays are filled with None)."""
        n = self.num_envs
        if rows.shape[0] == 0:
            return
        full = rows.shape[0] == n
        for key, v in arrays.items():
            if key not in infos:
                if full:
                    infos[key] = v.copy()
                    infos["_" + key] = np.ones(n, dtype=np.bool_)
                    continue
                if v.dtype == object:
                    infos[key] = np.full(n, None, dtype=object)
                else:
                    infos[key] = np.zeros((n, *v.shape[1:]), dtype=v.dtype)
                infos["_" + key] = np.zeros(n, dtype=np.bool_)
            infos[key][rows] = v
            infos["_" + key][rows] = True

    # ------------------------------------------------------------------ snapshot / restore
    def snapshot(self, i: int) -> SpineSnapshot:
        """Full state of sub-env ``i`` (as :meth:`spine_gym.envs.spine_env.SpineEnv.snapshot`, plus
        its autoreset flag)."""
        if not self._ever_reset:
            raise RuntimeError("call reset() before snapshot()")
        i = self._check_index(i)
        snap = self._core.snapshot(i)
        state = self._rngs[i].bit_generator.state
        return snap.with_rng(state, autoreset=bool(self._autoreset[i]), obs=self._core.obs[i].copy())

    def restore(self, i: int, snap: SpineSnapshot) -> None:
        """Put a snapshot (of any sub-env or single env of the same configuration) into sub-env ``i``."""
        if not self._ever_reset:
            raise RuntimeError("call reset() before restore()")
        i = self._check_index(i)
        self._core.restore(i, snap)
        if snap.rng_state is not None:
            self._rngs[i].bit_generator.state = snap.rng_state
        self._autoreset[i] = bool(snap.extra.get("autoreset", snap.extra.get("done", False)))
        if "obs" in snap.extra:
            self._core.obs[i] = snap.extra["obs"]

    def _check_index(self, i) -> int:
        if isinstance(i, bool) or not isinstance(i, int | np.integer) or not 0 <= i < self.num_envs:
            raise ValueError(f"sub-env index must be an integer in [0, {self.num_envs - 1}], got {i!r}")
        return int(i)

    # ------------------------------------------------------------------ misc
    def render(self):
        """A tuple of ``num_envs`` (480, 480, 3) uint8 frames if ``render_mode == "rgb_array"``."""
        if self.render_mode is None:
            return None
        if not self._ever_reset:
            raise RuntimeError("call reset() before render()")
        return tuple(self._frame(i, slot=i) for i in range(self.num_envs))

    def close_extras(self, **kwargs):
        """Release the renderer's figure."""
        self._close_renderer()

    def __setstate__(self, d):
        self.__dict__.update(d)
        if self.kernel_choice is not None or self._core.parallel:  # a fresh process: start numba's threads
            launch_threads()

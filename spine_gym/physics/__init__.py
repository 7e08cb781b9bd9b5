"""Jitted physics kernels of the SMA spine (numpy + numba only; no gymnasium, torch or matplotlib).

Two cores, each a subpackage with the same module names, and the modules both share at the top:

* :mod:`.planar` — one planar spine with two antagonistic wires (MODEL.md):
  :mod:`.planar.columns` (state vector), :mod:`.planar.tube` (segmented-line bending, §4),
  :mod:`.planar.solver` (composite solve and time integration, §5, §6), :mod:`.planar.stability`
  (is an equilibrium stable, §4.9), :mod:`.planar.record` (the output row), :mod:`.planar.batch`
  (the recorded time loop of :func:`spine_gym.simulate`);
* :mod:`.spatial` — any number of wires and modules in 3-D (SPATIAL.md):
  :mod:`.spatial.columns` (wire and module tables, state offsets), :mod:`.spatial.tube`,
  :mod:`.spatial.solver`, :mod:`.spatial.stability`;
* shared: :mod:`.columns` (the constants ``kp``, the solver options ``ks`` and the status codes),
  :mod:`.sma` (the MAS wire model, §3), :mod:`.coupled` (the coupled phase step, §6.5),
  :mod:`.dense` (sub-steps across held output steps), :mod:`.stability` (generic stability and LU
  kernels, §4.9), :mod:`.env_kernels` (one control period of the envs, either core),
  :mod:`.rollout` (the MPC's batched rollouts, either core), :mod:`._jit` (numba options) and
  :mod:`._deal` (rows of a ``prange`` loop dealt out one at a time).

A core imports from the shared modules and never from the other core.
"""

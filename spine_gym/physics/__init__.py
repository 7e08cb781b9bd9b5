"""Jitted physics kernels of the SMA spine (numpy + numba only; no gymnasium, torch or matplotlib).

Two cores, each a subpackage with the same module and function names (the core is chosen by the
module: ``planar.control.step_spine`` or ``spatial.control.step_spine``), and the modules both share
at the top:

* :mod:`.planar` — one planar spine with two antagonistic wires (MODEL.md);
* :mod:`.spatial` — any number of wires and modules in 3-D (SPATIAL.md).

Each core, from the bottom up:

* ``columns`` — the state vector (the spatial core's also its wire and module tables);
* ``tube`` — the tube's bending (segmented line, §4) and ``stability`` — is an equilibrium
  stable (§4.9);
* ``work`` — the time step's scratch arrays (the spatial core's also its state views);
* ``mechanics`` — strains, stresses and the wire moment of a shape, the loop gain and dσ/dx (§3.6, §4);
* ``composite`` — the composite solve (§5): coupled Newton, its fallbacks, the buckling status;
* ``record`` — the output row of one spine;
* ``substep`` — one sub-step (§6.1, §6.5) and ``integrate`` — the output step
  (``advance``, ``advance_held``/``advance_held_in``, ``init_state``);
* ``run`` — the recorded time loop of :func:`spine_gym.simulate`;
* ``control`` — one control period of the envs (``step_spine``, ``record_many``);
* ``rollout`` — the MPC's batched open-loop rollouts (``rollout_many``, ``rollout_many_serial``).

Shared: :mod:`.columns` (the constants ``kp``, the solver options ``ks`` and the status codes),
:mod:`.sma` (the MAS wire model, §3), :mod:`.coupled` (the coupled phase step, §6.5),
:mod:`.dense` (sub-steps across held output steps), :mod:`.stability` (generic stability and LU
kernels, §4.9), :mod:`.rollout_rows` (what a failed rollout records), :mod:`._jit` (numba options)
and :mod:`._deal` (rows of a ``prange`` loop dealt out one at a time). The modules
``env_kernels``, ``rollout``, ``planar.solver``, ``planar.batch`` and ``spatial.solver`` only
re-export names under their former paths.

A core imports from the shared modules and never from the other core.
"""

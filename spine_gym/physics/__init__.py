"""Jitted physics kernels of the SMA spine (numpy + numba only; no gymnasium, torch or matplotlib).

* :mod:`.sma` — MAS wire model (MODEL.md §3)
* :mod:`.tube` — segmented-line bending (§4)
* :mod:`.solver` — composite solve and time integration (§5, §6)
* :mod:`.batch` — loops over many spines (vector env, design sweeps)
* :mod:`.layout` — index constants of the flat arrays the kernels take
"""

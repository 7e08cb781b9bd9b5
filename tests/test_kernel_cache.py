"""numba's cache is re-validated against a kernel's own file only; spine_gym._kernel_cache clears every cached
kernel when any kernel source changed (an edit of integrate.py must reach the kernels of control.py)."""

from __future__ import annotations

from spine_gym import _kernel_cache as kc


def _tree(tmp_path):
    src = tmp_path / "integrate.py"
    src.write_text("def advance(): return 1\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    kernels = [cache / "control.step_spine-26.py311.nbi", cache / "control.step_spine-26.py311.1.nbc"]
    for f in kernels:
        f.write_bytes(b"compiled")
    keep = cache / "integrate.cpython-311.pyc"
    keep.write_bytes(b"bytecode")
    return src, cache, kernels, keep


def test_unchanged_sources_keep_the_cache(tmp_path):
    src, cache, kernels, keep = _tree(tmp_path)
    assert kc.clear_stale_caches([src], [cache])  # no stamp yet: first run clears and stamps
    for f in kernels:
        f.write_bytes(b"compiled again")
    assert not kc.clear_stale_caches([src], [cache])
    assert all(f.exists() for f in kernels) and keep.exists()


def test_an_edited_callee_clears_every_cached_kernel(tmp_path):
    src, cache, kernels, keep = _tree(tmp_path)
    kc.clear_stale_caches([src], [cache])
    for f in kernels:
        f.write_bytes(b"compiled with the old advance")
    src.write_text("def advance(): return 2\n")
    assert kc.clear_stale_caches([src], [cache])
    assert not any(f.exists() for f in kernels)
    assert keep.exists()  # Python's own bytecode is not ours to touch


def test_the_package_stamp_covers_every_kernel_source():
    names = {"/".join(p.parts[-2:]) for p in kc.KERNEL_SOURCES}
    expected = {"planar/integrate.py", "planar/tube.py", "physics/sma.py", "planar/control.py", "spatial/integrate.py"}
    assert expected | {"envs/readout.py"} <= names
    assert (kc.KERNEL_CACHE_DIRS[0] / kc.STAMP_NAME).is_file()  # written when the package was imported

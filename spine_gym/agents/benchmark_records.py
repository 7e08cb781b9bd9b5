"""A study's per-seed run records as one compressed archive (``records.tar.xz`` in its folder).

A run of the benchmark (:func:`spine_gym.agents.benchmark_run.run_one`) leaves ``curve.csv``,
``meta.json`` and ``done.json`` in its ``runs/<env id>/<algo>/seed_<k>/`` folder, and the
benchmark caches the reference controllers' validation episodes in ``references/<env id>.json``;
a study of a few hundred runs is a few hundred small files. A study folder keeps them as one
archive instead:

* :func:`pack_records` — every record file under the folder (``model.zip`` and
  ``vecnormalize.pkl`` are not records) and the folder's ``references/*.json`` into
  ``records.tar.xz``, byte-reproducible (sorted members, no time stamps or owners), so that
  packing the same records twice gives the same file;
* :func:`archived_records` — the archive's files (path relative to the study folder -> bytes);
* :func:`restore_records` — unpack the archived runs whose folder does not exist yet, never
  touching one that does, and the reference files that are missing
  (:func:`restore_references`): what the benchmark does on start, so that a study folder with the
  archive resumes as one with the run folders (finished runs skipped, references not recomputed,
  the table rewritten).
"""

from __future__ import annotations

import io
import tarfile
from pathlib import Path, PurePosixPath

ARCHIVE = "records.tar.xz"
DONE = "done.json"  # written last: a run folder without it is a run to start over
RECORD_FILES = ("curve.csv", DONE, "meta.json")  # what a finished run keeps besides its model
REFERENCES = "references"  # the benchmark's cache of the references' episodes: references/<env id>.json


def record_paths(folder: Path) -> list[Path]:
    """The record files of every run under ``folder`` (any depth of ``runs/`` folders) and its
    ``references/*.json``, sorted."""
    folder = Path(folder)
    paths = (p for name in RECORD_FILES for p in folder.rglob(name))
    runs = [p for p in paths if "runs" in p.relative_to(folder).parts and p.is_file()]
    return sorted(runs + [p for p in (folder / REFERENCES).glob("*.json") if p.is_file()])


def pack_records(folder: Path) -> Path:
    """Write the run records under ``folder`` into ``folder/records.tar.xz`` (replacing it); returns
    its path. ValueError if the folder holds no run record."""
    folder = Path(folder)
    paths = record_paths(folder)
    if not paths:
        raise ValueError(f"{folder} holds no run records ({', '.join(RECORD_FILES)} under runs/)")
    with tarfile.open(folder / ARCHIVE, "w:xz", preset=9, format=tarfile.PAX_FORMAT) as tar:
        for path in paths:
            data = path.read_bytes()
            info = tarfile.TarInfo(path.relative_to(folder).as_posix())
            info.size, info.mode, info.mtime = len(data), 0o644, 0
            tar.addfile(info, io.BytesIO(data))
    return folder / ARCHIVE


def _is_reference(path: PurePosixPath) -> bool:
    return len(path.parts) == 2 and path.parts[0] == REFERENCES and path.suffix == ".json"


def _member_path(name: str) -> PurePosixPath:
    path = PurePosixPath(name)
    if path.is_absolute() or ".." in path.parts or not (path.name in RECORD_FILES or _is_reference(path)):
        allowed = f"{', '.join(RECORD_FILES)} or {REFERENCES}/*.json"
        raise ValueError(f"{ARCHIVE}: {name!r} is not a run record ({allowed} inside the folder)")
    return path


def archived_records(archive: Path) -> dict[str, bytes]:
    """The files of a records archive: path relative to its folder -> bytes. ValueError on a member
    that is not a run record file inside the folder (an absolute path, ``..``, another name)."""
    with tarfile.open(archive, "r:xz") as tar:
        return {
            _member_path(m.name).as_posix(): tar.extractfile(m).read() for m in tar.getmembers() if m.isfile()
        }


def restore_references(folder: Path) -> int:
    """Unpack the ``references/*.json`` of ``folder/records.tar.xz`` that ``folder`` does not hold
    (one that exists is kept as it is); returns how many files were written (0 without an archive)."""
    archive = Path(folder) / ARCHIVE
    if not archive.exists():
        return 0
    files = {n: d for n, d in archived_records(archive).items() if _is_reference(PurePosixPath(n))}
    missing = {Path(folder) / n: d for n, d in files.items() if not (Path(folder) / n).exists()}
    for path, data in missing.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    return len(missing)


def restore_records(folder: Path) -> int:
    """Unpack ``folder/records.tar.xz`` into ``folder``, run by run: the records of each run whose
    folder does not exist yet (a run folder that exists is kept as it is, e.g. a run rerun since;
    ``done.json`` is written last, as a run writes it), and the missing reference files
    (:func:`restore_references`); returns how many runs were written (0 without an archive)."""
    archive = Path(folder) / ARCHIVE
    if not archive.exists():
        return 0
    restore_references(folder)
    runs: dict[Path, dict[str, bytes]] = {}
    for name, data in archived_records(archive).items():
        if _is_reference(PurePosixPath(name)):
            continue
        path = Path(folder) / name
        runs.setdefault(path.parent, {})[path.name] = data
    missing = {run: files for run, files in runs.items() if not run.exists()}
    for run, files in missing.items():
        run.mkdir(parents=True)
        for name in sorted(files, key=lambda n: n == DONE):
            (run / name).write_bytes(files[name])
    return len(missing)

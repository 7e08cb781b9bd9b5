"""spine_gym.agents.benchmark_records: a study's run records as one archive, read and unpacked as
the run folders they came from."""

import io
import json
import shutil
import tarfile

import pytest

from spine_gym.agents.benchmark_records import (
    ARCHIVE,
    archived_records,
    pack_records,
    record_paths,
    restore_records,
    restore_references,
)


def _study(folder):
    """A tiny synthetic study: two finished runs (one in a candidate's sub-folder), the references'
    cache of one env id and a model file."""
    files = {"references/SmaSpine-v1.json": json.dumps({"pid": {"means": {"rmse": 3.0}}}).encode()}
    for run, rmse in (("runs/SmaSpine-v1/ppo/seed_0", 3.5), ("cand_a/runs/SmaSpine-v1/sac/seed_1", 4.25)):
        files[f"{run}/curve.csv"] = f"step,rmse\n0,9.0\n1000,{rmse}\n".encode()
        files[f"{run}/meta.json"] = json.dumps({"algo": run.split("/")[-2]}).encode()
        files[f"{run}/done.json"] = json.dumps({"record": {"final_rmse": rmse}}).encode()
    for name, data in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(data)
    (folder / "runs/SmaSpine-v1/ppo/seed_0/model.zip").write_bytes(b"not a record")
    (folder / "table.md").write_text("| not a record |\n")
    return files


def test_the_archive_holds_exactly_the_records_of_the_folder(tmp_path):
    files = _study(tmp_path)
    archive = pack_records(tmp_path)
    assert archive == tmp_path / ARCHIVE
    assert archived_records(archive) == files
    assert [p.relative_to(tmp_path).as_posix() for p in record_paths(tmp_path)] == sorted(files)


def test_packing_the_same_records_twice_gives_the_same_bytes(tmp_path):
    _study(tmp_path)
    first = pack_records(tmp_path).read_bytes()
    for p in record_paths(tmp_path):
        p.touch()  # other time stamps, same records
    assert pack_records(tmp_path).read_bytes() == first


def test_restoring_into_an_empty_folder_gives_back_the_run_folders(tmp_path):
    files = _study(tmp_path / "study")
    pack_records(tmp_path / "study")
    clone = tmp_path / "clone"
    clone.mkdir()
    (tmp_path / "study" / ARCHIVE).rename(clone / ARCHIVE)
    assert restore_records(clone) == 2
    assert {p.relative_to(clone).as_posix(): p.read_bytes() for p in record_paths(clone)} == files
    assert restore_records(clone) == 0  # every run folder there now


def test_the_references_alone_are_restored_and_one_that_exists_is_kept(tmp_path):
    files = _study(tmp_path)
    pack_records(tmp_path)
    ref = tmp_path / "references/SmaSpine-v1.json"
    ref.unlink()
    shutil.rmtree(tmp_path / "cand_a")
    assert restore_references(tmp_path) == 1
    assert ref.read_bytes() == files["references/SmaSpine-v1.json"]
    assert not (tmp_path / "cand_a").exists()  # the runs are restore_records'
    ref.write_text("{}")  # recomputed since: kept
    assert restore_references(tmp_path) == 0 and ref.read_text() == "{}"


def test_a_run_folder_that_exists_is_kept_as_it_is(tmp_path):
    _study(tmp_path)
    pack_records(tmp_path)
    rerun = tmp_path / "runs/SmaSpine-v1/ppo/seed_0"
    for p in rerun.iterdir():
        p.unlink()
    (rerun / "curve.csv").write_text("step,rmse\n0,9.0\n")  # a rerun under way: no done.json yet
    assert restore_records(tmp_path) == 0
    assert sorted(p.name for p in rerun.iterdir()) == ["curve.csv"]


def test_no_archive_restores_nothing_and_no_records_is_refused(tmp_path):
    assert restore_records(tmp_path) == 0
    with pytest.raises(ValueError, match="holds no run records"):
        pack_records(tmp_path)
    assert not (tmp_path / ARCHIVE).exists()


@pytest.mark.parametrize(
    "name",
    ["../runs/a/done.json", "/tmp/runs/a/done.json", "runs/a/model.zip", "references/a.txt", "a/references/b.json"],
)
def test_a_member_that_is_not_a_record_inside_the_folder_is_refused(tmp_path, name):
    with tarfile.open(tmp_path / ARCHIVE, "w:xz") as tar:
        info = tarfile.TarInfo(name)
        info.size = 2
        tar.addfile(info, io.BytesIO(b"{}"))
    with pytest.raises(ValueError, match="is not a run record"):
        restore_records(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == [ARCHIVE]

"""A dataset's identity: the draw version it records, and what a checksum mismatch says."""

import json

import h5py
import pytest

from nh_operators.data import H5Rows, MemoryRows, generate_dataset, load_dataset
from nh_operators.data.generate import checksum_mismatch, describe_draw
from nh_operators.solving import Calibration
from nh_operators.solving.catalog import WEIGHTS


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A draw-2 file, and the same file as an older version wrote it (no ``draw``)."""
    folder = tmp_path_factory.mktemp("identity")
    new = folder / "new.h5"
    generate_dataset(6, seed=4, path=new, progress=False)
    old = folder / "old.h5"
    old.write_bytes(new.read_bytes())
    with h5py.File(old, "r+") as f:
        generator = json.loads(f.attrs["generator"])
        del generator["draw"]
        f.attrs["generator"] = json.dumps(generator, sort_keys=True)
    return new, old


def test_a_new_file_records_draw_2_and_an_old_one_reads_as_draw_1(files):
    new, old = files
    ds = load_dataset(new)
    assert ds.attrs["generator"]["draw"] == 2
    assert ds.generator == {**ds.attrs["generator"], "package": ds.attrs["version"]}
    assert load_dataset(old).generator["draw"] == 1
    assert H5Rows(new).generator["draw"] == 2 and H5Rows(old).generator["draw"] == 1
    assert MemoryRows(ds).generator["draw"] == 2
    # attributes are not hashed: the same arrays, the same checksum
    assert load_dataset(old).checksum == ds.checksum


def test_a_shipped_calibration_names_the_draw_of_its_dataset(files):
    cal = Calibration.read(WEIGHTS / "phaseonet-paper" / "calibration.json")
    assert "dataset_draw" not in cal.info  # shipped before draw 2: draw 1
    with pytest.raises(ValueError) as err:
        cal.check_dataset(files[0], "phaseonet-paper")
    msg = str(err.value)
    assert msg.startswith("this is not the dataset phaseonet-paper was calibrated on: "
                          f"checksum {load_dataset(files[0]).checksum}, recorded "
                          f"{cal.info['dataset_checksum']}.")
    assert (f"The recorded dataset was made by {describe_draw(1)} (the record names no "
            "draw: it predates draw 2).") in msg
    assert f"This file was made by {describe_draw(2)} with nh-operators 0.1.0" in msg
    assert "draws with draw 2. Another draw gives other last bits" in msg


def test_mismatch_messages_for_the_same_draw(files):
    old = load_dataset(files[1])
    msg = checksum_mismatch("the record's dataset", "sha256:0", old)
    assert "Draw 1's bits depend on the CPU's BLAS kernel" in msg
    msg = checksum_mismatch("the record's dataset", "sha256:0", load_dataset(files[0]), 2)
    assert msg.endswith("Same draw: the file was made with other parameters, seed or size, "
                        "or was modified.")
    cal = Calibration.read(WEIGHTS / "phaseonet-paper" / "calibration.json")
    same = Calibration.from_json({**cal.to_json(), "info": {
        **cal.to_json()["info"], "dataset_checksum": load_dataset(files[0]).checksum}})
    assert same.check_dataset(files[0]) is None  # the recorded dataset: no error

"""Outputs never replace a file the run reads, nor a device (issue 39): the
checks of the library's run() hold for the Python API as for the CLI."""

import os
import stat

import pytest

import isoloft
from test_isoloft import read_bytes, write_sparse_label_volume


def test_an_output_onto_the_input_is_refused_and_the_input_kept(tmp_path):
    vol = tmp_path / "labels.mha"
    write_sparse_label_volume(vol)
    before = read_bytes(vol)
    with pytest.raises(isoloft.ParamError, match=r"report .*labels\.mha: is the input .*labels\.mha; an output never"):
        isoloft.reconstruct(vol, report=vol)
    with pytest.raises(isoloft.ParamError, match=r"labelmap .*labels\.mha: is the input"):
        isoloft.reconstruct(vol, labelmap=vol)
    assert read_bytes(vol) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["labels.mha"], "nothing else written"


def test_a_report_to_a_device_is_written_in_place(tmp_path):
    vol = tmp_path / "labels.mha"
    write_sparse_label_volume(vol)
    res = isoloft.reconstruct(vol, report="/dev/null")
    assert res.report["objects"]
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    with pytest.raises(isoloft.InputError, match=r"report /dev/full: cannot write file \(No space left on device\)"):
        isoloft.reconstruct(vol, report="/dev/full")


# ---------------------------------------------------------------- save() (issue 39)

def test_save_checks_its_paths_as_reconstruct_does_and_writes_all_or_none(tmp_path):
    vol = tmp_path / "labels.mha"
    write_sparse_label_volume(vol)
    before = read_bytes(vol)
    res = isoloft.reconstruct(vol, method="levin")
    assert len(res.objects) == 2
    with pytest.raises(isoloft.ParamError, match=r"path .*labels\.mha: is the input .*labels\.mha; an output never"):
        res.objects[0].save(tmp_path / "labels.mha")
    # The combined file of Result.save() onto the input: refused before any object's file is written.
    with pytest.raises(isoloft.ParamError, match=r"path .*labels\.mha: is the input"):
        res.save(vol)
    with pytest.raises(isoloft.ParamError, match=r"path .*: is a directory, not a regular file"):
        res.objects[0].save(tmp_path)
    assert read_bytes(vol) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["labels.mha"], "nothing else written"
    # A device (here through a link with a mesh extension) is written in place, never replaced by a
    # rename; a full one is an error naming the path and errno.
    (tmp_path / "null.ply").symlink_to("/dev/null")
    (tmp_path / "full.ply").symlink_to("/dev/full")
    res.objects[0].save(tmp_path / "null.ply")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode) and (tmp_path / "null.ply").is_symlink()
    with pytest.raises(isoloft.Error, match=r"path .*full\.ply: write error \(No space left on device\)"):
        res.objects[0].save(tmp_path / "full.ply")
    for link in ("null.ply", "full.ply"):
        (tmp_path / link).unlink()
    files = res.save(tmp_path / "m.ply")
    assert [os.path.basename(f) for f in files] == ["m_label4.ply", "m_label9.ply", "m.ply"]
    assert all(os.path.isfile(f) for f in files)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "no staged file left"


def test_save_refuses_a_data_file_and_a_reference_the_run_read(tmp_path):
    vol = tmp_path / "labels.mhd"
    raw = tmp_path / "labels.raw"
    write_sparse_label_volume(tmp_path / "labels.mha")
    data = read_bytes(tmp_path / "labels.mha")
    header, voxels = data[:data.index(b"ElementDataFile = LOCAL\n")], data[data.index(b"LOCAL\n") + 6:]
    vol.write_bytes(header + b"ElementDataFile = labels.raw\n")
    raw.write_bytes(voxels)
    with pytest.raises(isoloft.ParamError, match=r"report .*labels\.raw: is the input's data file .*labels\.raw"):
        isoloft.reconstruct(vol, report=raw)
    res = isoloft.reconstruct(vol, method="levin")
    with pytest.raises(isoloft.ParamError, match=r"path .*labels\.raw: is the input's data file"):
        res.objects[0].save(raw)
    assert read_bytes(raw) == voxels


# ---------------------------------------------------------------- names in errors (issue 39)

def _rtss_with_names(path, data_dir, renamed):
    """The repository's breast RT Structure Set with ROI names replaced by
    bytes of the same length (implicit VR: no length to rewrite)."""
    data = bytearray((data_dir / "rtstruct" / "rtss.dcm").read_bytes())
    for old, new in renamed.items():
        assert len(old) == len(new)
        tag = b"\x06\x30\x26\x00" + len(old).to_bytes(4, "little") + old
        at = bytes(data).index(tag)
        data[at + 8:at + 8 + len(old)] = new
    path.write_bytes(bytes(data))
    return path


def test_errors_raised_to_python_carry_no_raw_control_byte(tmp_path, data_dir):
    rt = _rtss_with_names(tmp_path / "esc.dcm", data_dir, {b"Tumor Bed ": b"T\x1b]0;x\x07ed ", b"Scar": b"S\x1b\x07r"})
    with pytest.raises(isoloft.InputError) as err:
        isoloft.read(rt, roi="Tumor Bed")  # not there any more: the message lists the ROIs by name
    message = str(err.value)
    assert not any(ord(c) < 0x20 or ord(c) == 0x7F for c in message), repr(message)
    assert "T\\x1B]0;x\\x07ed" in message and "S\\x1B\\x07r" in message, message
    # The names themselves stay as read.
    assert "S\x1b\x07r" in isoloft.read(rt, roi=[8, 9]).names

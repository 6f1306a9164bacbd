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

"""The record reader's numbers: its fast path (model/c/record.c, parse_decimal: m 10^e read with one correctly
rounded operation where m <= 2^53 and |e| <= 22, Clinger 1990) gives strtod's value to the bit, at two million
random tokens of every form a record holds. A white-box check compiled from model/c with the system's gcc."""
import shutil
import subprocess

import pytest

from tests.conftest import compile_white_box


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_the_fast_reader_equals_strtod_to_the_bit(tmp_path):
    exe = compile_white_box(tmp_path, "record_parse.c")
    trials, fast, differ = map(int, subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split())
    assert trials == 2_000_000
    assert fast > trials // 4, fast  # the fast path read a good share (the rest: strtod's)
    assert differ == 0, differ

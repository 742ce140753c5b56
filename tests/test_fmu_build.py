"""fmu_build: builds from source, only when the sources changed."""

from __future__ import annotations

import zipfile

import pytest

from fmu_build.__main__ import main
from fmu_build.build import build_fmu, win64_compiler


def test_rebuild_only_when_sources_change(tmp_path):
    out = tmp_path / "RockingBlock.fmu"
    build_fmu(out, platforms=["linux64"])  # linux64 alone: quicker, and the stamp works alike
    stamp = out.stat().st_mtime_ns
    build_fmu(out, platforms=["linux64"])  # unchanged sources: nothing to do
    assert out.stat().st_mtime_ns == stamp
    build_fmu(out, platforms=["linux64"], force=True)
    assert out.stat().st_mtime_ns != stamp


def test_fmu_contents(tmp_path):
    out = build_fmu(tmp_path / "RockingBlock.fmu")
    names = set(zipfile.ZipFile(out).namelist())
    assert {"modelDescription.xml", "binaries/linux64/RockingBlock.so", "sources/fmi2.c", "sources/model.c",
            "sources/solver.c", "sources/integrator.c", "sources/config.h", "sources/variables.def"} <= names
    assert ("binaries/win64/RockingBlock.dll" in names) == (win64_compiler() is not None)


def test_the_fmu_documents_every_variable(fmu_path):
    """documentation/index.html: every variable with its unit and every enumeration item,
    then the model's documentation, as well-formed HTML."""
    from html.parser import HTMLParser

    from fmu_build.build import C_DIR
    from fmu_build.variables import read_enumerations, read_variables

    with zipfile.ZipFile(fmu_path) as zf:
        page = zf.read("documentation/index.html").decode("utf-8")

    class Text(HTMLParser):
        def __init__(self):
            super().__init__()
            self.parts: list[str] = []
            self.open: list[str] = []

        def handle_starttag(self, tag, attrs):
            if tag not in ("br", "hr", "meta", "img", "input"):
                self.open.append(tag)

        def handle_endtag(self, tag):
            assert self.open and self.open[-1] == tag, (tag, self.open[-5:])
            self.open.pop()

        def handle_data(self, data):
            self.parts.append(data)

    parser = Text()
    parser.feed(page)
    assert not parser.open
    text = " ".join(parser.parts)
    for v in read_variables(C_DIR / "variables.def"):
        assert v.name in text and v.description.split("(")[0].strip() in text, v.name
    for enum in read_enumerations(C_DIR / "variables.def").values():
        assert all(item in text for _, item, _ in enum.items)
    assert "Equation of motion" in text and "Model Exchange" in text


def test_without_the_cross_compiler_the_fmu_has_no_windows_binary_until_it_is_installed(tmp_path, monkeypatch,
                                                                                        capsys):
    out = tmp_path / "RockingBlock.fmu"
    monkeypatch.setenv("CC_WIN64", "x86_64-w64-mingw32-gcc-not-installed")
    build_fmu(out)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "has no Windows binary" in err, err
    assert not any(name.startswith("binaries/win64/") for name in zipfile.ZipFile(out).namelist())
    monkeypatch.delenv("CC_WIN64")
    if win64_compiler() is None:
        pytest.skip("the rest needs x86_64-w64-mingw32-gcc (Debian: gcc-mingw-w64-x86-64)")
    build_fmu(out)  # same sources, but now win64 can be built: the stamp says rebuild
    assert "binaries/win64/RockingBlock.dll" in zipfile.ZipFile(out).namelist()


def test_a_platform_that_cannot_be_built_is_a_one_line_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("CC_WIN64", "x86_64-w64-mingw32-gcc-not-installed")
    out = tmp_path / "RockingBlock.fmu"
    for args, message in [(["--platforms", "win64"], "cross compiler 'x86_64-w64-mingw32-gcc-not-installed' is "
                                                      "not installed"),
                          (["--platforms", "linux64,macos"], "unknown platform 'macos'"),
                          (["--sanitize", "--platforms", "linux64,win64"], "for linux64 only")]:
        assert main([*args, "--out", str(out)]) == 1
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1 and message in err, err
    assert not out.exists()

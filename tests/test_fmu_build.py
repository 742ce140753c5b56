"""fmu_build: builds from source, only when the sources changed."""

from __future__ import annotations

import zipfile

from fmu_build.build import build_fmu


def test_rebuild_only_when_sources_change(tmp_path):
    out = tmp_path / "RockingBlock.fmu"
    build_fmu(out)
    stamp = out.stat().st_mtime_ns
    build_fmu(out)  # unchanged sources: nothing to do
    assert out.stat().st_mtime_ns == stamp
    build_fmu(out, force=True)
    assert out.stat().st_mtime_ns != stamp


def test_fmu_contents(tmp_path):
    out = build_fmu(tmp_path / "RockingBlock.fmu")
    names = set(zipfile.ZipFile(out).namelist())
    assert {"modelDescription.xml", "binaries/linux64/RockingBlock.so", "sources/fmi2.c", "sources/model.c",
            "sources/solver.c", "sources/integrator.c", "sources/config.h", "sources/variables.def"} <= names


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

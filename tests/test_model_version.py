"""The renderer advice's cache key (``model_version``): a digest of every module the noise
model reads — a change to any of them makes cached predictions stale, and nothing else
does."""
from __future__ import annotations

from pathlib import Path

import pytest

from envfit.advisor._renderer_model import model_version


@pytest.mark.parametrize("where", ["renderers/mitsuba3/_envmap.py", "renderers/cycles/_render.py",
                                   "predict/renderer/_cell_request.py",
                                   "predict/renderer/randomisation/_owen.py",
                                   "shading/microfacet/_conductor.py"])
def test_a_change_to_any_model_module_changes_the_version(monkeypatch, where):
    before = model_version()
    read = Path.read_bytes

    def edited(self):
        data = read(self)
        return data + b"\n# edited\n" if self.as_posix().endswith(where) else data

    monkeypatch.setattr(Path, "read_bytes", edited)
    assert model_version() != before


def test_modules_outside_the_model_leave_the_version(monkeypatch):
    before = model_version()
    read = Path.read_bytes
    monkeypatch.setattr(Path, "read_bytes", lambda self: read(self) + (
        b"\n# edited\n" if self.as_posix().endswith("cli/_advise.py") else b""))
    assert model_version() == before

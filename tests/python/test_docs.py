"""docs/python.md is executed: its python blocks run in order in one namespace (a notebook's
cells), from a folder holding the repository's scenes/; a block after an
`<!-- not run: ... -->` line is skipped (it needs what the tests do not install)."""

import os
import re


def _blocks(text):
    blocks = []
    for m in re.finditer(r"(<!-- not run:[^\n]*-->\n)?```python\n(.*?)```", text, re.S):
        if m.group(1) is None:
            blocks.append(m.group(2))
    return blocks


def test_python_md_runs(repo, tmp_path, monkeypatch, capsys):
    text = (repo / "docs" / "python.md").read_text()
    blocks = _blocks(text)
    assert len(blocks) >= 7, "the page's examples"
    (tmp_path / "scenes").symlink_to(repo / "scenes")
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs__"}
    for n, code in enumerate(blocks):
        try:
            exec(compile(code, f"docs/python.md block {n + 1}", "exec"), namespace)
        except Exception as e:
            raise AssertionError(f"docs/python.md block {n + 1} failed: {e!r}\n{code}") from e
    out = capsys.readouterr().out
    assert "<isoview.Image 128x96 analytic on" in out
    assert (tmp_path / "torus.exr").is_file() and (tmp_path / "fixed.exr").is_file()

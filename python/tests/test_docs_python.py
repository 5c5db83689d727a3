"""The guide's Python page runs: every code block marked as tested in docs/src/how-to/python.md is executed,
in order, in one namespace, from the checkout root (a block that raises fails the test)."""

import re

from conftest import ROOT

PAGE = ROOT / "docs" / "src" / "how-to" / "python.md"
MARKER = "<!-- tested: python/tests/test_docs_python.py runs this block -->"


def _tested_blocks():
    text = PAGE.read_text()
    blocks = re.findall(re.escape(MARKER) + r"\n```python\n(.*?)```", text, flags=re.S)
    # Every marker is followed by a Python block (a marker before anything else would test nothing).
    assert len(blocks) == text.count(MARKER), "a tested marker is not followed by a ```python block"
    return blocks


def test_the_python_page_examples_run(monkeypatch):
    blocks = _tested_blocks()
    assert len(blocks) >= 4, f"only {len(blocks)} tested blocks in {PAGE}"
    monkeypatch.chdir(ROOT)
    namespace = {"__name__": "__docs__"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"{PAGE.name} block {i + 1}", "exec"), namespace)

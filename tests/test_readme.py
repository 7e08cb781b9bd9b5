"""The README's Python examples run as written and print what their comments say.

Every ```python block of README.md runs in one namespace, in order; each ``print(...)  # text``
line must print ``text``. The bash blocks are checked elsewhere: the quick start by CI itself,
the ``spine-gym`` commands by tests/test_cli.py.
"""

from __future__ import annotations

import contextlib
import io
import re

from repo import ROOT

README = ROOT / "README.md"
PRINT_COMMENT = re.compile(r"^\s*print\(.*\)\s+#\s*(?P<expected>.+?)\s*$")


def python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, re.S)


def expected_prints(block: str) -> list[str]:
    return [m["expected"] for line in block.splitlines() if (m := PRINT_COMMENT.match(line))]


def test_the_readme_has_python_examples_with_stated_outputs():
    blocks = python_blocks(README.read_text())
    assert len(blocks) >= 2
    assert sum(len(expected_prints(b)) for b in blocks) >= 2


def test_the_readme_python_blocks_run_and_print_what_they_say():
    namespace: dict = {"__name__": "readme"}
    for block in python_blocks(README.read_text()):
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            exec(compile(block, str(README), "exec"), namespace)  # noqa: S102 - the README's own code
        assert out.getvalue().splitlines() == expected_prints(block)

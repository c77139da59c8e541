"""The Python examples of the docs run as written (issue 35: docs/gym.md's vector env)."""

import re

import pytest
from conftest import PROJECT_ROOT

RUNNABLE = ["docs/gym.md"]


@pytest.mark.parametrize("page", RUNNABLE)
def test_every_python_block_of_the_page_runs(page, capsys):
    blocks = re.findall(r"```python\n(.*?)```", (PROJECT_ROOT / page).read_text(), re.S)
    assert blocks
    for block in blocks:
        exec(compile(block, page, "exec"), {})
    assert "cells visited per env" in capsys.readouterr().out

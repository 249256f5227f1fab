"""docs/python.md: every python block runs as it is on the example campaign it describes
(campaigns/examples/python-alignment.json, planned, run and reported as the page says)."""

import os
import re
import subprocess
import sys

import pytest

from conftest import SOURCE, exe


@pytest.fixture(scope="module")
def example(tmp_path_factory):
    exe("granary-engine")
    d = tmp_path_factory.mktemp("python-doc")
    env = dict(os.environ, GRANARY_CACHE_DIR=str(d / "beds"))
    spec = os.path.join(SOURCE, "campaigns", "examples", "python-alignment.json")
    for args in (["plan", spec, "--db", "study.db"], ["run", "--db", "study.db", "--jobs", "2"],
                 ["report", "--db", "study.db", "--out", "report", "--no-figures"]):
        r = subprocess.run([exe("campaign"), *args], capture_output=True, text=True, cwd=d, env=env)
        assert r.returncode == 0, f"campaign {' '.join(args)}:\n{r.stdout[-3000:]}{r.stderr[-3000:]}"
    return d


def blocks():
    text = open(os.path.join(SOURCE, "docs", "python.md")).read()
    return re.findall(r"```python\n(.*?)```", text, re.S)


def test_the_page_has_its_blocks():
    assert len(blocks()) == 4


@pytest.mark.parametrize("k", range(4))
def test_every_python_block_of_docs_python_md_runs(example, k):
    code = blocks()[k]
    env = dict(os.environ, PYTHONPATH=os.path.join(SOURCE, "python"))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=example, env=env)
    assert r.returncode == 0, f"docs/python.md python block {k + 1}:\n{code}\n{r.stdout}{r.stderr}"
    expected = ["aligned_fraction", "t = ", "contacts", "aligned_fraction"][k]
    assert expected in r.stdout, r.stdout

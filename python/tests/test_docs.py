"""docs/python.md stays true: its training example runs (with a smaller count) and its API
reference is what scripts/python_api_docs.py generates from the docstrings."""
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
DOC = os.path.join(ROOT, "docs", "python.md")


def section(title):
    text = open(DOC).read()
    start = text.index("## " + title)
    end = text.find("\n## ", start + 3)
    return text[start:end if end >= 0 else len(text)]


def test_training_example_runs():
    pytest.importorskip("torch")
    code = re.search(r"```python\n(.*?)```", section("Training in ten lines"), re.S).group(1)
    assert '"count": 2000' in code
    lines = code.strip().splitlines()
    assert len(lines) <= 12 and max(map(len, lines)) <= 100, (len(lines), max(map(len, lines)))
    code = code.replace('"count": 2000', '"count": 16')
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=os.environ, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "psnr" in out.stdout and "tensor" in out.stdout


def test_api_reference_is_generated_from_the_docstrings():
    sys.path.insert(0, os.path.join(ROOT, "python", "tools"))
    try:
        import api_docs
    finally:
        sys.path.pop(0)
    text = open(DOC).read()
    new = api_docs.updated(text)
    if new != text and os.environ.get("TURBID_UPDATE_DOCS") == "1":
        with open(DOC, "w") as f:
            f.write(new)
        text = new
    assert new == text, ("docs/python.md: the API reference is out of date; run "
                         "PYTHONPATH=build/python python3 python/tools/api_docs.py")
    for name in ("turbid.score(image, ref=None", "domain='srgb8'", "class turbid.data.RenderDataset",
                 "turbid.data.RenderDataset.set_epoch(epoch)", "turbid.srgb_encode"):
        assert name in text, name

import os
import shutil

import pytest


@pytest.fixture(scope="session")
def cli():
    """The `turbid` executable built beside the package (CTest passes TURBID_CLI)."""
    path = os.environ.get("TURBID_CLI") or shutil.which("turbid")
    if not path or not os.path.exists(path):
        pytest.skip("TURBID_CLI is not set and no turbid on PATH: CLI comparisons skipped")
    return path

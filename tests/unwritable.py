"""The ``unwritable_folder`` fixture: a folder in which no file can be created, also for root
(chattr +i; root ignores permission bits), else with chmod 555. Import it into a test module:
``from unwritable import unwritable_folder  # noqa: F401``."""

import os
import subprocess

import pytest


@pytest.fixture
def unwritable_folder(tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir()
    if os.geteuid() == 0:
        if subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode != 0:
            pytest.skip("cannot make a folder unwritable for root here (no chattr +i)")
        try:
            yield folder
        finally:
            subprocess.run(["chattr", "-i", str(folder)], check=True)
    else:
        folder.chmod(0o555)
        try:
            yield folder
        finally:
            folder.chmod(0o755)

"""scripts/*.py import the cacas of their own checkout, not an installed one (persona_table.py's
way: the checkout first on sys.path), also when run from another folder with another cacas on
PYTHONPATH. profile_study_quality.py is the exception by design: it imports the SOURCE_TREE it
is given (a before/after comparison of two trees). results_table.py and accuracy_by_preference.py
import no cacas at all (pandas only)."""

import re
import subprocess
import sys

import pytest

from cacas.paths import PROJECT_ROOT

USES_CACAS = re.compile(r"^\s*(from cacas[. ]|import cacas\b)", re.M)
SCRIPTS = sorted(p for p in (PROJECT_ROOT / "scripts").glob("*.py")
                 if USES_CACAS.search(p.read_text()) and p.name != "profile_study_quality.py")
PROBE = r"""
import runpy, sys
runpy.run_path(sys.argv[1], run_name="not_main")  # the module's top level, not its main()
import cacas
print(cacas.__file__)
"""


def test_the_scripts_that_use_cacas_are_found():
    names = {p.name for p in SCRIPTS}
    assert {"persona_table.py", "bench_store.py", "bench_recognition.py", "profile_adapt.py",
            "sound_library_overview.py"} <= names
    assert "results_table.py" not in names and "accuracy_by_preference.py" not in names


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_a_script_imports_its_own_checkouts_cacas(script, tmp_path):
    other = tmp_path / "other" / "cacas"
    other.mkdir(parents=True)
    (other / "__init__.py").write_text("OTHER = True\n")
    (other / "spaces.py").write_text("raise ImportError('the other cacas was imported')\n")
    proc = subprocess.run([sys.executable, "-c", PROBE, str(script)], cwd=tmp_path, capture_output=True,
                          text=True, env={"PYTHONPATH": str(tmp_path / "other"), "PATH": "/usr/bin:/bin"},
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip().splitlines()[-1] == str(PROJECT_ROOT / "cacas" / "__init__.py")

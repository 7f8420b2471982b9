"""A script of scripts/ loaded as a module, for the tests of its functions (scripts are not a package)."""

import importlib.util

from cacas.paths import PROJECT_ROOT


def load_script(name: str):
    """scripts/<name>.py as a module (its ``if __name__ == "__main__"`` part not run)."""
    spec = importlib.util.spec_from_file_location(name, PROJECT_ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module

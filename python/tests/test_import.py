"""Importing the package from a checkout's python/ folder while another copy (the wheel, or the build's) is
installed: the source folder has no compiled module, and the import must say so plainly, not fail with a bare
ModuleNotFoundError for mlsdeform._mlsdeform."""
import glob
import os
import subprocess
import sys

import pytest

import mlsdeform

SOURCE = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def test_import_from_the_checkouts_python_folder_says_why_it_fails():
    package = os.path.join(SOURCE, "mlsdeform")
    if not os.path.isfile(os.path.join(package, "__init__.py")):
        pytest.skip("the tests do not run from a checkout (no python/mlsdeform beside them)")
    if glob.glob(os.path.join(package, "_mlsdeform*")):
        pytest.skip("the checkout's python/mlsdeform holds a compiled module (built in place)")
    installed = os.path.dirname(os.path.dirname(os.path.abspath(mlsdeform.__file__)))
    assert installed != SOURCE
    # As a user would: `python -c "import mlsdeform"` in the checkout's python/ folder (first on sys.path), with
    # the installed package further down.
    env = dict(os.environ, PYTHONPATH=installed)
    run = subprocess.run(
        [sys.executable, "-c", "import mlsdeform"], cwd=SOURCE, env=env, capture_output=True, text=True
    )
    assert run.returncode != 0
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: mlsdeform: the compiled module _mlsdeform is not in " + package), last
    assert installed in last and "run from another folder" in last, last


def test_numpy_2_with_an_old_pybind11_is_refused_at_import():
    """A build whose pybind11 predates numpy 2 (Debian 12's 2.10) refuses numpy 2 with a clear ImportError;
    numpy 1 with it, and numpy 2 with pybind11 2.12 or newer, import."""
    import mlsdeform

    with pytest.raises(ImportError, match=r"pybind11 2\.10.*numpy 2\.2\.4.*numpy<2"):
        mlsdeform._check_numpy("2.2.4", (2, 10))
    mlsdeform._check_numpy("1.24.2", (2, 10))
    mlsdeform._check_numpy("2.2.4", (2, 13))
    mlsdeform._check_numpy("2.0.0rc1", (2, 12))

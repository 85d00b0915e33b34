"""The PEP 517 build backend of the Python package (pyproject.toml): setuptools, whose setup.py drives CMake.

Everything is setuptools' own backend except the build requirements of a wheel: CMake from PyPI is added only
where no CMake >= 3.20 is on PATH. An offline build (pip --no-build-isolation, python3 -m build --no-isolation)
uses Debian's cmake; an isolated build on a machine without one gets it from the index.
"""
import re
import shutil
import subprocess

from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # noqa: F401,F403 - the backend's hooks, all but those defined below

CMAKE_MINIMUM = (3, 20)  # CMakeLists.txt's cmake_minimum_required


def _cmake_requirement():
    cmake = shutil.which("cmake")
    if cmake:
        try:
            out = subprocess.run([cmake, "--version"], capture_output=True, text=True, check=True).stdout
        except (OSError, subprocess.CalledProcessError):
            out = ""
        m = re.search(r"version (\d+)\.(\d+)", out)
        if m and (int(m.group(1)), int(m.group(2))) >= CMAKE_MINIMUM:
            return []
    return ["cmake>=%d.%d" % CMAKE_MINIMUM]


def get_requires_for_build_wheel(config_settings=None):
    return _setuptools.get_requires_for_build_wheel(config_settings) + _cmake_requirement()


def get_requires_for_build_editable(config_settings=None):
    return _setuptools.get_requires_for_build_editable(config_settings) + _cmake_requirement()

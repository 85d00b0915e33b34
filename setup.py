"""The Python package's build (pyproject.toml names this backend): setuptools packages what CMake builds.

CMake builds two targets, the compiled module `_mlsdeform` (linked statically against the library) and the
`mlsdeform` program; setuptools puts the module into the package `mlsdeform` (python/mlsdeform/) and the
program into the wheel's scripts, so that pip installs it into the environment's bin/ as it is (an ELF
executable, never rewritten), with its bundled meshes in <prefix>/share/mlsdeform/data.

Where CMake builds:
- MLSDEFORM_BUILD_DIR unset: build-wheel/ in the source tree, configured by this file (Release, no tests, no
  benchmarks, CHOLMOD only with MLSDEFORM_CHOLMOD=ON) and kept, so that the next build is incremental.
- MLSDEFORM_BUILD_DIR=<dir> of an existing CMake build (for example the project's own build/): used as it is
  configured, only the two targets are built (CI packages the build it has just tested this way). Its
  MLSDEFORM_CHOLMOD decides the licence.
The licence in the metadata follows what is linked: MIT, or GPL-2.0-or-later when CHOLMOD (GPL-2+) is.
MLSDEFORM_WHEEL_PROGRAM=OFF leaves the program and its meshes out (the Blender extension's wheel: Blender unpacks
a wheel as it is into its site-packages, where a program has no use).

An editable install (pip install -e .) links python/mlsdeform/_mlsdeform*.so to the module in the CMake build
directory: rebuilding there (cmake --build <dir> --target _mlsdeform) is what the next `import mlsdeform` loads.
"""
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

from distutils.command.build_scripts import build_scripts  # setuptools' own copy of distutils

ROOT = Path(__file__).resolve().parent
ON = {"1", "ON", "TRUE", "YES", "Y"}


def version():
    """The project's one version: CMakeLists.txt's project(mlsdeform VERSION x.y.z)."""
    text = (ROOT / "CMakeLists.txt").read_text()
    m = re.search(r"project\(\s*mlsdeform\s+VERSION\s+([0-9]+(?:\.[0-9]+)*)", text)
    if not m:
        sys.exit("setup.py: no `project(mlsdeform VERSION x.y.z ...)` in CMakeLists.txt")
    return m.group(1)


def cmake_cache(build_dir):
    """The CMake cache of build_dir as a dict (empty if it is not configured)."""
    values = {}
    try:
        lines = (build_dir / "CMakeCache.txt").read_text().splitlines()
    except OSError:
        return values
    for line in lines:
        m = re.match(r"^([A-Za-z_0-9]+):[A-Z_]+=(.*)$", line)
        if m:
            values[m.group(1)] = m.group(2)
    return values


class Build:
    """What CMake builds, and where: resolved once per process (metadata, module and program agree)."""

    def __init__(self):
        given = os.environ.get("MLSDEFORM_BUILD_DIR")
        self.dir = Path(given).resolve() if given else ROOT / "build-wheel"
        self.reuse = bool(given) and (self.dir / "CMakeCache.txt").exists()
        wanted = os.environ.get("MLSDEFORM_CHOLMOD")
        self.program = os.environ.get("MLSDEFORM_WHEEL_PROGRAM", "ON").upper() in ON
        if self.reuse:
            cache = cmake_cache(self.dir)
            self.cholmod = cache.get("MLSDEFORM_CHOLMOD", "OFF").upper() in ON
            problems = []
            if cache.get("MLSDEFORM_BUILD_PYTHON", "OFF").upper() not in ON:
                problems.append("MLSDEFORM_BUILD_PYTHON is not ON")
            if self.program and cache.get("MLSDEFORM_BUILD_TOOLS", "OFF").upper() not in ON:
                problems.append("MLSDEFORM_BUILD_TOOLS is not ON (the wheel ships the mlsdeform program)")
            if cache.get("MLSDEFORM_SANITIZE", "OFF").upper() in ON:
                problems.append("it is a sanitizer build")
            if wanted is not None and (wanted.upper() in ON) != self.cholmod:
                problems.append(
                    f"MLSDEFORM_CHOLMOD={wanted} asked for, but the build has "
                    f"MLSDEFORM_CHOLMOD={cache.get('MLSDEFORM_CHOLMOD', 'OFF')}"
                )
            if problems:
                sys.exit(f"setup.py: MLSDEFORM_BUILD_DIR={self.dir} cannot be packaged: " + "; ".join(problems))
        else:
            self.cholmod = (wanted or "OFF").upper() in ON
        self._built = None

    def license(self):
        return "GPL-2.0-or-later" if self.cholmod else "MIT"

    def license_classifier(self):
        if self.cholmod:
            return "License :: OSI Approved :: GNU General Public License v2 or later (GPLv2+)"
        return "License :: OSI Approved :: MIT License"

    def _configure(self):
        args = [
            "cmake",
            "-S",
            str(ROOT),
            "-B",
            str(self.dir),
            "-DCMAKE_BUILD_TYPE=Release",
            "-DMLSDEFORM_BUILD_PYTHON=ON",
            "-DMLSDEFORM_BUILD_TOOLS=ON",
            "-DMLSDEFORM_BUILD_TESTS=OFF",
            "-DMLSDEFORM_BUILD_BENCH=OFF",
            f"-DMLSDEFORM_CHOLMOD={'ON' if self.cholmod else 'OFF'}",
            f"-DPython3_EXECUTABLE={sys.executable}",
        ]
        try:  # pybind11 from the build environment (PyPI's in an isolated build); else CMake finds Debian's
            import pybind11

            args.append(f"-Dpybind11_DIR={pybind11.get_cmake_dir()}")
        except ImportError:
            pass
        subprocess.run(args, check=True)

    def build(self):
        """Builds the module and (unless left out) the program; returns (module, program or None)."""
        if self._built:
            return self._built
        if not self.reuse:
            self._configure()
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        targets = ["_mlsdeform"] + (["mlsdeform"] if self.program else [])
        subprocess.run(["cmake", "--build", str(self.dir), "--parallel", jobs, "--target", *targets], check=True)
        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        modules = sorted((self.dir / "python" / "mlsdeform").glob("_mlsdeform*.so"))
        module = next((m for m in modules if m.name == "_mlsdeform" + suffix), None)
        if module is None:
            sys.exit(
                f"setup.py: no _mlsdeform{suffix} for this Python ({sys.executable}) in {self.dir}/python/"
                f"mlsdeform (found: {[m.name for m in modules]}): that build was configured for another "
                "Python; configure it with -DPython3_EXECUTABLE=<this python>"
            )
        program = self.dir / "tools" / "mlsdeform" if self.program else None
        if program is not None and not program.exists():
            sys.exit(f"setup.py: the mlsdeform program was not built ({program})")
        self._built = (module, program)
        return self._built


BUILD = Build()


def copy_stripped(src, dest):
    """A copy without the symbol tables (a third of the size); the build tree keeps them."""
    dest = Path(dest)
    dest.parent.mkdir(parents=True, exist_ok=True)
    if dest.is_symlink() or dest.exists():
        dest.unlink()
    strip = shutil.which("strip")
    if strip:
        subprocess.run([strip, "--strip-unneeded", "-o", str(dest), str(src)], check=True)
    else:
        shutil.copyfile(src, dest)
    shutil.copymode(src, dest)


class CMakeBuildExt(build_ext):
    def build_extension(self, ext):
        module, _ = BUILD.build()
        copy_stripped(module, self.get_ext_fullpath(ext.name))

    def copy_extensions_to_source(self):
        # Editable: a link, not a copy, so that a rebuild in the CMake build directory is picked up.
        module, _ = BUILD.build()
        build_py = self.get_finalized_command("build_py")
        for ext in self.extensions:
            package = ".".join(ext.name.split(".")[:-1])
            target = Path(build_py.get_package_dir(package)) / os.path.basename(self.get_ext_filename(ext.name))
            if target.is_symlink() or target.exists():
                target.unlink()
            target.symlink_to(module)


class BuildProgram(build_scripts):
    """The `mlsdeform` program as the wheel's one script, copied as it is (it is no Python script)."""

    def get_source_files(self):
        return []  # built, not a source file: nothing for the sdist

    def run(self):
        _, program = BUILD.build()
        dest = Path(self.build_dir) / "mlsdeform"
        copy_stripped(program, dest)
        dest.chmod(0o755)


CLASSIFIERS = [
    "Development Status :: 4 - Beta",
    "Intended Audience :: Science/Research",
    "Operating System :: POSIX :: Linux",
    "Programming Language :: C++",
    "Programming Language :: Python :: 3",
    "Programming Language :: Python :: Implementation :: CPython",
    "Topic :: Multimedia :: Graphics :: 3D Modeling",
    "Topic :: Scientific/Engineering :: Mathematics",
]

setup(
    version=version(),
    license=BUILD.license(),
    classifiers=CLASSIFIERS + [BUILD.license_classifier()],
    packages=["mlsdeform"],
    package_dir={"mlsdeform": "python/mlsdeform"},
    package_data={"mlsdeform": ["*.pyi", "py.typed"]},
    ext_modules=[Extension("mlsdeform._mlsdeform", sources=[])],
    scripts=["mlsdeform"] if BUILD.program else [],  # built by BuildProgram
    data_files=[("share/mlsdeform/data", ["data/human_man.obj", "data/human_bend.json", "data/LICENSES.txt"])]
    if BUILD.program
    else [],
    cmdclass={"build_ext": CMakeBuildExt, "build_scripts": BuildProgram},
    zip_safe=False,
    # setuptools' own build folders beside CMake's, not in the project's build/
    options={"build": {"build_base": str(BUILD.dir / "setuptools")}},
)

"""Builds the `lec6._lec6` extension with the repository's CMake project.

Metadata is in pyproject.toml. The build configures the repository root
(the directory above this one) with -DLEC6_PYTHON=ON, builds only the
`_lec6` target (the library layers it links and the module: no CLI, tests or
benchmarks) with -O2, and copies the module into the wheel.
CMAKE_BUILD_PARALLEL_LEVEL sets the parallel jobs (default: all cores);
LEC6_CMAKE_ARGS adds CMake arguments (space-separated).
"""
import os
import re
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    return re.search(r"project\(lec6 VERSION ([0-9.]+)", text).group(1)


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = Path(self.build_temp).resolve() / "cmake"
        # -O2 as the project's own builds (GCC 12 at -O3 warns falsely in
        # <string>, and warnings are errors).
        # LEC6_CMAKE_ARGS (space-separated) come last: e.g. the packaging test
        # builds at -O0, to check the install quickly (python/tests/pip_install_test.sh).
        extra = os.environ.get("LEC6_CMAKE_ARGS", "").split()
        subprocess.run(["cmake", "-S", str(ROOT), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                        "-DCMAKE_CXX_FLAGS_RELEASE=-O2 -DNDEBUG",
                        "-DLEC6_PYTHON=ON", "-DLEC6_BENCH=OFF", "-DLEC6_FUZZ=OFF",
                        "-DLEC6_SANITIZE=OFF", "-DLEC6_WEB=OFF", "-DLEC6_TESTS=OFF",
                        "-DLEC6_WERROR=OFF", f"-DPython_EXECUTABLE={sys.executable}", *extra],
                       check=True)
        env = dict(os.environ)
        env.setdefault("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 1))
        subprocess.run(["cmake", "--build", str(build), "--target", "_lec6"], check=True, env=env)
        built = sorted((build / "python" / "lec6").glob("_lec6*.so"))
        if not built:
            raise RuntimeError(f"the build left no _lec6 module in {build / 'python' / 'lec6'}")
        dest = Path(self.get_ext_fullpath(ext.name))
        dest.parent.mkdir(parents=True, exist_ok=True)
        self.copy_file(str(built[0]), str(dest))


setup(version=project_version(), ext_modules=[CMakeExtension("lec6._lec6")],
      cmdclass={"build_ext": CMakeBuild})

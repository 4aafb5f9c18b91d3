"""turbid's PEP 517 build backend: `pip install .` and `python3 -m build` from a checkout.

Standard library only (the build needs nothing from PyPI: offline, with Debian's python3-pip /
python3-build). It drives the project's CMake build (the extension module turbid._turbid and the
two plugins it loads on demand) and packs the result into a wheel by hand (docs/python.md,
"Installing").

Where it builds (config settings go through `pip --config-settings KEY=VALUE` or
`python3 -m build -C KEY=VALUE`):
  build-dir   a CMake build folder. One that is already configured (CMakeCache.txt) is only
              built, never re-configured: point it at your own build/ to pack what you built (the
              test suite does). Otherwise it is configured as a Release build of the Python
              package alone. Default: $TURBID_WHEEL_BUILD_DIR, else build-wheel/ in the source
              tree (kept, so a second `pip install .` rebuilds only what changed).
  jobs        parallel compile jobs (default: $CMAKE_BUILD_PARALLEL_LEVEL, else every core).
The compiler launcher (ccache) is taken from $CMAKE_CXX_COMPILER_LAUNCHER as CMake does.
"""

import base64
import hashlib
import io
import os
import re
import subprocess
import sys
import sysconfig
import tarfile
import time
import zipfile

NAME = "turbid"
SOURCE_DIR = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SUMMARY = "Underwater image degradation: simulator, enhancement methods, metrics and sweeps"
# Plugins the extension loads with dlopen from its own folder (scenes/plugin_loader.cc).
PLUGINS = ("turbid_oiio.so", "turbid_hdf5.so")


def _version():
    """The version CMake builds (project(turbid VERSION x.y.z)): one number for both."""
    with open(os.path.join(SOURCE_DIR, "CMakeLists.txt"), encoding="utf-8") as f:
        match = re.search(r"project\(\s*turbid\s+VERSION\s+([0-9.]+)", f.read())
    if not match:
        raise RuntimeError("turbid_build: no 'project(turbid VERSION x.y.z)' in CMakeLists.txt")
    return match.group(1)


def _setting(config_settings, key, env, default):
    value = (config_settings or {}).get(key)
    if value:
        return value if isinstance(value, str) else value[-1]
    return os.environ.get(env) or default


def _metadata():
    return "\n".join([
        "Metadata-Version: 2.1",
        f"Name: {NAME}",
        f"Version: {_version()}",
        f"Summary: {SUMMARY}",
        "Requires-Python: >=3.9",
        "Requires-Dist: numpy",
        "Provides-Extra: torch",
        "Requires-Dist: torch; extra == \"torch\"",
        "",
    ])


def _wheel_tag():
    """cpXY-cpXY-<platform>: the extension is built for this interpreter and machine."""
    impl = f"cp{sys.version_info.major}{sys.version_info.minor}"
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{impl}-{impl}-{platform}"


def _run(command, **kwargs):
    print("turbid_build: " + " ".join(command), file=sys.stderr, flush=True)
    subprocess.run(command, check=True, **kwargs)


def _build(config_settings):
    """Builds the extension and plugins; returns {path in the wheel: file on disk}."""
    build_dir = os.path.abspath(_setting(config_settings, "build-dir", "TURBID_WHEEL_BUILD_DIR",
                                         os.path.join(SOURCE_DIR, "build-wheel")))
    jobs = _setting(config_settings, "jobs", "CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 1))
    if not os.path.exists(os.path.join(build_dir, "CMakeCache.txt")):
        _run(["cmake", "-S", SOURCE_DIR, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
              "-DTURBID_BUILD_TESTS=OFF", "-DTURBID_BUILD_PYTHON=ON",
              f"-DPython_EXECUTABLE={sys.executable}"])
    _run(["cmake", "--build", build_dir, "-j", jobs, "--target", "turbid_python", "turbid_oiio",
          "turbid_hdf5"])
    package = os.path.join(build_dir, "python", NAME)
    if not os.path.isdir(package):
        raise RuntimeError(f"turbid_build: {build_dir} built no Python package ({package}); "
                           "is python3-pybind11 installed?")
    files = {}
    for name in sorted(os.listdir(package)):
        if name.endswith((".py", ".pyi", ".so")) or name == "py.typed":
            files[f"{NAME}/{name}"] = os.path.join(package, name)
    if not any(k.startswith(f"{NAME}/_turbid") for k in files):
        raise RuntimeError(f"turbid_build: no extension module _turbid*.so in {package}")
    for plugin in PLUGINS:
        path = os.path.join(build_dir, plugin)
        if not os.path.exists(path):
            raise RuntimeError(f"turbid_build: plugin {path} was not built")
        files[f"{NAME}/{plugin}"] = path
    return files


def _record_line(name, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def _zip_info(name, mode):
    # A fixed time stamp: the same build gives the same wheel bytes.
    info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
    info.external_attr = (mode & 0xFFFF) << 16
    info.compress_type = zipfile.ZIP_DEFLATED
    return info


def _dist_info_files():
    dist_info = f"{NAME}-{_version()}.dist-info"
    wheel = "\n".join(["Wheel-Version: 1.0", "Generator: turbid_build", "Root-Is-Purelib: false",
                       f"Tag: {_wheel_tag()}", ""])
    return dist_info, {
        f"{dist_info}/METADATA": _metadata().encode(),
        f"{dist_info}/WHEEL": wheel.encode(),
        f"{dist_info}/top_level.txt": f"{NAME}\n".encode(),
    }


# --- PEP 517 hooks -------------------------------------------------------------------------------

def get_requires_for_build_wheel(config_settings=None):
    return []


def get_requires_for_build_sdist(config_settings=None):
    return []


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    dist_info, files = _dist_info_files()
    for name, data in files.items():
        path = os.path.join(metadata_directory, name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            f.write(data)
    return dist_info


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    files = _build(config_settings)
    dist_info, meta = _dist_info_files()
    wheel_name = f"{NAME}-{_version()}-{_wheel_tag()}.whl"
    os.makedirs(wheel_directory, exist_ok=True)
    target = os.path.join(wheel_directory, wheel_name)
    temporary = target + ".tmp"
    record = []
    with zipfile.ZipFile(temporary, "w") as wheel:
        for name, path in files.items():
            with open(path, "rb") as f:
                data = f.read()
            mode = 0o755 if name.endswith(".so") else 0o644
            wheel.writestr(_zip_info(name, mode), data)
            record.append(_record_line(name, data))
        for name, data in meta.items():
            wheel.writestr(_zip_info(name, 0o644), data)
            record.append(_record_line(name, data))
        record.append(f"{dist_info}/RECORD,,")
        wheel.writestr(_zip_info(f"{dist_info}/RECORD", 0o644), "\n".join(record) + "\n")
    os.replace(temporary, target)
    return wheel_name


def _source_files():
    """The files of the source tree: git's tracked files when it is a checkout, else every file
    outside build folders."""
    try:
        out = subprocess.run(["git", "-C", SOURCE_DIR, "ls-files", "-z"], check=True,
                             capture_output=True).stdout
        return [p for p in out.decode().split("\0") if p and os.path.isfile(os.path.join(SOURCE_DIR, p))]
    except (OSError, subprocess.CalledProcessError):
        paths = []
        for root, dirs, names in os.walk(SOURCE_DIR):
            dirs[:] = sorted(d for d in dirs if not d.startswith(("build", ".", "out")))
            rel = os.path.relpath(root, SOURCE_DIR)
            paths += [os.path.normpath(os.path.join(rel, n)) for n in sorted(names)]
        return paths


def build_sdist(sdist_directory, config_settings=None):
    base = f"{NAME}-{_version()}"
    os.makedirs(sdist_directory, exist_ok=True)
    target = os.path.join(sdist_directory, base + ".tar.gz")
    stamp = int(os.environ.get("SOURCE_DATE_EPOCH", time.time()))
    with tarfile.open(target, "w:gz", format=tarfile.PAX_FORMAT) as tar:
        for path in _source_files():
            tar.add(os.path.join(SOURCE_DIR, path), arcname=f"{base}/{path}", recursive=False)
        info = tarfile.TarInfo(f"{base}/PKG-INFO")
        data = _metadata().encode()
        info.size = len(data)
        info.mtime = stamp
        tar.addfile(info, io.BytesIO(data))
    return base + ".tar.gz"

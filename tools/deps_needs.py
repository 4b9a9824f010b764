"""What the build and the tests use from the machine, as files to map to Debian
packages (tools/check-deps maps them with `dpkg -S`):

- Python modules: every module loaded when the imports of the Python code in
  tests/, bench/, tools/, fuzz/, python/, examples/ (files, heredocs and
  `python3 -c` in scripts) run on /usr/bin/python3, not only the imports we
  write (pymodbus.client loads serial_asyncio);
- programs: the command words of the shell scripts there (tools/deps_shell.py)
  and of the command lines C++ tests run (popen/system/run("..."));
  the programs Python starts with subprocess, and INDIRECT below;
- CMake: every FILEPATH/PATH entry of the configured CMakeCache.txt files
  (the packages' config files for *_DIR), pkg-config modules' .pc files;
- headers: every #include <...> of the sources, on the compiler's search path;
- compiler runtimes: the sanitizer and libFuzzer libraries of the build modes
  the Makefile configures.
"""

import ast
import json
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import deps_shell

ROOT = Path(__file__).resolve().parent.parent
PY = "/usr/bin/python3"
DEBIAN_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"
SCRIPT_DIRS = ("tests", "bench", "tools", "fuzz", "python", "examples", ".ci")
SOURCE_DIRS = ("src", "include", "tests", "bench", "fuzz", "python", "examples")
# Programs started in ways the scan cannot see, and who starts them.
INDIRECT = {
    "bash": "ctest runs tests/integration/*_test.sh with bash (tests/CMakeLists.txt)",
    "cmake": "the Makefile configures and builds",
    "ctest": "the Makefile runs the tests",
    "make": "the README's commands",
    "ninja": "the Makefile configures its trees with -G Ninja (GENERATOR)",
}
_SUBPROCESS = {"run", "Popen", "call", "check_call", "check_output", "execvp", "execv"}


@dataclass
class Need:
    what: str  # "module serial_asyncio", "program mbpoll", ...
    where: str  # who needs it
    files: list = field(default_factory=list)  # any of them, owned by a package in the closure
    problem: str = ""  # set when there is nothing to map (not installed, ...)
    entry: object = None  # the list entry it must come from ([py:]/[bin:] annotations)


def _rel(path):
    try:
        return str(Path(path).resolve().relative_to(ROOT))
    except ValueError:
        return str(path)


def _files(dirs, match):
    for d in dirs:
        base = ROOT / d
        if base.is_dir():
            for p in sorted(base.rglob("*")):
                if p.is_file() and "__pycache__" not in p.parts and match(p):
                    yield p


def _shebang(p):
    try:
        with open(p, "rb") as f:
            head = f.readline(200)
    except OSError:
        return ""
    return head.decode(errors="replace") if head.startswith(b"#!") else ""


def python_files():
    return list(_files(SCRIPT_DIRS, lambda p: p.suffix == ".py" or (not p.suffix and "python" in _shebang(p))))


def shell_files():
    return list(_files(SCRIPT_DIRS, lambda p: p.suffix in (".sh", ".bash") or
                       (not p.suffix and re.search(r"\b(ba)?sh\b", _shebang(p)))))


class _DocBlocks(type(Path())):
    """A Markdown file read as the shell of its ```sh blocks: the README test
    runs them as pasted (tests/integration/readme.py), so the programs they
    start are needs like a script's (mosquitto_sub in docs/mqtt.md was not
    listed, and a fresh machine's README test failed on it)."""

    def read_text(self, *args, **kwargs):
        out, inside = [], False
        for line in super().read_text(*args, **kwargs).splitlines():
            if not inside and line.strip() == "```sh":
                inside = True
            elif inside and line.strip() == "```":
                inside = False
            elif inside:
                out.append(line)
        return "\n".join(out) + "\n"


def doc_shell_files():
    """README.md and docs/*.md, each read as the shell of its ```sh blocks."""
    return [_DocBlocks(p) for p in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))] if p.is_file()]


# ---- Python -----------------------------------------------------------------------

def _imports(code):
    """[(module, optional)] imported by `code`; `from a import b` may import a.b."""
    try:
        tree = ast.parse(code)
    except SyntaxError:
        return [(m, False) for m in re.findall(r"(?m)^\s*(?:from\s+([\w.]+)\s+)?import\s+[\w.]+", code) if m]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, False) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.append((node.module, False))
            out += [(f"{node.module}.{a.name}", True) for a in node.names if a.name != "*"]
    return out


def _cmake_lists():
    return sorted(p for p in ROOT.rglob("CMakeLists.txt") if not p.relative_to(ROOT).parts[0].startswith(("build", ".")))


def _local_modules():
    names = {p.stem for p in ROOT.rglob("*.py") if not p.relative_to(ROOT).parts[0].startswith("build")}
    names |= {p.parent.name for p in ROOT.rglob("__init__.py")}
    for cm in _cmake_lists():
        names |= set(re.findall(r"(?:pybind11_add_module|Python_add_library|python_add_library)\(\s*(\w+)", cm.read_text()))
    return names


def python_imports(shell_texts):
    """{module: (where, optional)} over the Python code of the tree."""
    found = {}

    def add(code, where):
        for m, optional in _imports(code):
            if m not in found or (found[m][1] and not optional):
                found[m] = (where, optional)

    for p in python_files():
        add(p.read_text(errors="replace"), _rel(p))
    for path, text, heredocs in shell_texts:
        for head, body in heredocs:
            if re.search(r"python|\.py\b", head):
                add(body, f"{_rel(path)} (heredoc)")
        for a, b in re.findall(r"python3?[\w.]*\"?\s+-c\s+(?:'([^']*)'|\"((?:[^\"\\]|\\.)*)\")", text):
            add(a or b, f"{_rel(path)} (python3 -c)")
    local = _local_modules()
    return {m: v for m, v in found.items() if m.split(".")[0] not in local}


_IMPORTER = r"""
import importlib, json, sys
wanted, out = json.loads(sys.argv[1]), sys.argv[2]
errors, loaded_by = {}, {}
for name in wanted:
    before = set(sys.modules)
    try:
        importlib.import_module(name)
    except BaseException as e:
        errors[name] = [type(e).__name__, str(e), getattr(e, "name", None)]
    for m in set(sys.modules) - before:
        loaded_by[m] = name
files = {n: m.__file__ for n, m in list(sys.modules.items()) if getattr(m, "__file__", None)}
json.dump({"errors": errors, "files": files, "loaded_by": loaded_by}, open(out, "w"))
"""


def python_needs(shell_texts, declared):
    """Needs for every module the imports load; `declared` = {module: entry}."""
    if not os.access(PY, os.X_OK):
        return [Need("program python3", "every Python test and tools/check-deps", problem=f"{PY} is missing")]
    imports = python_imports(shell_texts)
    for m in declared:
        imports.setdefault(m, (f"tools/deps.txt [py: {m}]", False))
    with tempfile.NamedTemporaryFile(suffix=".json") as out:
        r = subprocess.run([PY, "-I", "-c", _IMPORTER, json.dumps(sorted(imports)), out.name],
                           capture_output=True, text=True, timeout=120, cwd="/")
        if r.returncode != 0:
            return [Need("Python imports", "tools/check-deps", problem=r.stderr.strip()[-500:])]
        result = json.load(open(out.name))
    needs, reported = [], set()
    for name, (kind, message, missing) in sorted(result["errors"].items()):
        where, optional = imports[name]
        if optional or (missing or name) in reported:
            continue  # `from a import b`: b may be a name (a itself is checked); one line per module
        reported.add(missing or name)
        needs.append(Need(f"module {missing or name}", f"`import {name}` in {where}",
                          problem=f"{PY} cannot import it: {kind}: {message}"))
    for name, file in sorted(result["files"].items()):
        top = result["loaded_by"].get(name)
        if not top:
            continue  # loaded at start-up: the stdlib, or .pth hooks of whatever is installed
        needs.append(Need(f"module {name}", f"`import {top}` in {imports[top][0]}", [file], entry=declared.get(name)))
    return needs


def file_needs(entries):
    """Needs for the data files entries declare with [file: GLOB] (what no
    import or command line shows, e.g. the wheels an offline pip install reads)."""
    needs = []
    for e in entries:
        for pattern in e.files:
            found = sorted(str(p) for p in Path("/").glob(pattern.lstrip("/")))
            need = Need(f"file {pattern}", f"tools/deps.txt line {e.line}", found, entry=e)
            if not found:
                need.problem = "not installed"
            needs.append(need)
    return needs


# ---- programs ---------------------------------------------------------------------

def _python_programs(path):
    text = path.read_text(errors="replace")
    guarded = set(re.findall(r"shutil\.which\(\s*['\"]([^'\"]+)", text))
    try:
        tree = ast.parse(text)
    except SyntaxError:
        return []
    out = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and node.args):
            continue
        f = node.func
        name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
        arg = node.args[0]
        if name in _SUBPROCESS and isinstance(arg, (ast.List, ast.Tuple)) and arg.elts:
            first = arg.elts[0]
            if isinstance(first, ast.Constant) and isinstance(first.value, str) and first.value not in guarded:
                out.append((first.value, node.lineno))
    return out


# Shell command lines in C++ tests: popen("..."), system("..."), run("... ...").
_CPP_COMMAND = re.compile(r'\b(?:popen|system|run)\s*\(\s*"((?:[^"\\]|\\.)*\s(?:[^"\\]|\\.)*)"')


def _cpp_commands():
    for p in _files(("tests", "bench", "fuzz"), lambda f: f.suffix in (".cpp", ".hpp", ".c")):
        text = p.read_text(errors="replace")
        for m in _CPP_COMMAND.finditer(text):
            yield p, text.count("\n", 0, m.start()) + 1, m.group(1).encode().decode("unicode_escape")


def _builtins():
    r = subprocess.run(["bash", "-c", "compgen -b; compgen -k"], capture_output=True, text=True)
    return set(r.stdout.split()) | {"[[", "]]", "[", "source", "."}


def program_needs(shell_texts, declared):
    """Needs for the programs the scripts start; `declared` = {program: entry}."""
    builtins = _builtins()
    functions, uses = set(), {}
    for path, text, _ in shell_texts:
        functions |= deps_shell.functions(text) | deps_shell.functions(path.read_text(errors="replace"))
    for path, text, _ in shell_texts:
        variables = deps_shell.path_variables(path.read_text(errors="replace"))
        for word in deps_shell.command_words(text):
            m = re.match(r"^\$\{?(\w+)\}?$", word)
            if m and m.group(1) in variables:
                word = variables[m.group(1)]
            elif word in builtins or word in functions or not re.match(r"^[\w/][\w.+/-]*$", word):
                continue
            uses.setdefault(word, _rel(path))
    for p in python_files():
        for word, line in _python_programs(p):
            uses.setdefault(word, f"{_rel(p)}:{line}")
    for p, line, command in _cpp_commands():
        for word in deps_shell.command_words(command):
            if word not in builtins and re.match(r"^[\w/][\w.+/-]*$", word):
                uses.setdefault(word, f"{_rel(p)}:{line}")
    for word, why in INDIRECT.items():
        uses.setdefault(word, why)
    for word in declared:
        uses.setdefault(word, f"tools/deps.txt [bin: {word}]")
    needs = []
    for word, where in sorted(uses.items()):
        if word == "python3" and not where.startswith("tools/deps.txt"):
            needs.append(Need("program python3", where, problem=f"call {PY} by its path: `python3` on "
                              "PATH may be another interpreter (pyenv) that cannot see Debian's python3-* packages"))
            continue
        if "/" in word:
            if not word.startswith("/"):
                continue  # a script of the tree, run by its relative path
            path = word if os.access(word, os.X_OK) else None
        else:
            path = shutil.which(word, path=DEBIAN_PATH)
        need = Need(f"program {word}", where, entry=declared.get(word))
        if path:
            need.files = [path]
        else:
            need.problem = "not installed (not on a Debian PATH)"
        needs.append(need)
    return needs


# ---- CMake, headers, compiler runtimes -------------------------------------------------

def read_cache(path):
    entries = {}
    for line in Path(path).read_text(errors="replace").splitlines():
        m = re.match(r"^([^#/][^:=]*):(\w+)=(.*)$", line)
        if m:
            entries[m.group(1)] = (m.group(2), m.group(3))
    return entries


def outside(p, *dirs):
    return not any(str(p).startswith(str(d) + "/") or str(p) == str(d) for d in dirs)


# Tools CMake takes from whatever is installed (llvm-ar when llvm is there,
# binutils' ar otherwise): the build works with either, and the compilers'
# hard Depends bring a working set (binutils), so they are not needs.
_OPPORTUNISTIC = re.compile(r"^CMAKE_((\w+_COMPILER_)?(AR|RANLIB)|ADDR2LINE|DLLTOOL|LINKER|NM|OBJCOPY|OBJDUMP|"
                            r"READELF|STRIP|TAPI|MT)$")


def cmake_needs(cache_path):
    """(needs, include dirs) of one configured build."""
    cache = read_cache(cache_path)
    build = Path(cache_path).resolve().parent
    needs, include_dirs = [], []
    for key, (kind, value) in sorted(cache.items()):
        if key.endswith("_INCLUDE_DIRS") and kind == "INTERNAL":
            include_dirs += [d for d in value.split(";") if d]
        if not (kind in ("FILEPATH", "PATH") or key in ("CMAKE_COMMAND", "CMAKE_CTEST_COMMAND")):
            continue
        if key.startswith("CMAKE_INSTALL") or not value.startswith("/") or _OPPORTUNISTIC.match(key):
            continue
        p = Path(value)
        if not p.exists() or not outside(p.resolve(), ROOT, build):
            continue
        files = [str(p)]
        if p.is_dir():
            files = [str(c) for c in sorted(p.glob("*onfig.cmake"))] or files
        needs.append(Need(f"CMake {key}", _rel(cache_path), files))
    # Python's headers (Development.Module): pybind11 includes Python.h, which
    # no source of ours names.
    kind, value = cache.get("_Python_INCLUDE_DIR", ("", ""))
    if value and (Path(value) / "Python.h").exists():
        needs.append(Need("header <Python.h>", _rel(cache_path), [str(Path(value) / "Python.h")]))
    return needs, include_dirs


def pkg_config_needs():
    """(needs, include dirs) of the pkg-config modules the CMakeLists.txt files ask for."""
    needs, include_dirs = [], []
    for cm in _cmake_lists():
        for args in re.findall(r"pkg_(?:check|search)_modules\(([^)]*)\)", cm.read_text()):
            for arg in args.split()[1:]:
                if arg.isupper():
                    continue  # REQUIRED, IMPORTED_TARGET, ...
                module = re.split(r"[<>=]", arg)[0]
                need = Need(f"pkg-config module {module}", _rel(cm))
                r = subprocess.run(["pkg-config", "--path", module], capture_output=True, text=True)
                if r.returncode == 0 and r.stdout.strip():
                    need.files = [r.stdout.strip()]
                    flags = subprocess.run(["pkg-config", "--cflags-only-I", module], capture_output=True, text=True)
                    include_dirs += [f[2:] for f in flags.stdout.split() if f.startswith("-I")]
                else:
                    need.problem = "pkg-config does not find it"
                needs.append(need)
    return needs, include_dirs


def _search_dirs(compiler):
    r = subprocess.run([compiler, "-E", "-x", "c++", "-", "-v"], input="", capture_output=True, text=True)
    text = r.stderr.split("#include <...> search starts here:")[-1].split("End of search list.")[0]
    return [line.strip() for line in text.splitlines() if line.strip()]


def header_needs(compiler, include_dirs):
    dirs = [ROOT / "include", ROOT / "src"] + [Path(d) for d in _search_dirs(compiler) + include_dirs]
    seen, needs = {}, []
    for src in _files(SOURCE_DIRS, lambda p: p.suffix in (".c", ".cc", ".cpp", ".h", ".hpp")):
        for header in re.findall(r"(?m)^\s*#\s*include\s*<([^>]+)>", src.read_text(errors="replace")):
            seen.setdefault(header, _rel(src))
    for header, where in sorted(seen.items()):
        found = next((d / header for d in dirs if (d / header).exists()), None)
        if found and not outside(found.resolve(), ROOT):
            continue
        need = Need(f"header <{header}>", where)
        if found:
            need.files = [str(found)]
        else:
            need.problem = "not found on the compiler's include path"
        needs.append(need)
    return needs


def runtime_needs():
    """The compilers of the Makefile's build modes, and their sanitizer and
    libFuzzer runtimes (clang's are a separate package in Debian)."""
    needs = []
    for line in (ROOT / "Makefile").read_text().splitlines():
        if "cmake -S" not in line:
            continue
        m = re.search(r"\bCXX=(\S+)", line)
        compiler = m.group(1) if m else "c++"
        flags = []
        if "-DLEC6_SANITIZE=ON" in line or "-DLEC6_FUZZ=ON" in line:
            flags.append("-fsanitize=address,undefined")
        if "-DLEC6_FUZZ=ON" in line:
            flags.append("-fsanitize=fuzzer")
        where = f"Makefile: {' '.join([compiler] + flags)}"
        path = shutil.which(compiler, path=DEBIAN_PATH)
        if not path:
            needs.append(Need(f"program {compiler}", where, problem="not installed"))
            continue
        needs.append(Need(f"program {compiler}", where, [path]))
        if not flags:
            continue
        r = subprocess.run([path, *flags, "-x", "c++", "/dev/null", "-o", "/dev/null", "-###"],
                           capture_output=True, text=True)
        libs = set(re.findall(r"(/[^\s\"]*lib(?:clang_rt\.[\w.-]+|asan\w*|ubsan\w*)\.(?:a|so|o))(?=[\s\"])", r.stderr))
        for lib in ("libasan.so", "libubsan.so"):
            p = subprocess.run([path, f"-print-file-name={lib}"], capture_output=True, text=True).stdout.strip()
            if p.startswith("/"):
                libs.add(p)
        for lib in sorted(libs):
            need = Need(f"runtime {Path(lib).name}", where, [lib])
            if not Path(lib).exists():
                need.problem = f"{lib} is missing"
            needs.append(need)
    # A linker the Makefile asks the compilers for (-fuse-ld=lld: ld.lld; a
    # path: that file), outside comments.
    code = "\n".join(line.split("#", 1)[0] for line in (ROOT / "Makefile").read_text().splitlines())
    for linker in sorted(set(re.findall(r"-fuse-ld=([\w./+-]+)", code))):
        program = linker if linker.startswith("/") else f"ld.{linker}"
        path = program if os.access(program, os.X_OK) else shutil.which(program, path=DEBIAN_PATH)
        need = Need(f"program {program}", f"Makefile: -fuse-ld={linker}", [path] if path else [])
        if not path:
            need.problem = "not installed"
        needs.append(need)
    return needs

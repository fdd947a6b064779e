"""choreo's modules and the test modules compiled once per parallel run, by its first process.

Each xdist worker imports every test module (pytest rewrites their asserts first) and choreo's
modules, and so does each ``choreo`` process a test starts (choreo's modules). Where
PYTHONDONTWRITEBYTECODE is set (this project's development environment and CI) none of them can
keep what it compiled: each worker spent ~5 s of CPU compiling the same files. The first
process compiles them once, before xdist starts the workers, and takes the files away again at
the end of the run (the setting asks for no bytecode to be left behind); the workers and the
processes they start only read them, each checked against its source as usual (an edited file
is compiled again). With three workers: 31-33 s of CPU before the first test, now 19-20 s.
"""

from __future__ import annotations

import compileall
import fnmatch
import sys
from collections.abc import Iterable
from pathlib import Path

# pytest's own rewriting and its cache's layout: not public, but what its import hook calls
# (the same in pytest 8.0 and 9.2). A pytest without them only loses this saving.
try:
    from _pytest.assertion.rewrite import (
        PYC_TAIL,
        _rewrite_test,
        _write_pyc,
        assertstate_key,
        get_cache_dir,
    )
except ImportError:
    _rewrite_test = None


def worth_compiling(config) -> bool:
    """Whether this is the first process of a parallel run that may not write bytecode."""
    return (
        _rewrite_test is not None
        and sys.dont_write_bytecode
        and not sys.pycache_prefix  # bytecode kept elsewhere, as the user chose
        and not hasattr(config, "workerinput")
        and config.pluginmanager.get_plugin("dsession") is not None  # xdist starts workers
    )


def compile_once(config, package: Path, tests: Path, asked: list[Path]) -> list[Path]:
    """Compile ``package`` and the modules under ``tests``: the helpers and conftest files, and
    the test modules in the files or folders ``asked`` for, as pytest rewrites them. The files
    written, for ``remove``."""
    before = _bytecode_files([package, tests])
    # quiet: a module that does not compile is the workers' to report, as without this
    compileall.compile_dir(package, quiet=2)
    rewrites = config.getoption("assertmode") == "rewrite"
    test_patterns = config.getini("python_files")
    for source in sorted(tests.rglob("*.py")):
        is_test = any(fnmatch.fnmatch(source.name, pattern) for pattern in test_patterns)
        if is_test and not any(path == source or path in source.parents for path in asked):
            continue  # not collected: no worker imports it
        if rewrites and (is_test or source.name == "conftest.py"):
            _rewrite(config, source)
        else:
            compileall.compile_file(source, quiet=2)
    return sorted(_bytecode_files([package, tests]) - before)


def _rewrite(config, source: Path) -> None:
    try:
        source_hash, code = _rewrite_test(source, config)
    except SyntaxError:
        return
    pyc = get_cache_dir(source) / (source.name[:-3] + PYC_TAIL)
    pyc.parent.mkdir(exist_ok=True)
    _write_pyc(config.stash[assertstate_key], code, source_hash, pyc)


def remove(written: Iterable[Path]) -> None:
    """The files ``compile_once`` wrote, and the __pycache__ folders they leave empty."""
    folders = set()
    for pyc in written:
        pyc.unlink(missing_ok=True)
        folders.add(pyc.parent)
    for folder in folders:
        if folder.is_dir() and not any(folder.iterdir()):
            folder.rmdir()


def _bytecode_files(roots: list[Path]) -> set[Path]:
    return {pyc for root in roots for pyc in root.rglob("__pycache__/*.pyc")}

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
import multiprocessing
import os
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
    global _config
    _config = config  # read by _compile in the processes forked below
    sources = sorted(package.rglob("*.py")) + [
        source for source in sorted(tests.rglob("*.py")) if _collected(config, source, asked)
    ]
    # Spread over a process per core and one more, as the workers will be: the run is otherwise
    # one process here for these seconds, and beside other busy programs one process gets a
    # smaller share of the cores than the workers after it: a run reached its first test ~2 s
    # sooner, quiet or beside two CPU hogs.
    if "fork" in multiprocessing.get_all_start_methods():
        processes = len(os.sched_getaffinity(0)) + 1 if hasattr(os, "sched_getaffinity") else 2
        with multiprocessing.get_context("fork").Pool(processes) as pool:
            pool.map(_compile, sources, chunksize=8)
    else:  # spawned processes would not inherit the config: one process does it all
        for source in sources:
            _compile(source)
    return sorted(_bytecode_files([package, tests]) - before)


_config = None


def _collected(config, source: Path, asked: list[Path]) -> bool:
    """Whether a worker imports this module: every helper, only the tests asked for."""
    if not _is_test(config, source):
        return True
    return any(path == source or path in source.parents for path in asked)


def _is_test(config, source: Path) -> bool:
    return any(fnmatch.fnmatch(source.name, pattern) for pattern in config.getini("python_files"))


def _compile(source: Path) -> None:
    """One module compiled as the workers will import it: rewritten by pytest if it is a test
    module or a conftest file, plainly otherwise. A module that does not compile is the
    workers' to report, as without this."""
    rewrites = _config.getoption("assertmode") == "rewrite"
    if rewrites and (_is_test(_config, source) or source.name == "conftest.py"):
        _rewrite(_config, source)
    else:
        compileall.compile_file(source, quiet=2)


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

"""``choreo studio``: author a motion live in the browser.

The motion file stays the one source of truth: the page shows what the file says, planned and
simulated (``session``), follows every save of the file and the files it uses (``watch``),
writes the page's edits back into the file changing only what it must (``yaml_edit``), and draws
it all with viser (``scene``, ``page``, ``server``); ``live`` drives a robot through the same
safety path as ``choreo play``. ``server.Studio`` is made of one part per concern: ``timeline``,
``posing``, ``editing`` and ``driving`` (the live robot), sharing the state ``parts`` names.

viser, mjviser and ruamel.yaml are the ``choreo[studio]`` extra, imported only in this package.
"""

from __future__ import annotations

from choreo.errors import ChoreoError

EXTRA_HINT = "install the studio extra: pip install 'choreo[studio]'"


def require(module: str):
    """Import one of the studio extra's modules, or say which extra brings it."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise ChoreoError(f"choreo studio needs {module.split('.')[0]}: {EXTRA_HINT}") from None

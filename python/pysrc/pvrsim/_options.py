"""Keywords to options by flag name: ``ert_table=20`` is ``--ert-table 20``.

The option tables come from the command line's own definitions (through
``_native.option_table``), so the names, defaults, choices and help texts
shown by ``help(pvrsim.render)`` are the CLI's, and parsing and validation
are the job layer's: nothing is decided here but the spelling.
"""

from __future__ import annotations

import difflib
import functools
import os
import textwrap
from typing import Any, Dict, List, Tuple

from . import _native
from ._errors import OptionError, UnknownOptionError

Options = List[Tuple[str, Any]]

#: File options: the module returns what they hold, and writes the file
#: only when the keyword is given (the command line always writes ``-o``).
_WRITTEN_WHEN_GIVEN = ("output",)


@functools.lru_cache(maxsize=None)
def table(command: str) -> Dict[str, Dict[str, Any]]:
    """The options of ``pvrsim COMMAND`` by keyword (``render``, ``cluster``)."""
    return {o["name"]: o for o in _native.option_table(command)}


def _value(command: str, name: str, v: Any) -> Any:
    """A keyword's value as the job layer takes it (bool, int, float, str)."""
    if hasattr(v, "item") and callable(v.item) and getattr(v, "shape", None) == ():
        v = v.item()  # a numpy scalar
    if isinstance(v, os.PathLike):
        v = os.fspath(v)
    if isinstance(v, bytes):
        v = os.fsdecode(v)
    if isinstance(v, (list, tuple)):
        # Options that take lists on the command line take them comma-separated.
        v = ",".join(str(_value(command, name, x)) for x in v)
    if table(command)[name]["flag_only"] and not isinstance(v, bool):
        e = OptionError(
            f"{name}={v!r}: --{name.replace('_', '-')} is a switch: pass True or False"
        )
        e.option = name
        raise e
    if not isinstance(v, (bool, int, float, str)):
        raise TypeError(
            f"pvrsim.{command}: {name}={v!r}: expected a bool, a number, a string or a path"
        )
    return v


def options(command: str, scene: str, kw: Dict[str, Any]) -> Options:
    """``[("scene", scene), (keyword, value), ...]`` for ``pvrsim COMMAND``.

    ``None`` means "not given" (the CLI's default). An unknown keyword raises
    ``UnknownOptionError`` naming it (and the nearest known ones).
    """
    known = table(command)
    out: Options = [("scene", scene)]
    for name, v in kw.items():
        o = known.get(name)
        if o is None or o["positional"]:
            near = difflib.get_close_matches(
                name, [k for k, x in known.items() if not x["hidden"] and not x["positional"]], n=3
            )
            hint = f"; did you mean {', '.join(near)}?" if near else ""
            e = UnknownOptionError(
                f"pvrsim.{command}() got an unknown keyword {name!r}{hint} "
                f"(the keywords are the options of `pvrsim {command}`, with _ for -: "
                f"help(pvrsim.{command}))"
            )
            e.option = name
            raise e
        if v is None:
            continue
        out.append((name, _value(command, name, v)))
    return out


def doc(command: str) -> str:
    """The options of ``pvrsim COMMAND`` as a docstring section."""
    lines = [
        f"Options (every option of `pvrsim {command}`, keyword = flag name with _ for -;",
        "None or leaving it out means the CLI's default):",
        "",
    ]
    for name, o in table(command).items():
        if o["hidden"] or o["positional"]:
            continue
        head = f"{name}"
        if o["flag_only"]:
            head += "=True"
        elif o["choices"]:
            head += "=" + "|".join(repr(c) for c in o["choices"])
        elif o["value_name"]:
            head += f"={o['value_name']}"
        if name in _WRITTEN_WHEN_GIVEN:
            head += "  [written only when given]"
        elif o["default"] is not None and not o["flag_only"]:
            head += f"  [default: {o['default']}]"
        lines.append("    " + head)
        text = " ".join(o["help"].split())
        if text:
            lines.extend(textwrap.wrap(text, 72, initial_indent="        ", subsequent_indent="        "))
    return "\n".join(lines) + "\n"

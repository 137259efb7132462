"""Reading YAML/TOML/JSON documents and turning validation errors into one clear
message with file, line, key path, what was expected and what was found."""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import tomllib
import yaml
from pydantic import BaseModel, ValidationError

from wsgrasp.errors import SpecError

__all__ = [
    "load_document",
    "validate_document",
    "validation_messages",
    "DocumentLines",
]


class DocumentLines:
    """Maps key paths of a loaded document to line numbers (1-based)."""

    def __init__(self, path: Path | None, text: str, node: yaml.Node | None) -> None:
        self.path = path
        self.text = text
        self.node = node

    def line_of(self, loc: Sequence[str | int]) -> int | None:
        """Line of the deepest existing key along ``loc``."""
        node = self.node
        line = None
        for key in loc:
            if isinstance(node, yaml.MappingNode):
                found = None
                for k, v in node.value:
                    if getattr(k, "value", None) == str(key):
                        found = (k, v)
                        break
                if found is None:
                    break
                line = found[0].start_mark.line + 1
                node = found[1]
            elif isinstance(node, yaml.SequenceNode) and isinstance(key, int):
                if key >= len(node.value):
                    break
                node = node.value[key]
                line = node.start_mark.line + 1
            else:
                break
        if line is None and self.node is None and loc:
            # TOML: no parser positions; find the last key textually.
            for key in reversed([k for k in loc if isinstance(k, str)]):
                m = re.search(rf"^\s*{re.escape(key)}\s*=", self.text, re.MULTILINE)
                if m:
                    return self.text.count("\n", 0, m.start()) + 1
        return line


def load_document(path: str | Path) -> tuple[dict[str, Any], DocumentLines]:
    """Load a YAML, TOML or JSON file into a dict, with line information.

    Raises
    ------
    SpecError
        The file is missing, unreadable, not a mapping, or does not parse.
    """
    p = Path(path)
    if not p.is_file():
        raise SpecError(
            f"{p}: file not found",
            hint="check the path (relative to the current directory)",
        )
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise SpecError(
            f"{p}: not a text file (byte {exc.start} is not UTF-8)",
            hint="give a YAML, TOML or JSON text file",
        ) from None
    suffix = p.suffix.lower()
    node: yaml.Node | None = None
    try:
        if suffix == ".toml":
            data: Any = tomllib.loads(text)
        elif suffix == ".json":
            data = json.loads(text, object_pairs_hook=_unique_pairs)
            node = yaml.compose(text, Loader=yaml.SafeLoader)
        else:
            node = yaml.compose(text, Loader=yaml.SafeLoader)
            _refuse_duplicate_keys(node)
            data = yaml.safe_load(text)
    except _DuplicateKey as exc:
        where = f"{p}:{exc.line}" if exc.line else str(p)
        raise SpecError(
            f"{where}: key {exc.key!r} is given twice in one mapping"
            + (f" (first at line {exc.first})" if exc.first else ""),
            hint="keep one of them; a later one would silently replace the first",
        ) from None
    except (yaml.YAMLError, json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        line = _parse_error_line(exc)
        where = f"{p}:{line}" if line else str(p)
        raise SpecError(
            f"{where}: cannot parse {suffix.lstrip('.') or 'YAML'}: "
            f"{str(exc).splitlines()[0]}",
            hint="fix the syntax at that line",
        ) from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise SpecError(
            f"{p}: expected a mapping of keys at the top level, found "
            f"{type(data).__name__}",
            hint="start the file with `key: value` lines",
        )
    return data, DocumentLines(p, text, node)


class _DuplicateKey(Exception):
    def __init__(self, key: str, line: int | None, first: int | None) -> None:
        super().__init__(key)
        self.key, self.line, self.first = key, line, first


def _refuse_duplicate_keys(node: yaml.Node | None) -> None:
    """Raise ``_DuplicateKey`` for a key given twice in one YAML mapping (PyYAML
    keeps the last one without a word)."""
    stack = [node] if node is not None else []
    while stack:
        n = stack.pop()
        if isinstance(n, yaml.MappingNode):
            seen: dict[str, int] = {}
            for k, v in n.value:
                key = str(getattr(k, "value", k))
                line = k.start_mark.line + 1
                if isinstance(k, yaml.ScalarNode) and key != "<<":
                    if key in seen:
                        raise _DuplicateKey(key, line, seen[key])
                    seen[key] = line
                stack.append(v)
        elif isinstance(n, yaml.SequenceNode):
            stack.extend(n.value)


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise _DuplicateKey(k, None, None)
        out[k] = v
    return out


def _parse_error_line(exc: Exception) -> int | None:
    mark = getattr(exc, "problem_mark", None)
    if mark is not None:
        return int(mark.line) + 1
    lineno = getattr(exc, "lineno", None)
    if lineno is not None:
        return int(lineno)
    m = re.search(r"line (\d+)", str(exc))
    return int(m.group(1)) if m else None


def format_validation_error(
    exc: ValidationError,
    lines: DocumentLines | None,
    what: str,
    prefix: Sequence[str | int] = (),
) -> str:
    """One message for the first error of a pydantic ``ValidationError``, with a
    count of the others (:func:`validation_messages` gives them all)."""
    messages = validation_messages(exc, lines, what, prefix)
    text = messages[0]
    more = len(messages) - 1
    if more:
        text += f" (and {more} more problem{'s' if more > 1 else ''})"
    return text


def validation_messages(
    exc: ValidationError,
    lines: DocumentLines | None,
    what: str,
    prefix: Sequence[str | int] = (),
) -> list[str]:
    """One message per error of a pydantic ``ValidationError``, in file order
    where lines are known: file, line, key path, what was expected and found."""
    out = []
    for err in exc.errors():
        loc = [*prefix, *[x for x in err["loc"] if not str(x).startswith("function-")]]
        line = lines.line_of(loc) if lines is not None else None
        out.append((line or 0, _error_text(err, loc, lines, line, what)))
    out.sort(key=lambda item: item[0])  # stable: pydantic's order within a line
    return [text for _, text in out]


def _error_text(
    err: Any,
    loc: list[Any],
    lines: DocumentLines | None,
    line: int | None,
    what: str,
) -> str:
    key = ".".join(str(x) for x in loc) or "(top level)"
    where = ""
    if lines is not None and lines.path is not None:
        where = f"{lines.path}:{line}: " if line else f"{lines.path}: "
    found = err.get("input")
    kind = err["type"]
    if kind == "extra_forbidden":
        text = f"unknown key {key!r} in {what}"
    elif kind == "missing":
        text = f"missing key {key!r} in {what}"
    elif kind == "value_error" and isinstance(found, (dict, list, BaseModel)):
        # a check of a whole section: its message says what and why
        msg = str(err["msg"]).removeprefix("Value error, ").rstrip(".")
        text = f"{key}: {msg}"
    else:
        shown = repr(found)
        if len(shown) > 60:
            shown = shown[:57] + "..."
        msg = str(err["msg"]).removeprefix("Value error, ").rstrip(".")
        text = f"{key}: {msg}; found {shown}"
    return where + text


def validate_document(
    model: type[BaseModel],
    data: dict[str, Any],
    lines: DocumentLines | None,
    what: str,
    hint: str,
) -> Any:
    """Validate ``data`` against ``model`` or raise one ``SpecError``."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise SpecError(format_validation_error(exc, lines, what), hint=hint) from None

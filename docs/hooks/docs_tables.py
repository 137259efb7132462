"""Markdown helpers shared by the documentation's generated pages."""

from __future__ import annotations

import inspect
import json
import re
from typing import Any

__all__ = ["cell", "code", "doc_summary", "plain", "short", "table", "type_name"]


def cell(text: Any) -> str:
    """A value made safe for one Markdown table cell."""
    s = str(text).replace("\n", " ").replace("|", "\\|")
    return s


def code(value: Any) -> str:
    if value is None:
        return "–"
    return "`" + json.dumps(value, default=str) + "`"


def type_name(annotation: Any) -> str:
    """A short, readable name of a field's type."""
    s = str(annotation) if not isinstance(annotation, type) else annotation.__name__
    s = re.sub(r"typing\.|pydantic\.types\.|annotated_types\.", "", s)
    s = re.sub(r"Annotated\[(\w+), [^\]]*\]", r"\1", s)
    s = re.sub(r"<class '([\w.]+)'>", lambda m: m.group(1).rsplit(".", 1)[-1], s)
    s = re.sub(r"wsgrasp\.spec\.", "", s)
    s = s.replace("NoneType", "None").replace(" | ", " or ")
    return s


def table(header: list[str], rows: list[list[Any]]) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return "\n".join(out) + "\n"


def doc_summary(obj: Any) -> str:
    doc = inspect.getdoc(obj) or ""
    return " ".join(doc.split("\n\n")[0].split())


def plain(value: Any) -> Any:
    from pydantic import BaseModel

    if isinstance(value, BaseModel):
        return value.model_dump(mode="json")
    if isinstance(value, list):
        return [plain(v) for v in value]
    if isinstance(value, tuple):
        return [plain(v) for v in value]
    return value


def short(gripper: str) -> str:
    """A gripper named by a YAML path, by its file's stem."""
    return gripper.rsplit("/", 1)[-1].removesuffix(".yaml")

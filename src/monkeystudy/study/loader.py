"""Read a study file: YAML 1.2 with line numbers, strict validation, ``file:line: key: message``.

ruamel.yaml's round-trip loader reads YAML 1.2 (``1e-3`` is a number, ``no`` is text) and keeps
the line of every key and item. The plain-Python copy of the tree is validated by the strict
models of :mod:`monkeystudy.study.schema`; every error is reported, each located in the file::

    studies/x.yaml:12: robot.links[0].mass: must be > 0, got -1.0
"""
from __future__ import annotations

import difflib
import hashlib
import re
from dataclasses import dataclass
from datetime import date, datetime
from pathlib import Path
from typing import Any

from pydantic import ValidationError
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq
from ruamel.yaml.error import MarkedYAMLError, YAMLError

from . import schema as S
from .models import SEEN_MODELS
from .progress import count


@dataclass(frozen=True)
class Issue:
    """One problem in a study file (``line`` is 1-based, 0 when unknown)."""

    file: str
    line: int
    key: str
    message: str

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}" if self.line else self.file
        return f"{where}: {self.key}: {self.message}" if self.key else f"{where}: {self.message}"


class StudyError(ValueError):
    """A study file that cannot be run; ``issues`` lists every problem found."""

    def __init__(self, issues: list[Issue]):
        self.issues = sorted(issues, key=lambda i: (i.line, i.key))
        super().__init__("\n".join(str(i) for i in self.issues))


@dataclass(frozen=True)
class LoadedStudy:
    """A validated study with the text it came from."""

    study: S.Study
    text: str
    path: Path

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.text.encode("utf-8")).hexdigest()


def load_study(path: str | Path, shown: str | None = None) -> LoadedStudy:
    """Read and validate a study file; raise :class:`StudyError` listing every problem.

    ``shown`` names the file in messages (default: ``path`` as given)."""
    path = Path(path)
    shown = str(path) if shown is None else shown
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise StudyError([Issue(shown, 0, "", "no such file")]) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise StudyError([Issue(shown, 0, "", f"cannot read: {exc}")]) from None
    return parse_study(text, shown, path)


def parse_study(text: str, shown: str = "<string>", path: Path | None = None) -> LoadedStudy:
    """Validate study ``text``; ``shown`` names the file in messages."""
    tree = _parse_yaml(text, shown)
    plain = _plain(tree)
    seen: dict[int, type] = {}
    token = SEEN_MODELS.set(seen)
    study = None
    # files a study names (a robot's URDF) are relative to the study file's folder
    context = {"study_dir": str(Path(path).parent if path is not None else Path("."))}
    try:
        study = S.Study.model_validate(plain, context=context)
    except ValidationError as exc:
        issues = [_issue(shown, tree, plain, err, seen) for err in exc.errors()]
    finally:
        SEEN_MODELS.reset(token)
    # every problem in one pass: the checks across steps that the valid fields allow too
    problems = (S.cross_check(study) if study is not None
                else S.cross_check_parts(plain, context=context))
    if study is None or problems:
        raise StudyError((issues if study is None else [])
                         + [Issue(shown, _line_of(tree, loc), _dotted(loc), msg)
                            for loc, msg in problems])
    return LoadedStudy(study, text, Path(path) if path is not None else Path(shown))


# --- YAML ---------------------------------------------------------------------------------------
_YAML11 = re.compile(r"^%YAML\s+1\.[01]\b", re.MULTILINE)


def _parse_yaml(text: str, shown: str):
    m = _YAML11.search(text)
    if m:
        line = text.count("\n", 0, m.start()) + 1
        raise StudyError([Issue(shown, line, "", "YAML 1.1 is not supported (its 'no' is "
                                "false and '1e-3' is text); remove the %YAML directive")])
    yaml = YAML(typ="rt")
    try:
        docs = list(yaml.load_all(text))
    except MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else 0
        what = " ".join(p for p in (exc.context, exc.problem) if p)
        if "duplicate key" in str(exc).lower():
            what = _duplicate_key_message(exc)
        raise StudyError([Issue(shown, line, "", f"invalid YAML: {what}")]) from None
    except YAMLError as exc:
        raise StudyError([Issue(shown, 0, "", f"invalid YAML: {exc}")]) from None
    docs = [d for d in docs if d is not None]
    if not docs:
        raise StudyError([Issue(shown, 1, "", "empty study file")])
    if len(docs) > 1:
        raise StudyError([Issue(shown, 0, "", "one YAML document per study file, found "
                                f"{len(docs)}")])
    if not isinstance(docs[0], CommentedMap):
        raise StudyError([Issue(shown, 1, "", "a study file is a mapping of keys "
                                "(schema_version, name, robot, gait, integrator, steps)")])
    return docs[0]


def _duplicate_key_message(exc: MarkedYAMLError) -> str:
    m = re.search(r'found duplicate key "([^"]*)"', str(exc))
    return f"duplicate key {m.group(1)!r}" if m else "duplicate key"


def _plain(node: Any) -> Any:
    """Plain Python copy of a ruamel tree (dict, list, str, int, float, bool, None)."""
    if isinstance(node, dict):
        return {str(k) if not isinstance(k, str) else k: _plain(v) for k, v in node.items()}
    if isinstance(node, list):
        return [_plain(v) for v in node]
    if isinstance(node, bool):
        return bool(node)
    if isinstance(node, int):
        return int(node)
    if isinstance(node, float):
        return float(node)
    if isinstance(node, str):
        return str(node)
    return node


# --- locating ----------------------------------------------------------------------------------
def _strip_tags(plain: Any, loc: tuple, names_key: bool = True) -> tuple:
    """Drop pydantic's union tags from ``loc`` (they name no key in the data).

    ``names_key``: the error is about a key (missing, unknown), so a last element absent from
    the data is that key, not a tag.
    """
    out: list = []
    node = plain
    for i, part in enumerate(loc):
        last = i == len(loc) - 1
        if isinstance(node, dict):
            if part in node:
                out.append(part)
                node = node[part]
            elif last and names_key:
                out.append(part)
                node = None
            # else: a tag such as 'grid' or 'parameters'
        elif isinstance(node, list) and isinstance(part, int):
            out.append(part)
            node = node[part] if 0 <= part < len(node) else None
        elif isinstance(part, str):
            continue  # a tag such as 'preset' or 'point' under a scalar or a list
        else:
            out.append(part)
            node = None
    return tuple(out)


def _node_at(plain: Any, loc: tuple) -> Any:
    node = plain
    for part in loc:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
        else:
            return None
    return node


def _line_of(tree: Any, loc: tuple) -> int:
    """1-based line of the deepest element of ``loc`` present in the ruamel tree."""
    line = 0
    node = tree
    try:
        line = tree.lc.line + 1
    except AttributeError:
        pass
    for part in loc:
        if isinstance(node, CommentedMap) and part in node:
            try:
                line = node.lc.key(part)[0] + 1
            except KeyError:    # a key merged in from an anchor (<<: *name): the mapping's line
                pass
            node = node[part]
        elif (isinstance(node, CommentedSeq) and isinstance(part, int)
              and 0 <= part < len(node)):
            line = node.lc.item(part)[0] + 1
            node = node[part]
        else:
            break
    return line


def _dotted(loc: tuple) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


# --- messages ------------------------------------------------------------------------------------
def _show(value: Any) -> str:
    if isinstance(value, (dict, list)):
        text = repr(value)
        return text if len(text) <= 60 else text[:57] + "..."
    if isinstance(value, (date, datetime)):
        return f"{value.isoformat()} (a date)"
    return repr(value)


def _looks_numeric(value: Any) -> bool:
    if not isinstance(value, str):
        return False
    try:
        float(value)
    except ValueError:
        return False
    return True


def _number(v: Any) -> str:
    if isinstance(v, float) and v.is_integer():
        return str(int(v))
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def _message(err: dict, parent_cls: type | None) -> str:
    t = err["type"]
    ctx = err.get("ctx") or {}
    value = err.get("input")
    got = f", got {_show(value)}"
    if t == "missing":
        return "required key missing"
    if t == "extra_forbidden":
        key = str(err["loc"][-1]) if err["loc"] else ""
        if parent_cls is None:
            return "unknown key"
        allowed = parent_cls.allowed_keys()
        close = difflib.get_close_matches(key, allowed, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        return f"unknown key{hint} (allowed: {', '.join(allowed)})"
    if t in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        op, bound = {"greater_than": (">", "gt"), "greater_than_equal": (">=", "ge"),
                     "less_than": ("<", "lt"), "less_than_equal": ("<=", "le")}[t]
        return f"must be {op} {_number(ctx[bound])}{got}"
    if t == "finite_number":
        return f"must be finite{got}"
    if t in ("float_type", "float_parsing"):
        if _looks_numeric(value):
            return f"must be a number, got the text {value!r} (remove the quotes)"
        return f"must be a number{got}"
    if t in ("int_type", "int_parsing", "int_from_float"):
        return f"must be an integer{got}"
    if t in ("bool_type", "bool_parsing"):
        return f"must be true or false{got}"
    if t == "string_type":
        return f"must be text{got}"
    if t == "string_pattern_mismatch":
        return f"must be a name of letters, digits, '_', '-' and '.'{got}"
    if t == "string_too_long":
        return f"must be at most {ctx.get('max_length')} characters"
    if t == "literal_error":
        return f"must be {ctx.get('expected')}{got}"
    if t in ("too_short", "too_long"):
        lo = ctx.get("min_length")
        hi = ctx.get("max_length")
        n = ctx.get("actual_length")
        if t == "too_short" and lo == 1:
            return "must not be empty"
        if lo == 2 or hi == 2:  # points and links: every 2-list of the schema is exactly 2
            return f"must have exactly 2 items, got {n}"
        if t == "too_short":
            return f"must have at least {count(lo, 'item')}, got {n}"
        return f"must have at most {count(hi, 'item')}, got {n}"
    if t == "list_type":
        return f"must be a list{got}"
    if t in ("model_type", "dict_type", "model_attributes_type"):
        return f"must be a mapping{got}"
    if t == "union_tag_invalid":
        return f"must be one of {ctx.get('expected_tags')}{got if value is None else ''}" + \
            (f", got {ctx.get('tag')!r}" if ctx.get("tag") is not None else "")
    if t == "union_tag_not_found":
        return "required key missing"
    if t == "value_error":
        msg = str(err["msg"])
        return msg[len("Value error, "):] if msg.startswith("Value error, ") else msg
    return str(err["msg"])


def _issue(shown: str, tree: Any, plain: Any, err: dict, seen: dict[int, type]) -> Issue:
    loc = _strip_tags(plain, tuple(err["loc"]),
                      err["type"] in ("missing", "extra_forbidden"))
    if err["type"] in ("union_tag_invalid", "union_tag_not_found"):
        key = str(err.get("ctx", {}).get("discriminator", "kind")).strip("'")
        loc = loc + (key,)
    parent = _node_at(plain, loc[:-1]) if loc else None
    parent_cls = seen.get(id(parent)) if isinstance(parent, dict) else None
    return Issue(shown, _line_of(tree, loc), _dotted(loc), _message(err, parent_cls))


__all__ = ["Issue", "LoadedStudy", "StudyError", "load_study", "parse_study"]

"""Which request field an error names: ``errors[].loc`` is always a path the request model has.

A core error names the field at fault as the joint or Cartesian request spells it (``limits``,
``duration``); a program or ``/v1/compare`` reuses that core under other names, where the same
fact lives at ``segments.3`` or ``task.duration`` and a program has no ``limits`` at all. The
problem body must not send a client to a field its request cannot have: ``request_loc`` picks the
candidate path (the error's own field, within its program segment) that goes deepest into the
request model and cuts it where the model ends, so the answer names the nearest real field.
"""

from __future__ import annotations

import types
from collections.abc import Sequence
from typing import Annotated, Any, Union, get_args, get_origin

from pydantic import BaseModel, Tag

from core.errors import PlanningError

Path = tuple[str | int, ...]


def valid_depth(annotation: Any, path: Sequence[str | int]) -> int:
    """How many leading parts of ``path`` name a field (a string) or an element (an index >= 0)
    of a value of type ``annotation`` (pydantic models, lists, tuples, dicts, unions)."""
    if not path:
        return 0
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return valid_depth(args[0], path)
    if origin in (Union, types.UnionType):
        return max(valid_depth(a, path) for a in args)
    part, rest = path[0], path[1:]
    if origin in (list, tuple) and isinstance(part, int) and part >= 0 and args:
        if origin is tuple and args[-1] is not Ellipsis:
            return 1 + valid_depth(args[part], rest) if part < len(args) else 0
        return 1 + valid_depth(args[0], rest)
    if origin is dict and isinstance(part, str) and len(args) == 2:
        return 1 + valid_depth(args[1], rest)
    if isinstance(annotation, type) and issubclass(annotation, BaseModel) and isinstance(part, str):
        field = annotation.model_fields.get(part)
        return 0 if field is None else 1 + valid_depth(field.annotation, rest)
    return 0


def _members(annotation: Any) -> tuple[Any, ...] | None:
    """The members of a union (through ``Annotated``), or None for any other type."""
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return _members(args[0])
    return args if origin in (Union, types.UnionType) else None


def _tagged(member: Any, tag: str) -> bool:
    """Whether pydantic's union tag ``tag`` names ``member``: its class name (``str``,
    ``InlineRobot``) or a value of one of its ``Literal`` fields (a discriminator, ``ptp``)."""
    if getattr(member, "__name__", None) == tag:
        return True
    if get_origin(member) is Annotated and any(
        isinstance(m, Tag) and m.tag == tag for m in get_args(member)[1:]
    ):  # a member of a union with a callable discriminator (``Tag("rows")``)
        return True
    if isinstance(member, type) and issubclass(member, BaseModel):
        return any(tag in get_args(f.annotation) for f in member.model_fields.values())
    return _members(member) is not None and any(_tagged(m, tag) for m in _members(member) or ())


def _child(annotation: Any, part: str | int) -> Any:
    """The type of field or element ``part`` of ``annotation`` (``valid_depth`` of 1)."""
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return _child(args[0], part)
    members = _members(annotation)
    if members is not None:
        return _child(next(m for m in members if valid_depth(m, (part,))), part)
    if origin is dict:
        return args[1]
    if origin in (list, tuple):
        return args[part] if origin is tuple and args[-1] is not Ellipsis else args[0]  # type: ignore[index]
    return annotation.model_fields[part].annotation


def without_tags(annotation: Any, path: Sequence[str | int]) -> Path:
    """``path`` (a pydantic error's ``loc``, without ``"body"``) without the tags pydantic puts in
    it at a union: ``robot.InlineRobot.urdf`` is ``robot.urdf`` of the request, and
    ``segments.0.ptp.goal`` is ``segments.0.goal``. A part past the model (an unknown field) ends it
    unchanged."""
    out: list[str | int] = []
    for k, part in enumerate(path):
        if valid_depth(annotation, (part,)):
            out.append(part)
            annotation = _child(annotation, part)
            continue
        members = _members(annotation)
        if members is None or not isinstance(part, str):
            return (*out, *path[k:])
        chosen = [m for m in members if _tagged(m, part)]
        if len(chosen) == 1:
            annotation = chosen[0]
        elif not chosen:
            return (*out, *path[k:])
    return tuple(out)


def request_loc(model: type[BaseModel] | None, field: Path, segment: int | None = None) -> Path:
    """The path of ``field`` in a request of type ``model`` (without the leading ``"body"``).

    Candidates: ``field`` itself, and ``("segments", segment, *field)`` for an error of a program
    segment; the one that names the most parts of the model wins, cut where the model ends (``()``:
    the body as a whole). Without a model, ``field`` unchanged."""
    if model is None:
        return field
    candidates = [field]
    if segment is not None and field[:1] != ("segments",):
        candidates.append(("segments", segment, *field))
    depths = [valid_depth(model, c) for c in candidates]
    best = max(range(len(candidates)), key=lambda k: (depths[k] == len(candidates[k]), depths[k]))
    return candidates[best][: depths[best]]


def nest(err: PlanningError, prefix: Path) -> PlanningError:
    """``err`` with its field inside ``prefix`` (a request nested in another, as ``/v1/compare``'s
    ``task``), unless it names a path there already; ``err`` itself, for ``raise``."""
    if err.field is not None and err.field[: len(prefix)] != prefix:
        err.field = (*prefix, *err.field)
    return err

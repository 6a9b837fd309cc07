"""The ``curl`` examples of the project's Markdown (README.md, docs/api.md) and their documented
answers, read so that tests can send each one to the app in-process and compare the answer.

An example is a ``curl`` command in a ``bash`` block; the comment lines right after it that start
with ``# {``, ``# [`` or ``# <status> {`` (continued by lines starting with ``#`` and two or more
spaces) are its documented answer. The answer is JSON abridged by one convention (docs/api.md,
"Conventions"):

- ``...`` where an array element goes: any number of elements there (``["a", ..., "z"]``: the
  first is ``"a"``, the last ``"z"``); where an object member goes (``{"a": 1, ...}``) or as a
  whole object (``{...}``): nothing more is promised (every documented object is abridged: a live
  object may have more keys than the documented one);
- ``...`` inside a string: any text there (``".../unreachable"``);
- a number matches to half a unit in its last digit shown (``1.3551`` is 1.35505 to 1.35515; an
  integer ``41`` exactly), or to 1e-12 relative; one shown below 1e-9 in magnitude is round-off and
  matches any number below 1e-9 in magnitude;
- timings (``compute_time_ms``, ``*_time_ms``, ``*_time_us_*``) vary between runs: not compared.

Text after the answer's last bracket (``(self-distances ...)``) is a note, not part of it.
"""

from __future__ import annotations

import json
import re
import shlex
from dataclasses import dataclass
from decimal import Decimal
from typing import Any, ClassVar

ELLIPSIS = object()
"""``...`` in a documented array or object."""
ANY_OBJECT: dict[str, Any] = {}
"""``{...}``: an object with anything in it (compared by identity)."""
ROUND_OFF = 1e-9
UNTIMED = re.compile(r"(^compute_time_ms$|_time_ms$|_time_us_)")


@dataclass(frozen=True)
class Number:
    """A documented number and the half unit of its last digit shown."""

    value: float
    half_unit: float
    text: str


@dataclass(frozen=True)
class CurlExample:
    method: str
    url: str
    """Path with query, without the host."""
    body: bytes | None
    status: int
    code: str | None
    answer: str | None
    """The documented answer's JSON text (status prefix removed), or None."""
    line: int
    """1-based line of the ``curl`` in its file."""

    @property
    def name(self) -> str:
        return f"L{self.line}-{self.method}-{self.url.split('?')[0]}"


ANSWER_START = re.compile(r"^#\s(?:(\d{3})\s+)?([\[{].*)$")


def curl_examples(text: str) -> list[CurlExample]:
    """Every ``curl`` of the ``bash`` blocks of ``text``, in order."""
    examples = []
    lines = text.splitlines()
    in_bash, i = False, 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("```"):
            in_bash = line.strip() == "```bash" and not in_bash
            i += 1
            continue
        if not in_bash or not line.startswith("curl "):
            i += 1
            continue
        first, command = i, line
        while True:  # a quoted body, or a backslash continuation, spans lines
            try:
                argv = shlex.split(command.replace("\\\n", " "), comments=True)
                if not command.rstrip().endswith("\\"):
                    break
            except ValueError:
                pass
            i += 1
            command += "\n" + lines[i]
        i += 1
        if "|" in argv:
            argv = argv[: argv.index("|")]
        method = argv[argv.index("-X") + 1] if "-X" in argv else "GET"
        url = next(a for a in argv if a.startswith(("localhost:8000", "127.0.0.1:8000")))
        body = argv[argv.index("-d") + 1].encode() if "-d" in argv else None
        status, answer = 200, None
        start = ANSWER_START.match(lines[i]) if i < len(lines) else None
        if start:
            status = int(start.group(1) or 200)
            parts = [start.group(2)]
            i += 1
            ndjson = "stream=ndjson" in url  # one JSON value per answer line, each on its own
            more = r"^# \{" if ndjson else r"^#\s{2,}\S"
            while i < len(lines) and re.match(more, lines[i]):
                parts.append(lines[i][1:].strip())
                i += 1
            answer = ("\n" if ndjson else " ").join(parts)
        named = re.search(r'"code":\s*"(\w+)"', answer or "") if status >= 400 else None
        code = named.group(1) if named else None
        examples.append(
            CurlExample(method, url.split(":8000", 1)[1], body, status, code, answer, first + 1)
        )
    return examples


class _Reader:
    """A recursive-descent reader of abridged JSON (see the module docstring)."""

    NUMBER = re.compile(r"-?\d+(\.\d+)?([eE][-+]?\d+)?")
    WORDS: ClassVar[dict[str, Any]] = {"true": True, "false": False, "null": None}

    def __init__(self, text: str) -> None:
        self.text, self.i = text, 0

    def _skip(self) -> None:
        while self.i < len(self.text) and self.text[self.i].isspace():
            self.i += 1

    def _peek(self, token: str) -> bool:
        self._skip()
        return self.text.startswith(token, self.i)

    def _take(self, token: str) -> None:
        if not self._peek(token):
            raise ValueError(f"expected {token!r} at {self.text[self.i : self.i + 40]!r}")
        self.i += len(token)

    def value(self) -> Any:
        self._skip()
        if self._peek("..."):
            self.i += 3
            return ELLIPSIS
        char = self.text[self.i]
        if char == "{":
            return self._object()
        if char == "[":
            return self._array()
        if char == '"':
            end = self.i + 1
            while self.text[end] != '"':
                end += 2 if self.text[end] == "\\" else 1
            string = json.loads(self.text[self.i : end + 1])
            self.i = end + 1
            return string
        for word, value in self.WORDS.items():
            if self.text.startswith(word, self.i):
                self.i += len(word)
                return value
        match = self.NUMBER.match(self.text, self.i)
        if not match:
            raise ValueError(f"no JSON value at {self.text[self.i : self.i + 40]!r}")
        self.i = match.end()
        literal = match.group(0)
        if match.group(1) is None and match.group(2) is None:
            return Number(float(literal), 0.0, literal)
        exponent = Decimal(literal).as_tuple().exponent
        assert isinstance(exponent, int)
        return Number(float(literal), 0.5 * 10.0**exponent, literal)

    def _object(self) -> dict[str, Any]:
        self._take("{")
        if self._peek("...}"):
            self._take("...")
            self._take("}")
            return ANY_OBJECT
        out: dict[str, Any] = {}
        while not self._peek("}"):
            if self._peek("..."):
                self._take("...")
            else:
                key = self.value()
                self._take(":")
                out[key] = self.value()
            if not self._peek("}"):
                self._take(",")
        self._take("}")
        return out

    def _array(self) -> list[Any]:
        self._take("[")
        out = []
        while not self._peek("]"):
            out.append(self.value())
            if not self._peek("]"):
                self._take(",")
        self._take("]")
        return out


def parse_answer(text: str) -> Any:
    """The documented answer: dicts, lists, strings, bools, None, ``Number`` and ``ELLIPSIS``."""
    return _Reader(text).value()


def _number_matches(doc: Number, live: Any) -> bool:
    if isinstance(live, bool) or not isinstance(live, (int, float)):
        return False
    if abs(doc.value) < ROUND_OFF:
        return abs(live) < ROUND_OFF
    slack = max(doc.half_unit * (1 + 1e-9), 1e-12 * abs(doc.value))
    return abs(live - doc.value) <= slack


def _string_matches(doc: str, live: Any) -> bool:
    if not isinstance(live, str):
        return False
    if "..." not in doc:
        return doc == live
    pattern = ".*".join(re.escape(part) for part in doc.split("..."))
    return re.fullmatch(pattern, live, flags=re.S) is not None


def mismatches(doc: Any, live: Any, where: str = "") -> list[str]:
    """Where the live answer differs from the documented one (empty: it matches)."""
    if doc is ANY_OBJECT:
        return [] if isinstance(live, dict) else [f"{where}: expected an object, got {live!r}"]
    if isinstance(doc, dict):
        if not isinstance(live, dict):
            return [f"{where}: expected an object, got {str(live)[:80]}"]
        out = []
        for key, value in doc.items():
            if key not in live:
                out.append(f"{where}.{key}: documented, absent from the answer")
            elif not UNTIMED.search(key):
                out += mismatches(value, live[key], f"{where}.{key}")
        return out
    if isinstance(doc, list):
        return _list_mismatches(doc, live, where)
    if isinstance(doc, Number):
        ok = _number_matches(doc, live)
        return [] if ok else [f"{where}: documented {doc.text}, answered {live!r}"]
    if isinstance(doc, str):
        return [] if _string_matches(doc, live) else [f"{where}: documented {doc!r}, got {live!r}"]
    same = doc is live or (doc == live and type(doc) is type(live))
    return [] if same else [f"{where}: documented {doc!r}, answered {live!r}"]


def _list_mismatches(doc: list[Any], live: Any, where: str) -> list[str]:
    if not isinstance(live, list):
        return [f"{where}: expected an array, got {str(live)[:80]}"]
    runs: list[list[Any]] = [[]]
    for item in doc:
        if item is ELLIPSIS:
            runs.append([])
        else:
            runs[-1].append(item)
    if len(runs) == 1:
        if len(live) != len(doc):
            return [f"{where}: documented {len(doc)} elements, answered {len(live)}"]
        return [
            m
            for k, (d, v) in enumerate(zip(doc, live, strict=True))
            for m in mismatches(d, v, f"{where}[{k}]")
        ]
    head, tail = runs[0], runs[-1]
    if len(live) < len(head) + len(tail):
        return [f"{where}: documented at least {len(head) + len(tail)} elements, got {len(live)}"]
    out = [m for k, d in enumerate(head) for m in mismatches(d, live[k], f"{where}[{k}]")]
    offset = len(live) - len(tail)
    out += [
        m
        for k, d in enumerate(tail)
        for m in mismatches(d, live[offset + k], f"{where}[{offset + k}]")
    ]
    position = len(head)
    for run in runs[1:-1]:  # the middle runs: in order, anywhere between head and tail
        while position + len(run) <= offset:
            if not any(mismatches(d, live[position + k]) for k, d in enumerate(run)):
                break
            position += 1
        else:
            out.append(f"{where}: no run of {len(run)} documented elements in the middle")
        position += len(run)
    return out

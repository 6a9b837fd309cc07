"""Every POST route takes a JSON body: any other ``Content-Type`` is 415 ``unsupported_media_type``.

FastAPI hands a body it does not take for JSON (no ``Content-Type``, ``text/plain``, a form) to
validation as bytes, so a form post was a 422 about the body. ``require_json``, a dependency of every
router that computes (``service.app``), answers it first: ``application/json`` or any
``application/*+json`` (parameters such as ``charset`` ignored, case-insensitive) is JSON; anything
else, a missing header included (with a body), is 415 naming the expected type in ``detail`` and in
``Accept-Post`` (RFC 9110, section 15.5.16). A body declared JSON that does not parse stays 422
``validation`` (FastAPI parses it before any dependency runs). Being a route dependency, the check
runs after routing: an unknown path stays 404 and a wrong method 405.
"""

from __future__ import annotations

from fastapi import Request
from starlette.exceptions import HTTPException

JSON_MEDIA_TYPE = "application/json"


def is_json(content_type: str | None) -> bool:
    """True for ``application/json`` and ``application/<name>+json``, with or without parameters;
    False for anything else and for no header."""
    if not content_type:
        return False
    media = content_type.split(";", 1)[0].strip().lower()
    main, _, sub = media.partition("/")
    return main == "application" and (sub == "json" or (sub.endswith("+json") and len(sub) > 5))


async def require_json(request: Request) -> None:
    """415 ``unsupported_media_type`` for a POST with a body whose ``Content-Type`` is not JSON
    (no body at all has no media type: it stays 422 ``validation``, the body missing)."""
    if request.method != "POST" or is_json(request.headers.get("content-type")):
        return
    if request.headers.get("content-type") is not None or await request.body():
        raise HTTPException(415, headers={"Accept-Post": JSON_MEDIA_TYPE})

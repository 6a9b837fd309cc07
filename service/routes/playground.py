"""GET /: the playground page, and GET /static/{name}: its script, style sheet and Plotly.

The page is plain HTML + JavaScript (no build step) in ``service/static/``; it calls only the public
API (``/v1/...``), like any client. Plotly is the ``plotly.min.js`` that the Python ``plotly``
package ships in ``plotly/package_data/``, served from here: the page needs no CDN and works in a
container without internet. The Content-Security-Policy of the page allows this origin only, so a
script or request to any other host would be blocked, not silently fetched.
"""

from __future__ import annotations

import importlib.util
from functools import lru_cache
from pathlib import Path

from fastapi import APIRouter, HTTPException
from fastapi.responses import FileResponse

router = APIRouter(include_in_schema=False)

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"
MEDIA_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
}
CSP = (
    "default-src 'self'; script-src 'self'; connect-src 'self'; img-src 'self' data: blob:; "
    "style-src 'self' 'unsafe-inline'; font-src 'self' data:; object-src 'none'; "
    "base-uri 'none'; frame-ancestors 'none'"
)
"""Same-origin only; Plotly sets inline styles and exports PNGs through data: and blob: URLs."""
CACHE = "no-cache"
"""Revalidate on every load (cheap: ETag / Last-Modified), so a new version is never stale."""


@lru_cache(maxsize=1)
def plotly_js() -> Path:
    """Path of ``plotly.min.js`` inside the installed ``plotly`` package (404 when it is absent)."""
    spec = importlib.util.find_spec("plotly")
    if spec is None or not spec.submodule_search_locations:
        raise FileNotFoundError("the Python package 'plotly' is not installed")
    path = Path(next(iter(spec.submodule_search_locations))) / "package_data" / "plotly.min.js"
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing from the plotly package")
    return path


def _file(path: Path, headers: dict[str, str] | None = None) -> FileResponse:
    return FileResponse(
        path,
        media_type=MEDIA_TYPES[path.suffix],
        headers={"Cache-Control": CACHE, "X-Content-Type-Options": "nosniff", **(headers or {})},
    )


@router.get("/", summary="The playground page")
def index() -> FileResponse:
    return _file(STATIC_DIR / "index.html", {"Content-Security-Policy": CSP})


@router.get("/static/plotly.min.js", summary="Plotly, from the Python plotly package")
def plotly() -> FileResponse:
    try:
        return _file(plotly_js())
    except FileNotFoundError as e:
        raise HTTPException(
            404, "plotly.min.js is not available: install the plotly package"
        ) from e


@router.get("/static/{name}", summary="The playground's script and style sheet")
def static(name: str) -> FileResponse:
    # Only the files shipped in service/static/, by exact name: no paths, no traversal.
    allowed = {p.name: p for p in STATIC_DIR.iterdir() if p.suffix in (".js", ".css")}
    if name not in allowed:
        raise HTTPException(404, "no such static file")
    return _file(allowed[name])

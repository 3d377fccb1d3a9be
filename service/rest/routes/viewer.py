"""GET / — the designer page: draw specified nodes and their motions and watch the solution space
of an unspecified node (computed in the browser, Eqs. 4–6), or pick an auxetic sheet, an
allosteric pair or a named example; design, play the finite motion, refine and certify as jobs,
read the report, download every export. Plain static files shipped in the package
(service/rest/static: HTML, CSS, vanilla JavaScript drawing SVG); no CDN, no build step."""

from __future__ import annotations

from importlib.resources import files

from fastapi import APIRouter, HTTPException
from fastapi.responses import HTMLResponse, Response

router = APIRouter(tags=["viewer"], include_in_schema=False)

STATIC = files("zeromode.service.rest") / "static"
# The files the page loads, with their media types; nothing else is served from the folder.
ASSETS = {"designer.js": "text/javascript", "solution_space.js": "text/javascript", "landscape.js": "text/javascript",
          "designer.css": "text/css"}


@router.get("/", response_class=HTMLResponse)
def viewer_page() -> HTMLResponse:
    return HTMLResponse((STATIC / "index.html").read_text(encoding="utf-8"))


@router.get("/viewer/{name}")
def viewer_asset(name: str) -> Response:
    if name not in ASSETS:
        raise HTTPException(404, detail={"code": "not_found", "message": f"the viewer has no file {name!r}."})
    return Response((STATIC / name).read_bytes(), media_type=ASSETS[name], headers={"cache-control": "no-cache"})

"""GET /health."""

from fastapi import APIRouter
from pydantic import BaseModel

from zeromode.service import __version__

router = APIRouter(tags=["health"])


class Health(BaseModel):
    status: str
    version: str


@router.get("/health", response_model=Health)
async def health() -> dict:
    # async: served on the event loop, never queued behind compute in the thread pool.
    return {"status": "ok", "version": __version__}

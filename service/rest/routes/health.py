"""GET /health."""

from fastapi import APIRouter, Request
from pydantic import BaseModel, Field

from zeromode.service import __version__

router = APIRouter(tags=["health"])


class Health(BaseModel):
    status: str
    version: str
    engine: str = Field(
        description="The job engine (Dask): 'running', or 'idle' until the first job (or, with "
        "offloading on, work to adopt or a database shared by replicas, while it starts and between "
        "the retries of a failed start)."
    )
    kernels: str = Field(
        description="The analysis's compiled kernels: 'compiling' while the service loads them at "
        "startup (compiles them, in a fresh environment), then 'ready'. A request that needs one "
        "before waits for it; the wait is not charged to its time budget."
    )


@router.get("/health", response_model=Health)
async def health(request: Request) -> dict:
    # async: served on the event loop, never queued behind compute in the thread pool.
    jobs = request.app.state.jobs
    running = jobs is not None and jobs.engine.started
    kernels = "ready" if request.app.state.kernels_ready.is_set() else "compiling"
    return {"status": "ok", "version": __version__, "engine": "running" if running else "idle", "kernels": kernels}

"""GET /v1/examples — the paper's named cases as ready request bodies."""

from fastapi import APIRouter, HTTPException

from zeromode.service.wire.examples import (
    example_description,
    example_endpoint,
    example_names,
    example_request,
)
from zeromode.service.wire.schemas.common import ErrorResponse
from zeromode.solver.errors import InvalidInput

router = APIRouter(prefix="/v1", tags=["examples"])


@router.get("/examples")
def list_examples() -> list[dict]:
    """Names, descriptions and endpoints (the path each request is for) of the built-in examples."""
    return [{"name": n, "description": example_description(n), "endpoint": example_endpoint(n)} for n in example_names()]


@router.get(
    "/examples/{name}/request",
    responses={404: {"model": ErrorResponse, "description": "No example of that name."}},
)
def get_example_request(name: str) -> dict:
    """The request body of a named example, ready to POST to its endpoint (/v1/design unless
    GET /v1/examples names another)."""
    try:
        return example_request(name)
    except InvalidInput as exc:
        raise HTTPException(404, detail={"code": exc.code, "message": exc.message}) from exc

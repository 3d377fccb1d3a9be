"""zeromode_client — a typed Python client (sync and async) for the zeromode REST service.

Example:

    from zeromode_client import Client, Frame

    with Client("http://127.0.0.1:8000") as client:
        triangle = Frame([[0, 0], [1, 0], [0, 1]], [[0, 1], [1, 2], [0, 2]])
        print(client.analyze(triangle).zero_modes)  # 3: the rigid motions of the plane
"""

from zeromode_client._client import AsyncClient, Client
from zeromode_client._core import DEFAULT_TIMEOUT
from zeromode_client._core import VERSION as __version__
from zeromode_client._errors import ZeromodeConnectionError, ZeromodeError, ZeromodeTimeoutError
from zeromode_client._models import (
    Analysis,
    Design,
    EpsilonCurve,
    ExportFile,
    Frame,
    Health,
    JobStatus,
    RankGap,
    Result,
    SolutionSpace,
    SweepPoint,
    SweepProgress,
    SweepStatus,
)

__all__ = [
    "DEFAULT_TIMEOUT",
    "Analysis",
    "AsyncClient",
    "Client",
    "Design",
    "EpsilonCurve",
    "ExportFile",
    "Frame",
    "Health",
    "JobStatus",
    "RankGap",
    "Result",
    "SolutionSpace",
    "SweepPoint",
    "SweepProgress",
    "SweepStatus",
    "ZeromodeConnectionError",
    "ZeromodeError",
    "ZeromodeTimeoutError",
    "__version__",
]

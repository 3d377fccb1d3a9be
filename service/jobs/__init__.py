"""The job engine: job and sweep records (``store``), the work of one job on a Dask worker
(``tasks``, running the library's operations), the Dask cluster (``cluster``), the engine that
runs and records jobs (``engine``), sweeps (``sweeps``) and the admission limits (``manager``).
It imports the wire format and the library; nothing of the REST layer."""

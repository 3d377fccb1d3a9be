"""The REST layer: the FastAPI app (``app``), its routes (parse → call an operation →
serialise), the body reader, the error handlers and the offload of heavy requests to the job
engine. It imports every layer below it; only the CLI imports it."""

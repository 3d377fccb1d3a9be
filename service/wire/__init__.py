"""The wire format, the lowest service layer: the settings and the request limits they set,
request and response schemas (pydantic), error bodies, and ``responses.py``, the one place
solver results become response bodies. It imports the solver, viz and export only."""

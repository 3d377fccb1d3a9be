"""Errors the solver raises. Each carries a fixed snake_case ``code`` and one human sentence."""


class DomainError(Exception):
    """The mathematics says no (e.g. ``no_solution``): the request was well formed."""

    def __init__(self, code: str, message: str):
        super().__init__(message)
        self.code = code
        self.message = message


class InvalidInput(DomainError):
    """The request itself is malformed (bad shape, NaN, duplicate edge, ...)."""

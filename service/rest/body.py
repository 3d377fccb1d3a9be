"""What a request body must be before any route parses it: bytes counted as they arrive, gzip
decoded while streaming, UTF-8 JSON of bounded nesting.

The guard reads the whole body (the routes parse JSON, which needs all of it anyway), so the
limit holds on the bytes actually received — a chunked body, or one whose Content-Length lies,
is refused with 413 as soon as it passes ``max_body_bytes``, and a gzip body is refused as soon
as its *decoded* size passes the limit (a gzip bomb costs at most the limit). The checked body is
then handed on as one message, with a Content-Length that is true.
"""

from __future__ import annotations

import re
import zlib
from dataclasses import dataclass

import numpy as np
from starlette.datastructures import MutableHeaders
from starlette.types import Receive, Scope

# JSON nesting deeper than this is refused before parsing: no request of the API nests deeper
# than 6 (sweep grids included), and Python's parser fails with a RecursionError near 1000.
MAX_JSON_DEPTH = 64
# Content types a JSON endpoint accepts (application/json and any +json type).
_JSON_TYPE = re.compile(r"^application/([a-z0-9.+-]*\+)?json\s*(;.*)?$", re.IGNORECASE)
# String literals, removed before brackets are counted (a "[" inside a string is not nesting).
_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)


@dataclass(frozen=True)
class BodyRefusal(Exception):
    """The body cannot be served: HTTP ``status`` with an error ``code`` and one sentence."""

    status: int
    code: str
    message: str


def json_depth(body: bytes) -> int:
    """Deepest nesting of arrays and objects in a JSON text (strings ignored); linear time."""
    text = np.frombuffer(_STRING.sub(b"", body), dtype=np.uint8)
    opens = (text == ord("[")) | (text == ord("{"))
    closes = (text == ord("]")) | (text == ord("}"))
    where = np.flatnonzero(opens | closes)  # only the brackets take part in the running sum
    return int(np.cumsum(opens[where].astype(np.int32) * 2 - 1).max(initial=0))


def check_json_text(body: bytes, content_type: str | None) -> None:
    """Refuse what is not a UTF-8 JSON text of bounded depth (an empty body is the route's)."""
    if not body:
        return
    if content_type is not None and not _JSON_TYPE.match(content_type):
        raise BodyRefusal(415, "unsupported_media_type", f"the body must be application/json, not {content_type[:60]}.")
    if b"\x00" in body or body.startswith((b"\xef\xbb\xbf", b"\xff\xfe", b"\xfe\xff")):
        raise BodyRefusal(400, "not_utf8", "the body must be UTF-8 JSON without a byte-order mark.")
    try:
        body.decode("utf-8")
    except UnicodeDecodeError as error:
        raise BodyRefusal(400, "not_utf8", f"the body is not UTF-8 (byte {error.start}).") from None
    if json_depth(body) > MAX_JSON_DEPTH:
        raise BodyRefusal(400, "too_deep", f"the JSON nests deeper than {MAX_JSON_DEPTH} levels.")


class _Decoder:
    """Identity or streaming gzip decoding with the decoded size capped at ``limit`` bytes."""

    def __init__(self, encoding: str | None, limit: int):
        encoding = (encoding or "identity").strip().lower()
        if encoding not in ("identity", "gzip"):
            raise BodyRefusal(415, "unsupported_encoding", f"Content-Encoding {encoding[:30]} is not accepted (gzip or none).")
        self.gzip = zlib.decompressobj(16 + zlib.MAX_WBITS) if encoding == "gzip" else None
        self.limit = limit
        self.received = 0
        self.parts: list[bytes] = []
        self.size = 0

    def feed(self, chunk: bytes) -> None:
        self.received += len(chunk)
        if self.gzip is None:
            self._keep(chunk)
            return
        try:
            # At most limit + 1 decoded bytes per step: a bomb never expands past the limit.
            data = self.gzip.decompress(chunk, self.limit + 1 - self.size)
            self._keep(data)
            while self.gzip.unconsumed_tail:
                self._keep(self.gzip.decompress(self.gzip.unconsumed_tail, self.limit + 1 - self.size))
        except zlib.error:
            raise BodyRefusal(400, "invalid_encoding", "the body is not valid gzip.") from None

    def _keep(self, data: bytes) -> None:
        self.size += len(data)
        if self.size > self.limit or self.received > self.limit:
            raise BodyRefusal(413, "body_too_large", f"the request body has more than {self.limit} bytes; the limit is {self.limit}.")
        self.parts.append(data)

    def body(self) -> bytes:
        if self.gzip is not None and not self.gzip.eof:
            raise BodyRefusal(400, "invalid_encoding", "the gzip body ends before its end marker.")
        return b"".join(self.parts)


async def read_checked_body(scope: Scope, receive: Receive, limit: int) -> bytes:
    """The request body, decoded and checked (``BodyRefusal`` otherwise)."""
    headers = MutableHeaders(scope=scope)
    decoder = _Decoder(headers.get("content-encoding"), limit)
    more = True
    while more:
        message = await receive()
        if message["type"] == "http.disconnect":
            raise BodyRefusal(400, "client_disconnected", "the client closed the connection.")
        decoder.feed(message.get("body", b""))
        more = message.get("more_body", False)
    body = decoder.body()
    check_json_text(body, headers.get("content-type"))
    # The app downstream sees the decoded body with a true length and no encoding.
    del headers["content-encoding"]
    del headers["transfer-encoding"]
    headers["content-length"] = str(len(body))
    return body


def replay(body: bytes, receive: Receive) -> Receive:
    """A receive callable that yields ``body`` once, then waits on the real connection (so a
    later disconnect still reaches the app)."""
    sent = False

    async def receive_again():
        nonlocal sent
        if not sent:
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return receive_again


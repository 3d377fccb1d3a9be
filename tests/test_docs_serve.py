"""The guide served locally by the one command the README documents: `.venv/bin/mkdocs serve`
(run from the checkout, as shown), answering at http://127.0.0.1:8001/ with the guide's home page
and an executed tutorial. The strict build itself is the README's test command; this checks the
command a reader is told to use while editing."""

from __future__ import annotations

import re
import shlex
import subprocess
import time
from pathlib import Path

import httpx
import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
# The whole build runs before the server answers (the tutorials are executed): ~30 s of CPU.
START_WAIT_S = 600.0


def test_mkdocs_serve_as_the_readme_shows_it():
    shown = re.search(r"`(\.venv/bin/mkdocs serve)` shows it at <(http://[0-9.:]+/)>", README)
    assert shown, "the README names the command that serves the guide, and where"
    command, url = shown.groups()
    server = subprocess.Popen(shlex.split(command), cwd=ROOT,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + START_WAIT_S
        while True:
            if server.poll() is not None:
                pytest.fail(f"mkdocs serve exited {server.returncode}: {server.stderr.read()[-2000:]}")
            try:
                home = httpx.get(url, timeout=10)
                break
            except httpx.TransportError:
                assert time.monotonic() < deadline, f"mkdocs serve did not answer at {url}"
                time.sleep(1.0)
        assert home.status_code == 200 and "zeromode" in home.text
        tutorial = httpx.get(url + "tutorials/fig3_outward/", timeout=30)
        # Executed: the notebook's output cells are in the page (stored without outputs).
        assert tutorial.status_code == 200 and "jp-OutputArea" in tutorial.text
    finally:
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait(timeout=30)

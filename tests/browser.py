"""Debian's chromium driven by Playwright for the page tests (tests/test_viewer.py,
tests/test_designer.py): no browser download, ``executable_path`` points at the system's binary.
Without them a test is skipped with the way to get them — except under CI (``CI=true``), where
it fails: CI must run it."""

from __future__ import annotations

import shutil

import pytest
from required import missing

CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]
HOW_TO_GET_ONE = (
    "the page tests need a Chromium and Playwright's Python package: on Debian or Ubuntu "
    "`apt-get install -y chromium` and `pip install playwright` (no `playwright install`: the "
    "system's /usr/bin/chromium is used)"
)


def chromium_path() -> str | None:
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.fixture(scope="module")
def browser():
    path = chromium_path()
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        path = None
    if path is None:
        missing("the page tests", HOW_TO_GET_ONE)
    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=path, args=CHROMIUM_ARGS)
        yield chromium
        chromium.close()


def console_problems(page) -> list[str]:
    """The page's console errors and uncaught exceptions, collected as they happen."""
    problems: list[str] = []
    page.on("console", lambda msg: problems.append(msg.text) if msg.type == "error" else None)
    page.on("pageerror", lambda exc: problems.append(str(exc)))
    return problems


@pytest.fixture(scope="module")
def designer_url(dask_scheduler):
    """The real app served by uvicorn on loopback for the designer page (GET /), its jobs on the
    session's Dask cluster."""
    from tests.client.conftest import served
    from zeromode.service.rest.app import create_app
    from zeromode.service.wire.settings import Settings

    with served(create_app(Settings(dask_scheduler=dask_scheduler))) as url:
        yield url


def open_page(browser, url, width=1280):
    """A new page of the designer at ``url``, ``width`` px wide, its examples listed; (page, the
    list its console errors and uncaught exceptions are collected in)."""
    from benchmarks.bench_designer import goto_designer

    page = browser.new_page(viewport={"width": width, "height": 900}, accept_downloads=True)
    problems = console_problems(page)
    return goto_designer(page, url), problems

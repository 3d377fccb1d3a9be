"""Every fenced code block of the docs runs as written (issue #38): README.md, the client's
README and docs/**/*.md (any Markdown file matched by DOCUMENTS, so blocks that move stay tested).
The tutorials (docs/tutorials/*.ipynb) are not run here: the guide's build (``mkdocs build
--strict``, the last step of CI's command) executes them; here they are checked to be stored
without outputs. The README is the front page: its two commands, a short quickstart, and links
that stay inside the repository (issue #39).

How a block runs, by its language (every block must name one):
- bash, sh, shell: with bash (``set -eo pipefail``; an HTTP error answer fails ``curl``), in
  document order, in one terminal per document: a temporary directory, where ``.venv`` is the
  virtual environment running these tests, and an environment whose PATH does not hold it
  until a block activates it (``source .venv/bin/activate``): what a block exports, the next has.
- console: ``$ `` lines are typed as above; the lines below one are its promised output.
- python: a script, run in a subprocess in the document's directory.
- json: a file or a request, as its directive says (below).
- text: not code (diagrams, layouts); not run.

Promised outputs. ``# → OUTPUT`` at the end of a Python expression statement (or alone on the
line after it): the expression shows OUTPUT (its repr; a tuple's items joined by ", ";
``print(x)`` shows ``str(x)``). On its own line in a shell block: what the commands since the
last promise printed. A JSON OUTPUT (``{`` or ``[``) matches the printed document, ``…`` being any
value, or the remaining keys or items; elsewhere ``…`` (or ``...``) is any text. Every promise of
a Python script must be reached.

Directives: ``<!-- snippet: DIRECTIVE -->`` on the line before a block (invisible on the page).
- ``ci``: the command CI runs, not run again here: it must equal .ci/run's command.
- ``install``: commands that CI's command covers (the venv, ``pip install`` of packages it
  installs), then at most ``zeromode serve``, which is how this test starts its server; not run.
- ``synopsis``: usage lines (docs/reference/cli.md) ``zeromode SUB [--option …]``: every subcommand and option exists in
  the CLI (its ``--help``), and every subcommand of the CLI is listed.
- ``file NAME``: the block is the file NAME, written into the document's directory where it
  stands (the sentence before it names NAME, so the reader sees which file it is).
- ``request METHOD PATH [as FIELD]``: a request body (or its FIELD), sent to the server: 2xx.
  With ``…`` placeholders, its keys must be fields of the endpoint's request schema instead.
- ``container``: ``docker build -t TAG .`` and ``docker run … TAG``, not run (no container engine
  in CI; tests/container replays the Dockerfile): the tag is the one built, each ``-p`` port is
  one the Dockerfile exposes, each ``-e`` variable one the Dockerfile or the settings read.

``localhost:8000`` and ``127.0.0.1:8000`` become the test server's loopback port. The server is
``zeromode serve`` with the user's default settings (job records in a temporary file).
Each terminal and the server have a temporary HOME, so nothing is written outside the checkout
(numba's cache, beside its module) and the system's temporary directory.
"""

from __future__ import annotations

import ast
import io
import itertools
import json
import os
import re
import shlex
import subprocess
import sys
import tokenize
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest
from snippet_expect import ELLIPSIS, json_pattern, output_matches
from test_sweeps import zeromode_service

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = ("README.md", "clients/python/README.md", "docs/**/*.md")
SHELL = {"bash", "sh", "shell", "console"}
LANGUAGES = SHELL | {"python", "json", "text"}
DOCS_ADDRESS = re.compile(r"\b(?:localhost|127\.0\.0\.1):8000\b")
DIRECTIVE = re.compile(r"<!--\s*snippet:\s*(.*?)\s*-->")
PROMISE = re.compile(r"#\s*→\s*(.*?)\s*$")
BLOCK_TIMEOUT_S = 300
VENV = Path(sys.prefix)

# Blocks that fail only because of a known bug fixed on another branch: (document, a line of the
# block) → the bug. strict: such a test fails once the fix lands, and its entry is then removed.
KNOWN_BUGS: dict[tuple[str, str], str] = {}


@dataclass(frozen=True)
class Block:
    document: str  # relative to ROOT
    line: int  # of the block's first line of code, 1-based
    language: str
    code: str
    directive: str  # "" without one
    before: str  # the paragraph above the block, as the reader sees it

    @property
    def where(self) -> str:
        return f"{self.document}:{self.line}"

    def runs_against_server(self) -> bool:
        if self.language in SHELL:
            return self.directive not in ("ci", "install", "synopsis", "container")
        return self.language == "python" or self.directive.startswith("request ")


def documents() -> list[str]:
    paths = [ROOT / DOCUMENTS[0], ROOT / DOCUMENTS[1], *sorted(ROOT.glob(DOCUMENTS[2]))]
    return [str(p.relative_to(ROOT)) for p in paths]


def blocks_of(document: str) -> list[Block]:
    """The fenced code blocks of a Markdown file, each with its directive and the paragraph above."""
    lines = (ROOT / document).read_text().splitlines()
    blocks, i = [], 0
    while i < len(lines):
        fence = re.match(r"\s*(`{3,}|~{3,})\s*(\S*)", lines[i])
        if not fence:
            i += 1
            continue
        closing = re.compile(f"{re.escape(fence.group(1)[0])}{{{len(fence.group(1))},}}\\s*")
        end = next((j for j in range(i + 1, len(lines)) if closing.fullmatch(lines[j].strip())), len(lines))
        above = i - 1
        while above >= 0 and not lines[above].strip():
            above -= 1
        directive = DIRECTIVE.fullmatch(lines[above].strip()) if above >= 0 else None
        if directive:
            above -= 1
            while above >= 0 and not lines[above].strip():
                above -= 1
        top = above
        while top > 0 and lines[top - 1].strip() and not lines[top - 1].lstrip().startswith(("```", "~~~")):
            top -= 1
        blocks.append(Block(document, i + 2, fence.group(2).lower(), "\n".join(lines[i + 1:end]),
                            directive.group(1) if directive else "", "\n".join(lines[top:above + 1])))
        i = end + 1
    return blocks


ALL_BLOCKS = [block for document in documents() for block in blocks_of(document)]


def known_bug(block: Block) -> str | None:
    return next((reason for (document, line), reason in KNOWN_BUGS.items()
                 if document == block.document and line in block.code), None)


def block_params() -> list:
    return [pytest.param(block, id=f"{block.where}-{block.language or 'none'}",
                         marks=[pytest.mark.xfail(strict=True, reason=reason)] if (reason := known_bug(block)) else [])
            for block in ALL_BLOCKS]


# --- the server and each document's terminal --------------------------------------------------


@pytest.fixture(scope="module")
def docs_server(tmp_path_factory: pytest.TempPathFactory):
    """``zeromode serve`` (the README's first command) on a free loopback port, with the user's
    default settings (offloading on) but its job records in a temporary SQLite file: its URL."""
    directory = tmp_path_factory.mktemp("docs-server")
    env = {"ZEROMODE_OFFLOAD": "true", "ZEROMODE_DATABASE_URL": f"sqlite:///{directory}/jobs.sqlite3",
           "HOME": str(directory)}
    with zeromode_service(directory, env, "serve") as (url, _):
        yield url


class Terminal:
    """One reader going through one document: its directory (``.venv`` in it), the environment
    its blocks leave, and what became of each block run so far."""

    def __init__(self, directory: Path, url: str | None):
        self.directory = directory / "work"
        self.state = directory / "state"
        self.directory.mkdir()
        self.state.mkdir()
        (self.directory / ".venv").symlink_to(VENV, target_is_directory=True)
        self.url = url
        venv_bin = str(VENV / "bin")
        path = [p for p in os.environ.get("PATH", "").split(os.pathsep) if p and p != venv_bin]
        self.env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONHOME", "ZEROMODE_OFFLOAD")}
        # A home of its own: caches and configuration (matplotlib, Dask) stay in the temporary directory.
        self.env |= {"PATH": os.pathsep.join(path), "HOME": str(directory)}
        self.env = {k: v for k, v in self.env.items() if not k.startswith(("XDG_", "MPLCONFIGDIR", "DASK_"))}
        self.cwd = self.directory
        self.outcomes: dict[int, BaseException | None] = {}

    def address(self, text: str) -> str:
        return DOCS_ADDRESS.sub(self.url.removeprefix("http://"), text) if self.url else text

    def run_through(self, block: Block) -> None:
        """Run the document's blocks up to ``block`` that have not run yet (in order, as a reader
        would), then raise what ``block`` raised."""
        for earlier in blocks_of(block.document):
            if earlier.line > block.line:
                break
            if earlier.line not in self.outcomes:
                try:
                    run_block(earlier, self)
                    self.outcomes[earlier.line] = None
                # Whatever a block raised is its own test's outcome, raised there.
                except (Exception, pytest.fail.Exception, pytest.skip.Exception) as error:  # noqa: BLE001
                    self.outcomes[earlier.line] = error
        if (error := self.outcomes[block.line]) is not None:
            raise error


@pytest.fixture(scope="module")
def terminals() -> dict[str, Terminal]:
    """Each document's terminal, opened by its first block."""
    return {}


@pytest.mark.parametrize("block", block_params())
def test_snippet_runs_as_written(block: Block, terminals, tmp_path_factory, request):
    if not (VENV / "bin" / "activate").exists():
        pytest.skip(f"the tests run outside a virtual environment such as the README's ({VENV})")
    if block.document not in terminals:
        needs_server = any(b.runs_against_server() for b in blocks_of(block.document))
        url = request.getfixturevalue("docs_server") if needs_server else None
        terminals[block.document] = Terminal(tmp_path_factory.mktemp("docs"), url)
    terminals[block.document].run_through(block)


def test_every_block_names_a_language_this_test_knows():
    unknown = [f"{b.where}: ```{b.language}" for b in ALL_BLOCKS if b.language not in LANGUAGES]
    assert not unknown, "name one of " + ", ".join(sorted(LANGUAGES)) + " for " + "; ".join(unknown)


# --- running one block ------------------------------------------------------------------------


def run_block(block: Block, terminal: Terminal) -> None:
    directive, _, argument = block.directive.partition(" ")
    if block.language == "text":
        return
    if directive == "ci":
        check_ci(block)
    elif directive == "install":
        check_install(block)
    elif directive == "synopsis":
        check_synopsis(block)
    elif directive == "container":
        check_container(block)
    elif directive == "file":
        write_file(block, argument, terminal)
    elif directive == "request":
        send_request(block, argument, terminal)
    elif block.language in SHELL:
        run_shell(block, terminal)
    elif block.language == "python":
        run_python(block, terminal)
    else:
        pytest.fail(f"{block.where}: a {block.language} block needs a directive (`file NAME` or `request …`)")


def commands(code: str) -> list[str]:
    """The commands of a shell block: lines without their comments, continuations joined, split at &&."""
    found = []
    for line in re.sub(r"\\\n", " ", code).splitlines():
        words = shlex.split(line, comments=True)
        while words:
            step = words.index("&&") if "&&" in words else len(words)
            found.append(shlex.join(words[:step]))
            words = words[step + 1:]
    return found


def ci_command() -> str:
    """The README's test command as .ci/run runs it: its line from ``python3 -m venv`` on (what
    comes before, e.g. variables, is CI's own)."""
    line = next(line for line in (ROOT / ".ci" / "run").read_text().splitlines()[::-1] if "python3 -m venv" in line)
    return line[line.index("python3 -m venv"):]


def check_ci(block: Block) -> None:
    assert commands(block.code) == commands(ci_command()), (
        f"{block.where} is marked as CI's command but .ci/run runs `{ci_command()}`")


def pip_packages(command: str) -> set[str] | None:
    """The packages a ``pip install`` command installs (``.[test]`` counts as ``.``), None for
    another command."""
    words = shlex.split(command)
    if len(words) < 2 or Path(words[0]).name != "pip" or words[1] != "install":
        return None
    return {re.sub(r"\[.*\]$", "", w) for w in words[2:] if not w.startswith("-")}


def check_install(block: Block) -> None:
    ci = commands(ci_command())
    ci_packages = set().union(*(p for c in ci if (p := pip_packages(c)) is not None))
    steps = commands(block.code)
    if steps and Path(shlex.split(steps[-1])[0]).name == "zeromode":
        assert shlex.split(steps.pop())[1:] == ["serve"], (
            f"{block.where}: the service is started as `zeromode serve` (this test's server)")
    for step in steps:
        packages = pip_packages(step)
        assert step in ci or (packages is not None and packages <= ci_packages), (
            f"{block.where}: `{step}` is not covered by CI's command `{ci_command()}`")


def check_synopsis(block: Block) -> None:
    zeromode = str(VENV / "bin" / "zeromode")
    overview = subprocess.run([zeromode, "--help"], capture_output=True, text=True, check=True).stdout
    subcommands = set(re.search(r"\{([\w,-]+)\}", overview).group(1).split(","))
    listed = set()
    for usage in (u.strip() for line in block.code.splitlines() for u in line.split("#")[0].split(" | ")):
        if not usage:
            continue
        words = usage.split()
        assert words[0] == "zeromode", f"{block.where}: `{usage}` is not a zeromode command"
        sub = words[1] if len(words) > 1 and not words[1].startswith("-") else None
        assert sub is None or sub in subcommands, f"{block.where}: `zeromode {sub}` is no subcommand"
        listed.add(sub)
        helped = subprocess.run([zeromode, *([sub] if sub else []), "--help"], capture_output=True, text=True,
                                check=True).stdout
        for option in re.findall(r"(?<![\w-])(--?[A-Za-z][\w-]*)", usage):
            assert re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", helped), (
                f"{block.where}: `zeromode {sub or ''}` has no option {option}")
    assert subcommands <= listed, f"{block.where} does not list {sorted(subcommands - listed)}"


def check_container(block: Block) -> None:
    from zeromode.service.wire.settings import Settings

    dockerfile = (ROOT / "Dockerfile").read_text()
    exposed = set(re.findall(r"^EXPOSE\s+(\d+)", dockerfile, flags=re.MULTILINE))
    settings = {f"ZEROMODE_{name.upper()}" for name in Settings.model_fields}
    tags = []
    for step in commands(block.code):
        words = shlex.split(step)
        assert words[:2] in (["docker", "build"], ["docker", "run"]), f"{block.where}: `{step}`"
        if words[1] == "build":
            assert words[-1] == "." and "-t" in words, f"{block.where}: `{step}` builds this folder with a tag"
            tags.append(words[words.index("-t") + 1])
            continue
        assert words[-1] in tags, f"{block.where}: `{step}` runs an image the block did not build"
        for flag, value in itertools.pairwise(words):
            if flag == "-p":
                assert value.rsplit(":", 1)[-1] in exposed, f"{block.where}: the Dockerfile does not expose {value}"
            if flag == "-e":
                name = value.split("=", 1)[0]
                assert name in settings or name in dockerfile, f"{block.where}: nothing reads {name}"


def write_file(block: Block, name: str, terminal: Terminal) -> None:
    assert name in block.before, f"{block.where}: the text before the block does not name {name}"
    if name.endswith(".json"):
        json.loads(block.code)
    (terminal.cwd / name).write_text(block.code + "\n")


def send_request(block: Block, argument: str, terminal: Terminal) -> None:
    method, path, *rest = argument.split()
    body = json.loads(terminal.address(block.code)) if not ELLIPSIS.search(block.code) else None
    if body is None:
        schema = httpx.get(f"{terminal.url}/openapi.json").json()
        operation = schema["paths"][path][method.lower()]
        request_schema = operation["requestBody"]["content"]["application/json"]["schema"]
        if rest:  # as FIELD
            request_schema = properties(request_schema, schema)[rest[1]]
        unknown = unknown_keys(json_pattern(block.code), request_schema, schema)
        assert not unknown, f"{block.where}: {sorted(unknown)} are not fields of {method} {path}"
        return
    if rest:
        body = {rest[1]: body}
    response = httpx.request(method, terminal.url + path, json=body, timeout=60)
    assert response.is_success, f"{block.where}: {method} {path} answered {response.status_code} {response.text}"


def resolve(node: dict, schema: dict) -> dict:
    while "$ref" in node:
        node = schema["components"]["schemas"][node["$ref"].rsplit("/", 1)[1]]
    return node


def properties(node: dict, schema: dict) -> dict[str, dict]:
    """Every property an object schema (or any branch of it) names."""
    node = resolve(node, schema)
    found = dict(node.get("properties", {}))
    for branch in node.get("anyOf", []) + node.get("oneOf", []) + node.get("allOf", []):
        found |= properties(branch, schema)
    return found


def unknown_keys(value, node: dict, schema: dict, prefix: str = "") -> set[str]:
    if isinstance(value, dict):
        known = properties(node, schema)
        missing = {prefix + k for k in value if k not in known and not k.startswith("⟨")}
        for key, item in value.items():
            if key in known:
                missing |= unknown_keys(item, known[key], schema, f"{prefix}{key}.")
        return missing
    if isinstance(value, list):
        items = resolve(node, schema).get("items", {})
        return set().union(*(unknown_keys(item, items, schema, prefix) for item in value))
    return set()


def run_shell(block: Block, terminal: Terminal) -> None:
    """The block in bash, with a marker printed after each group of commands that promises an
    output, so that each promise is held against what its own commands printed."""
    segments = shell_segments(block)
    script = ["set -eo pipefail",
              'trap \'env -0 > "$SNIPPET_STATE/env"; pwd > "$SNIPPET_STATE/cwd"\' EXIT',
              'curl() { command curl --fail-with-body "$@"; }']
    for number, (code, promise) in enumerate(segments):
        script.append(terminal.address(code))
        if promise is not None:
            script.append(f"printf '\\036{number}\\036\\n'")
    result = subprocess.run(["bash", "-c", "\n".join(script)], check=False, cwd=terminal.cwd, capture_output=True, text=True,
                            env={**terminal.env, "SNIPPET_STATE": str(terminal.state)}, timeout=BLOCK_TIMEOUT_S)
    if (terminal.state / "env").exists():
        carried = (terminal.state / "env").read_bytes().decode().split("\0")
        terminal.env = dict(v.split("=", 1) for v in carried if "=" in v and not v.startswith(("_=", "SHLVL=")))
        terminal.cwd = Path((terminal.state / "cwd").read_text().strip())
    assert result.returncode == 0, (
        f"{block.where} exited {result.returncode}\n--- block ---\n{block.code}\n"
        f"--- stdout ---\n{result.stdout[-3000:]}\n--- stderr ---\n{result.stderr[-3000:]}")
    printed = re.split(r"\x1e\d+\x1e\n", result.stdout)
    for (code, promise), output in zip(segments, printed, strict=False):
        if promise is not None:
            assert output_matches(output, promise), (
                f"{block.where}: the docs promise `{promise}` from\n{code}\nwhich printed\n{output[:3000]}")


def shell_segments(block: Block) -> list[tuple[str, str | None]]:
    """(commands, the output they promise or None): ``# →`` lines close a segment; in a console
    block, a ``$ `` line is a command and the lines below it its output."""
    segments: list[tuple[str, str | None]] = []
    if block.language == "console":
        for chunk in re.split(r"^\$ ", block.code, flags=re.MULTILINE)[1:]:
            command, _, output = chunk.partition("\n")
            segments.append((command, output if output.strip() else None))
        return segments
    code: list[str] = []
    for line in block.code.splitlines():
        if (promise := PROMISE.match(line.strip())) and line.lstrip().startswith("#"):
            segments.append(("\n".join(code), promise.group(1)))
            code = []
        else:
            code.append(line)
    return [*segments, ("\n".join(code), None)]


def run_python(block: Block, terminal: Terminal) -> None:
    """The block as a script (``python snippet.py`` in the document's directory), its promised
    outputs checked where they are evaluated; every promise must be reached."""
    script, promised = python_with_promises(block)
    path = terminal.cwd / f"snippet_{Path(block.document).stem}_{block.line}.py"
    path.write_text("from snippet_expect import expect as __expect__  # tests/test_snippets.py\n"
                    + terminal.address(script))
    log = terminal.state / f"{path.stem}.promises"
    log.unlink(missing_ok=True)
    env = {**terminal.env, "PYTHONPATH": str(ROOT / "tests"), "SNIPPET_EXPECT_LOG": str(log)}
    result = subprocess.run([sys.executable, path.name], check=False, cwd=terminal.cwd, capture_output=True, text=True, env=env,
                            timeout=BLOCK_TIMEOUT_S)
    assert result.returncode == 0, (
        f"{block.where} (script line n is the block's line n − 1) exited {result.returncode}\n"
        f"--- stdout ---\n{result.stdout[-3000:]}\n--- stderr ---\n{result.stderr[-5000:]}")
    reached = set(log.read_text().split()) if log.exists() else set()
    assert promised <= reached, f"{block.where}: promises never evaluated: {sorted(promised - reached)}"


def python_with_promises(block: Block) -> tuple[str, set[str]]:
    """The block with each ``EXPR  # → OUTPUT`` statement as ``__expect__((EXPR), "OUTPUT", where)``
    (lines kept where they were), and the places of its promises."""
    lines = block.code.splitlines()
    promises = {}
    for token in tokenize.generate_tokens(io.StringIO(block.code + "\n").readline):
        if token.type == tokenize.COMMENT and (promise := PROMISE.match(token.string)):
            promises[token.start[0]] = promise.group(1)
    statements = {node.end_lineno: node for node in ast.walk(ast.parse(block.code)) if isinstance(node, ast.Expr)}
    for line in sorted(promises, reverse=True):
        alone = lines[line - 1].lstrip().startswith("#")
        node = statements.get(line - 1 if alone else line)
        where = f"{block.document}:{block.line + line - 1}"
        assert node is not None, f"{where}: `# →` follows no expression statement"
        value, printed = node.value, False
        if (isinstance(value, ast.Call) and isinstance(value.func, ast.Name) and value.func.id == "print"
                and len(value.args) == 1 and not value.keywords):
            value, printed = value.args[0], True
        first, last = value.lineno - 1, value.end_lineno - 1
        text = "\n".join(lines[first:last + 1]).encode()  # ast's columns count UTF-8 bytes
        start = value.col_offset
        end = len(text) - len(lines[last].encode()) + value.end_col_offset
        expression = text[start:end].decode()
        flags = ", printed=True" if printed else ", items=True" if isinstance(value, ast.Tuple) else ""
        call = f"__expect__(({expression}), {promises[line]!r}, {where!r}{flags})"
        lines[first:last + 1] = (text[:start].decode() + call + text[end:].decode()).split("\n")
    return "\n".join(lines) + "\n", {f"{block.document}:{block.line + line - 1}" for line in promises}


# --- the README as a front page (issue #39) ---------------------------------------------------

README_MAX_LINES = 250
QUICKSTART_MAX_LINES = 30
MARKDOWN_LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def test_the_readme_gives_exactly_the_two_commands():
    """One install block that ends by starting the service, one CI block (check_ci holds it to
    .ci/run's command, which builds the guide too), in that order; and the CLI synopsis is kept
    somewhere in the docs (check_synopsis holds it to the CLI)."""
    readme = blocks_of("README.md")
    installs = [b for b in readme if b.directive == "install"]
    cis = [b for b in readme if b.directive == "ci"]
    assert len(installs) == 1 and len(cis) == 1 and installs[0].line < cis[0].line
    assert shlex.split(commands(installs[0].code)[-1])[1:] == ["serve"]
    assert commands(ci_command())[-1] == ".venv/bin/mkdocs build --strict"
    assert any(b.directive == "synopsis" for b in ALL_BLOCKS)


def test_the_readme_is_a_front_page():
    """≤ 250 lines, a quickstart section of ≤ 30 lines with a library and a REST example, and
    every link or picture it references a file or folder of this repository."""
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= README_MAX_LINES
    quickstart = re.search(r"^## Quickstart\n(.*?)(?=^## )", text, flags=re.MULTILINE | re.DOTALL)
    assert quickstart is not None and len(quickstart.group(1).strip().splitlines()) <= QUICKSTART_MAX_LINES
    assert "import zeromode as zm" in quickstart.group(1) and "localhost:8000/v1/" in quickstart.group(1)
    targets = [t.split("#")[0] for t in MARKDOWN_LINK.findall(text)]
    outside = [t for t in targets if re.match(r"[a-z]+:", t) and not t.startswith("http://127.0.0.1")]
    missing = [t for t in targets if not re.match(r"[a-z]+:", t) and not (ROOT / t).exists()]
    assert not outside and not missing, f"outside the repository: {outside}; missing: {missing}"


def test_tutorials_are_stored_without_outputs():
    """The build executes the notebooks; stored outputs would be stale pictures in the repository."""
    notebooks = sorted((ROOT / "docs" / "tutorials").glob("*.ipynb"))
    assert notebooks
    for notebook in notebooks:
        cells = json.loads(notebook.read_text())["cells"]
        stored = [i for i, c in enumerate(cells) if c.get("outputs") or c.get("execution_count")]
        assert not stored, f"{notebook.name}: cells {stored} hold outputs"

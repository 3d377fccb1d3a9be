"""The ``zeromode`` command line: serve the API; analyse, design, plot and export frames; show examples."""

from __future__ import annotations

import os

# zeromode's linear algebra is many small dense problems: a multi-threaded BLAS only contends
# (measured 50× slower per SVD on a busy 2-core machine). Parallelism comes from workers.
# Set before numpy is first imported; uvicorn workers inherit it.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import socket
import sys

# Only the standard library above: `zeromode --help` must not wait for numpy and scipy. Each
# command imports what it needs.


def _load_json(path: str) -> dict:
    with (sys.stdin if path == "-" else open(path)) as fh:
        return json.load(fh)


def _tcp_listener(host: str, port: int) -> socket.socket:
    """A listening socket created with proto=IPPROTO_TCP.

    uvicorn's multi-worker supervisor binds its listener with proto 0; accepted connections
    inherit it and asyncio then never sets TCP_NODELAY, so every keep-alive response waits for
    the client's delayed ACK (~40 ms on Linux; uvicorn issue #3149). Binding it here avoids that.
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((host, port))
    sock.set_inheritable(True)
    return sock


def cmd_serve(args) -> int:
    import uvicorn
    from uvicorn.supervisors import Multiprocess

    print(
        f"zeromode listening on http://{args.host}:{args.port}  (try: curl -s "
        f"http://{args.host}:{args.port}/v1/examples/outward_2d/request | curl -s -H "
        f"'content-type: application/json' -d @- http://{args.host}:{args.port}/v1/design)",
        flush=True,
    )
    from zeromode.service.wire.settings import Settings, server_options

    app = "zeromode.service.rest.app:app"
    options = server_options(Settings())
    # Each uvicorn worker that runs jobs starts its own embedded Dask cluster: together they use
    # one worker process per core.
    os.environ.setdefault("ZEROMODE_DASK_WORKERS", str(max((os.cpu_count() or 1) // max(args.workers, 1), 1)))
    if args.workers <= 1:
        uvicorn.run(app, host=args.host, port=args.port, log_level="info", **options)
        return 0
    config = uvicorn.Config(
        app, host=args.host, port=args.port, workers=args.workers, log_level="info", **options
    )
    Multiprocess(config, sockets=[_tcp_listener(args.host, args.port)]).run()
    return 0


def cmd_analyze(args) -> int:
    """The /v1/analyze answer for a Frame, or for a /v1/analyze request ({"frame", "options"})."""
    from zeromode.operations import endpoints
    from zeromode.operations.documents import validated
    from zeromode.service.wire.schemas.analyze import AnalyzeRequest

    doc = _load_json(args.frame)
    body = endpoints.analyze(validated(doc if "frame" in doc else {"frame": doc}, AnalyzeRequest)).body
    if args.pretty:
        gap = body["rank_gap"]
        print(
            f"N={body['nodes']} N_B={body['edges']} d={body['dim']}  Maxwell count {body['maxwell_count']}\n"
            f"rank C = {body['rank']}  (σ_r = {gap['last_nonzero']:.3e}, σ_r+1 = {gap['first_zero']:.3e})\n"
            f"zero modes {body['zero_modes']} = {body['rigid_body_modes']} rigid + "
            f"{body['nontrivial_zero_modes']} nontrivial;  self-stresses {body['self_stresses']}"
        )
    else:
        print(json.dumps(body, allow_nan=False))
    return 0


def cmd_example(args) -> int:
    from zeromode.service.wire.examples import example_description, example_names, example_request

    if args.action == "list":
        for name in example_names():
            print(f"{name:24s} {example_description(name)}")
        return 0
    if not args.name:
        print("error: 'zeromode example show' needs a NAME (see 'zeromode example list').", file=sys.stderr)
        return 2
    json.dump(example_request(args.name), sys.stdout, indent=2)
    print()
    return 0


PLOT_FORMATS = (".svg", ".png", ".pdf")
# Dots per inch of a map's chart at --scale 1 (matplotlib's figure of inches, not SVG pixels).
MAP_DPI = 72


def cmd_plot(args) -> int:
    import dataclasses
    from pathlib import Path

    from zeromode.operations.plotting import figure_for_document, picture_for_document
    from zeromode.viz.layout import layout
    from zeromode.viz.svg import scene_svg

    output = Path(args.output)
    if output.suffix.lower() not in PLOT_FORMATS:
        print(f"error: the output file must end in {', '.join(PLOT_FORMATS)}.", file=sys.stderr)
        return 2
    document = _load_json(args.design)
    figure = figure_for_document(document, title=args.title)  # a module's map: a matplotlib chart
    if figure is not None:
        figure.savefig(output, dpi=MAP_DPI * args.scale)
        return 0
    picture = picture_for_document(document, solution_space=not args.no_solution_space)
    if args.title is not None:
        picture = dataclasses.replace(picture, title=args.title)
    scene = layout(picture)
    if output.suffix.lower() == ".svg":
        output.write_text(scene_svg(scene), encoding="utf-8")
    else:
        from zeromode.viz.raster import write_raster  # matplotlib: only for PNG and PDF

        write_raster(scene, output, args.scale)
    return 0


def cmd_design(args) -> int:
    from zeromode.operations.endpoints import respond

    body, _ = respond(_load_json(args.request))
    return _write_json(body, args.output)


def _write_json(body: dict, output: str | None) -> int:
    """``body`` as one line of JSON, to the file ``output`` or to stdout."""
    text = json.dumps(body, allow_nan=False)
    if output:
        with open(output, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")
    else:
        print(text)
    return 0



def cmd_export(args) -> int:
    from pathlib import Path

    from zeromode.operations.documents import validated
    from zeromode.operations.exporting import export_file, format_for_suffix
    from zeromode.service.wire.schemas.export import ExportRequest

    output = Path(args.output)
    document = _load_json(args.document)
    fmt = args.format or format_for_suffix(output.suffix, document)
    if fmt is None:
        print(f"error: give --format (the suffix {output.suffix or '(none)'} does not name one format).", file=sys.stderr)
        return 2
    body = {
        "format": fmt,
        "document": document,
        "fabrication": {k: v for k, v in (
            ("mm_per_unit", args.mm_per_unit), ("pin_diameter_mm", args.pin_diameter),
            ("link_width_mm", args.link_width), ("thickness_mm", args.thickness),
        ) if v is not None},
        "animation": {"frames": args.frames, "fps": args.fps, "title": args.title},
    }
    if args.frame:
        frame = _load_json(args.frame)
        body["frame"] = frame.get("frame", frame)
    content, _, _ = export_file(validated(body, ExportRequest))
    output.write_bytes(content)
    return 0


def _http_json(method: str, url: str, api_key: str | None, body: dict | None = None) -> dict:
    """One JSON request with the standard library (the service package needs no HTTP client);
    an error answer raises DomainError with the service's code and sentence."""
    import urllib.error
    import urllib.request

    from zeromode.solver.errors import DomainError

    try:
        data = None if body is None else json.dumps(body, allow_nan=False).encode()
    except ValueError as exc:
        raise DomainError("invalid_request", "every number in a request must be finite.") from exc
    headers = {"content-type": "application/json", **({"x-api-key": api_key} if api_key else {})}
    try:
        request = urllib.request.Request(url, data, headers, method=method)
        with urllib.request.urlopen(request) as resp:
            return json.load(resp)
    except urllib.error.HTTPError as exc:
        try:
            detail = json.load(exc).get("detail", {})
        except (ValueError, AttributeError):
            detail = {}
        if not isinstance(detail, dict):
            detail = {"message": str(detail)}
        code, message = detail.get("code", "http_error"), detail.get("message", f"HTTP {exc.code}")
        raise DomainError(code, message) from exc
    except urllib.error.URLError as exc:
        raise DomainError("connection_error", f"cannot reach {url}: {exc.reason}.") from exc


FINISHED = ("done", "failed", "cancelled", "interrupted")


def _progress_bar(fraction: float, message: str, width: int = 30) -> None:
    done = round(width * fraction)
    bar = f"[{'#' * done}{'.' * (width - done)}] {100 * fraction:3.0f}%"
    print(f"\r{bar}  {message[:40]:40s}", end="", file=sys.stderr, flush=True)


def cmd_sweep(args) -> int:
    """A sweep here (on an embedded LocalCluster, or --scheduler's cluster) or on a service
    (--url): a progress bar, the points as NDJSON, optionally the table as CSV or Parquet."""
    import time

    if args.table and args.table.endswith(".parquet"):
        from zeromode.service.jobs.sweeps import PARQUET
        from zeromode.service.wire.extras import require

        require(*PARQUET)  # before any work: one sentence with the install line, exit code 2
    spec = _load_json(args.grid)
    endpoint = "/v1/" + str(spec.get("endpoint", "")).strip("/").removeprefix("v1/")
    records: list[dict] = []
    if args.url:
        base = args.url.rstrip("/")
        body = {"endpoint": endpoint, **{k: spec[k] for k in ("template", "grid", "requests") if k in spec}}
        sweep = _http_json("POST", f"{base}/v1/sweeps", args.api_key, body)
        after = 0
        while True:
            status = _http_json("GET", f"{base}/v1/sweeps/{sweep['id']}?after={after}&limit=1000", args.api_key)
            records += [{k: r[k] for k in ("point", "params", "status", "result", "error") if r.get(k) is not None}
                        for r in status["results"]]
            after = status["next"]
            _progress_bar(status["progress"], f"{status['done']} done, {status['failed']} failed of {status['total']}")
            if status["status"] != "running" and len(status["results"]) < 1000:
                break
            time.sleep(args.poll)
    else:
        from zeromode.service.jobs.sweeps import SweepRefused, run_sweep
        from zeromode.solver.errors import DomainError

        def progress(p) -> None:
            _progress_bar(p.fraction, f"{p.done} done, {p.failed} failed of {p.total}")

        try:
            records = list(run_sweep(endpoint, spec.get("template"), spec.get("grid"), spec.get("requests"),
                                     scheduler=args.scheduler, on_progress=progress))
        except SweepRefused as exc:  # the service's 422, here before anything runs
            raise DomainError(exc.detail["code"], exc.detail["message"]) from exc
    print(file=sys.stderr)
    return _write_sweep(sorted(records, key=lambda r: r["point"]), args.output, args.table)


def _write_sweep(records: list[dict], output: str, table: str | None) -> int:
    """The points as NDJSON (``output``, - for stdout) and the table (``table``: .csv or
    .parquet); exit status 0 when every point is done, 1 otherwise."""
    from pathlib import Path

    from zeromode.service.jobs.sweeps import csv_text, ndjson_line, parquet_bytes, row

    lines = b"".join(ndjson_line(r) for r in records)
    if output == "-":
        sys.stdout.buffer.write(lines)
    else:
        Path(output).write_bytes(lines)
    if table:
        rows = [row(r) for r in records]
        if table.endswith(".parquet"):
            Path(table).write_bytes(parquet_bytes(rows))
        else:
            Path(table).write_text(csv_text(rows))
    failed = sum(r["status"] != "done" for r in records)
    print(f"{len(records)} points: {len(records) - failed} done, {failed} not", file=sys.stderr)
    return 0 if failed == 0 else 1


def cmd_job(args) -> int:
    import time

    from zeromode.solver.errors import DomainError

    endpoint = "/v1/" + args.endpoint.strip("/").removeprefix("v1/")
    base = args.url.rstrip("/")
    submission = {"endpoint": endpoint, "request": _load_json(args.request)}
    job = _http_json("POST", f"{base}/v1/jobs", args.api_key, submission)
    while True:
        status = _http_json("GET", f"{base}/v1/jobs/{job['id']}", args.api_key)
        _progress_bar(status["progress"], status["message"])
        if status["status"] in FINISHED:
            print(file=sys.stderr)
            break
        time.sleep(args.poll)
    if status["status"] != "done":
        raise DomainError(status["error"]["code"], status["error"]["message"])
    json.dump(status["result"], sys.stdout)
    print()
    return 0


def cmd_motion(args) -> int:
    from zeromode.operations import endpoints
    from zeromode.operations.documents import validated
    from zeromode.service.wire.schemas.motion import MotionRequest

    doc = _load_json(args.frame)
    body = dict(doc) if "frame" in doc else {"frame": doc}  # a /v1/motion request, or a frame
    options = {"target": args.target and json.loads(args.target), "amplitude": args.amplitude, "direction": args.direction}
    body.update({k: v for k, v in options.items() if v is not None})
    # a singular path or an unreachable target raises its DomainError: main prints it (exit 2)
    return _write_json(endpoints.motion(validated(body, MotionRequest)).body, args.output)


def build_parser() -> argparse.ArgumentParser:
    from zeromode.service import __version__  # importlib.metadata only: --help stays fast

    parser = argparse.ArgumentParser(prog="zeromode", description=__doc__)
    parser.add_argument("--version", action="version", version=f"zeromode {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    serve = sub.add_parser("serve", help="run the REST service")
    serve.add_argument("--host", default="127.0.0.1")
    serve.add_argument("--port", type=int, default=8000)
    serve.add_argument("--workers", type=int, default=1)
    serve.set_defaults(func=cmd_serve)
    an = sub.add_parser("analyze", help="analyse a frame here and print the /v1/analyze answer")
    an.add_argument("frame", help="a Frame or a /v1/analyze request (frame, options): JSON file (or - for stdin)")
    an.add_argument("--pretty", action="store_true", help="a readable summary instead of JSON")
    an.set_defaults(func=cmd_analyze)
    ex = sub.add_parser("example", help="list the paper's named examples or print one as a /v1/design request")
    ex.add_argument("action", choices=["list", "show"])
    ex.add_argument("name", nargs="?")
    ex.set_defaults(func=cmd_example)
    pl = sub.add_parser(
        "plot", help="draw a response (or request, designed first) of /v1/design, /v1/design/auxetic, "
        "/v1/design/allosteric, /v1/design/multistable or /v1/design/sequential (its chain), a /v1/map "
        "request or response (the module beside its map) or a /v1/plot body, as SVG, PNG or PDF"
    )
    pl.add_argument("design", help="JSON file (or - for stdin)")
    pl.add_argument("-o", "--output", required=True, help="out.svg, out.png or out.pdf")
    pl.add_argument("--title", default=None)
    pl.add_argument("--no-solution-space", action="store_true", help="do not draw the solution space")
    pl.add_argument("--scale", type=float, default=1.5, help="PNG pixels per SVG pixel (default 1.5)")
    pl.set_defaults(func=cmd_plot)
    jb = sub.add_parser(
        "job", help="run a request as a job on a running service (progress bar); print its result"
    )
    jb.add_argument("endpoint", help="e.g. /v1/design/auxetic (or design/auxetic)")
    jb.add_argument("request", help="the endpoint's request body: JSON file (or - for stdin)")
    jb.add_argument("--url", default="http://127.0.0.1:8000", help="default: %(default)s")
    jb.add_argument(
        "--api-key", default=os.environ.get("ZEROMODE_API_KEY"), help="default: $ZEROMODE_API_KEY"
    )
    jb.add_argument("--poll", type=float, default=0.5, help="seconds between status requests")
    jb.set_defaults(func=cmd_job)
    sw = sub.add_parser(
        "sweep", help="run a sweep (a JSON file: endpoint, template and grid or requests) here on Dask, "
        "or on a service with --url; write its points as NDJSON"
    )
    sw.add_argument("grid", help="JSON file (or - for stdin): {endpoint, template, grid | requests}")
    sw.add_argument("-o", "--output", default="-", help="the points as NDJSON (default: stdout)")
    sw.add_argument("--table", default=None, help="also the table of scalar fields: out.csv or out.parquet")
    sw.add_argument("--scheduler", default=None, help="a Dask scheduler (tcp://host:8786); default: "
                    "$ZEROMODE_DASK_SCHEDULER, else an embedded LocalCluster")
    sw.add_argument("--url", default=None, help="run on this service instead (e.g. http://127.0.0.1:8000)")
    sw.add_argument("--api-key", default=os.environ.get("ZEROMODE_API_KEY"), help="default: $ZEROMODE_API_KEY")
    sw.add_argument("--poll", type=float, default=0.5, help="seconds between status requests (--url)")
    sw.set_defaults(func=cmd_sweep)
    de = sub.add_parser(
        "design", help="run a /v1/design, /v1/design/auxetic, /v1/design/allosteric, /v1/design/multistable, "
        "/v1/design/sequential or /v1/map request here (no service needed) and print its response"
    )
    de.add_argument("request", help="the request body: JSON file (or - for stdin)")
    de.add_argument("-o", "--output", default=None, help="write the response here instead of stdout")
    de.set_defaults(func=cmd_design)
    exp = sub.add_parser(
        "export", help="write a design, lattice, allosteric, multistable or sequential design (its chain), "
        "module map (its module; .csv: the sampled map), refinement or motion (a response, or a request "
        "designed first) for ParaView, networkx, a laser cutter, a 3D printer, or as an animation"
    )
    exp.add_argument("document", help="JSON file (or - for stdin)")
    exp.add_argument("-o", "--output", required=True, help="e.g. out.vtu, out.graphml, out.dxf, out.stl, out.gif")
    exp.add_argument(
        "--format", default=None, help="vtk, xdmf, graphml, node_link_json, dxf, cut_svg, stl, kit_csv, "
        "svg_animation, gif, mp4, map_csv, map_svg or map_png (GET /v1/export/formats); default: from the "
        "output's suffix (a module map's .csv, .svg, .png: map_csv, map_svg, map_png)",
    )
    exp.add_argument("--frame", default=None, help="the frame (JSON) a /v1/motion response moved")
    exp.add_argument("--mm-per-unit", type=float, default=None, help="cut files: mm per frame unit")
    exp.add_argument("--pin-diameter", type=float, default=None, help="cut files: pin hole diameter, mm (3)")
    exp.add_argument("--link-width", type=float, default=None, help="cut files: link width, mm (8)")
    exp.add_argument("--thickness", type=float, default=None, help="stl: plate thickness, mm (3)")
    exp.add_argument("--frames", type=int, default=40, help="animations: configurations shown (40)")
    exp.add_argument("--fps", type=float, default=20.0, help="animations: frames per second (20)")
    exp.add_argument("--title", default=None, help="animations: a title")
    exp.set_defaults(func=cmd_export)
    mo = sub.add_parser(
        "motion", help="trace a frame's finite motion here (as POST /v1/motion), e.g. until a target is reached"
    )
    mo.add_argument("frame", help="a frame or a /v1/motion request: JSON file (or - for stdin)")
    mo.add_argument("--target", default=None, help='e.g. \'{"kind": "angle", "nodes": [3, 0, 1], "value": 0.9}\'')
    mo.add_argument("--amplitude", type=float, default=None, help="how far instead of a target (default 0.2)")
    mo.add_argument("--direction", choices=["both", "forward", "backward"], default=None)
    mo.add_argument("-o", "--output", default=None, help="write the response here instead of stdout")
    mo.set_defaults(func=cmd_motion)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from zeromode.service.wire.extras import MissingExtra  # after parsing: --help needs no numpy
    from zeromode.solver.errors import DomainError

    try:
        return args.func(args)
    except DomainError as exc:
        print(f"error [{exc.code}]: {exc.message}", file=sys.stderr)
        return 2
    except MissingExtra as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except (OSError, json.JSONDecodeError, KeyError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

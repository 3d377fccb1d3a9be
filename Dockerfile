# zeromode REST service: docker build -t zeromode . && docker run -p 8000:8000 zeromode
FROM python:3.11-slim-bookworm

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    ZEROMODE_WORKERS=2

RUN groupadd --system --gid 10001 zeromode \
    && useradd --system --uid 10001 --gid zeromode --no-create-home --home-dir /nonexistent \
        --shell /usr/sbin/nologin zeromode

WORKDIR /app

# Dependencies first (pinned, wheels only: slim has no compiler), so code edits reuse this layer.
COPY requirements.lock ./
RUN pip install --no-cache-dir --only-binary=:all: -r requirements.lock

COPY pyproject.toml README.md ./
COPY zeromode ./zeromode
COPY solver ./solver
COPY service ./service
COPY viz ./viz
COPY export ./export
RUN pip install --no-cache-dir --no-deps --no-build-isolation . \
    && rm -rf build ./*.egg-info

# The rigidity analysis's numba kernels, compiled once here into a cache the service's user may
# read and extend (28-40 s of CPU; each worker then loads them in 0.3-0.4 s, in the background).
ENV NUMBA_CACHE_DIR=/var/cache/zeromode/numba
RUN mkdir -p "$NUMBA_CACHE_DIR" \
    && python -c "from zeromode.solver.analysis.rigidity import warm_up; warm_up()" \
    && chown -R 10001:10001 /var/cache/zeromode

# Job and sweep records (SQLite): a directory the service's user owns; mount a volume here to
# keep them across containers.
RUN mkdir -p /var/lib/zeromode && chown 10001:10001 /var/lib/zeromode
ENV ZEROMODE_DATABASE_URL=sqlite:////var/lib/zeromode/jobs.sqlite3
VOLUME ["/var/lib/zeromode"]

USER 10001:10001
EXPOSE 8000

HEALTHCHECK --interval=30s --timeout=5s --start-period=30s --retries=3 \
    CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/health', timeout=4)"]

# exec: the server becomes PID 1 and receives docker's SIGTERM for a graceful shutdown.
CMD ["sh", "-c", "exec zeromode serve --host 0.0.0.0 --port 8000 --workers ${ZEROMODE_WORKERS:-2}"]
